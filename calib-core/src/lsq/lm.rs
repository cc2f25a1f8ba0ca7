//! Levenberg–Marquardt: the one non-linear least-squares solver every
//! non-linear fit of the crate calls (in the spirit of PX4's `lm_fit`).
//!
//! The solver is pure: the problem gives, at a parameter vector, the
//! Gauss–Newton normal equations `JᵀJ`, `Jᵀr` and the cost `Σr²` through
//! [`LmProblem`]; the solver owns the iteration. Its whole policy — how the
//! damping is added and changed, when a step is accepted, when to stop — is
//! in one [`LmOptions`]. Fixed-size arrays, no allocation, generic over
//! [`Real`].
//!
//! One iteration: with damping `μ`, solve `(JᵀJ + μ·D)·δ = −Jᵀr` (Cholesky),
//! evaluate the cost at `p + δ`; accept by [`Acceptance`] and lower `μ`, or
//! raise `μ` and try again (at most [`LmOptions::max_tries`] times). `D` is
//! chosen by [`Damping`].

use crate::linalg::cholesky_solve;
use crate::Real;

/// The Gauss–Newton normal equations at one parameter vector.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linearisation<T, const N: usize> {
    /// `JᵀJ` (with any prior's information).
    pub jtj: [[T; N]; N],
    /// `Jᵀr`, the gradient of half the cost.
    pub jtr: [T; N],
    /// The cost `Σr²` there.
    pub cost: T,
}

impl<T: Real, const N: usize> Linearisation<T, N> {
    /// Normal equations of no residual: every problem starts from these
    /// and adds its residuals row by row ([`Linearisation::add_row`]).
    pub fn zero() -> Self {
        Self { jtj: [[T::ZERO; N]; N], jtr: [T::ZERO; N], cost: T::ZERO }
    }

    /// Adds one residual `r` with its Jacobian row `j` (`∂r/∂p`).
    pub fn add_row(&mut self, j: &[T; N], r: T) {
        self.add_weighted_row(j, r, T::ONE);
    }

    /// Adds one residual with weight `w` (its information): `JᵀWJ`, `JᵀWr`,
    /// `w·r²`.
    ///
    /// Only the upper triangle of `JᵀJ` (`a ≤ b`) is accumulated;
    /// [`Linearisation::symmetrise`] fills the lower one, and [`solve`] calls
    /// it on every linearisation it is given. A zero `j[a]` (a term the
    /// residual does not depend on, or one held fixed) adds nothing and is
    /// skipped. The joint back-stepping's 26-parameter rows made this the
    /// host tests' hottest loop: three quarters of a merged-log calibration's
    /// time, halved by this.
    pub fn add_weighted_row(&mut self, j: &[T; N], r: T, w: T) {
        self.cost += w * r * r;
        for a in 0..N {
            let wa = w * j[a];
            if wa == T::ZERO {
                continue;
            }
            self.jtr[a] += wa * r;
            let row = &mut self.jtj[a];
            for b in a..N {
                row[b] += wa * j[b];
            }
        }
    }

    /// Copies the upper triangle of `JᵀJ` onto the lower one (what
    /// [`Linearisation::add_weighted_row`] leaves out). Idempotent on a
    /// symmetric matrix.
    pub fn symmetrise(&mut self) {
        for a in 0..N {
            for b in 0..a {
                self.jtj[a][b] = self.jtj[b][a];
            }
        }
    }
}

/// A non-linear least-squares problem for [`solve`].
pub trait LmProblem<T, const N: usize> {
    /// The normal equations at `p`; `None` where the model cannot be
    /// evaluated (the solve stops with [`LmStop::NotEvaluable`]).
    fn linearise(&mut self, p: &[T; N]) -> Option<Linearisation<T, N>>;
    /// The cost at a candidate `p`; `None` where the model cannot be
    /// evaluated (the candidate is rejected).
    fn cost(&mut self, p: &[T; N]) -> Option<T>;
}

/// How the damping enters the normal matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Damping {
    /// Marquardt's: `JᵀJ_kk += μ·(JᵀJ_kk + ε)`.
    Marquardt,
    /// Jacobi scaling to a unit diagonal, then `+ μ` on it (for parameters
    /// whose sizes differ by orders of magnitude).
    JacobiScaled,
}

/// When a candidate step is accepted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Acceptance {
    /// The cost must fall.
    Decrease,
    /// The cost must not rise.
    NoIncrease,
    /// Every step that solves (Gauss–Newton without a cost check).
    Always,
}

/// What a singular damped normal matrix does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum OnSingular {
    /// Counts as a rejected try: the damping rises.
    RaiseDamping,
    /// Stops the solve with [`LmStop::Singular`].
    Stop,
}

/// The solver's whole policy.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LmOptions<T> {
    /// How the damping is added.
    pub damping: Damping,
    /// `μ` at the start.
    pub initial_damping: T,
    /// `μ` is multiplied by this after a rejected try and divided by it
    /// after an accepted step.
    pub damping_factor: T,
    /// `μ` is not lowered below this.
    pub min_damping: T,
    /// When a step is accepted.
    pub acceptance: Acceptance,
    /// What a singular damped matrix does.
    pub on_singular: OnSingular,
    /// Iterations (linearisations) at most.
    pub max_iterations: u32,
    /// Tries (damping values) per iteration at most.
    pub max_tries: u32,
    /// Stop after an accepted step whose largest component is below this
    /// (0: never).
    pub step_tolerance: T,
    /// Stop after an accepted step that lowered the cost by no more than
    /// this fraction of it (`None`: never).
    pub cost_tolerance: Option<T>,
}

impl<T: Real> LmOptions<T> {
    /// Marquardt damping from `initial_damping`, factor 10, floor 1e-12,
    /// strict decrease, a singular matrix raising the damping, 100
    /// iterations of up to 30 tries, no stopping tolerance.
    pub fn marquardt(initial_damping: T) -> Self {
        Self {
            damping: Damping::Marquardt,
            initial_damping,
            damping_factor: T::from_f64(10.0),
            min_damping: T::from_f64(1e-12),
            acceptance: Acceptance::Decrease,
            on_singular: OnSingular::RaiseDamping,
            max_iterations: 100,
            max_tries: 30,
            step_tolerance: T::ZERO,
            cost_tolerance: None,
        }
    }
}

/// Why a solve stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LmStop {
    /// An accepted step was below [`LmOptions::step_tolerance`].
    SmallStep,
    /// An accepted step lowered the cost by less than
    /// [`LmOptions::cost_tolerance`].
    CostSettled,
    /// No try of an iteration was accepted: a (local) minimum to working
    /// precision.
    NoDescent,
    /// [`LmOptions::max_iterations`] were used.
    MaxIterations,
    /// The problem could not be linearised at the current parameters.
    NotEvaluable,
    /// The damped matrix was singular ([`OnSingular::Stop`]).
    Singular,
}

/// A solve's result: the last accepted parameters and how it ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOutcome<T, const N: usize> {
    /// The parameters.
    pub params: [T; N],
    /// The cost there (NaN with [`Acceptance::Always`] after a step).
    pub cost: T,
    /// Iterations started.
    pub iterations: u32,
    /// Largest |component| of the accepted steps.
    pub largest_step: T,
    /// Why it stopped.
    pub stop: LmStop,
}

/// The damped step `δ` at `lin` (in the parameters' units), or `None` when
/// the damped matrix is singular.
fn damped_step<T: Real, const N: usize>(lin: &Linearisation<T, N>, mu: T, damping: Damping) -> Option<[T; N]> {
    match damping {
        Damping::Marquardt => {
            let mut a = lin.jtj;
            for (k, row) in a.iter_mut().enumerate() {
                row[k] += mu * (lin.jtj[k][k] + T::EPSILON);
            }
            cholesky_solve(&a, &lin.jtr.map(|v| -v)).ok()
        }
        Damping::JacobiScaled => {
            let scale: [T; N] = core::array::from_fn(|k| {
                let d = lin.jtj[k][k];
                if d > T::ZERO {
                    T::ONE / d.sqrt()
                } else {
                    T::ONE
                }
            });
            let mut a = lin.jtj;
            for i in 0..N {
                for j in 0..N {
                    a[i][j] *= scale[i] * scale[j];
                }
                a[i][i] += mu;
            }
            let neg: [T; N] = core::array::from_fn(|k| -lin.jtr[k] * scale[k]);
            let step = cholesky_solve(&a, &neg).ok()?;
            Some(core::array::from_fn(|k| step[k] * scale[k]))
        }
    }
}

/// Minimises the problem's cost from `p0` by Levenberg–Marquardt under
/// `opts` (see the module documentation). Never panics; the outcome says
/// why it stopped.
pub fn solve<T: Real, const N: usize>(problem: &mut impl LmProblem<T, N>, p0: &[T; N], opts: &LmOptions<T>) -> LmOutcome<T, N> {
    let mut out = LmOutcome { params: *p0, cost: T::NAN, iterations: 0, largest_step: T::ZERO, stop: LmStop::MaxIterations };
    let Some(mut lin) = problem.linearise(p0) else {
        out.stop = LmStop::NotEvaluable;
        return out;
    };
    lin.symmetrise();
    out.cost = lin.cost;
    let mut fresh = true;
    let mut mu = opts.initial_damping;
    while out.iterations < opts.max_iterations {
        if !fresh {
            match problem.linearise(&out.params) {
                Some(l) => {
                    lin = l;
                    lin.symmetrise();
                }
                None => {
                    out.stop = LmStop::NotEvaluable;
                    return out;
                }
            }
        }
        out.iterations += 1;
        let (cand, cost, step) = match try_steps(problem, &lin, &out.params, out.cost, &mut mu, opts) {
            Tried::Accepted(cand, cost, step) => (cand, cost, step),
            Tried::Rejected => {
                out.stop = LmStop::NoDescent;
                return out;
            }
            Tried::Singular => {
                out.stop = LmStop::Singular;
                return out;
            }
        };
        let largest = step.iter().fold(T::ZERO, |m, v| m.max(v.abs()));
        let settled = opts.cost_tolerance.is_some_and(|tol| out.cost - cost <= tol * out.cost);
        out.largest_step = out.largest_step.max(largest);
        out.params = cand;
        out.cost = cost;
        fresh = false;
        mu = (mu / opts.damping_factor).max(opts.min_damping);
        if largest < opts.step_tolerance {
            out.stop = LmStop::SmallStep;
            return out;
        }
        if settled {
            out.stop = LmStop::CostSettled;
            return out;
        }
    }
    out.stop = LmStop::MaxIterations;
    out
}

/// What the tries of one iteration came to.
enum Tried<T, const N: usize> {
    /// The candidate, its cost and the step.
    Accepted([T; N], T, [T; N]),
    /// No try was accepted (`mu` raised each time).
    Rejected,
    /// The damped matrix was singular under [`OnSingular::Stop`].
    Singular,
}

/// The tries of one iteration.
fn try_steps<T: Real, const N: usize>(
    problem: &mut impl LmProblem<T, N>,
    lin: &Linearisation<T, N>,
    p: &[T; N],
    cost: T,
    mu: &mut T,
    opts: &LmOptions<T>,
) -> Tried<T, N> {
    for _ in 0..opts.max_tries {
        let Some(step) = damped_step(lin, *mu, opts.damping) else {
            if opts.on_singular == OnSingular::Stop {
                return Tried::Singular;
            }
            *mu *= opts.damping_factor;
            continue;
        };
        let cand: [T; N] = core::array::from_fn(|k| p[k] + step[k]);
        let c = match opts.acceptance {
            Acceptance::Always => return Tried::Accepted(cand, T::NAN, step),
            _ => problem.cost(&cand),
        };
        let accept = match (c, opts.acceptance) {
            (Some(c), Acceptance::Decrease) => c < cost,
            (Some(c), _) => c <= cost,
            (None, _) => false,
        };
        if let (true, Some(c)) = (accept, c) {
            return Tried::Accepted(cand, c, step);
        }
        *mu *= opts.damping_factor;
    }
    Tried::Rejected
}

#[cfg(test)]
mod tests {
    /// The builder's normal equations against the same sums written out
    /// (a 3-residual, 2-parameter problem computed by hand).
    #[test]
    fn the_builder_adds_rows_as_the_normal_equations_say() {
        let mut lin = Linearisation::<f64, 2>::zero();
        lin.add_row(&[1.0, 2.0], 0.5);
        lin.add_row(&[-1.0, 0.0], 2.0);
        lin.add_weighted_row(&[0.0, 3.0], -1.0, 4.0);
        // JᵀWJ = [[1+1, 2], [2, 4+36]], JᵀWr = [0.5−2, 1−12], Σwr² = 0.25+4+4;
        // the rows fill the upper triangle, `symmetrise` the lower.
        assert_eq!(lin.jtj, [[2.0, 2.0], [0.0, 40.0]]);
        lin.symmetrise();
        assert_eq!(lin.jtj, [[2.0, 2.0], [2.0, 40.0]]);
        assert_eq!(lin.jtr, [-1.5, -11.0]);
        assert_eq!(lin.cost, 8.25);
    }

    use super::*;

    /// Rosenbrock's function as least squares: r = (10(y − x²), 1 − x),
    /// minimum at (1, 1) (Moré, Garbow & Hillstrom 1981, problem 1).
    struct Rosenbrock;

    impl LmProblem<f64, 2> for Rosenbrock {
        fn linearise(&mut self, p: &[f64; 2]) -> Option<Linearisation<f64, 2>> {
            let r = [10.0 * (p[1] - p[0] * p[0]), 1.0 - p[0]];
            let j = [[-20.0 * p[0], 10.0], [-1.0, 0.0]];
            let mut lin = Linearisation { jtj: [[0.0; 2]; 2], jtr: [0.0; 2], cost: r[0] * r[0] + r[1] * r[1] };
            for m in 0..2 {
                for a in 0..2 {
                    lin.jtr[a] += j[m][a] * r[m];
                    for b in 0..2 {
                        lin.jtj[a][b] += j[m][a] * j[m][b];
                    }
                }
            }
            Some(lin)
        }
        fn cost(&mut self, p: &[f64; 2]) -> Option<f64> {
            self.linearise(p).map(|l| l.cost)
        }
    }

    #[test]
    fn rosenbrock_from_the_standard_start() {
        // MGH's start (−1.2, 1); the known minimum is (1, 1) with cost 0.
        let mut opts = LmOptions::marquardt(1e-3);
        opts.step_tolerance = 1e-12;
        let out = solve(&mut Rosenbrock, &[-1.2, 1.0], &opts);
        assert!((out.params[0] - 1.0).abs() < 1e-8 && (out.params[1] - 1.0).abs() < 1e-8, "{out:?}");
        assert!(out.iterations < 100, "{out:?}");
    }

    #[test]
    fn jacobi_scaled_reaches_the_same_minimum() {
        let mut opts = LmOptions::marquardt(1e-4);
        opts.damping = Damping::JacobiScaled;
        opts.on_singular = OnSingular::Stop;
        opts.cost_tolerance = Some(1e-20);
        let out = solve(&mut Rosenbrock, &[-1.2, 1.0], &opts);
        assert!((out.params[0] - 1.0).abs() < 1e-6 && (out.params[1] - 1.0).abs() < 1e-6, "{out:?}");
    }

    struct Unevaluable;

    impl LmProblem<f64, 1> for Unevaluable {
        fn linearise(&mut self, _: &[f64; 1]) -> Option<Linearisation<f64, 1>> {
            None
        }
        fn cost(&mut self, _: &[f64; 1]) -> Option<f64> {
            None
        }
    }

    #[test]
    fn a_problem_that_cannot_be_evaluated_stops_without_a_step() {
        let out = solve(&mut Unevaluable, &[3.0], &LmOptions::marquardt(1e-3));
        assert_eq!((out.stop, out.params, out.iterations), (LmStop::NotEvaluable, [3.0], 0));
    }
}
