//! The batch reference of the gyro-aided fit (host, `f64`): the linear
//! solve of [`super::GyroFit`] over every window, alternated with a
//! Gauss–Newton estimate of the gyro's bias and the magnetometer's
//! sub-sample lag behind it, and the two-stack window chain that feeds it.

use super::*;
use crate::lsq::NormalEquations;
/// Most Gauss–Newton passes for the gyro bias and lag per alternation. One:
/// a second (as before) cost a chain pass a round and moved no committed
/// recording's answer by more than the alternation's own stop allows (gyro
/// bias within 3.3e-7 rad/s of two passes', the stop being 1e-6 rad/s;
/// BROAD validation headings within 4e-7°).
const TIMING_PASSES: u32 = 1;
/// Most alternations between the linear field solve and the gyro-bias step.
const MAX_ALTERNATIONS: usize = 40;
/// The alternation stops when the gyro bias moves less than this, rad/s.
const BIAS_TOLERANCE_RAD_S: f64 = 1e-6;
/// … and the lag less than this, s.
const LAG_TOLERANCE_S: f64 = 1e-5;
/// What the batch reference determined.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GyroBatch<T> {
    /// The field calibration and its quality.
    pub estimate: GyroEstimate<T>,
    /// The gyro's bias, rad/s (the configuration's start plus the estimate).
    pub gyro_bias_rad_s: Vec3<T>,
    /// The magnetometer's lag behind the gyro, s (likewise).
    pub gyro_lag_s: T,
}

/// The batch reference: normalises the samples, alternates the linear fit
/// with a Gauss–Newton estimate of the gyro's bias and of the
/// magnetometer's lag behind it (field fixed, same windows), and returns
/// the final estimate with the bias (rad/s) and the lag (s), both starting
/// from the configuration's.
///
/// In `f64` the linear solves accumulate the normal equations (the
/// information matrix's condition number squared is far inside `f64`'s
/// precision; several times cheaper than the square-root form a sample),
/// their covariance the inverse information; where they fail (a solve
/// refused, no covariance) the whole alternation is done again in the
/// square-root form, which then decides. In `f32` every solve is the
/// square-root form's.
pub fn fit_gyro_batch<T: Real>(samples: &[GyroSample<T>], cfg: &GyroConfig<T>, field_nt: T) -> Result<GyroBatch<T>, FitError> {
    let norm = normalization_of(samples).ok_or(FitError::TooFewSamples { have: samples.len() as u32, need: 2 })?;
    if T::EPSILON < T::from_f64(1e-10) {
        if let Ok((batch, true)) = alternate::<T, NormalEquations<T, UNKNOWNS>>(samples, norm, cfg, field_nt) {
            return Ok(batch);
        }
    }
    alternate::<T, QrRls<T, UNKNOWNS>>(samples, norm, cfg, field_nt).map(|(batch, _)| batch)
}

/// The alternation of [`fit_gyro_batch`] with the accumulator `L`, and
/// whether the final fit has a covariance (without one the estimate's σ
/// are NaN, [`GyroFit::estimate`]).
fn alternate<T: Real, L: Information<T, UNKNOWNS>>(samples: &[GyroSample<T>], norm: Normalization<T>, cfg: &GyroConfig<T>, field_nt: T) -> Result<(GyroBatch<T>, bool), FitError> {
    let mut cfg = *cfg;
    let mut fit = run::<T, L>(samples, norm, &cfg);
    // The linear solve absorbs part of a gyro bias into A and c, so the
    // alternation converges linearly: on the unit tests' data 3 rounds left
    // 6e-4 rad/s and 0.18° of heading, 12 rounds 2e-5 rad/s.
    // The timing steps: Gauss–Newton (every step taken; Jacobi scaling
    // with a negligible damping keeps a direction the windows do not see,
    // e.g. the lag of a steady turn, at its value) for TIMING_PASSES
    // iterations with the field fixed.
    let mut opts = LmOptions::marquardt(T::from_f64(1e-9));
    opts.damping = Damping::JacobiScaled;
    opts.acceptance = Acceptance::Always;
    opts.max_iterations = TIMING_PASSES;
    opts.max_tries = 1;
    for _ in 0..MAX_ALTERNATIONS {
        let (_, n) = fit.solve_normalised()?;
        let mut problem = GyroTimingProblem { samples, norm: &norm, cfg: &cfg, n: &n };
        let b = cfg.gyro_bias_rad_s;
        let out = lm::solve(&mut problem, &[b[0], b[1], b[2], cfg.gyro_lag_s], &opts);
        let [bx, by, bz, lag] = out.params;
        let moved = (0..3).fold(T::ZERO, |m, k| m.max((out.params[k] - b[k]).abs()));
        let lag_moved = (lag - cfg.gyro_lag_s).abs();
        cfg.gyro_bias_rad_s = [bx, by, bz];
        cfg.gyro_lag_s = lag;
        fit = run::<T, L>(samples, norm, &cfg);
        if moved < T::from_f64(BIAS_TOLERANCE_RAD_S) && lag_moved < T::from_f64(LAG_TOLERANCE_S) {
            break;
        }
    }
    let estimate = fit.estimate(field_nt)?;
    let has_covariance = fit.rls.unscaled_covariance().is_some();
    Ok((GyroBatch { estimate, gyro_bias_rad_s: cfg.gyro_bias_rad_s, gyro_lag_s: cfg.gyro_lag_s }, has_covariance))
}

/// The samples through a [`GyroFit`] as [`GyroFit::push`] takes them, the
/// windows' rotations from a [`WindowChain`] (the batch's: a few matrix
/// products a sample instead of one a window step).
fn run<T: Real, L: Information<T, UNKNOWNS>>(samples: &[GyroSample<T>], norm: Normalization<T>, cfg: &GyroConfig<T>) -> GyroFit<T, L> {
    let mut fit = GyroFit::<T, L>::with_accumulator(norm, *cfg);
    let mut chain = WindowChain::new();
    for s in samples {
        if !finite_sample(s) {
            fit.rejected = fit.rejected.saturating_add(1);
            chain.reset();
            continue;
        }
        let r = norm.apply(s.raw);
        let window = chain.push(s, r, cfg);
        fit.absorb_batch(s, r, window);
    }
    fit
}

impl<T: Real, L: Information<T, UNKNOWNS>> GyroFit<T, L> {
    /// [`GyroFit::absorb`] with the window's rows formed from the rotation's
    /// columns: `R·E_k·r_i` is column `row(k)` of `R` times `r_i[col(k)]`,
    /// where `absorb` multiplies `R` by a vector with two zeros. The same
    /// numbers (the products skipped add exact zeros), fewer operations;
    /// the MCU keeps `absorb`.
    fn absorb_batch(&mut self, s: &GyroSample<T>, r: Vec3<T>, window: Option<ChainStep<T>>) {
        if let Some((ri, rj, rot)) = window {
            // A·r_j − R·A·r_i − (I − R)·c = 0, three rows.
            let u: [Vec3<T>; 9] = core::array::from_fn(|k| {
                let (row, col) = ENTRIES[k];
                core::array::from_fn(|m| if m == row { rj[col] } else { T::ZERO } - rot[m][row] * ri[col])
            });
            self.add_window_rows(&u, &rot);
        }
        // The attitude row and the moments, as `absorb` adds them.
        self.absorb(s, r, None);
    }
}

/// A finite time, reading and rate (what [`GyroFit::push`] takes).
fn finite_sample<T: Real>(s: &GyroSample<T>) -> bool {
    s.t_s.is_finite() && s.raw.iter().chain(s.rate_rad_s.iter()).all(|v| v.is_finite())
}

/// [`Chain`]'s windows with their rotations multiplied in two stacks
/// instead of afresh each sample: the steps since the last regrouping are
/// kept as one product (the newest on the left), the older steps of the
/// window as their products up to the regrouping, so a window's rotation
/// is one product of the two, and every window's length of samples the
/// older part is rebuilt once — about three matrix products a sample
/// instead of one a window step. The same windows and the same rotation
/// to rounding (the products are grouped differently: within 2e-15 on
/// the unit test's 32-step windows), for the batch fit and the host's
/// robust refinement; the MCU's [`GyroFit::push`] keeps [`Chain`].
#[derive(Debug, Clone)]
pub struct WindowChain<T>(Stacks<T, Mat3<T>>);

impl<T: Real> Default for WindowChain<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> WindowChain<T> {
    /// No samples yet.
    pub fn new() -> Self {
        Self(Stacks::new())
    }

    /// Breaks the chain, as a new one would start (the stores are written
    /// before they are read again, so they are left as they are: a broken
    /// chain costs nothing to restart).
    pub fn reset(&mut self) {
        self.0.reset();
    }

    /// Adds a finite sample (normalised reading `raw`): once the chain holds
    /// a window of `cfg.window_steps` steps (at most [`MAX_WINDOW_STEPS`]),
    /// the reading at its start, `raw`, and the rotation from the start's
    /// body frame to this one. A step of no time or longer than
    /// `cfg.max_step_s` starts a new chain at this sample.
    pub fn push(&mut self, s: &GyroSample<T>, raw: Vec3<T>, cfg: &GyroConfig<T>) -> Option<(Vec3<T>, Vec3<T>, Mat3<T>)> {
        self.0.push(s, raw, cfg)
    }
}

/// What a window chain multiplies, one per step: the step's rotation, alone
/// ([`Mat3`]) or with what rides along ([`Sensitive`]). Composition is
/// associative, so the two stacks may group the steps as they like.
pub(super) trait WindowElement<T>: Copy {
    /// The element of a step that turned the body by `theta_rad` (rad,
    /// body frame) over `dt_s`, the rate changing by `rate_change_rad_s`.
    fn step(theta_rad: Vec3<T>, dt_s: T, rate_change_rad_s: Vec3<T>) -> Self;
    /// `self` applied after `earlier`.
    fn after(&self, earlier: &Self) -> Self;
    /// The window's rotation.
    fn rotation(&self) -> &Mat3<T>;
}

impl<T: Real> WindowElement<T> for Mat3<T> {
    fn step(theta_rad: Vec3<T>, _: T, _: Vec3<T>) -> Self {
        body_step_rotation(theta_rad)
    }

    fn after(&self, earlier: &Self) -> Self {
        mul_mat(self, earlier)
    }

    fn rotation(&self) -> &Mat3<T> {
        self
    }
}

/// A window's rotation `R` with its sensitivity to the timing `p` (the gyro
/// bias, rad/s, and the lag, s): `∂(R·h)/∂p = [R·h]× · G` for any `h`.
/// A step `S = exp(−[θ]×)` moved by `δθ` is `exp(−[J·δθ]×)·S` to first
/// order (`J` the left Jacobian of the exponential at `−θ`), so a step's
/// `G` is `J·∂θ/∂p` (`∂θ/∂b = −dt·I`, `∂θ/∂lag = −Δω`) and a product's
/// `G` is the later part's rotation times the earlier's `G` plus the
/// later's: `(R₂, G₂)∘(R₁, G₁) = (R₂R₁, R₂G₁ + G₂)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Sensitive<T> {
    rotation: Mat3<T>,
    /// `G`, 3 × [`TIMING`].
    g: [[T; TIMING]; 3],
}

impl<T: Real> WindowElement<T> for Sensitive<T> {
    fn step(theta_rad: Vec3<T>, dt_s: T, rate_change_rad_s: Vec3<T>) -> Self {
        let (k, k2, s, c, a2) = rodrigues_terms(theta_rad);
        let mut rotation = identity3();
        for i in 0..3 {
            for j in 0..3 {
                rotation[i][j] += s * k[i][j] + c * k2[i][j];
            }
        }
        // J = I + c·K + d·K², d = (a − sin a)/a³ (its series near zero).
        let d = if a2 < T::from_f64(1e-4) { T::ONE / T::from_f64(6.0) - a2 / T::from_f64(120.0) } else { (T::ONE - s) / a2 };
        let mut j = identity3();
        for r in 0..3 {
            for q in 0..3 {
                j[r][q] += c * k[r][q] + d * k2[r][q];
            }
        }
        let jdw = mul_mat_vec(&j, rate_change_rad_s);
        let g = core::array::from_fn(|r| [-dt_s * j[r][0], -dt_s * j[r][1], -dt_s * j[r][2], -jdw[r]]);
        Self { rotation, g }
    }

    fn after(&self, earlier: &Self) -> Self {
        let rotation = mul_mat(&self.rotation, &earlier.rotation);
        let g = core::array::from_fn(|r| {
            core::array::from_fn(|q| self.rotation[r][0] * earlier.g[0][q] + self.rotation[r][1] * earlier.g[1][q] + self.rotation[r][2] * earlier.g[2][q] + self.g[r][q])
        });
        Self { rotation, g }
    }

    fn rotation(&self) -> &Mat3<T> {
        &self.rotation
    }
}

#[cfg(test)]
impl<T: Real> Sensitive<T> {
    /// `G[row][p]`.
    pub(super) fn g_entry(&self, row: usize, p: usize) -> T {
        self.g[row][p]
    }
}

/// The two stacks of [`WindowChain`] over any [`WindowElement`].
#[derive(Debug, Clone)]
pub(super) struct Stacks<T, E> {
    raw: [Vec3<T>; MAX_WINDOW_STEPS + 1],
    /// The step into each sample, by the sample's index in the chain.
    step: [E; MAX_WINDOW_STEPS + 1],
    /// `back[a] = S_{m−1} ⋯ S_a` for the window's steps before `m`.
    back: [E; MAX_WINDOW_STEPS + 1],
    /// `S_h ⋯ S_m`, the steps since the regrouping (`None`: none yet).
    front: Option<E>,
    /// The first step in `front`.
    m: usize,
    /// Samples in the unbroken chain (the newest's index + 1).
    count: usize,
    previous: Option<(T, Vec3<T>)>,
}

impl<T: Real, E: WindowElement<T>> Default for Stacks<T, E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, E: WindowElement<T>> Stacks<T, E> {
    /// No samples yet.
    pub(super) fn new() -> Self {
        let none = E::step([T::ZERO; 3], T::ZERO, [T::ZERO; 3]);
        Self { raw: [[T::ZERO; 3]; MAX_WINDOW_STEPS + 1], step: [none; MAX_WINDOW_STEPS + 1], back: [none; MAX_WINDOW_STEPS + 1], front: None, m: 1, count: 0, previous: None }
    }

    /// As [`WindowChain::reset`].
    pub(super) fn reset(&mut self) {
        self.front = None;
        self.m = 1;
        self.count = 0;
        self.previous = None;
    }

    /// As [`WindowChain::push`], the window's element in place of its
    /// rotation.
    pub(super) fn push(&mut self, s: &GyroSample<T>, raw: Vec3<T>, cfg: &GyroConfig<T>) -> Option<(Vec3<T>, Vec3<T>, E)> {
        let cap = MAX_WINDOW_STEPS + 1;
        let step = match self.previous {
            Some((t0, w0)) => {
                let dt = s.t_s - t0;
                (dt > T::ZERO && dt <= cfg.max_step_s).then(|| {
                    let half = T::from_f64(0.5);
                    let (b, lag) = (cfg.gyro_bias_rad_s, cfg.gyro_lag_s);
                    let theta = [0, 1, 2].map(|k| ((w0[k] + s.rate_rad_s[k]) * half - b[k]) * dt - lag * (s.rate_rad_s[k] - w0[k]));
                    E::step(theta, dt, [0, 1, 2].map(|k| s.rate_rad_s[k] - w0[k]))
                })
            }
            None => None,
        };
        match step {
            Some(st) => {
                let h = self.count;
                self.count += 1;
                self.step[h % cap] = st;
                self.raw[h % cap] = raw;
                self.front = Some(match &self.front {
                    Some(f) => st.after(f),
                    None => st,
                });
            }
            None => {
                self.raw[0] = raw;
                self.count = 1;
                self.m = 1;
                self.front = None;
            }
        }
        self.previous = Some((s.t_s, s.rate_rad_s));
        let k = cfg.window_steps.clamp(1, MAX_WINDOW_STEPS);
        if self.count < k + 1 {
            return None;
        }
        let h = self.count - 1;
        let w = h + 1 - k;
        let element = if w < self.m {
            let back = self.back[w % cap];
            match &self.front {
                Some(f) => f.after(&back),
                None => back,
            }
        } else {
            // Regroup: the window's steps become the older part.
            self.back[h % cap] = self.step[h % cap];
            for a in (w..h).rev() {
                self.back[a % cap] = self.back[(a + 1) % cap].after(&self.step[a % cap]);
            }
            self.m = h + 1;
            self.front = None;
            self.back[w % cap]
        };
        Some((self.raw[(h - k) % cap], raw, element))
    }
}

/// Centre and scale of the finite raw samples (as [`Normalization::from_samples`]).
pub(super) fn normalization_of<T: Real>(samples: &[GyroSample<T>]) -> Option<Normalization<T>> {
    let finite = samples.iter().map(|s| s.raw).filter(|r| r.iter().all(|v| v.is_finite()));
    if finite.clone().count() < 2 {
        return None;
    }
    Normalization::from_raw_iter(finite)
}

/// Timing parameters the batch fit estimates: the gyro bias (rad/s, 3) and
/// the magnetometer's lag behind the gyro (s).
const TIMING: usize = 4;

/// The gyro bias and lag with the field fixed, as a problem for the crate's
/// Levenberg–Marquardt: minimises `Σ |h_j − R(b, lag)·h_i|²` over the
/// windows, derivatives carried along the window chain ([`Sensitive`]).
struct GyroTimingProblem<'a, T> {
    samples: &'a [GyroSample<T>],
    norm: &'a Normalization<T>,
    cfg: &'a GyroConfig<T>,
    n: &'a Normalised<T>,
}

impl<T: Real> LmProblem<T, TIMING> for GyroTimingProblem<'_, T> {
    fn linearise(&mut self, p: &[T; TIMING]) -> Option<Linearisation<T, TIMING>> {
        let mut cfg = *self.cfg;
        cfg.gyro_bias_rad_s = [p[0], p[1], p[2]];
        cfg.gyro_lag_s = p[3];
        let mut chain = Stacks::<T, Sensitive<T>>::new();
        let n = self.n;
        let field = |r: Vec3<T>| {
            let h = mul_mat_vec(&n.a, r);
            [h[0] - n.c[0], h[1] - n.c[1], h[2] - n.c[2]]
        };
        let mut lin = Linearisation::zero();
        let mut windows = 0u32;
        for s in self.samples {
            if !finite_sample(s) {
                chain.reset();
                continue;
            }
            let r = self.norm.apply(s.raw);
            let Some((ri, rj, window)) = chain.push(s, r, &cfg) else { continue };
            let (hi, hj) = (field(ri), field(rj));
            let p0 = mul_mat_vec(window.rotation(), hi);
            let e = [hj[0] - p0[0], hj[1] - p0[1], hj[2] - p0[2]];
            // Column k of the Jacobian of e: −∂(R h_i)/∂p_k = G_k × R h_i.
            let g = &window.g;
            let cols: [Vec3<T>; TIMING] = core::array::from_fn(|k| [g[1][k] * p0[2] - g[2][k] * p0[1], g[2][k] * p0[0] - g[0][k] * p0[2], g[0][k] * p0[1] - g[1][k] * p0[0]]);
            for (m, &em) in e.iter().enumerate() {
                lin.add_row(&core::array::from_fn(|a| cols[a][m]), em);
            }
            windows += 1;
        }
        lin.symmetrise();
        (windows >= 4).then_some(lin)
    }

    fn cost(&mut self, p: &[T; TIMING]) -> Option<T> {
        self.linearise(p).map(|l| l.cost)
    }
}
