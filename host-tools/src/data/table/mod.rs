//! Tables on disk in the CSV format of `docs/INTERFACES.md`, the one
//! reader and writer of every CSV in host-tools: one header row, columns
//! found by name in any order and any case (a UTF-8 BOM ignored), extra
//! columns ignored, rows as long as the header, an empty cell or `nan`
//! meaning "not available", errors naming file, line and column; written
//! with NaN as an empty cell. The column names live in [`col`].

mod read;
mod registry;
mod units;
mod write;

pub use read::*;
pub use registry::*;
pub use units::*;
pub use write::*;

use std::path::{Path, PathBuf};

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

#[cfg(test)]
mod tests;
