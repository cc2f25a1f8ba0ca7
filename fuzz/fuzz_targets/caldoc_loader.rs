//! Arbitrary bytes as a calibration document: parsed and validated, or
//! refused with a reason.
//!
//! The body is in `caldoc_loader_drive.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "caldoc_loader_drive.rs"]
mod drive;

fuzz_target!(|data: &[u8]| drive::drive(data));
