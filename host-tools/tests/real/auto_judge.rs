//! `fit` without `--model` (auto) on a thin, fast BROAD cut: 294 rows of
//! trial 02's calibration part (rows 98–391: rotation with three breaks,
//! headings within 150°, |roll|, |pitch| ≤ 25°), judged on the trial's
//! whole validation part against the optical heading after one constant
//! offset (`tests/data/broad-02-limited`, CC-BY-4.0). The floor is the
//! trial's true calibration (`02.truth.json`): 1.70°.

use std::path::PathBuf;

use calib_core::cal::{FieldCal, ModelKind};
use calib_core::heading::magnetic_heading_rad;
use host_tools::compute::{fit_auto, fit_auto_judged, YawJudge};
use host_tools::doc::{HeldOutBasis, MAX_HELD_OUT_DEG};
use host_tools::compute::{heading_rms_after_offset_deg, ComputeError, FitOptions, GyroLag};
use host_tools::data::Recording;

use super::real_gyro::{optical_deg, Truth};

fn dir() -> PathBuf {
    super::data("broad-02-limited")
}

fn cut(v: &Option<Vec<f64>>, lo: usize, hi: usize) -> Option<Vec<f64>> {
    v.as_ref().map(|v| v[lo..hi].to_vec())
}

/// Rows `lo..hi` of `r`: the field, the attitude and the gyro.
fn rows(r: &Recording, lo: usize, hi: usize) -> Recording {
    Recording {
        t_s: cut(&r.t_s, lo, hi),
        mag: r.mag[lo..hi].to_vec(),
        roll_deg: cut(&r.roll_deg, lo, hi),
        pitch_deg: cut(&r.pitch_deg, lo, hi),
        gx_rad_s: cut(&r.gx_rad_s, lo, hi),
        gy_rad_s: cut(&r.gy_rad_s, lo, hi),
        gz_rad_s: cut(&r.gz_rad_s, lo, hi),
        ..Recording::default()
    }
}

/// Rows `lo..hi` of the calibration part.
fn calib_rows(lo: usize, hi: usize) -> Recording {
    rows(&Recording::read(&dir().join("02_calib.csv")).unwrap(), lo, hi)
}

/// Heading RMS on the validation part after one constant offset, degrees.
fn validation_deg(cal: &FieldCal<f64>) -> f64 {
    let path = dir().join("02_validate.csv");
    let v = Recording::read(&path).unwrap();
    let (roll, pitch) = (v.roll_deg.as_ref().unwrap(), v.pitch_deg.as_ref().unwrap());
    let h = (0..v.len()).map(|i| magnetic_heading_rad(cal.apply(v.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
    heading_rms_after_offset_deg(h.zip(optical_deg(&path))).0.rms
}

fn truth_json() -> Truth {
    serde_json::from_str(&std::fs::read_to_string(dir().join("02.truth.json")).unwrap()).unwrap()
}

/// Before the heading judge, auto judged this cut by the field's dip and
/// horizontal intensity, kept `attitude` (held-out 1.89°, expected 2.79°)
/// and wrote a calibration 5.88° off on the validation part (the floor
/// 1.70°; the gyro fit's own 2.00°). A rotation of the horizontal field
/// leaves the dip and the intensity as they are; the heading's changes
/// against the gyro's yaw see it.
#[test]
fn a_thin_fast_cut_is_judged_by_its_heading_and_nothing_far_off_is_kept() {
    let t = truth_json();
    let floor = validation_deg(&FieldCal { bias: t.bias, matrix: t.matrix });
    assert!((floor - 1.70).abs() < 0.01, "{floor}");
    let rec = calib_rows(98, 392);
    assert_eq!(rec.len(), 294);
    let opts = FitOptions { model: ModelKind::Attitude, field_nt: t.field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: None };
    match fit_auto(&rec, &opts) {
        Ok((doc, choice)) => {
            let observed = validation_deg(&doc.field_cal());
            let expected = doc.quality.expected_heading_rms_deg.unwrap();
            eprintln!("kept {} ({:?}): {observed:.2}° on the validation part, expected {expected:.2}°, floor {floor:.2}°; {:?}", choice.chosen, choice.basis, choice.candidates);
            assert_eq!(choice.basis, HeldOutBasis::GyroYaw);
            assert!(choice.kept_weak.is_none());
            // Measured: gyro kept, 2.00° (expected 2.08°).
            assert!(observed < floor + 1.0, "kept {} at {observed:.2}° against the floor {floor:.2}°", choice.chosen);
            assert!((0.5..=2.0).contains(&(observed / expected)), "{observed} / {expected}");
        }
        Err(e) => {
            // A refusal must say why, with its numbers.
            let text = e.to_string();
            assert!(matches!(e, ComputeError::NoModelQualifies { .. }) && text.contains(&format!("{MAX_HELD_OUT_DEG}°")), "{text}");
        }
    }
}

/// The tapped trial without a magnet (`broad-25-28-34/broad_25.csv`, one
/// series with the optical heading): fitted on its first half (12 s
/// held-out blocks without a break), judged on its second half. With the
/// gyro yaw integrated over whole blocks its drift was counted as the
/// calibration's error: the gyro fit was judged 6.45° and refused (1.86°
/// on the second half). Stretches cut at 4 s: kept.
#[test]
fn a_long_stretch_without_breaks_is_not_refused_for_the_gyros_drift() {
    let d = super::data("broad-25-28-34");
    let path = d.join("broad_25.csv");
    let all = Recording::read(&path).unwrap();
    let half = all.len() / 2;
    let part = |lo: usize, hi: usize| rows(&all, lo, hi);
    let (calib, val) = (part(0, half), part(half, all.len()));
    let optical = optical_deg(&path)[half..].to_vec();
    let t: Truth = serde_json::from_str(&std::fs::read_to_string(d.join("broad_25.truth.json")).unwrap()).unwrap();
    let heading = |cal: &FieldCal<f64>| {
        let (roll, pitch) = (val.roll_deg.as_ref().unwrap(), val.pitch_deg.as_ref().unwrap());
        let h = (0..val.len()).map(|i| magnetic_heading_rad(cal.apply(val.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
        heading_rms_after_offset_deg(h.zip(optical.iter().copied())).0.rms
    };
    let floor = heading(&FieldCal { bias: t.bias, matrix: t.matrix });
    let opts = FitOptions { model: ModelKind::Attitude, field_nt: t.field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: None };
    let (doc, choice) = fit_auto(&calib, &opts).unwrap();
    let observed = heading(&doc.field_cal());
    eprintln!("broad_25: kept {} ({:?}) {observed:.2}° on the second half, floor {floor:.2}°, expected {:?}", choice.chosen, choice.basis, doc.quality.expected_heading_rms_deg);
    assert_eq!(choice.basis, HeldOutBasis::GyroYaw);
    // Measured: gyro, 1.86° (floor 1.75°), expected 2.68°.
    assert!(observed < floor + 0.5, "{observed} {floor}");
}

/// A limited-tilt trial: its calibration part, its validation part's
/// heading error (after one offset, degrees) of a calibration, its floor.
struct Trial {
    calib: Recording,
    truth: Truth,
    validate: Recording,
    optical: Vec<f64>,
}

impl Trial {
    fn load(name: &str, id: &str) -> Self {
        let d = super::data(name);
        let vpath = d.join(format!("{id}_validate.csv"));
        Trial {
            calib: Recording::read(&d.join(format!("{id}_calib.csv"))).unwrap(),
            truth: serde_json::from_str(&std::fs::read_to_string(d.join(format!("{id}.truth.json"))).unwrap()).unwrap(),
            validate: Recording::read(&vpath).unwrap(),
            optical: optical_deg(&vpath),
        }
    }

    fn validation_deg(&self, cal: &FieldCal<f64>) -> f64 {
        let v = &self.validate;
        let (roll, pitch) = (v.roll_deg.as_ref().unwrap(), v.pitch_deg.as_ref().unwrap());
        let h = (0..v.len()).map(|i| magnetic_heading_rad(cal.apply(v.mag[i]), roll[i].to_radians(), pitch[i].to_radians()));
        heading_rms_after_offset_deg(h.zip(self.optical.iter().copied())).0.rms
    }

    fn floor_deg(&self) -> f64 {
        self.validation_deg(&FieldCal { bias: self.truth.bias, matrix: self.truth.matrix })
    }

    /// The tapped trial 25 without a magnet: its first half the calibration
    /// part, its second half the validation part.
    fn broad_25() -> Self {
        let d = super::data("broad-25-28-34");
        let path = d.join("broad_25.csv");
        let all = Recording::read(&path).unwrap();
        let half = all.len() / 2;
        Trial {
            calib: rows(&all, 0, half),
            truth: serde_json::from_str(&std::fs::read_to_string(d.join("broad_25.truth.json")).unwrap()).unwrap(),
            validate: rows(&all, half, all.len()),
            optical: optical_deg(&path)[half..].to_vec(),
        }
    }

    /// `fit` (auto, no site) on rows `lo..hi` of the calibration part: the
    /// kept model and its validation error, or `None` when refused.
    fn auto(&self, lo: usize, hi: usize) -> Option<(String, f64)> {
        self.auto_judged(lo, hi, &YawJudge::default())
    }

    /// [`Self::auto`] with the gyro-yaw judge's constants `judge`.
    fn auto_judged(&self, lo: usize, hi: usize, judge: &YawJudge) -> Option<(String, f64)> {
        let opts = FitOptions { model: ModelKind::Attitude, field_nt: self.truth.field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: None };
        match fit_auto_judged(&rows(&self.calib, lo, hi), &opts, judge) {
            Ok((doc, choice)) => Some((choice.chosen, self.validation_deg(&doc.field_cal()))),
            Err(e) => {
                let text = e.to_string();
                assert!(matches!(e, ComputeError::NoModelQualifies { .. } | ComputeError::NoModel { .. }) && text.contains(&format!("{MAX_HELD_OUT_DEG}°")), "{text}");
                None
            }
        }
    }
}

const LIMITED_TILT: [(&str, &str); 5] = [("broad-02-limited", "02"), ("broad-03", "03"), ("broad-05", "05"), ("broad-06", "06"), ("broad-09", "09")];

/// Two 294-row cuts whose headings leave 230–290° unvisited: auto kept
/// `attitude` (its own expected error 2.81° and 3.40°, held-out 2.54° and
/// 4.59°) 5.09° and 5.35° off on the validation part (floors 1.70°,
/// 2.43°). The attitude fit's covariance does not see its error outside
/// the headings it saw; widened by the gap, it no longer qualifies.
#[test]
fn a_cut_that_never_saw_most_headings_is_not_kept_far_off() {
    for (name, id, lo) in [("broad-02-limited", "02", 49), ("broad-06", "06", 0)] {
        let trial = Trial::load(name, id);
        let kept = trial.auto(lo, lo + 294);
        eprintln!("{id} rows {lo}–{}: {kept:?}, floor {:.2}°", lo + 293, trial.floor_deg());
        // Measured: 02 gyro kept, 3.13°; 06 refused.
        if let Some((model, observed)) = kept {
            assert!(observed < MAX_HELD_OUT_DEG, "{id} rows {lo}: {model} kept {observed:.2}° off");
        }
    }
}

/// Every 294-row cut (stride 49) of the five limited-tilt trials'
/// calibration parts, and the whole parts: kept within 5° or refused
/// (`--ignored --nocapture` prints each). Measured: 52 kept ≤ 5°, 3
/// refused, none kept > 5° (before the heading-gap widening: 51, 2, 2);
/// the whole parts as before (02 gyro 1.67°, 03 gyro 1.59°, 05 gyro 1.69°,
/// 06 gyro 2.66°, 09 attitude 1.92°).
#[test]
#[ignore = "55 auto fits: a sweep for the report"]
fn every_294_row_cut_is_kept_within_5_deg_or_refused() {
    let (mut within, mut refused, mut far) = (0, 0, Vec::new());
    for (name, id) in LIMITED_TILT {
        let trial = Trial::load(name, id);
        let floor = trial.floor_deg();
        let whole = trial.auto(0, trial.calib.len());
        println!("{id} whole part: {whole:?}, floor {floor:.2}°");
        assert!(whole.as_ref().is_some_and(|(_, v)| *v < floor + 0.5), "{id}: {whole:?}");
        let mut lo = 0;
        while lo + 294 <= trial.calib.len() {
            let kept = trial.auto(lo, lo + 294);
            println!("{id} rows {lo}–{}: {kept:?}, floor {floor:.2}°", lo + 293);
            match kept {
                None => refused += 1,
                Some((_, v)) if v <= MAX_HELD_OUT_DEG => within += 1,
                Some(k) => far.push((id, lo, k)),
            }
            lo += 49;
        }
    }
    println!("kept ≤ {MAX_HELD_OUT_DEG}°: {within}, refused: {refused}, kept > {MAX_HELD_OUT_DEG}°: {far:?}");
    assert_eq!(within + refused + far.len(), 55);
    assert!(far.is_empty(), "{far:?}");
}

/// The gyro-yaw judge's constants (stretch length, usable share) chosen
/// leave-one-trial-out: each of the six BROAD trials with the optical
/// heading (the five limited-tilt trials' whole calibration parts and their
/// 294-row cuts; trial 25's first half and its cuts, judged on its second
/// half) is scored by the constants the other five choose. Score: fits
/// kept more than 5° off, then refusals, then fits kept more than 1° above
/// the floor, then the kept fits' mean excess over the floor.
#[test]
#[ignore = "a sweep of some 1 300 auto fits, for choosing the defaults"]
fn the_gyro_yaw_judges_constants_leave_one_trial_out() {
    let mut trials: Vec<(&str, Trial)> = LIMITED_TILT.iter().map(|(name, id)| (*id, Trial::load(name, id))).collect();
    trials.push(("25", Trial::broad_25()));
    let grid: Vec<YawJudge> = [1.0, 2.0, 4.0, 8.0, 16.0].iter().flat_map(|&s| [0.25, 0.5, 0.75, 0.9].map(|m| YawJudge { max_stretch_s: s, min_share: m })).collect();
    // score[c][t] = (far, refused, above floor + 1°, excess sum, kept)
    let mut score = vec![vec![(0usize, 0usize, 0usize, 0.0f64, 0usize); trials.len()]; grid.len()];
    for (c, judge) in grid.iter().enumerate() {
        for (t, (id, trial)) in trials.iter().enumerate() {
            let floor = trial.floor_deg();
            let n = trial.calib.len();
            let cuts = std::iter::once((0, n)).chain((0..).map(|k| k * 49).take_while(|lo| lo + 294 <= n).map(|lo| (lo, lo + 294)));
            let s = &mut score[c][t];
            for (lo, hi) in cuts {
                match trial.auto_judged(lo, hi, judge) {
                    None => s.1 += 1,
                    Some((_, v)) => {
                        s.0 += usize::from(v > MAX_HELD_OUT_DEG);
                        s.2 += usize::from(v > floor + 1.0);
                        s.3 += v - floor;
                        s.4 += 1;
                    }
                }
            }
            println!("{:>4.1} s {:.2}: {id}: {} far, {} refused, {} > floor + 1°, mean excess {:.3}° over {} kept", judge.max_stretch_s, judge.min_share, s.0, s.1, s.2, s.3 / s.4.max(1) as f64, s.4);
        }
    }
    let key = |c: usize, ts: &[usize]| {
        let sum = ts.iter().fold((0, 0, 0, 0.0, 0), |a, &t| {
            let s = score[c][t];
            (a.0 + s.0, a.1 + s.1, a.2 + s.2, a.3 + s.3, a.4 + s.4)
        });
        (sum.0, sum.1, sum.2, sum.3 / sum.4.max(1) as f64)
    };
    for (t, (id, _)) in trials.iter().enumerate() {
        let others: Vec<usize> = (0..trials.len()).filter(|&u| u != t).collect();
        // The first of the grid among equal scores: the shorter stretch, the lower share.
        let best = (0..grid.len()).min_by(|&a, &b| key(a, &others).partial_cmp(&key(b, &others)).unwrap()).unwrap();
        let (own, def) = (key(best, &[t]), key(grid.iter().position(|j| *j == YawJudge::default()).unwrap(), &[t]));
        println!("held out {id}: chosen {:?} (others {:?}); held-out trial {own:?}, with the default {def:?}", grid[best], key(best, &others));
        // Measured: no held-out trial keeps a fit more than 5° off, with its
        // chosen constants or the default.
        assert_eq!((own.0, def.0), (0, 0), "{id}");
    }
}

/// The whole calibration part of trial 02 with the lab's site (IGRF-14 at
/// TU Berlin, 2020-06-01: 67.94°; the lab's own dip is about 1.6° steeper,
/// its README). The gyro fit weighs IGRF's dip against what the data tell
/// (they tell it to 0.3°: the reference weighs 8 %, measured), and the
/// gyro fit with the dip held at IGRF's is refused because the data alone
/// put it 6σ of their own away (held there, it was kept by the held-out
/// judge at 2.17° on the validation part against the free fit's 1.63°).
/// Before, auto had no held gyro row; the kept gyro fit read 1.67°.
#[test]
fn with_the_labs_site_the_gyro_fit_weighs_igrfs_dip_and_is_not_held_against_its_data() {
    let site = host_tools::geomag::Site::new(52.51, 13.32, "2020-06-01").unwrap();
    let reference = host_tools::doc::Reference::world_model(site, &site.field().unwrap());
    let rec = Recording::read(&dir().join("02_calib.csv")).unwrap();
    let opts = FitOptions { model: ModelKind::Gyro, field_nt: reference.field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: Some(reference) };
    let (doc, choice) = fit_auto(&rec, &opts).unwrap();
    let held = choice.candidates.iter().find(|r| r.model == "gyro (dip held at the world model's)").expect("a held gyro row");
    assert!(held.refused.as_deref().is_some_and(|w| w.contains("holding it contradicts them")), "{held:?}");
    assert_eq!(choice.chosen, "gyro");
    let constraint = doc.reference.as_ref().and_then(|r| r.constraint.clone()).expect("the constraint block");
    assert!(!constraint.held && constraint.reference_share < 0.2 && constraint.text.contains("the data shaped the dip"), "{constraint:?}");
    // Measured 1.632° (the floor, the true calibration, 1.70°).
    let v = validation_deg(&doc.field_cal());
    assert!(v < 1.70, "{v}");
}

/// Seaglider SG236 calibrated on dives 4–5 (no gyro) with a site 14° of
/// dip away (30° N, 124.89° W: IGRF-14 53.68° against the glider's
/// 67.82°). The attitude-aided fit's data alone put the dip at 69.31° ±
/// 0.23° (their block scatter counted): 7.8σ from the wrong site's with
/// the tilt sensor's 2° counted, so holding it there contradicts them; the
/// free fit disagrees with that reference, and `auto` keeps nothing.
/// Before, the held attitude fit had no such rule and `auto` kept it: the
/// dip scatter on dives 1–3 was 9.36° (with the glider's own site, the
/// held fit's 0.66°, kept as before: `glider_world.rs`).
#[test]
fn a_glider_is_not_held_at_a_wrong_sites_dip() {
    use host_tools::doc::Reference;
    use host_tools::geomag::Site;
    let site = Site::new(30.0, -124.894, "2023-06-01").unwrap();
    let reference = Reference::world_model(site, &site.field().unwrap());
    let rec = Recording::read(&super::data("seaglider-sg236").join("sg236_validate.csv")).unwrap();
    let opts = FitOptions { model: ModelKind::Attitude, field_nt: reference.field_nt, saturation: None, allow_weak: false, gyro_lag: GyroLag::Given(0.0), reference: Some(reference) };
    let kept = fit_auto(&rec, &opts);
    assert!(kept.is_err(), "kept {:?}", kept.map(|(_, c)| c.chosen));
    let (_, weak) = fit_auto(&rec, &FitOptions { allow_weak: true, ..opts }).unwrap();
    let held = weak.candidates.iter().find(|r| r.model == "attitude (dip held at the world model's)").expect("a held attitude row");
    assert!(held.note.as_deref().is_some_and(|n| n.contains("does not qualify")), "{held:?}");
}
