//! Arbitrary bytes as a calibration document: parsed and validated, or
//! refused with a reason.
#![no_main]
use host_tools::doc::CalDoc;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(doc) = serde_json::from_slice::<CalDoc>(data) {
        if doc.validate(std::path::Path::new("fuzz.json")).is_ok() {
            let cal = doc.calibration();
            let out = cal.apply([1.0, 2.0, 3.0], 0.1, 0.2);
            assert!(out.true_heading_rad.is_finite() || !out.field_nt.iter().all(|v| v.is_finite()));
        }
    }
});
