//! Arbitrary bytes as a recording: read, and when readable, fit — errors,
//! never panics.
//!
//! The body is in `csv_reader_drive.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "csv_reader_drive.rs"]
mod drive;

fuzz_target!(|data: &[u8]| drive::drive(data));
