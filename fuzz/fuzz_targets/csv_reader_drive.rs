//! Arbitrary bytes as a recording: read, and when readable, fit — errors,
//! never panics.
//!
//! The `csv_reader` fuzz target's body, a plain function: libFuzzer calls it
//! through `csv_reader.rs`, and `cargo xtask test` replays every seed and
//! corpus input through it (`xtask/src/fuzz.rs`, `replay`).
use calib_core::cal::ModelKind;
use host_tools::compute::{fit_recording, FitOptions};
use host_tools::data::Recording;

/// Runs one input.
pub fn drive(data: &[u8]) {
    if let Ok(rec) = Recording::from_reader(data, std::path::Path::new("fuzz.csv")) {
        // The gyro model too: arbitrary t, gx, gy, gz columns reach it.
        for model in [ModelKind::Sphere, ModelKind::Axis, ModelKind::Full, ModelKind::Gyro] {
            let _ = fit_recording(&rec, &FitOptions { model, field_nt: 48_730.0, saturation: Some(1e9), allow_weak: false, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None });
        }
    }
}
