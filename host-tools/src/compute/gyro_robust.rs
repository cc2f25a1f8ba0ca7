//! The gyro-aided fit made robust: the equations of [`calib_core::gyro`]
//! (over each window of integrated rotation `A·r_j − R·(A·r_i) + (I − R)·c
//! = 0`, and the levelled vertical `lᵀ(A·r − c) = Z`), solved by
//! iteratively reweighted least squares with Huber weights, started from
//! a given calibration (the attitude-aided fit's, where there is one), with
//! the gyro's bias and lag as the plain batch fit estimated them. Windows
//! where the gyro and the field disagree (a fast turn's integration error,
//! a disturbance in the room) lose weight instead of bending the fit.

use calib_core::cal::FieldCal;
use calib_core::fit::Normalization;
use calib_core::gyro::{GyroConfig, GyroSample, WindowChain};
use calib_core::heading::Tilt;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Unknowns: `A` without `A₀₀ = 1` (8), `c` (3), `Z`.
const N: usize = 12;

/// Huber's constant, in robust standard deviations of each kind of
/// equation.
pub const HUBER_K: f64 = 1.345;
/// Most reweighting passes.
pub const PASSES: usize = 8;
/// The passes stop once one moves no unknown by more than this (normalised
/// units: `A`'s entries near 1, `c` and `Z` in field radii). Each pass
/// shrinks the step 7–10× on the bench's swing and the BROAD trials (from
/// about 1e-3 after the first), so what is left then is about 1e-9.
pub const SETTLED: f64 = 1e-8;

/// One row of `Φ` and its target.
type Row = ([f64; N], f64);

/// The equations of a recording: each window's three rows, and each
/// levelled-vertical row, in the samples' order.
struct Equations {
    kinematic: Vec<[Row; 3]>,
    attitude: Vec<Row>,
}

/// The equations of every window and attitude row of `samples`, normalised
/// with `norm`; the windows' rotations from calib-core's [`WindowChain`]
/// (the batch fit's: a few matrix products a sample instead of one a
/// window step).
fn equations(samples: &[GyroSample<f64>], norm: &Normalization<f64>, cfg: &GyroConfig<f64>) -> Equations {
    let mut out = Equations { kinematic: Vec::with_capacity(samples.len()), attitude: Vec::with_capacity(samples.len()) };
    let mut chain = WindowChain::new();
    for s in samples {
        let finite = s.t_s.is_finite() && s.raw.iter().chain(s.rate_rad_s.iter()).all(|v| v.is_finite());
        if !finite {
            chain.reset();
            continue;
        }
        let r = norm.apply(s.raw);
        if let Some((ri, rj, rot)) = chain.push(s, r, cfg) {
            let rot = Matrix3::from_fn(|i, j| rot[i][j]);
            let col = |row: usize, c: usize| -> Vector3<f64> {
                let mut ej = Vector3::zeros();
                ej[row] = rj[c];
                let mut ei = Vector3::zeros();
                ei[row] = ri[c];
                ej - rot * ei
            };
            let u0 = col(0, 0);
            let mut rows = [([0.0; N], 0.0); 3];
            for (m, out_row) in rows.iter_mut().enumerate() {
                let mut phi = [0.0; N];
                for (idx, (row, c)) in ENTRIES.iter().enumerate() {
                    phi[idx] = col(*row, *c)[m];
                }
                for nn in 0..3 {
                    let i_minus_r = if m == nn { 1.0 } else { 0.0 } - rot[(m, nn)];
                    phi[8 + nn] = -i_minus_r;
                }
                *out_row = (phi, -u0[m]);
            }
            out.kinematic.push(rows);
        }
        let w = cfg.attitude_weight;
        if s.roll_rad.is_finite() && s.pitch_rad.is_finite() && w > 0.0 {
            let [_, _, l] = Tilt::new(s.roll_rad, s.pitch_rad).matrix();
            let mut phi = [0.0; N];
            for (idx, (row, c)) in ENTRIES.iter().enumerate() {
                phi[idx] = w * l[*row] * r[*c];
            }
            for nn in 0..3 {
                phi[8 + nn] = -w * l[nn];
            }
            phi[11] = -w;
            out.attitude.push((phi, -w * l[0] * r[0]));
        }
    }
    out
}

/// `A`'s entries among the unknowns, in order (`A₀₀ = 1` is not one).
const ENTRIES: [(usize, usize); 8] = [(0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 0), (2, 1), (2, 2)];

/// The residual norm of a group of rows at `x`, per row.
fn residual(rows: &[Row], x: &SVector<f64, N>) -> f64 {
    rows.iter().map(|(phi, y)| (SVector::<f64, N>::from_column_slice(phi).dot(x) - y).powi(2)).sum::<f64>().sqrt() / (rows.len() as f64).sqrt()
}

/// Adds `w·φφᵀ` to the lower triangle of `ata` (what the Cholesky factor
/// reads; each entry `(w·φ_i)·φ_j` as the outer product gives it) and
/// `w·y·φ` to `atb`, for each row.
fn add_rows(ata: &mut [[f64; N]; N], atb: &mut SVector<f64, N>, rows: &[Row], w: f64) {
    for (phi, y) in rows {
        for i in 0..N {
            let wp = w * phi[i];
            for j in 0..=i {
                ata[i][j] += wp * phi[j];
            }
        }
        *atb += w * *y * SVector::<f64, N>::from_column_slice(phi);
    }
}

/// Huber's weight of a residual `r` against the robust scale `s`.
fn huber_weight(r: f64, s: Option<f64>) -> f64 {
    match s {
        Some(s) if s > 0.0 && r > HUBER_K * s => HUBER_K * s / r,
        _ => 1.0,
    }
}

/// The unknowns of a calibration `h = M·(raw − b)` in `norm`'s units
/// (`A₀₀ = 1`), `Z` the mean levelled vertical.
fn unknowns_of(cal: &FieldCal<f64>, norm: &Normalization<f64>, samples: &[GyroSample<f64>]) -> Option<SVector<f64, N>> {
    let m00 = cal.matrix[0][0];
    if !(m00.abs() > 0.0) {
        return None;
    }
    let a = Matrix3::from_fn(|i, j| cal.matrix[i][j] / m00);
    let d = Vector3::from_fn(|i, _| (cal.bias[i] - norm.centre[i]) / norm.scale);
    let c = a * d;
    let mut x = SVector::<f64, N>::zeros();
    for (idx, (row, col)) in ENTRIES.iter().enumerate() {
        x[idx] = a[(*row, *col)];
    }
    x[8] = c[0];
    x[9] = c[1];
    x[10] = c[2];
    let (mut sum, mut count) = (0.0, 0.0);
    for s in samples.iter().filter(|s| s.roll_rad.is_finite() && s.pitch_rad.is_finite() && s.raw.iter().all(|v| v.is_finite())) {
        let r = norm.apply(s.raw);
        let h = a * Vector3::new(r[0], r[1], r[2]) - c;
        sum += Tilt::new(s.roll_rad, s.pitch_rad).level([h[0], h[1], h[2]])[2];
        count += 1.0;
    }
    x[11] = if count > 0.0 { sum / count } else { 0.0 };
    Some(x)
}

/// The robust fit from `start`; `None` when the equations do not determine
/// the unknowns or the matrix turns over.
pub fn refine(samples: &[GyroSample<f64>], cfg: &GyroConfig<f64>, field_nt: f64, start: &FieldCal<f64>) -> Option<FieldCal<f64>> {
    let finite: Vec<[f64; 3]> = samples.iter().map(|s| s.raw).filter(|r| r.iter().all(|v| v.is_finite())).collect();
    let norm = Normalization::from_raw_iter(finite.iter().copied())?;
    let eq = equations(samples, &norm, cfg);
    if eq.kinematic.len() < 4 {
        return None;
    }
    let mut x = unknowns_of(start, &norm, samples)?;
    // Every row at unit weight, once: a pass adds `(w − 1)·φφᵀ` for the
    // rows Huber's weight takes down (about a tenth of them) instead of
    // every row's `w·φφᵀ`.
    let (mut base_ata, mut base_atb) = ([[0.0; N]; N], SVector::<f64, N>::zeros());
    for rows in &eq.kinematic {
        add_rows(&mut base_ata, &mut base_atb, rows, 1.0);
    }
    add_rows(&mut base_ata, &mut base_atb, &eq.attitude, 1.0);
    // Each group's residual norm per row at the pass's `x` (computed once a
    // pass, for the scale and the weights), and a copy the median reorders.
    let (mut res_k, mut res_a, mut scratch) = (vec![0.0; eq.kinematic.len()], vec![0.0; eq.attitude.len()], Vec::new());
    // Robust scale of each kind: 1.4826 × the median residual norm (per row
    // of the group).
    let mut scale = |res: &[f64]| {
        scratch.clear();
        scratch.extend_from_slice(res);
        calib_core::series::median(&mut scratch).map(|m| 1.4826 * m)
    };
    for _ in 0..PASSES {
        for (r, rows) in res_k.iter_mut().zip(&eq.kinematic) {
            *r = residual(rows, &x);
        }
        for (r, row) in res_a.iter_mut().zip(&eq.attitude) {
            *r = residual(core::slice::from_ref(row), &x);
        }
        let (sk, sa) = (scale(&res_k), scale(&res_a));
        let (mut ata, mut atb) = (base_ata, base_atb);
        for (rows, &r) in eq.kinematic.iter().zip(&res_k) {
            let w = huber_weight(r, sk);
            if w < 1.0 {
                add_rows(&mut ata, &mut atb, rows, w - 1.0);
            }
        }
        for (row, &r) in eq.attitude.iter().zip(&res_a) {
            let w = huber_weight(r, sa);
            if w < 1.0 {
                add_rows(&mut ata, &mut atb, core::slice::from_ref(row), w - 1.0);
            }
        }
        let ata = SMatrix::<f64, N, N>::from_fn(|i, j| if j <= i { ata[i][j] } else { ata[j][i] });
        let next = ata.cholesky()?.solve(&atb);
        let moved = (next - x).amax();
        x = next;
        if moved < SETTLED {
            break;
        }
    }
    // Back to a calibration scaled to `field_nt` (as calib-core's estimate).
    let mut a = Matrix3::identity();
    for (idx, (row, col)) in ENTRIES.iter().enumerate() {
        a[(*row, *col)] = x[idx];
    }
    if !(a.determinant() > 0.0) {
        return None;
    }
    let c = Vector3::new(x[8], x[9], x[10]);
    let rms = (finite.iter().map(|raw| (a * Vector3::from(norm.apply(*raw)) - c).norm_squared()).sum::<f64>() / finite.len() as f64).sqrt();
    if !(rms > 0.0) {
        return None;
    }
    let k = field_nt / rms;
    let b = a.try_inverse()? * c;
    Some(FieldCal {
        bias: [0, 1, 2].map(|i| norm.centre[i] + norm.scale * b[i]),
        matrix: [0, 1, 2].map(|i| [0, 1, 2].map(|j| a[(i, j)] * k / norm.scale)),
    })
}

/// [`refine`] on a recording, with the plain gyro-aided fit's gyro bias
/// and lag (`plain`), the rates read `given_lag_s` earlier (as the plain
/// fit read them).
pub fn refine_recording(rec: &crate::data::Recording, field_nt: f64, given_lag_s: f64, plain: &crate::doc::results::GyroQuality, start: &FieldCal<f64>) -> Option<FieldCal<f64>> {
    let t = rec.t_s.as_ref()?;
    let rates = super::gyro::rates_at_lag(t, &rec.gyro_rad_s()?, given_lag_s);
    let step_s = crate::data::pairing::median_step_s(t)?;
    let nan = vec![f64::NAN; rec.len()];
    let (roll, pitch) = (rec.roll_deg.as_ref().unwrap_or(&nan), rec.pitch_deg.as_ref().unwrap_or(&nan));
    let samples: Vec<GyroSample<f64>> = (0..rec.len())
        .map(|i| GyroSample { t_s: t[i], raw: rec.mag[i], rate_rad_s: rates[i], roll_rad: roll[i].to_radians(), pitch_rad: pitch[i].to_radians() })
        .collect();
    let mut cfg = GyroConfig::new(1.5 * step_s);
    cfg.window_steps = ((super::gyro::WINDOW_S / step_s).round() as usize).clamp(1, calib_core::gyro::MAX_WINDOW_STEPS);
    cfg.attitude_weight = super::gyro::ATTITUDE_WEIGHT;
    cfg.gyro_bias_rad_s = plain.gyro_bias_rad_s;
    cfg.gyro_lag_s = plain.gyro_lag_s - given_lag_s;
    refine(&samples, &cfg, field_nt, start)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compute::gyro::{fit_gyro_recording, GyroLag};
    use crate::data::Recording;

    /// A swing at ±15° / ±5° turning at 1/12 rad/s, 5 Hz, built from the
    /// kinematics; the raw field is the truth's through bias (300, −200,
    /// 100) and per-axis scale. Every 37th row the gyro's z reads 0.5
    /// rad/s too much (a glitch: each spoils the windows across it).
    fn swing_with_glitches() -> Recording {
        let mut rec = crate::compute::gyro::tests::swing_recording(0.2, 3000, 0.0, 0.0);
        for (i, gz) in rec.gz_rad_s.iter_mut().flatten().enumerate() {
            if i % 37 == 0 {
                *gz += 0.5;
            }
        }
        rec
    }

    #[test]
    fn glitches_of_the_gyro_bend_the_reweighted_fit_less_than_half_as_much_as_the_plain_one() {
        let rec = swing_with_glitches();
        let (plain, q) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Given(0.0)).unwrap();
        let robust = refine_recording(&rec, 48_000.0, 0.0, &q, &plain).unwrap();
        // The truth (the simulation's): bias (300, −200, 100) raw.
        let err = |c: &FieldCal<f64>| (c.bias[0] - 300.0).abs().max((c.bias[1] + 200.0).abs()).max((c.bias[2] - 100.0).abs());
        eprintln!("bias error: plain {:.2} raw, reweighted {:.2} raw", err(&plain), err(&robust));
        // Measured: plain 85.9 raw, reweighted 37.3 raw.
        assert!(err(&robust) < 0.5 * err(&plain), "{} {}", err(&robust), err(&plain));
    }
}
