//! The gyro-aided fit (`fit --model gyro`, defaults) on the four real BROAD
//! trials with the optical heading (`tests/data/broad-*`): heading RMS on
//! each trial's validation part, after one constant offset, against the
//! floor the trial's true calibration (`NN.truth.json`) reaches. The
//! host defaults (`compute::gyro::WINDOW_S`, `ATTITUDE_WEIGHT`) were chosen
//! leave-one-trial-out on these four trials: each held-out trial's number
//! comes from defaults the other three chose (30 steps, weight 0.03–0.1 in
//! every fold; the held-out results differ by ≤ 0.001° between them).

use std::path::{Path, PathBuf};

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::magnetic_heading_rad;
use host_tools::compute::{fit_recording, heading_rms_after_offset_deg, FitOptions};
use host_tools::data::Recording;

fn dir(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data").join(name)
}

/// The optical heading column of a validation file, degrees.
pub(crate) fn optical_deg(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let col = lines.next().and_then(|h| h.split(',').position(|c| c == "truth_heading_deg")).unwrap();
    lines.map(|l| l.split(',').nth(col).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)).collect()
}

#[derive(serde::Deserialize)]
pub(crate) struct Truth {
    pub(crate) bias: [f64; 3],
    pub(crate) matrix: [[f64; 3]; 3],
    pub(crate) field_nt: f64,
}

/// (heading RMS of the gyro fit with the product's defaults, the floor),
/// degrees.
fn trial(name: &str, id: &str) -> (f64, f64) {
    let d = dir(name);
    let calib = Recording::read(&d.join(format!("{id}_calib.csv"))).unwrap();
    let validate = Recording::read(&d.join(format!("{id}_validate.csv"))).unwrap();
    let optical = optical_deg(&d.join(format!("{id}_validate.csv")));
    let t: Truth = serde_json::from_str(&std::fs::read_to_string(d.join(format!("{id}.truth.json"))).unwrap()).unwrap();
    let heading = |cal: &FieldCal<f64>| {
        let (roll, pitch) = (validate.roll_deg.as_ref().unwrap(), validate.pitch_deg.as_ref().unwrap());
        let h = (0..validate.len()).map(|i| magnetic_heading_rad(cal.apply(validate.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
        heading_rms_after_offset_deg(h.zip(optical.iter().copied())).0.rms
    };
    let floor = heading(&FieldCal { bias: t.bias, matrix: t.matrix });
    // `magcal fit --model gyro` without options: no lag given (the fit
    // estimates the remaining sub-sample lag itself).
    let opts = FitOptions { model: ModelKind::Gyro, field_nt: t.field_nt, saturation: None, allow_weak: true, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None };
    let fit = fit_recording(&calib, &opts).unwrap();
    let rms = heading(&fit.field_cal());
    eprintln!("{name}: gyro {rms:.3}°, floor {floor:.3}°");
    (rms, floor)
}

/// The goal: within 0.5° of the floor on every trial.
const MARGIN_DEG: f64 = 0.5;

/// Runs one trial: its floor must be the one its true calibration gives
/// (`floor_deg`, checks this file's evaluation), and the fit within
/// [`MARGIN_DEG`] of it.
fn check(name: &str, id: &str, floor_deg: f64) {
    let (rms, floor) = trial(name, id);
    assert!((floor - floor_deg).abs() < 0.01, "{floor}");
    assert!(rms <= floor + MARGIN_DEG, "{rms} vs floor {floor}");
}

#[test]
fn broad_02_limited() {
    // Floor 1.70°; measured 1.67° (before the ring fix and the
    // leave-one-out defaults: 2.07°).
    check("broad-02-limited", "02", 1.699);
}

#[test]
fn broad_03() {
    // Floor 2.46°; measured 1.59° (before the ring fix: 1.67°).
    check("broad-03", "03", 2.457);
}

#[test]
fn broad_05() {
    // Floor 2.22° (as its README publishes); measured 1.69° (before: 1.67°).
    check("broad-05", "05", 2.217);
}

#[test]
fn broad_09_fast_rotation_with_breaks() {
    // Floor 2.05°; measured 1.60° (before the ring fix: 2.8°; windows across
    // the chain's ring wrap used one gyro step twice).
    check("broad-09", "09", 2.050);
}
