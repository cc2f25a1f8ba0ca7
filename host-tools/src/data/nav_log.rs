//! The navigation computer's log (`docs/INTERFACES.md`, "Navigation log"):
//! attitude, GPS and the rest on the navigation clock, `magcal merge`'s
//! second input. The one home of its columns.

use std::path::Path;

use super::recording::RecordingError;
use super::table::{col, column_set, present_columns, read_table_mapped, take_columns, write_table, ColumnMap, ColumnSet, TableError};

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
    /// `gx`: the body x rate, rad/s.
    pub gx_rad_s: Option<Vec<f64>>,
    /// `gy`, rad/s.
    pub gy_rad_s: Option<Vec<f64>>,
    /// `gz`, rad/s.
    pub gz_rad_s: Option<Vec<f64>>,
    /// `speed_mps`.
    pub speed_mps: Option<Vec<f64>>,
    /// `motor_current_a`.
    pub motor_current_a: Option<Vec<f64>>,
}

// The navigation log's columns by their registry names.
column_set!(NavLog {
    required: [T => t_s, ROLL_DEG => roll_deg, PITCH_DEG => pitch_deg],
    optional: [
        HEADING_DEG => heading_deg,
        REF_HEADING_DEG => ref_heading_deg,
        LAT_DEG => lat_deg,
        LON_DEG => lon_deg,
        GYRO[0] => gx_rad_s,
        GYRO[1] => gy_rad_s,
        GYRO[2] => gz_rad_s,
        SPEED_MPS => speed_mps,
        MOTOR_CURRENT_A => motor_current_a,
    ]
});

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
        const REQUIRED: [&str; 3] = [T, ROLL_DEG, PITCH_DEG];
        let file = std::fs::File::open(path).map_err(|source| TableError::Io { path: path.into(), source })?;
        let mut t = read_table_mapped(file, path, &REQUIRED, Self::NAMES.get(REQUIRED.len()..).unwrap_or_default(), map)?;
        let mut log = Self { t_s: t.take(T).unwrap_or_default(), roll_deg: t.take(ROLL_DEG).unwrap_or_default(), pitch_deg: t.take(PITCH_DEG).unwrap_or_default(), ..Self::default() };
        take_columns(&mut log, &mut t);
        // The body rate is used only whole.
        if log.gx_rad_s.is_none() || log.gy_rad_s.is_none() || log.gz_rad_s.is_none() {
            (log.gx_rad_s, log.gy_rad_s, log.gz_rad_s) = (None, None, None);
        }
        Ok(log)
    }

    /// The body rate's three columns, when the log has them.
    pub fn gyro_rad_s(&self) -> Option<[&[f64]; 3]> {
        Some([self.gx_rad_s.as_deref()?, self.gy_rad_s.as_deref()?, self.gz_rad_s.as_deref()?])
    }

    /// Writes the log in the columns [`NavLog::read`] reads.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let cols = present_columns(self);
        let header: Vec<&str> = cols.iter().map(|(n, _)| *n).collect();
        let rows = (0..self.t_s.len()).map(|i| cols.iter().map(|(_, c)| c.get(i).copied().unwrap_or(f64::NAN)).collect());
        write_table(path, &header, rows)
    }
}
