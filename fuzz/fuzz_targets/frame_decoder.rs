//! Arbitrary bytes on the host link: the firmware's whole request path
//! (frame decoder, link server, device) must answer or ignore, never panic,
//! and never switch coefficients without a valid unlock and commit.
//!
//! A shadow of what the protocol allows is kept beside the device: a
//! `Committed` reply must follow an acknowledged `Unlock` and an acknowledged
//! `WriteCoefficients` whose set has the committed CRC; the store must then
//! hold exactly that set, and reading back must give it. Seeds in
//! `fuzz/seeds/frame_decoder/` (valid unlock/write/commit sequences, written
//! by the firmware's `fuzz_seed_corpus_is_current` test) let the fuzzer start
//! on the deep paths.
//!
//! The body is in `frame_decoder_drive.rs`.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "frame_decoder_drive.rs"]
mod drive;

fuzz_target!(|data: &[u8]| drive::drive(data));
