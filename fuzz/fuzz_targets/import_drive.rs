//! The `import` fuzz target's body, shared with the test that replays its
//! seeds (`magcal/tests/commands/import_formats/mod.rs`): the first byte
//! picks the format (`Format::ALL`, in order) and, at 128 or more, asks for
//! the second magnetometer instance; the rest is the log. A clear error or
//! an import whose every column is as long as its time column — never a
//! panic.
use host_tools::data::{import, Format, ImportOptions};

/// Runs one input.
pub fn drive(data: &[u8]) {
    let Some((&pick, log)) = data.split_first() else { return };
    let format = Format::ALL[pick as usize % Format::ALL.len()];
    let _ = Format::detect(log);
    let opts = ImportOptions { instance: (pick >= 128).then_some(1), ..ImportOptions::default() };
    if let Ok(im) = import(log, format, &opts) {
        let rows = im.report.rows;
        assert!(im.columns.iter().all(|c| c.values.len() == rows), "a column of another length than t");
    }
}
