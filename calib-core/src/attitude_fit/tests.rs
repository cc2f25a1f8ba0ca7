//! The attitude-aided fit on physics-built data: a glider's motion (every
//! heading, roll ±15°, pitch ±25° while gliding) through a known Earth field,
//! distorted by a known soft-iron matrix and hard iron; the fit must give
//! them back.

use super::*;
use crate::heading::{magnetic_heading_rad, ned_field, ned_to_body, wrap_pi};

/// The true calibration: `h = M·(raw − b)` (raw in counts, ~0.1 µT each),
/// `M` with scale errors, couplings and a 0.1° skew (misalignment).
fn truth() -> FieldCal<f64> {
    let s = 0.1f64.to_radians();
    FieldCal {
        bias: [310.0, -145.0, 220.0],
        matrix: [[95.0, -7.3 + 95.0 * s, 5.1], [-7.3 - 95.0 * s, 106.0, -6.6], [5.1, -6.6, 98.7]],
    }
}

const FIELD_NT: f64 = 52_000.0;
const DIP_DEG: f64 = 67.8;

/// A deterministic Gaussian-ish noise (sum of four uniforms, σ ≈ 0.58·amp).
struct Noise(u64);
impl Noise {
    fn next(&mut self, amp: f64) -> f64 {
        let mut s = 0.0;
        for _ in 0..4 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            s += (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        }
        s * amp
    }
}

/// (roll, pitch, yaw) in rad at sample `i`: dives and climbs (pitch ±25°
/// switching every 150 samples), a slow roll of ±15°, heading through three
/// turns.
fn attitude(i: usize, n: usize) -> (f64, f64, f64) {
    let t = i as f64;
    let pitch = if (i / 150).is_multiple_of(2) { -25.0 } else { 22.0 } + 3.0 * (t / 7.0).sin();
    let roll = 15.0 * (t / 23.0).sin();
    let yaw = 3.0 * core::f64::consts::TAU * t / n as f64;
    (roll.to_radians(), pitch.to_radians(), yaw)
}

/// `n` samples; `field_noise_counts` on each axis; `bad_every`-th sample
/// with a wrong attitude (a wave or an AHRS glitch: 20° of roll error).
fn samples(n: usize, field_noise_counts: f64, bad_every: usize) -> (Vec<AttitudeSample<f64>>, Vec<f64>) {
    let cal = truth();
    let inv = inverse3(&cal.matrix).unwrap();
    let ned = ned_field(FIELD_NT, DIP_DEG.to_radians(), 0.0);
    let mut noise = Noise(7);
    let mut out = Vec::new();
    let mut yaw_out = Vec::new();
    for i in 0..n {
        let (roll, pitch, yaw) = attitude(i, n);
        let h = ned_to_body(ned, roll, pitch, yaw);
        let d = mul_mat_vec(&inv, h);
        let raw = core::array::from_fn(|k| d[k] + cal.bias[k] + noise.next(field_noise_counts));
        let logged_roll = if bad_every > 0 && i % bad_every == 0 { roll + 20f64.to_radians() } else { roll };
        out.push(AttitudeSample { raw, tilt: Tilt::new(logged_roll, pitch) });
        yaw_out.push(yaw);
    }
    (out, yaw_out)
}

/// RMS heading error of `cal` on clean data (no bad attitudes), degrees.
fn heading_rms_deg(cal: &FieldCal<f64>) -> f64 {
    let n = 720;
    let inv = inverse3(&truth().matrix).unwrap();
    let ned = ned_field(FIELD_NT, DIP_DEG.to_radians(), 0.0);
    let mut ss = 0.0;
    for i in 0..n {
        let (roll, pitch, yaw) = attitude(i, n);
        let d = mul_mat_vec(&inv, ned_to_body(ned, roll, pitch, yaw));
        let raw = core::array::from_fn(|k| d[k] + truth().bias[k]);
        let e = wrap_pi(magnetic_heading_rad(cal.apply(raw), roll, pitch) - yaw);
        ss += e * e;
    }
    (ss / n as f64).sqrt().to_degrees()
}

fn max_rel_matrix_error(cal: &FieldCal<f64>) -> f64 {
    let t = truth();
    let mut worst = 0.0f64;
    for i in 0..3 {
        for j in 0..3 {
            worst = worst.max((cal.matrix[i][j] - t.matrix[i][j]).abs() / 100.0);
        }
    }
    worst
}

#[test]
fn a_glider_motion_gives_back_the_soft_and_hard_iron() {
    // Noise of σ ≈ 2.3 counts (0.23 µT) per axis. Measured: bias within
    // 0.5 count, matrix within 0.15 % of the gain, dip 0.01°, heading
    // 0.059° RMS (the covariance predicts 0.047°), σ 233 nT.
    let (s, _) = samples(1500, 4.0, 0);
    let est = fit_attitude(&s, FIELD_NT, &AttitudeConfig::new()).unwrap();
    for k in 0..3 {
        assert!((est.cal.bias[k] - truth().bias[k]).abs() < 3.0, "{:?}", est.cal.bias);
    }
    assert!(max_rel_matrix_error(&est.cal) < 5e-3, "{:?}", est.cal.matrix);
    assert!((est.dip_rad.to_degrees() - DIP_DEG).abs() < 0.03, "{}", est.dip_rad.to_degrees());
    let h = heading_rms_deg(&est.cal);
    eprintln!("bias {:?}, matrix error {:.2e}, dip {:.4}°, heading {h:.3}°, predicted {:.3}°, σ {:.0} nT", est.cal.bias, max_rel_matrix_error(&est.cal), est.dip_rad.to_degrees(), est.predicted_heading_rms_rad.to_degrees(), est.residual_sigma_nt);
    assert!(h < 0.15, "{h}");
    // The covariance knows the error is small, and says so in the same units.
    let p = est.predicted_heading_rms_rad.to_degrees();
    assert!(p > 0.015 && p < 0.15, "{p}");
    // The robust scale is the noise: 4 counts·0.58 ≈ 2.3 counts ≈ 230 nT per
    // axis, the levelled residuals are about that.
    assert!(est.residual_sigma_nt > 100.0 && est.residual_sigma_nt < 500.0, "{}", est.residual_sigma_nt);
}

#[test]
fn bad_attitudes_are_down_weighted() {
    // One sample in ten with 20° of roll error. Measured: heading 0.15°
    // with the robust loss, 3.2° with plain least squares.
    let (s, _) = samples(1500, 4.0, 10);
    let robust = fit_attitude(&s, FIELD_NT, &AttitudeConfig::new()).unwrap();
    let plain = fit_attitude(&s, FIELD_NT, &AttitudeConfig { huber_k: 1e9, ..AttitudeConfig::new() }).unwrap();
    let (hr, hp) = (heading_rms_deg(&robust.cal), heading_rms_deg(&plain.cal));
    eprintln!("robust {hr:.3}°, plain {hp:.3}°, down-weighted {}", robust.downweighted);
    assert!(hr < 0.3 && hr < 0.5 * hp, "robust {hr}°, plain {hp}°");
    assert!(robust.downweighted >= 150, "{}", robust.downweighted);
}

/// The samples rounded to `f32`, as the board holds them.
fn to_f32(s: &[AttitudeSample<f64>]) -> Vec<AttitudeSample<f32>> {
    s.iter()
        .map(|a| AttitudeSample {
            raw: a.raw.map(|v| v as f32),
            tilt: Tilt { sin_roll: a.tilt.sin_roll as f32, cos_roll: a.tilt.cos_roll as f32, sin_pitch: a.tilt.sin_pitch as f32, cos_pitch: a.tilt.cos_pitch as f32 },
        })
        .collect()
}

#[test]
fn f32_gives_the_f64_heading() {
    let (s, _) = samples(1500, 4.0, 0);
    let s32 = to_f32(&s);
    let e32 = fit_attitude(&s32, FIELD_NT as f32, &AttitudeConfig::new()).unwrap();
    let cal = FieldCal { bias: e32.cal.bias.map(f64::from), matrix: e32.cal.matrix.map(|r| r.map(f64::from)) };
    let h = heading_rms_deg(&cal);
    // Measured: 0.059°, as in f64.
    eprintln!("f32: heading {h:.3}°");
    assert!(h < 0.2, "{h}");
}

#[test]
fn bad_input_is_refused_with_its_reason() {
    let (s, _) = samples(1500, 4.0, 0);
    assert_eq!(fit_attitude(&s[..12], FIELD_NT, &AttitudeConfig::new()).unwrap_err(), FitError::TooFewSamples { have: 12, need: 13 });
    assert_eq!(fit_attitude(&s, f64::NAN, &AttitudeConfig::new()).unwrap_err(), FitError::BadReference);
    // NaN attitudes are left out, not fitted.
    let mut with_nan = s.clone();
    for a in with_nan.iter_mut().step_by(3) {
        a.tilt.sin_roll = f64::NAN;
    }
    assert!(fit_attitude(&with_nan, FIELD_NT, &AttitudeConfig::new()).unwrap().samples == 1000);
    // One heading, level: the horizontal is not determined.
    let still: Vec<_> = (0..200).map(|_| AttitudeSample { raw: s[0].raw, tilt: Tilt::new(0.0, 0.0) }).collect();
    assert!(fit_attitude(&still, FIELD_NT, &AttitudeConfig::new()).is_err());
}

/// The fit with working memory is the fit without, bit for bit (the
/// median by selection runs the same bisection as the one by counting), in
/// `f64` and `f32`, with outliers and with some samples left out; a scratch
/// too short falls back to counting.
#[test]
fn working_memory_changes_nothing() {
    let (mut s, _) = samples(1500, 4.0, 10);
    for a in s.iter_mut().step_by(7) {
        a.tilt.sin_roll = f64::NAN;
    }
    let cfg = AttitudeConfig::new();
    let without = fit_attitude(&s, FIELD_NT, &cfg).unwrap();
    let mut scratch = vec![0.0; scratch_len(s.len())];
    assert_eq!(fit_attitude_in(&s, FIELD_NT, &cfg, &mut scratch).unwrap(), without);
    assert_eq!(fit_attitude_in(&s, FIELD_NT, &cfg, &mut scratch[..10]).unwrap(), without);
    let s32 = to_f32(&s);
    let mut scratch32 = vec![0.0f32; scratch_len(s32.len())];
    assert_eq!(fit_attitude_in(&s32, FIELD_NT as f32, &AttitudeConfig::new(), &mut scratch32).unwrap(), fit_attitude(&s32, FIELD_NT as f32, &AttitudeConfig::new()).unwrap());
}

/// Started near (the whole recording's fit, for a fit of four fifths of
/// it), the fit ends where it ends from its own start: the iterations'
/// fixed point is the data's, not the start's. With a dip prior whose
/// weight the data's scatter sets (read at a different point on the two
/// paths) and one attitude in ten wrong (the robust loss at work).
/// Both converge before the prior's weight is read, so they read the same
/// weight. Measured: the start 1.8e-3 of the gain from the fold's fit;
/// they end 1e-15 of the gain (matrix), 4e-13 counts (hard iron), 2e-16
/// rad (dip) apart. A start that is no calibration (a singular matrix)
/// is the fit from its own start, bit for bit.
#[test]
fn a_fit_started_near_ends_where_it_ends_from_its_own_start() {
    let (s, _) = samples(1500, 4.0, 10);
    let cfg = AttitudeConfig { dip_prior: Some(((DIP_DEG + 0.5).to_radians(), 1f64.to_radians())), ..AttitudeConfig::new() };
    let fold: Vec<_> = s[..600].iter().chain(&s[900..]).copied().collect();
    let mut scratch = vec![0.0; scratch_len(s.len())];
    let whole = fit_attitude_in(&s, FIELD_NT, &cfg, &mut scratch).unwrap();
    let own = fit_attitude_in(&fold, FIELD_NT, &cfg, &mut scratch).unwrap();
    let near = fit_attitude_near(&fold, FIELD_NT, &cfg, &mut scratch, &whole.cal).unwrap();
    // The start is not the answer: the fold's fit is elsewhere.
    let moved = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max((whole.cal.matrix[i][j] - own.cal.matrix[i][j]).abs() / 100.0));
    let apart = (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max((near.cal.matrix[i][j] - own.cal.matrix[i][j]).abs() / 100.0));
    let bias = (0..3).fold(0.0f64, |m, k| m.max((near.cal.bias[k] - own.cal.bias[k]).abs()));
    eprintln!("start {moved:.1e} from the fold's fit; ends {apart:.1e} (matrix), {bias:.1e} counts (hard iron), {:.1e} rad (dip) apart", (near.dip_rad - own.dip_rad).abs());
    assert!(moved > 1e-5, "{moved}");
    assert!(apart < 1e-11, "{apart}");
    assert!(bias < 1e-8, "{bias}");
    assert!((near.dip_rad - own.dip_rad).abs() < 1e-12);
    assert!((near.dip_data_inflation / own.dip_data_inflation - 1.0).abs() < 1e-9, "{} {}", near.dip_data_inflation, own.dip_data_inflation);
    let singular = FieldCal { bias: [0.0; 3], matrix: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]] };
    assert_eq!(fit_attitude_near(&fold, FIELD_NT, &cfg, &mut scratch, &singular).unwrap(), own);
}

/// The normal equations summed through the rows' structure are the rows'
/// outer products summed one by one (the square-root form's rows, added to
/// the normal equations): the same step and covariance to rounding, plain
/// and reweighted, at a point away from the solution. Measured: 4e-14 of
/// the step, 1e-13 of the covariance (relative to its diagonal).
#[test]
fn the_structured_normal_equations_are_the_rows_summed() {
    let (s, _) = samples(1500, 4.0, 10);
    let cfg = AttitudeConfig { dip_prior: Some((DIP_DEG.to_radians(), 1f64.to_radians())), ..AttitudeConfig::new() };
    let norm = Normalization::from_raw_iter(s.iter().map(|a| a.raw)).unwrap();
    let data = Prepared { samples: &s, norm };
    let x = start(&data, &cfg);
    let sigma = median_abs_residual(&x, &data, &mut []) / 0.6745;
    for robust in [false, true] {
        let (rows, down_rows) = step::<f64, NormalEquations<f64, UNKNOWNS>>(&x, &data, &cfg, sigma, robust, 1.3);
        let (structured, down) = reweighted_pass(&x, &data, &cfg, sigma, robust, 1.3);
        assert_eq!(down, down_rows);
        let (a, b) = (rows.solve().unwrap(), structured.solve().unwrap());
        let step = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let apart = a.iter().zip(&b).fold(0.0f64, |m, (p, q)| m.max((p - q).abs()));
        let (ca, cb) = (rows.covariance().unwrap(), structured.covariance().unwrap());
        let cov_apart = (0..UNKNOWNS).flat_map(|i| (0..UNKNOWNS).map(move |j| (i, j))).fold(0.0f64, |m, (i, j)| m.max((ca[i][j] - cb[i][j]).abs() / (ca[i][i] * ca[j][j]).sqrt()));
        eprintln!("robust {robust}: step {step:.1e}, apart {:.1e} of it; covariance {cov_apart:.1e}", apart / step);
        assert!(step > 1e-4 && apart < 1e-12 * step, "{step} {apart}");
        assert!(cov_apart < 1e-12, "{cov_apart}");
    }
    // Newton's with every residual within the threshold is the plain step.
    let wide = AttitudeConfig { huber_k: 1e12, ..cfg };
    let (plain, _) = reweighted_pass(&x, &data, &wide, sigma, false, 1.3);
    let (a, b) = (plain.solve().unwrap(), newton_step(&x, &data, &wide, sigma, 1.3).unwrap());
    assert!(a.iter().zip(&b).all(|(p, q)| (p - q).abs() < 1e-12 * p.abs().max(1e-6)), "{a:?} {b:?}");
}
