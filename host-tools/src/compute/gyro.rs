//! The gyro-aided fit ([`calib_core::gyro`]) on a recording: for a vehicle
//! that cannot tumble. Reads `t`, `gx, gy, gz` and, where present,
//! `roll_deg, pitch_deg`; says which parameters the data leave weak.

use calib_core::cal::FieldCal;
use calib_core::gyro::{fit_gyro_batch, GyroConfig, GyroSample, MAX_WINDOW_STEPS};

use super::error::{ComputeError, GyroError};
use crate::doc::results::GyroQuality;
use crate::data::Recording;

/// Integration window: 1.05 s (30 steps at BROAD's 28.6 Hz). Chosen
/// leave-one-trial-out on the four real BROAD trials (`tests/real_gyro.rs`)
/// among 10…50 steps that the ring holds (≤ `MAX_WINDOW_STEPS`): 30 won
/// every fold (10 steps cost 1.3° on trial 02, 20 steps 0.3°).
pub const WINDOW_S: f64 = 1.05;

/// Weight of the levelled-vertical equations against the kinematic ones.
/// Chosen leave-one-trial-out among 0.03…3 on the same trials: 0.03 and
/// 0.1 won every fold, within 0.001° of each other (0.1…0.5 within 0.04°;
/// 1 cost 0.3° on trial 02 and 3 cost 3.2°); of the tied ones the
/// stronger tie is kept, for vehicles that tilt less. The vertical is constant only in a uniform field with
/// an exact attitude; a real room's field varies along the path and the
/// AHRS has its own errors, so the constraint stays weak: it ties what the
/// gyro cannot see (the vertical gain and hard iron under small tilts).
pub const ATTITUDE_WEIGHT: f64 = 0.1;

/// A hard-iron 1σ above this fraction of the field (in raw units) is
/// reported as weakly determined.
const WEAK_BIAS_FRACTION: f64 = 0.005;
/// A soft-iron entry's 1σ above this (relative to the x gain) is reported.
const WEAK_MATRIX_REL: f64 = 0.01;
/// A predicted heading error above this is reported, degrees.
const WEAK_HEADING_DEG: f64 = 1.0;

/// The gyro rates at `t − lag_s`, linearly interpolated between rows
/// (NaN outside the recording or next to a missing rate).
pub(crate) fn rates_at_lag(t: &[f64], rates: &[[f64; 3]], lag_s: f64) -> Vec<[f64; 3]> {
    if lag_s == 0.0 {
        return rates.to_vec();
    }
    let axes: [Vec<f64>; 3] = core::array::from_fn(|k| rates.iter().map(|r| r[k]).collect());
    t.iter()
        .map(|&ti| match crate::data::pairing::bracket(t, ti - lag_s, f64::INFINITY) {
            Some(b) => core::array::from_fn(|k| b.lerp(&axes[k])),
            None => [f64::NAN; 3],
        })
        .collect()
}

/// The magnetometer's lag behind the gyro, for the gyro-aided fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GyroLag {
    /// Known, s: the rates are read this much earlier than each field sample.
    Given(f64),
    /// Estimated from the data ([`estimate_gyro_lag_s`]).
    Estimate,
}

impl Default for GyroLag {
    /// No lag.
    fn default() -> Self {
        GyroLag::Given(0.0)
    }
}

/// Largest lag [`estimate_gyro_lag_s`] searches, s.
pub const MAX_LAG_S: f64 = 0.25;

/// Estimates the magnetometer's lag behind the gyro: the lag (on a grid of
/// a quarter of the sample interval within ±[`MAX_LAG_S`]) whose rates make
/// the kinematic and attitude equations fit best (least residual RMS).
/// Returns the lag and the residual at it, nT.
pub fn estimate_gyro_lag_s(rec: &Recording, field_nt: f64) -> Result<(f64, f64), ComputeError> {
    let t = rec.t_s.as_ref().ok_or(ComputeError::NeedsColumn("t"))?;
    let step_s = crate::data::pairing::median_step_s(t).ok_or(GyroError::TimeNotAdvancing)?;
    let grid = step_s / 4.0;
    let n = (MAX_LAG_S / grid).floor() as i64;
    let mut best: Option<(f64, f64)> = None;
    for k in -n..=n {
        let lag = k as f64 * grid;
        let Ok((_, q)) = fit_gyro_recording(rec, field_nt, GyroLag::Given(lag)) else { continue };
        if best.is_none_or(|(_, r)| q.residual_rms_nt < r) {
            best = Some((lag, q.residual_rms_nt));
        }
    }
    Ok(best.ok_or(GyroError::NoLag { max_lag_s: MAX_LAG_S })?)
}

/// Fits the gyro-aided calibration; the magnitude is scaled to `field_nt`.
pub fn fit_gyro_recording(rec: &Recording, field_nt: f64, gyro_lag: GyroLag) -> Result<(FieldCal<f64>, GyroQuality), ComputeError> {
    let t = rec.t_s.as_ref().ok_or(ComputeError::NeedsColumn("t"))?;
    let rates = rec.gyro_rad_s().ok_or(if rec.gx_rad_s.is_none() {
        ComputeError::NeedsColumn("gx")
    } else if rec.gy_rad_s.is_none() {
        ComputeError::NeedsColumn("gy")
    } else {
        ComputeError::NeedsColumn("gz")
    })?;
    let gyro_lag_s = match gyro_lag {
        GyroLag::Given(lag_s) => lag_s,
        GyroLag::Estimate => estimate_gyro_lag_s(rec, field_nt)?.0,
    };
    if !gyro_lag_s.is_finite() || gyro_lag_s.abs() > 1.0 {
        return Err(GyroError::LagOutOfRange { lag_s: gyro_lag_s }.into());
    }
    let step_s = crate::data::pairing::median_step_s(t).ok_or(GyroError::TimeNotAdvancing)?;
    let rates = rates_at_lag(t, &rates, gyro_lag_s);
    let nan = vec![f64::NAN; rec.len()];
    let (roll, pitch) = (rec.roll_deg.as_ref().unwrap_or(&nan), rec.pitch_deg.as_ref().unwrap_or(&nan));
    let samples: Vec<GyroSample<f64>> = (0..rec.len())
        .map(|i| GyroSample { t_s: t[i], raw: rec.mag[i], rate_rad_s: rates[i], roll_rad: roll[i].to_radians(), pitch_rad: pitch[i].to_radians() })
        .collect();
    if samples.iter().any(|s| s.rate_rad_s.iter().any(|w| w.abs() > 35.0)) {
        // 35 rad/s = 2 000 °/s, a MEMS gyro's largest range: larger values
        // are deg/s or raw counts.
        return Err(GyroError::NotRadPerS { max_rad_s: 35.0 }.into());
    }
    let mut cfg = GyroConfig::new(1.5 * step_s);
    cfg.window_steps = ((WINDOW_S / step_s).round() as usize).clamp(1, MAX_WINDOW_STEPS);
    cfg.attitude_weight = ATTITUDE_WEIGHT;
    let batch = fit_gyro_batch(&samples, &cfg, field_nt)?;
    let (est, gyro_bias) = (batch.estimate, batch.gyro_bias_rad_s);
    let mut weak = Vec::new();
    if est.attitude_rows == 0 {
        weak.push("no roll_deg/pitch_deg: the vertical gain and hard iron rest on the gyro alone; record the AHRS attitude too".to_string());
    }
    let mean_gain = (est.cal.matrix[0][0] + est.cal.matrix[1][1] + est.cal.matrix[2][2]) / 3.0;
    let radius_raw = field_nt / mean_gain.abs();
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        let sigma = est.bias_sigma_raw[k];
        if !(sigma <= WEAK_BIAS_FRACTION * radius_raw) {
            weak.push(format!(
                "the {axis} hard iron is weakly determined: 1σ {sigma:.1} raw units ({:.1} % of the field); more roll and pitch would tie it",
                100.0 * sigma / radius_raw
            ));
        }
    }
    for (k, name) in ["xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"].iter().enumerate() {
        let sigma = est.matrix_sigma_rel[k];
        if !(sigma <= WEAK_MATRIX_REL) {
            weak.push(format!("the matrix's {name} entry is weakly determined: 1σ {:.1} % of the x gain", 100.0 * sigma));
        }
    }
    let predicted_deg = est.predicted_heading_rms_rad.to_degrees();
    if !(predicted_deg <= WEAK_HEADING_DEG) {
        weak.push(format!("the fit's own uncertainty predicts {predicted_deg:.2}° of heading error (1σ): turn through more headings and attitudes"));
    }
    let quality = GyroQuality {
        kinematic_windows: est.kinematic_windows,
        attitude_rows: est.attitude_rows,
        window_s: cfg.window_steps as f64 * step_s,
        gyro_lag_s: gyro_lag_s + batch.gyro_lag_s,
        gyro_bias_rad_s: gyro_bias,
        vertical_nt: est.vertical_nt,
        residual_rms_nt: est.residual_rms_nt,
        bias_sigma_raw: est.bias_sigma_raw,
        matrix_sigma_rel: est.matrix_sigma_rel,
        predicted_heading_rms_deg: predicted_deg,
        weakly_determined: weak,
    };
    Ok((est.cal, quality))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A swing test at ±15° / ±5°, turning at 1/12 rad/s, built from the
    /// kinematics as the simulator does: `n` rows `dt` apart whose
    /// magnetometer (and attitude) sample the motion at `t − mag_late_s`
    /// and whose gyro samples it at `t − gyro_late_s`; the raw field is the
    /// truth's through bias (300, −200, 100) and per-axis scale.
    pub(crate) fn swing_recording(dt: f64, n: usize, mag_late_s: f64, gyro_late_s: f64) -> Recording {
        let ned = calib_core::heading::ned_field(48_000.0, 1.05, 0.0);
        let motion = |t: f64| {
            let (roll, pitch, yaw) = (0.26 * (t / 6.0).sin(), 0.09 * (t / 9.0).sin(), t / 12.0);
            let (rd, pd, yd) = (0.26 / 6.0 * (t / 6.0).cos(), 0.09 / 9.0 * (t / 9.0).cos(), 1.0 / 12.0);
            let rate = [rd - yd * pitch.sin(), pd * roll.cos() + yd * roll.sin() * pitch.cos(), -pd * roll.sin() + yd * roll.cos() * pitch.cos()];
            (roll, pitch, yaw, rate)
        };
        let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), gx_rad_s: Some(vec![]), gy_rad_s: Some(vec![]), gz_rad_s: Some(vec![]), ..Recording::default() };
        for i in 0..n {
            let t = i as f64 * dt;
            let (roll, pitch, yaw, _) = motion(t - mag_late_s);
            let (_, _, _, rate) = motion(t - gyro_late_s);
            let h = calib_core::heading::ned_to_body(ned, roll, pitch, yaw);
            rec.mag.push([h[0] * 0.011 + 300.0, h[1] * 0.009 - 200.0, h[2] * 0.010 + 100.0]);
            rec.t_s.as_mut().unwrap().push(t);
            rec.roll_deg.as_mut().unwrap().push(roll.to_degrees());
            rec.pitch_deg.as_mut().unwrap().push(pitch.to_degrees());
            rec.gx_rad_s.as_mut().unwrap().push(rate[0]);
            rec.gy_rad_s.as_mut().unwrap().push(rate[1]);
            rec.gz_rad_s.as_mut().unwrap().push(rate[2]);
        }
        rec
    }

    /// A simulated swing test at ±15° / ±5° whose gyro is read 0.2 s late
    /// (rates shifted by one sample at 5 Hz): the estimate finds the lag
    /// and the heading comes back.
    #[test]
    fn a_gyro_lag_is_estimated_from_the_data() {
        // The rates of a steady turn with rolling; the gyro row at t holds
        // the rate of t − one sample.
        let rec = swing_recording(0.2, 3000, 0.0, 0.2);
        let (lag, _) = estimate_gyro_lag_s(&rec, 48_000.0).unwrap();
        // The magnetometer leads the rows' gyro by one sample: reading the
        // rates 0.2 s *later* (lag −0.2 s) lines them up.
        assert!((lag + 0.2).abs() < 0.051, "{lag}");
        let (with_lag, q) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Estimate).unwrap();
        let (without, _) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Given(0.0)).unwrap();
        let err = |c: &FieldCal<f64>| (c.bias[0] - 300.0).abs().max((c.bias[1] + 200.0).abs()).max((c.bias[2] - 100.0).abs());
        eprintln!("lag {lag} s (applied {} s); bias error {} with it, {} without", q.gyro_lag_s, err(&with_lag), err(&without));
        assert!(err(&with_lag) < err(&without));
    }

    /// The magnetometer (and the attitude paired with it) sampling the
    /// motion 0.3 sample after the gyro, or 0.3 sample before it, built from
    /// the kinematics: with no whole-sample shift given, the fit's
    /// sub-sample lag is the one put in, sign included.
    #[test]
    fn a_sub_sample_lag_of_either_sign_is_reported_with_its_sign() {
        let dt = 0.2;
        for lag_samples in [0.3, -0.3] {
            let lag_s = lag_samples * dt;
            let rec = swing_recording(dt, 3000, lag_s, 0.0);
            let (cal, q) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Given(0.0)).unwrap();
            let err = (cal.bias[0] - 300.0).abs().max((cal.bias[1] + 200.0).abs()).max((cal.bias[2] - 100.0).abs());
            eprintln!("lag {lag_s:+.3} s: reported {:+.5} s, bias error {err:.3} raw", q.gyro_lag_s);
            // Noise-free: measured ±0.05998 s (0.02 ms off), bias within
            // 0.004 raw of the truth.
            assert!((q.gyro_lag_s - lag_s).abs() < 1e-4, "lag {lag_s} s: reported {} s", q.gyro_lag_s);
            assert!(err < 0.02, "lag {lag_s} s: bias off by {err} raw");
        }
    }

    #[test]
    fn a_lag_reads_the_rates_earlier() {
        let t = [0.0, 1.0, 2.0, 3.0];
        let r = [[0.0; 3], [1.0; 3], [2.0; 3], [3.0; 3]];
        let shifted = rates_at_lag(&t, &r, 0.25);
        assert!(shifted[0][0].is_nan());
        assert!((shifted[1][0] - 0.75).abs() < 1e-12 && (shifted[3][2] - 2.75).abs() < 1e-12);
    }
}
