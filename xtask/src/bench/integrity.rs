//! Issue 23: the heading's integrity on real data (BROAD trials 30 and 33,
//! disturbed; 02, 03, 05, 09, undisturbed), by `magcal apply`'s code (the
//! board's per-sample path), with each trial's undisturbed calibration and
//! the rule of the issue (heading error against `truth_heading_deg` with one
//! constant offset removed; rows off by more than 5° are bad).
//!
//! The constants are chosen leave-one-dataset-out: for each trial, among a
//! small grid around [`Tuning::standard`] (gate, gyro scale uncertainty,
//! re-anchoring time), the tuning that does best on the *other* trials
//! (mean fraction of good rows kept ok plus mean fraction of bad rows not
//! ok), reported on the trial left out. The standard tuning's numbers are
//! printed beside it.

use std::path::Path;

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::integrity::Tuning;
use host_tools::compute::apply::{apply_recording, score, ApplyOptions, IntegrityScore};
use host_tools::compute::card::read_reference_column;
use host_tools::data::results::Quality;
use host_tools::data::{CalDoc, Recording};
use serde_json::json;

/// The trials: name, recording, undisturbed calibration.
const TRIALS: [(&str, &str, &str); 6] = [
    ("broad-30", "broad-30/broad_30.csv", "broad-30/broad_30.truth.json"),
    ("broad-33", "broad-33/broad_33.csv", "broad-33/broad_33.truth.json"),
    ("broad-02", "broad-02-limited/02_validate.csv", "broad-02-limited/02.truth.json"),
    ("broad-03", "broad-03/03_validate.csv", "broad-03/03.truth.json"),
    ("broad-05", "broad-05/05_validate.csv", "broad-05/05.truth.json"),
    ("broad-09", "broad-09/09_validate.csv", "broad-09/09.truth.json"),
];

struct Trial {
    rec: Recording,
    truth_deg: Vec<f64>,
    doc: CalDoc,
}

fn load(data: &Path, csv: &str, truth_json: &str) -> Option<Trial> {
    #[derive(serde::Deserialize)]
    struct Truth {
        bias: [f64; 3],
        matrix: [[f64; 3]; 3],
        field_nt: f64,
    }
    let t: Truth = serde_json::from_str(&std::fs::read_to_string(data.join(truth_json)).ok()?).ok()?;
    let doc = CalDoc::new(ModelKind::Full, &FieldCal { bias: t.bias, matrix: t.matrix }, t.field_nt, Quality::default());
    Some(Trial { rec: Recording::read(&data.join(csv)).ok()?, truth_deg: read_reference_column(&data.join(csv), "truth_heading_deg").ok()??, doc })
}

fn run(trial: &Trial, tuning: Tuning<f64>) -> Option<IntegrityScore> {
    let applied = apply_recording(&trial.rec, &trial.doc, &ApplyOptions { tuning: Some(tuning), ..Default::default() }).ok()?;
    Some(score(&applied, &trial.truth_deg, 5.0))
}

/// The grid: gate σ × gyro scale 1σ per √rad × re-anchoring time, s.
fn grid() -> Vec<(f64, f64, f64)> {
    let mut g = Vec::new();
    for gate in [3.0, 3.5, 4.0] {
        for scale in [0.03, 0.05, 0.08] {
            for reanchor in [0.5, 1.0, 2.0] {
                g.push((gate, scale, reanchor));
            }
        }
    }
    g
}

fn tuning((gate, scale, reanchor): (f64, f64, f64)) -> Tuning<f64> {
    Tuning { gate_sigma: gate, scale_var_per_rad: scale * scale, reanchor_s: reanchor, ..Tuning::standard() }
}

/// Fraction of the good rows (|error| ≤ 5°) judged ok.
fn good_ok(s: &IntegrityScore) -> f64 {
    let ok_bad = s.bad_rows as f64 * (1.0 - if s.bad_not_ok_fraction.is_nan() { 0.0 } else { s.bad_not_ok_fraction });
    (s.ok_fraction * s.rows as f64 - ok_bad) / (s.rows - s.bad_rows) as f64
}

/// The objective on a set of trials: the mean fraction of good rows
/// (|error| ≤ 5°) kept ok plus the mean fraction of bad rows not ok (over
/// the trials with at least 5 bad rows). (Choosing instead the most bad rows
/// caught while every trial keeps 90 % of its good rows picks the most
/// lenient tuning when trial 30 is left out — 92.9 % ok, 32 % caught — as
/// trial 33 is caught whatever the tuning: one trial of transient
/// disturbances cannot choose its own thresholds.)
fn objective(scores: &[&IntegrityScore]) -> f64 {
    let kept = scores.iter().map(|s| good_ok(s)).sum::<f64>() / scores.len() as f64;
    let with_bad: Vec<f64> = scores.iter().filter(|s| s.bad_rows >= 5).map(|s| s.bad_not_ok_fraction).collect();
    kept + with_bad.iter().sum::<f64>() / with_bad.len().max(1) as f64
}

fn row(s: &IntegrityScore) -> serde_json::Value {
    json!({
        "rows": s.rows, "ok_pct": 100.0 * s.ok_fraction, "bad_rows": s.bad_rows,
        "bad_not_ok_pct": 100.0 * s.bad_not_ok_fraction, "ok_rms_deg": s.ok_rms_deg,
        "ok_predicted_deg": s.ok_predicted_deg, "sigma_ratio": s.sigma_ratio(),
    })
}

/// The section: per trial, the standard tuning's numbers and the
/// leave-one-out choice's. `root` is the workspace.
pub fn section(root: &Path) -> serde_json::Value {
    let data = root.join("tests/data");
    let trials: Vec<(&str, Trial)> = TRIALS.iter().filter_map(|(n, c, t)| load(&data, c, t).map(|tr| (*n, tr))).collect();
    let grid = grid();
    // scores[g][t]
    let scores: Vec<Vec<Option<IntegrityScore>>> = grid.iter().map(|&g| trials.iter().map(|(_, tr)| run(tr, tuning(g))).collect()).collect();
    let standard: Vec<Option<IntegrityScore>> = trials.iter().map(|(_, tr)| run(tr, Tuning::standard())).collect();
    let mut out = serde_json::Map::new();
    eprintln!("| trial | tuning | rows | ok % | bad rows | bad not ok % | ok RMS ° | predicted ° | ratio |");
    eprintln!("|---|---|---|---|---|---|---|---|---|");
    for (t, (name, _)) in trials.iter().enumerate() {
        let best = (0..grid.len())
            .filter_map(|g| {
                let others: Vec<&IntegrityScore> = (0..trials.len()).filter(|&u| u != t).filter_map(|u| scores[g][u].as_ref()).collect();
                (others.len() + 1 == trials.len()).then(|| (g, objective(&others)))
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        let print = |label: &str, s: &IntegrityScore| {
            eprintln!(
                "| {name} | {label} | {} | {:.1} | {} | {:.1} | {:.2} | {:.2} | {:.2} |",
                s.rows,
                100.0 * s.ok_fraction,
                s.bad_rows,
                100.0 * s.bad_not_ok_fraction,
                s.ok_rms_deg,
                s.ok_predicted_deg,
                s.sigma_ratio()
            )
        };
        let mut entry = serde_json::Map::new();
        if let Some(s) = &standard[t] {
            print("standard", s);
            entry.insert("standard".into(), row(s));
        }
        if let Some((g, _)) = best {
            if let Some(s) = &scores[g][t] {
                let (gate, scale, reanchor) = grid[g];
                print(&format!("left out: gate {gate}σ, scale {scale}, re-anchor {reanchor} s"), s);
                let mut r = row(s);
                r["chosen"] = json!({"gate_sigma": gate, "scale_sigma_per_sqrt_rad": scale, "reanchor_s": reanchor});
                entry.insert("leave_one_out".into(), r);
            }
        }
        out.insert(name.to_string(), serde_json::Value::Object(entry));
    }
    serde_json::Value::Object(out)
}

#[cfg(test)]
mod tests {
    /// Only this section: `cargo test -p xtask bench::integrity::tests::integrity_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn integrity_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let v = super::section(&root);
        eprintln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
        assert_eq!(v.as_object().map(|o| o.len()), Some(6), "{v}");
    }
}
