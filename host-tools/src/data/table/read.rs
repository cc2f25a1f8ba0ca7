//! The reader: the outlier gate, cells, the table reader (any separator,
//! a column mapping) and the line-stream reader.

use super::*;

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
/// Where column `name` is among the header's names: trimmed, any case, a
/// leading UTF-8 BOM ignored.
pub(crate) fn column_index<'h>(header: impl IntoIterator<Item = &'h str>, name: &str) -> Option<usize> {
    header.into_iter().position(|h| h.trim().trim_start_matches('\u{feff}').eq_ignore_ascii_case(name))
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
