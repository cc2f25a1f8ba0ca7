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
//!
//! Seaglider SG236 (`tests/data/seaglider-sg236`, no gyro, a sample every
//! 5–9 s) has no independent heading reference (GPS at the surface only; its
//! `onboard_heading_deg` is the same compass with the glider's own
//! calibration): its row ([`glider`]) gives what can be judged without one —
//! the states with the glider's own calibration and the field's magnitude
//! and dip against IGRF-14 on the rows below 3 m, `ok` and not — and takes
//! no part in the leave-one-out choice.

use std::path::Path;

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::level;
use calib_core::integrity::IntegrityState;
use calib_core::integrity::Tuning;
use host_tools::compute::apply::{apply_recording, score, Applied, ApplyOptions, IntegrityScore};
use host_tools::compute::card::read_reference_column;
use host_tools::compute::reference::Reference;
use host_tools::data::results::Quality;
use host_tools::data::{CalDoc, Recording};
use serde_json::json;

/// The BROAD lab's inclination, degrees: the mean of `lab_inclination_deg`
/// over the four undisturbed B/C trials' READMEs (02 69.361, 03 68.050,
/// 05 69.513, 09 68.947), measured with the optical reference: the
/// reference each stored calibration is judged against (issue 28).
const LAB_INCLINATION_DEG: f64 = 68.968;

/// The trials: name, recording, undisturbed calibration.
const TRIALS: [(&str, &str, &str); 6] = [
    (
        "broad-30",
        "broad-30/broad_30.csv",
        "broad-30/broad_30.truth.json",
    ),
    (
        "broad-33",
        "broad-33/broad_33.csv",
        "broad-33/broad_33.truth.json",
    ),
    (
        "broad-02-limited",
        "broad-02-limited/02_validate.csv",
        "broad-02-limited/02.truth.json",
    ),
    (
        "broad-03",
        "broad-03/03_validate.csv",
        "broad-03/03.truth.json",
    ),
    (
        "broad-05",
        "broad-05/05_validate.csv",
        "broad-05/05.truth.json",
    ),
    (
        "broad-09",
        "broad-09/09_validate.csv",
        "broad-09/09.truth.json",
    ),
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
    let t: Truth =
        serde_json::from_str(&std::fs::read_to_string(data.join(truth_json)).ok()?).ok()?;
    let mut doc = CalDoc::new(
        ModelKind::Full,
        &FieldCal {
            bias: t.bias,
            matrix: t.matrix,
        },
        t.field_nt,
        Quality::default(),
    );
    doc.reference = Some(Reference {
        inclination_deg: Some(LAB_INCLINATION_DEG),
        ..Reference::user_intensity(t.field_nt)
    });
    Some(Trial {
        rec: Recording::read(&data.join(csv)).ok()?,
        truth_deg: read_reference_column(&data.join(csv), "truth_heading_deg").ok()??,
        doc,
    })
}

fn run(trial: &Trial, tuning: Tuning<f64>) -> Option<IntegrityScore> {
    let applied = apply_recording(
        &trial.rec,
        &trial.doc,
        &ApplyOptions {
            tuning: Some(tuning),
            ..Default::default()
        },
    )
    .ok()?;
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
    Tuning {
        gate_sigma: gate,
        scale_var_per_rad: scale * scale,
        reanchor_s: reanchor,
        ..Tuning::standard()
    }
}

/// Fraction of the good rows (|error| ≤ 5°) judged ok.
fn good_ok(s: &IntegrityScore) -> f64 {
    let ok_bad = s.bad_rows as f64
        * (1.0
            - if s.bad_not_ok_fraction.is_nan() {
                0.0
            } else {
                s.bad_not_ok_fraction
            });
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
    let with_bad: Vec<f64> = scores
        .iter()
        .filter(|s| s.bad_rows >= 5)
        .map(|s| s.bad_not_ok_fraction)
        .collect();
    kept + with_bad.iter().sum::<f64>() / with_bad.len().max(1) as f64
}

fn row(s: &IntegrityScore) -> serde_json::Value {
    json!({
        "rows": s.rows, "ok_pct": 100.0 * s.ok_fraction, "bad_rows": s.bad_rows,
        "bad_not_ok_pct": 100.0 * s.bad_not_ok_fraction, "ok_rms_deg": s.ok_rms_deg,
        "ok_predicted_deg": s.ok_predicted_deg, "sigma_ratio": s.sigma_ratio(),
    })
}

/// The glider's site (its README): IGRF-14 at 46.902° N, −124.894° E,
/// 2023-06-01, sea level.
const GLIDER_FIELD_NT: f64 = 52_203.0;
/// See [`GLIDER_FIELD_NT`], degrees.
const GLIDER_INCLINATION_DEG: f64 = 67.82;
/// The glider is judged below this depth (its README's rule: at the
/// surface it pitches −60…−75° beside its antenna's electronics).
const GLIDER_JUDGE_DEPTH_M: f64 = 3.0;

/// The glider's validation dives with its own calibration
/// (`onboard_calibration.json`, as the real-data bench's floor).
struct Glider {
    rec: Recording,
    depth_m: Vec<f64>,
    doc: CalDoc,
}

fn load_glider(dir: &Path) -> Option<Glider> {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("onboard_calibration.json")).ok()?)
            .ok()?;
    let bias: [f64; 3] = serde_json::from_value(v["bias"].clone()).ok()?;
    let matrix: [[f64; 3]; 3] = serde_json::from_value(v["matrix"].clone()).ok()?;
    let mut doc = CalDoc::new(
        ModelKind::Full,
        &FieldCal { bias, matrix },
        v["field_nt"].as_f64()?,
        Quality::default(),
    );
    // The world model at the glider's site (its README) is the reference.
    let site = host_tools::geomag::Site::new(46.902, -124.894, "2023-06-01").ok()?;
    doc.reference = Some(Reference::world_model(site, &site.field().ok()?));
    let path = dir.join("sg236_validate.csv");
    Some(Glider {
        rec: Recording::read(&path).ok()?,
        depth_m: read_reference_column(&path, "depth_m").ok()??,
        doc,
    })
}

/// Mean, 1σ and RMS about a reference of `v` (NaN when empty).
fn spread(v: &[f64], reference: f64) -> (f64, f64, f64) {
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / (n - 1.0).max(1.0)).sqrt();
    let rms = (v
        .iter()
        .map(|x| (x - reference) * (x - reference))
        .sum::<f64>()
        / n)
        .sqrt();
    (mean, sd, rms)
}

/// |F| and dip of the calibrated field on the rows `keep`: mean, 1σ and
/// RMS about IGRF-14's, as JSON.
fn field_residuals(applied: &Applied, rec: &Recording, keep: &[usize]) -> serde_json::Value {
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else {
        return json!(null);
    };
    let (mut mag, mut dip) = (vec![], vec![]);
    for &i in keep {
        let h = applied.rows[i].field_nt;
        let l = level(h, roll[i].to_radians(), pitch[i].to_radians());
        mag.push((h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt());
        dip.push(l[2].atan2(l[0].hypot(l[1])).to_degrees());
    }
    let (m_mean, m_sd, m_rms) = spread(&mag, GLIDER_FIELD_NT);
    let (d_mean, d_sd, d_rms) = spread(&dip, GLIDER_INCLINATION_DEG);
    json!({
        "rows": keep.len(),
        "field_mean_nt": m_mean, "field_sd_pct": 100.0 * m_sd / m_mean, "field_rms_vs_igrf_nt": m_rms,
        "dip_mean_deg": d_mean, "dip_sd_deg": d_sd, "dip_rms_vs_igrf_deg": d_rms,
    })
}

/// The glider's row: the states (all rows, and below 3 m), the field's
/// magnitude and dip residuals on the `ok` rows and the others below 3 m,
/// the σ the board would stream on the `ok` rows — and no observed heading
/// error, for want of a reference.
fn glider(data: &Path) -> Option<serde_json::Value> {
    let g = load_glider(&data.join("seaglider-sg236"))?;
    let applied = apply_recording(&g.rec, &g.doc, &ApplyOptions::default()).ok()?;
    let below: Vec<usize> = (0..applied.rows.len())
        .filter(|&i| g.depth_m.get(i).is_some_and(|d| *d > GLIDER_JUDGE_DEPTH_M))
        .collect();
    let count = |rows: &mut dyn Iterator<Item = usize>| {
        let mut c = [0usize; 5];
        for i in rows {
            c[applied.rows[i].integrity as usize] += 1;
        }
        json!({"ok": c[0], "disturbed": c[1], "cal_invalid": c[2], "no_attitude": c[3], "unjudged": c[4]})
    };
    let (ok, not_ok): (Vec<usize>, Vec<usize>) = below
        .iter()
        .partition(|&&i| applied.rows[i].integrity == IntegrityState::Ok);
    let sigma: Vec<f64> = ok
        .iter()
        .filter_map(|&i| applied.rows[i].heading_sigma_deg)
        .collect();
    let predicted = (sigma.iter().map(|s| s * s).sum::<f64>() / sigma.len() as f64).sqrt();
    let v = json!({
        "calibration": "the glider's own (onboard_calibration.json)",
        "heading_reference": null,
        "note": "no independent heading reference (GPS at the surface only; onboard_heading_deg is the same compass): no observed heading error, no observed/predicted sigma",
        "rows": applied.rows.len(),
        "states": count(&mut (0..applied.rows.len())),
        "ok_pct": 100.0 * applied.rows.iter().filter(|r| r.integrity == IntegrityState::Ok).count() as f64 / applied.rows.len() as f64,
        "below_3m": {"rows": below.len(), "states": count(&mut below.iter().copied()), "ok_pct": 100.0 * ok.len() as f64 / below.len() as f64},
        "ok_predicted_deg": predicted,
        "inclination_in_use_deg": applied.inclination_deg,
        "field_sigma_nt": applied.reference.field_sigma_nt,
        "residuals_below_3m": {"ok": field_residuals(&applied, &g.rec, &ok), "not_ok": field_residuals(&applied, &g.rec, &not_ok), "all": field_residuals(&applied, &g.rec, &below)},
    });
    let b = &v["below_3m"];
    let r = &v["residuals_below_3m"];
    eprintln!(
        "| seaglider-sg236 | standard, the glider's own calibration | {} | {:.1} (below 3 m: {:.1} of {}) | no heading reference | — | — | {:.2} | — |",
        applied.rows.len(),
        v["ok_pct"].as_f64().unwrap_or(f64::NAN),
        b["ok_pct"].as_f64().unwrap_or(f64::NAN),
        below.len(),
        predicted
    );
    for part in ["ok", "not_ok", "all"] {
        let x = &r[part];
        eprintln!(
            "  glider below 3 m, {part} rows ({}): |F| {:.0} nT (1σ {:.2} %, RMS vs IGRF {:.0} nT), dip {:.2}° (1σ {:.2}°, RMS vs IGRF {:.2}°)",
            x["rows"], x["field_mean_nt"].as_f64().unwrap_or(f64::NAN), x["field_sd_pct"].as_f64().unwrap_or(f64::NAN), x["field_rms_vs_igrf_nt"].as_f64().unwrap_or(f64::NAN),
            x["dip_mean_deg"].as_f64().unwrap_or(f64::NAN), x["dip_sd_deg"].as_f64().unwrap_or(f64::NAN), x["dip_rms_vs_igrf_deg"].as_f64().unwrap_or(f64::NAN)
        );
    }
    eprintln!(
        "  glider states (all rows): {}; below 3 m: {}",
        v["states"], b["states"]
    );
    Some(v)
}

/// The section: per trial, the standard tuning's numbers and the
/// leave-one-out choice's. `root` is the workspace.
pub fn section(root: &Path) -> serde_json::Value {
    let data = root.join("tests/data");
    let trials: Vec<(&str, Trial)> = TRIALS
        .iter()
        .filter_map(|(n, c, t)| load(&data, c, t).map(|tr| (*n, tr)))
        .collect();
    let grid = grid();
    // scores[g][t]
    let scores: Vec<Vec<Option<IntegrityScore>>> = grid
        .iter()
        .map(|&g| trials.iter().map(|(_, tr)| run(tr, tuning(g))).collect())
        .collect();
    let standard: Vec<Option<IntegrityScore>> = trials
        .iter()
        .map(|(_, tr)| run(tr, Tuning::standard()))
        .collect();
    let mut out = serde_json::Map::new();
    eprintln!("| trial | tuning | rows | ok % | bad rows | bad not ok % | ok RMS ° | predicted ° | ratio |");
    eprintln!("|---|---|---|---|---|---|---|---|---|");
    for (t, (name, _)) in trials.iter().enumerate() {
        let best = (0..grid.len())
            .filter_map(|g| {
                let others: Vec<&IntegrityScore> = (0..trials.len())
                    .filter(|&u| u != t)
                    .filter_map(|u| scores[g][u].as_ref())
                    .collect();
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
                print(
                    &format!("left out: gate {gate}σ, scale {scale}, re-anchor {reanchor} s"),
                    s,
                );
                let mut r = row(s);
                r["chosen"] = json!({"gate_sigma": gate, "scale_sigma_per_sqrt_rad": scale, "reanchor_s": reanchor});
                entry.insert("leave_one_out".into(), r);
            }
        }
        out.insert(name.to_string(), serde_json::Value::Object(entry));
    }
    if let Some(g) = glider(&data) {
        out.insert("seaglider-sg236".into(), g);
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
        assert_eq!(v.as_object().map(|o| o.len()), Some(7), "{v}");
    }
}
