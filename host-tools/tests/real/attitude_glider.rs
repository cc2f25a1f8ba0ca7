//! The attitude-aided fit on real glider dives (Seaglider SG236, no gyro,
//! roll ±15°): calibrate on dives 1–3, judge on dives 4–5 below 3 m by the
//! scatter of the calibrated field's magnitude and dip.

use std::path::{Path, PathBuf};

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::level;
use host_tools::compute::{fit_recording, FitOptions};
use host_tools::data::Recording;

fn data(name: &str) -> PathBuf {
    super::data("seaglider-sg236").join(name)
}

/// IGRF-14 at the site (README): 52 203 nT.
const FIELD_NT: f64 = 52_203.0;

/// `depth_m` read apart (the recording reader ignores it).
fn depth_m(path: &Path) -> Vec<f64> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let col = lines.next().unwrap().split(',').position(|c| c == "depth_m").unwrap();
    lines.map(|l| l.split(',').nth(col).unwrap().parse().unwrap()).collect()
}

fn std_dev(v: &[f64]) -> f64 {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
}

/// (dip scatter °, magnitude scatter %) below 3 m on the validation dives.
fn judge(cal: &FieldCal<f64>) -> (f64, f64) {
    let path = data("sg236_validate.csv");
    let rec = Recording::read(&path).unwrap();
    let depth = depth_m(&path);
    let (roll, pitch) = (rec.roll_deg.as_ref().unwrap(), rec.pitch_deg.as_ref().unwrap());
    let (mut dip, mut mag) = (vec![], vec![]);
    for i in 0..rec.len() {
        if depth[i].is_nan() || depth[i] <= 3.0 {
            continue;
        }
        let h = cal.apply(rec.mag[i]);
        let l = level(h, roll[i].to_radians(), pitch[i].to_radians());
        dip.push(l[2].atan2(l[0].hypot(l[1])).to_degrees());
        mag.push((h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt());
    }
    let mean_mag = mag.iter().sum::<f64>() / mag.len() as f64;
    (std_dev(&dip), 100.0 * std_dev(&mag) / mean_mag)
}

/// The glider's own calibration (its JSON carries a `source` note, so it
/// is read as plain JSON).
fn peer() -> FieldCal<f64> {
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(data("onboard_calibration.json")).unwrap()).unwrap();
    let num = |x: &serde_json::Value| x.as_f64().unwrap();
    FieldCal { bias: core::array::from_fn(|i| num(&v["bias"][i])), matrix: core::array::from_fn(|i| core::array::from_fn(|j| num(&v["matrix"][i][j]))) }
}

fn opts(model: ModelKind) -> FitOptions {
    FitOptions { model, field_nt: FIELD_NT, saturation: None, allow_weak: false, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None }
}

#[test]
fn the_attitude_fit_calibrates_a_glider_from_its_dives() {
    let rec = Recording::read(&data("sg236_calib.csv")).unwrap();
    let doc = fit_recording(&rec, &opts(ModelKind::Attitude)).unwrap();
    let (dip, mag) = judge(&doc.field_cal());
    let peer = peer();
    let (peer_dip, peer_mag) = judge(&peer);
    eprintln!("attitude fit: dip {dip:.3}°, magnitude {mag:.3} %; peer {peer_dip:.3}°, {peer_mag:.3} %; warnings {:?}; predicted {:?}", doc.quality.fit.as_ref().map(|f| &f.warnings), doc.quality.predicted_heading_rms_deg);
    // The evaluation reproduces the README's numbers for the glider's own
    // calibration: 0.78° and 1.72 %.
    assert!((peer_dip - 0.78).abs() < 0.01 && (peer_mag - 1.72).abs() < 0.01, "{peer_dip} {peer_mag}");
    // Measured: dip 0.609°, magnitude 1.669 % (the peer: 0.784°, 1.722 %;
    // the target: dip ≤ the peer's with the magnitude ≤ 1.1 × its
    // 1.72 % = 1.89 %). The bounds sit between what the fit gives and the
    // target.
    assert!(dip < 0.70, "dip scatter {dip}°");
    assert!(mag < 1.85, "magnitude scatter {mag} %");
    assert_eq!(doc.model, ModelKind::Attitude);
    // The covariance predicts 0.15° of heading error (not checkable here:
    // no heading reference); it must be there and small.
    let predicted = doc.quality.predicted_heading_rms_deg.unwrap();
    assert!(predicted > 0.03 && predicted < 0.6, "{predicted}");
}

#[test]
fn the_ellipsoid_fits_refuse_the_glider_and_name_the_attitude_model() {
    // The glider has roll and pitch and no gyro: the refusal names the
    // model it can use, and not the one it cannot.
    let rec = Recording::read(&data("sg236_calib.csv")).unwrap();
    let e = fit_recording(&rec, &opts(ModelKind::Full)).unwrap_err();
    let text = e.to_string();
    assert!(text.contains("of field directions were visited") && text.contains("(`attitude`)") && !text.contains("`gyro`"), "{text}");
}

#[test]
fn the_attitude_fit_without_roll_and_pitch_says_so() {
    let rec = Recording::read(&data("sg236_calib.csv")).unwrap();
    let e = fit_recording(&Recording { pitch_deg: None, ..rec.clone() }, &opts(ModelKind::Attitude)).unwrap_err();
    assert_eq!(e.to_string(), "the recording has no `pitch_deg` column, which this command needs");
    let e = fit_recording(&Recording { roll_deg: None, ..rec.clone() }, &opts(ModelKind::Attitude)).unwrap_err();
    assert_eq!(e.to_string(), "the recording has no `roll_deg` column, which this command needs");
    // Radians where degrees belong is caught only when out of range; a
    // roll column in hundredths of a degree is.
    let centi = Recording { roll_deg: rec.roll_deg.as_ref().map(|v| v.iter().map(|r| r * 100.0).collect()), ..rec };
    let e = fit_recording(&centi, &opts(ModelKind::Attitude)).unwrap_err();
    assert!(e.to_string().contains("must be in degrees"), "{e}");
}
