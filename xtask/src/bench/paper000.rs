//! Paper 000: simulated field tests.

use std::fmt::Write as _;

use serde_json::json;

/// Paper 000's field test, simulated for several seeds and two vehicles.
pub fn paper000() -> (serde_json::Value, String) {
    use magcal_sim::{evaluate, SensorModel};
    let mut rows = Vec::new();
    let mut md = String::from(
        "| vehicle | seed | step: axis fit | paper | ours (nT) | heading RMS: axis fit | paper | ours (°) | field error: paper | ours (nT) | GPS delay (s) |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for (name, sensor) in [("paper-like", SensorModel::paper_like()), ("hull-coupled", SensorModel::hull_coupled())] {
        for seed in 1..=5 {
            let o = match evaluate(name, sensor, seed) {
                Ok(o) => o,
                Err(e) => {
                    let _ = writeln!(md, "| {name} | {seed} | failed: {e} |");
                    rows.push(json!({"vehicle": name, "seed": seed, "error": e.to_string()}));
                    continue;
                }
            };
            let _ = writeln!(
                md,
                "| {name} | {seed} | {:.0} | {:.1} | {:.1} | {:.2} | {:.2} | {:.2} | {:.0} | {:.1} | {:.2} |",
                o.step_axis_fit_nt, o.step_paper_nt, o.step_ours_nt, o.heading_rms_axis_fit_deg, o.heading_rms_paper_deg, o.heading_rms_ours_deg, o.field_error_paper_nt, o.field_error_ours_nt, o.gps_delay_ours_s
            );
            rows.push(json!({"vehicle": name, "seed": seed, "outcome": o}));
        }
    }
    (json!(rows), md)
}

/// The `results.md` section "Paper 000: simulated field tests".
pub fn markdown(p0_md: &str) -> String {
    format!("## Paper 000: simulated field tests\n\nTurnaround step on the calibration run; true-heading RMS and |F| − IGRF RMS on a separate validation run (other courses, other current), each chain finished by a swing fit against the delayed GPS course.\n\n{p0_md}\n")
}
