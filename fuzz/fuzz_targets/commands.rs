//! Random valid-looking recordings, calibration documents, NMEA logs and
//! option values through the library's command entry points (`apply`,
//! `swing`, `card`, `import --nmea`): errors, never panics. The input's
//! layout and the calls are in `commands_drive.rs`; the seeds
//! (`fuzz/seeds/commands/`) are small real inputs joined by its separator.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "commands_drive.rs"]
mod drive;

fuzz_target!(|data: &[u8]| drive::drive(data));
