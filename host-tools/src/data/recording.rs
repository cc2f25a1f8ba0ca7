//! Recordings in the CSV format of `docs/INTERFACES.md`: one header row,
//! columns found by name in any order, extra columns ignored, an empty cell
//! or `nan` meaning "not available".

use std::path::{Path, PathBuf};

/// Why a recording could not be read.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// The file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The file has no header row.
    #[error("{0}: empty file (expected a header row naming the columns t, mx, my, mz, ...)")]
    Empty(PathBuf),
    /// The header has no data rows after it.
    #[error("{0}: header only, no data rows")]
    NoRows(PathBuf),
    /// A required column is missing.
    #[error("{path}: missing column `{column}` (the header has: {header})")]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column needed.
        column: &'static str,
        /// The columns found.
        header: String,
    },
    /// A cell is not a number.
    #[error("{path}:{line}: column `{column}`: `{text}` is not a number")]
    BadNumber {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: String,
        /// The cell.
        text: String,
    },
    /// A row has a different number of cells than the header.
    #[error("{path}:{line}: {found} cells, the header has {expected}")]
    Ragged {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Cells in the row.
        found: usize,
        /// Cells in the header.
        expected: usize,
    },
    /// Time goes backwards.
    #[error("{path}:{line}: time goes backwards ({t_s} s after {previous_s} s); `t` must be non-decreasing")]
    TimeBackwards {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The time on that line.
        t_s: f64,
        /// The time before it.
        previous_s: f64,
    },
    /// An attitude or heading cell outside its range (roll ±180°, pitch
    /// ±90°, heading ±360°).
    #[error("{path}:{line}: column `{column}`: {value} is outside ±{limit_deg}°")]
    OutOfRange {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// Column name.
        column: String,
        /// The cell's value.
        value: f64,
        /// The limit, degrees.
        limit_deg: f64,
    },
    /// A field sample far beyond the recording's others (a glitch).
    #[error("{path}: data row {row}: |m| = {magnitude:.4e} is more than {OUTLIER_FACTOR}× the recording's median |m| {median:.4e}: a glitch; remove the row")]
    FieldOutlier {
        /// The file.
        path: PathBuf,
        /// 1-based data row (the header not counted).
        row: usize,
        /// Its magnitude, raw units.
        magnitude: f64,
        /// The median magnitude, raw units.
        median: f64,
    },
    /// Malformed CSV (quoting, encoding).
    #[error("{path}: {source}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        #[source]
        source: csv::Error,
    },
}

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
        let file = std::fs::File::open(path).map_err(|source| RecordingError::Io { path: path.into(), source })?;
        Self::from_reader(file, path)
    }

    /// Reads CSV from any reader (`path` names it in errors).
    pub fn from_reader<R: std::io::Read>(reader: R, path: &Path) -> Result<Self, RecordingError> {
        let mut t = read_table_from(reader, path, &["mx", "my", "mz"], &["t", "roll_deg", "pitch_deg", "ref_heading_deg", "lat_deg", "lon_deg", "gx", "gy", "gz", "speed_mps", "motor_current_a", "temp_c"])?;
        let (mx, my, mz) = (t.take("mx").unwrap_or_default(), t.take("my").unwrap_or_default(), t.take("mz").unwrap_or_default());
        let mag: Vec<[f64; 3]> = mx.into_iter().zip(my).zip(mz).map(|((x, y), z)| [x, y, z]).collect();
        check_outliers(&mag, path)?;
        Ok(Recording {
            mag,
            t_s: t.take("t"),
            roll_deg: t.take("roll_deg"),
            pitch_deg: t.take("pitch_deg"),
            ref_heading_deg: t.take("ref_heading_deg"),
            lat_deg: t.take("lat_deg"),
            lon_deg: t.take("lon_deg"),
            gx_rad_s: t.take("gx"),
            gy_rad_s: t.take("gy"),
            gz_rad_s: t.take("gz"),
            speed_mps: t.take("speed_mps"),
            motor_current_a: t.take("motor_current_a"),
            temp_c: t.take("temp_c"),
        })
    }

    /// Writes the recording as CSV with the columns it has.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        self.write_with_extra(path, &[])
    }

    /// Writes the recording plus extra named columns (which readers ignore),
    /// e.g. the simulator's truth.
    pub fn write_with_extra(&self, path: &Path, extra: &[(&str, &Vec<f64>)]) -> Result<(), RecordingError> {
        let io = |source| RecordingError::Io { path: path.into(), source };
        let mut w = csv::Writer::from_path(path).map_err(|source| RecordingError::Csv { path: path.into(), source })?;
        let mut cols: Vec<(&str, &Vec<f64>)> = [
            ("t", &self.t_s),
            ("roll_deg", &self.roll_deg),
            ("pitch_deg", &self.pitch_deg),
            ("ref_heading_deg", &self.ref_heading_deg),
            ("lat_deg", &self.lat_deg),
            ("lon_deg", &self.lon_deg),
            ("gx", &self.gx_rad_s),
            ("gy", &self.gy_rad_s),
            ("gz", &self.gz_rad_s),
            ("speed_mps", &self.speed_mps),
            ("motor_current_a", &self.motor_current_a),
            ("temp_c", &self.temp_c),
        ]
        .into_iter()
        .filter_map(|(n, c)| c.as_ref().map(|c| (n, c)))
        .collect();
        cols.extend(extra.iter().copied());
        let mut header: Vec<&str> = vec!["mx", "my", "mz"];
        header.splice(0..0, cols.iter().filter(|(n, _)| *n == "t").map(|(n, _)| *n));
        header.extend(cols.iter().filter(|(n, _)| *n != "t").map(|(n, _)| *n));
        w.write_record(&header).map_err(|source| RecordingError::Csv { path: path.into(), source })?;
        for (i, m) in self.mag.iter().enumerate() {
            let mut row: Vec<String> = Vec::with_capacity(header.len());
            for name in &header {
                let v = match *name {
                    "mx" => m[0],
                    "my" => m[1],
                    "mz" => m[2],
                    other => cols.iter().find(|(n, _)| *n == other).and_then(|(_, c)| c.get(i).copied()).unwrap_or(f64::NAN),
                };
                row.push(if v.is_finite() { format!("{v}") } else { String::new() });
            }
            w.write_record(&row).map_err(|source| RecordingError::Csv { path: path.into(), source })?;
        }
        w.flush().map_err(io)?;
        Ok(())
    }
}

/// A cell: a number, or empty/`nan` for "not available". `None` if neither.
pub(crate) fn parse_cell(text: &str) -> Option<f64> {
    let t = text.trim();
    if t.is_empty() || t.eq_ignore_ascii_case("nan") {
        return Some(f64::NAN);
    }
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Some(v),
        _ => None,
    }
}

/// Columns of a CSV log, by name.
pub(crate) struct Table {
    names: Vec<&'static str>,
    columns: Vec<Option<Vec<f64>>>,
}

impl Table {
    /// Takes a column out (`None` if absent or not asked for).
    pub(crate) fn take(&mut self, name: &str) -> Option<Vec<f64>> {
        let k = self.names.iter().position(|n| *n == name)?;
        self.columns[k].take()
    }
}

/// Reads the named columns of a CSV log file; see [`read_table_from`].
/// A field sample whose magnitude is more than this many times the
/// recording's median is refused as a glitch (the Earth's field varies by
/// 3× over the globe, a calibration's gains by far less within a recording).
pub const OUTLIER_FACTOR: f64 = 10.0;

/// Refuses a field sample more than [`OUTLIER_FACTOR`] times the median
/// magnitude, naming its row.
fn check_outliers(mag: &[[f64; 3]], path: &Path) -> Result<(), RecordingError> {
    let norm = |m: &[f64; 3]| (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
    let mut sorted: Vec<f64> = mag.iter().map(norm).filter(|n| n.is_finite()).collect();
    if sorted.is_empty() {
        return Ok(());
    }
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    if !(median > 0.0) {
        return Ok(());
    }
    match mag.iter().position(|m| norm(m) > OUTLIER_FACTOR * median) {
        Some(i) => Err(RecordingError::FieldOutlier { path: path.into(), row: i + 1, magnitude: norm(&mag[i]), median }),
        None => Ok(()),
    }
}

/// The largest magnitude, degrees, of an attitude or heading column.
fn angle_limit_deg(column: &str) -> Option<f64> {
    match column {
        "roll_deg" => Some(180.0),
        "pitch_deg" => Some(90.0),
        "ref_heading_deg" => Some(360.0),
        _ => None,
    }
}

pub(crate) fn read_table(path: &Path, required: &[&'static str], optional: &[&'static str]) -> Result<Table, RecordingError> {
    let file = std::fs::File::open(path).map_err(|source| RecordingError::Io { path: path.into(), source })?;
    read_table_from(file, path, required, optional)
}

/// Reads the named columns of CSV (the recording format's rules: header
/// row, columns by name, empty or `nan` = absent; a `t` column finite and
/// non-decreasing). `path` names the source in errors; the first required
/// column decides whether there are rows.
pub(crate) fn read_table_from<R: std::io::Read>(reader: R, path: &Path, required: &[&'static str], optional: &[&'static str]) -> Result<Table, RecordingError> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(true).trim(csv::Trim::All).from_reader(reader);
    let csv_err = |source| RecordingError::Csv { path: path.into(), source };
    let header = rdr.headers().map_err(csv_err)?.clone();
    if header.is_empty() || header.iter().all(str::is_empty) {
        return Err(RecordingError::Empty(path.into()));
    }
    let header_list = header.iter().collect::<Vec<_>>().join(", ");
    let col = |name: &str| header.iter().position(|h| h.eq_ignore_ascii_case(name));
    let mut names = Vec::new();
    let mut index = Vec::new();
    for &name in required {
        let i = col(name).ok_or_else(|| RecordingError::MissingColumn { path: path.into(), column: name, header: header_list.clone() })?;
        names.push(name);
        index.push(Some(i));
    }
    for &name in optional {
        names.push(name);
        index.push(col(name));
    }
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut previous_t = f64::NEG_INFINITY;
    for (row, result) in rdr.records().enumerate() {
        let record = result.map_err(csv_err)?;
        let line = record.position().map(|p| p.line()).unwrap_or(row as u64 + 2);
        if record.len() != header.len() {
            return Err(RecordingError::Ragged { path: path.into(), line, found: record.len(), expected: header.len() });
        }
        for (k, i) in index.iter().enumerate() {
            let Some(i) = *i else { continue };
            let text = record.get(i).unwrap_or("");
            let bad = || RecordingError::BadNumber { path: path.into(), line, column: names[k].to_string(), text: text.to_string() };
            let v = parse_cell(text).ok_or_else(bad)?;
            if names[k] == "t" {
                if !v.is_finite() {
                    return Err(bad());
                }
                if v < previous_t {
                    return Err(RecordingError::TimeBackwards { path: path.into(), line, t_s: v, previous_s: previous_t });
                }
                previous_t = v;
            }
            if let Some(limit_deg) = angle_limit_deg(names[k]) {
                if v.abs() > limit_deg {
                    return Err(RecordingError::OutOfRange { path: path.into(), line, column: names[k].to_string(), value: v, limit_deg });
                }
            }
            columns[k].push(v);
        }
    }
    if columns[0].is_empty() {
        return Err(RecordingError::NoRows(path.into()));
    }
    let columns = columns.into_iter().zip(&index).map(|(c, i)| i.map(|_| c)).collect();
    Ok(Table { names, columns })
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
        // Issue 24: one roll of 999° (or 1e300) in a run silently worsened
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
