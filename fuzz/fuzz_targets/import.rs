//! Arbitrary bytes as a vehicle log of every format the one importer reads
//! (the first byte picks the format, the rest is the log; detection from the
//! content too) — a clear error or an import, never a panic, never a row
//! longer or shorter than its time column.
#![no_main]
use host_tools::data::import::{import, Format, ImportOptions};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, log)) = data.split_first() else { return };
    let format = Format::ALL[pick as usize % Format::ALL.len()];
    let _ = Format::detect(log);
    let opts = ImportOptions { instance: (pick >= 128).then_some(1), ..ImportOptions::default() };
    if let Ok(im) = import(log, format, &opts) {
        let rows = im.report.rows;
        assert!(im.columns.iter().all(|c| c.values.len() == rows), "a column of another length than t");
    }
});
