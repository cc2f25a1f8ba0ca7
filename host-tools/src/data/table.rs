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
    /// `compass_heading_deg`: a heading-only compass's magnetic heading as
    /// the compass gives it (its own deviation not applied), degrees.
    pub const COMPASS_HEADING_DEG: &str = "compass_heading_deg";
    /// `variation_deg`: the magnetic variation (declination) a log states,
    /// degrees, east positive.
    pub const VARIATION_DEG: &str = "variation_deg";
    /// `course_deg`: GPS course over ground, true, degrees.
    pub const COURSE_DEG: &str = "course_deg";
    /// `gps_speed_mps`: GPS speed over ground, m/s.
    pub const GPS_SPEED_MPS: &str = "gps_speed_mps";
    /// `ahrs_yaw_deg`: the vehicle's own heading estimate (an autopilot's
    /// yaw, from its compasses: never a reference), degrees.
    pub const AHRS_YAW_DEG: &str = "ahrs_yaw_deg";
}

/// What a column measures: the unit a mapping may give it, and how it is
/// interpolated between two rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// The magnetic field (nT, µT, gauss, mG, counts).
    Field,
    /// An attitude, heading, course or position angle (deg, rad).
    Angle,
    /// A heading or course: an angle interpolated the short way round 360°.
    Heading,
    /// A body rate (rad/s, deg/s).
    Rate,
    /// A time (s, ms, µs).
    Time,
    /// Anything else, in its one unit (m/s, A, °C, nT of a truth column, a
    /// health word): no unit may be given.
    Other,
}

/// How a column is carried between two clocks (`magcal merge` resampling a
/// navigation-log column to a board sample's time).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interp {
    /// Linearly.
    Linear,
    /// An angle on ±180° (roll), the short way round.
    Angle180,
    /// A heading or course on 0–360°, the short way round.
    Heading360,
}

/// Which logs hold a column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Logs {
    /// A recording ([`crate::data::Recording`]: the calibration's input).
    pub recording: bool,
    /// A navigation log ([`crate::data::NavLog`]); with `recording` too,
    /// `magcal merge` resamples it into the merged recording.
    pub nav: bool,
    /// A board log ([`crate::data::board_log::BoardLog`]: what `magcal log`
    /// writes and `merge` reads).
    pub board: bool,
}

/// One column of the project: its name, what it measures, the largest
/// magnitude it may hold (angles, degrees), the logs that hold it and how it
/// is resampled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    /// The name in the header.
    pub name: &'static str,
    /// What it measures.
    pub quantity: Quantity,
    /// Values beyond ± this are refused by row (angles), degrees.
    pub limit_deg: Option<f64>,
    /// The logs whose type holds it.
    pub logs: Logs,
    /// How it is resampled to another clock.
    pub interp: Interp,
}

const fn column(name: &'static str, quantity: Quantity, limit_deg: Option<f64>, logs: Logs, interp: Interp) -> Column {
    Column { name, quantity, limit_deg, logs, interp }
}

/// In a navigation log only.
const NAV: Logs = Logs { recording: false, nav: true, board: false };
/// In a recording and a navigation log: merged from the navigation log
/// into the recording.
const BOTH: Logs = Logs { recording: true, nav: true, board: false };
/// In a recording and the board log (the board's own measurements).
const REC_BOARD: Logs = Logs { recording: true, nav: false, board: true };
/// In the board log only.
const BOARD: Logs = Logs { recording: false, nav: false, board: true };
/// In every log (the time, each on its own clock).
const ALL: Logs = Logs { recording: true, nav: true, board: true };
/// In none of the types (a truth, a compass log's or an output column).
const OTHER: Logs = Logs { recording: false, nav: false, board: false };

/// Every column a recording, a navigation log or a board log may hold: the
/// one list that the column mapping (`--columns`), the unit conversions, the
/// range checks, the recording's and navigation log's readers and writers,
/// and `merge`'s resampling read. A new column is one line here and its
/// field in the type that holds it ([`crate::data::Recording`],
/// [`crate::data::NavLog`], [`crate::data::board_log::BoardLog`]: one line
/// of their column list each).
pub const COLUMNS: [Column; 25] = {
    use col::*;
    use Interp::*;
    use Quantity::*;
    [
        column(T, Time, None, ALL, Linear),
        column(MAG[0], Field, None, REC_BOARD, Linear),
        column(MAG[1], Field, None, REC_BOARD, Linear),
        column(MAG[2], Field, None, REC_BOARD, Linear),
        column(ROLL_DEG, Angle, Some(180.0), BOTH, Angle180),
        column(PITCH_DEG, Angle, Some(90.0), BOTH, Linear),
        column(HEADING_DEG, Heading, None, NAV, Heading360),
        column(REF_HEADING_DEG, Heading, Some(360.0), BOTH, Heading360),
        column(LAT_DEG, Angle, None, BOTH, Linear),
        column(LON_DEG, Angle, None, BOTH, Linear),
        column(GYRO[0], Rate, None, BOTH, Linear),
        column(GYRO[1], Rate, None, BOTH, Linear),
        column(GYRO[2], Rate, None, BOTH, Linear),
        column(SPEED_MPS, Other, None, BOTH, Linear),
        column(MOTOR_CURRENT_A, Other, None, BOTH, Linear),
        column(TEMP_C, Other, None, REC_BOARD, Linear),
        column(HEALTH, Other, None, BOARD, Linear),
        column(T_BOARD, Time, None, OTHER, Linear),
        column(TRUE_HEADING_DEG, Heading, None, OTHER, Heading360),
        column(TRUE_FIELD_NT, Other, None, OTHER, Linear),
        column(COMPASS_HEADING_DEG, Heading, Some(360.0), OTHER, Heading360),
        column(VARIATION_DEG, Angle, Some(180.0), OTHER, Linear),
        column(COURSE_DEG, Heading, Some(360.0), OTHER, Heading360),
        column(GPS_SPEED_MPS, Other, None, OTHER, Linear),
        column(AHRS_YAW_DEG, Heading, Some(360.0), OTHER, Heading360),
    ]
};

/// The columns `magcal merge` carries from the navigation log into the
/// recording (in both logs), but the time.
pub fn merged_columns() -> impl Iterator<Item = &'static Column> {
    COLUMNS.iter().filter(|c| c.logs.recording && c.logs.nav && c.name != col::T)
}

/// A log type whose columns are reached by their registry name. Implemented
/// by [`column_set!`] from the one list of (name, field) pairs beside the
/// type's definition; the registry test checks each pair against
/// [`COLUMNS`]' `logs`.
pub trait ColumnSet {
    /// The names of the type's columns, required then optional.
    const NAMES: &'static [&'static str];
    /// The column named `name`, when the type holds it and it is present.
    fn column(&self, name: &str) -> Option<&[f64]>;
    /// The slot of an optional column named `name`, when the type holds one.
    fn column_slot(&mut self, name: &str) -> Option<&mut Option<Vec<f64>>>;
}

/// Fills each optional column of `log` that `table` has, by name.
pub(crate) fn take_columns<C: ColumnSet>(log: &mut C, table: &mut Table) {
    for name in C::NAMES {
        if let Some(slot) = log.column_slot(name) {
            *slot = table.take(name);
        }
    }
}

/// The columns `log` has, by name, in its list's order (what its writer
/// writes).
pub(crate) fn present_columns<C: ColumnSet>(log: &C) -> Vec<(&'static str, &[f64])> {
    C::NAMES.iter().filter_map(|&n| log.column(n).map(|c| (n, c))).collect()
}

/// Implements [`ColumnSet`] from `required: NAME => field, …; optional:
/// NAME => field, …` (`Vec<f64>` and `Option<Vec<f64>>` fields).
macro_rules! column_set {
    ($ty:ty { required: [$($rn:expr => $rf:ident),* $(,)?], optional: [$($on:expr => $of:ident),* $(,)?] }) => {
        impl $crate::data::table::ColumnSet for $ty {
            const NAMES: &'static [&'static str] = &[$($rn,)* $($on,)*];
            fn column(&self, name: &str) -> Option<&[f64]> {
                $(if name == $rn { return Some(&self.$rf); })*
                $(if name == $on { return self.$of.as_deref(); })*
                None
            }
            fn column_slot(&mut self, name: &str) -> Option<&mut Option<Vec<f64>>> {
                $(if name == $on { return Some(&mut self.$of); })*
                None
            }
        }
    };
}
pub(crate) use column_set;

/// A project column by name.
pub fn column_spec(name: &str) -> Option<&'static Column> {
    COLUMNS.iter().find(|c| c.name == name)
}

/// Why a table (a recording, a log) could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
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
    #[error("{path}: missing column `{column}` (the header has: {header}){hint}")]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The column needed.
        column: &'static str,
        /// The columns found.
        header: String,
        /// For the field's columns: the mapping the header's names suggest
        /// (`; ... give the column mapping mx=...`), else empty.
        hint: String,
    },
    /// A column mapping names a column the header does not have.
    #[error("{path}: the column mapping gives `{column}` as `{name}`, which the header does not have (the header has: {header})")]
    MappedColumnMissing {
        /// The file.
        path: PathBuf,
        /// The project's column.
        column: String,
        /// The file's name the mapping gives.
        name: String,
        /// The columns found.
        header: String,
    },
    /// A column read appears more than once in the header.
    #[error("{path}: the header has `{name}` {times} times: which one is `{column}`? (rename or remove the others)")]
    DuplicateColumn {
        /// The file.
        path: PathBuf,
        /// The project's column.
        column: String,
        /// The file's name for it.
        name: String,
        /// How many times the header has it.
        times: usize,
    },
    /// Two of the project's columns would be read from one cell of the
    /// header (a mapping naming a column the header also holds under the
    /// project's name, or two columns mapped to one name).
    #[error("{path}: `{first}` and `{second}` would both be read from the header's `{name}`: each column needs its own")]
    SharedColumn {
        /// The file.
        path: PathBuf,
        /// The first project column.
        first: String,
        /// The second.
        second: String,
        /// The header's cell.
        name: String,
    },
    /// The header line holds more than one of comma, semicolon and tab.
    #[error("{path}: the header line `{header}` has more than one of comma, semicolon and tab: which separates the cells?")]
    AmbiguousSeparator {
        /// The file.
        path: PathBuf,
        /// The header line.
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
    column_spec(column).and_then(|c| c.limit_deg)
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

/// A unit a mapped column is given in (`--columns mx=NAME:uT`), converted
/// on reading to the project's: the field to nT, angles to degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ColumnUnit {
    /// Nanotesla.
    Nanotesla,
    /// Microtesla (`uT` or `µT`).
    Microtesla,
    /// Gauss (1 G = 100 000 nT).
    Gauss,
    /// Milligauss (1 mG = 100 nT).
    Milligauss,
    /// Raw sensor counts: kept as they are.
    Counts,
    /// Degrees.
    Degrees,
    /// Radians.
    Radians,
    /// Radians per second (a gyro's rate).
    RadiansPerSecond,
    /// Degrees per second.
    DegreesPerSecond,
    /// Seconds (a time column).
    Seconds,
    /// Milliseconds.
    Milliseconds,
    /// Microseconds (e.g. ArduPilot's `TimeUS`).
    Microseconds,
}

/// What a unit measures: it fits only columns of the same kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum UnitKind {
    Field,
    Angle,
    Rate,
    Time,
}

/// The units a mapping may name, as written.
pub const COLUMN_UNITS: &str = "nT, uT, µT, gauss, mG, counts (field); deg, rad (angles); rad/s, deg/s (gx, gy, gz); s, ms, us (t, t_board)";

impl ColumnUnit {
    /// From its name (any case): `None` when unknown.
    fn parse(text: &str) -> Option<Self> {
        Some(match text.trim().to_ascii_lowercase().as_str() {
            "nt" => Self::Nanotesla,
            "ut" | "µt" | "μt" => Self::Microtesla,
            "g" | "gauss" => Self::Gauss,
            "mg" | "mgauss" | "milligauss" => Self::Milligauss,
            "counts" | "raw" => Self::Counts,
            "deg" | "degrees" => Self::Degrees,
            "rad" | "radians" => Self::Radians,
            "rad/s" | "rad_s" => Self::RadiansPerSecond,
            "deg/s" | "dps" | "deg_s" => Self::DegreesPerSecond,
            "s" | "sec" | "seconds" => Self::Seconds,
            "ms" | "milliseconds" => Self::Milliseconds,
            "us" | "µs" | "μs" | "microseconds" => Self::Microseconds,
            _ => return None,
        })
    }

    /// The factor to the project's unit (nT, degrees, rad/s, s; counts
    /// stay counts).
    fn factor(self) -> f64 {
        match self {
            Self::Nanotesla | Self::Counts | Self::Degrees | Self::RadiansPerSecond | Self::Seconds => 1.0,
            Self::Microtesla => 1e3,
            Self::Gauss => 1e5,
            Self::Milligauss => 100.0,
            Self::Radians => 180.0 / std::f64::consts::PI,
            Self::DegreesPerSecond => std::f64::consts::PI / 180.0,
            Self::Milliseconds => 1e-3,
            Self::Microseconds => 1e-6,
        }
    }

    /// What it measures.
    fn kind(self) -> UnitKind {
        match self {
            Self::Nanotesla | Self::Microtesla | Self::Gauss | Self::Milligauss | Self::Counts => UnitKind::Field,
            Self::Degrees | Self::Radians => UnitKind::Angle,
            Self::RadiansPerSecond | Self::DegreesPerSecond => UnitKind::Rate,
            Self::Seconds | Self::Milliseconds | Self::Microseconds => UnitKind::Time,
        }
    }
}

/// The project's columns a mapping may name: every one.
fn mappable_columns() -> Vec<&'static str> {
    COLUMNS.iter().map(|c| c.name).collect()
}

/// Why a column mapping could not be understood.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ColumnMapError {
    /// An entry is not `column=NAME` or `column=NAME:unit`.
    #[error("column mapping `{0}`: expected column=NAME or column=NAME:unit (e.g. mx=Magnetometer X (uT):uT)")]
    Syntax(String),
    /// The mapping names a column the project does not have.
    #[error("column mapping `{0}`: no such column; the columns are: {1}")]
    UnknownColumn(String, String),
    /// The unit is not one of [`COLUMN_UNITS`].
    #[error("column mapping `{0}`: unknown unit `{1}` (the units: {COLUMN_UNITS})")]
    UnknownUnit(String, String),
    /// A unit given for a column it does not fit (a field unit for an angle,
    /// any unit for a column other than the field's and the angles').
    #[error("column mapping `{0}`: a unit fits only mx, my, mz (nT, uT, gauss, mG, counts), angle columns (deg, rad), gx, gy, gz (rad/s, deg/s) and t, t_board (s, ms, us)")]
    WrongUnit(String),
    /// A column mapped twice.
    #[error("column mapping: `{0}` is mapped twice")]
    Duplicate(String),
}

/// The file's own names (and units) for the project's columns:
/// `mx=mag_x_gauss:gauss,my=...,roll_deg=Roll (rad):rad`. Names are matched
/// exactly but in any case; they may hold spaces and parentheses, not `,`
/// or `:`. Columns not mapped keep their project names.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ColumnMap {
    /// (project column, the file's name, unit).
    entries: Vec<(&'static str, String, Option<ColumnUnit>)>,
}

impl std::str::FromStr for ColumnMap {
    type Err = ColumnMapError;

    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let mut entries: Vec<(&'static str, String, Option<ColumnUnit>)> = Vec::new();
        for entry in spec.split(',').map(str::trim).filter(|e| !e.is_empty()) {
            let (key, value) = entry.split_once('=').ok_or_else(|| ColumnMapError::Syntax(entry.into()))?;
            let known = mappable_columns();
            let column = *known.iter().find(|c| c.eq_ignore_ascii_case(key.trim())).ok_or_else(|| ColumnMapError::UnknownColumn(entry.into(), known.join(", ")))?;
            let (name, unit) = match value.rsplit_once(':') {
                Some((name, unit)) => (name, Some(ColumnUnit::parse(unit).ok_or_else(|| ColumnMapError::UnknownUnit(entry.into(), unit.trim().into()))?)),
                None => (value, None),
            };
            let name = name.trim();
            if name.is_empty() {
                return Err(ColumnMapError::Syntax(entry.into()));
            }
            if let Some(u) = unit {
                let kind = column_spec(column).and_then(|c| match c.quantity {
                    Quantity::Field => Some(UnitKind::Field),
                    Quantity::Angle | Quantity::Heading => Some(UnitKind::Angle),
                    Quantity::Rate => Some(UnitKind::Rate),
                    Quantity::Time => Some(UnitKind::Time),
                    Quantity::Other => None,
                });
                let fits = kind == Some(u.kind());
                if !fits {
                    return Err(ColumnMapError::WrongUnit(entry.into()));
                }
            }
            if entries.iter().any(|(c, _, _)| *c == column) {
                return Err(ColumnMapError::Duplicate(column.into()));
            }
            entries.push((column, name.to_string(), unit));
        }
        Ok(Self { entries })
    }
}

impl ColumnMap {
    /// The name the file gives the project's `column`.
    fn file_name<'a>(&'a self, column: &'a str) -> &'a str {
        self.entries.iter().find(|(c, _, _)| *c == column).map_or(column, |(_, n, _)| n.as_str())
    }

    /// The unit the mapping gives the project's `column`, if any.
    pub fn unit(&self, column: &str) -> Option<ColumnUnit> {
        self.entries.iter().find(|(c, _, _)| *c == column).and_then(|(_, _, u)| *u)
    }

    /// The file's name of the project's `column` (its own name when not
    /// mapped).
    pub fn name_of<'a>(&'a self, column: &'a str) -> &'a str {
        self.file_name(column)
    }

    /// The factor from the file's unit of `column` to the project's.
    fn factor(&self, column: &str) -> f64 {
        self.entries.iter().find(|(c, _, _)| *c == column).and_then(|(_, _, u)| *u).map_or(1.0, ColumnUnit::factor)
    }
}

/// For a missing field column: the header's names that look like the
/// magnetometer's, as a mapping to give (empty when none do).
fn mapping_hint(header: &[&str]) -> String {
    let looks_like_field = |lower: &str| {
        let words: Vec<&str> = lower.split(|c: char| !c.is_alphanumeric()).filter(|w| !w.is_empty()).collect();
        let axis = words.iter().find_map(|w| match *w {
            "x" | "y" | "z" => Some(*w),
            w if w.starts_with("mag") && w.len() == 4 => w.get(3..),
            _ => None,
        });
        let unit = words.iter().find_map(|w| match *w {
            "ut" | "nt" | "gauss" | "mg" => Some(*w),
            _ => None,
        });
        let field = lower.contains("mag") || (axis.is_some() && (unit.is_some() || lower.contains("field")));
        field.then(|| (axis.map(str::to_string), unit.map(str::to_string)))
    };
    let candidates: Vec<(&str, Option<String>, Option<String>)> =
        header.iter().filter_map(|h| looks_like_field(&h.trim().to_lowercase()).map(|(a, u)| (h.trim(), a, u))).collect();
    if candidates.is_empty() {
        return String::new();
    }
    let by_axis: Vec<Option<String>> = ["x", "y", "z"]
        .iter()
        .zip(col::MAG)
        .map(|(axis, mag)| {
            let (name, _, unit) = candidates.iter().find(|(_, a, _)| a.as_deref() == Some(*axis))?;
            Some(format!("{mag}={name}{}", unit.as_ref().map(|u| format!(":{u}")).unwrap_or_default()))
        })
        .collect();
    let names = candidates.iter().map(|(n, _, _)| format!("`{n}`")).collect::<Vec<_>>().join(", ");
    match by_axis.into_iter().collect::<Option<Vec<_>>>() {
        Some(map) => format!("; {names} look like magnetometer columns: give the column mapping `{}`", map.join(",")),
        None => format!("; {names} look like magnetometer columns: give a column mapping `mx=NAME,my=NAME,mz=NAME`"),
    }
}

/// The separator of a table's cells, from its header line: comma,
/// semicolon, tab, or (none of those) runs of spaces; `None` when more than
/// one of comma, semicolon and tab appear.
fn separator(header_line: &[u8]) -> Option<Separator> {
    let found: Vec<u8> = [b',', b';', b'\t'].into_iter().filter(|s| header_line.contains(s)).collect();
    match found[..] {
        [] if header_line.trim_ascii().contains(&b' ') => Some(Separator::Spaces),
        [] => Some(Separator::Byte(b',')),
        [one] => Some(Separator::Byte(one)),
        _ => None,
    }
}

/// How a table's cells are separated.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Separator {
    /// One byte: comma, semicolon or tab.
    Byte(u8),
    /// Runs of spaces (the cells hold none).
    Spaces,
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
    read_table_mapped(reader, path, required, optional, &ColumnMap::default())
}

/// [`read_table_from`] with the cells separated by comma, semicolon, tab or
/// runs of spaces (found from the header line), and the columns under the
/// file's own names and units of `map` (converted to the project's).
pub(crate) fn read_table_mapped<R: std::io::Read>(reader: R, path: &Path, required: &[&'static str], optional: &[&str], map: &ColumnMap) -> Result<Table, TableError> {
    use std::io::{BufRead, Cursor, Read};
    let io_err = |source| TableError::Io { path: path.into(), source };
    let mut reader = std::io::BufReader::new(reader);
    let mut first = Vec::new();
    reader.read_until(b'\n', &mut first).map_err(io_err)?;
    let sep = separator(&first).ok_or_else(|| TableError::AmbiguousSeparator { path: path.into(), header: String::from_utf8_lossy(&first).trim().to_string() })?;
    match sep {
        Separator::Byte(delimiter) => read_csv(Cursor::new(first).chain(reader), delimiter, path, required, optional, map),
        Separator::Spaces => {
            let mut all = first;
            reader.read_to_end(&mut all).map_err(io_err)?;
            let text: Vec<String> = String::from_utf8_lossy(&all).lines().map(|l| l.split_whitespace().collect::<Vec<_>>().join(",")).collect();
            read_csv(Cursor::new(text.join("\n").into_bytes()), b',', path, required, optional, map)
        }
    }
}

/// Where each wanted column is in the header (the file's name from `map`),
/// checking that every name `map` gives is there.
fn locate(header: &csv::StringRecord, path: &Path, required: &[&'static str], optional: &[&str], map: &ColumnMap) -> Result<Vec<Option<usize>>, TableError> {
    let names: Vec<&str> = header.iter().map(|h| h.trim().trim_start_matches('\u{feff}')).collect();
    let header_list = names.join(", ");
    if let Some((column, name, _)) = map.entries.iter().find(|(_, n, _)| column_index(names.iter().copied(), n).is_none()) {
        return Err(TableError::MappedColumnMissing { path: path.into(), column: column.to_string(), name: name.clone(), header: header_list });
    }
    let mut index = Vec::new();
    for &name in required {
        let i = column_index(names.iter().copied(), map.file_name(name)).ok_or_else(|| {
            let hint = if col::MAG.contains(&name) { mapping_hint(&names) } else { String::new() };
            TableError::MissingColumn { path: path.into(), column: name, header: header_list.clone(), hint }
        })?;
        index.push(Some(i));
    }
    index.extend(optional.iter().map(|name| column_index(names.iter().copied(), map.file_name(name))));
    // A column read must be one cell of the header, and each cell at most
    // one column: a name twice (`mx,…,mx`) or two columns on one cell (a
    // mapping `my=mx`) would be read silently from the first.
    for (k, name) in required.iter().chain(optional).enumerate() {
        let Some(i) = index[k] else { continue };
        let file_name = map.file_name(name);
        let times = names.iter().filter(|h| h.eq_ignore_ascii_case(file_name)).count();
        if times > 1 {
            return Err(TableError::DuplicateColumn { path: path.into(), column: name.to_string(), name: names[i].to_string(), times });
        }
        if let Some(other) = required.iter().chain(optional).take(k).zip(&index).find(|(_, j)| **j == Some(i)).map(|(n, _)| n) {
            return Err(TableError::SharedColumn { path: path.into(), first: other.to_string(), second: name.to_string(), name: names[i].to_string() });
        }
    }
    Ok(index)
}

/// Reads the CSV of [`read_table_mapped`] once its separator is known.
fn read_csv<R: std::io::Read>(reader: R, delimiter: u8, path: &Path, required: &[&'static str], optional: &[&str], map: &ColumnMap) -> Result<Table, TableError> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(true).flexible(true).delimiter(delimiter).trim(csv::Trim::All).from_reader(reader);
    let csv_err = |source| TableError::Csv { path: path.into(), source };
    let header = rdr.headers().map_err(csv_err)?.clone();
    if header.is_empty() || header.iter().all(str::is_empty) {
        return Err(TableError::Empty(path.into()));
    }
    let index = locate(&header, path, required, optional, map)?;
    let names: Vec<String> = required.iter().chain(optional).map(|n| n.to_string()).collect();
    let factors: Vec<f64> = names.iter().map(|n| map.factor(n)).collect();
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
            let v = parse_cell(text).ok_or_else(bad)? * factors[k];
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

/// A cell of a table the product writes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Cell<'a> {
    /// A number in its shortest round-trip form; NaN or infinite: empty.
    Number(f64),
    /// A number to this many decimals; NaN or infinite: empty.
    Fixed(f64, usize),
    /// An integer count.
    Count(u64),
    /// Text, quoted by the CSV rules when it holds a comma, quote or newline.
    Text(&'a str),
    /// Not available.
    Empty,
}

impl Cell<'_> {
    /// A number, or empty when `None`.
    pub fn opt(v: Option<f64>) -> Self {
        v.map_or(Cell::Empty, Cell::Number)
    }

    /// A number to `decimals`, or empty when `None`.
    pub fn opt_fixed(v: Option<f64>, decimals: usize) -> Self {
        v.map_or(Cell::Empty, |v| Cell::Fixed(v, decimals))
    }

    fn text(&self) -> std::borrow::Cow<'_, str> {
        match *self {
            Cell::Number(v) => cell(v).into(),
            Cell::Fixed(v, d) if v.is_finite() => format!("{v:.d$}").into(),
            Cell::Count(n) => n.to_string().into(),
            Cell::Text(t) => t.into(),
            Cell::Fixed(..) | Cell::Empty => "".into(),
        }
    }
}

/// The one CSV writer: a header, then rows of typed [`Cell`]s, streamed
/// (the csv crate's quoting, so a label with a comma stays one cell). A
/// row of the wrong length is refused rather than written ragged.
pub struct TableWriter<W: std::io::Write> {
    out: csv::Writer<W>,
    columns: usize,
}

impl<W: std::io::Write> TableWriter<W> {
    /// Starts a table on `out` with its header.
    pub fn new(out: W, header: &[&str]) -> std::io::Result<Self> {
        let mut out = csv::WriterBuilder::new().flexible(false).from_writer(out);
        out.write_record(header).map_err(std::io::Error::other)?;
        Ok(Self { out, columns: header.len() })
    }

    /// One row.
    pub fn row(&mut self, cells: &[Cell<'_>]) -> std::io::Result<()> {
        if cells.len() != self.columns {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("a row of {} cells in a table of {} columns", cells.len(), self.columns)));
        }
        self.out.write_record(cells.iter().map(|c| c.text().into_owned())).map_err(std::io::Error::other)
    }

    /// One row of numbers (NaN empty).
    pub fn numbers(&mut self, values: &[f64]) -> std::io::Result<()> {
        let cells: Vec<Cell<'_>> = values.iter().map(|&v| Cell::Number(v)).collect();
        self.row(&cells)
    }

    /// Writes what is buffered through to the underlying writer and flushes it.
    pub fn flush(&mut self) -> std::io::Result<()> {
        self.out.flush()
    }
}

/// Writes a CSV file: the header, then one row per item of `rows` (NaN as
/// an empty cell).
///
/// Through [`crate::files::write_atomic`]: the old file or the new one,
/// never half of one.
pub(crate) fn write_table(path: &Path, header: &[&str], rows: impl Iterator<Item = Vec<f64>>) -> Result<(), TableError> {
    Ok(write_cells(path, header, |w| {
        for row in rows {
            w.numbers(&row)?;
        }
        Ok(())
    })?)
}

/// Writes a CSV file of typed cells: the header, then what `rows` writes,
/// through [`crate::files::write_atomic`].
pub(crate) fn write_cells(
    path: &Path,
    header: &[&str],
    rows: impl FnOnce(&mut TableWriter<std::io::BufWriter<&mut std::fs::File>>) -> std::io::Result<()>,
) -> Result<(), crate::files::OutputError> {
    crate::files::write_atomic(path, |file| {
        let mut w = TableWriter::new(std::io::BufWriter::new(file), header)?;
        rows(&mut w)?;
        w.flush()
    })
}

/// A line stream's header lacks a column it needs.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("missing column `{column}` (the header has: {header})")]
pub struct StreamHeaderError {
    /// The column missing.
    pub column: String,
    /// The header as it came.
    pub header: String,
}

/// The cells of one CSV line, by the csv crate's rules (quotes included);
/// empty when the line is not one record.
fn line_cells(line: &str) -> Vec<String> {
    let mut reader = csv::ReaderBuilder::new().has_headers(false).flexible(true).from_reader(line.as_bytes());
    reader.records().next().and_then(Result::ok).map(|r| r.iter().map(str::to_string).collect()).unwrap_or_default()
}

/// The columns of a line stream (a FIFO, stdin): the header line's
/// positions of the wanted names, then each line's values, read by name.
#[derive(Debug)]
pub(crate) struct StreamColumns {
    wanted: Vec<&'static str>,
    index: Vec<Option<usize>>,
}

/// One line's values of a stream's wanted columns.
#[derive(Debug)]
pub(crate) struct StreamRow<'a> {
    wanted: &'a [&'static str],
    values: Vec<f64>,
}

impl StreamRow<'_> {
    /// The value of the column named `name` (NaN where the line or the
    /// header lacks it, or it was not wanted).
    pub(crate) fn get(&self, name: &str) -> f64 {
        self.wanted.iter().position(|w| *w == name).and_then(|i| self.values.get(i).copied()).unwrap_or(f64::NAN)
    }
}

impl StreamColumns {
    /// From the header line; `Err` names the first of `required` missing.
    pub(crate) fn new(header: &str, wanted: &[&'static str], required: usize) -> Result<Self, StreamHeaderError> {
        let names = line_cells(header);
        let index: Vec<Option<usize>> = wanted.iter().map(|w| column_index(names.iter().map(String::as_str), w)).collect();
        match wanted.iter().zip(&index).take(required).find(|(_, i)| i.is_none()) {
            Some((name, _)) => Err(StreamHeaderError { column: (*name).to_string(), header: header.to_string() }),
            None => Ok(Self { wanted: wanted.to_vec(), index }),
        }
    }

    /// The wanted columns' values on a line (NaN where absent); `None` when
    /// a cell is not a number.
    pub(crate) fn values(&self, line: &str) -> Option<StreamRow<'_>> {
        let cells = line_cells(line);
        let values = self.index.iter().map(|i| i.and_then(|i| cells.get(i)).map_or(Some(f64::NAN), |c| parse_cell(c))).collect::<Option<Vec<f64>>>()?;
        Some(StreamRow { wanted: &self.wanted, values })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &[u8], required: &[&'static str], optional: &[&str]) -> Result<Table, TableError> {
        read_table_from(text, Path::new("x.csv"), required, optional)
    }

    /// The recording's, the navigation log's and the board log's types hold
    /// exactly the registry's columns of their log (`mx, my, mz` are their
    /// `mag`), so that reading, writing and merging, which iterate the
    /// registry, miss none; and merge carries what both hold.
    #[test]
    fn each_log_type_holds_the_registry_columns_of_its_log() {
        use crate::data::nav_log::NavLog;
        use crate::data::Recording;
        let sorted = |mut v: Vec<&'static str>| {
            v.sort_unstable();
            v
        };
        let of = |pick: fn(&Logs) -> bool| sorted(COLUMNS.iter().filter(|c| pick(&c.logs) && !col::MAG.contains(&c.name)).map(|c| c.name).collect());
        assert_eq!(sorted(Recording::NAMES.to_vec()), of(|l| l.recording));
        assert_eq!(sorted(NavLog::NAMES.to_vec()), of(|l| l.nav));
        assert_eq!(sorted(crate::data::board_log::BoardLog::NAMES.to_vec()), of(|l| l.board));
        let merged: Vec<&str> = merged_columns().map(|c| c.name).collect();
        assert_eq!(merged, ["roll_deg", "pitch_deg", "ref_heading_deg", "lat_deg", "lon_deg", "gx", "gy", "gz", "speed_mps", "motor_current_a"]);
    }

    /// The registry holds each name once, and every name of `col` (what
    /// the readers and writers use) is in it.
    #[test]
    fn the_column_registry_holds_every_column_once() {
        let mut names: Vec<&str> = COLUMNS.iter().map(|c| c.name).collect();
        names.sort_unstable();
        let n = names.len();
        names.dedup();
        assert_eq!(names.len(), n, "a name twice");
        use col::*;
        let mut all = vec![T, ROLL_DEG, PITCH_DEG, HEADING_DEG, REF_HEADING_DEG, LAT_DEG, LON_DEG, SPEED_MPS, MOTOR_CURRENT_A, TEMP_C, HEALTH, T_BOARD, TRUE_HEADING_DEG, TRUE_FIELD_NT, COMPASS_HEADING_DEG, VARIATION_DEG, COURSE_DEG, GPS_SPEED_MPS];
        all.extend(MAG);
        all.extend(GYRO);
        for c in all {
            assert!(column_spec(c).is_some(), "{c} is not in the registry");
        }
        // What the registry says drives the mapping: an angle's unit on a
        // heading column, none on a speed.
        assert!("compass_heading_deg=HDG:rad".parse::<ColumnMap>().is_ok());
        assert!(matches!("speed_mps=STW:deg".parse::<ColumnMap>(), Err(ColumnMapError::WrongUnit(_))));
    }

    /// The one writer: typed cells, text quoted by the CSV rules (a label
    /// holding a comma stays one cell; written by hand it split the row),
    /// NaN and `None` empty, a row of the wrong length refused, and what it
    /// writes reads back by the one reader.
    #[test]
    fn the_writer_quotes_text_and_refuses_ragged_rows() {
        let mut w = TableWriter::new(Vec::new(), &["label", "t", "x", "n"]).unwrap();
        w.row(&[Cell::Text("N, by \"compass\""), Cell::Fixed(1.23456, 3), Cell::Number(f64::NAN), Cell::Count(7)]).unwrap();
        w.row(&[Cell::Empty, Cell::opt_fixed(None, 2), Cell::opt(Some(-0.5)), Cell::Count(0)]).unwrap();
        assert!(w.row(&[Cell::Empty]).is_err());
        w.flush().unwrap();
        let text = String::from_utf8(w.out.into_inner().unwrap()).unwrap();
        assert_eq!(text, "label,t,x,n\n\"N, by \"\"compass\"\"\",1.235,,7\n,,-0.5,0\n");
        let mut t = read(text.as_bytes(), &["n"], &["x"]).unwrap();
        assert_eq!(t.take("n"), Some(vec![7.0, 0.0]));
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
        assert!(v.get("t") == 1.5 && v.get("roll_deg") == 2.0 && v.get("gx").is_nan() && v.get("not_wanted").is_nan());
        let e = StreamColumns::new("t,x", &["t", "roll_deg"], 2).unwrap_err();
        assert_eq!(e, StreamHeaderError { column: "roll_deg".into(), header: "t,x".into() });
        assert_eq!(e.to_string(), "missing column `roll_deg` (the header has: t,x)");
        // Quoted cells by the CSV rules: a comma inside quotes is one cell.
        let s = StreamColumns::new("\"t\",note,roll_deg", &["t", "roll_deg"], 2).unwrap();
        let v = s.values("2.5,\"a, b\",-3").unwrap();
        assert!(v.get("t") == 2.5 && v.get("roll_deg") == -3.0, "{v:?}");
        assert_eq!((cell(f64::NAN), cell(1.25)), (String::new(), "1.25".to_string()));
    }

    fn mapped(text: &str, map: &str) -> Result<Table, TableError> {
        read_table_mapped(text.as_bytes(), Path::new("x.csv"), &col::MAG, &[col::T, col::ROLL_DEG], &map.parse().unwrap())
    }

    /// Semicolon, tab and space-separated files read as the comma file does.
    #[test]
    fn the_separator_is_found_from_the_header() {
        let comma = "t,mx,my,mz,roll_deg\n0,1.5,-2,3,10\n1,4,5,6,nan\n";
        let want = |mut t: Table| (t.take("t"), t.take("mx"), t.take("mz"));
        let expect = want(mapped(comma, "").unwrap());
        assert_eq!(expect.1, Some(vec![1.5, 4.0]));
        for sep in [";", "\t", " ", "   "] {
            let text = comma.replace(',', sep);
            assert_eq!(want(mapped(&text, "").unwrap()), expect, "separator {sep:?}");
        }
        // An empty cell is only possible with a real separator: in a space
        // file a row with a missing value is ragged.
        assert!(matches!(mapped("t mx my mz\n0 1 2\n", ""), Err(TableError::Ragged { line: 2, .. })));
        let e = mapped("t,mx;my,mz\n0,1,2,3\n", "").unwrap_err();
        assert!(matches!(e, TableError::AmbiguousSeparator { .. }), "{e}");
    }

    /// Other tools' names and units: gauss to nT, radians to degrees.
    #[test]
    fn a_mapping_reads_other_names_and_units() {
        let text = "Time;Magnetometer X (uT);Magnetometer Y (uT);mag_z_gauss;Roll (rad)\n0;48.5;-1.25;0.2;0.5\n";
        let mut t = mapped(text, "t=time, mx=Magnetometer X (uT):uT, my=MAGNETOMETER Y (UT):µT, mz=mag_z_gauss:gauss, roll_deg=Roll (rad):rad").unwrap();
        // 48.5 µT = 48 500 nT; 0.2 G = 20 000 nT; 0.5 rad = 28.6479 deg.
        assert_eq!(t.take("mx"), Some(vec![48_500.0]));
        assert_eq!(t.take("my"), Some(vec![-1_250.0]));
        assert!((t.take("mz").unwrap()[0] - 20_000.0).abs() < 1e-9);
        assert!((t.take("roll_deg").unwrap()[0] - 28.647_889_756).abs() < 1e-8);
        // A gyro in degrees per second and a time in microseconds (other
        // tools' logs: ArduPilot's TimeUS, an IMU's deg/s): 90 deg/s =
        // π/2 rad/s; 1 500 000 µs = 1.5 s.
        let text = "TimeUS,MagX,MagY,MagZ,GyrX,GyrY,GyrZ\n1500000,1,2,3,90,-45,0\n";
        let map = "t=TimeUS:us,mx=MagX,my=MagY,mz=MagZ,gx=GyrX:deg/s,gy=GyrY:deg/s,gz=GyrZ:deg/s".parse().unwrap();
        let mut t = read_table_mapped(text.as_bytes(), Path::new("x.csv"), &col::MAG, &[col::T, col::GYRO[0], col::GYRO[1], col::GYRO[2]], &map).unwrap();
        assert_eq!(t.take("t"), Some(vec![1.5]));
        assert!((t.take("gx").unwrap()[0] - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
        assert!((t.take("gy").unwrap()[0] + std::f64::consts::FRAC_PI_4).abs() < 1e-15);
        // An angle in radians is range-checked after conversion: 3.2 rad > 180°.
        let e = mapped("mx,my,mz,r\n1,2,3,3.2\n", "roll_deg=r:rad").unwrap_err();
        assert!(matches!(e, TableError::OutOfRange { line: 2, .. }), "{e}");
    }

    #[test]
    fn bad_mappings_are_refused_by_name() {
        let e = mapped("a,b,c\n1,2,3\n", "mx=a,my=b,mz=nope").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: the column mapping gives `mz` as `nope`, which the header does not have (the header has: a, b, c)");
        let parse = |s: &str| s.parse::<ColumnMap>().unwrap_err();
        assert!(matches!(parse("mx"), ColumnMapError::Syntax(_)));
        assert!(matches!(parse("mx="), ColumnMapError::Syntax(_)));
        assert!(matches!(parse("magx=a"), ColumnMapError::UnknownColumn(..)));
        assert!(matches!(parse("mx=a:tesla"), ColumnMapError::UnknownUnit(_, u) if u == "tesla"));
        assert!(matches!(parse("mx=a:deg"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("roll_deg=a:uT"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("t=a:rad"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("gx=a:deg"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("roll_deg=a:deg/s"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("speed_mps=a:ms"), ColumnMapError::WrongUnit(_)));
        assert!(matches!(parse("mx=a,MX=b"), ColumnMapError::Duplicate(_)));
    }

    /// Issue 37: a column read twice from the header, or two columns read
    /// from one cell, is refused (the first `mx` was read silently); a
    /// column twice that is not read stays harmless.
    #[test]
    fn a_column_read_twice_or_two_from_one_cell_are_refused() {
        let e = mapped("t,mx,my,mz,MX\n0,1,2,3,4\n", "").unwrap_err();
        assert!(matches!(e, TableError::DuplicateColumn { times: 2, .. }), "{e}");
        assert_eq!(e.to_string(), "x.csv: the header has `mx` 2 times: which one is `mx`? (rename or remove the others)");
        let e = mapped("t,a,b,c\n0,1,2,3\n", "mx=a,my=a,mz=c").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: `mx` and `my` would both be read from the header's `a`: each column needs its own");
        let e = mapped("t,mx,my,mz\n0,1,2,3\n", "roll_deg=mx").unwrap_err();
        assert!(matches!(e, TableError::SharedColumn { .. }), "{e}");
        let mut t = mapped("t,mx,my,mz,note,note\n0,1,2,3,a,b\n", "").unwrap();
        assert_eq!(t.take("mx"), Some(vec![1.0]));
    }

    /// Issue 24: "missing column `mx`" alone left other tools' users stuck.
    #[test]
    fn a_missing_field_column_suggests_the_mapping() {
        let e = mapped("time,mag_x_gauss,mag_y_gauss,mag_z_gauss\n0,1,2,3\n", "").unwrap_err();
        assert!(e.to_string().ends_with("give the column mapping `mx=mag_x_gauss:gauss,my=mag_y_gauss:gauss,mz=mag_z_gauss:gauss`"), "{e}");
        let e = mapped("Magnetometer X (uT)\tMagnetometer Y (uT)\tMagnetometer Z (uT)\n1\t2\t3\n", "").unwrap_err();
        assert!(e.to_string().contains("`mx=Magnetometer X (uT):ut,my=Magnetometer Y (uT):ut,mz=Magnetometer Z (uT):ut`"), "{e}");
        let e = mapped("t,magnetic\n0,1\n", "").unwrap_err();
        assert!(e.to_string().ends_with("`magnetic` look like magnetometer columns: give a column mapping `mx=NAME,my=NAME,mz=NAME`"), "{e}");
        // Nothing field-like (temperature, current): no suggestion.
        let e = mapped("t,temp_c,motor_current_a\n0,1,2\n", "").unwrap_err();
        assert!(e.to_string().ends_with("(the header has: t, temp_c, motor_current_a)"), "{e}");
    }
}
