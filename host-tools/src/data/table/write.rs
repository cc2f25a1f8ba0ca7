//! The writer: cells and rows written with NaN as an empty cell.

use super::*;

/// A value as a cell: the number, or empty when not available (NaN).
pub(crate) fn cell(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        String::new()
    }
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
    pub(super) out: csv::Writer<W>,
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
