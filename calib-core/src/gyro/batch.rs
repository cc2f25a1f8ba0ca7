//! The batch reference of the gyro-aided fit (host, `f64`): the linear
//! solve of [`super::GyroFit`] over every window, alternated with a
//! Gauss–Newton estimate of the gyro's bias and the magnetometer's
//! sub-sample lag behind it, and the two-stack window chain that feeds it.

use super::*;
use crate::lsq::NormalEquations;
/// Most Gauss–Newton passes for the gyro bias and lag per alternation.
const TIMING_PASSES: u32 = 2;
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
        fit.absorb(s, r, window);
    }
    fit
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
pub struct WindowChain<T> {
    raw: [Vec3<T>; MAX_WINDOW_STEPS + 1],
    /// The step into each sample, by the sample's index in the chain.
    step: [Mat3<T>; MAX_WINDOW_STEPS + 1],
    /// `back[a] = S_{m−1} ⋯ S_a` for the window's steps before `m`.
    back: [Mat3<T>; MAX_WINDOW_STEPS + 1],
    /// `S_h ⋯ S_m`, the steps since the regrouping (`None`: none yet).
    front: Option<Mat3<T>>,
    /// The first step in `front`.
    m: usize,
    /// Samples in the unbroken chain (the newest's index + 1).
    count: usize,
    previous: Option<(T, Vec3<T>)>,
}

impl<T: Real> Default for WindowChain<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> WindowChain<T> {
    /// No samples yet.
    pub fn new() -> Self {
        Self { raw: [[T::ZERO; 3]; MAX_WINDOW_STEPS + 1], step: [identity3(); MAX_WINDOW_STEPS + 1], back: [identity3(); MAX_WINDOW_STEPS + 1], front: None, m: 1, count: 0, previous: None }
    }

    /// Breaks the chain, as a new one would start (the stores are written
    /// before they are read again, so they are left as they are: a broken
    /// chain costs nothing to restart).
    pub fn reset(&mut self) {
        self.front = None;
        self.m = 1;
        self.count = 0;
        self.previous = None;
    }

    /// Adds a finite sample (normalised reading `raw`): once the chain holds
    /// a window of `cfg.window_steps` steps (at most [`MAX_WINDOW_STEPS`]),
    /// the reading at its start, `raw`, and the rotation from the start's
    /// body frame to this one. A step of no time or longer than
    /// `cfg.max_step_s` starts a new chain at this sample.
    pub fn push(&mut self, s: &GyroSample<T>, raw: Vec3<T>, cfg: &GyroConfig<T>) -> Option<(Vec3<T>, Vec3<T>, Mat3<T>)> {
        let cap = MAX_WINDOW_STEPS + 1;
        let step = match self.previous {
            Some((t0, w0)) => {
                let dt = s.t_s - t0;
                (dt > T::ZERO && dt <= cfg.max_step_s).then(|| {
                    let half = T::from_f64(0.5);
                    let (b, lag) = (cfg.gyro_bias_rad_s, cfg.gyro_lag_s);
                    body_step_rotation([0, 1, 2].map(|k| ((w0[k] + s.rate_rad_s[k]) * half - b[k]) * dt - lag * (s.rate_rad_s[k] - w0[k])))
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
                    Some(f) => mul_mat(&st, f),
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
        let rot = if w < self.m {
            let back = self.back[w % cap];
            match &self.front {
                Some(f) => mul_mat(f, &back),
                None => back,
            }
        } else {
            // Regroup: the window's steps become the older part.
            self.back[h % cap] = self.step[h % cap];
            for a in (w..h).rev() {
                self.back[a % cap] = mul_mat(&self.back[(a + 1) % cap], &self.step[a % cap]);
            }
            self.m = h + 1;
            self.front = None;
            self.back[w % cap]
        };
        Some((self.raw[(h - k) % cap], raw, rot))
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
/// windows, derivatives by differences.
struct GyroTimingProblem<'a, T> {
    samples: &'a [GyroSample<T>],
    norm: &'a Normalization<T>,
    cfg: &'a GyroConfig<T>,
    n: &'a Normalised<T>,
}

impl<T: Real> GyroTimingProblem<'_, T> {
    /// The configuration with the timing `p`, parameter `k − 1` moved by
    /// `eps` (none for `k = 0`).
    fn perturbed(&self, p: &[T; TIMING], k: usize, eps: T) -> GyroConfig<T> {
        let mut c = *self.cfg;
        let mut q = *p;
        if k > 0 {
            q[k - 1] += eps;
        }
        c.gyro_bias_rad_s = [q[0], q[1], q[2]];
        c.gyro_lag_s = q[3];
        c
    }
}

impl<T: Real> LmProblem<T, TIMING> for GyroTimingProblem<'_, T> {
    fn linearise(&mut self, p: &[T; TIMING]) -> Option<Linearisation<T, TIMING>> {
        let eps = T::from_f64(1e-4);
        let cfgs: [GyroConfig<T>; TIMING + 1] = core::array::from_fn(|k| self.perturbed(p, k, eps));
        let mut chains: [WindowChain<T>; TIMING + 1] = core::array::from_fn(|_| WindowChain::new());
        let n = self.n;
        let field = |r: Vec3<T>| {
            let h = mul_mat_vec(&n.a, r);
            [h[0] - n.c[0], h[1] - n.c[1], h[2] - n.c[2]]
        };
        let mut lin = Linearisation::zero();
        let mut windows = 0u32;
        for s in self.samples {
            if !(s.t_s.is_finite() && s.raw.iter().chain(s.rate_rad_s.iter()).all(|v| v.is_finite())) {
                chains.iter_mut().for_each(WindowChain::reset);
                continue;
            }
            let r = self.norm.apply(s.raw);
            let out: [Option<ChainStep<T>>; TIMING + 1] = core::array::from_fn(|k| chains[k].push(s, r, &cfgs[k]));
            let Some((ri, rj, r0)) = out[0] else { continue };
            let (hi, hj) = (field(ri), field(rj));
            let p0 = mul_mat_vec(&r0, hi);
            let e = [hj[0] - p0[0], hj[1] - p0[1], hj[2] - p0[2]];
            // Column k of the Jacobian of e: −∂(R h_i)/∂p_k.
            let mut cols = [[T::ZERO; 3]; TIMING];
            for (k, col) in cols.iter_mut().enumerate() {
                let (_, _, rot) = out[k + 1]?;
                let p = mul_mat_vec(&rot, hi);
                *col = [-(p[0] - p0[0]) / eps, -(p[1] - p0[1]) / eps, -(p[2] - p0[2]) / eps];
            }
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
