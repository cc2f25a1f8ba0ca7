//! The heading's integrity on real data (BROAD trials 30 and 33,
//! disturbed; 02, 03, 05, 09, undisturbed), by `magcal apply`'s code (the
//! board's per-sample path), with each trial's undisturbed calibration and
//! the scoring rule (heading error against `truth_heading_deg` with one
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
use host_tools::compute::{apply_recording, gate_curve, score, Applied, ApplyOptions, IntegrityScore};
use host_tools::compute::read_reference_column;
use host_tools::doc::Reference;
use host_tools::doc::Quality;
use host_tools::data::Recording;
use host_tools::doc::CalDoc;
use serde_json::json;

/// The BROAD lab's inclination, degrees: the mean of `lab_inclination_deg`
/// over the four undisturbed B/C trials' READMEs (02 69.361, 03 68.050,
/// 05 69.513, 09 68.947), measured with the optical reference: the
/// reference each stored calibration is judged against (an independent
/// inclination, not one learned from the stream judged).
const LAB_INCLINATION_DEG: f64 = 68.968;

/// What a trial holds, and so what the monitor should do on it (the targets each kind is held to).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A magnet fixed in the room, passed now and then: ≥ 60 % of the bad
    /// rows flagged while ≥ 85 % of the good rows stay ok.
    Stationary,
    /// A magnet on the board all along: ≥ 95 % of the bad rows flagged.
    Attached,
    /// No magnet (undisturbed, or tapped): ≥ 95 % of the rows ok.
    NoMagnet,
}

impl Kind {
    fn name(self) -> &'static str {
        match self {
            Kind::Stationary => "stationary magnet",
            Kind::Attached => "attached magnet",
            Kind::NoMagnet => "no magnet",
        }
    }

    /// How far a score falls short of the kind's numbers (0: meets them),
    /// in fractions: the leave-one-out objective's first term.
    fn shortfall(self, s: &IntegrityScore) -> f64 {
        let short = |have: f64, want: f64| {
            if have.is_nan() {
                0.0
            } else {
                (want - have).max(0.0)
            }
        };
        let rms = if s.ok_rms_deg.is_nan() {
            0.0
        } else {
            ((s.ok_rms_deg - OK_RMS_MAX_DEG) / OK_RMS_MAX_DEG).max(0.0)
        };
        rms + match self {
            Kind::Stationary => {
                short(s.bad_not_ok_fraction, 0.60) + short(s.good_ok_fraction, 0.85)
            }
            Kind::Attached => short(s.bad_not_ok_fraction, 0.95),
            Kind::NoMagnet => short(s.ok_fraction, 0.95),
        }
    }

    /// Whether a score meets the kind's numbers.
    fn meets(self, s: &IntegrityScore) -> bool {
        self.shortfall(s) == 0.0
    }
}

/// The heading RMS allowed on rows called ok on every trial, degrees.
const OK_RMS_MAX_DEG: f64 = 3.0;

/// The trials: name, recording, undisturbed calibration, kind. Every real
/// trial with an optical heading: the disturbed ones whole, the undisturbed
/// ones' validation parts.
pub const TRIALS: [(&str, &str, &str, Kind); 10] = [
    (
        "broad-30",
        "broad-30/broad_30.csv",
        "broad-30/broad_30.truth.json",
        Kind::Stationary,
    ),
    (
        "broad-28",
        "broad-25-28-34/broad_28.csv",
        "broad-25-28-34/broad_28.truth.json",
        Kind::Stationary,
    ),
    (
        "broad-33",
        "broad-33/broad_33.csv",
        "broad-33/broad_33.truth.json",
        Kind::Attached,
    ),
    (
        "broad-34",
        "broad-25-28-34/broad_34.csv",
        "broad-25-28-34/broad_34.truth.json",
        Kind::Attached,
    ),
    (
        "broad-25",
        "broad-25-28-34/broad_25.csv",
        "broad-25-28-34/broad_25.truth.json",
        Kind::NoMagnet,
    ),
    (
        "broad-02-limited",
        "broad-02-limited/02_validate.csv",
        "broad-02-limited/02.truth.json",
        Kind::NoMagnet,
    ),
    (
        "broad-03",
        "broad-03/03_validate.csv",
        "broad-03/03.truth.json",
        Kind::NoMagnet,
    ),
    (
        "broad-05",
        "broad-05/05_validate.csv",
        "broad-05/05.truth.json",
        Kind::NoMagnet,
    ),
    (
        "broad-06",
        "broad-06/06_validate.csv",
        "broad-06/06.truth.json",
        Kind::NoMagnet,
    ),
    (
        "broad-09",
        "broad-09/09_validate.csv",
        "broad-09/09.truth.json",
        Kind::NoMagnet,
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

/// One point of the leave-one-out grid: the monitor's knobs that set its
/// operating point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Knobs {
    /// Field gate (magnitude and dip), σ.
    pub field_gate: f64,
    /// Gyro innovation gate, σ.
    pub gyro_gate: f64,
    /// Gyro scale 1σ per √rad turned.
    pub scale: f64,
    /// Re-anchoring time, s.
    pub reanchor_s: f64,
    /// Turn needed to re-anchor, degrees.
    pub reanchor_turn_deg: f64,
    /// Passing time that ends a disturbance, s.
    pub exit_s: f64,
}

impl Knobs {
    /// The shipped point ([`Tuning::standard`]).
    pub fn shipped() -> Self {
        let t = Tuning::<f64>::standard();
        Knobs {
            field_gate: t.gate_sigma,
            gyro_gate: t.gyro_gate_sigma,
            scale: t.scale_var_per_rad.sqrt(),
            reanchor_s: t.reanchor_s,
            reanchor_turn_deg: t.reanchor_turn_rad.to_degrees().round(),
            exit_s: t.exit_s,
        }
    }

    fn tuning(self) -> Tuning<f64> {
        Tuning {
            gate_sigma: self.field_gate,
            gyro_gate_sigma: self.gyro_gate,
            scale_var_per_rad: self.scale * self.scale,
            reanchor_s: self.reanchor_s,
            reanchor_turn_rad: self.reanchor_turn_deg.to_radians(),
            exit_s: self.exit_s,
            ..Tuning::standard()
        }
    }

    fn json(self) -> serde_json::Value {
        json!({"field_gate_sigma": self.field_gate, "gyro_gate_sigma": self.gyro_gate, "scale_sigma_per_sqrt_rad": self.scale, "reanchor_s": self.reanchor_s, "reanchor_turn_deg": self.reanchor_turn_deg, "exit_s": self.exit_s})
    }

    fn label(self) -> String {
        format!(
            "gates {}σ/{}σ, scale {}, re-anchor {} s and {}°, exit {} s",
            self.field_gate,
            self.gyro_gate,
            self.scale,
            self.reanchor_s,
            self.reanchor_turn_deg,
            self.exit_s
        )
    }
}

/// The grid: 5 field gates × 4 gyro gates × 3 gyro scale errors × 3
/// re-anchoring times × 3 re-anchoring turns × 3 exit times (1 620
/// points). Three constants are safety floors, not tuned: the misfit exit
/// and time constant (0.1 over 2 s: with either looser a wrong
/// calibration re-validates itself wherever it happens to fit — a 30 %
/// soft-iron gain error at 0.2 gets 43 rows `ok` up to 6.4° off, over 1 s
/// 111 rows up to 10.2° off, `calib_core` test
/// `the_guard_refuses_an_estimate_that_does_not_explain_the_misfit`; the
/// BROAD trials alone would choose 0.3, or 1 s: trial 28's good rows
/// 84–85 % `ok` instead of 79 % before the start-up recovery,
/// `calib_core::integrity::STARTUP_HOLD_S`, which gives it 89 %), and
/// a re-anchoring turn of at least 45° (without one, any disturbance
/// across the meridian that lasts longer than the re-anchoring time is
/// taken as the truth — test
/// `a_passing_disturbance_is_caught_by_the_gyro_and_ends_with_hysteresis`;
/// the BROAD trials score 0° and 45° alike, within 0.2 % of one trial's
/// good rows).
pub fn grid() -> Vec<Knobs> {
    let mut g = Vec::new();
    for field_gate in [3.0, 3.5, 4.0, 4.5, 5.0] {
        for gyro_gate in [2.5, 3.0, 3.5, 4.0] {
            for scale in [0.03, 0.05, 0.08] {
                for reanchor_s in [0.5, 1.0, 2.0] {
                    for reanchor_turn_deg in [45.0, 90.0, 180.0] {
                        for exit_s in [0.1, 0.3, 0.6] {
                            g.push(Knobs { field_gate, gyro_gate, scale, reanchor_s, reanchor_turn_deg, exit_s });
                        }
                    }
                }
            }
        }
    }
    g
}

/// The leave-one-out objective on a set of trials: the sum of how far
/// each falls short of its kind's numbers ([`Kind::shortfall`]). (An earlier
/// objective maximised the mean fraction of good rows kept plus bad rows caught, on
/// two disturbed trials: the operating point it chose on trial 30 did not
/// carry to trials it never saw.)
fn objective(scores: &[(Kind, &IntegrityScore)]) -> f64 {
    scores.iter().map(|(k, s)| k.shortfall(s)).sum::<f64>()
}

fn row(s: &IntegrityScore, kind: Kind) -> serde_json::Value {
    json!({
        "kind": kind.name(), "meets": kind.meets(s),
        "rows": s.rows, "ok_pct": 100.0 * s.ok_fraction, "bad_rows": s.bad_rows,
        "bad_not_ok_pct": 100.0 * s.bad_not_ok_fraction, "gross_rows": s.gross_rows, "gross_not_ok_pct": 100.0 * s.gross_not_ok_fraction, "good_rows": s.good_rows,
        "good_ok_pct": 100.0 * s.good_ok_fraction, "ok_rms_deg": s.ok_rms_deg,
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
        let mut c = [0usize; IntegrityState::COUNT];
        for i in rows {
            c[applied.rows[i].integrity.index()] += 1;
        }
        let by_name: serde_json::Map<String, serde_json::Value> = IntegrityState::ALL
            .iter()
            .map(|s| (s.name().to_string(), json!(c[s.index()])))
            .collect();
        serde_json::Value::Object(by_name)
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

/// One trial's score as a table row.
fn print_row(name: &str, kind: Kind, label: &str, s: &IntegrityScore) {
    eprintln!(
        "| {name} | {} | {label} | {} | {} | {:.1} | {} | {:.1} | {} | {:.1} | {:.1} | {:.2} | {:.2} | {} |",
        kind.name(),
        s.rows,
        s.bad_rows,
        100.0 * s.bad_not_ok_fraction,
        s.gross_rows,
        100.0 * s.gross_not_ok_fraction,
        s.good_rows,
        100.0 * s.good_ok_fraction,
        100.0 * s.ok_fraction,
        s.ok_rms_deg,
        s.sigma_ratio(),
        if kind.meets(s) { "yes" } else { "**no**" }
    );
}

/// Loads every trial of [`TRIALS`] (`None` for one that does not load).
fn load_all(data: &Path) -> Vec<(&'static str, Kind, Option<Trial>)> {
    TRIALS
        .iter()
        .map(|(n, c, t, k)| (*n, *k, load(data, c, t)))
        .collect()
}

/// The section: per trial, the shipped tuning's numbers, the leave-one-out
/// choice's, and the curve over the gates. `root` is the workspace.
pub fn section(root: &Path) -> serde_json::Value {
    let data = root.join("tests/data");
    let trials = load_all(&data);
    let missing: Vec<&str> = trials
        .iter()
        .filter(|(_, _, t)| t.is_none())
        .map(|(n, _, _)| *n)
        .collect();
    if !missing.is_empty() {
        return json!({"error": format!("trials that do not load: {missing:?}")});
    }
    let loaded: Vec<(&str, Kind, &Trial)> = trials
        .iter()
        .filter_map(|(n, k, t)| t.as_ref().map(|t| (*n, *k, t)))
        .collect();
    let grid = grid();
    // scores[g][t]
    let scores: Vec<Vec<Option<IntegrityScore>>> = grid
        .iter()
        .map(|g| {
            loaded
                .iter()
                .map(|(_, _, tr)| run(tr, g.tuning()))
                .collect()
        })
        .collect();
    let shipped = Knobs::shipped();
    let mut out = serde_json::Map::new();
    // The choice on every trial (what ships, if the leave-one-out choices agree).
    let on_all = best(&grid, &scores, &loaded, None);
    out.insert("shipped".into(), shipped.json());
    // The safety floors ([`grid`]'s doc), reported, not searched.
    let t = Tuning::<f64>::standard();
    out.insert("safety_floors".into(), json!({"misfit_exit": t.misfit_exit, "misfit_tau_s": t.misfit_tau_s, "reanchor_turn_deg_min": 45.0}));
    out.insert(
        "chosen_on_all_trials".into(),
        on_all
            .map(|g| grid[g].json())
            .unwrap_or(serde_json::Value::Null),
    );
    eprintln!(
        "shipped: {} (safety floors: misfit exit {} over {} s); chosen on all trials: {}",
        shipped.label(),
        t.misfit_exit,
        t.misfit_tau_s,
        on_all.map(|g| grid[g].label()).unwrap_or_default()
    );
    eprintln!("| trial | kind | tuning | rows | bad rows (> 5°) | flagged % | rows > 10° | flagged % | good rows (< 2°) | good ok % | all ok % | ok RMS ° | observed/predicted | meets |");
    eprintln!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut trials_out = serde_json::Map::new();
    for (t, (name, kind, tr)) in loaded.iter().enumerate() {
        let mut entry = serde_json::Map::new();
        if let Some(s) = run(tr, shipped.tuning()) {
            print_row(name, *kind, "shipped", &s);
            entry.insert("shipped".into(), row(&s, *kind));
        }
        if let Some(g) = best(&grid, &scores, &loaded, Some(t)) {
            if let Some(s) = &scores[g][t] {
                print_row(name, *kind, &format!("left out ({})", grid[g].label()), s);
                let mut r = row(s, *kind);
                r["chosen"] = grid[g].json();
                entry.insert("leave_one_out".into(), r);
            }
        }
        let curve: Vec<serde_json::Value> = gate_curve(&tr.rec, &tr.doc, &ApplyOptions { tuning: Some(shipped.tuning()), ..Default::default() }, &tr.truth_deg, 5.0)
            .unwrap_or_default()
            .iter()
            .map(|p| {
                let s = &p.score;
                json!({"gates_times": p.gates_times, "shipped": p.gates_times == 1.0, "flagged_pct": 100.0 * s.bad_not_ok_fraction, "good_ok_pct": 100.0 * s.good_ok_fraction, "ok_pct": 100.0 * s.ok_fraction, "ok_rms_deg": s.ok_rms_deg})
            })
            .collect();
        entry.insert("curve".into(), json!(curve));
        trials_out.insert(name.to_string(), serde_json::Value::Object(entry));
    }
    eprintln!("curve (both gates × k; flagged % / good ok % / ok RMS °; * the shipped point):");
    for (name, _, _) in &loaded {
        let c = &trials_out[*name]["curve"];
        let cells: Vec<String> = c
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| {
                format!(
                    "{}{:.2}: {:.0}/{:.0}/{:.1}",
                    if p["shipped"] == true { "*" } else { "" },
                    p["gates_times"].as_f64().unwrap_or(f64::NAN),
                    p["flagged_pct"].as_f64().unwrap_or(f64::NAN),
                    p["good_ok_pct"].as_f64().unwrap_or(f64::NAN),
                    p["ok_rms_deg"].as_f64().unwrap_or(f64::NAN)
                )
            })
            .collect();
        eprintln!("  {name:17} {}", cells.join("  "));
    }
    out.insert("trials".into(), serde_json::Value::Object(trials_out));
    if let Some(g) = glider(&data) {
        out.insert("seaglider-sg236".into(), g);
    }
    serde_json::Value::Object(out)
}

/// The grid point that does best on every trial but `left_out` (all of
/// them with `None`); ties go to the earlier point.
fn best(
    grid: &[Knobs],
    scores: &[Vec<Option<IntegrityScore>>],
    trials: &[(&str, Kind, &Trial)],
    left_out: Option<usize>,
) -> Option<usize> {
    (0..grid.len())
        .filter_map(|g| {
            let others: Vec<(Kind, &IntegrityScore)> = (0..trials.len())
                .filter(|&u| Some(u) != left_out)
                .filter_map(|u| scores[g][u].as_ref().map(|s| (trials[u].1, s)))
                .collect();
            (others.len() + usize::from(left_out.is_some()) == trials.len())
                .then(|| (g, objective(&others)))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(g, _)| g)
}

/// The shipped tuning's rows only (what the targets are about; no
/// leave-one-out grid, no curve): `{"trials": {name: {"shipped": row}}}`,
/// the shape of [`section`]'s.
pub fn shipped_only(root: &Path) -> serde_json::Value {
    let trials = load_all(&root.join("tests/data"));
    let mut out = serde_json::Map::new();
    for (name, kind, tr) in &trials {
        let entry = match tr.as_ref().and_then(|tr| run(tr, Knobs::shipped().tuning())) {
            Some(s) => {
                print_row(name, *kind, "shipped", &s);
                json!({"shipped": row(&s, *kind)})
            }
            None => json!({"error": "the trial does not load"}),
        };
        out.insert(name.to_string(), entry);
    }
    json!({ "trials": out })
}

/// The section's targets, on the shipped tuning, per trial by its kind: a
/// stationary magnet ≥ 60 % of the bad rows flagged with ≥ 85 % of the good
/// rows `ok`; an attached one ≥ 95 % flagged; no magnet ≥ 95 % of the rows
/// `ok`; on every trial with `ok` rows their heading RMS ≤ 3°. A missed one
/// is held at what was measured ([`HELD`]). `v` is [`section`]'s or
/// [`shipped_only`]'s JSON.
pub fn targets(v: &serde_json::Value) -> Vec<super::targets::Target> {
    use super::targets::{Bound, Target};
    let mut out = Vec::new();
    for (name, _, _, kind) in TRIALS {
        let row = &v["trials"][name]["shipped"];
        let mut add = |key: &'static str, what: &str, bound: Bound| {
            let t = Target::new("integrity", format!("{name} ({}): {what}", kind.name()), row[key].as_f64(), bound);
            out.push(match HELD.iter().find(|h| h.0 == name && h.1 == key) {
                Some(&(_, _, held, why)) => t.held(held, why),
                None => t,
            });
        };
        match kind {
            Kind::Stationary => {
                add("bad_not_ok_pct", "bad rows flagged, %", Bound::AtLeast(60.0));
                add("good_ok_pct", "good rows ok, %", Bound::AtLeast(85.0));
            }
            Kind::Attached => add("bad_not_ok_pct", "bad rows flagged, %", Bound::AtLeast(95.0)),
            Kind::NoMagnet => add("ok_pct", "rows ok, %", Bound::AtLeast(95.0)),
        }
        if row["ok_pct"].as_f64().is_none_or(|p| p > 0.0) {
            add("ok_rms_deg", "heading RMS on the ok rows, °", Bound::AtMost(OK_RMS_MAX_DEG));
        }
    }
    out
}

/// The missed targets, held at what the shipped tuning measured (trial,
/// figure, bound, why): broad-30 27.2 % flagged (`magcal apply` with the
/// lab's inclination, the bench's rule; `xtask/python/integrity_loo.py`
/// ports the monitor exactly, 2026-11-27).
const HELD: [(&str, &str, super::targets::Bound, &str); 1] = [
    ("broad-30", "bad_not_ok_pct", super::targets::Bound::AtLeast(27.0), "rows 5–8° off whose field fits and whose heading change the gyro confirms: the stored calibration's own error tail after the file's gaps"),
];

#[cfg(test)]
mod tests {
    /// Only this section: `cargo test -p xtask bench::integrity::tests::integrity_section -- --ignored --nocapture`.
    #[test]
    #[ignore = "a benchmark: prints its numbers"]
    fn integrity_section() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let v = super::section(&root);
        eprintln!("{}", serde_json::to_string_pretty(&v).unwrap_or_default());
        assert_eq!(
            v["trials"].as_object().map(|o| o.len()),
            Some(super::TRIALS.len()),
            "{v}"
        );
        let misses = crate::bench::targets::check(&super::targets(&v)).1;
        assert!(misses.is_empty(), "{misses:?}");
    }
}

