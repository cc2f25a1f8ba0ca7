//! The recovery of the stored calibration from an on-line hard iron that a
//! transient left applied: a vehicle turning and rocking in a known field
//! (the frame equations of `heading.rs`), the gyro's body rates from the
//! Euler-angle rates.

extern crate std;

use super::*;
use crate::cal::{EnvTerms, FieldCal, Swing};
use crate::hardiron::HardIron;
use crate::heading::{ned_field, ned_to_body};
use crate::linalg::identity3;
use std::vec::Vec;

const F_NT: f64 = 48_000.0;
const SIGMA_NT: f64 = 300.0;
const DIP_RAD: f64 = 1.1;
const DT_S: f64 = 0.1;

/// Attitude and body rates at time t: roll and pitch rocking (±0.35 and
/// ±0.25 rad), the yaw sweeping ±0.5 rad (±29°) with a 31 s period —
/// never the 90° a window must turn to confirm an on-line hard iron (at
/// most 74° in 20 s).
fn sweep(t: f64) -> ([f64; 3], [f64; 3]) {
    let (roll, roll_dot) = (0.35 * (0.7 * t).sin(), 0.35 * 0.7 * (0.7 * t).cos());
    let (pitch, pitch_dot) = (0.25 * (0.45 * t).sin(), 0.25 * 0.45 * (0.45 * t).cos());
    let yaw_dot = 0.1 * (0.2 * t).cos();
    let (sr, cr, sp, cp) = (roll.sin(), roll.cos(), pitch.sin(), pitch.cos());
    let w = [
        roll_dot - sp * yaw_dot,
        cr * pitch_dot + sr * cp * yaw_dot,
        -sr * pitch_dot + cr * cp * yaw_dot,
    ];
    ([roll, pitch, 0.3 + 0.5 * (0.2 * t).sin()], w)
}

/// After a transient the estimator may have formed an offset from the
/// transient's samples and the clean ones after it, small enough that the
/// field it corrects fits too, and the guard applies it. Nothing then
/// confirms it (the vehicle never turns 90° in a window) and nothing
/// refutes it (its field fits): before the stored calibration's own check,
/// every sample after it stayed `cal_invalid` to the end (measured: 0 of
/// the 1 500 samples ok, the test failing at "never came back"). Now the stored field's misfit fraction falls
/// below `Tuning::misfit_exit` (from 1, 4.5 s at a 2 s time constant, and
/// tracked for at least 6 s) while its headings agree with the gyro for
/// `Tuning::recover_s`: the estimate is withdrawn and the stored
/// calibration is `ok` again (measured: from 6.2 s after the application
/// on, every sample).
#[test]
fn an_estimate_a_transient_left_applied_gives_way_to_the_stored_calibration() {
    let cal = Calibration {
        field: FieldCal { bias: [0.0; 3], matrix: identity3() },
        swing: Swing::zero(),
        declination_rad: 0.0,
        env: EnvTerms::none(),
    };
    let reference = Reference {
        field_nt: F_NT,
        field_sigma_nt: SIGMA_NT,
        noise_nt: SIGMA_NT,
        inclination_rad: Some(DIP_RAD),
        heading_sigma_rad: 0.0,
    };
    let mut online = OnlineIntegrity::new(reference, Tuning::standard()).unwrap();
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    // A deterministic noise, ±σ per axis.
    let mut seed = 9u64;
    let mut noise = || {
        seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    };
    let mut states: Vec<(f64, IntegrityState)> = Vec::new();
    for k in 0..1800 {
        let t = k as f64 * DT_S;
        if k == 300 {
            // What the transient left: 781 nT, σ 50 nT, within the guard.
            let e = HardIron { offset_nt: [600.0, -400.0, 300.0], sigma_nt: [50.0; 3], residual_rms_z: 1.0 };
            online.try_apply(&e, Some(DIP_RAD.sin()));
            assert!(online.applied_offset_nt().is_some(), "the guard applies it");
        }
        let (att, w) = sweep(t);
        let b = ned_to_body(ned, att[0], att[1], att[2]);
        let raw = [0, 1, 2].map(|i| b[i] + SIGMA_NT * noise());
        let out = online.process(&cal, raw, Some(&Tilt::new(att[0], att[1])), Some(w), DT_S);
        states.push((t, out.verdict.state));
    }
    let ok = |from_s: f64| {
        let after: Vec<_> = states.iter().filter(|(t, _)| *t >= from_s).collect();
        after.iter().filter(|(_, s)| *s == IntegrityState::Ok).count() as f64 / after.len() as f64
    };
    let first_ok = states.iter().find(|(t, s)| *t >= 30.0 && *s == IntegrityState::Ok).map(|(t, _)| t - 30.0);
    std::println!("ok before {:.3}, after the application {:.3}, from 10 s after {:.3}; first ok {first_ok:?} s after", ok(0.0), ok(30.0), ok(40.0));
    // Clean before it: every sample ok.
    assert!(states[..300].iter().all(|(_, s)| *s == IntegrityState::Ok));
    // Back within 10 s (measured 6.2 s), and ok from then on.
    let first_ok = first_ok.expect("the stored calibration never came back");
    assert!(first_ok < 10.0, "{first_ok}");
    assert_eq!(ok(40.0), 1.0);
    assert_eq!(online.applied_offset_nt(), None);
}
