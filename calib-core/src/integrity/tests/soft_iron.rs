//! The horizontal intensity's two-cycle test on a level turn with a gain
//! error on x (a soft-iron error), checked against a hand calculation.
//!
//! Level (roll and pitch 0), heading `ψ` turning at 20°/s, 10 Hz, the
//! field `F` = 48 000 nT at dip 1.1 rad: `H = F cos I` = 21 774 nT,
//! `Z = F sin I` = 42 780 nT. The body field with the x gain `k` is
//! `(k H cos ψ, −H sin ψ, Z)`, so
//! `H_h² = H² ((k² + 1)/2 + (k² − 1)/2 · cos 2ψ)` and, to first order, the
//! two-cycle amplitude of `H_h` over its mean is `(k² − 1) / (2 (k² + 1))`:
//! k = 1.05 → 0.0244 (1.40°), k = 1.15 → 0.0694 (3.98°), k = 1.3 → 0.1283
//! (7.35°). The heading's error is `atan(tan ψ / k) − ψ`, at most
//! `atan((k − 1) / (2 √k))`: 1.40°, 4.00°, 7.50° (the amplitude above is
//! this error's, as the test intends). The limit is 3°: 1.05 is never
//! found, 1.15 and 1.3 are. The reference's σ is 1.2 % of F (576 nT, the
//! board's default), so k = 1.15's largest |F| (49 570 nT, 2.7σ) and dip
//! residual (`(Z/|F| − sin I) F / (σ cos I)` = 5.2σ) are inside the test's
//! wider gate (7.5σ) and every heading counts; k = 1.3's dip residual at
//! ψ = 0 is 10.5σ, so the headings nearest north (where `H_h` is largest)
//! are kept out and the fit sees less than the full-circle 7.35°.

use super::Noise;
use crate::heading::{heading_of_levelled, ned_field, ned_to_body, Tilt};
use crate::integrity::two_cycle::fit;
use crate::integrity::{IntegrityState, Monitor, Reference, Tuning};

const F_NT: f64 = 48_000.0;
const DIP_RAD: f64 = 1.1;
const DT_S: f64 = 0.1;
const RATE_RAD_S: f64 = 20.0 * core::f64::consts::PI / 180.0;

/// The monitor of the level turns: the field `F_NT` at `DIP_RAD`, its
/// allowance and noise `sigma_nt`, the standard tuning.
fn level_turn_monitor(sigma_nt: f64) -> Monitor<f64> {
    let reference = Reference { field_nt: F_NT, field_sigma_nt: sigma_nt, noise_nt: sigma_nt, inclination_rad: Some(DIP_RAD), heading_sigma_rad: 0.0 };
    Monitor::new(reference, Tuning::standard()).unwrap()
}

/// Runs a level turn of `n` samples with the x gain `k` (uniform noise of
/// RMS 576 nT per axis); returns the monitor and each sample's state and
/// whether the two-cycle test had found the error.
fn turn(k: f64, n: usize) -> (Monitor<f64>, std::vec::Vec<(IntegrityState, bool)>) {
    let sigma = 0.012 * F_NT;
    let mut m = level_turn_monitor(sigma);
    let mut noise = Noise(11);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let tilt = Tilt::new(0.0, 0.0);
    let states = (0..n)
        .map(|i| {
            let psi = 0.3 + RATE_RAD_S * i as f64 * DT_S;
            let b = ned_to_body(ned, 0.0, 0.0, psi);
            let h = [k * b[0], b[1], b[2]].map(|v| v + super::NOISE * sigma * noise.next());
            let heading = heading_of_levelled(tilt.level(h));
            let state = m.step(h, heading, Some(&tilt), Some([0.0, 0.0, RATE_RAD_S]), DT_S).state;
            (state, m.two_cycle_found())
        })
        .collect();
    (m, states)
}

/// The fit's amplitude over its level, degrees of heading.
fn amplitude_deg(m: &Monitor<f64>) -> f64 {
    let (amp, _, c0) = fit(&m.two_cycle.total).unwrap();
    (amp / c0).to_degrees()
}

#[test]
fn a_gain_error_on_x_is_found_by_the_horizontal_intensitys_two_cycle_variation() {
    // Two full turns (36 s).
    let n = 360;
    // (gain, hand amplitude °, found, found within this many samples).
    for (k, want_deg, found, within) in [(1.0, 0.0, false, 0), (1.05, 1.40, false, 0), (1.15, 3.98, true, 180), (1.3, 7.35, true, 90)] {
        let (m, states) = turn(k, n);
        let amp = amplitude_deg(&m);
        let first = states.iter().position(|(_, found)| *found);
        std::println!("k {k}: amplitude {amp:.2}° (hand {want_deg}°), found {}, first found at sample {first:?}", m.two_cycle_found());
        // The hand value within 0.35° (the noise over the fit's memory of
        // about 80 samples, the second-order terms; measured 0.28°, 1.36°,
        // 3.98°), and for 1.3 (its samples nearest north kept out by the
        // dip) between the limit and the hand value (measured 6.54°).
        if k < 1.2 {
            assert!((amp - want_deg).abs() < 0.35, "k {k}: {amp}° against {want_deg}°");
        } else {
            assert!((4.0..want_deg).contains(&amp), "k {k}: {amp}° against {want_deg}°");
        }
        assert_eq!(m.two_cycle_found(), found, "k {k}");
        if found {
            // Found within the first turn (1.15, 1° above the limit) or
            // half turn (1.3), and every sample after it is cal_invalid (the
            // finding counts from the next sample). Measured: the 111th and
            // the 47th sample.
            let first = first.unwrap();
            assert!(first < within, "k {k}: first at {first}");
            assert!(states[first + 1..].iter().all(|s| *s == (IntegrityState::CalInvalid, true)), "k {k}");
        } else {
            // Never found, and every sample ok (the field and the gyro fit).
            assert!(first.is_none(), "k {k}: {first:?}");
            assert!(states.iter().all(|(s, _)| *s == IntegrityState::Ok), "k {k}");
        }
    }
}

#[test]
fn the_fit_of_sums_from_outside_data_never_panics_and_decides_nothing() {
    use crate::integrity::two_cycle::judge;
    // No samples, too few, a single heading (no spread), and sums that are
    // not finite: undecided, the last finding stands.
    let one_heading = [8.0, 8.0, 0.0, 8.0, 0.0, 8.0e4, 8.0e4, 0.0, 8.0e8];
    for t in [[0.0; 9], [3.0, 0.0, 0.0, 1.5, 0.0, 3.0e4, 0.0, 0.0, 3.0e8], one_heading, [f64::NAN; 9], [f64::INFINITY; 9]] {
        assert_eq!(judge(&t), None, "{t:?}");
    }
    assert_eq!(judge(&[f32::NAN; 9]), None);
}

/// A level turn of the true calibration (`k` = 1) at `rate_deg_s` sampled
/// every `dt_s`, with a field of `extra_nt` along body x (a hull or a magnet
/// held in the body) from sample `start` for `len` samples, uniform noise
/// of RMS `noise_nt` per axis, without a gyro
/// (as the report's validation run); each sample's
/// state and whether the two-cycle test had found an error.
fn turn_with_a_body_fixed_transient(rate_deg_s: f64, dt_s: f64, n: usize, start: usize, len: usize, extra_nt: f64, noise_nt: f64) -> std::vec::Vec<(IntegrityState, bool)> {
    let mut m = level_turn_monitor(0.012 * F_NT);
    let mut noise = Noise(11);
    let ned = ned_field(F_NT, DIP_RAD, 0.0);
    let tilt = Tilt::new(0.0, 0.0);
    let rate = rate_deg_s.to_radians();
    (0..n)
        .map(|i| {
            let psi = 0.3 + rate * i as f64 * dt_s;
            let b = ned_to_body(ned, 0.0, 0.0, psi);
            let x = if (start..start + len).contains(&i) { extra_nt } else { 0.0 };
            let h = [b[0] + x, b[1], b[2]].map(|v| v + super::NOISE * noise_nt * noise.next());
            let heading = heading_of_levelled(tilt.level(h));
            // No gyro, as the report's validation run.
            let state = m.step(h, heading, Some(&tilt), None, dt_s).state;
            (state, m.two_cycle_found())
        })
        .collect()
}

/// Of a run with a transient over samples `start..start + len`: the
/// samples the two-cycle test found soft iron on, the transient's samples
/// not `ok`, and the samples not `ok` from `exit_rows` after it.
fn transient_counts(states: &[(IntegrityState, bool)], start: usize, len: usize, exit_rows: usize) -> (usize, usize, usize) {
    let not_ok = |rows: &[(IntegrityState, bool)]| rows.iter().filter(|(s, _)| *s != IntegrityState::Ok).count();
    let found = states.iter().filter(|(_, f)| *f).count();
    (found, not_ok(states.get(start..start + len).unwrap_or(&[])), not_ok(states.get(start + len + exit_rows..).unwrap_or(&[])))
}

#[test]
fn a_field_held_in_the_body_over_one_arc_is_not_taken_for_a_soft_iron_error() {
    // The report's case on the simulator's field: a level turn at 1° a
    // sample (2°/s at 2 Hz), and 5000 nT along x (23 % of H = 21 774 nT)
    // for 20 s over 40° of it (ψ 300–340°, x near the field's direction),
    // after the vehicle has turned 283°: the horizontal intensity rises by
    // 2500–5000 nT over that arc only. A gain error would make H_h vary the
    // same way at the opposite headings; there the half-circles seen before
    // show no variation (k = 1: amplitude 0), so the test must never find
    // it, and the rows after the transient are ok again once the misfit
    // fraction's exit has passed (τ ln 10 = 4.6 s). Without noise (as the
    // report's run) and with 100 nT per axis.
    let (dt_s, start, len) = (0.5, 283, 40);
    for noise_nt in [0.0, 100.0] {
        let states = turn_with_a_body_fixed_transient(2.0, dt_s, 600, start, len, 5000.0, noise_nt);
        let (found, not_ok_during, not_ok_after) = transient_counts(&states, start, len, (4.6 / dt_s).ceil() as usize + 1);
        std::println!("noise {noise_nt} nT: found on {found} samples, {not_ok_during} of {len} transient samples not ok, {not_ok_after} not ok after the exit");
        // Measured: never found, no row not ok after the exit. Before the
        // half-circles' veto: found on 154 and 152 samples, 140 and 139
        // rows not ok after the exit.
        assert_eq!(found, 0, "noise {noise_nt}");
        assert_eq!(not_ok_after, 0, "noise {noise_nt}");
        // The transient itself is flagged by the field's gates (measured:
        // all 40).
        assert!(not_ok_during * 10 >= len * 9, "noise {noise_nt}: {not_ok_during} of {len}");
    }
}

#[test]
fn a_field_held_in_the_body_before_the_vehicle_has_turned_a_quarter_is_not_taken_for_a_soft_iron_error() {
    // The report's hull (5000 nT along x for 40 samples, 1° a sample at
    // 2 Hz, no gyro) met as the turn begins: after 0–30° of turning (ψ
    // from 17°), so no half-circle clear of it has been seen to veto it,
    // and over one quadrant any rise and fall of H_h fits a two-cycle
    // variation. With the true calibration (k = 1: no two-cycle
    // variation) the test must not find it before the vehicle reaches a
    // second quadrant, by when the totals have forgotten it or the second
    // quadrant vetoes it.
    let (dt_s, len) = (0.5_f64, 40);
    // The misfit fraction's exit after the transient (τ ln 10 = 4.6 s).
    let exit_rows = (4.6 / dt_s).ceil() as usize + 1;
    for start in [0, 10, 20, 30] {
        let states = turn_with_a_body_fixed_transient(2.0, dt_s, 600, start, len, 5000.0, 0.0);
        let (found, not_ok_during, not_ok_after) = transient_counts(&states, start, len, exit_rows);
        std::println!("start {start}: found on {found} samples, {not_ok_during} of {len} transient samples not ok, {not_ok_after} not ok after the exit");
        // Measured: never found, none not ok after the exit. Before the
        // wait for a second quadrant: found on 64, 40, 24 and 8 samples,
        // 27, 19, 9 and 0 rows not ok after the exit. The field's gates
        // flag the transient itself (measured 40, 40, 40 and 30 of its 40
        // samples: from 30° on, its last samples lie across x, where
        // 5000 nT moves |F| and the dip less).
        assert_eq!(found, 0, "start {start}");
        assert_eq!(not_ok_after, 0, "start {start}");
        assert!(not_ok_during * 10 >= len * 7, "start {start}: {not_ok_during} of {len}");
    }
    // With 100 nT a sample per axis the transient still wins where the
    // totals still hold it when the second quadrant's first block comes
    // (nothing tells the two apart then: a gain error's first finding on
    // BROAD 30 looks the same). Over the starts 0–40° (every 5°), rows not
    // ok after the exit: measured 201 (before the wait: 382).
    let mut not_ok_after = 0;
    for start in (0..=40).step_by(5) {
        let states = turn_with_a_body_fixed_transient(2.0, dt_s, 600, start, len, 5000.0, 100.0);
        not_ok_after += transient_counts(&states, start, len, exit_rows).2;
    }
    std::println!("100 nT, starts 0–40°: {not_ok_after} rows not ok after the exit");
    assert!(not_ok_after <= 250, "{not_ok_after}");
}
