//! The heading-only swing on a real yacht's compass circles
//! (`tests/data/cirrus-yacht`), against the independent reference there
//! (`reference.json`: numpy's plain 5-term least squares at its best course
//! delay, `reference.py`), in-sample and on held-out halves.

use std::path::Path;

use host_tools::compute::swing_compass;
use host_tools::compute::{Delay, WaterCurrentMode};
use host_tools::data::CompassLog;
use serde_json::json;

/// `reference.json`, the fields the bench shows.
#[derive(serde::Deserialize)]
struct Reference {
    declination_deg: f64,
    best_delay_s: f64,
    pairs: u32,
    residual_rms_deg: f64,
    before_rms_deg: f64,
    held_out_before_rms_deg: f64,
    held_out_after_rms_deg: f64,
}

/// The section's numbers and its Markdown table.
pub fn section(root: &Path) -> (serde_json::Value, String) {
    let dir = root.join("tests/data/cirrus-yacht");
    let reference: Reference = match std::fs::read_to_string(dir.join("reference.json")).map_err(|e| e.to_string()).and_then(|t| serde_json::from_str(&t).map_err(|e| e.to_string())) {
        Ok(r) => r,
        Err(e) => return (json!({"error": format!("reference.json: {e}")}), format!("\nnot measured: reference.json: {e}\n")),
    };
    let log = match CompassLog::read(&dir.join("compass_log.csv")) {
        Ok(l) => l,
        Err(e) => return (json!({"error": e.to_string()}), format!("\nnot measured: {e}\n")),
    };
    let mut md = String::from("\n| fit | delay (s) | pairs | terms | before (° RMS) | after (° RMS) | held out: before → after (° RMS) |\n|---|---|---|---|---|---|---|\n");
    let mut rows = Vec::new();
    for (label, delay) in [("ours, delay estimated over ±5 s", Delay::Estimate { min_s: -5.0, max_s: 5.0 }), ("ours, at the reference's delay", Delay::Given(reference.best_delay_s)), ("ours, delay 0", Delay::Given(0.0))] {
        match swing_compass(&log, Some(reference.declination_deg), delay, WaterCurrentMode::Off) {
            Ok((doc, fit, delay_s, _)) => {
                let q = doc.quality.swing.as_ref();
                let held = q.and_then(|q| q.held_out);
                md.push_str(&format!(
                    "| {label} | {delay_s:.2} | {} | {} | {:.2} | {:.2} | {} |\n",
                    fit.samples,
                    fit.terms.count(),
                    fit.before_rms_rad.to_degrees(),
                    fit.residual_rms_rad.to_degrees(),
                    held.map_or("—".into(), |h| format!("{:.2} → {:.2}", h.before_rms_deg, h.after_rms_deg))
                ));
                rows.push(json!({"fit": label, "delay_s": delay_s, "pairs": fit.samples, "terms": fit.terms.count(), "before_rms_deg": fit.before_rms_rad.to_degrees(), "after_rms_deg": fit.residual_rms_rad.to_degrees(), "held_out": held.map(|h| json!({"before_rms_deg": h.before_rms_deg, "after_rms_deg": h.after_rms_deg, "pairs": h.pairs}))}));
            }
            Err(e) => {
                md.push_str(&format!("| {label} | refused: {e} | | | | | |\n"));
                rows.push(json!({"fit": label, "error": e.to_string()}));
            }
        }
    }
    md.push_str(&format!(
        "| numpy 5-term least squares at its best delay (`reference.py`) | {:.2} | {} | 5 | {:.2} | {:.2} | {:.2} → {:.2} |\n",
        reference.best_delay_s, reference.pairs, reference.before_rms_deg, reference.residual_rms_deg, reference.held_out_before_rms_deg, reference.held_out_after_rms_deg
    ));
    let ours = rows.first().and_then(|r| r["after_rms_deg"].as_f64());
    md.push_str(&format!(
        "\nAsked: a residual no worse than a 5-term least squares with the best course delay ({:.2}°): {}.\n",
        reference.residual_rms_deg,
        match ours {
            Some(o) if o <= reference.residual_rms_deg * 1.01 => format!("met ({o:.2}°)"),
            Some(o) => format!("missed ({o:.2}°)"),
            None => "not measured".into(),
        }
    ));
    (json!({"log": "tests/data/cirrus-yacht/compass_log.csv", "declination_deg": reference.declination_deg, "fits": rows, "reference": {"delay_s": reference.best_delay_s, "pairs": reference.pairs, "before_rms_deg": reference.before_rms_deg, "after_rms_deg": reference.residual_rms_deg, "held_out_before_rms_deg": reference.held_out_before_rms_deg, "held_out_after_rms_deg": reference.held_out_after_rms_deg}}), md)
}

/// The `results.md` section "A heading-only compass's swing".
pub fn markdown(compass_md: &str) -> String {
    format!("\n## A heading-only compass's swing\n\nThe yacht Cirrus's real calibration circles: compass − GNSS course before and after the swing, in-sample and on held-out halves (each half corrected by the swing fitted on the other), against numpy's plain least squares.\n{compass_md}")
}

#[cfg(test)]
mod tests {
    /// Only this section: `cargo test -p xtask bench::compass::tests::compass_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn compass_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let (v, md) = super::section(&root);
        eprintln!("{md}");
        assert!(v["fits"].as_array().is_some_and(|f| f.len() == 3), "{v}");
    }
}
