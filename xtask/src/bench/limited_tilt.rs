//! A vehicle that cannot tumble: simulated swing tests with and without a gyro, and BROAD trial 05 against the peers.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::json;

/// The simulated half of [`limited_tilt`]: the swing test at ±55° / ±10°
/// and ±15° / ±5°, with and without a gyro, three seeds each.
pub fn limited_tilt_simulated() -> (Vec<serde_json::Value>, String) {
    use magcal_sim::scenario::{evaluate_limited, LimitedSwing};
    use magcal_sim::SensorModel;

    let mut md = String::from("Simulated (paper-like hull, our chain, validation run):\n\n| swing test | gyro | seed | heading RMS (°) | field error (nT) |\n|---|---|---|---|---|\n");
    let mut sim_rows = Vec::new();
    for (roll, pitch) in [(55.0, 10.0), (15.0, 5.0)] {
        for gyro in [false, true] {
            for seed in 1..=3 {
                let kind = LimitedSwing { roll_amp_deg: roll, pitch_amp_deg: pitch, gyro };
                match evaluate_limited(SensorModel::paper_like(), seed, kind) {
                    Ok(o) => {
                        let cell = match (&o.heading_rms_deg, &o.refused) {
                            (Some(h), _) => format!("{h:.3} | {:.1}", o.field_error_nt.unwrap_or(f64::NAN)),
                            (None, Some(r)) => format!("refused: {r} | —"),
                            _ => "— | —".into(),
                        };
                        let _ = writeln!(md, "| ±{roll}° / ±{pitch}° | {} | {seed} | {cell} |", if gyro { "yes" } else { "no" });
                        sim_rows.push(json!(o));
                    }
                    Err(e) => {
                        let _ = writeln!(md, "| ±{roll}° / ±{pitch}° | {gyro} | {seed} | failed: {e} | |");
                    }
                }
            }
        }
    }
    (sim_rows, md)
}

/// A vehicle that cannot tumble. The simulated swing test at the
/// paper's ±55° / ±10° and at ±15° / ±5°, with and without a gyro (our
/// chain each time); and the real BROAD trial 05 data: magcal's gyro-aided
/// fit against the true calibration, the sphere fit and the peers shipped
/// in the `magyc` package (MAGYC-LS/NLS, TWOSTEP, SAR-LS, ellipsoid fit)
/// when it installs.
pub fn limited_tilt(root: &Path) -> (serde_json::Value, String) {
    use calib_core::cal::{FieldCal, ModelKind};
    use calib_core::heading::magnetic_heading_rad;
    use host_tools::compute::{fit_recording, heading_rms_after_offset_deg, FitOptions};
    use host_tools::data::Recording;

    let (sim_rows, mut md) = limited_tilt_simulated();
    // broad-05.
    let dir = root.join("tests/data/broad-05");
    let (Ok(calib), Ok(validate)) = (Recording::read(&dir.join("05_calib.csv")), Recording::read(&dir.join("05_validate.csv"))) else {
        return (json!({"simulated": sim_rows, "broad05": "tests/data/broad-05 missing"}), md);
    };
    let optical: Vec<f64> = host_tools::compute::read_reference_column(&dir.join("05_validate.csv"), "truth_heading_deg").ok().flatten().unwrap_or_default();
    let heading = |cal: &FieldCal<f64>| {
        let (Some(roll), Some(pitch)) = (validate.roll_deg.as_ref(), validate.pitch_deg.as_ref()) else { return f64::NAN };
        let h = (0..validate.len()).map(|i| magnetic_heading_rad(cal.apply(validate.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
        heading_rms_after_offset_deg(h.zip(optical.iter().copied())).0.rms
    };
    let lab_field_nt = 44_204.0;
    let mut rows: Vec<(String, Option<f64>, String)> = Vec::new();
    #[derive(serde::Deserialize)]
    struct Cal {
        bias: [f64; 3],
        matrix: [[f64; 3]; 3],
    }
    if let Some(t) = std::fs::read_to_string(dir.join("05.truth.json")).ok().and_then(|s| serde_json::from_str::<Cal>(&s).ok()) {
        rows.push(("the true calibration (the floor)".into(), Some(heading(&FieldCal { bias: t.bias, matrix: t.matrix })), String::new()));
    }
    rows.push(("none (raw counts)".into(), Some(heading(&FieldCal::identity())), String::new()));
    let opts = |model| FitOptions { model, field_nt: lab_field_nt, saturation: None, allow_weak: false, gyro_lag: host_tools::compute::GyroLag::Given(0.0), reference: None };
    let started = std::time::Instant::now();
    match fit_recording(&calib, &opts(ModelKind::Gyro)) {
        Ok(doc) => {
            let predicted = doc.quality.predicted_heading_rms_deg.unwrap_or(f64::NAN);
            rows.push(("magcal gyro-aided (`fit --model gyro`)".into(), Some(heading(&doc.field_cal())), format!("{:.0} ms; predicted {predicted:.2}° (noise only)", started.elapsed().as_secs_f64() * 1e3)));
        }
        Err(e) => rows.push(("magcal gyro-aided".into(), None, e.to_string())),
    }
    match fit_recording(&calib, &opts(ModelKind::Sphere)) {
        Ok(doc) => rows.push(("magcal sphere".into(), Some(heading(&doc.field_cal())), "accepted".into())),
        Err(e) => rows.push(("magcal sphere".into(), None, format!("refused: {e}"))),
    }
    if let Ok(doc) = fit_recording(&calib, &FitOptions { allow_weak: true, ..opts(ModelKind::Sphere) }) {
        rows.push(("magcal sphere with --allow-weak".into(), Some(heading(&doc.field_cal())), "what a silent acceptance gave".into()));
    }
    // The peers, in Python (their own code), when `magyc` imports or installs.
    let script = root.join("xtask/bench/magyc_broad05.py");
    let python = |args: &[&str]| std::process::Command::new("python3").args(args).output().ok().filter(|o| o.status.success());
    if python(&["-c", "import magyc"]).is_none() {
        let _ = python(&["-m", "pip", "install", "-q", "magyc"]);
    }
    let calib_csv = dir.join("05_calib.csv");
    let field_counts = format!("{}", lab_field_nt / 10.0);
    match python(&[&script.to_string_lossy(), &calib_csv.to_string_lossy(), &field_counts]).and_then(|o| serde_json::from_slice::<serde_json::Value>(&o.stdout).ok()) {
        Some(peers) => {
            for name in ["MAGYC-LS", "MAGYC-NLS", "TWOSTEP", "SAR-LS", "ellipsoid fit"] {
                match serde_json::from_value::<Cal>(peers[name].clone()) {
                    Ok(c) => rows.push((format!("magyc {name}"), Some(heading(&FieldCal { bias: c.bias, matrix: c.matrix })), String::new())),
                    Err(_) => rows.push((format!("magyc {name}"), None, peers[name]["error"].as_str().unwrap_or("no answer").to_string())),
                }
            }
        }
        None => rows.push(("magyc (PyPI)".into(), None, "not available here (pip install magyc failed)".into())),
    }
    let _ = writeln!(md, "\nReal data, BROAD trial 05 (`tests/data/broad-05`, |roll|, |pitch| ≤ 25°): calibration part in, heading RMS on the validation part against the optical reference out (one constant offset removed):\n\n| calibration | heading RMS (°) | note |\n|---|---|---|");
    for (name, h, note) in &rows {
        let _ = writeln!(md, "| {name} | {} | {note} |", h.map_or("—".into(), |v| format!("{v:.2}")));
    }
    let broad: Vec<_> = rows.iter().map(|(n, h, note)| json!({"calibration": n, "heading_rms_deg": h, "note": note})).collect();
    (json!({"simulated": sim_rows, "broad05": broad}), md)
}

/// The `results.md` section "A vehicle that cannot tumble".
pub fn markdown(limited_md: &str) -> String {
    format!("## A vehicle that cannot tumble\n\n{limited_md}\n")
}
