//! Heading-only compasses (a commercial AHRS, a boat's fluxgate): the
//! recording they leave — a heading, no raw field (their calibration
//! document, only the swing: [`crate::doc::compass`]).
//!
//! A compass log (`docs/INTERFACES.md`, "Heading-only compasses") has `t`
//! and `compass_heading_deg` (the compass's magnetic heading before any
//! correction) and any of `ref_heading_deg` (true heading, or GPS course),
//! `lat_deg`, `lon_deg`, `speed_mps` (through water), `variation_deg`,
//! `course_deg`, `gps_speed_mps`. The rows need not pair up: `magcal import
//! --nmea` writes one row per sentence, the compass's rows with a heading
//! and the GPS's with a course; the heading at a reference's time is
//! interpolated.

use std::path::Path;

use super::table::{col, read_table_mapped, write_table, ColumnMap, TableError};

/// A heading-only compass's log, column by column (NaN where not available).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CompassLog {
    /// `t`, seconds (non-decreasing).
    pub t_s: Vec<f64>,
    /// `compass_heading_deg`: the compass's magnetic heading, degrees.
    pub compass_heading_deg: Vec<f64>,
    /// `ref_heading_deg`: the reference, degrees true.
    pub ref_heading_deg: Option<Vec<f64>>,
    /// `lat_deg`.
    pub lat_deg: Option<Vec<f64>>,
    /// `lon_deg`.
    pub lon_deg: Option<Vec<f64>>,
    /// `speed_mps`: speed through water, m/s.
    pub speed_mps: Option<Vec<f64>>,
    /// `variation_deg`: the variation the log states, degrees east.
    pub variation_deg: Option<Vec<f64>>,
}

/// The columns a compass log may have besides `t` and `compass_heading_deg`.
const OPTIONAL: [&str; 5] = [col::REF_HEADING_DEG, col::LAT_DEG, col::LON_DEG, col::SPEED_MPS, col::VARIATION_DEG];

impl CompassLog {
    /// Rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Reads a compass log (`t` and `compass_heading_deg` required).
    pub fn read(path: &Path) -> Result<Self, TableError> {
        Self::read_mapped(path, &ColumnMap::default())
    }

    /// [`CompassLog::read`] with the file's own names and units.
    pub fn read_mapped(path: &Path, map: &ColumnMap) -> Result<Self, TableError> {
        let file = std::fs::File::open(path).map_err(|source| TableError::Io { path: path.into(), source })?;
        Self::from_reader_mapped(file, path, map)
    }

    /// From any reader (`path` names it in errors).
    pub fn from_reader_mapped<R: std::io::Read>(reader: R, path: &Path, map: &ColumnMap) -> Result<Self, TableError> {
        let mut t = read_table_mapped(reader, path, &[col::T, col::COMPASS_HEADING_DEG], &OPTIONAL, map)?;
        Ok(Self {
            t_s: t.take(col::T).unwrap_or_default(),
            compass_heading_deg: t.take(col::COMPASS_HEADING_DEG).unwrap_or_default(),
            ref_heading_deg: t.take(col::REF_HEADING_DEG),
            lat_deg: t.take(col::LAT_DEG),
            lon_deg: t.take(col::LON_DEG),
            speed_mps: t.take(col::SPEED_MPS),
            variation_deg: t.take(col::VARIATION_DEG),
        })
    }

    /// Writes the log with the columns it has.
    pub fn write(&self, path: &Path) -> Result<(), TableError> {
        let optional = [
            (col::REF_HEADING_DEG, &self.ref_heading_deg),
            (col::LAT_DEG, &self.lat_deg),
            (col::LON_DEG, &self.lon_deg),
            (col::SPEED_MPS, &self.speed_mps),
            (col::VARIATION_DEG, &self.variation_deg),
        ];
        let present: Vec<(&str, &Vec<f64>)> = optional.iter().filter_map(|(n, c)| c.as_ref().map(|c| (*n, c))).collect();
        let mut header = vec![col::T, col::COMPASS_HEADING_DEG];
        header.extend(present.iter().map(|(n, _)| *n));
        let at = |c: &Vec<f64>, i: usize| c.get(i).copied().unwrap_or(f64::NAN);
        let rows = (0..self.len()).map(|i| [at(&self.t_s, i), at(&self.compass_heading_deg, i)].into_iter().chain(present.iter().map(|(_, c)| at(c, i))).collect());
        write_table(path, &header, rows)
    }

    /// The median of the log's stated variation, degrees east (`None`
    /// without one).
    pub fn stated_variation_deg(&self) -> Option<f64> {
        let mut v: Vec<f64> = self.variation_deg.as_ref()?.iter().copied().filter(|v| v.is_finite()).collect();
        calib_core::series::median(&mut v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_compass_log_reads_with_rows_that_do_not_pair_up() {
        let text = "t,compass_heading_deg,ref_heading_deg,variation_deg\n0.0,10.5,,\n0.5,11.0,,3.1\n1.0,,14.2,\n";
        let log = CompassLog::from_reader_mapped(text.as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap();
        assert_eq!(log.len(), 3);
        assert!(log.compass_heading_deg[2].is_nan());
        assert_eq!(log.ref_heading_deg.as_ref().unwrap()[2], 14.2);
        assert_eq!(log.stated_variation_deg(), Some(3.1));
        let e = CompassLog::from_reader_mapped("t,ref_heading_deg\n0,1\n".as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap_err();
        assert!(e.to_string().contains("compass_heading_deg"), "{e}");
        let e = CompassLog::from_reader_mapped("t,compass_heading_deg\n0,400\n".as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap_err();
        assert!(matches!(e, TableError::OutOfRange { .. }), "{e}");
    }
}
