//! The navigation computer's log (`docs/INTERFACES.md`, "Navigation log"):
//! attitude, GPS and the rest on the navigation clock, `magcal merge`'s
//! second input. The one home of its columns.

use std::path::Path;

use super::recording::RecordingError;
use super::table::{col, read_table_mapped, write_table, ColumnMap, TableError};

/// `t`: seconds on the navigation clock.
pub const T: &str = col::T;
/// `roll_deg`.
pub const ROLL_DEG: &str = col::ROLL_DEG;
/// `pitch_deg`.
pub const PITCH_DEG: &str = col::PITCH_DEG;
/// `heading_deg`: the AHRS's heading.
pub const HEADING_DEG: &str = col::HEADING_DEG;
/// `ref_heading_deg`: GPS course or a reference heading.
pub const REF_HEADING_DEG: &str = col::REF_HEADING_DEG;
/// `lat_deg`.
pub const LAT_DEG: &str = col::LAT_DEG;
/// `lon_deg`.
pub const LON_DEG: &str = col::LON_DEG;
/// `gx`, `gy`, `gz`: the body rate, rad/s.
pub const GYRO: [&str; 3] = col::GYRO;
/// `speed_mps`.
pub const SPEED_MPS: &str = col::SPEED_MPS;
/// `motor_current_a`.
pub const MOTOR_CURRENT_A: &str = col::MOTOR_CURRENT_A;

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
        Self::read_mapped(path, &ColumnMap::default())
    }

    /// [`NavLog::read`] of a log under its own column names and units
    /// (`--nav-columns`: a navigation computer's or another tool's export),
    /// cells separated by comma, semicolon, tab or spaces.
    pub fn read_mapped(path: &Path, map: &ColumnMap) -> Result<Self, RecordingError> {
        let optional = [HEADING_DEG, REF_HEADING_DEG, LAT_DEG, LON_DEG, GYRO[0], GYRO[1], GYRO[2], SPEED_MPS, MOTOR_CURRENT_A];
        let file = std::fs::File::open(path).map_err(|source| TableError::Io { path: path.into(), source })?;
        let mut t = read_table_mapped(file, path, &[T, ROLL_DEG, PITCH_DEG], &optional, map)?;
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
        let header: Vec<&str> = cols.iter().map(|(n, _)| *n).collect();
        let rows = (0..self.t_s.len()).map(|i| cols.iter().map(|(_, c)| c.get(i).copied().unwrap_or(f64::NAN)).collect());
        write_table(path, &header, rows)
    }
}
