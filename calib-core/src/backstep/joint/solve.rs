//! The solution: the normal equations with the priors, the crate's
//! Levenberg–Marquardt on them, the re-weighting and the misalignment's
//! decision, and the covariance (inflated for correlated residuals).

use super::model::{Model, B0, BR0, C0, DI, GH, GZ, K0, M0, MP, MR};
use super::{JointConfig, JointNote, JointSigmas, SwingSample, NP};
use crate::backstep::{BackstepError, RunSample};
use crate::lsq::lm::{self, Damping, LmOptions, LmProblem, LmStop, Linearisation, OnSingular};
use crate::Real;

/// Smallest residual σ the re-weighting uses, nT.
const MIN_RESIDUAL_SIGMA_NT: f64 = 0.5;

/// Largest variance inflation for correlated residuals.
const MAX_INFLATION: f64 = 1000.0;

/// The normal equations (the crate's one builder, [`Linearisation`], with
/// the priors added), the priors' part of the cost, and the residuals'
/// unweighted sums of squares.
#[derive(Clone)]
pub(super) struct Normal<T> {
    /// `JᵀWJ`, `JᵀWr` and the data's cost `Σ w r²`.
    pub(super) lin: Linearisation<T, NP>,
    prior_cost: T,
    /// Σ unweighted r² and count of the run's residuals, and of the swing's.
    pub(super) run_ss: (T, u32),
    pub(super) swing_ss: (T, u32),
}

impl<T: Real> Normal<T> {
    pub(super) fn new(jtj: [[T; NP]; NP]) -> Self {
        let mut lin = Linearisation::zero();
        lin.jtj = jtj;
        Self { lin, prior_cost: T::ZERO, run_ss: (T::ZERO, 0), swing_ss: (T::ZERO, 0) }
    }

    /// Adds a residual `r` with its square-root weight `w` (`w·r` is
    /// unit-variance); the held terms' columns are left out.
    pub(super) fn add(&mut self, active: &[bool; NP], r: T, w: T, j: &[T; NP]) {
        let j = core::array::from_fn(|a| if active[a] { j[a] } else { T::ZERO });
        self.lin.add_weighted_row(&j, r, w * w);
    }

    /// The whole cost: the data's and the priors'.
    fn cost(&self) -> T {
        self.lin.cost + self.prior_cost
    }
}

fn normal_equations<T: Real>(model: &Model<T>, p: &[T; NP], prior: &[T; NP], prior_w: &[T; NP], run: &[RunSample<T>], swing: &[SwingSample<T>]) -> Normal<T> {
    let mut n = Normal::new([[T::ZERO; NP]; NP]);
    let active = model.active;
    for s in run {
        model.run_residuals(p, s, &mut |r, w, j| {
            n.run_ss = (n.run_ss.0 + r * r, n.run_ss.1 + 1);
            n.add(&active, r, w, j)
        });
    }
    for s in swing {
        model.swing_residual(p, s, &mut |r, w, j| {
            n.swing_ss = (n.swing_ss.0 + r * r, n.swing_ss.1 + 1);
            n.add(&active, r, w, j)
        });
    }
    n.lin.symmetrise();
    for a in 0..NP {
        if active[a] {
            let r = (p[a] - prior[a]) * prior_w[a];
            n.prior_cost += r * r;
            n.lin.jtr[a] += prior_w[a] * r;
            n.lin.jtj[a][a] += prior_w[a] * prior_w[a];
        } else {
            // Held: an identity row keeps the system regular, the step zero.
            n.lin.jtj[a][a] = T::ONE;
        }
    }
    n
}

/// The joint problem for the crate's Levenberg–Marquardt. A candidate's
/// normal equations are kept, so that an accepted step is not linearised
/// twice.
struct JointProblem<'a, T> {
    model: &'a Model<T>,
    prior: &'a [T; NP],
    prior_w: &'a [T; NP],
    run: &'a [RunSample<T>],
    swing: &'a [SwingSample<T>],
    last: Option<([T; NP], Normal<T>)>,
}

impl<T: Real> JointProblem<'_, T> {
    fn normal(&mut self, p: &[T; NP]) -> Normal<T> {
        match &self.last {
            Some((at, n)) if at == p => n.clone(),
            _ => {
                let n = normal_equations(self.model, p, self.prior, self.prior_w, self.run, self.swing);
                self.last = Some((*p, n.clone()));
                n
            }
        }
    }
}

impl<T: Real> LmProblem<T, NP> for JointProblem<'_, T> {
    fn linearise(&mut self, p: &[T; NP]) -> Option<Linearisation<T, NP>> {
        let n = self.normal(p);
        let cost = n.cost();
        Some(Linearisation { cost, ..n.lin })
    }

    fn cost(&mut self, p: &[T; NP]) -> Option<T> {
        let n = self.normal(p);
        Some(n.cost())
    }
}

/// Levenberg–Marquardt from `p0` with Jacobi scaling (matrix entries,
/// counts-sized biases and their gradients differ by many orders of
/// magnitude): damping 1e-4, strict decrease, at most 50 iterations of 20
/// tries, stopped when the cost settles to 1e-10 of itself.
fn solve<T: Real>(
    model: &Model<T>,
    p0: &[T; NP],
    prior: &[T; NP],
    prior_w: &[T; NP],
    run: &[RunSample<T>],
    swing: &[SwingSample<T>],
) -> Result<([T; NP], u8), BackstepError> {
    let mut problem = JointProblem { model, prior, prior_w, run, swing, last: None };
    let mut opts = LmOptions::marquardt(T::from_f64(1e-4));
    opts.damping = Damping::JacobiScaled;
    opts.on_singular = OnSingular::Stop;
    opts.max_iterations = 50;
    opts.max_tries = 20;
    opts.cost_tolerance = Some(T::from_f64(1e-10));
    let out = lm::solve(&mut problem, p0, &opts);
    if out.stop == LmStop::Singular {
        return Err(BackstepError::Singular);
    }
    if !out.params.iter().all(|v| v.is_finite()) {
        return Err(BackstepError::Diverged);
    }
    Ok((out.params, out.iterations.min(u32::from(u8::MAX)) as u8))
}

/// The data and the prior of one joint problem.
pub(super) struct JointData<'a, T> {
    pub(super) prior: &'a [T; NP],
    pub(super) prior_w: &'a [T; NP],
    pub(super) run: &'a [RunSample<T>],
    pub(super) swing: &'a [SwingSample<T>],
}

impl<T: Real> JointData<'_, T> {
    fn solve(&self, model: &Model<T>, p0: &[T; NP]) -> Result<([T; NP], u8), BackstepError> {
        solve(model, p0, self.prior, self.prior_w, self.run, self.swing)
    }

    fn normal(&self, model: &Model<T>, p: &[T; NP]) -> Normal<T> {
        normal_equations(model, p, self.prior, self.prior_w, self.run, self.swing)
    }

    /// Solves from the prior, replaces the assumed residual σ by the
    /// residuals' own scatter (so that the priors weigh what they should
    /// against the data), and solves again.
    pub(super) fn solve_reweighted(&self, model: &mut Model<T>) -> Result<([T; NP], u8), BackstepError> {
        let (p, iterations) = self.solve(model, self.prior)?;
        let n0 = self.normal(model, &p);
        let floor = T::from_f64(MIN_RESIDUAL_SIGMA_NT);
        let rms = |(ss, k): (T, u32)| if k > 0 { (ss / T::from_f64(f64::from(k))).sqrt() } else { T::NAN };
        let (run_rms, swing_rms) = (rms(n0.run_ss), rms(n0.swing_ss));
        if run_rms.is_finite() {
            model.w_run = T::ONE / run_rms.max(floor);
        }
        if swing_rms.is_finite() {
            model.w_swing = T::ONE / swing_rms.max(floor);
        }
        let (p1, it1) = self.solve(model, &p)?;
        Ok((p1, iterations.saturating_add(it1)))
    }

    /// Keeps the misalignment only where the data shrink its σ below half
    /// the prior's; otherwise holds it at zero, solves again and returns the
    /// note. Returns the parameters, their normal equations, the added
    /// iterations and whether the misalignment is estimated.
    pub(super) fn settle_misalignment(&self, model: &mut Model<T>, p: [T; NP], cfg: &JointConfig<T>) -> Result<Settled<T>, BackstepError> {
        let n = self.normal(model, &p);
        let first = spd_cov(&n, model)?;
        let ratio = first[MR][MR].max(first[MP][MP]).sqrt() / cfg.misalignment_prior_rad;
        if !cfg.terms.misalignment || ratio < T::from_f64(0.5) {
            return Ok(Settled { p, n, iterations: 0, estimated: cfg.terms.misalignment, note: None });
        }
        model.active[MR] = false;
        model.active[MP] = false;
        let mut start_p = p;
        start_p[MR] = T::ZERO;
        start_p[MP] = T::ZERO;
        let (p2, it2) = self.solve(model, &start_p)?;
        let n = self.normal(model, &p2);
        Ok(Settled { p: p2, n, iterations: it2, estimated: false, note: Some(JointNote::MisalignmentNotObservable { sigma_ratio: ratio }) })
    }
}

/// The solution after the misalignment's decision.
pub(super) struct Settled<T> {
    pub(super) p: [T; NP],
    pub(super) n: Normal<T>,
    pub(super) iterations: u8,
    pub(super) estimated: bool,
    pub(super) note: Option<JointNote<T>>,
}

/// Lag-1 autocorrelation of the run's residuals (vertical and horizontal
/// channels each with its predecessor), in [0, 1).
fn residual_autocorrelation<T: Real>(model: &Model<T>, p: &[T; NP], run: &[RunSample<T>]) -> T {
    let (mut prev, mut cross, mut square) = ([T::NAN; 2], T::ZERO, T::ZERO);
    for s in run {
        let mut k = 0usize;
        let mut now = [T::NAN; 2];
        model.run_residuals(p, s, &mut |r, _, _| {
            if k < 2 {
                now[k] = r;
            }
            k += 1;
        });
        for c in 0..2 {
            if now[c].is_finite() {
                square += now[c] * now[c];
                if prev[c].is_finite() {
                    cross += now[c] * prev[c];
                }
            }
        }
        prev = now;
    }
    if !(square > T::ZERO) {
        return T::ZERO;
    }
    (cross / square).max(T::ZERO).min(T::from_f64(0.999))
}

/// Divides the data's part of the information by the AR(1) variance
/// inflation (1 + ρ)/(1 − ρ) of the run's residuals (neighbouring samples
/// are not independent: slow AHRS errors, the field's gradient along the
/// track); the priors' part stays. Returns the inflation.
pub(super) fn inflate_for_correlation<T: Real>(n: &mut Normal<T>, model: &Model<T>, p: &[T; NP], prior_w: &[T; NP], run: &[RunSample<T>]) -> T {
    let rho = residual_autocorrelation(model, p, run);
    let inflation = ((T::ONE + rho) / (T::ONE - rho)).max(T::ONE).min(T::from_f64(MAX_INFLATION));
    for a in 0..NP {
        if !model.active[a] {
            continue;
        }
        let pa = prior_w[a] * prior_w[a];
        for b in 0..NP {
            if model.active[b] {
                let prior_part = if a == b { pa } else { T::ZERO };
                n.lin.jtj[a][b] = (n.lin.jtj[a][b] - prior_part) / inflation + prior_part;
            }
        }
    }
    inflation
}

/// The covariance (inverse of the normal matrix with the priors, fixed terms
/// zeroed) and its scale factor (1: the residual weights were set from the
/// residuals' scatter before).
pub(super) fn spd_cov<T: Real>(n: &Normal<T>, model: &Model<T>) -> Result<[[T; NP]; NP], BackstepError> {
    let mut cov = crate::uncertainty::spd_inverse(&n.lin.jtj).ok_or(BackstepError::Singular)?;
    for a in 0..NP {
        if !model.active[a] {
            for b in 0..NP {
                cov[a][b] = T::ZERO;
                cov[b][a] = T::ZERO;
            }
        }
    }
    // The weights are the residuals' own scatter: no further scale.
    Ok(cov)
}

/// Each parameter's 1σ from the covariance.
pub(super) fn sigmas_of<T: Real>(cov: &[[T; NP]; NP]) -> JointSigmas<T> {
    let sd = |a: usize| cov[a][a].max(T::ZERO).sqrt();
    JointSigmas {
        matrix: core::array::from_fn(|a| sd(M0 + a)),
        bias: core::array::from_fn(|k| sd(B0 + k)),
        running_bias: core::array::from_fn(|k| sd(BR0 + k)),
        bias_per_a: core::array::from_fn(|k| sd(C0 + k)),
        gain_per_c: core::array::from_fn(|k| sd(K0 + k)),
        local_inclination_rad: sd(DI),
        misalignment_rad: [sd(MR), sd(MP)],
        gradient_nt_per_m: [sd(GH), sd(GZ)],
    }
}
