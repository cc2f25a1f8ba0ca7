//! The navigation computer's log (`docs/INTERFACES.md`, "Navigation log"):
//! attitude, GPS and the rest on the navigation clock, `magcal merge`'s
//! second input. The one home of its columns.

use std::path::Path;

use super::recording::{read_table, RecordingError};

/// `t`: seconds on the navigation clock.
pub const T: &str = "t";
/// `roll_deg`.
pub const ROLL_DEG: &str = "roll_deg";
/// `pitch_deg`.
pub const PITCH_DEG: &str = "pitch_deg";
/// `heading_deg`: the AHRS's heading.
pub const HEADING_DEG: &str = "heading_deg";
/// `ref_heading_deg`: GPS course or a reference heading.
pub const REF_HEADING_DEG: &str = "ref_heading_deg";
/// `lat_deg`.
pub const LAT_DEG: &str = "lat_deg";
/// `lon_deg`.
pub const LON_DEG: &str = "lon_deg";
/// `gx`, `gy`, `gz`: the body rate, rad/s.
pub const GYRO: [&str; 3] = ["gx", "gy", "gz"];
/// `speed_mps`.
pub const SPEED_MPS: &str = "speed_mps";
/// `motor_current_a`.
pub const MOTOR_CURRENT_A: &str = "motor_current_a";

/// The navigation computer's log on its own clock.
#[derive(Debug, Clone, Default)]
pub struct NavLog {
    /// `t`, seconds on the navigation clock.
    pub t_s: Vec<f64>,
    /// `roll_deg`.
    pub roll_deg: Vec<f64>,
    /// `pitch_deg`.
    pub pitch_deg: Vec<f64>,
    /// `heading_deg`: the AHRS's heading, when logged.
    pub heading_deg: Option<Vec<f64>>,
    /// `ref_heading_deg`: GPS course (at the surface) or a reference heading.
    pub ref_heading_deg: Option<Vec<f64>>,
    /// `lat_deg`.
    pub lat_deg: Option<Vec<f64>>,
    /// `lon_deg`.
    pub lon_deg: Option<Vec<f64>>,
    /// `gx, gy, gz`, rad/s.
    pub gyro_rad_s: Option<[Vec<f64>; 3]>,
    /// `speed_mps`.
    pub speed_mps: Option<Vec<f64>>,
    /// `motor_current_a`.
    pub motor_current_a: Option<Vec<f64>>,
}

impl NavLog {
    /// Reads a navigation log: `t, roll_deg, pitch_deg` required; the rest
    /// optional (see `docs/INTERFACES.md`).
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        let optional = [HEADING_DEG, REF_HEADING_DEG, LAT_DEG, LON_DEG, GYRO[0], GYRO[1], GYRO[2], SPEED_MPS, MOTOR_CURRENT_A];
        let mut t = read_table(path, &[T, ROLL_DEG, PITCH_DEG], &optional)?;
        let gyro = match GYRO.map(|c| t.take(c)) {
            [Some(x), Some(y), Some(z)] => Some([x, y, z]),
            _ => None,
        };
        Ok(Self {
            t_s: t.take(T).unwrap_or_default(),
            roll_deg: t.take(ROLL_DEG).unwrap_or_default(),
            pitch_deg: t.take(PITCH_DEG).unwrap_or_default(),
            heading_deg: t.take(HEADING_DEG),
            ref_heading_deg: t.take(REF_HEADING_DEG),
            lat_deg: t.take(LAT_DEG),
            lon_deg: t.take(LON_DEG),
            gyro_rad_s: gyro,
            speed_mps: t.take(SPEED_MPS),
            motor_current_a: t.take(MOTOR_CURRENT_A),
        })
    }

    /// Writes the log in the columns [`NavLog::read`] reads.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![(T, &self.t_s), (ROLL_DEG, &self.roll_deg), (PITCH_DEG, &self.pitch_deg)];
        for (name, c) in [
            (HEADING_DEG, &self.heading_deg),
            (REF_HEADING_DEG, &self.ref_heading_deg),
            (LAT_DEG, &self.lat_deg),
            (LON_DEG, &self.lon_deg),
            (SPEED_MPS, &self.speed_mps),
            (MOTOR_CURRENT_A, &self.motor_current_a),
        ] {
            if let Some(c) = c {
                cols.push((name, c));
            }
        }
        if let Some([x, y, z]) = &self.gyro_rad_s {
            cols.extend([(GYRO[0], x), (GYRO[1], y), (GYRO[2], z)]);
        }
        let csv_err = |source| RecordingError::Csv { path: path.into(), source };
        let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
        w.write_record(cols.iter().map(|(n, _)| *n)).map_err(csv_err)?;
        for i in 0..self.t_s.len() {
            let row = cols.iter().map(|(_, c)| c.get(i).copied().filter(|v| v.is_finite()).map_or(String::new(), |v| format!("{v}")));
            w.write_record(row).map_err(csv_err)?;
        }
        w.flush().map_err(|source| RecordingError::Io { path: path.into(), source })
    }
}
