//! Gyro-aided field calibration for vehicles that cannot tumble.
//!
//! In the body frame a constant field turns as `ḣ = −ω × h` (ALGORITHMS.md,
//! kinematics of a body-fixed sensor; Troni & Whitcomb 2019, MAGYC 2024). So
//! how the readings rotate, measured by the gyro, determines the soft iron
//! `A` and the hard iron `c = A·b` of `h = A·raw − c` — up to one common
//! scale — without a full tumble and without a heading reference. Two
//! things make it work on a real vehicle:
//!
//! - **Integrated, not differentiated.** Differentiating noisy readings
//!   makes a noisy regression; instead the gyro is integrated over a window
//!   of `K` steps into the rotation `R` that carries the body frame from
//!   sample `i` to sample `j = i + K`, and the constraint is
//!   `A·raw_j − c = R·(A·raw_i − c)`, linear in `A` and `c`:
//!   `A·raw_j − R·A·raw_i − (I − R)·c = 0`.
//! - **The attitude adds what the gyro cannot see.** With roll and pitch
//!   from the AHRS, the levelled vertical component of the field is constant
//!   over a recording: `lᵀ(A·raw − c) = Z` with `l` the third row of the
//!   levelling rotation, `Z` one more unknown. Small tilts leave the
//!   vertical gain and bias weakly tied by the kinematics alone; this row
//!   ties them.
//!
//! The unknowns are the general 3×3 `A` with `A₀₀ = 1` (the scale is free
//! in both constraints), `c` and `Z`: twelve in all. `A` is not restricted
//! to a symmetric matrix as an ellipsoid fit may be: the gyro sees the
//! magnetometer's frame, so the rotation part of `A` (non-orthogonality,
//! misalignment against the gyro) is observable and must be fitted — a
//! symmetric `A` left 4 % magnitude scatter on a simulated hull with
//! paper 001's non-orthogonality. They are absorbed one equation at a
//! time by the square-root RLS of [`crate::lsq`], so the same [`GyroFit`]
//! runs on the MCU in `f32` and as the batch reference in `f64`. The scale
//! is set at the end from the reference intensity (or any nominal one: a
//! heading does not depend on it). [`fit_gyro_batch`] adds the gyro's bias
//! and the magnetometer's sub-sample lag behind the gyro, estimated from
//! the same windows by Gauss–Newton (the crate's [`crate::lsq::lm`]) with
//! the field fixed, alternated with the linear solve.

use crate::cal::FieldCal;
use crate::fit::{FitError, Normalization};
use crate::heading::{Tilt, Vec3};
use crate::linalg::{det3, identity3, inverse3, mul_mat, mul_mat_vec, Mat3};
use crate::lsq::lm::{self, Acceptance, Damping, LmOptions, LmProblem, Linearisation};
use crate::lsq::{Information, QrRls};
use crate::Real;

/// Longest integration window, in steps (the ring buffer's size).
pub const MAX_WINDOW_STEPS: usize = 32;

/// Unknowns of the linear problem: `A₀₁ A₀₂ A₁₀ A₁₁ A₁₂ A₂₀ A₂₁ A₂₂`
/// ([`MATRIX_UNKNOWNS`] entries of `A` besides `A₀₀ = 1`), `c₀ c₁ c₂`, `Z`.
pub const UNKNOWNS: usize = 12;

/// Entries of `A` among the unknowns.
pub const MATRIX_UNKNOWNS: usize = 8;

/// The `(row, column)` of each matrix unknown; entry 0 is `A₀₀ = 1`.
const ENTRIES: [(usize, usize); 9] = [(0, 0), (0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 0), (2, 1), (2, 2)];

/// One synchronous sample of magnetometer, gyro and attitude.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroSample<T> {
    /// Sample time, s.
    pub t_s: T,
    /// Magnetometer, raw units.
    pub raw: Vec3<T>,
    /// Body rotation rate from the gyro, rad/s (body frame, x forward, y
    /// right, z down).
    pub rate_rad_s: Vec3<T>,
    /// Roll from the AHRS, rad (NaN when not available).
    pub roll_rad: T,
    /// Pitch from the AHRS, rad (NaN when not available).
    pub pitch_rad: T,
}

/// How a [`GyroFit`] forms its equations.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroConfig<T> {
    /// Steps the gyro is integrated over for one kinematic equation (1 to
    /// [`MAX_WINDOW_STEPS`]). Longer windows see more rotation per unit of
    /// noise; on BROAD trial 05 at 28.6 Hz, 20 steps (0.7 s) gave 1.7° and
    /// 1 step (differentiation) 2.5°. (host-tools sets its own for real
    /// recordings, chosen leave-one-trial-out on four real trials.)
    pub window_steps: usize,
    /// A step longer than this (or not forward in time) breaks the chain of
    /// integrated rotations, s.
    pub max_step_s: T,
    /// The gyro's bias, subtracted from its readings, rad/s.
    pub gyro_bias_rad_s: Vec3<T>,
    /// The magnetometer's lag behind the gyro, s: each step's rotation is
    /// integrated over the interval this much earlier, to first order
    /// `∫ω dt − lag·(ω₁ − ω₀)` (exact for rates linear in time; meant for
    /// lags up to about one sample, larger ones are shifted by the caller).
    pub gyro_lag_s: T,
    /// Weight of the levelled-vertical equations against the kinematic ones
    /// (both in normalised field units; 0 = gyro only). 1 suits a uniform
    /// field and an exact attitude (the simulations); a real room's field
    /// varies along the path, and host-tools uses a weaker one chosen
    /// leave-one-trial-out.
    pub attitude_weight: T,
}

impl<T: Real> GyroConfig<T> {
    /// 20-step windows, chains broken by steps over `max_step_s`, no gyro
    /// bias, no lag, unit attitude weight.
    pub fn new(max_step_s: T) -> Self {
        Self { window_steps: 20, max_step_s, gyro_bias_rad_s: [T::ZERO; 3], gyro_lag_s: T::ZERO, attitude_weight: T::ONE }
    }
}

/// The terms of Rodrigues' formula for [`body_step_rotation`]: `K = [−θ]×`,
/// `K²`, `sin a / a`, `(1 − cos a) / a²` (their series near zero) and
/// `a² = |θ|²`; the rotation is `I + s·K + c·K²`. Inlined always, so the
/// board's code is what it was when the rotation formed them itself.
#[inline(always)]
pub(crate) fn rodrigues_terms<T: Real>(theta_rad: Vec3<T>) -> (Mat3<T>, Mat3<T>, T, T, T) {
    let [x, y, z] = theta_rad;
    let a2 = x * x + y * y + z * z;
    let a = a2.sqrt();
    let (s, c) = if a < T::from_f64(1e-4) {
        (T::ONE - a2 / T::from_f64(6.0), T::from_f64(0.5) - a2 / T::from_f64(24.0))
    } else {
        (a.sin() / a, (T::ONE - a.cos()) / a2)
    };
    let k: Mat3<T> = [[T::ZERO, z, -y], [-z, T::ZERO, x], [y, -x, T::ZERO]];
    let k2 = mul_mat(&k, &k);
    (k, k2, s, c, a2)
}

/// `exp(−[θ]×)`: the rotation that carries body-frame vectors of a constant
/// world vector across a step in which the body turned by `θ` (rad, body
/// frame). Rodrigues' formula, with its series near zero.
pub fn body_step_rotation<T: Real>(theta_rad: Vec3<T>) -> Mat3<T> {
    let (k, k2, s, c, _) = rodrigues_terms(theta_rad);
    let mut r = identity3();
    for i in 0..3 {
        for j in 0..3 {
            r[i][j] += s * k[i][j] + c * k2[i][j];
        }
    }
    r
}

/// What [`Chain::push`] yields: the raw field `K` steps back, this sample's
/// raw field, and the rotation integrated between them.
type ChainStep<T> = (Vec3<T>, Vec3<T>, Mat3<T>);

/// The last `K + 1` samples of an unbroken chain and the step rotations
/// between them: yields, for every new sample, the pair (sample `K` steps
/// back, this sample) with the integrated rotation between them.
#[derive(Debug, Clone)]
struct Chain<T> {
    raw: [Vec3<T>; MAX_WINDOW_STEPS + 1],
    /// The step into each sample slot (same index as `raw`).
    step: [Mat3<T>; MAX_WINDOW_STEPS + 1],
    /// Samples held (≤ MAX + 1); the newest is at `head`.
    len: usize,
    head: usize,
    previous: Option<(T, Vec3<T>)>,
}

impl<T: Real> Chain<T> {
    fn new() -> Self {
        Self { raw: [[T::ZERO; 3]; MAX_WINDOW_STEPS + 1], step: [identity3(); MAX_WINDOW_STEPS + 1], len: 0, head: 0, previous: None }
    }

    /// Adds a sample (normalised raw); returns `(raw_i, raw_j, R)` once the
    /// chain spans `window` steps.
    fn push(&mut self, s: &GyroSample<T>, raw: Vec3<T>, cfg: &GyroConfig<T>) -> Option<ChainStep<T>> {
        let cap = MAX_WINDOW_STEPS + 1;
        let continues = match self.previous {
            Some((t0, _)) => {
                let dt = s.t_s - t0;
                dt > T::ZERO && dt <= cfg.max_step_s
            }
            None => false,
        };
        if continues {
            if let Some((t0, w0)) = self.previous {
                let dt = s.t_s - t0;
                let half = T::from_f64(0.5);
                let (b, lag) = (cfg.gyro_bias_rad_s, cfg.gyro_lag_s);
                let theta = [0, 1, 2].map(|k| ((w0[k] + s.rate_rad_s[k]) * half - b[k]) * dt - lag * (s.rate_rad_s[k] - w0[k]));
                // The step into slot `head + 1` is stored at that slot: a
                // ring one shorter would give the steps into slots 0 and
                // MAX the same place, and a window across both would use
                // one step twice and lose the other.
                self.head = (self.head + 1) % cap;
                self.step[self.head] = body_step_rotation(theta);
                self.raw[self.head] = raw;
                self.len = (self.len + 1).min(cap);
            }
        } else {
            self.head = 0;
            self.raw[0] = raw;
            self.len = 1;
        }
        self.previous = Some((s.t_s, s.rate_rad_s));
        let k = cfg.window_steps.clamp(1, MAX_WINDOW_STEPS);
        if self.len < k + 1 {
            return None;
        }
        // R = R_head · R_head−1 ··· (k steps), oldest applied first.
        let mut r = identity3();
        for back in (0..k).rev() {
            let idx = (self.head + cap - back) % cap;
            r = mul_mat(&self.step[idx], &r);
        }
        let i = (self.head + cap - k) % cap;
        Some((self.raw[i], raw, r))
    }
}

/// `E_k·v` for the unit matrix `E_k` of [`ENTRIES`]`[k]`.
fn basis_times<T: Real>(k: usize, v: Vec3<T>) -> Vec3<T> {
    let mut out = [T::ZERO; 3];
    let (row, col) = ENTRIES[k % 9];
    out[row] = v[col];
    out
}

/// The matrix of the unknowns (with `A₀₀ = 1`).
fn matrix_of<T: Real>(x: &[T; UNKNOWNS]) -> Mat3<T> {
    let mut a = [[T::ZERO; 3]; 3];
    a[0][0] = T::ONE;
    for k in 1..9 {
        let (row, col) = ENTRIES[k];
        a[row][col] = x[k - 1];
    }
    a
}

/// `c` and `Z` among the unknowns.
fn offsets_of<T: Real>(x: &[T; UNKNOWNS]) -> (Vec3<T>, T) {
    let m = MATRIX_UNKNOWNS;
    ([x[m], x[m + 1], x[m + 2]], x[m + 3])
}

/// The solution in normalised units, before the scale is set.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Normalised<T> {
    a: Mat3<T>,
    c: Vec3<T>,
    vertical: T,
}

/// Gyro-aided recursive fit (see the module documentation). One instance
/// per recording or session; runs in `f32` on the MCU with the
/// square-root accumulator `L` ([`QrRls`]); the host's batch reference
/// accumulates the same equations in the normal equations
/// ([`crate::lsq::NormalEquations`], `f64`).
#[derive(Debug, Clone)]
pub struct GyroFit<T, L = QrRls<T, UNKNOWNS>> {
    norm: Normalization<T>,
    cfg: GyroConfig<T>,
    rls: L,
    chain: Chain<T>,
    /// Σr, Σr·rᵀ and the count of the normalised samples (for the scale).
    sum: Vec3<T>,
    sum_sq: Mat3<T>,
    samples: u32,
    kinematic_windows: u32,
    attitude_rows: u32,
    rejected: u32,
}

/// What a gyro-aided fit determined, and how well.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct GyroEstimate<T> {
    /// The field calibration, scaled to the reference intensity.
    pub cal: FieldCal<T>,
    /// The levelled vertical field, nT (on the reference's scale).
    pub vertical_nt: T,
    /// Windows of integrated rotation used.
    pub kinematic_windows: u32,
    /// Levelled-vertical equations used.
    pub attitude_rows: u32,
    /// RMS of all equations' residuals, nT.
    pub residual_rms_nt: T,
    /// 1σ of the hard iron per axis, raw units (from the fit's covariance,
    /// equations taken as independent).
    pub bias_sigma_raw: Vec3<T>,
    /// 1σ of the matrix entries relative to `A₀₀`:
    /// `A₀₁ A₀₂ A₁₀ A₁₁ A₁₂ A₂₀ A₂₁ A₂₂`.
    pub matrix_sigma_rel: [T; MATRIX_UNKNOWNS],
    /// The 1σ heading error over all headings, level, that the covariance
    /// predicts, rad.
    pub predicted_heading_rms_rad: T,
}

impl<T: Real> GyroFit<T> {
    /// A fit whose raw samples are normalised with `norm` (centre near the
    /// hard iron, scale about the field's radius in raw units).
    pub fn new(norm: Normalization<T>, cfg: GyroConfig<T>) -> Self {
        Self::with_accumulator(norm, cfg)
    }
}

impl<T: Real, L: Information<T, UNKNOWNS>> GyroFit<T, L> {
    /// [`GyroFit::new`] with the accumulator `L`.
    pub fn with_accumulator(norm: Normalization<T>, cfg: GyroConfig<T>) -> Self {
        Self {
            norm,
            cfg,
            rls: L::default(),
            chain: Chain::new(),
            sum: [T::ZERO; 3],
            sum_sq: [[T::ZERO; 3]; 3],
            samples: 0,
            kinematic_windows: 0,
            attitude_rows: 0,
            rejected: 0,
        }
    }

    /// The normalisation in use.
    pub fn normalization(&self) -> &Normalization<T> {
        &self.norm
    }

    /// Kinematic windows absorbed.
    pub fn kinematic_windows(&self) -> u32 {
        self.kinematic_windows
    }

    /// Levelled-vertical equations absorbed.
    pub fn attitude_rows(&self) -> u32 {
        self.attitude_rows
    }

    /// Samples refused (non-finite field, rate or time).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Absorbs one sample. A sample with a non-finite field, rate or time is
    /// refused (and breaks the chain); missing roll/pitch only drops its
    /// attitude equation.
    pub fn push(&mut self, s: &GyroSample<T>) -> bool {
        let finite = s.t_s.is_finite() && s.raw.iter().chain(s.rate_rad_s.iter()).all(|v| v.is_finite());
        if !finite {
            self.rejected = self.rejected.saturating_add(1);
            self.chain = Chain::new();
            return false;
        }
        let r = self.norm.apply(s.raw);
        let window = self.chain.push(s, r, &self.cfg);
        self.absorb(s, r, window);
        true
    }

    /// A window's three rows, `A·r_j − R·A·r_i − (I − R)·c = 0`: `u[k]` is
    /// the coefficient of the matrix's `k`-th entry in each row (`k = 0`,
    /// the fixed one, the target's); the window is counted when all three
    /// are absorbed.
    fn add_window_rows(&mut self, u: &[Vec3<T>; 9], rot: &Mat3<T>) {
        let mut all = true;
        for m in 0..3 {
            let mut phi = [T::ZERO; UNKNOWNS];
            for k in 1..9 {
                phi[k - 1] = u[k][m];
            }
            for n in 0..3 {
                let i_minus_r = if m == n { T::ONE } else { T::ZERO } - rot[m][n];
                phi[MATRIX_UNKNOWNS + n] = -i_minus_r;
            }
            all &= self.rls.update(&phi, -u[0][m]);
        }
        if all {
            self.kinematic_windows = self.kinematic_windows.saturating_add(1);
        }
    }

    /// Absorbs one finite sample (normalised reading `r`) with the window
    /// its chain yields.
    fn absorb(&mut self, s: &GyroSample<T>, r: Vec3<T>, window: Option<ChainStep<T>>) {
        if let Some((ri, rj, rot)) = window {
            // A·r_j − R·A·r_i − (I − R)·c = 0, three rows.
            let u: [Vec3<T>; 9] = core::array::from_fn(|k| {
                let ej = basis_times(k, rj);
                let rei = mul_mat_vec(&rot, basis_times(k, ri));
                [ej[0] - rei[0], ej[1] - rei[1], ej[2] - rei[2]]
            });
            self.add_window_rows(&u, &rot);
        }
        let w = self.cfg.attitude_weight;
        if s.roll_rad.is_finite() && s.pitch_rad.is_finite() && w > T::ZERO {
            let t = Tilt::new(s.roll_rad, s.pitch_rad);
            let [_, _, l] = t.matrix();
            let dot = |v: Vec3<T>| l[0] * v[0] + l[1] * v[1] + l[2] * v[2];
            let mut phi = [T::ZERO; UNKNOWNS];
            for k in 1..9 {
                phi[k - 1] = w * dot(basis_times(k, r));
            }
            for n in 0..3 {
                phi[MATRIX_UNKNOWNS + n] = -w * l[n];
            }
            phi[MATRIX_UNKNOWNS + 3] = -w;
            if self.rls.update(&phi, -w * dot(basis_times(0, r))) {
                self.attitude_rows = self.attitude_rows.saturating_add(1);
            }
        }
        for i in 0..3 {
            self.sum[i] += r[i];
            for j in 0..3 {
                self.sum_sq[i][j] += r[i] * r[j];
            }
        }
        self.samples = self.samples.saturating_add(1);
    }

    fn solve_normalised(&self) -> Result<([T; UNKNOWNS], Normalised<T>), FitError> {
        if self.kinematic_windows < 4 {
            return Err(FitError::TooFewSamples { have: self.kinematic_windows, need: 4 });
        }
        let x = self.rls.solve_all()?;
        let a = matrix_of(&x);
        // A must keep the field's handedness: A₀₀ = 1 fixes the sign, and a
        // real sensor has no axis that reads the field backwards.
        if !(det3(&a) > T::ZERO) {
            return Err(FitError::NotAnEllipsoid);
        }
        let (c, vertical) = offsets_of(&x);
        Ok((x, Normalised { a, c, vertical }))
    }

    /// RMS of `|A·r − c|` over the samples, from their moments.
    fn rms_magnitude(&self, n: &Normalised<T>) -> T {
        let count = T::from_f64(f64::from(self.samples.max(1)));
        // Σ|A r − c|² = tr(A S Aᵀ) − 2 cᵀA Σr + N|c|².
        let as_ = mul_mat(&n.a, &self.sum_sq);
        let mut tr = T::ZERO;
        for i in 0..3 {
            for k in 0..3 {
                tr += as_[i][k] * n.a[i][k];
            }
        }
        let a_sum = mul_mat_vec(&n.a, self.sum);
        let cross = n.c[0] * a_sum[0] + n.c[1] * a_sum[1] + n.c[2] * a_sum[2];
        let cc = n.c[0] * n.c[0] + n.c[1] * n.c[1] + n.c[2] * n.c[2];
        ((tr - T::from_f64(2.0) * cross + count * cc) / count).max(T::ZERO).sqrt()
    }

    /// The calibration for reference intensity `field_nt` (any positive
    /// value when the intensity is unknown: headings do not depend on it).
    pub fn estimate(&self, field_nt: T) -> Result<GyroEstimate<T>, FitError> {
        if !(field_nt > T::ZERO && field_nt.is_finite()) {
            return Err(FitError::BadReference);
        }
        let (x, n) = self.solve_normalised()?;
        let rms = self.rms_magnitude(&n);
        if !(rms > T::ZERO) {
            return Err(FitError::NotAnEllipsoid);
        }
        let k = field_nt / rms;
        let inv = inverse3(&n.a).ok_or(FitError::NotAnEllipsoid)?;
        let b_norm = mul_mat_vec(&inv, n.c);
        let s = self.norm.scale;
        let mut matrix = n.a;
        for row in matrix.iter_mut() {
            for v in row.iter_mut() {
                *v = *v * k / s;
            }
        }
        let bias = [0, 1, 2].map(|i| self.norm.centre[i] + s * b_norm[i]);
        let rows = self.kinematic_windows.saturating_mul(3).saturating_add(self.attitude_rows);
        let dof = T::from_f64(f64::from(rows.saturating_sub(UNKNOWNS as u32).max(1)));
        let sigma2 = self.rls.residual_sum_of_squares_at(&x) / dof;
        let residual_rms_nt = sigma2.sqrt() * k;
        let (mut bias_sigma_raw, mut matrix_sigma_rel, mut predicted) = ([T::NAN; 3], [T::NAN; MATRIX_UNKNOWNS], T::NAN);
        let m = MATRIX_UNKNOWNS;
        if let Some(cov) = self.rls.unscaled_covariance() {
            // bias = centre + s·A⁻¹c: σ from c's covariance through A⁻¹.
            for (i, sigma) in bias_sigma_raw.iter_mut().enumerate() {
                let mut v = T::ZERO;
                for p in 0..3 {
                    for q in 0..3 {
                        v += inv[i][p] * cov[m + p][m + q] * inv[i][q];
                    }
                }
                *sigma = s * (v * sigma2).max(T::ZERO).sqrt();
            }
            for (i, sigma) in matrix_sigma_rel.iter_mut().enumerate() {
                *sigma = (cov[i][i] * sigma2).max(T::ZERO).sqrt();
            }
            // Each sample's noise enters three equations (the start of one
            // window, the end of another, its attitude row), so they are not
            // independent: the information is about a third of what the RLS
            // counts (variance × 3). With it, observed / predicted over
            // seeds is ≈ 1.6 (unit test); without, 2.8.
            predicted = predicted_heading_rms(&x, &n, rms, &cov, sigma2 * T::from_f64(3.0));
        }
        Ok(GyroEstimate {
            cal: FieldCal { bias, matrix },
            vertical_nt: n.vertical * k,
            kinematic_windows: self.kinematic_windows,
            attitude_rows: self.attitude_rows,
            residual_rms_nt,
            bias_sigma_raw,
            matrix_sigma_rel,
            predicted_heading_rms_rad: predicted,
        })
    }
}

/// The 1σ heading error, RMS over 36 level headings, that the covariance of
/// the unknowns predicts: for a field of the fitted vertical and horizontal
/// intensity at each heading, the raw reading that gives it, and the heading
/// that reading gets when each unknown moves (numerical derivative).
fn predicted_heading_rms<T: Real>(x: &[T; UNKNOWNS], n: &Normalised<T>, rms: T, cov: &[[T; UNKNOWNS]; UNKNOWNS], sigma2: T) -> T {
    let Some(inv) = inverse3(&n.a) else { return T::NAN };
    let z = n.vertical;
    let horizontal = (rms * rms - z * z).max(T::ZERO).sqrt();
    let heading = |xx: &[T; UNKNOWNS], raw: Vec3<T>| {
        let h = mul_mat_vec(&matrix_of(xx), raw);
        let (c, _) = offsets_of(xx);
        (-(h[1] - c[1])).atan2(h[0] - c[0])
    };
    let mut total = T::ZERO;
    let steps: u32 = 36;
    for step in 0..steps {
        let psi = T::from_u32(step) * T::from_f64(10.0f64.to_radians());
        let h = [horizontal * psi.cos(), -horizontal * psi.sin(), z];
        let raw = mul_mat_vec(&inv, [h[0] + n.c[0], h[1] + n.c[1], h[2] + n.c[2]]);
        let sigma = crate::uncertainty::angle_sigma(x, cov, |xx| heading(xx, raw));
        let var = sigma * sigma;
        total += var * sigma2;
    }
    (total / T::from_u32(steps)).max(T::ZERO).sqrt()
}

mod batch;
pub use batch::{fit_gyro_batch, GyroBatch, WindowChain};

#[cfg(test)]
mod tests;
