//! The coefficient store under arbitrary input, two ways:
//!
//! * arbitrary flash contents (a RAM flash): the store finds a record or
//!   none, what it returns decodes to coefficients that pass validation or
//!   is refused, and a save after the garbage loads back;
//! * a power cut at a fuzzer-chosen byte operation of a save, on the
//!   datasheet model of the F405's flash (`firmware::store::f405_flash`,
//!   the unit tests' double, feature `mock-flash`: erase in a seeded random
//!   order, half-programmed bytes), with fuzzer-chosen old and new payloads:
//!   the next power-up loads the old set or the new one, never a mix,
//!   nothing or an error; the new one only if the save got to its commit
//!   slot; and a save after the cut completes.
//!
//! The body is in `coefficient_record_drive.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "coefficient_record_drive.rs"]
mod drive;

fuzz_target!(|data: &[u8]| drive::drive(data));
