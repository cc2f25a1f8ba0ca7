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
//!
//! One room per job: the records and frames, their checksums and the
//! resynchronisation ([`framing`]); what is kept of each message read
//! ([`messages`]); the import itself, here.

use std::collections::{BTreeMap, BTreeSet, HashMap};

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage};
use mavlink::Message;

use super::rules::{self, Kind, Series};
use super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use crate::data::dataflash::{compass_matrix, solve3};
use crate::data::table::col;

mod framing;
mod messages;

pub use framing::looks_like;
use framing::{read_frames, record, Record, UNIX_US};
use messages::{compass_parameters, keep, suffix, Kept};

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
mod tests;
