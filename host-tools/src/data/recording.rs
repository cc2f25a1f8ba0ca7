//! Recordings in the CSV format of `docs/INTERFACES.md`: one header row,
//! columns found by name in any order, extra columns ignored, an empty cell
//! or `nan` meaning "not available".

use std::path::Path;

pub use super::table::TableError as RecordingError;
use super::table::{col, column_set, present_columns, read_table_mapped, take_columns, write_table, ColumnMap, ColumnSet};

/// A recording, column by column (NaN where not available).
#[derive(Debug, Clone, Default)]
pub struct Recording {
    /// `t`, seconds (NaN-free and non-decreasing when present).
    pub t_s: Option<Vec<f64>>,
    /// `mx, my, mz`, raw sensor units.
    pub mag: Vec<[f64; 3]>,
    /// `roll_deg`.
    pub roll_deg: Option<Vec<f64>>,
    /// `pitch_deg`.
    pub pitch_deg: Option<Vec<f64>>,
    /// `ref_heading_deg`, true.
    pub ref_heading_deg: Option<Vec<f64>>,
    /// `lat_deg`.
    pub lat_deg: Option<Vec<f64>>,
    /// `lon_deg`.
    pub lon_deg: Option<Vec<f64>>,
    /// `gx`, rad/s (body x rate from the gyro).
    pub gx_rad_s: Option<Vec<f64>>,
    /// `gy`, rad/s.
    pub gy_rad_s: Option<Vec<f64>>,
    /// `gz`, rad/s.
    pub gz_rad_s: Option<Vec<f64>>,
    /// `speed_mps`: speed through water (DVL water track or propeller model), m/s.
    pub speed_mps: Option<Vec<f64>>,
    /// `motor_current_a`: thruster current that disturbs the magnetometer, A
    /// (0 with the thrusters off).
    pub motor_current_a: Option<Vec<f64>>,
    /// `temp_c`: temperature at the magnetometer, °C.
    pub temp_c: Option<Vec<f64>>,
}

// The recording's columns by their registry names (`mx, my, mz` are `mag`).
column_set!(Recording {
    required: [],
    optional: [
        col::T => t_s,
        col::ROLL_DEG => roll_deg,
        col::PITCH_DEG => pitch_deg,
        col::REF_HEADING_DEG => ref_heading_deg,
        col::LAT_DEG => lat_deg,
        col::LON_DEG => lon_deg,
        col::GYRO[0] => gx_rad_s,
        col::GYRO[1] => gy_rad_s,
        col::GYRO[2] => gz_rad_s,
        col::SPEED_MPS => speed_mps,
        col::MOTOR_CURRENT_A => motor_current_a,
        col::TEMP_C => temp_c,
    ]
});

impl Recording {
    /// Rows in the recording.
    pub fn len(&self) -> usize {
        self.mag.len()
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.mag.is_empty()
    }

    /// The magnetometer samples whose three components are all present,
    /// with their row indices.
    pub fn complete_mag(&self) -> (Vec<usize>, Vec<[f64; 3]>) {
        self.mag.iter().enumerate().filter(|(_, m)| m.iter().all(|v| v.is_finite())).map(|(i, m)| (i, *m)).unzip()
    }

    /// The gyro's three columns, when the recording has all of them.
    pub fn gyro_rad_s(&self) -> Option<Vec<[f64; 3]>> {
        let (x, y, z) = (self.gx_rad_s.as_ref()?, self.gy_rad_s.as_ref()?, self.gz_rad_s.as_ref()?);
        Some(x.iter().zip(y).zip(z).map(|((&a, &b), &c)| [a, b, c]).collect())
    }

    /// Reads a CSV recording. `mx, my, mz` are required; the rest optional.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        Self::read_mapped(path, &ColumnMap::default())
    }

    /// Reads a recording whose columns have the file's own names and units
    /// (`map`; the separator comma, semicolon, tab or spaces as for every
    /// recording).
    pub fn read_mapped(path: &Path, map: &ColumnMap) -> Result<Self, RecordingError> {
        let file = std::fs::File::open(path).map_err(|source| RecordingError::Io { path: path.into(), source })?;
        Self::from_reader_mapped(file, path, map)
    }

    /// Reads CSV from any reader (`path` names it in errors).
    pub fn from_reader<R: std::io::Read>(reader: R, path: &Path) -> Result<Self, RecordingError> {
        Self::from_reader_mapped(reader, path, &ColumnMap::default())
    }

    /// [`Recording::from_reader`] with the file's names and units of `map`.
    pub fn from_reader_mapped<R: std::io::Read>(reader: R, path: &Path, map: &ColumnMap) -> Result<Self, RecordingError> {
        let mut t = read_table_mapped(reader, path, &col::MAG, Self::NAMES, map)?;
        let [mx, my, mz] = col::MAG.map(|c| t.take(c).unwrap_or_default());
        let mag: Vec<[f64; 3]> = mx.into_iter().zip(my).zip(mz).map(|((x, y), z)| [x, y, z]).collect();
        super::table::check_outliers(&mag, path)?;
        let mut rec = Recording { mag, ..Recording::default() };
        take_columns(&mut rec, &mut t);
        Ok(rec)
    }

    /// Writes the recording as CSV with the columns it has.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        self.write_with_extra(path, &[])
    }

    /// Writes the recording plus extra named columns (which readers ignore),
    /// e.g. the simulator's truth: `t` first, then `mx, my, mz`, then the
    /// rest.
    pub fn write_with_extra(&self, path: &Path, extra: &[(&str, &[f64])]) -> Result<(), RecordingError> {
        use col::*;
        let mut cols: Vec<(&str, &[f64])> = present_columns(self).into_iter().filter(|(n, _)| *n != T).collect();
        cols.extend(extra.iter().copied().filter(|(n, _)| *n != T));
        let t = self.t_s.as_deref().or_else(|| extra.iter().find(|(n, _)| *n == T).map(|(_, c)| *c));
        let mut header: Vec<&str> = t.map(|_| T).into_iter().collect();
        header.extend(MAG);
        header.extend(cols.iter().map(|(n, _)| *n));
        let at = |c: &[f64], i: usize| c.get(i).copied().unwrap_or(f64::NAN);
        let rows = self.mag.iter().enumerate().map(|(i, m)| t.map(|t| at(t, i)).into_iter().chain(*m).chain(cols.iter().map(|(_, c)| at(c, i))).collect());
        write_table(path, &header, rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<Recording, RecordingError> {
        Recording::from_reader(text.as_bytes(), Path::new("rec.csv"))
    }

    #[test]
    fn columns_are_found_by_name_in_any_order() {
        let r = read("extra,mz,t,my,mx,roll_deg\n1,3.5,0.0,2,1,10\nx,6,0.1,,4,nan\n").unwrap();
        assert_eq!(r.len(), 2);
        assert_eq!(r.mag[0], [1.0, 2.0, 3.5]);
        assert!(r.mag[1][1].is_nan());
        assert_eq!(r.t_s.as_deref(), Some(&[0.0, 0.1][..]));
        assert!(r.roll_deg.as_ref().unwrap()[1].is_nan());
        assert!(r.pitch_deg.is_none());
        assert_eq!(r.complete_mag().0, vec![0]);
    }

    #[test]
    fn each_kind_of_bad_file_has_its_own_message() {
        assert!(matches!(read(""), Err(RecordingError::Empty(_))));
        assert!(matches!(read("mx,my,mz\n"), Err(RecordingError::NoRows(_))));
        let e = read("mx,my\n1,2\n").unwrap_err();
        assert!(matches!(e, RecordingError::MissingColumn { column: "mz", .. }));
        assert!(e.to_string().contains("the header has: mx, my"), "{e}");
        let e = read("mx,my,mz\n1,2,abc\n").unwrap_err();
        assert_eq!(e.to_string(), "rec.csv:2: column `mz`: `abc` is not a number");
        assert!(matches!(read("mx,my,mz\n1,2,inf\n"), Err(RecordingError::BadNumber { .. })));
        assert!(matches!(read("mx,my,mz\n1,2\n"), Err(RecordingError::Ragged { line: 2, .. })));
        let e = read("t,mx,my,mz\n1.0,1,2,3\n0.5,1,2,3\n").unwrap_err();
        assert!(matches!(e, RecordingError::TimeBackwards { line: 3, .. }), "{e}");
    }

    #[test]
    fn impossible_attitudes_and_glitches_are_refused_by_row() {
        // One roll of 999° (or 1e300) in a run once silently worsened
        // the heading from 0.23° to 0.74° (2.2°).
        let e = read("mx,my,mz,roll_deg,pitch_deg\n1,2,3,10,5\n1,2,3,999,5\n").unwrap_err();
        assert_eq!(e.to_string(), "rec.csv:3: column `roll_deg`: 999 is outside ±180°");
        let e = read("mx,my,mz,roll_deg,pitch_deg\n1,2,3,1e300,5\n").unwrap_err();
        assert!(matches!(e, RecordingError::OutOfRange { line: 2, .. }), "{e}");
        assert!(matches!(read("mx,my,mz,pitch_deg\n1,2,3,-90.5\n").unwrap_err(), RecordingError::OutOfRange { .. }));
        assert!(matches!(read("mx,my,mz,ref_heading_deg\n1,2,3,1e300\n").unwrap_err(), RecordingError::OutOfRange { .. }));
        // At the limits, and absent: read.
        let r = read("mx,my,mz,roll_deg,pitch_deg,ref_heading_deg\n1,2,3,-180,90,359.9\n1,2,3,,nan,\n").unwrap();
        assert_eq!(r.roll_deg.unwrap()[0], -180.0);
        // One mx = 1e7 among samples of |m| ≈ 480: named by its row.
        let mut text = String::from("mx,my,mz\n");
        for k in 0..50 {
            text += &if k == 17 { "1e7,0,0\n".to_string() } else { format!("{},{},300\n", 300.0 + k as f64, -200.0) };
        }
        let e = read(&text).unwrap_err();
        assert!(matches!(e, RecordingError::FieldOutlier { row: 18, .. }), "{e}");
        assert!(e.to_string().contains("data row 18"), "{e}");
    }

    #[test]
    fn write_then_read_round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("r.csv");
        let rec = Recording {
            t_s: Some(vec![0.0, 0.5]),
            mag: vec![[1.5, -2.0, 3.25], [f64::NAN, 1.0, 2.0]],
            roll_deg: Some(vec![1.0, 2.0]),
            ref_heading_deg: Some(vec![f64::NAN, 90.0]),
            ..Recording::default()
        };
        rec.write(&p).unwrap();
        let back = Recording::read(&p).unwrap();
        assert_eq!(back.mag[0], rec.mag[0]);
        assert!(back.mag[1][0].is_nan());
        assert_eq!(back.t_s, rec.t_s);
        assert_eq!(back.roll_deg, rec.roll_deg);
        assert!(back.ref_heading_deg.unwrap()[0].is_nan());
    }
}
