//! What the import keeps of each MAVLink message it reads (the others are
//! only counted), and the names of the compass parameters it follows.

use mavlink::dialects::ardupilotmega::{MavAutopilot, MavMessage};

use super::framing::UNIX_US;

/// The compass parameters' suffix of an instance (`COMPASS_OFS_X`,
/// `COMPASS_OFS2_X`, …).
pub(super) fn suffix(instance: u32) -> String {
    if instance == 0 {
        String::new()
    } else {
        (instance + 1).to_string()
    }
}

/// What the import keeps of a message of a kind it uses (others are only
/// counted): times on the autopilot's boot clock, s; fields in mGauss;
/// rates in rad/s; angles in degrees.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Kept {
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
pub(super) fn keep(m: &MavMessage) -> Option<Kept> {
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
pub(super) fn compass_parameters(instance: u32) -> Vec<String> {
    let sfx = suffix(instance);
    let mut names: Vec<String> = ["OFS", "DIA", "ODI", "MOT"].iter().flat_map(|b| ["_X", "_Y", "_Z"].map(|a| format!("COMPASS_{b}{sfx}{a}"))).collect();
    names.extend([format!("COMPASS_SCALE{sfx}"), "COMPASS_MOTCT".to_string(), "COMPASS_PMOT_EN".to_string()]);
    names
}
