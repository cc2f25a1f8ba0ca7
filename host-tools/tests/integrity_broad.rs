//! The heading's integrity on real data: BROAD trials (Laidig et al.,
//! *Data* 6(7):72, 2021, CC-BY-4.0, `tests/data/broad-*`) with the optical
//! heading as the reference. Trial 30: a magnet fixed in the room, passed
//! now and then (a transient disturbance); trial 33: a magnet 2 cm from the
//! IMU all along (a new hard iron); trials 02, 03, 05 and 09 (validation
//! parts): undisturbed, for false alarms. Each is run with the IMU's
//! undisturbed calibration (`*.truth.json`: what the board had stored) and
//! nothing else from the data: no inclination (learned), the default
//! scatter (1.2 % of F), `Tuning::standard()`. The rule (issue 23): heading
//! error against `truth_heading_deg` with one constant offset removed, rows
//! off by more than 5° are "bad".

use std::path::{Path, PathBuf};

use calib_core::cal::{FieldCal, ModelKind};
use host_tools::compute::apply::{apply_recording, score, ApplyOptions, IntegrityScore};
use host_tools::compute::card::read_reference_column;
use host_tools::compute::reference::Reference;
use host_tools::data::results::Quality;
use host_tools::data::{CalDoc, Recording};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../tests/data")
        .join(rel)
}

#[derive(serde::Deserialize)]
struct Truth {
    bias: [f64; 3],
    matrix: [[f64; 3]; 3],
    field_nt: f64,
}

/// The BROAD lab's inclination, degrees: the mean of `lab_inclination_deg`
/// over the four undisturbed B/C trials' READMEs (02 69.361, 03 68.050,
/// 05 69.513, 09 68.947), measured with the optical reference — the
/// independent reference the monitor judges the dip against (issue 28).
const LAB_INCLINATION_DEG: f64 = 68.968;

/// The stored calibration as a document: bias, matrix, field_nt, and the
/// lab's inclination as its reference.
fn doc(truth_json: &str) -> CalDoc {
    let t: Truth =
        serde_json::from_str(&std::fs::read_to_string(data(truth_json)).unwrap()).unwrap();
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

#[test]
fn trial_30_a_magnet_passed_in_the_room() {
    let s = judge("broad-30/broad_30.csv", "broad-30/broad_30.truth.json");
    assert_eq!(s.rows, 1222);
    // Measured: 84.1 % of the rows ok; of the 75 rows off by more than 5°,
    // 56.0 % not ok (the floor: 75 % and 50 %). The rows missed are
    // nearly all within 0.11 s after a gap in the file (rows the data's
    // preparation dropped), where the gyro prediction must start again.
    assert_eq!(s.bad_rows, 75);
    assert!(s.ok_fraction >= 0.75, "{s:?}");
    assert!(s.bad_not_ok_fraction >= 0.50, "{s:?}");
    // σ honest on the ok rows: measured 2.38° observed, 1.98° predicted (1.20).
    assert!((0.5..=2.0).contains(&s.sigma_ratio()), "{s:?}");
    assert!(s.ok_rms_deg < 3.0, "{s:?}");
}

#[test]
fn trial_33_a_magnet_on_the_board() {
    let s = judge("broad-33/broad_33.csv", "broad-33/broad_33.truth.json");
    assert_eq!(s.rows, 1388);
    // Measured: every one of the 923 rows off by more than 5° not ok
    // (cal_invalid from 0.66 s on); no row ok: the on-line hard iron does
    // not recover (the magnet 2 cm away distorts beyond an offset: not even
    // an ellipsoid fits these data), and the guard refuses it.
    assert_eq!(s.bad_rows, 923);
    assert!(s.bad_not_ok_fraction >= 0.95, "{s:?}");
    // The rule: the rows called ok (if any) within 3° RMS, honest σ.
    if s.ok_fraction > 0.0 {
        assert!(s.ok_rms_deg <= 3.0, "{s:?}");
        assert!((0.5..=2.0).contains(&s.sigma_ratio()), "{s:?}");
    }
    assert!(s.ok_fraction < 0.05, "{s:?}");
}

#[test]
fn undisturbed_trials_stay_ok_with_an_honest_sigma() {
    // Measured ok fractions 99.1 %, 96.5 %, 99.7 %, 92.8 % (02, 03, 05, 09;
    // 09 moves fastest, to 290°/s, where the gyro's 2 % scale error shows)
    // and observed/predicted σ 0.87, 1.32, 1.12, 1.06.
    for (csv, truth, min_ok) in [
        (
            "broad-02-limited/02_validate.csv",
            "broad-02-limited/02.truth.json",
            0.95,
        ),
        ("broad-03/03_validate.csv", "broad-03/03.truth.json", 0.90),
        ("broad-05/05_validate.csv", "broad-05/05.truth.json", 0.95),
        ("broad-09/09_validate.csv", "broad-09/09.truth.json", 0.85),
    ] {
        let s = judge(csv, truth);
        assert!(s.ok_fraction >= min_ok, "{csv}: {s:?}");
        assert!((0.5..=2.0).contains(&s.sigma_ratio()), "{csv}: {s:?}");
    }
}
