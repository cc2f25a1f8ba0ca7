//! The test data are made here from the physics, independently of the
//! estimator: a raw sample is `g(T) ⊙ (D·h_body + b + c·I) + noise` with
//! `g(T) = 1 + k·(T − T₀)`, the body field is the *local* field (IGRF plus
//! an anomaly) rotated by the true attitude, and the AHRS reports roll and
//! pitch with a constant misalignment and noise.

use super::*;
use crate::backstep::Leg;
use crate::cal::Environment;
use crate::conformance::SplitMix64;
use crate::heading::{magnetic_heading_rad, ned_to_body};

/// IGRF at the site (the reference the estimator gets): N, E, D, nT.
const IGRF_NED: [f64; 3] = [27_450.0, 0.0, 40_289.0];
/// The local anomaly added to it (not along F, so the inclination changes).
const ANOMALY_NED: [f64; 3] = [-80.0, 40.0, 90.0];

#[derive(Clone, Copy)]
struct Truth {
    d: [[f64; 3]; 3],
    b: [f64; 3],
    c_per_a: [f64; 3],
    k_per_c: [f64; 3],
    t0_c: f64,
    /// Added by the AHRS to the true roll and pitch, rad.
    ahrs_offset_rad: [f64; 2],
}

fn truth() -> Truth {
    Truth {
        d: [[0.19556, 0.003, 0.004], [0.003, 0.09001, -0.002], [0.0035, -0.002, 0.16142]],
        b: [-1865.0, 1385.0, -903.0],
        c_per_a: [4.0, -3.0, 8.0],
        k_per_c: [0.003, -0.002, 0.0025],
        t0_c: 15.0,
        ahrs_offset_rad: [0.8f64.to_radians(), -0.5f64.to_radians()],
    }
}

fn local_ned() -> [f64; 3] {
    [0, 1, 2].map(|i| IGRF_NED[i] + ANOMALY_NED[i])
}

fn raw_of(t: &Truth, h_body: [f64; 3], current_a: f64, temp_c: f64, noise: [f64; 3]) -> [f64; 3] {
    let r = crate::linalg::mul_mat_vec(&t.d, h_body);
    [0, 1, 2].map(|i| (1.0 + t.k_per_c[i] * (temp_c - t.t0_c)) * (r[i] + t.b[i] + t.c_per_a[i] * current_a) + noise[i])
}

struct Conditions {
    current: fn(usize) -> f64,
    temp: fn(usize) -> f64,
}

/// Thrusters stepped every 400 s between 2 and 14 A; the temperature cycling
/// with the depth by ±4 °C around 16 °C.
const VARYING: Conditions = Conditions { current: |k| [2.0, 8.0, 14.0, 5.0][(k / 400) % 4], temp: |k| 16.0 + 4.0 * (k as f64 * core::f64::consts::TAU / 1700.0).sin() };

/// An out-and-back run (course 62° then 242°, ±10° zig-zags) at 1 Hz.
fn run(t: &Truth, cond: &Conditions, seed: u64) -> Vec<RunSample<f64>> {
    let mut rng = SplitMix64::new(seed);
    let f = local_ned();
    (0..6000)
        .map(|k| {
            let back = k >= 3000;
            let course: f64 = if back { 242.0 } else { 62.0 };
            let yaw = (course + 10.0 * (k as f64 * 0.004).sin()).to_radians();
            let (roll, pitch) = ((3.0 * (k as f64 * 0.05).sin()).to_radians(), (8.0 * (k as f64 * 0.003).sin()).to_radians());
            let h = ned_to_body(f, roll, pitch, yaw);
            let (i_a, t_c) = ((cond.current)(k), (cond.temp)(k));
            let raw = raw_of(t, h, i_a, t_c, [0.5 * rng.gauss(), 0.5 * rng.gauss(), 0.5 * rng.gauss()]);
            let ahrs_noise = 0.03f64.to_radians();
            let leg = if (2500..3000).contains(&k) { Leg::Out } else if (3000..3500).contains(&k) { Leg::Back } else { Leg::Other };
            RunSample {
                raw,
                roll_rad: roll + t.ahrs_offset_rad[0] + ahrs_noise * rng.gauss(),
                pitch_rad: pitch + t.ahrs_offset_rad[1] + ahrs_noise * rng.gauss(),
                h_ref_nt: IGRF_NED[0],
                z_ref_nt: IGRF_NED[2],
                leg,
                current_a: i_a,
                temp_c: t_c,
                position_m: [f64::NAN; 2],
            }
        })
        .collect()
}

/// A swing test: two turns with ±25° roll and ±10° pitch, thrusters off.
fn swing(t: &Truth, seed: u64) -> Vec<SwingSample<f64>> {
    let mut rng = SplitMix64::new(seed ^ 0xABCD);
    let f = local_ned();
    (0..720)
        .map(|k| {
            let yaw = (k as f64).to_radians();
            let (roll, pitch) = ((25.0 * (k as f64 * 0.07).sin()).to_radians(), (10.0 * (k as f64 * 0.031).cos()).to_radians());
            let h = ned_to_body(f, roll, pitch, yaw);
            let temp_c = 18.0;
            SwingSample { raw: raw_of(t, h, 0.0, temp_c, [0.5 * rng.gauss(), 0.5 * rng.gauss(), 0.5 * rng.gauss()]), current_a: 0.0, temp_c }
        })
        .collect()
}

/// What a step-1 axis fit would start from: the diagonal, 1–2 % off, and
/// the bias 20–40 counts off.
fn start(t: &Truth) -> FieldCal<f64> {
    let s = [t.d[0][0] * 1.01, t.d[1][1] * 0.99, t.d[2][2] * 1.02];
    let z = 0.0;
    FieldCal { bias: [t.b[0] + 30.0, t.b[1] - 20.0, t.b[2] + 40.0], matrix: [[1.0 / s[0], z, z], [z, 1.0 / s[1], z], [z, z, 1.0 / s[2]]] }
}

fn igrf_f() -> f64 {
    (IGRF_NED[0] * IGRF_NED[0] + IGRF_NED[2] * IGRF_NED[2]).sqrt()
}

/// RMS heading error of the calibration on a level 360° turn (5° steps) at
/// varying current and temperature, against the heading from the local
/// field's north; the AHRS reports its misalignment.
fn validation_rms_deg(t: &Truth, sol: &JointSolution<f64>, seed: u64) -> f64 {
    validation_at(t, sol, seed, None)
}

/// As [`validation_rms_deg`], at fixed conditions when given.
fn validation_at(t: &Truth, sol: &JointSolution<f64>, seed: u64, at: Option<Environment<f64>>) -> f64 {
    let mut rng = SplitMix64::new(seed ^ 0x5555);
    let f = local_ned();
    let local_north = f[1].atan2(f[0]);
    let mut ss = 0.0;
    for step in 0..72 {
        let yaw = (step as f64 * 5.0).to_radians();
        let h = ned_to_body(f, 0.0, 0.0, yaw);
        let random = Environment { current_a: 2.0 + 12.0 * rng.uniform(), temp_c: 12.0 + 8.0 * rng.uniform() };
        let env = at.unwrap_or(random);
        let raw = raw_of(t, h, env.current_a, env.temp_c, [0.0; 3]);
        let field = sol.running.apply(sol.env.correct_raw(raw, &env));
        let psi = magnetic_heading_rad(field, t.ahrs_offset_rad[0], t.ahrs_offset_rad[1]);
        let e = crate::heading::wrap_pi(psi - (yaw - local_north));
        ss += e * e;
    }
    (ss / 72.0).sqrt().to_degrees()
}

#[test]
fn current_temperature_and_local_field_are_recovered() {
    let t = truth();
    let mut ratios = Vec::new();
    for seed in 1..=5u64 {
        let run = run(&t, &VARYING, seed);
        let sw = swing(&t, seed);
        let sol = joint_refine_env(&start(&t), &run, &sw, igrf_f(), &JointConfig { ref_c: Some(t.t0_c), ..JointConfig::default() }).unwrap();
        assert!(sol.current_estimated && sol.temperature_estimated, "{:?}", sol.notes);
        let c = sol.env.bias_per_a;
        let c_norm = t.c_per_a.iter().map(|v| v * v).sum::<f64>().sqrt();
        let c_err = (0..3).map(|i| (c[i] - t.c_per_a[i]).powi(2)).sum::<f64>().sqrt() / c_norm;
        let k_err = (0..3).map(|i| (sol.env.gain_per_c[i] - t.k_per_c[i]).abs()).fold(0.0, f64::max);
        let lf = local_ned();
        let (h_true, z_true) = (lf[0].hypot(lf[1]), lf[2]);
        let (h_est, z_est) = (sol.reference_hz_nt[0] + sol.local_offset_hz_nt[0], sol.reference_hz_nt[1] + sol.local_offset_hz_nt[1]);
        let incl_err_deg = (z_est.atan2(h_est) - z_true.atan2(h_true)).to_degrees();
        let f_err = h_est.hypot(z_est) - h_true.hypot(z_true);
        let f_sigma = sol.intensity_sigma_nt;
        let incl_sigma_deg = sol.sigma.local_inclination_rad.to_degrees();
        let observed = validation_rms_deg(&t, &sol, seed);
        let predicted = sol.predicted_heading_rms_rad.to_degrees();
        ratios.push(observed / predicted);
        eprintln!(
            "seed {seed}: c err {:.2} %, k err {:.2e}/°C, incl err {incl_err_deg:.4}° (σ {incl_sigma_deg:.4}°), F err {f_err:.1} nT (σ {f_sigma:.1}), heading {observed:.4}° predicted {predicted:.4}°, c {c:?} ± {:?}, k {:?} ± {:?}, δ {:?}, notes {:?}, iters {}",
            100.0 * c_err,
            k_err,
            sol.sigma.bias_per_a,
            sol.env.gain_per_c,
            sol.sigma.gain_per_c,
            sol.misalignment_rad,
            sol.notes,
            sol.iterations
        );
        // Measured ≤ 1.0 % (c), ≤ 3.3e-5/°C (k), ≤ 0.004° inclination (σ 0.0024°),
        // F −30 nT (σ 106, IGRF's: not observable), heading ≤ 0.01°.
        assert!(c_err < 0.03, "current vector off by {:.1} %", 100.0 * c_err);
        assert!(k_err < 1e-4, "gain off by {k_err:.2e}/°C");
        assert!(incl_err_deg.abs() < 4.0 * incl_sigma_deg, "inclination off by {incl_err_deg}°");
        assert!(f_err.abs() < 3.0 * f_sigma, "F off by {f_err} nT with σ {f_sigma}");
        assert!(observed < 0.03, "heading {observed}°");
    }
    // Each seed's observed RMS is one draw (a few effective degrees of
    // freedom: the horizontal bias), so single ratios scatter: measured 0.49,
    // 1.71, 1.17, 1.04, 0.62; pooled (RMS of the ratios) 1.08.
    let pooled = (ratios.iter().map(|r| r * r).sum::<f64>() / ratios.len() as f64).sqrt();
    eprintln!("observed / predicted: {ratios:?}, pooled {pooled:.2}");
    assert!(ratios.iter().all(|r| (0.4..=2.5).contains(r)), "{ratios:?}");
    assert!((0.7..=1.4).contains(&pooled), "{pooled}");
}


/// The same run with a constant current (or none) and constant temperature.
const CONSTANT: Conditions = Conditions { current: |_| 8.0, temp: |_| 16.0 };

#[test]
fn constant_current_and_temperature_are_refused_and_the_rest_still_fits() {
    let t = truth();
    let run = run(&t, &CONSTANT, 7);
    let sw = swing(&t, 7);
    let sol = joint_refine_env(&start(&t), &run, &sw, igrf_f(), &JointConfig::default()).unwrap();
    // The swing test's 0 A counts as data: with the run at a constant 8 A the
    // current still varies between the swing and the run, so use the run only.
    assert!(sol.current_estimated, "the swing test at 0 A against the run at 8 A separates the current");
    let sol = joint_refine_env(&start(&t), &run, &[], igrf_f(), &JointConfig::default()).unwrap();
    assert!(!sol.current_estimated && !sol.temperature_estimated);
    let msg = |n: &Option<JointNote<f64>>| n.map(|n| n.to_string()).unwrap_or_default();
    assert!(matches!(sol.notes[0], Some(JointNote::CurrentNotVaried { .. })), "{:?}", sol.notes);
    assert!(msg(&sol.notes[0]).contains("never varied"), "{}", msg(&sol.notes[0]));
    assert!(matches!(sol.notes[1], Some(JointNote::TemperatureConstant { .. })), "{:?}", sol.notes);
    assert!(msg(&sol.notes[1]).contains("constant"), "{}", msg(&sol.notes[1]));
    assert_eq!(sol.env.bias_per_a, [0.0; 3]);
    assert_eq!(sol.env.gain_per_c, [0.0; 3]);
    // The running bias takes the thrusters' 8 A field: c·8 A, through the gain at 16 °C.
    let want = [0, 1, 2].map(|i| t.c_per_a[i] * 8.0 + t.k_per_c[i] * (16.0 - t.t0_c) * (t.b[i] + t.c_per_a[i] * 8.0));
    for i in 0..3 {
        // Measured −21, −5, +4 counts (≈ 100 nT in x: the run alone, two
        // courses, leaves the horizontal bias weakly determined).
        assert!((sol.running.bias[i] - (t.b[i] + want[i])).abs() < 60.0, "{i}: {:?} vs {:?}", sol.running.bias, want);
    }
    // The fallback still calibrates the heading at the run's conditions:
    // measured 0.011° (predicted 0.0095°).
    let hdg = validation_at(&t, &sol, 7, Some(Environment { current_a: 8.0, temp_c: 16.0 }));
    eprintln!("fallback heading {hdg:.4}° (predicted {:.4}°)", sol.predicted_heading_rms_rad.to_degrees());
    assert!(hdg < 0.05, "{hdg}");
    // No current column at all.
    let mut none = run.clone();
    for s in none.iter_mut() {
        s.current_a = f64::NAN;
        s.temp_c = f64::NAN;
    }
    let sol = joint_refine_env(&start(&t), &none, &[], igrf_f(), &JointConfig::default()).unwrap();
    assert!(matches!(sol.notes[0], Some(JointNote::NoCurrentColumn)) && matches!(sol.notes[1], Some(JointNote::NoTemperatureColumn)), "{:?}", sol.notes);
    assert!(msg(&sol.notes[0]).contains("no motor current"));
}

#[test]
fn a_hypothetical_turn_lowers_the_predicted_error() {
    // The out-and-back alone (no swing test) leaves the horizontal bias
    // weakly determined across the two courses; a level turn determines it.
    let t = truth();
    let run = run(&t, &VARYING, 3);
    let sol = joint_refine_env(&start(&t), &run, &[], igrf_f(), &JointConfig { ref_c: Some(t.t0_c), ..JointConfig::default() }).unwrap();
    let now = sol.predicted_heading_rms_rad;
    let (per, with_turn) = sol.predicted_with(sol.level_turn(360)).unwrap();
    let (_, with_two) = sol.predicted_with(sol.level_turn(720)).unwrap();
    eprintln!("predicted {:.4}° now, {:.4}° with a turn, {:.4}° with two; per heading {:?}", now.to_degrees(), with_turn.to_degrees(), with_two.to_degrees(), per.map(f64::to_degrees));
    assert!(with_turn < 0.8 * now && with_two < with_turn, "{now} {with_turn} {with_two}");
    // The heading error varies with heading (not one number repeated).
    let (lo, hi) = sol.heading_sigma_rad.iter().fold((f64::MAX, 0.0f64), |(a, b), v| (a.min(*v), b.max(*v)));
    assert!(hi > 1.2 * lo, "{lo} {hi}");
}
