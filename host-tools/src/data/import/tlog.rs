//! MAVLink telemetry logs (`.tlog`: QGroundControl, BlueOS, MAVProxy) to a
//! recording.
//!
//! **Framing.** A tlog is a sequence of records, each an 8-byte big-endian
//! time (µs since 1970, the topside's clock when it received the frame) and
//! one MAVLink frame, v1 (`0xFE`) or v2 (`0xFD`, signed or not). That
//! framing is read here by hand: the `mavlink` crate reads frames from a
//! stream, knows nothing of the time in front of each and does not count
//! what it passes over. Each frame's checksum (CRC-16/MCRF4XX with the
//! message's CRC_EXTRA) is checked and its message decoded by the `mavlink`
//! crate (MAVLink's own Rust implementation, ArduPilot dialect, MAVLink 2
//! extension fields on). A frame whose checksum fails, whose message the
//! dialect does not know or which does not decode is skipped and counted;
//! its length is trusted only when another record follows it, else the
//! reader moves on byte by byte to the next place holding a plausible time,
//! a start byte and a frame whose checksum holds (the bytes passed over
//! counted). Nothing in the file's content ends the import.
//!
//! **What ArduPilot sends** (`libraries/GCS_MAVLink/GCS_Common.cpp`,
//! `GCS_MAVLINK::send_raw_imu` and `GCS_MAVLINK::send_scaled_imu`):
//! - `RAW_IMU` is IMU 0 and compass 0 (instance 0 here), `SCALED_IMU2`
//!   IMU 1 and compass 1 (instance 1), `SCALED_IMU3` instance 2. MAVLink's
//!   definition calls `RAW_IMU`'s values "raw"; ArduPilot fills them with
//!   the same scaled values as `SCALED_IMU*`: the gyro `ins.get_gyro(i) ×
//!   1000`, mrad/s (here ÷ 1000 → rad/s, body frame FRD), the field
//!   `compass.get_field(i)` as int16, mGauss. `RAW_IMU.time_usec` is
//!   `AP_HAL::micros64()` and `SCALED_IMU*.time_boot_ms` `AP_HAL::millis()`:
//!   the autopilot's boot clock. An instance with no compass is sent as a
//!   zero field: such samples are refused.
//! - `compass.get_field(i)` is the field **after** the autopilot's
//!   correction (`AP_Compass_Backend::correct_field`, AP_Compass_Backend.cpp):
//!   `field = Mat·(s·(raw + Ofs)) + MO`, with `Ofs` = `COMPASS_OFS*`, `s` =
//!   `COMPASS_SCALE*` (within 1/1.5…1.5), `Mat` the symmetric matrix of
//!   `COMPASS_DIA*`/`COMPASS_ODI*` and `MO` the motor compensation. The
//!   recording holds the raw field, so the correction is undone as the
//!   DataFlash import does ([`crate::data::dataflash`], the same matrix):
//!   `raw = (s·Mat)⁻¹·field − Ofs`, with the parameters from the log's
//!   `PARAM_VALUE` messages in force at each sample (in the log's order; for
//!   samples before the parameters were first sent, their first values;
//!   without `COMPASS_OFS*` at all, `SENSOR_OFFSETS.mag_ofs_*` for compass 0).
//!   `MO` is not in a tlog: with motor compensation on (`COMPASS_MOTCT` ≠ 0
//!   and `COMPASS_MOT*` not zero) the note says the field written still holds
//!   it. The field is sent in whole mGauss, so the raw field is known to
//!   about ±1 mGauss. From another autopilot than ArduPilot the field is
//!   written as sent (the note says so).
//! - `ATTITUDE` (rad) gives `roll_deg`, `pitch_deg` and the autopilot's own
//!   heading `ahrs_yaw_deg` (never a reference); `GPS_RAW_INT` (lat/lon
//!   1e-7°, `vel` cm/s, `cog` c°) the position, the ground speed, the course
//!   (where the vehicle moves) and, at a ground speed of
//!   [`ImportOptions::min_course_speed_mps`] or more, the course as the
//!   reference heading ([`rules::course_at_speed_deg`]). Its `yaw` (c°, 0 =
//!   not given, 36000 = north, 65535 = not available) is a GNSS compass's true
//!   heading and the reference where set, except when the GPS is fed by a
//!   companion over `GPS_INPUT` (an underwater positioning system; in a
//!   BlueROV2 log with a Water Linked underwater GPS its yaw ran within 0.5°
//!   of the vehicle's own `ATTITUDE` yaw, whole degrees: the compass being
//!   calibrated, sent back): then it is not used and the note says how close
//!   it runs to `ATTITUDE`'s yaw. `SENSOR_OFFSETS`
//!   gives the declination in use (`variation_deg`). `VFR_HUD` is counted,
//!   not written: its ground speed is the autopilot's estimate, not the GNSS.
//!
//! **Clock.** `t` is the autopilot's boot clock, s: each message's own
//! `time_usec`/`time_boot_ms` (`GPS_RAW_INT.time_usec`: the fix's boot time,
//! `last_fix_time_ms × 1000` in `AP_GPS`; a message stamped with Unix time
//! instead is counted and not used), the times the autopilot stamped its samples
//! with (the tlog's times are when the topside received them, after the
//! link's delays and in bursts). Attitude and GNSS are carried to each
//! compass sample through [`rules::Series`].
//!
//! **Several systems.** The autopilot is the sender of the first `HEARTBEAT`
//! whose autopilot type is not `MAV_AUTOPILOT_INVALID`; the messages read
//! from any other system or component are counted as skipped.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage};
use mavlink::{MavlinkVersion, Message};

use super::rules::{self, Kind, Series};
use super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use crate::data::dataflash::{compass_matrix, solve3};
use crate::data::table::col;

/// Why a MAVLink telemetry log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum TlogError {
    /// No MAVLink frame with a valid checksum after an 8-byte time.
    #[error("not a MAVLink telemetry log: no MAVLink frame with a valid checksum after an 8-byte big-endian time in {bytes} bytes{}", if *truncated { " (the file ends inside its first record: truncated)" } else { "" })]
    NotTlog {
        /// Size of the input.
        bytes: usize,
        /// Whether the file starts like a tlog and ends inside its first record.
        truncated: bool,
    },
    /// No magnetometer message from the autopilot.
    #[error("no magnetometer in the MAVLink telemetry log: no RAW_IMU, SCALED_IMU2 or SCALED_IMU3 with a field from {autopilot} (messages read: {found})")]
    NoMagnetometer {
        /// The system and component taken as the autopilot.
        autopilot: String,
        /// The messages read, with their counts.
        found: String,
    },
    /// The compass's offsets are nowhere in the log.
    #[error("compass instance {instance}: the field ArduPilot sends is its corrected one and the log holds no {parameter} (PARAM_VALUE){sensor_offsets}: the raw field cannot be recovered (import the autopilot's DataFlash log, or record the tlog with the parameters downloaded, as QGroundControl does on connecting)", sensor_offsets = if *instance == 0 { " nor SENSOR_OFFSETS" } else { "" })]
    NoCompassOffsets {
        /// Compass instance.
        instance: u32,
        /// The parameter missing.
        parameter: String,
    },
    /// The compass's correction matrix cannot be inverted.
    #[error("compass instance {instance}: COMPASS scale/DIA/ODI parameters make a singular matrix: the raw field cannot be recovered")]
    Singular {
        /// Compass instance.
        instance: u32,
    },
}

/// A time in µs since 1970 within 2000–2100: a tlog record's time.
const UNIX_US: std::ops::RangeInclusive<u64> = 946_684_800_000_000..=4_102_444_800_000_000;
const STX_V1: u8 = 0xFE;
const STX_V2: u8 = 0xFD;
/// The time in front of each frame, bytes.
const TIME_LEN: usize = 8;

/// One MAVLink frame of a tlog, its checksum checked.
#[derive(Debug, Clone, Copy)]
struct Frame<'a> {
    /// The record's time, µs since 1970 (the topside's clock).
    t_unix_us: u64,
    version: MavlinkVersion,
    sysid: u8,
    compid: u8,
    msgid: u32,
    payload: &'a [u8],
}

/// What the bytes at one place of a tlog are.
enum Record<'a> {
    /// A frame whose checksum holds; the record's length (time included).
    Good(Frame<'a>, usize),
    /// A frame whose checksum fails; the record's length by its header.
    BadCrc(usize),
    /// A frame of a message the dialect does not know (its checksum cannot
    /// be checked); the record's length by its header.
    UnknownMessage(usize),
    /// A plausible time and start byte, and the file ends inside the frame.
    Truncated,
    /// Not the start of a record.
    No,
}

/// The record's time when the 8 bytes at the start of `b` are one.
fn record_time(b: &[u8]) -> Option<u64> {
    let t = u64::from_be_bytes(b.get(..TIME_LEN)?.try_into().ok()?);
    UNIX_US.contains(&t).then_some(t)
}

/// Reads the record at `o`.
fn record(bytes: &[u8], o: usize) -> Record<'_> {
    let Some(rest) = bytes.get(o..) else { return Record::No };
    let Some(t_unix_us) = record_time(rest) else { return Record::No };
    let f = rest.get(TIME_LEN..).unwrap_or_default();
    let (version, header_len) = match f.first() {
        Some(&STX_V1) => (MavlinkVersion::V1, 6),
        Some(&STX_V2) => (MavlinkVersion::V2, 10),
        Some(_) => return Record::No,
        None => return Record::Truncated,
    };
    let Some(&payload_len) = f.get(1) else { return Record::Truncated };
    let payload_len = payload_len as usize;
    let signature = match (version, f.get(2)) {
        (MavlinkVersion::V2, None) => return Record::Truncated,
        (MavlinkVersion::V2, Some(incompat)) if incompat & 1 != 0 => 13,
        _ => 0,
    };
    let frame_len = header_len + payload_len + 2 + signature;
    let Some(frame) = f.get(..frame_len) else { return Record::Truncated };
    let len = TIME_LEN + frame_len;
    let (sysid, compid, msgid) = match version {
        MavlinkVersion::V1 => (frame[3], frame[4], frame[5] as u32),
        MavlinkVersion::V2 => (frame[5], frame[6], u32::from_le_bytes([frame[7], frame[8], frame[9], 0])),
    };
    if MavMessage::default_message_from_id(msgid).is_none() {
        return Record::UnknownMessage(len);
    }
    let crc_at = header_len + payload_len;
    let crc = u16::from_le_bytes([frame[crc_at], frame[crc_at + 1]]);
    if mavlink::calculate_crc(&frame[1..crc_at], MavMessage::extra_crc(msgid)) != crc {
        return Record::BadCrc(len);
    }
    let payload = &frame[header_len..crc_at];
    Record::Good(Frame { t_unix_us, version, sysid, compid, msgid, payload }, len)
}

/// Whether a record could start at `o` (time and start byte; the checksum
/// is not checked).
fn could_start(bytes: &[u8], o: usize) -> bool {
    bytes.get(o..).and_then(record_time).is_some() && matches!(bytes.get(o + TIME_LEN), Some(&STX_V1 | &STX_V2))
}

/// What the framing skipped, by kind.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
struct FrameSkips {
    bad_crc: usize,
    unknown_message: usize,
    garbage_bytes: usize,
    truncated_tail_bytes: usize,
}

/// Reads every record of a tlog, calling `each` on every frame whose
/// checksum holds, in file order.
fn read_frames<'a>(bytes: &'a [u8], mut each: impl FnMut(Frame<'a>)) -> FrameSkips {
    let mut s = FrameSkips::default();
    let mut o = 0;
    while o < bytes.len() {
        let here = record(bytes, o);
        let frame_len = match here {
            Record::Good(frame, len) => {
                each(frame);
                o += len;
                continue;
            }
            Record::BadCrc(len) | Record::UnknownMessage(len) => Some(len),
            _ => None,
        };
        let mut count_frame = || match here {
            Record::BadCrc(_) => s.bad_crc += 1,
            _ => s.unknown_message += 1,
        };
        // A frame's length is trusted when a record (or the end) follows it.
        if let Some(len) = frame_len.filter(|&len| o + len == bytes.len() || could_start(bytes, o + len)) {
            count_frame();
            o += len;
            continue;
        }
        match next_good(bytes, o + 1) {
            Some(p) => {
                // A bad frame ending before the next good one is counted as a frame, the rest as bytes.
                match frame_len.filter(|&len| o + len <= p) {
                    Some(len) => {
                        count_frame();
                        s.garbage_bytes += p - o - len;
                    }
                    None => s.garbage_bytes += p - o,
                }
                o = p;
            }
            None => {
                // Nothing readable after: a record cut by the end of the file, or junk.
                if matches!(here, Record::Truncated) {
                    s.truncated_tail_bytes += bytes.len() - o;
                } else {
                    s.garbage_bytes += bytes.len() - o;
                }
                break;
            }
        }
    }
    s
}

/// The next place from `from` where a record with a good checksum starts.
fn next_good(bytes: &[u8], from: usize) -> Option<usize> {
    (from..bytes.len()).find(|&p| could_start(bytes, p) && matches!(record(bytes, p), Record::Good(..)))
}

/// Whether a log's first bytes look like a MAVLink telemetry log: from the
/// start, records one after another (a plausible time, a start byte, the
/// frame's length), the first of them whose checksum holds at least two (or
/// all of them, in a shorter head) — a corrupt or unknown frame among them
/// does not hide the format.
pub fn looks_like(head: &[u8]) -> bool {
    let (mut o, mut good, mut seen) = (0, 0, 0);
    while seen < 8 && o < head.len() {
        let len = match record(head, o) {
            Record::Good(_, len) => {
                good += 1;
                len
            }
            Record::BadCrc(len) | Record::UnknownMessage(len) => len,
            Record::Truncated => break,
            Record::No => return false,
        };
        seen += 1;
        o += len;
    }
    good >= 2 || (good == 1 && seen == 1)
}

/// The compass parameters' suffix of an instance (`COMPASS_OFS_X`,
/// `COMPASS_OFS2_X`, …).
fn suffix(instance: u32) -> String {
    if instance == 0 {
        String::new()
    } else {
        (instance + 1).to_string()
    }
}

/// One sample of the chosen magnetometer.
struct MagRow {
    t_s: f64,
    /// The field as sent, mGauss.
    field: [f64; 3],
    /// The compass parameters in force (an index into the versions).
    params: usize,
    /// The latest `SENSOR_OFFSETS` magnetometer offsets, mGauss.
    sensor_ofs: Option<[f64; 3]>,
    /// The declination in use, degrees.
    declination_deg: f64,
    /// The same message's gyro (instance 0: RAW_IMU is IMU 0), rad/s.
    gyro: Option<[f64; 3]>,
}

/// What the import keeps of a message of a kind it uses (others are only
/// counted): times on the autopilot's boot clock, s; fields in mGauss;
/// rates in rad/s; angles in degrees.
#[derive(Debug, Clone, PartialEq)]
enum Kept {
    /// A HEARTBEAT: the sender's autopilot type.
    Heartbeat(MavAutopilot),
    /// RAW_IMU (instance 0, with IMU 0's gyro), SCALED_IMU2 (1), SCALED_IMU3 (2).
    Mag { instance: u32, t_s: f64, field: [f64; 3], gyro: Option<[f64; 3]>, unix_clock: bool },
    /// ATTITUDE: roll, pitch, yaw.
    Attitude { t_s: f64, deg: [f64; 3] },
    /// GPS_RAW_INT: lat, lon, ground speed (m/s), course, GNSS yaw (NaN when
    /// not given), fix type.
    Gps { t_s: f64, v: [f64; 6] },
    /// SENSOR_OFFSETS: compass 0's offsets and the declination in use.
    SensorOffsets { ofs: [f64; 3], declination_deg: f64 },
    /// PARAM_VALUE of a compass parameter.
    Param { name: String, value: f64 },
    /// GPS_INPUT (a companion feeding the autopilot's GPS).
    GpsInput,
}

/// What the import keeps of a message, `None` for the kinds it only counts.
#[allow(deprecated)] // SENSOR_OFFSETS: deprecated in MAVLink's definitions (2022), still sent by ArduPilot
fn keep(m: &MavMessage) -> Option<Kept> {
    let mag = |x: i16, y: i16, z: i16| [x, y, z].map(f64::from);
    let finite = |v: f64| if v.is_finite() { v } else { f64::NAN };
    Some(match m {
        MavMessage::HEARTBEAT(h) => Kept::Heartbeat(h.autopilot),
        MavMessage::RAW_IMU(r) => Kept::Mag {
            instance: 0,
            t_s: r.time_usec as f64 / 1e6,
            field: mag(r.xmag, r.ymag, r.zmag),
            gyro: Some([r.xgyro, r.ygyro, r.zgyro].map(|g| f64::from(g) / 1e3)),
            unix_clock: r.time_usec >= *UNIX_US.start(),
        },
        MavMessage::SCALED_IMU2(r) => Kept::Mag { instance: 1, t_s: f64::from(r.time_boot_ms) / 1e3, field: mag(r.xmag, r.ymag, r.zmag), gyro: None, unix_clock: false },
        MavMessage::SCALED_IMU3(r) => Kept::Mag { instance: 2, t_s: f64::from(r.time_boot_ms) / 1e3, field: mag(r.xmag, r.ymag, r.zmag), gyro: None, unix_clock: false },
        MavMessage::ATTITUDE(a) => Kept::Attitude { t_s: f64::from(a.time_boot_ms) / 1e3, deg: [a.roll, a.pitch, a.yaw].map(|v| finite(f64::from(v).to_degrees())) },
        MavMessage::GPS_RAW_INT(g) => {
            let known = |v: u16| if v == u16::MAX { f64::NAN } else { f64::from(v) / 100.0 };
            let yaw = match g.yaw {
                0 | u16::MAX => f64::NAN,
                y => (f64::from(y) / 100.0).rem_euclid(360.0),
            };
            let v = [f64::from(g.lat) / 1e7, f64::from(g.lon) / 1e7, known(g.vel), known(g.cog), yaw, f64::from(g.fix_type as u8)];
            Kept::Gps { t_s: g.time_usec as f64 / 1e6, v }
        }
        MavMessage::SENSOR_OFFSETS(o) => Kept::SensorOffsets { ofs: mag(o.mag_ofs_x, o.mag_ofs_y, o.mag_ofs_z), declination_deg: f64::from(o.mag_declination).to_degrees() },
        MavMessage::PARAM_VALUE(p) => {
            let name = p.param_id.to_str().unwrap_or_default();
            if !name.starts_with("COMPASS_") {
                return None;
            }
            Kept::Param { name: name.to_string(), value: f64::from(p.param_value) }
        }
        MavMessage::GPS_INPUT(_) => Kept::GpsInput,
        _ => return None,
    })
}

/// The compass parameters of an instance the import reads (the correction
/// and the motor compensation), bounded: other names are not kept.
fn compass_parameters(instance: u32) -> Vec<String> {
    let sfx = suffix(instance);
    let mut names: Vec<String> = ["OFS", "DIA", "ODI", "MOT"].iter().flat_map(|b| ["_X", "_Y", "_Z"].map(|a| format!("COMPASS_{b}{sfx}{a}"))).collect();
    names.extend([format!("COMPASS_SCALE{sfx}"), "COMPASS_MOTCT".to_string(), "COMPASS_PMOT_EN".to_string()]);
    names
}

/// A date and time (UTC) from µs since 1970, for the report (the civil
/// date by the project's one calendar, [`crate::data::nmea::Date`]).
fn utc(t_unix_us: u64) -> String {
    let s = t_unix_us / 1_000_000;
    let (days, sod) = ((s / 86_400) as i64, s % 86_400);
    let d = crate::data::nmea::Date::from_days_since_epoch(days);
    format!("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", d.year, d.month, d.day, sod / 3600, sod / 60 % 60, sod % 60)
}

/// Imports a MAVLink telemetry log held in memory: one row per sample of the
/// chosen magnetometer instance (`RAW_IMU` 0, `SCALED_IMU2` 1, `SCALED_IMU3`
/// 2).
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    // Every frame: counted by message; the kinds used kept with their sender.
    let mut messages: BTreeMap<String, usize> = BTreeMap::new();
    let mut kept: Vec<(u8, u8, Kept)> = Vec::new();
    let (mut frames, mut undecodable, mut first_t_us) = (0usize, 0usize, None);
    let skips = read_frames(bytes, |f| {
        frames += 1;
        first_t_us.get_or_insert(f.t_unix_us);
        match MavMessage::parse(f.version, f.msgid, f.payload) {
            Ok(m) => {
                *messages.entry(m.message_name().to_string()).or_default() += 1;
                if let Some(k) = keep(&m) {
                    kept.push((f.sysid, f.compid, k));
                }
            }
            Err(_) => undecodable += 1,
        }
    });
    if frames == 0 {
        return Err(TlogError::NotTlog { bytes: bytes.len(), truncated: matches!(record(bytes, 0), Record::Truncated) }.into());
    }
    let mut notes: Vec<String> = Vec::new();

    // The autopilot: the first HEARTBEAT of an autopilot, else the sender of
    // the first magnetometer message.
    let mut autopilots: Vec<(u8, u8, MavAutopilot)> = Vec::new();
    for (s, c, k) in &kept {
        if let Kept::Heartbeat(a) = k {
            if *a != MavAutopilot::MAV_AUTOPILOT_INVALID && !autopilots.iter().any(|b| (b.0, b.1) == (*s, *c)) {
                autopilots.push((*s, *c, *a));
            }
        }
    }
    let (sysid, compid, ardupilot) = match autopilots.first() {
        Some(&(s, c, a)) => {
            if autopilots.len() > 1 {
                notes.push(format!(
                    "HEARTBEATs of {} autopilots (sysid/compid {}): the first, {s}/{c}, imported",
                    autopilots.len(),
                    autopilots.iter().map(|a| format!("{}/{}", a.0, a.1)).collect::<Vec<_>>().join(", ")
                ));
            }
            (s, c, a == MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA)
        }
        None => {
            let Some(&(s, c, _)) = kept.iter().find(|(_, _, k)| matches!(k, Kept::Mag { .. })) else {
                return Err(no_magnetometer("no autopilot (no HEARTBEAT of one)".into(), &messages));
            };
            notes.push(format!("no HEARTBEAT of an autopilot: the sender of the first magnetometer message (sysid {s}, compid {c}) taken as the autopilot, ArduPilot assumed"));
            (s, c, true)
        }
    };
    let autopilot = format!("the autopilot (sysid {sysid}, compid {compid})");
    let ours = |s: u8, c: u8| (s, c) == (sysid, compid);

    // The instances with a field (ArduPilot sends a zero field for a compass it does not have).
    let found: Vec<u32> = kept
        .iter()
        .filter_map(|(s, c, k)| match k {
            Kept::Mag { instance, field, .. } if ours(*s, *c) && *field != [0.0; 3] => Some(*instance),
            _ => None,
        })
        .collect::<BTreeSet<_>>()
        .into_iter()
        .collect();
    if found.is_empty() {
        return Err(no_magnetometer(autopilot, &messages));
    }
    let (instance, note) = rules::choose_instance("magnetometer (RAW_IMU = 0, SCALED_IMU2 = 1, SCALED_IMU3 = 2)", &found, opts.instance)?;
    notes.extend(note);

    // One pass in log order: the samples, the compass parameters in force.
    let names = compass_parameters(instance);
    let mut skipped: BTreeMap<&'static str, usize> = BTreeMap::new();
    let mut skip = |kind: &'static str| *skipped.entry(kind).or_default() += 1;
    let (mut current, mut first_values): (HashMap<String, f64>, HashMap<String, f64>) = (HashMap::new(), HashMap::new());
    // The parameters as each row found them: a new version only when they changed.
    let mut versions: Vec<HashMap<String, f64>> = vec![HashMap::new()];
    let (mut sensor_ofs, mut declination_deg) = (None, f64::NAN);
    let mut rows: Vec<MagRow> = Vec::new();
    let mut att = Series::new([Kind::Angle180, Kind::Linear, Kind::Heading360]);
    // lat, lon, ground speed, course, GNSS yaw, fix type.
    let mut gps = Series::new([Kind::Latest; 6]);
    let mut gyro0 = Series::new([Kind::Linear; 3]);
    let mut gps_input_senders = BTreeSet::new();
    for (s, c, k) in &kept {
        if let Kept::GpsInput = k {
            gps_input_senders.insert((*s, *c));
            continue;
        }
        if !ours(*s, *c) {
            if !matches!(k, Kept::Heartbeat(_)) {
                skip("messages_from_other_systems");
            }
            continue;
        }
        match k {
            Kept::Heartbeat(_) | Kept::GpsInput => {}
            Kept::Attitude { t_s, deg } => att.push(*t_s, *deg),
            // ArduPilot stamps it with the fix's boot time (last_fix_time_ms × 1000).
            Kept::Gps { t_s, .. } if *t_s >= *UNIX_US.start() as f64 / 1e6 => skip("gps_not_on_boot_clock"),
            Kept::Gps { t_s, v } => gps.push(*t_s, *v),
            Kept::SensorOffsets { ofs, declination_deg: d } => (sensor_ofs, declination_deg) = (Some(*ofs), *d),
            Kept::Param { name, value } => {
                if names.contains(name) {
                    first_values.entry(name.clone()).or_insert(*value);
                    current.insert(name.clone(), *value);
                }
            }
            Kept::Mag { instance: i, t_s, field, gyro, unix_clock } => {
                if *unix_clock {
                    skip("raw_imu_not_on_boot_clock");
                    continue;
                }
                if let Some(g) = gyro {
                    gyro0.push(*t_s, *g);
                }
                if *i != instance {
                    continue;
                }
                if *field == [0.0; 3] {
                    skip("zero_field_samples");
                    continue;
                }
                if let Some(last) = rows.last() {
                    if *t_s < last.t_s {
                        skip("magnetometer_time_backwards");
                        notes.push(format!("the autopilot's clock went back in the log (a reboot?): magnetometer samples earlier than {:.3} s refused; split the log to import the rest", last.t_s));
                        continue;
                    }
                    if *t_s == last.t_s {
                        skip("duplicate_magnetometer_samples");
                        continue;
                    }
                }
                if versions.last() != Some(&current) {
                    versions.push(current.clone());
                }
                rows.push(MagRow { t_s: *t_s, field: *field, params: versions.len() - 1, sensor_ofs, declination_deg, gyro: *gyro });
            }
        }
    }
    if rows.is_empty() {
        return Err(no_magnetometer(autopilot, &messages));
    }

    // The raw field: ArduPilot's correction undone.
    let sfx = suffix(instance);
    let ofs_names = ["_X", "_Y", "_Z"].map(|a| format!("COMPASS_OFS{sfx}{a}"));
    let offsets_of = |v: &HashMap<String, f64>| -> Option<[f64; 3]> { Some([v.get(&ofs_names[0])?, v.get(&ofs_names[1])?, v.get(&ofs_names[2])?].map(|x| *x)) };
    let mut raw = Vec::with_capacity(rows.len());
    let (mut before_params, mut from_sensor_offsets) = (0usize, 0usize);
    let mut missing_all: BTreeSet<String> = BTreeSet::new();
    for r in &rows {
        if !ardupilot {
            raw.push(r.field);
            continue;
        }
        // The parameters in force; those not sent yet, their first values in the log.
        let mut params = versions.get(r.params).cloned().unwrap_or_default();
        let before = params.len();
        for (name, value) in &first_values {
            params.entry(name.clone()).or_insert(*value);
        }
        if params.len() > before {
            before_params += 1;
        }
        let ofs = match (offsets_of(&params), r.sensor_ofs) {
            (Some(o), _) => o,
            (None, Some(o)) if instance == 0 => {
                from_sensor_offsets += 1;
                o
            }
            _ => return Err(TlogError::NoCompassOffsets { instance, parameter: ofs_names.join("/") }.into()),
        };
        let (mat, missing) = compass_matrix(&params, instance as u8);
        missing_all.extend(missing);
        let corrected = solve3(&mat, r.field).ok_or(TlogError::Singular { instance })?;
        raw.push([0, 1, 2].map(|k| corrected[k] - ofs[k]));
    }
    let last = current;
    if ardupilot {
        notes.push(format!(
            "the field ArduPilot sends (RAW_IMU/SCALED_IMU2/3 xmag, compass.get_field: whole mGauss) is its corrected one; the raw field written is (s·Mat)⁻¹·field − Ofs with COMPASS_OFS{sfx}_*, DIA{sfx}_*, ODI{sfx}_*, SCALE{sfx} from the log's PARAM_VALUE in force at each sample (±1 mGauss from the rounding)"
        ));
        if before_params > 0 {
            notes.push(format!("{before_params} samples before the compass parameters were first sent: their first values in the log used"));
        }
        if from_sensor_offsets > 0 {
            notes.push(format!("no COMPASS_OFS_* in the log: SENSOR_OFFSETS mag_ofs (whole mGauss) used as the offsets for {from_sensor_offsets} samples"));
        }
        if !missing_all.is_empty() {
            let missing: Vec<String> = missing_all.into_iter().collect();
            notes.push(format!("no PARAM_VALUE {} in the log: taken as ArduPilot's defaults (DIA 1, ODI 0, SCALE 1)", missing.join(", ")));
        }
        let motct = last.get("COMPASS_MOTCT").copied().unwrap_or(0.0);
        let mot: Vec<f64> = ["_X", "_Y", "_Z"].iter().filter_map(|a| last.get(&format!("COMPASS_MOT{sfx}{a}")).copied()).collect();
        if motct != 0.0 && mot.iter().any(|v| *v != 0.0) {
            notes.push(format!("motor compensation was on (COMPASS_MOTCT = {motct}, COMPASS_MOT{sfx}_* = {mot:?}): its offsets per sample are not in a tlog and are still in the field written; the DataFlash log has them (MAG MOX/MOY/MOZ)"));
        }
        if instance == 0 && last.get("COMPASS_PMOT_EN").is_some_and(|v| *v != 0.0) {
            notes.push("per-motor compass compensation was on (COMPASS_PMOT_EN): its offsets are not in a tlog and are still in the field written".to_string());
        }
    } else {
        notes.push("the autopilot is not ArduPilot: the field is written as sent (whether that autopilot calibrated it first is not known here)".to_string());
    }

    // The other columns at each compass sample.
    let n = rows.len();
    let mut cols: BTreeMap<&'static str, Vec<f64>> = BTreeMap::new();
    let mut set = |name: &'static str, i: usize, v: f64| cols.entry(name).or_insert_with(|| vec![f64::NAN; n])[i] = v;
    let gnss_yaw_is_reference = gps_input_senders.is_empty();
    for (i, (r, field)) in rows.iter().zip(&raw).enumerate() {
        for (name, v) in col::MAG.into_iter().zip(field) {
            set(name, i, *v);
        }
        if let Some(g) = r.gyro.or_else(|| gyro0.at(r.t_s, opts.max_age_s)) {
            for (name, v) in col::GYRO.into_iter().zip(g) {
                set(name, i, v);
            }
        }
        if let Some([roll, pitch, yaw]) = att.at(r.t_s, opts.max_age_s) {
            set(col::ROLL_DEG, i, roll);
            set(col::PITCH_DEG, i, pitch);
            set(col::AHRS_YAW_DEG, i, yaw);
        }
        if let Some([lat, lon, speed, cog, yaw, fix]) = gps.at(r.t_s, opts.max_age_s) {
            if fix >= 3.0 {
                set(col::LAT_DEG, i, lat);
                set(col::LON_DEG, i, lon);
                set(col::GPS_SPEED_MPS, i, speed);
                if speed > 0.0 {
                    set(col::COURSE_DEG, i, cog);
                }
                let reference = if gnss_yaw_is_reference && yaw.is_finite() { yaw } else { rules::course_at_speed_deg(cog, speed, opts.min_course_speed_mps) };
                set(col::REF_HEADING_DEG, i, reference);
            }
        }
        set(col::VARIATION_DEG, i, r.declination_deg);
    }
    if !gnss_yaw_is_reference {
        let diffs: Vec<f64> = gps_yaw_vs_attitude(&kept, &ours, &att);
        let senders: Vec<String> = gps_input_senders.iter().map(|(s, c)| format!("{s}/{c}")).collect();
        let agreement = match median(diffs.clone()) {
            Some(m) => format!("; it runs within a median {m:.2}° of ATTITUDE's yaw over {} GPS_RAW_INT samples", diffs.len()),
            None => String::new(),
        };
        notes.push(format!(
            "the GPS is fed over GPS_INPUT by sysid/compid {}: GPS_RAW_INT yaw is not used as a reference (a companion such as an underwater positioning system may send the vehicle's own heading back){agreement}",
            senders.join(", ")
        ));
    }

    let t: Vec<f64> = rows.iter().map(|r| r.t_s).collect();
    let clock = "s since the autopilot's boot (RAW_IMU time_usec, SCALED_IMU2/3 and ATTITUDE time_boot_ms, GPS_RAW_INT time_usec)";
    let mut b = Builder::new(Format::Tlog, t, clock);
    b.report.field_unit = Some("mGauss".into());
    let mag_from = match instance {
        0 => "RAW_IMU xmag/ymag/zmag",
        1 => "SCALED_IMU2 xmag/ymag/zmag",
        _ => "SCALED_IMU3 xmag/ymag/zmag",
    };
    let mag_from = if ardupilot {
        format!("{mag_from} (compass instance {instance}) of {autopilot}, mGauss, ArduPilot's correction undone with COMPASS_OFS{sfx}/DIA{sfx}/ODI{sfx}/SCALE{sfx} from PARAM_VALUE: the raw field")
    } else {
        format!("{mag_from} (compass instance {instance}) of {autopilot}, mGauss, as sent")
    };
    let gyro_from = format!("RAW_IMU xgyro/ygyro/zgyro (IMU 0) of {autopilot}: ArduPilot sends mrad/s, ÷ 1000 → rad/s{}", if instance == 0 { "" } else { ", interpolated to the compass's times" });
    let gps_from = |field: &str| format!("GPS_RAW_INT {field} of {autopilot} with a 3D fix (the latest within {} s)", opts.max_age_s);
    let reference_from = if gnss_yaw_is_reference {
        format!(
            "GPS_RAW_INT yaw (a GNSS compass's true heading) where set, else cog (course over ground) at a ground speed of {} m/s or more, with a 3D fix",
            opts.min_course_speed_mps
        )
    } else {
        format!("GPS_RAW_INT cog (course over ground) at a ground speed of {} m/s or more, with a 3D fix (its yaw not used: see the notes)", opts.min_course_speed_mps)
    };
    let mut sources: Vec<(&'static str, String, Role)> = Vec::new();
    for name in col::MAG {
        sources.push((name, mag_from.clone(), Role::Compass));
    }
    for name in col::GYRO {
        sources.push((name, gyro_from.clone(), Role::Sensor));
    }
    sources.push((col::ROLL_DEG, format!("ATTITUDE roll of {autopilot}, rad → degrees"), Role::Sensor));
    sources.push((col::PITCH_DEG, format!("ATTITUDE pitch of {autopilot}, rad → degrees"), Role::Sensor));
    sources.push((col::AHRS_YAW_DEG, format!("ATTITUDE yaw of {autopilot}, rad → degrees: the autopilot's own heading, from its compasses (not a reference)"), Role::OwnEstimate));
    sources.push((col::LAT_DEG, gps_from("lat (1e-7°)"), Role::Sensor));
    sources.push((col::LON_DEG, gps_from("lon (1e-7°)"), Role::Sensor));
    sources.push((col::GPS_SPEED_MPS, gps_from("vel (cm/s)"), Role::Sensor));
    sources.push((col::COURSE_DEG, gps_from("cog (c°) when moving"), Role::Sensor));
    sources.push((col::REF_HEADING_DEG, reference_from, Role::Reference));
    sources.push((col::VARIATION_DEG, format!("SENSOR_OFFSETS mag_declination of {autopilot} (the declination the autopilot uses), rad → degrees"), Role::Sensor));
    for (name, from, role) in sources {
        if let Some(values) = cols.remove(name) {
            b.column(name, values, from, role)?;
        }
    }
    b.report.messages = messages;
    b.skip("frames_with_bad_checksum", skips.bad_crc);
    b.skip("frames_of_unknown_message_id", skips.unknown_message);
    b.skip("frames_undecodable", undecodable);
    b.skip("bytes_skipped_to_resynchronise", skips.garbage_bytes);
    b.skip("truncated_tail_bytes", skips.truncated_tail_bytes);
    for (kind, count) in skipped {
        b.skip(kind, count);
    }
    b.skip("attitude_samples_out_of_time_order", att.out_of_order);
    b.skip("gps_samples_out_of_time_order", gps.out_of_order);
    b.skip("gyro_samples_out_of_time_order", gyro0.out_of_order);
    if let Some(t) = first_t_us {
        b.note(format!("the tlog's first frame was received at {} (the topside's clock)", utc(t)));
    }
    for note in notes {
        b.note(note);
    }
    b.finish()
}

/// The refusal for a log without a magnetometer, naming what it holds.
fn no_magnetometer(autopilot: String, messages: &BTreeMap<String, usize>) -> ImportError {
    let found = if messages.is_empty() { "none".to_string() } else { messages.iter().map(|(k, n)| format!("{k} {n}")).collect::<Vec<_>>().join(", ") };
    TlogError::NoMagnetometer { autopilot, found }.into()
}

/// |GPS_RAW_INT yaw − ATTITUDE yaw| at each GPS sample with a yaw, degrees.
fn gps_yaw_vs_attitude(kept: &[(u8, u8, Kept)], ours: &impl Fn(u8, u8) -> bool, att: &Series<3>) -> Vec<f64> {
    kept.iter()
        .filter(|(s, c, _)| ours(*s, *c))
        .filter_map(|(_, _, k)| match k {
            Kept::Gps { t_s, v } if v[4].is_finite() => {
                let [_, _, yaw] = att.at(*t_s, 1.0)?;
                Some(rules::wrap180(v[4] - yaw).abs())
            }
            _ => None,
        })
        .collect()
}

/// The median, `None` for no values.
fn median(mut v: Vec<f64>) -> Option<f64> {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => v.get(n / 2).copied(),
        _ => Some((v[n / 2 - 1] + v[n / 2]) / 2.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{
        ATTITUDE_DATA, GpsFixType, HEARTBEAT_DATA, MavType, PARAM_VALUE_DATA, RAW_IMU_DATA, SCALED_IMU2_DATA,
    };
    use mavlink::{MAVLinkV1MessageRaw, MAVLinkV2MessageRaw, MavHeader};

    const T0: u64 = 1_683_220_541_000_000;

    fn record(t_us: u64, sysid: u8, compid: u8, msg: &MavMessage, v1: bool) -> Vec<u8> {
        let header = MavHeader { system_id: sysid, component_id: compid, sequence: 0 };
        let mut out = t_us.to_be_bytes().to_vec();
        if v1 {
            let mut raw = MAVLinkV1MessageRaw::new();
            raw.serialize_message(header, msg);
            out.extend_from_slice(raw.raw_bytes());
        } else {
            let mut raw = MAVLinkV2MessageRaw::new();
            raw.serialize_message(header, msg);
            out.extend_from_slice(raw.raw_bytes());
        }
        out
    }

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_SUBMARINE, autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA, ..Default::default() })
    }

    fn param(name: &str, value: f32) -> MavMessage {
        let mut id = [0u8; 16];
        id[..name.len()].copy_from_slice(name.as_bytes());
        MavMessage::PARAM_VALUE(PARAM_VALUE_DATA { param_id: id.into(), param_value: value, ..Default::default() })
    }

    fn raw_imu(t_ms: u64, mag: [i16; 3], gyro: [i16; 3]) -> MavMessage {
        MavMessage::RAW_IMU(RAW_IMU_DATA {
            time_usec: t_ms * 1000,
            xgyro: gyro[0],
            ygyro: gyro[1],
            zgyro: gyro[2],
            xmag: mag[0],
            ymag: mag[1],
            zmag: mag[2],
            ..Default::default()
        })
    }

    /// A small log: heartbeat, offsets 10/20/30 (DIA 1, ODI 0 by default),
    /// 5 RAW_IMU at 2 Hz and ATTITUDE at 10 Hz, alternating v1 and v2.
    fn log() -> Vec<u8> {
        let mut b = Vec::new();
        let mut t = T0;
        let mut push = |m: MavMessage, b: &mut Vec<u8>| {
            t += 1000;
            let v1 = t.is_multiple_of(2000);
            b.extend(record(t, 1, 1, &m, v1));
        };
        push(heartbeat(), &mut b);
        push(MavMessage::HEARTBEAT(HEARTBEAT_DATA { mavtype: MavType::MAV_TYPE_GCS, autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID, ..Default::default() }), &mut b);
        for (name, v) in [("COMPASS_OFS_X", 10.0), ("COMPASS_OFS_Y", 20.0), ("COMPASS_OFS_Z", 30.0)] {
            push(param(name, v), &mut b);
        }
        for k in 0..25u64 {
            let yaw = (k as f32 * 0.1).sin();
            push(MavMessage::ATTITUDE(ATTITUDE_DATA { time_boot_ms: 1000 + 100 * k as u32, roll: 0.1, pitch: -0.05, yaw, ..Default::default() }), &mut b);
            if k % 5 == 0 {
                push(raw_imu(1000 + 100 * k, [110, 220, 330 + k as i16], [1, -2, 3]), &mut b);
            }
        }
        b
    }

    #[test]
    fn a_log_is_read_and_the_correction_undone() {
        let bytes = log();
        assert!(looks_like(&bytes[..bytes.len().min(4096)]));
        // A first frame with a bad checksum does not hide the format.
        let mut first_bad = bytes.clone();
        first_bad[TIME_LEN + 12] ^= 0xFF;
        assert!(looks_like(&first_bad) && !matches!(super::record(&first_bad, 0), Record::Good(..)));
        assert!(!looks_like(b"t,mx,my,mz\n0,1,2,3\n") && !looks_like(&[]));
        let im = import(&bytes, &ImportOptions::default()).unwrap();
        assert_eq!(im.report.rows, 5);
        assert_eq!(im.report.messages["RAW_IMU"], 5);
        assert_eq!(im.report.messages["ATTITUDE"], 25);
        assert_eq!(im.report.messages["HEARTBEAT"], 2);
        assert_eq!(im.column("mx").unwrap(), [100.0; 5]);
        assert_eq!(im.column("mz").unwrap()[4], 300.0 + 20.0);
        assert_eq!(im.column("t").unwrap()[1], 1.5);
        assert!((im.column("gy").unwrap()[0] + 0.002).abs() < 1e-12);
        assert!((im.column("roll_deg").unwrap()[0] - 0.1f32.to_degrees() as f64).abs() < 1e-4);
        assert_eq!(im.report.column_sources["ahrs_yaw_deg"].role, Role::OwnEstimate);
        assert!(im.report.skipped.is_empty(), "{:?}", im.report.skipped);
        assert!(im.report.notes.iter().any(|n| n.contains("corrected one")), "{:?}", im.report.notes);
    }

    #[test]
    fn corrupt_frames_are_skipped_and_counted() {
        let good = log();
        let clean = import(&good, &ImportOptions::default()).unwrap();
        // A flipped payload byte in the 6th record (a bad checksum), junk
        // between two records, and a record cut by the end of the file.
        let mut lens = Vec::new();
        let mut o = 0;
        while let Record::Good(_, len) = super::record(&good, o) {
            lens.push((o, len));
            o += len;
        }
        let (o5, l5) = lens[5];
        let mut bad = good[..o5].to_vec();
        let mut frame = good[o5..o5 + l5].to_vec();
        frame[TIME_LEN + 12] ^= 0x55;
        bad.extend(frame);
        bad.extend([0xFD, 0x00, 0x13, 0x37, 0xFE]);
        bad.extend(&good[o5 + l5..]);
        bad.extend(&good[lens[3].0..lens[3].0 + 12]);
        let im = import(&bad, &ImportOptions::default()).unwrap();
        assert_eq!(im.report.skipped["frames_with_bad_checksum"], 1);
        assert_eq!(im.report.skipped["bytes_skipped_to_resynchronise"], 5);
        assert_eq!(im.report.skipped["truncated_tail_bytes"], 12);
        let lost = clean.report.messages.values().sum::<usize>() - im.report.messages.values().sum::<usize>();
        assert_eq!(lost, 1);
    }

    #[test]
    fn hostile_input_is_refused_by_name() {
        let e = import(b"t,mx,my,mz\n0,1,2,3\n", &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains("not a MAVLink telemetry log"), "{e}");
        let bytes = log();
        let e = import(&bytes[..20], &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        // A start byte other than 0xFE/0xFD everywhere.
        let wrong: Vec<u8> = bytes.iter().map(|&b| if b == STX_V1 || b == STX_V2 { 0xFC } else { b }).collect();
        assert!(!looks_like(&wrong));
        assert!(import(&wrong, &ImportOptions::default()).unwrap_err().to_string().contains("not a MAVLink telemetry log"));
        // No magnetometer: only attitude.
        let mut no_mag = record(T0, 1, 1, &heartbeat(), false);
        no_mag.extend(record(T0 + 1, 1, 1, &MavMessage::ATTITUDE(ATTITUDE_DATA::default()), false));
        let e = import(&no_mag, &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains("no magnetometer") && e.contains("ATTITUDE 1"), "{e}");
        // An instance not in the log.
        let e = import(&bytes, &ImportOptions { instance: Some(2), ..Default::default() }).unwrap_err().to_string();
        assert!(e.contains("no instance 2") && e.contains("[0]"), "{e}");
        // No offsets anywhere: the raw field cannot be recovered.
        let mut no_ofs = record(T0, 1, 1, &heartbeat(), false);
        no_ofs.extend(record(T0 + 1, 1, 1, &raw_imu(1000, [1, 2, 3], [0; 3]), false));
        let e = import(&no_ofs, &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains("COMPASS_OFS_X") && e.contains("SENSOR_OFFSETS"), "{e}");
        // Random bytes never panic.
        let mut x = 0x2545_F491_4F6C_DD1Du64;
        for n in [0usize, 1, 7, 9, 100, 5000] {
            let junk: Vec<u8> = (0..n)
                .map(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    x as u8
                })
                .collect();
            let _ = import(&junk, &ImportOptions::default());
            let mut spliced = bytes.clone();
            spliced.splice(100..100, junk);
            let _ = import(&spliced, &ImportOptions::default());
        }
    }

    #[test]
    fn other_systems_and_zero_fields_are_counted() {
        let mut b = log();
        // A second system's RAW_IMU, and a SCALED_IMU2 of no compass (zeros).
        b.extend(record(T0 + 900_000, 2, 1, &raw_imu(5000, [1, 1, 1], [0; 3]), false));
        b.extend(record(T0 + 900_001, 1, 1, &MavMessage::SCALED_IMU2(SCALED_IMU2_DATA { time_boot_ms: 5000, ..Default::default() }), false));
        let im = import(&b, &ImportOptions::default()).unwrap();
        assert_eq!(im.report.skipped["messages_from_other_systems"], 1);
        assert_eq!(im.report.rows, 5);
        let e = import(&b, &ImportOptions { instance: Some(1), ..Default::default() }).unwrap_err().to_string();
        assert!(e.contains("no instance 1"), "{e}");
    }

    #[test]
    fn dates_are_civil() {
        assert_eq!(utc(0), "1970-01-01T00:00:00Z");
        assert_eq!(utc(1_683_220_541_055_000), "2023-05-04T17:15:41Z");
        assert_eq!(utc(951_782_400_000_000), "2000-02-29T00:00:00Z");
    }

    #[test]
    fn a_gnss_compass_or_the_course_at_speed_is_the_reference() {
        use mavlink::dialects::ardupilotmega::{GPS_INPUT_DATA, GPS_RAW_INT_DATA};
        let gps = |t_ms: u64, vel_cm_s: u16, cog_cdeg: u16, yaw_cdeg: u16| {
            MavMessage::GPS_RAW_INT(GPS_RAW_INT_DATA {
                time_usec: t_ms * 1000,
                lat: 483_861_418,
                lon: -1_246_305_732,
                vel: vel_cm_s,
                cog: cog_cdeg,
                fix_type: GpsFixType::GPS_FIX_TYPE_3D_FIX,
                yaw: yaw_cdeg,
                ..Default::default()
            })
        };
        let mut b = log();
        let mut t = T0 + 10_000_000;
        for m in [
            gps(5_000, 30, 9_000, 0), // slow, no yaw: nothing
            raw_imu(5_100, [1, 1, 1], [0; 3]),
            gps(5_200, 150, 9_000, 0), // 1.5 m/s, no yaw: the course
            raw_imu(5_300, [1, 1, 2], [0; 3]),
            gps(5_400, 150, 9_000, 36_000), // a GNSS compass: north
            raw_imu(5_500, [1, 1, 3], [0; 3]),
        ] {
            t += 100_000;
            b.extend(record(t, 1, 1, &m, false));
        }
        let im = import(&b, &ImportOptions::default()).unwrap();
        let reference = im.column("ref_heading_deg").unwrap();
        let course = im.column("course_deg").unwrap();
        assert!(reference[5].is_nan() && course[5] == 90.0, "{reference:?}");
        assert_eq!(reference[6], 90.0);
        assert_eq!(reference[7], 0.0);
        assert_eq!(im.column("gps_speed_mps").unwrap()[6], 1.5);
        assert!((im.column("lat_deg").unwrap()[7] - 48.386_141_8).abs() < 1e-9);
        assert_eq!(im.report.column_sources["ref_heading_deg"].role, Role::Reference);
        assert!(im.report.column_sources["ref_heading_deg"].from.contains("GNSS compass"));
        // A GPS stamped with Unix time (not the autopilot's boot clock): counted, not used.
        let mut unix = b.clone();
        unix.extend(record(t + 1, 1, 1, &gps(1_700_000_000_000, 150, 9_000, 0), false));
        assert_eq!(import(&unix, &ImportOptions::default()).unwrap().report.skipped["gps_not_on_boot_clock"], 1);
        // A GPS fed over GPS_INPUT: its yaw is not a reference.
        b.extend(record(t + 1, 1, 220, &MavMessage::GPS_INPUT(GPS_INPUT_DATA::default()), false));
        let im = import(&b, &ImportOptions::default()).unwrap();
        assert_eq!(im.column("ref_heading_deg").unwrap()[7], 90.0, "the course at speed instead");
        assert!(im.report.notes.iter().any(|n| n.contains("GPS_INPUT by sysid/compid 1/220")), "{:?}", im.report.notes);
    }

}
