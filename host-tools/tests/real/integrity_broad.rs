//! The heading's integrity on real data: BROAD trials (Laidig et al.,
//! *Data* 6(7):72, 2021, CC-BY-4.0, `tests/data/broad-*`) with the optical
//! heading as the reference. Trials 30 and 28: a magnet fixed in the room,
//! passed now and then (a transient disturbance); 33 and 34: a magnet 2 and
//! 3 cm from the IMU all along (a new hard iron); 25: tapped, no magnet;
//! 02, 03, 05, 06 and 09 (validation parts): undisturbed, for false alarms.
//! The monitor's constants were chosen leave-one-trial-out over all of them
//! (`xtask/src/bench/integrity.rs`). Each is run with the IMU's
//! undisturbed calibration (`*.truth.json`: what the board had stored), the
//! lab's inclination as its reference (the dip learned within the
//! reference's allowance), the default scatter (1.2 % of F),
//! `Tuning::standard()`. The rule: heading error against
//! `truth_heading_deg` with one constant offset removed (robustly:
//! `robust_offset_deg`), rows off by more than 5° "bad", within 2° "good".


use calib_core::cal::{FieldCal, ModelKind};
use host_tools::compute::{apply_recording, score, ApplyOptions, IntegrityScore};
use host_tools::compute::read_reference_column;
use host_tools::doc::Reference;
use host_tools::doc::Quality;
use host_tools::data::Recording;
use host_tools::doc::CalDoc;

use super::data;

#[derive(serde::Deserialize)]
struct Truth {
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
    field_nt: f64,
}

/// The BROAD lab's inclination, degrees: the mean of `lab_inclination_deg`
/// over the four undisturbed B/C trials' READMEs (02 69.361, 03 68.050,
/// 05 69.513, 09 68.947), measured with the optical reference — the
/// independent reference the monitor judges the dip against (not one learned from the stream judged).
const LAB_INCLINATION_DEG: f64 = 68.968;

/// The stored calibration as a document: bias, matrix, field_nt, and the
/// lab's inclination as its reference.
fn doc(truth_json: &str) -> CalDoc {
    doc_x_gain(truth_json, 1.0)
}

/// [`doc`] with the matrix's x row ×`gain` (a soft-iron gain error on x).
fn doc_x_gain(truth_json: &str, gain: f64) -> CalDoc {
    let mut t: Truth =
        serde_json::from_str(&std::fs::read_to_string(data(truth_json)).unwrap()).unwrap();
    t.matrix[0] = t.matrix[0].map(|v| gain * v);
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
    doc
}

fn judge(csv: &str, truth_json: &str) -> IntegrityScore {
    let rec = Recording::read(&data(csv)).unwrap();
    let truth = read_reference_column(&data(csv), "truth_heading_deg")
        .unwrap()
        .unwrap();
    let applied = apply_recording(&rec, &doc(truth_json), &ApplyOptions::default()).unwrap();
    let s = score(&applied, &truth, 5.0);
    println!("{csv}: {s:?} ratio {:.2}", s.sigma_ratio());
    s
}

/// The rule's numbers the tests check, with the measured values beside.
struct Want {
    /// Least fraction of the rows off by more than 5° not ok.
    flagged: f64,
    /// Least fraction of the rows off by more than 10° not ok.
    gross_flagged: f64,
    /// Least fraction of the rows within 2° ok.
    good_ok: f64,
}

fn check(s: &IntegrityScore, want: Want) {
    if s.bad_rows > 0 {
        assert!(s.bad_not_ok_fraction >= want.flagged, "{s:?}");
    }
    if s.gross_rows > 0 {
        assert!(s.gross_not_ok_fraction >= want.gross_flagged, "{s:?}");
    }
    assert!(s.good_ok_fraction >= want.good_ok, "{s:?}");
    // The rows called ok: within 3° RMS (the target) and an honest σ.
    if s.ok_fraction > 0.0 {
        assert!(s.ok_rms_deg <= 3.05, "{s:?}");
        assert!((0.5..=2.0).contains(&s.sigma_ratio()), "{s:?}");
    }
}

#[test]
fn trial_30_a_magnet_passed_in_the_room() {
    let s = judge("broad-30/broad_30.csv", "broad-30/broad_30.truth.json");
    assert_eq!(s.rows, 1222);
    // Measured: of the 81 rows off by more than 5°, 27.2 % not ok, and all
    // 11 off by more than 10°; 96.7 % of the 707 rows within 2° ok; ok rows
    // 2.48° RMS against 1.98° predicted (1.25). The rows 5–8° off that pass
    // are the stored calibration's own error (their neighbours are 0–3° off,
    // their field fits, the gyro agrees): nearly all just after a gap in
    // the file, where the gyro prediction must start again. Before the gyro
    // was integrated over each step with its mean rate, its prediction
    // strayed where the rate reverses at 300°/s: 89.4 % of the good rows ok
    // and, by the same stray flags, 48.1 % of the bad ones not ok.
    assert_eq!(s.bad_rows, 81);
    check(
        &s,
        Want {
            flagged: 0.22,
            gross_flagged: 0.95,
            good_ok: 0.93,
        },
    );
}

#[test]
fn trial_28_another_magnet_in_the_room_not_tuned_on() {
    let s = judge(
        "broad-25-28-34/broad_28.csv",
        "broad-25-28-34/broad_28.truth.json",
    );
    assert_eq!(s.rows, 970);
    // Measured: 61.1 % of the 175 rows off by more than 5° not ok, 98.7 %
    // of the 77 off by more than 10°; 89.1 % of the 423 rows within 2° ok
    // (79.9 % before the start-up recovery: the magnet's first pass, at the
    // file's start, left the calibration invalid until the misfit fraction
    // fell below a tenth, 3.3 s of a right heading; 78.7 % before the
    // gyro's step mean and its vouching for fields off the reference); ok
    // rows 2.98° RMS (1.49 × predicted). An "A" trial: its dip is 0.6–1°
    // off the lab's, inside the reference's allowance.
    check(
        &s,
        Want {
            flagged: 0.58,
            gross_flagged: 0.95,
            good_ok: 0.87,
        },
    );
}

#[test]
fn magnets_on_the_board_are_flagged_throughout() {
    // Measured: every row off by more than 5° not ok (33: 784, 34: 600),
    // no row ok: the on-line hard iron is never applied (33: the magnet 2 cm
    // away distorts beyond an offset) or never confirmed by the gyro.
    for (csv, truth) in [
        ("broad-33/broad_33.csv", "broad-33/broad_33.truth.json"),
        (
            "broad-25-28-34/broad_34.csv",
            "broad-25-28-34/broad_34.truth.json",
        ),
    ] {
        let s = judge(csv, truth);
        check(
            &s,
            Want {
                flagged: 0.95,
                gross_flagged: 0.95,
                good_ok: 0.0,
            },
        );
        assert!(s.ok_fraction < 0.05, "{csv}: {s:?}");
    }
}

#[test]
fn no_magnet_stays_ok_with_an_honest_sigma() {
    // Measured ok fractions: 25 (tapped, not tuned on) 99.9 %, 02 100 %,
    // 03 100 %, 05 100 %, 09 96.6 % (09 moves fastest, to 290°/s, where
    // the gyro's 2 % scale error shows); observed/predicted σ 0.95, 0.86,
    // 1.34, 1.12, 1.06. Trial 06 ("A", its field 5–6 % off the
    // calibration's for 4 s at 156–160 s, its headings 3° off there, while
    // it holds still): 99.3 % ok, ratio 1.18 — 81.2 % before, when the
    // field alone decided there and the gyro's end-of-step rate strayed
    // at its 300°/s reversals.
    let mut ratios = Vec::new();
    for (csv, truth, min_ok) in [
        (
            "broad-25-28-34/broad_25.csv",
            "broad-25-28-34/broad_25.truth.json",
            0.97,
        ),
        (
            "broad-02-limited/02_validate.csv",
            "broad-02-limited/02.truth.json",
            0.97,
        ),
        ("broad-03/03_validate.csv", "broad-03/03.truth.json", 0.97),
        ("broad-05/05_validate.csv", "broad-05/05.truth.json", 0.97),
        ("broad-06/06_validate.csv", "broad-06/06.truth.json", 0.95),
        ("broad-09/09_validate.csv", "broad-09/09.truth.json", 0.93),
    ] {
        let s = judge(csv, truth);
        assert!(s.ok_fraction >= min_ok, "{csv}: {s:?}");
        check(
            &s,
            Want {
                flagged: 0.0,
                gross_flagged: 0.0,
                good_ok: min_ok,
            },
        );
        ratios.push(s.sigma_ratio());
    }
    // One trial's ratio is one draw (each check above accepts 0.5–2); the
    // pool over the six is held to 0.7–1.4, as the joint back-stepping's
    // prediction is. Measured: 0.95, 0.86, 1.34, 1.12, 1.12, 1.06; pooled
    // (RMS of the ratios) 1.09.
    let pooled = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    println!("observed / predicted σ: {ratios:?}, pooled {pooled:.3}");
    assert!((0.7..=1.4).contains(&pooled), "{pooled}: {ratios:?}");
}

/// A transient on an undisturbed trial, judged as `magcal apply` judges it
/// with the trial's true calibration and the lab's site (IGRF-14's
/// inclination at 52.51° N, 13.32° E, 2020-06-01: 67.94°): trial 03's
/// validation part (its rows come in bursts of about 0.35 s between the
/// optical reference's dropouts of 2–6 s) with 60 counts (about 5 900 nT,
/// 13 % of F) added to x for 3 s from 144.52 s — a magnet carried past.
/// The calibration is judged invalid; the on-line estimator, fed the
/// transient and the clean bursts after it, forms an offset of about
/// 2 000 nT that fits the clean field too, and the guard applies it at
/// 152.4 s; the vehicle never turns the 90° a burst would need to confirm
/// it. Before the stored calibration's own check, every row from 152.5 s to
/// the end (166 s) was `cal_invalid` (0 of the 120 rows after 160 s `ok`;
/// 86 of the 342 rows `ok`). Now the stored field's misfit fraction falls
/// below the exit and its headings agree with the gyro for
/// `Tuning::recover_s`: the estimate is withdrawn at 164.7 s and the rows
/// after it are `ok` (measured: 39 of the 120 after 160 s, 125 of 342, the
/// last row `ok`; every row off by more than 10° flagged).
#[test]
fn a_transient_on_an_undisturbed_trial_ends_and_the_calibration_is_ok_again() {
    let path = data("broad-03/03_validate.csv");
    let mut rec = Recording::read(&path).unwrap();
    let t_s = rec.t_s.clone().unwrap();
    for (m, t) in rec.mag.iter_mut().zip(&t_s) {
        if (144.52..147.52).contains(t) {
            m[0] += 60.0;
        }
    }
    let truth = read_reference_column(&path, "truth_heading_deg").unwrap().unwrap();
    let mut doc = doc("broad-03/03.truth.json");
    doc.reference = None;
    let site = host_tools::geomag::Site::new(52.51, 13.32, "2020-06-01").unwrap();
    let inclination_deg = site.field().unwrap().inclination_deg();
    assert!((inclination_deg - 67.94).abs() < 0.01, "{inclination_deg}");
    let opts = ApplyOptions { inclination_deg: Some(inclination_deg), ..Default::default() };
    let applied = apply_recording(&rec, &doc, &opts).unwrap();
    let ok = |i: usize| applied.rows[i].integrity == calib_core::integrity::IntegrityState::Ok;
    let late: Vec<usize> = (0..t_s.len()).filter(|&i| t_s[i] >= 160.0).collect();
    let late_ok = late.iter().filter(|&&i| ok(i)).count();
    let s = score(&applied, &truth, 5.0);
    println!("rows after 160 s: {} ok of {}; {s:?}", late_ok, late.len());
    assert_eq!(late.len(), 120);
    // Measured 39 (0 before).
    assert!(late_ok >= 30, "{late_ok} of {} rows after 160 s ok", late.len());
    assert!(ok(t_s.len() - 1), "the last row is not ok");
    // The transient's rows stay flagged: measured 100 % of those > 10° off.
    assert!(s.gross_not_ok_fraction >= 0.95, "{s:?}");
    assert!(s.ok_rms_deg <= 3.05, "{s:?}");
}

/// The stored calibration with its x row ×`gain` (a soft-iron gain error on
/// x), judged against the lab's inclination, on `csv`: of the rows after the
/// first 10 s (the bench's rule for a wrong calibration) off by more than
/// 5° from the optical heading (after one robust offset over the whole
/// trial), how many, and the fraction not `ok`.
fn x_gain_rows_flagged(csv: &str, truth_json: &str, gain: f64) -> (usize, f64) {
    let rec = Recording::read(&data(csv)).unwrap();
    let truth = read_reference_column(&data(csv), "truth_heading_deg").unwrap().unwrap();
    let doc = doc_x_gain(truth_json, gain);
    let applied = apply_recording(&rec, &doc, &ApplyOptions::default()).unwrap();
    let t = rec.t_s.clone().unwrap();
    let errors: Vec<Option<f64>> = applied
        .rows
        .iter()
        .zip(&truth)
        .map(|(r, tr)| r.heading_deg.map(|h| h - tr))
        .collect();
    let all: Vec<f64> = errors.iter().flatten().copied().collect();
    let offset = host_tools::compute::robust_offset_deg(&all);
    let wrap = |e: f64| (e + 540.0).rem_euclid(360.0) - 180.0;
    let bad: Vec<bool> = errors
        .iter()
        .zip(&applied.rows)
        .zip(&t)
        .filter(|&((e, _), &ti)| ti >= t[0] + 10.0 && e.is_some_and(|e| wrap(e - offset).abs() > 5.0))
        .map(|((_, r), _)| r.integrity != calib_core::integrity::IntegrityState::Ok)
        .collect();
    let flagged = bad.iter().filter(|b| **b).count() as f64 / bad.len().max(1) as f64;
    println!("{csv} x gain ×{gain}: {} rows > 5° off after 10 s, {:.1} % not ok", bad.len(), 100.0 * flagged);
    (bad.len(), flagged)
}

#[test]
fn a_soft_iron_gain_error_is_flagged_on_every_trial_that_turns() {
    // A 30 % gain error on x: a heading error of about ±7.5° twice a turn,
    // which |F|, the dip and the gyro's allowance over a turn all let
    // through; the horizontal intensity's two-cycle test finds it. The
    // trials whose optical heading covers the whole circle (30, 28, 03, 05,
    // 09; 33 and 34 carry a magnet and are flagged throughout). Measured
    // rows > 5° off after 10 s not ok, before the test → with it:
    // 30 93.7 → 100 % (556 rows), 28 99.2 → 100 % (520), 03 16.7 → 100 %
    // (36), 05 48.1 → 100 % (285), 09 97.0 → 97.0 % (236: the on-line hard
    // iron, applied and withdrawn, restarts the test's sums each time).
    for (csv, truth) in [
        ("broad-30/broad_30.csv", "broad-30/broad_30.truth.json"),
        ("broad-25-28-34/broad_28.csv", "broad-25-28-34/broad_28.truth.json"),
        ("broad-03/03_validate.csv", "broad-03/03.truth.json"),
        ("broad-05/05_validate.csv", "broad-05/05.truth.json"),
        ("broad-09/09_validate.csv", "broad-09/09.truth.json"),
    ] {
        let (rows, flagged) = x_gain_rows_flagged(csv, truth, 1.3);
        assert!(rows >= 30, "{csv}: {rows}");
        assert!(flagged >= 0.95, "{csv}: {:.1} % of {rows} rows > 5° off flagged", 100.0 * flagged);
    }
}
