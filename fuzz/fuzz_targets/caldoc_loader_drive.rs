//! Arbitrary bytes as a calibration document: parsed and validated, or
//! refused with a reason.
//!
//! The `caldoc_loader` fuzz target's body, a plain function: libFuzzer calls it
//! through `caldoc_loader.rs`, and `cargo xtask test` replays every seed and
//! corpus input through it (`xtask/src/fuzz.rs`, `replay`).
use host_tools::doc::CalDoc;

/// Runs one input.
pub fn drive(data: &[u8]) {
    if let Ok(doc) = serde_json::from_slice::<CalDoc>(data) {
        if doc.validate(std::path::Path::new("fuzz.json")).is_ok() {
            let cal = doc.calibration();
            let out = cal.apply([1.0, 2.0, 3.0], 0.1, 0.2);
            assert!(out.true_heading_rad.is_finite() || !out.field_nt.iter().all(|v| v.is_finite()));
        }
    }
}
