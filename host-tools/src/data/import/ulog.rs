//! PX4 ULog (`.ulg`): the magnetometer, the gyro, the attitude, the GNSS and
//! the `CAL_MAG*` parameters of the log PX4 writes on every vehicle.
//!
//! **Read by hand** (the private `reader` module, from the PX4 documentation's "ULog File
//! Format") rather than with the `px4-ulog` crate (0.6.1, maintained under
//! the PX4 organisation): that crate panics on a subscription (`A`) or
//! parameter (`P`) message shorter than its fixed part (it indexes the
//! payload before checking its length: a 3-byte log tail `00 00 41` after
//! the definitions is enough), and it ends the whole read at the first
//! malformed message instead of skipping it (its README: recovery by the
//! synchronisation message "planned"). Here every length is checked, nested
//! formats resolve to a bounded depth, and a bad message is skipped and
//! counted by kind.
//!
//! What is read, one row per sample of the chosen magnetometer:
//! * the field, gauss (PX4's unit, the one `magcal export --format px4`
//!   writes), from the first of
//!   - `sensor_mag` (every instance: the first, or `--instance N`; the note
//!     says which exist and their device ids): the magnetometer's own
//!     field. PX4 v1.12 on applies `CAL_MAGn_*` in its sensors module, so
//!     `sensor_mag` is raw; before v1.12 the drivers applied the offsets and
//!     scales (`(raw − OFF)·SCALE`) before publishing, and that correction is
//!     undone (`field/SCALE + OFF`, with the `CAL_MAGn` whose `ID` is the
//!     instance's `device_id`; the v1.11 sample log bears this out: its
//!     `sensor_mag` equals its `vehicle_magnetometer` sample for sample, and
//!     as logged its internal magnetometer's horizontal field is near the
//!     Earth's there, 0.13 gauss against 0.14, where correcting it again
//!     would give 0.35). The field stays in the magnetometer's axes, where
//!     PX4 applies `CAL_MAGn`'s offsets; a rotation
//!     (`CAL_MAGn_ROT`, or `SENS_BOARD_ROT` for an internal one) is not
//!     applied and is said in a note;
//!   - `vehicle_magnetometer.magnetometer_ga` (`--topic vehicle_magnetometer`
//!     when `sensor_mag` is there too): PX4's **corrected** field, in the
//!     vehicle's axes, said so and not undone;
//!   - `sensor_combined.magnetometer_ga` (older PX4): the corrected field
//!     too, one row per new sample (`timestamp + magnetometer_timestamp_relative`);
//! * `roll_deg`, `pitch_deg` and `ahrs_yaw_deg` (the vehicle's own estimate,
//!   never a reference) from `vehicle_attitude.q` (Hamilton `w, x, y, z`,
//!   body FRD to world NED);
//! * `gx, gy, gz` (rad/s) from `sensor_combined.gyro_rad` (the vehicle's
//!   axes), else `sensor_gyro` instance 0 (the gyro's axes, said);
//! * `lat_deg`, `lon_deg`, `course_deg`, `gps_speed_mps` from
//!   `vehicle_gps_position` (else `sensor_gps`): `lat`/`lon` in 1e-7° or
//!   `latitude_deg`/`longitude_deg`, `vel_m_s`, `cog_rad`; fixes with
//!   `fix_type` < 2 are skipped and counted;
//! * `ref_heading_deg`: the GNSS compass's `heading` (rad, NaN when the
//!   receiver has none) when the log has one finite, else the course at
//!   speed ([`rules::course_at_speed_deg`]).
//!
//! Time: the ULog `timestamp`, µs since PX4's boot, in s. Dropouts (the
//! logger's buffer overran) are counted in the report's `skipped`.

mod reader;

use std::collections::{BTreeMap, HashMap};

use super::rules::{self, Kind, Series};
use super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use crate::data::table::col;

/// Why a PX4 ULog could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum UlogError {
    /// The first bytes are not a ULog's.
    #[error("not a PX4 ULog: the file does not start with the ULog magic \"ULog\" 01 12 35")]
    NotUlog,
    /// The file ends inside its 16-byte header.
    #[error("the ULog is truncated in its header ({0} of 16 bytes)")]
    TruncatedHeader(usize),
    /// An incompatible flag this reader does not know is set.
    #[error("the ULog sets incompatible flag byte {index} = {value:#04x}, which this reader does not know")]
    Incompatible {
        /// Byte of the incompatible flags.
        index: usize,
        /// Its value.
        value: u8,
    },
    /// The file ends before the data section.
    #[error("the ULog ends before its data section (truncated in the definitions)")]
    NoDataSection,
    /// No magnetometer topic with data.
    #[error("the ULog has no magnetometer (sensor_mag, vehicle_magnetometer or sensor_combined.magnetometer_ga); topics with data: {}", topics.join(", "))]
    NoMagnetometer {
        /// The topics with data.
        topics: Vec<String>,
    },
    /// `--topic` names no magnetometer topic with data.
    #[error("--topic {wanted}: not a magnetometer topic with data in this ULog (found: {})", found.join(", "))]
    NoTopic {
        /// The topic asked for.
        wanted: String,
        /// The magnetometer topics with data.
        found: Vec<String>,
    },
}

/// Whether a log's first bytes look like a PX4 ULog.
pub fn looks_like(head: &[u8]) -> bool {
    head.starts_with(&reader::MAGIC)
}

/// The magnetometer topics, in the order they are preferred.
const MAG_TOPICS: [&str; 3] = ["sensor_mag", "vehicle_magnetometer", "sensor_combined"];
/// `magnetometer_timestamp_relative` when there is no new sample.
const RELATIVE_INVALID: f64 = 2_147_483_647.0;

/// The topics and fields read (`timestamp` comes first by itself).
fn wanted() -> HashMap<&'static str, Vec<&'static str>> {
    let gps = vec!["lat", "lon", "latitude_deg", "longitude_deg", "vel_m_s", "cog_rad", "heading", "fix_type"];
    HashMap::from([
        ("sensor_mag", vec!["x", "y", "z", "device_id", "temperature"]),
        ("vehicle_magnetometer", vec!["magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]", "device_id"]),
        (
            "sensor_combined",
            vec!["magnetometer_ga[0]", "magnetometer_ga[1]", "magnetometer_ga[2]", "magnetometer_timestamp_relative", "gyro_rad[0]", "gyro_rad[1]", "gyro_rad[2]"],
        ),
        ("sensor_gyro", vec!["x", "y", "z"]),
        ("vehicle_attitude", vec!["q[0]", "q[1]", "q[2]", "q[3]"]),
        ("vehicle_gps_position", gps.clone()),
        ("sensor_gps", gps),
    ])
}

/// The rows of a topic's instance (empty when none).
fn rows_of<'a>(log: &'a reader::Log, topic: &str, instance: u8) -> &'a [Vec<f64>] {
    log.rows.get(&(topic.to_string(), instance)).map(Vec::as_slice).unwrap_or_default()
}

/// The instances of a magnetometer topic with a finite field.
fn mag_instances(log: &reader::Log, topic: &str) -> Vec<u32> {
    log.rows.iter().filter(|((t, _), rows)| t == topic && rows.iter().any(|r| r.get(1).is_some_and(|v| v.is_finite()))).map(|((_, i), _)| u32::from(*i)).collect()
}

/// The `CAL_MAGn` whose `ID` is `device_id`.
fn cal_index(params: &BTreeMap<String, f64>, device_id: f64) -> Option<usize> {
    (0..10).find(|k| params.get(&format!("CAL_MAG{k}_ID")) == Some(&device_id))
}

/// PX4's version from `ver_sw_release` (major, minor, patch, type: below 64
/// a development build, then alpha, beta, release candidate, 255 a
/// release): (major, minor) and the version for people.
fn version(log: &reader::Log) -> (Option<(u32, u32)>, String) {
    match log.info_num.get("ver_sw_release").map(|&v| v as u32) {
        Some(v) => {
            let kind = match v & 0xff {
                0..64 => " (development build)",
                64..128 => " (alpha)",
                128..192 => " (beta)",
                192..255 => " (release candidate)",
                _ => "",
            };
            (Some(((v >> 24) & 0xff, (v >> 16) & 0xff)), format!("v{}.{}.{}{kind}", (v >> 24) & 0xff, (v >> 16) & 0xff, (v >> 8) & 0xff))
        }
        None => (None, "of unknown version".to_string()),
    }
}

/// Imports a PX4 ULog held in memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    let log = reader::read(bytes, &wanted()).map_err(|e| match e {
        reader::ReadError::NotUlog => UlogError::NotUlog,
        reader::ReadError::TruncatedHeader(n) => UlogError::TruncatedHeader(n),
        reader::ReadError::Incompatible { index, value } => UlogError::Incompatible { index, value },
        reader::ReadError::NoDataSection => UlogError::NoDataSection,
    })?;
    let present: Vec<&str> = MAG_TOPICS.into_iter().filter(|t| !mag_instances(&log, t).is_empty()).collect();
    let topic = match &opts.topic {
        Some(w) => *present.iter().find(|t| *t == w).ok_or_else(|| UlogError::NoTopic { wanted: w.clone(), found: present.iter().map(|t| t.to_string()).collect() })?,
        None => *present.first().ok_or_else(|| UlogError::NoMagnetometer { topics: log.counts.keys().map(|(t, i)| format!("{t}/{i}")).collect() })?,
    };
    let (instance, choice) = rules::choose_instance(topic, &mag_instances(&log, topic), opts.instance)?;
    let instance = u8::try_from(instance).unwrap_or_default();

    // The compass's samples: time (s), field (gauss), temperature.
    let mut t_s = Vec::new();
    let mut field = Vec::new();
    let mut temp_c = Vec::new();
    let mut repeats = 0usize;
    for r in rows_of(&log, topic, instance) {
        let v = |k: usize| r.get(k).copied().unwrap_or(f64::NAN);
        let (t_us, temp) = match topic {
            "sensor_combined" if !v(4).is_finite() || v(4) == RELATIVE_INVALID => continue,
            "sensor_combined" => (v(0) + v(4), f64::NAN),
            "sensor_mag" => (v(0), v(5)),
            _ => (v(0), f64::NAN),
        };
        let t = t_us * 1e-6;
        if topic == "sensor_combined" && t_s.last() == Some(&t) {
            repeats += 1;
            continue;
        }
        t_s.push(t);
        field.push([v(1), v(2), v(3)]);
        temp_c.push(temp);
    }

    let mut b = Builder::new(Format::Ulog, t_s.clone(), "s since PX4's boot (the ULog timestamp, µs)");
    b.report.field_unit = Some("gauss".into());
    if let Some(c) = choice {
        b.note(c);
    }
    let from = match topic {
        "sensor_mag" => sensor_mag(&log, instance, &mut field, &mut b),
        "vehicle_magnetometer" => {
            b.note("vehicle_magnetometer is PX4's corrected field (CAL_MAG* offsets, scales and rotation applied, the vehicle's axes), not undone: prefer sensor_mag, the raw field, where the log has it");
            format!("vehicle_magnetometer instance {instance} magnetometer_ga[0..2] (gauss, PX4's corrected field)")
        }
        _ => {
            if repeats > 0 {
                b.note(format!("{repeats} sensor_combined messages repeat the previous magnetometer sample: one row per sample"));
            }
            b.note("sensor_combined.magnetometer_ga (older PX4) is the corrected field of the primary magnetometer (its driver's offsets and scales, the board rotation applied), not undone: which magnetometer it was is not logged");
            "sensor_combined magnetometer_ga[0..2] at timestamp + magnetometer_timestamp_relative (gauss, PX4's corrected field)".to_string()
        }
    };
    for k in 0..10 {
        let p = |name: &str| log.params.get(&format!("CAL_MAG{k}_{name}")).copied();
        let Some(id) = p("ID").filter(|id| *id != 0.0) else { continue };
        let v = |names: [&str; 3]| names.map(|n| p(n).map_or("?".into(), |v| format!("{v:.6}"))).join(" ");
        let flags: String = ["EN", "ROT"].iter().filter_map(|n| p(n).map(|v| format!(", {n} {v}"))).collect();
        b.note(format!("CAL_MAG{k}: ID {id}{flags}, OFF {} gauss, SCALE {}", v(["XOFF", "YOFF", "ZOFF"]), v(["XSCALE", "YSCALE", "ZSCALE"])));
    }
    for (k, name) in col::MAG.into_iter().enumerate() {
        b.column(name, field.iter().map(|m| m[k]).collect(), from.clone(), Role::Compass)?;
    }
    b.column(col::TEMP_C, temp_c, format!("{topic} instance {instance} temperature (°C)"), Role::Sensor)?;
    carried(&log, &t_s, opts, &mut b)?;
    counts(&log, &mut b);
    b.finish()
}

/// sensor_mag: the instances and their calibrations said, the pre-v1.12
/// driver correction undone in `field`; returns the field's source.
fn sensor_mag(log: &reader::Log, instance: u8, field: &mut [[f64; 3]], b: &mut Builder) -> String {
    let params = &log.params;
    let device_of = |i: u8| rows_of(log, "sensor_mag", i).iter().find_map(|r| r.get(4).copied().filter(|d| d.is_finite() && *d > 0.0));
    let ids: Vec<String> = mag_instances(log, "sensor_mag")
        .iter()
        .map(|&i| {
            let id = device_of(u8::try_from(i).unwrap_or_default());
            let k = id.and_then(|id| cal_index(params, id));
            let prime = id.is_some() && params.get("CAL_MAG_PRIME") == id.as_ref();
            format!("{i} = device id {}{}{}", id.map_or("?".into(), |d| format!("{d}")), k.map_or(String::new(), |k| format!(" (CAL_MAG{k})")), if prime { " CAL_MAG_PRIME" } else { "" })
        })
        .collect();
    b.note(format!("sensor_mag instances: {}", ids.join("; ")));
    let corrected = log.rows.iter().filter(|((t, _), _)| t == "vehicle_magnetometer").map(|(_, r)| r.len()).max().unwrap_or(0);
    if corrected > field.len() {
        b.note(format!("sensor_mag instance {instance} has {} samples, vehicle_magnetometer {corrected}: --topic vehicle_magnetometer imports those (PX4's corrected field)", field.len()));
    }
    let device_id = device_of(instance);
    let cal = device_id.and_then(|id| cal_index(params, id));
    let mut from = format!("sensor_mag instance {instance} x, y, z (gauss{})", device_id.map_or(String::new(), |d| format!(", device id {d}")));
    let (version, version_text) = version(log);
    match version {
        None => b.note("PX4's version is not in the log (no ver_sw_release): sensor_mag taken as the raw field, as PX4 v1.12 on writes it (before v1.12 its drivers applied CAL_MAG*)"),
        Some(v) if v >= (1, 12) => b.note(format!("sensor_mag of PX4 {version_text} is the drivers' field before PX4's calibration (CAL_MAG* applied in the sensors module from v1.12 on): the raw field")),
        Some(_) => {
            let p = |k: usize, name: &str| params.get(&format!("CAL_MAG{k}_{name}")).copied();
            let undo = cal.and_then(|k| {
                let off = [p(k, "XOFF")?, p(k, "YOFF")?, p(k, "ZOFF")?];
                let scale = [p(k, "XSCALE")?, p(k, "YSCALE")?, p(k, "ZSCALE")?];
                (off.iter().chain(&scale).all(|v| v.is_finite()) && scale.iter().all(|s| *s != 0.0)).then_some((k, off, scale))
            });
            match undo {
                Some((k, off, scale)) => {
                    for m in field.iter_mut() {
                        for a in 0..3 {
                            m[a] = m[a] / scale[a] + off[a];
                        }
                    }
                    from.push_str(&format!(", CAL_MAG{k}'s correction undone: the raw field"));
                    b.note(format!(
                        "sensor_mag of PX4 {version_text}, before v1.12, is corrected by its driver, (raw − OFF)·SCALE: undone with CAL_MAG{k} (OFF {:.6} {:.6} {:.6} gauss, SCALE {:.6} {:.6} {:.6}) as the log starts",
                        off[0], off[1], off[2], scale[0], scale[1], scale[2]
                    ));
                    if log.param_changes.iter().any(|(n, _)| n.starts_with(&format!("CAL_MAG{k}_"))) {
                        b.note(format!("CAL_MAG{k} changes during the log: the values as it starts are undone throughout"));
                    }
                }
                None => {
                    from.push_str(", corrected by its driver (not undone)");
                    b.note(format!("sensor_mag of PX4 {version_text}, before v1.12, is corrected by its driver and the log has no complete CAL_MAGn for device id {}: the field is the corrected one, not undone", device_id.map_or("?".into(), |d| format!("{d}"))));
                }
            }
        }
    }
    if let Some(k) = cal {
        let rot = params.get(&format!("CAL_MAG{k}_ROT")).copied().unwrap_or(-1.0);
        let board = params.get("SENS_BOARD_ROT").copied().unwrap_or(0.0);
        let turned = if rot < 0.0 { (board != 0.0).then(|| format!("internal: SENS_BOARD_ROT = {board}")) } else { (rot != 0.0).then(|| format!("CAL_MAG{k}_ROT = {rot}")) };
        if let Some(turned) = turned {
            b.note(format!("the field is in the magnetometer's axes, where PX4 applies CAL_MAG{k}'s offsets (as `magcal export --format px4` writes them); its rotation to the vehicle's axes ({turned}, PX4's rotation enumeration) is not applied, so its axes are not the attitude's and the gyro's"));
        }
        let comp_type = params.get("CAL_MAG_COMP_TYP").copied().unwrap_or(0.0);
        let comp = ["XCOMP", "YCOMP", "ZCOMP"].iter().any(|c| params.get(&format!("CAL_MAG{k}_{c}")).is_some_and(|v| *v != 0.0));
        if comp_type != 0.0 && comp {
            b.note(format!("CAL_MAG_COMP_TYP = {comp_type}: PX4's power compensation (CAL_MAG{k}_XCOMP…) is in the log and not undone"));
        }
    } else if device_id.is_some() {
        b.note("no CAL_MAGn_ID is this instance's device id: its rotation to the vehicle's axes is unknown");
    }
    from
}

/// The attitude, the gyro and the GNSS carried to the compass's times.
fn carried(log: &reader::Log, t_s: &[f64], opts: &ImportOptions, b: &mut Builder) -> Result<(), ImportError> {
    fn pick<const K: usize>(v: &[Option<[f64; K]>], k: usize) -> Vec<f64> {
        v.iter().map(|e| e.map_or(f64::NAN, |e| e[k])).collect()
    }
    let max_age = opts.max_age_s;
    let time = |r: &Vec<f64>| r.first().copied().unwrap_or(f64::NAN) * 1e-6;

    let mut att = Series::new([Kind::Angle180, Kind::Angle180, Kind::Heading360]);
    for r in rows_of(log, "vehicle_attitude", 0) {
        if let Some(e) = rules::quaternion_to_euler_deg([1, 2, 3, 4].map(|k| r.get(k).copied().unwrap_or(f64::NAN))) {
            att.push(time(r), e);
        }
    }
    let at: Vec<_> = t_s.iter().map(|&t| att.at(t, max_age)).collect();
    b.column(col::ROLL_DEG, pick(&at, 0), "vehicle_attitude q (roll of body FRD to NED, Z-Y-X)", Role::Sensor)?;
    b.column(col::PITCH_DEG, pick(&at, 1), "vehicle_attitude q (pitch of body FRD to NED, Z-Y-X)", Role::Sensor)?;
    b.column(col::AHRS_YAW_DEG, pick(&at, 2), "vehicle_attitude q (yaw: PX4's own estimate from its compass, not a reference)", Role::OwnEstimate)?;

    // sensor_combined (the vehicle's axes), else sensor_gyro instance 0.
    let combined = rows_of(log, "sensor_combined", 0);
    let (rows, cols, from) = if combined.iter().any(|r| r.get(5).is_some_and(|v| v.is_finite())) {
        (combined, [5, 6, 7], "sensor_combined gyro_rad[0..2] (rad/s, the vehicle's axes)")
    } else {
        (rows_of(log, "sensor_gyro", 0), [1, 2, 3], "sensor_gyro instance 0 x, y, z (rad/s, the gyro's axes)")
    };
    let mut gyro = Series::new([Kind::Linear; 3]);
    for r in rows {
        gyro.push(time(r), cols.map(|k| r.get(k).copied().unwrap_or(f64::NAN)));
    }
    let g: Vec<_> = t_s.iter().map(|&t| gyro.at(t, max_age)).collect();
    for (k, name) in col::GYRO.into_iter().enumerate() {
        b.column(name, pick(&g, k), from, Role::Sensor)?;
    }

    // vehicle_gps_position, else sensor_gps's first instance.
    let topic = if rows_of(log, "vehicle_gps_position", 0).is_empty() { "sensor_gps" } else { "vehicle_gps_position" };
    let instance = log.rows.keys().filter(|(t, _)| t == topic).map(|(_, i)| *i).min().unwrap_or(0);
    let rows = rows_of(log, topic, instance);
    let compass = rows.iter().any(|r| r.get(7).is_some_and(|h| h.is_finite()));
    let mut gps = Series::new([Kind::Linear, Kind::Linear, Kind::Heading360, Kind::Linear, Kind::Heading360]);
    let mut no_fix = 0;
    for r in rows {
        let v = |k: usize| r.get(k).copied().unwrap_or(f64::NAN);
        if v(8) < 2.0 {
            no_fix += 1;
            continue;
        }
        let (lat, lon) = if v(1).is_finite() { (v(1) * 1e-7, v(2) * 1e-7) } else { (v(3), v(4)) };
        let course = v(6).to_degrees().rem_euclid(360.0);
        let reference = if compass { v(7).to_degrees().rem_euclid(360.0) } else { rules::course_at_speed_deg(course, v(5), opts.min_course_speed_mps) };
        gps.push(time(r), [lat, lon, course, v(5), reference]);
    }
    b.skip("gnss_without_fix", no_fix);
    let fixes: Vec<_> = t_s.iter().map(|&t| gps.at(t, max_age)).collect();
    let src = format!("{topic} instance {instance}");
    b.column(col::LAT_DEG, pick(&fixes, 0), format!("{src} lat (1e-7 deg) or latitude_deg"), Role::Sensor)?;
    b.column(col::LON_DEG, pick(&fixes, 1), format!("{src} lon (1e-7 deg) or longitude_deg"), Role::Sensor)?;
    b.column(col::COURSE_DEG, pick(&fixes, 2), format!("{src} cog_rad (rad → deg)"), Role::Sensor)?;
    b.column(col::GPS_SPEED_MPS, pick(&fixes, 3), format!("{src} vel_m_s"), Role::Sensor)?;
    let ref_from = if compass {
        format!("{src} heading (a GNSS compass's true heading, rad → deg)")
    } else {
        format!("{src} cog_rad at vel_m_s ≥ {} m/s (the course over ground, not the heading: they differ by the crab angle in a current)", opts.min_course_speed_mps)
    };
    b.column(col::REF_HEADING_DEG, pick(&fixes, 4), ref_from, Role::Reference)?;
    b.skip("samples_back_in_time", att.out_of_order + gyro.out_of_order + gps.out_of_order);
    Ok(())
}

/// The messages read, the refusals, dropouts, appended sections, version.
fn counts(log: &reader::Log, b: &mut Builder) {
    for ((topic, instance), n) in &log.counts {
        *b.report.messages.entry(format!("{topic}/{instance}")).or_default() += n;
    }
    for (kind, n) in &log.other {
        *b.report.messages.entry(kind.to_string()).or_default() += n;
    }
    for (kind, n) in &log.skipped {
        b.skip(kind, *n);
    }
    let (dropouts, dropout_ms) = log.dropouts;
    b.skip("dropouts", dropouts);
    if dropouts > 0 {
        b.note(format!("{dropouts} dropouts: {dropout_ms} ms of messages lost by the logger (its buffer overran)"));
    }
    if log.appended_sections > 0 {
        b.note(format!("{} appended data sections read", log.appended_sections));
    }
    if log.version > 1 {
        b.note(format!("ULog format version {} (this reader knows 1): read as version 1", log.version));
    }
    let info: Vec<String> = ["sys_name", "ver_hw", "ver_sw"].iter().filter_map(|k| log.info_text.get(*k).map(|v| format!("{k} {v}"))).collect();
    let (_, version_text) = version(log);
    b.note(format!("PX4 {version_text}{}", if info.is_empty() { String::new() } else { format!(" ({})", info.join(", ")) }));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn msg(kind: u8, payload: &[u8]) -> Vec<u8> {
        let mut v = (payload.len() as u16).to_le_bytes().to_vec();
        v.push(kind);
        v.extend_from_slice(payload);
        v
    }

    fn keyed(key: &str, value: &[u8]) -> Vec<u8> {
        let mut p = vec![key.len() as u8];
        p.extend_from_slice(key.as_bytes());
        p.extend_from_slice(value);
        p
    }

    /// A ULog of PX4 `release` with one sensor_mag (device 7, samples at
    /// 1, 2, 3 s of (0.1·k, 0.2, 0.3) gauss), a sensor_gps (its second fix
    /// without a fix) and the parameters given.
    fn log(release: Option<u32>, params: &[(&str, f32)]) -> Vec<u8> {
        let mut b = reader::MAGIC.to_vec();
        b.push(1);
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend(msg(b'B', &[0; 40]));
        if let Some(r) = release {
            b.extend(msg(b'I', &keyed("uint32_t ver_sw_release", &r.to_le_bytes())));
        }
        b.extend(msg(b'F', b"sensor_mag:uint64_t timestamp;uint32_t device_id;float x;float y;float z;"));
        b.extend(msg(b'F', b"sensor_gps:uint64_t timestamp;double latitude_deg;double longitude_deg;float vel_m_s;float cog_rad;float heading;uint8_t fix_type;"));
        b.extend(msg(b'P', &keyed("int32_t CAL_MAG0_ID", &7i32.to_le_bytes())));
        for (name, v) in params {
            b.extend(msg(b'P', &keyed(&format!("float {name}"), &v.to_le_bytes())));
        }
        b.extend(msg(b'A', b"\x00\x00\x00sensor_mag"));
        b.extend(msg(b'A', b"\x01\x01\x00sensor_gps"));
        for k in 1..=3u64 {
            let mut d = vec![0, 0];
            d.extend_from_slice(&(k * 1_000_000).to_le_bytes());
            d.extend_from_slice(&7u32.to_le_bytes());
            for v in [0.1 * k as f32, 0.2, 0.3] {
                d.extend_from_slice(&v.to_le_bytes());
            }
            b.extend(msg(b'D', &d));
            let mut g = vec![1, 0];
            g.extend_from_slice(&(k * 1_000_000).to_le_bytes());
            for v in [60.5, 10.25] {
                g.extend_from_slice(&f64::to_le_bytes(v));
            }
            for v in [0.1f32, 1.0, 0.5] {
                g.extend_from_slice(&v.to_le_bytes());
            }
            g.push(if k == 2 { 1 } else { 3 });
            b.extend(msg(b'D', &g));
        }
        b
    }

    #[test]
    fn found_by_its_magic() {
        assert_eq!(Format::detect(&log(None, &[])), Some(Format::Ulog));
        assert_eq!(Format::detect(b"ULog\x01\x12\x36"), None);
    }

    #[test]
    fn a_gnss_compass_heading_is_the_reference() {
        let im = import(&log(Some(0x010E_00FF), &[]), &ImportOptions::default()).unwrap();
        assert_eq!(im.report.rows, 3);
        let r = im.column(col::REF_HEADING_DEG).unwrap();
        // 0.5 rad at 1 s and 3 s (the fix at 2 s has none): interpolated.
        for v in r {
            assert!((v - 0.5f64.to_degrees()).abs() < 1e-5, "{r:?}");
        }
        assert_eq!(im.report.column_sources[col::REF_HEADING_DEG].role, Role::Reference);
        assert!(im.report.column_sources[col::REF_HEADING_DEG].from.contains("heading (a GNSS compass"));
        assert_eq!(im.column(col::LAT_DEG).unwrap()[0], 60.5);
        assert_eq!(im.report.skipped["gnss_without_fix"], 1);
        assert_eq!(im.report.messages["sensor_gps/1"], 3);
        // v1.14: sensor_mag is raw, written as read.
        assert!((im.column("mx").unwrap()[2] - 0.3).abs() < 1e-7);
    }

    #[test]
    fn the_drivers_correction_before_1_12_is_undone_or_said() {
        let cal = [("CAL_MAG0_XOFF", 0.5), ("CAL_MAG0_YOFF", -0.25), ("CAL_MAG0_ZOFF", 0.0), ("CAL_MAG0_XSCALE", 2.0), ("CAL_MAG0_YSCALE", 0.5), ("CAL_MAG0_ZSCALE", 1.0)];
        let im = import(&log(Some(0x010A_01FF), &cal), &ImportOptions::default()).unwrap();
        // raw = field / SCALE + OFF.
        let (mx, my) = (im.column("mx").unwrap(), im.column("my").unwrap());
        assert!((mx[0] - (0.1 / 2.0 + 0.5)).abs() < 1e-7 && (my[0] - (0.2 / 0.5 - 0.25)).abs() < 1e-7, "{mx:?} {my:?}");
        assert!(im.report.notes.iter().any(|n| n.contains("v1.10.1") && n.contains("undone with CAL_MAG0")), "{:?}", im.report.notes);
        // Without the scales: the corrected field, said.
        let im = import(&log(Some(0x010A_01FF), &cal[..3]), &ImportOptions::default()).unwrap();
        assert!((im.column("mx").unwrap()[0] - 0.1).abs() < 1e-7);
        assert!(im.report.notes.iter().any(|n| n.contains("not undone")), "{:?}", im.report.notes);
        // No version: taken as raw, said.
        let im = import(&log(None, &cal), &ImportOptions::default()).unwrap();
        assert!((im.column("mx").unwrap()[0] - 0.1).abs() < 1e-7);
        assert!(im.report.notes.iter().any(|n| n.contains("no ver_sw_release")), "{:?}", im.report.notes);
    }

    proptest::proptest! {
        /// Any bytes after a valid start, or spliced into it: a result or a
        /// typed refusal, never a panic.
        #[test]
        fn any_bytes_never_panic(tail in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..600), cut in 0usize..1000) {
            let mut b = log(Some(0x010A_01FF), &[("CAL_MAG0_XSCALE", 0.0)]);
            let at = cut.min(b.len());
            b.splice(at..at, tail.iter().copied());
            let _ = import(&b, &ImportOptions::default());
            b.truncate(at);
            let _ = import(&b, &ImportOptions::default());
        }
    }

    #[test]
    fn hostile_bytes_of_a_real_log_never_panic() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/px4-ulog/sample_appended_multiple_cut.ulg");
        let good = std::fs::read(path).unwrap();
        let opts = ImportOptions::default();
        for n in (0..good.len()).step_by(251) {
            let _ = import(&good[..n], &opts);
        }
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        for _ in 0..40 {
            let mut b = good.clone();
            for _ in 0..20 {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let i = 16 + (state as usize) % (b.len() - 16);
                b[i] = (state >> 32) as u8;
            }
            if let Ok(im) = import(&b, &opts) {
                assert!(im.report.rows > 0);
            }
        }
        // A corrupt stretch in the data: skipped to the next sync and
        // counted, the rest read.
        let mut b = good.clone();
        let mut pos = 16;
        while b[pos + 2] != b'D' {
            pos += 3 + usize::from(u16::from_le_bytes([b[pos], b[pos + 1]]));
        }
        b[pos + 2] = 0;
        let im = import(&b, &opts).unwrap();
        assert!(im.report.skipped["corrupt_bytes"] > 0, "{:?}", im.report.skipped);
        assert!(im.report.messages["sensor_combined/0"] > 800, "{:?}", im.report.messages);
    }
}
