//! Arbitrary bytes as a vehicle log of every format the one importer reads
//! (`import_drive.rs`: the first byte picks the format, the rest is the
//! log; its seeds in `fuzz/seeds/import/` are replayed by
//! `import_formats::every_import_fuzz_input_replays_without_a_panic`).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "import_drive.rs"]
mod import_drive;

fuzz_target!(|data: &[u8]| import_drive::drive(data));
