//! The state machine on constructed sequences: a vehicle turning and
//! rocking in a known field (written from the frame equations of
//! `heading.rs`, eqs 1–3), with the gyro's body rates derived from the
//! Euler-angle rates, then a disturbance or a new hard iron added.

use super::*;
use crate::heading::Tilt;
use crate::cal::{Calibration, EnvTerms, FieldCal, Swing};
use crate::hardiron::HardIronEstimator;
use crate::heading::{heading_of_levelled, ned_field, ned_to_body, wrap_pi, wrap_two_pi};
use crate::linalg::identity3;
use crate::online::OnlineIntegrity;

mod magnets;
mod soft_iron;

const F_NT: f64 = 48_000.0;
const SIGMA_NT: f64 = 300.0;
const DIP_RAD: f64 = 1.1;
const DT_S: f64 = 0.1;
/// Uniform noise of this amplitude times σ per axis: RMS σ (√3 / √3), and
/// bounded, so a clean sample never fails a 3.5σ gate by chance.
const NOISE: f64 = 1.732_050_807_568_877_2;

/// Attitude and body rates at time t: yaw turning at 20°/s, roll and pitch
/// rocking (±0.35 and ±0.25 rad).
fn motion(t: f64) -> ([f64; 3], [f64; 3]) {
    motion_turning(t, false)
}

/// [`motion`], or with `zigzag` the yaw sweeping ±150° at 20°/s, turning
/// back every 15 s (a yaw rate of either sign, so no constant gyro bias
/// stands in for a scale error).
fn motion_turning(t: f64, zigzag: bool) -> ([f64; 3], [f64; 3]) {
    let (roll, roll_dot) = (0.35 * (0.7 * t).sin(), 0.35 * 0.7 * (0.7 * t).cos());
    let (pitch, pitch_dot) = (0.25 * (0.45 * t).sin(), 0.25 * 0.45 * (0.45 * t).cos());
    let rate = 20f64.to_radians();
    let (yaw, yaw_dot) = if zigzag {
        let phase = t.rem_euclid(30.0);
        if phase < 15.0 {
            (0.3 + rate * (phase - 7.5), rate)
        } else {
            (0.3 + rate * (22.5 - phase), -rate)
        }
    } else {
        (0.3 + rate * t, rate)
    };
    ([roll, pitch, yaw], body_rates(roll, pitch, [roll_dot, pitch_dot, yaw_dot]))
}

/// ZYX Euler-angle rates `[roll_dot, pitch_dot, yaw_dot]` (rad/s) at
/// `roll`, `pitch` (rad) → body rates `[p, q, r]` (rad/s).
fn body_rates(roll: f64, pitch: f64, euler_dot: [f64; 3]) -> [f64; 3] {
    let [roll_dot, pitch_dot, yaw_dot] = euler_dot;
    let (sr, cr, sp, cp) = (roll.sin(), roll.cos(), pitch.sin(), pitch.cos());
    [
        roll_dot - sp * yaw_dot,
        cr * pitch_dot + sr * cp * yaw_dot,
        -sr * pitch_dot + cr * cp * yaw_dot,
    ]
}

/// The stored calibration of the path tests: identity (raw in nT).
fn identity_cal() -> Calibration<f64> {
    Calibration {
        field: FieldCal {
            bias: [0.0; 3],
            matrix: identity3(),
        },
        swing: Swing::zero(),
        declination_rad: 0.0,
        env: EnvTerms::none(),
    }
}

/// A deterministic noise in [−1, 1) (a linear congruential generator).
struct Noise(u64);
impl Noise {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }
}

fn reference(incl: Option<f64>) -> Reference<f64> {
    Reference {
        field_nt: F_NT,
        field_sigma_nt: SIGMA_NT,
        noise_nt: SIGMA_NT,
        inclination_rad: incl,
        heading_sigma_rad: 0.0,
    }
}

/// Runs `n` samples; `extra(t, attitude)` is a body-frame field added to the
/// sample (a disturbance). Returns the states.
fn run(
    n: usize,
    incl: Option<f64>,
    extra: impl Fn(f64, &[f64; 3]) -> [f64; 3],
) -> Vec<(IntegrityState, f64)> {
    let mut m = Monitor::new(reference(incl), Tuning::standard()).unwrap();
    let mut noise = Noise(7);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    (0..n)
        .map(|k| {
            let t = k as f64 * DT_S;
            let (att, w) = motion(t);
            let b = ned_to_body(ned, att[0], att[1], att[2]);
            let d = extra(t, &att);
            let h = [0, 1, 2].map(|i| b[i] + d[i] + NOISE * SIGMA_NT * noise.next());
            let tilt = Tilt::new(att[0], att[1]);
            let heading = heading_of_levelled(tilt.level(h));
            let v = m.step(h, heading, Some(&tilt), Some(w), DT_S);
            (v.state, v.heading_sigma_rad)
        })
        .collect()
}

#[test]
fn a_clean_sequence_is_ok_throughout_with_the_noise_sigma() {
    let states = run(600, Some(DIP_RAD), |_, _| [0.0; 3]);
    assert!(
        states.iter().all(|(s, _)| *s == IntegrityState::Ok),
        "{:?}",
        states.iter().position(|(s, _)| *s != IntegrityState::Ok)
    );
    // σ = σ_F / H_h, H_h = F cos I = 21 774 nT: 0.79°.
    let want = (SIGMA_NT / (F_NT * DIP_RAD.cos())).to_degrees();
    for (_, s) in &states {
        // H_h measured through the noise: within 5 %.
        assert!(
            (s.to_degrees() / want - 1.0).abs() < 0.05,
            "{} vs {want}",
            s.to_degrees()
        );
    }
    // Learned inclination, from the same clean sequence: every test passes,
    // but against a dip the stream taught itself: all unjudged, none ok.
    let learned = run(600, None, |_, _| [0.0; 3]);
    assert!(learned.iter().all(|(s, _)| *s == IntegrityState::Unjudged));
}

/// A field perpendicular to the magnetic meridian (east in NED), which
/// neither the magnitude nor the dip sees much of: only the gyro catches it.
fn east_disturbance(nt: f64, from_s: f64, to_s: f64) -> impl Fn(f64, &[f64; 3]) -> [f64; 3] {
    move |t, att| {
        if t >= from_s && t < to_s {
            ned_to_body([0.0, nt, 0.0], att[0], att[1], att[2])
        } else {
            [0.0; 3]
        }
    }
}

#[test]
fn a_passing_disturbance_is_caught_by_the_gyro_and_ends_with_hysteresis() {
    // 4 500 nT east for 1 s across H_h = 21 774 nT: 11.7° of heading; |F|
    // moves by 211 nT (0.7 σ) and the dip by nothing: only the gyro test
    // sees it. (Coasting, the gyro's σ grows with the turn: 3.1° after 1 s
    // at 20°/s with `Tuning::standard`'s 8 % scale error, so the 3σ gate
    // is 9.2°: a 9° offset would be taken after 1 s.)
    let states = run(300, Some(DIP_RAD), east_disturbance(4500.0, 10.0, 11.0));
    let at = |t: f64| states[(t / DT_S).round() as usize].0;
    assert_eq!(at(9.9), IntegrityState::Ok);
    for k in 100..110 {
        assert_eq!(states[k].0, IntegrityState::Disturbed, "sample {k}");
    }
    // Its σ says how far off: at least the 6.6° it is off by.
    assert!(
        states[105].1.to_degrees() > 5.0,
        "{}",
        states[105].1.to_degrees()
    );
    // The end: the first clean sample passes but is still disturbed
    // (hysteresis, exit_s = 0.1 s: one more sample), then ok.
    assert_eq!(at(11.0), IntegrityState::Disturbed);
    assert_eq!(at(11.1), IntegrityState::Ok);
    assert!(states[111..].iter().all(|(s, _)| *s == IntegrityState::Ok));
    // Without the gyro the same disturbance passes the field tests.
    let mut m = Monitor::new(reference(Some(DIP_RAD)), Tuning::standard()).unwrap();
    let (att, _) = motion(10.5);
    let b = ned_to_body(ned_field(F_NT, DIP_RAD, 0.0), att[0], att[1], att[2]);
    let d = east_disturbance(3500.0, 10.0, 11.0)(10.5, &att);
    let h = [b[0] + d[0], b[1] + d[1], b[2] + d[2]];
    let tilt = Tilt::new(att[0], att[1]);
    let v = m.step(
        h,
        heading_of_levelled(tilt.level(h)),
        Some(&tilt),
        None,
        DT_S,
    );
    assert_eq!(v.state, IntegrityState::Ok);
}

#[test]
fn a_one_sample_glitch_is_one_disturbed_sample_not_an_invalid_calibration() {
    // 20 σ on |F| for one sample.
    let states = run(200, Some(DIP_RAD), |t, _| {
        if (t - 8.0).abs() < 0.01 {
            [0.0, 0.0, 20.0 * SIGMA_NT]
        } else {
            [0.0; 3]
        }
    });
    let bad: Vec<usize> = states
        .iter()
        .enumerate()
        .filter(|(_, (s, _))| *s != IntegrityState::Ok)
        .map(|(k, _)| k)
        .collect();
    // The glitch and the next sample (hysteresis), nothing else.
    assert_eq!(bad, vec![80, 81]);
}

#[test]
fn a_new_hard_iron_makes_the_calibration_invalid_within_seconds() {
    // 6 000 nT fixed in the body from t = 20 s (a payload switched on).
    let states = run(600, Some(DIP_RAD), |t, _| {
        if t >= 20.0 {
            [6000.0, -3000.0, 2000.0]
        } else {
            [0.0; 3]
        }
    });
    let first_invalid = states
        .iter()
        .position(|(s, _)| *s == IntegrityState::CalInvalid)
        .unwrap();
    let delay_s = first_invalid as f64 * DT_S - 20.0;
    // Measured 0.7 s (the bias-corrected misfit fraction crosses ½).
    assert!((0.0..3.0).contains(&delay_s), "{delay_s}");
    // From then on nothing is ok: the field rarely fits by chance.
    let ok_after = states[first_invalid..]
        .iter()
        .filter(|(s, _)| *s == IntegrityState::Ok)
        .count();
    assert_eq!(ok_after, 0);
    let invalid_after = states[first_invalid..]
        .iter()
        .filter(|(s, _)| *s == IntegrityState::CalInvalid)
        .count();
    assert!(
        invalid_after as f64 > 0.9 * (600 - first_invalid) as f64,
        "{invalid_after}"
    );
}

#[test]
fn no_attitude_is_its_own_state_and_bad_references_are_refused() {
    let mut m = Monitor::new(reference(None), Tuning::standard()).unwrap();
    let v = m.step([F_NT, 0.0, 0.0], 0.0, None, None, DT_S);
    assert_eq!(v.state, IntegrityState::NoAttitude);
    assert!(v.heading_sigma_rad.is_nan());
    let bad = |r: Reference<f64>| Monitor::new(r, Tuning::standard()).err();
    assert_eq!(
        bad(Reference {
            field_sigma_nt: 0.0,
            ..reference(None)
        }),
        Some(IntegrityError::BadReference)
    );
    assert_eq!(
        bad(Reference {
            field_nt: f64::NAN,
            ..reference(None)
        }),
        Some(IntegrityError::BadReference)
    );
    assert_eq!(
        bad(Reference {
            inclination_rad: Some(2.0),
            ..reference(None)
        }),
        Some(IntegrityError::BadReference)
    );
    assert_eq!(
        bad(Reference {
            noise_nt: 0.0,
            ..reference(None)
        }),
        Some(IntegrityError::BadReference)
    );
    let t = Tuning {
        misfit_exit: 0.6,
        ..Tuning::standard()
    };
    assert_eq!(
        Monitor::new(reference(None), t).err(),
        Some(IntegrityError::BadTuning)
    );
    for s in IntegrityState::ALL {
        assert_eq!(IntegrityState::from_code(s as u8), Some(s));
    }
    assert_eq!(IntegrityState::from_code(5), None);
}

#[test]
fn the_state_is_small_and_f32_judges_as_f64() {
    // Sizes for the firmware (f32): printed by `cargo test -- --nocapture`.
    let (monitor, online) = (
        core::mem::size_of::<Monitor<f32>>(),
        core::mem::size_of::<OnlineIntegrity<f32>>(),
    );
    std::println!(
        "Monitor<f32> {monitor} B, OnlineIntegrity<f32> {online} B, HardIronEstimator<f32> {} B",
        core::mem::size_of::<HardIronEstimator<f32>>()
    );
    // Measured: 184 B and 416 B before the two-cycle test (the reference's dip bounds, the second
    // gate, the on-line estimate's gyro confirmation, the stored
    // calibration's check while it is applied, the previous sample's yaw
    // rate for the trapezoid rule, the squares of the heading σ and the
    // gyro gate kept to fit the per-sample instruction budget, the
    // start-up recovery's clock; the inclination learner's block count
    // padded in its own struct); now 260 B and 492 B with the two-cycle
    // test's sums (2 × 9 values, its block count and finding); 400 B and
    // 632 B with its four quadrants' sums (4 × 9 values) and the
    // half-circles' veto bits.
    assert!(monitor <= 400 && online <= 632, "{monitor} {online}");
    // The same sequence in f32: the same states.
    let mut m32 = Monitor::<f32>::new(
        Reference {
            field_nt: F_NT as f32,
            field_sigma_nt: SIGMA_NT as f32,
            noise_nt: SIGMA_NT as f32,
            inclination_rad: Some(DIP_RAD as f32),
            heading_sigma_rad: 0.0,
        },
        Tuning::standard(),
    )
    .unwrap();
    let states64 = run(300, Some(DIP_RAD), east_disturbance(3500.0, 10.0, 11.0));
    let mut noise = Noise(7);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let mut differ = 0;
    for (k, (s64, _)) in states64.iter().enumerate() {
        let t = k as f64 * DT_S;
        let (att, w) = motion(t);
        let b = ned_to_body(ned, att[0], att[1], att[2]);
        let d = east_disturbance(3500.0, 10.0, 11.0)(t, &att);
        let h = [0, 1, 2].map(|i| (b[i] + d[i] + NOISE * SIGMA_NT * noise.next()) as f32);
        let tilt = Tilt::new(att[0] as f32, att[1] as f32);
        let v = m32.step(
            h,
            heading_of_levelled(tilt.level(h)),
            Some(&tilt),
            Some(w.map(|x| x as f32)),
            DT_S as f32,
        );
        differ += usize::from(v.state != *s64);
    }
    // f32 rounds differently: at the disturbance's end, where the gyro
    // filter had half taken the disturbed headings, f32 leaves the
    // disturbance 0.6 s later (measured: samples 111–116 of 300 differ).
    // The board and `magcal apply` run the same f32 or f64 code, bit for bit.
    assert!(differ <= 12, "{differ}");
}

/// The sequence of `a_new_hard_iron…` through the whole path: the stored
/// calibration (identity: raw in nT), the monitor, the estimator, the guard.
#[test]
fn the_on_line_hard_iron_is_estimated_applied_under_the_guard_and_honest() {
    hard_iron_case(1);
}

/// The board may run the estimator every other sample (its CPU budget),
/// the gyro rows then 0.2 s apart: applied too (measured at 42.3 s, 22 s
/// after the payload; 0.79° RMS against 0.81° predicted on the ok rows).
#[test]
fn the_on_line_hard_iron_every_other_sample() {
    hard_iron_case(2);
}

/// The payload sequence through the whole path; from the payload on, the
/// gyro's rates are multiplied by `gyro_gain_after` (1: a true gyro);
/// `zigzag`: the vehicle sweeps back and forth ([`motion_turning`]).
/// Returns when the estimate was first applied, the heading errors and σ of
/// the rows called ok after the payload, and the path.
fn hard_iron_run(
    every: u8,
    gyro_gain_after: f64,
    zigzag: bool,
) -> (Option<f64>, std::vec::Vec<(f64, f64)>, OnlineIntegrity<f64>) {
    let offset = [6000.0, -3000.0, 2000.0];
    let cal = identity_cal();
    let mut online = OnlineIntegrity::new(reference(Some(DIP_RAD)), Tuning::standard())
        .unwrap()
        .with_estimator_every(every);
    let mut noise = Noise(11);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let mut applied_at = None;
    let mut ok_errors = std::vec::Vec::new();
    for k in 0..2400 {
        let t = k as f64 * DT_S;
        let (att, w) = motion_turning(t, zigzag);
        let b = ned_to_body(ned, att[0], att[1], att[2]);
        let d = if t >= 20.0 { offset } else { [0.0; 3] };
        let raw = [0, 1, 2].map(|i| b[i] + d[i] + NOISE * SIGMA_NT * noise.next());
        let tilt = Tilt::new(att[0], att[1]);
        let gain = if t >= 20.0 { gyro_gain_after } else { 1.0 };
        let out = online.process(&cal, raw, Some(&tilt), Some(w.map(|v| v * gain)), DT_S);
        if out.hard_iron_applied && applied_at.is_none() {
            applied_at = Some(t);
        }
        if t >= 20.0 && out.verdict.state == IntegrityState::Ok {
            let err = wrap_pi(out.heading_rad.unwrap() - wrap_two_pi(att[2]));
            ok_errors.push((err, out.verdict.heading_sigma_rad));
        }
    }
    (applied_at, ok_errors, online)
}

fn hard_iron_case(every: u8) {
    let offset = [6000.0, -3000.0, 2000.0];
    let (applied_at, ok_errors, online) = hard_iron_run(every, 1.0, false);
    // Applied some tens of seconds after the payload came on (measured at
    // 63.2 s, 43 s after: the magnitude rows linearised about the old
    // estimate must be forgotten before the residual passes the guard).
    let at = applied_at.expect("never applied");
    assert!(at > 20.0 && at < 100.0, "{at}");
    // The estimate goes on while applied, and the offset in use follows it
    // (here the last estimate passed the guard too).
    let e = online.hard_iron().unwrap();
    assert_eq!(online.applied_offset_nt(), Some(e.offset_nt));
    for i in 0..3 {
        // Within 3σ or 100 nT of the offset put in (measured, every sample:
        // 28, 11, 1 nT off, σ 33, 29, 10 nT; every other sample 16, 21,
        // 16 nT off, σ 44, 39, 14 nT).
        assert!(
            (e.offset_nt[i] - offset[i]).abs() < (3.0 * e.sigma_nt[i]).max(100.0),
            "{i}: {:?} σ {:?}",
            e.offset_nt,
            e.sigma_nt
        );
    }
    // The headings called ok with it: small and within their σ (measured
    // every sample: 1 723 rows, 0.804° RMS against 0.799° predicted; every
    // other: 1 932 rows, 0.794° against 0.806°; the noise's 0.79° across
    // H_h and the estimate's). One run, but its ratio pools over rows
    // whose noise is drawn afresh (1.01 and 0.99 measured): held to 0.7–1.4.
    let n = ok_errors.len() as f64;
    assert!(n > 1000.0, "{n}");
    let rms = (ok_errors.iter().map(|(e, _)| e * e).sum::<f64>() / n).sqrt();
    let pred = (ok_errors.iter().map(|(_, s)| s * s).sum::<f64>() / n).sqrt();
    std::println!("every {every}: applied at {at} s, estimate {:?} σ {:?}, ok rows {n}, RMS {:.3}° predicted {:.3}°", e.offset_nt, e.sigma_nt, rms.to_degrees(), pred.to_degrees());
    assert!(rms.to_degrees() < 2.0, "{}", rms.to_degrees());
    assert!(
        rms / pred > 0.7 && rms / pred < 1.4,
        "observed {} predicted {}",
        rms.to_degrees(),
        pred.to_degrees()
    );
    let h = online.health();
    assert_eq!(h.hard_iron_applied, 1);
    assert!(h.samples_per_state[IntegrityState::CalInvalid as usize] > 0);
}

/// The guard: a heading from the on-line hard iron is `ok` only once
/// the gyro agrees with it. The same payload, but from the payload on the
/// gyro turns 30 % slower than the vehicle, which sweeps back and forth
/// (their headings disagree by 6° a second, either way): the estimate is
/// formed and applied as before (the field checks pass), and not one row
/// is called `ok`.
#[test]
fn an_on_line_hard_iron_the_gyro_disagrees_with_is_never_ok() {
    let (applied_at, ok_errors, online) = hard_iron_run(1, 0.7, true);
    assert!(
        applied_at.is_some(),
        "the field checks alone would apply it"
    );
    assert!(ok_errors.is_empty(), "{} rows ok", ok_errors.len());
    // Each application was withdrawn on the gyro's word.
    assert!(online.health().hard_iron_applied >= 1);
    // With a true gyro the same estimate is confirmed within a turn.
    let (at_true, ok_true, _) = hard_iron_run(1, 1.0, true);
    let rms = (ok_true.iter().map(|(e, _)| e * e).sum::<f64>() / ok_true.len().max(1) as f64).sqrt().to_degrees();
    std::println!("true gyro: applied at {at_true:?} s, {} rows ok at {rms:.2}° RMS", ok_true.len());
    // Measured: applied at 62.8 s, 1 721 rows ok at 0.80° RMS.
    assert!(ok_true.len() > 1000, "{}", ok_true.len());
    assert!(rms < 2.0, "{rms}");
}

#[test]
fn the_guard_refuses_an_estimate_that_does_not_explain_the_misfit() {
    // A soft-iron change (30 % gain on x), not an offset: the estimate is
    // applied now and then where the offset happens to fit (measured: 2
    // applications, 33 rows), never confirmed by the gyro, so no row is
    // ok with it; the stored calibration is ok on no row after 5 s (3
    // rows, 2.7° off at worst, before the two-cycle test). (A misfit exit of 0.2 instead of 0.1: 43 rows ok up
    // to 6.4° off; a misfit time constant of 1 s instead of 2: 111 rows,
    // 10.2° off: so both are fixed, not tuned on the BROAD trials.)
    let cal = identity_cal();
    let mut online = OnlineIntegrity::new(reference(Some(DIP_RAD)), Tuning::standard()).unwrap();
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let mut ok_late = 0;
    let mut applied = 0;
    let (mut ok_applied, mut worst) = (0, 0.0f64);
    for k in 0..1800 {
        let t = k as f64 * DT_S;
        let (att, w) = motion(t);
        let b = ned_to_body(ned, att[0], att[1], att[2]);
        let raw = [1.3 * b[0], b[1], b[2]];
        let tilt = Tilt::new(att[0], att[1]);
        let out = online.process(&cal, raw, Some(&tilt), Some(w), DT_S);
        if out.hard_iron_applied {
            applied += 1;
        }
        if t > 5.0 && out.verdict.state == IntegrityState::Ok {
            ok_late += 1;
            let err = wrap_pi(out.heading_rad.unwrap() - wrap_two_pi(att[2]))
                .to_degrees()
                .abs();
            worst = worst.max(err);
            if out.hard_iron_applied {
                ok_applied += 1;
            }
        }
    }
    std::println!("applied rows {applied}, ok late {ok_late} (with the estimate {ok_applied}), worst {worst:.2}°, applications {}", online.health().hard_iron_applied);
    assert_eq!(ok_applied, 0, "rows ok with an unconfirmed estimate");
    assert!(worst < 4.0, "{worst}° off called ok");
    // A few samples where a 30 % gain error happens to fit (heading near
    // ±90°, where x carries little): measured 3; a fiftieth at most.
    assert!(ok_late < 36, "{ok_late}");
}

/// While the stored calibration fits, the on-line estimator does not run
/// (the usual sample's cost is the monitor alone): no estimate after a
/// clean minute; one appears once a new hard iron has made the calibration
/// invalid.
#[test]
fn the_estimator_runs_only_once_the_calibration_is_invalid() {
    let cal = identity_cal();
    let mut online = OnlineIntegrity::new(reference(Some(DIP_RAD)), Tuning::standard()).unwrap();
    let mut noise = Noise(3);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let mut first_estimate_s = None;
    for k in 0..1200 {
        let t = k as f64 * DT_S;
        let (att, w) = motion(t);
        let b = ned_to_body(ned, att[0], att[1], att[2]);
        let d = if t >= 60.0 {
            [6000.0, -3000.0, 2000.0]
        } else {
            [0.0; 3]
        };
        let raw = [0, 1, 2].map(|i| b[i] + d[i] + NOISE * SIGMA_NT * noise.next());
        let out = online.process(&cal, raw, Some(&Tilt::new(att[0], att[1])), Some(w), DT_S);
        if t < 60.0 {
            assert_eq!(out.verdict.state, IntegrityState::Ok, "{t}");
            assert!(
                online.hard_iron().is_none(),
                "an estimate at {t} s while the calibration fits"
            );
        } else if first_estimate_s.is_none() && online.hard_iron().is_some() {
            first_estimate_s = Some(t);
        }
    }
    // The estimate starts with the misfit (measured: the first at 61.6 s,
    // 1.6 s after the payload: the calibration judged invalid, then a few
    // rows to determine all three components).
    let at = first_estimate_s.expect("an estimate once invalid");
    assert!(at > 60.0 && at < 64.0, "{at}");
}

/// A glider samples every 5–9 s, longer than the misfit's 2 s time
/// constant: one misfitting sample is `disturbed`, not a calibration gone
/// wrong; three in a row make it `cal_invalid` (`MAX_MISFIT_STEP`), and
/// passing samples clear it.
#[test]
fn at_a_slow_sampling_rate_one_misfit_is_a_disturbance_not_an_invalid_calibration() {
    let mut m = Monitor::new(reference(Some(DIP_RAD)), Tuning::standard()).unwrap();
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let dt = 6.0;
    let mut step = |k: usize, extra_nt: f64| {
        let (att, _) = motion(k as f64 * 3.7);
        let h = ned_to_body(ned, att[0], att[1], att[2]);
        // A misfit along the field: |F| off by 10 σ.
        let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        let h = h.map(|v| v * (1.0 + extra_nt / n));
        let tilt = Tilt::new(att[0], att[1]);
        m.step(h, heading_of_levelled(tilt.level(h)), Some(&tilt), None, dt)
            .state
    };
    for k in 0..10 {
        assert_eq!(step(k, 0.0), IntegrityState::Ok, "clean sample {k}");
    }
    assert_eq!(step(10, 10.0 * SIGMA_NT), IntegrityState::Disturbed);
    for k in 11..20 {
        assert_ne!(step(k, 0.0), IntegrityState::CalInvalid, "sample {k}");
    }
    let states: Vec<IntegrityState> = (20..23).map(|k| step(k, 10.0 * SIGMA_NT)).collect();
    assert_eq!(
        states,
        [
            IntegrityState::Disturbed,
            IntegrityState::Disturbed,
            IntegrityState::CalInvalid
        ]
    );
    // Eight passing samples bring the fraction under a tenth again.
    let back = (23..40)
        .position(|k| step(k, 0.0) != IntegrityState::CalInvalid)
        .expect("valid again");
    assert!((6..=9).contains(&back), "{back}");
}

/// A sample is `ok` only against an inclination the stream did not teach
/// itself: the same undisturbed turning stream is `ok` with the
/// reference's inclination and `unjudged` — never `ok` — with none, the
/// dip learned all the same (the σ and the field checks are the same).
#[test]
fn without_a_reference_inclination_nothing_is_ok() {
    let cal = identity_cal();
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    for (incl, want) in [
        (Some(DIP_RAD), IntegrityState::Ok),
        (None, IntegrityState::Unjudged),
    ] {
        let mut online = OnlineIntegrity::new(reference(incl), Tuning::standard()).unwrap();
        let mut noise = Noise(5);
        let mut states = std::vec::Vec::new();
        for k in 0..600 {
            let t = k as f64 * DT_S;
            let (att, w) = motion(t);
            let b = ned_to_body(ned, att[0], att[1], att[2]);
            let raw = [0, 1, 2].map(|i| b[i] + SIGMA_NT * noise.next());
            states.push(
                online
                    .process(&cal, raw, Some(&Tilt::new(att[0], att[1])), Some(w), DT_S)
                    .verdict
                    .state,
            );
        }
        let of =
            |s: IntegrityState| states[50..].iter().filter(|x| **x == s).count() as f64 / 550.0;
        assert!(of(want) > 0.95, "{incl:?}: {}", of(want));
        if incl.is_none() {
            assert_eq!(of(IntegrityState::Ok), 0.0);
            // The dip was learned all the same (within a degree).
            assert!(
                (online.monitor().inclination_rad().unwrap() - DIP_RAD).abs() < 1f64.to_radians()
            );
        }
    }
}

mod registry;
