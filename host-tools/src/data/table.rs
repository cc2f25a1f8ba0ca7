//! Tables on disk in the CSV format of `docs/INTERFACES.md`, the one
//! reader and writer of every CSV in host-tools: one header row, columns
//! found by name in any order and any case (a UTF-8 BOM ignored), extra
//! columns ignored, rows as long as the header, an empty cell or `nan`
//! meaning "not available", errors naming file, line and column; written
//! with NaN as an empty cell. The column names live in [`col`].

use std::path::{Path, PathBuf};

/// The column names of `docs/INTERFACES.md`, in one place.
pub mod col {
    /// `t`: seconds (the log's clock).
    pub const T: &str = "t";
    /// `mx`, `my`, `mz`: the raw field, sensor units.
    pub const MAG: [&str; 3] = ["mx", "my", "mz"];
    /// `roll_deg`.
    pub const ROLL_DEG: &str = "roll_deg";
    /// `pitch_deg`.
    pub const PITCH_DEG: &str = "pitch_deg";
    /// `heading_deg`: the AHRS's heading.
    pub const HEADING_DEG: &str = "heading_deg";
    /// `ref_heading_deg`: GPS course or a reference heading, true.
    pub const REF_HEADING_DEG: &str = "ref_heading_deg";
    /// `lat_deg`.
    pub const LAT_DEG: &str = "lat_deg";
    /// `lon_deg`.
    pub const LON_DEG: &str = "lon_deg";
    /// `gx`, `gy`, `gz`: the body rate, rad/s.
    pub const GYRO: [&str; 3] = ["gx", "gy", "gz"];
    /// `speed_mps`: speed through water, m/s.
    pub const SPEED_MPS: &str = "speed_mps";
    /// `motor_current_a`: thruster current, A.
    pub const MOTOR_CURRENT_A: &str = "motor_current_a";
    /// `temp_c`: temperature at the magnetometer, °C.
    pub const TEMP_C: &str = "temp_c";
    /// `health`: the board sample's health bits.
    pub const HEALTH: &str = "health";
    /// `t_board`: a merged row's time on the board's clock, s.
    pub const T_BOARD: &str = "t_board";
    /// `true_heading_deg`: a reference (or the simulator's true) heading.
    pub const TRUE_HEADING_DEG: &str = "true_heading_deg";
    /// `true_field_nt`: the simulator's true field magnitude, nT.
    pub const TRUE_FIELD_NT: &str = "true_field_nt";
}

/// Why a table (a recording, a log) could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
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

/// A field sample whose magnitude is more than this many times the
/// recording's median is refused as a glitch (the Earth's field varies by
/// 3× over the globe, a calibration's gains by far less within a recording).
pub const OUTLIER_FACTOR: f64 = 10.0;

/// Refuses a field sample more than [`OUTLIER_FACTOR`] times the median
/// magnitude, naming its row.
pub(crate) fn check_outliers(mag: &[[f64; 3]], path: &Path) -> Result<(), TableError> {
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
        Some(i) => Err(TableError::FieldOutlier { path: path.into(), row: i + 1, magnitude: norm(&mag[i]), median }),
        None => Ok(()),
    }
}

/// The largest magnitude, degrees, of an attitude or heading column.
fn angle_limit_deg(column: &str) -> Option<f64> {
    match column {
        col::ROLL_DEG => Some(180.0),
        col::PITCH_DEG => Some(90.0),
        col::REF_HEADING_DEG => Some(360.0),
        _ => None,
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

/// A value as a cell: the number, or empty when not available (NaN).
pub(crate) fn cell(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
}

/// Where column `name` is among the header's names: trimmed, any case, a
/// leading UTF-8 BOM ignored.
pub(crate) fn column_index<'h>(header: impl IntoIterator<Item = &'h str>, name: &str) -> Option<usize> {
    header.into_iter().position(|h| h.trim().trim_start_matches('\u{feff}').eq_ignore_ascii_case(name))
}

/// Columns of a CSV table, by name.
#[derive(Debug)]
pub(crate) struct Table {
    names: Vec<String>,
    columns: Vec<Option<Vec<f64>>>,
}

impl Table {
    /// Takes a column out (`None` if absent or not asked for).
    pub(crate) fn take(&mut self, name: &str) -> Option<Vec<f64>> {
        let k = self.names.iter().position(|n| n == name)?;
        self.columns[k].take()
    }
}

/// Reads the named columns of a CSV file; see [`read_table_from`].
pub(crate) fn read_table(path: &Path, required: &[&'static str], optional: &[&str]) -> Result<Table, TableError> {
    let file = std::fs::File::open(path).map_err(|source| TableError::Io { path: path.into(), source })?;
    read_table_from(file, path, required, optional)
}

/// Reads one column of a CSV file by name (any name): `Ok(None)` when the
/// header has no such column.
pub(crate) fn read_column(path: &Path, name: &str) -> Result<Option<Vec<f64>>, TableError> {
    read_table(path, &[], &[name]).map(|mut t| t.take(name))
}

/// Reads the named columns of CSV (header row, columns by name in any
/// case, rows as long as the header, empty or `nan` = absent; a `t` column
/// finite and non-decreasing). `path` names the source in errors.
pub(crate) fn read_table_from<R: std::io::Read>(reader: R, path: &Path, required: &[&'static str], optional: &[&str]) -> Result<Table, TableError> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(true).trim(csv::Trim::All).from_reader(reader);
    let csv_err = |source| TableError::Csv { path: path.into(), source };
    let header = rdr.headers().map_err(csv_err)?.clone();
    if header.is_empty() || header.iter().all(str::is_empty) {
        return Err(TableError::Empty(path.into()));
    }
    let header_list = header.iter().collect::<Vec<_>>().join(", ");
    let mut names: Vec<String> = Vec::new();
    let mut index = Vec::new();
    for &name in required {
        let i = column_index(&header, name).ok_or_else(|| TableError::MissingColumn { path: path.into(), column: name, header: header_list.clone() })?;
        names.push(name.to_string());
        index.push(Some(i));
    }
    for &name in optional {
        names.push(name.to_string());
        index.push(column_index(&header, name));
    }
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let (mut previous_t, mut rows) = (f64::NEG_INFINITY, 0usize);
    for (row, result) in rdr.records().enumerate() {
        let record = result.map_err(csv_err)?;
        let line = record.position().map(|p| p.line()).unwrap_or(row as u64 + 2);
        if record.len() != header.len() {
            return Err(TableError::Ragged { path: path.into(), line, found: record.len(), expected: header.len() });
        }
        rows += 1;
        for (k, i) in index.iter().enumerate() {
            let Some(i) = *i else { continue };
            let text = record.get(i).unwrap_or("");
            let bad = || TableError::BadNumber { path: path.into(), line, column: names[k].clone(), text: text.to_string() };
            let v = parse_cell(text).ok_or_else(bad)?;
            if names[k] == col::T {
                if !v.is_finite() {
                    return Err(bad());
                }
                if v < previous_t {
                    return Err(TableError::TimeBackwards { path: path.into(), line, t_s: v, previous_s: previous_t });
                }
                previous_t = v;
            }
            if let Some(limit_deg) = angle_limit_deg(&names[k]) {
                if v.abs() > limit_deg {
                    return Err(TableError::OutOfRange { path: path.into(), line, column: names[k].to_string(), value: v, limit_deg });
                }
            }
            columns[k].push(v);
        }
    }
    if rows == 0 && !required.is_empty() {
        return Err(TableError::NoRows(path.into()));
    }
    let columns = columns.into_iter().zip(&index).map(|(c, i)| i.map(|_| c)).collect();
    Ok(Table { names, columns })
}

/// Writes a CSV file: the header, then one row per item of `rows` (NaN as
/// an empty cell).
pub(crate) fn write_table(path: &Path, header: &[&str], rows: impl Iterator<Item = Vec<f64>>) -> Result<(), TableError> {
    let csv_err = |source| TableError::Csv { path: path.into(), source };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    w.write_record(header).map_err(csv_err)?;
    for row in rows {
        w.write_record(row.into_iter().map(cell)).map_err(csv_err)?;
    }
    w.flush().map_err(|source| TableError::Io { path: path.into(), source })
}

/// The columns of a line stream (a FIFO, stdin): the header line's
/// positions of the wanted names, then each line's values.
#[derive(Debug)]
pub(crate) struct StreamColumns {
    index: Vec<Option<usize>>,
}

impl StreamColumns {
    /// From the header line; `Err` names the first of `required` missing.
    pub(crate) fn new(header: &str, wanted: &[&str], required: usize) -> Result<Self, String> {
        let names: Vec<&str> = header.split(',').collect();
        let index: Vec<Option<usize>> = wanted.iter().map(|w| column_index(names.iter().copied(), w)).collect();
        match wanted.iter().zip(&index).take(required).find(|(_, i)| i.is_none()) {
            Some((name, _)) => Err(format!("missing column `{name}` (the header has: {header})")),
            None => Ok(Self { index }),
        }
    }

    /// The wanted columns' values on a line (NaN where absent); `None` when
    /// a cell is not a number.
    pub(crate) fn values(&self, line: &str) -> Option<Vec<f64>> {
        let cells: Vec<&str> = line.split(',').collect();
        self.index.iter().map(|i| i.and_then(|i| cells.get(i)).map_or(Some(f64::NAN), |c| parse_cell(c))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &[u8], required: &[&'static str], optional: &[&str]) -> Result<Table, TableError> {
        read_table_from(text, Path::new("x.csv"), required, optional)
    }

    /// One set of rules for every table: any case, a BOM, ragged rows and
    /// bad cells named by file and line, NaN written as an empty cell.
    #[test]
    fn the_rules_of_every_table() {
        let mut t = read("\u{feff}T,MX,Roll_Deg\n0,1,\n1,2,nan\n".as_bytes(), &["t", "mx"], &["roll_deg", "gx"]).unwrap();
        assert_eq!(t.take("mx"), Some(vec![1.0, 2.0]));
        assert!(t.take("roll_deg").unwrap().iter().all(|v| v.is_nan()));
        assert!(t.take("gx").is_none());
        let e = read(b"t,mx\n0,1\n1\n", &["t"], &[]).unwrap_err();
        assert!(matches!(e, TableError::Ragged { line: 3, found: 1, expected: 2, .. }), "{e}");
        let e = read(b"t,mx\n0,x\n", &["t", "mx"], &[]).unwrap_err();
        assert_eq!(e.to_string(), "x.csv:2: column `mx`: `x` is not a number");
        let s = StreamColumns::new("\u{feff}T , Roll_deg", &["t", "roll_deg", "gx"], 2).unwrap();
        let v = s.values("1.5,2").unwrap();
        assert!(v[0] == 1.5 && v[1] == 2.0 && v[2].is_nan());
        assert!(StreamColumns::new("t,x", &["t", "roll_deg"], 2).unwrap_err().contains("roll_deg"));
        assert_eq!((cell(f64::NAN), cell(1.25)), (String::new(), "1.25".to_string()));
    }
}
