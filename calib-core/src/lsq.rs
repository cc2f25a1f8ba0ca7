//! Linear least squares, two ways, and in [`lm`] the one non-linear solver.
//!
//! * [`NormalEquations`]: the batch reference, literally eq 16 of paper 000,
//!   `x̂ = (ΦᵀΦ)⁻¹ Φᵀz`, accumulated sample by sample (no storage of Φ) and
//!   solved by Cholesky. Meant for `f64` on the host.
//! * [`QrRls`]: recursive least squares in square-root information form. The
//!   upper-triangular `R` (with `RᵀR = ΦᵀΦ`) and `Qᵀz` are updated by Givens
//!   rotations, one sample at a time; the estimate is a back substitution.
//!   No covariance matrix is ever formed, so the condition number is not
//!   squared: the form that stays accurate in `f32` on the MCU. An optional
//!   forgetting factor `λ` scales `R` by `√λ` before each update.
//!
//! Both take normalised regressors (the models in [`crate::fit`] centre and
//! scale the raw field so every entry is O(1)).

use crate::linalg::cholesky_solve;
use crate::Real;

pub mod lm;

/// Why a least-squares solve failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SolveError {
    /// Fewer samples than unknowns.
    TooFewSamples {
        /// Samples accumulated.
        have: u32,
        /// Unknowns to determine.
        need: u32,
    },
    /// The data do not determine parameter `index` (the information matrix is
    /// singular or nearly so in that direction): insufficient excitation.
    IllConditioned {
        /// Index of the first undetermined parameter.
        index: u8,
    },
}

/// A least-squares accumulator: what the fits need from either engine.
pub trait LeastSquares<T, const N: usize> {
    /// Absorbs `φ·x ≈ y`; `false` (and nothing absorbed) for non-finite input.
    fn update(&mut self, phi: &[T; N], y: T) -> bool;
    /// Samples absorbed.
    fn count(&self) -> u32;
    /// Solves for the first `k` parameters only (the later columns are
    /// dropped from the model); the rest of the result is zero.
    fn solve_leading(&self, k: usize) -> Result<[T; N], SolveError>;
}

/// Relative size under which a diagonal of `R` counts as zero.
fn rank_tolerance<T: Real>() -> T {
    // ~1e-5 in f32, ~2e-14 in f64: a direction with that little information
    // relative to the best-determined one cannot be trusted.
    T::EPSILON.sqrt() * T::from_f64(1e-2).max(T::EPSILON.sqrt())
}

/// Recursive least squares in square-root information form (QR-RLS).
#[derive(Debug, Clone)]
pub struct QrRls<T, const N: usize> {
    r: [[T; N]; N],
    qtz: [T; N],
    rss: T,
    count: u32,
}

impl<T: Real, const N: usize> Default for QrRls<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const N: usize> QrRls<T, N> {
    /// No information yet.
    pub fn new() -> Self {
        Self { r: [[T::ZERO; N]; N], qtz: [T::ZERO; N], rss: T::ZERO, count: 0 }
    }

    /// Samples absorbed.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Residual sum of squares of the current least-squares solution (in the
    /// regression's normalised units).
    pub fn residual_sum_of_squares(&self) -> T {
        self.rss
    }

    /// Absorbs one equation `φ·x ≈ y`. Non-finite input is ignored and
    /// reported by returning `false`.
    pub fn update(&mut self, phi: &[T; N], y: T) -> bool {
        if !y.is_finite() || !phi.iter().all(|v| v.is_finite()) {
            return false;
        }
        let mut row = *phi;
        let mut yy = y;
        for i in 0..N {
            let b = row[i];
            if b == T::ZERO {
                continue;
            }
            let a = self.r[i][i];
            let h = hypot(a, b);
            let (c, s) = (a / h, b / h);
            self.r[i][i] = h;
            for j in i + 1..N {
                let rij = self.r[i][j];
                self.r[i][j] = c * rij + s * row[j];
                row[j] = c * row[j] - s * rij;
            }
            let zi = self.qtz[i];
            self.qtz[i] = c * zi + s * yy;
            yy = c * yy - s * zi;
        }
        self.rss += yy * yy;
        self.count = self.count.saturating_add(1);
        true
    }

    /// Discounts the past: multiplies the information by `lambda` (0 < λ ≤ 1).
    /// Call before each update for exponential forgetting.
    pub fn forget(&mut self, lambda: T) {
        if !(lambda > T::ZERO && lambda <= T::ONE) {
            return;
        }
        let s = lambda.sqrt();
        for row in self.r.iter_mut() {
            for v in row.iter_mut() {
                *v *= s;
            }
        }
        for v in self.qtz.iter_mut() {
            *v *= s;
        }
        self.rss *= lambda;
    }

    /// |R_ii|, the information along each parameter after the previous ones
    /// (a per-parameter excitation measure).
    pub fn information_diagonal(&self) -> [T; N] {
        let mut d = [T::ZERO; N];
        for (i, v) in d.iter_mut().enumerate() {
            *v = self.r[i][i].abs();
        }
        d
    }

    /// `(RᵀR)⁻¹ = R⁻¹R⁻ᵀ`, the unscaled covariance of the estimate (multiply
    /// by the residual variance for the parameters' covariance). `None` when
    /// a direction has no information.
    pub fn covariance(&self) -> Option<[[T; N]; N]> {
        let max = self.information_diagonal().iter().fold(T::ZERO, |m, &v| m.max(v));
        let tol = max * rank_tolerance::<T>();
        // R⁻¹ (upper triangular) by back substitution, column by column.
        let mut inv = [[T::ZERO; N]; N];
        for j in 0..N {
            for i in (0..=j).rev() {
                let d = self.r[i][i];
                if !(d.abs() > tol) {
                    return None;
                }
                let mut s = if i == j { T::ONE } else { T::ZERO };
                for k in i + 1..=j {
                    s -= self.r[i][k] * inv[k][j];
                }
                inv[i][j] = s / d;
            }
        }
        let mut cov = [[T::ZERO; N]; N];
        for i in 0..N {
            for j in 0..N {
                let mut s = T::ZERO;
                for k in i.max(j)..N {
                    s += inv[i][k] * inv[j][k];
                }
                cov[i][j] = s;
            }
        }
        Some(cov)
    }

    /// The least-squares estimate by back substitution.
    pub fn solve(&self) -> Result<[T; N], SolveError> {
        self.solve_leading(N)
    }

    /// The least-squares estimate of a model made of the first `k` columns
    /// only: because the QR factor of the leading columns is the leading
    /// block of `R`, nested models come from one accumulator.
    pub fn solve_leading(&self, k: usize) -> Result<[T; N], SolveError> {
        let k = k.min(N);
        if (self.count as usize) < k {
            return Err(SolveError::TooFewSamples { have: self.count, need: k as u32 });
        }
        let max = self.information_diagonal().iter().take(k).fold(T::ZERO, |m, &v| m.max(v));
        let tol = max * rank_tolerance::<T>();
        let mut x = [T::ZERO; N];
        for i in (0..k).rev() {
            let d = self.r[i][i];
            if !(d.abs() > tol) {
                return Err(SolveError::IllConditioned { index: i as u8 });
            }
            let mut s = self.qtz[i];
            for j in i + 1..k {
                s -= self.r[i][j] * x[j];
            }
            x[i] = s / d;
        }
        Ok(x)
    }
}

impl<T: Real, const N: usize> LeastSquares<T, N> for QrRls<T, N> {
    fn update(&mut self, phi: &[T; N], y: T) -> bool {
        QrRls::update(self, phi, y)
    }
    fn count(&self) -> u32 {
        QrRls::count(self)
    }
    fn solve_leading(&self, k: usize) -> Result<[T; N], SolveError> {
        QrRls::solve_leading(self, k)
    }
}

impl<T: Real, const N: usize> LeastSquares<T, N> for NormalEquations<T, N> {
    fn update(&mut self, phi: &[T; N], y: T) -> bool {
        NormalEquations::update(self, phi, y)
    }
    fn count(&self) -> u32 {
        NormalEquations::count(self)
    }
    fn solve_leading(&self, k: usize) -> Result<[T; N], SolveError> {
        NormalEquations::solve_leading(self, k)
    }
}

/// What a fit reads back from its accumulator besides the estimate: the
/// unscaled covariance and the residual sum of squares. [`QrRls`] (the
/// MCU's, any precision) and [`NormalEquations`] (the host's batch fits in
/// `f64`, where the condition number squared is far inside the precision).
pub trait Information<T, const N: usize>: LeastSquares<T, N> + Default {
    /// The estimate of every parameter, refused where [`QrRls::solve`]
    /// refuses it (too few samples, a direction with too little
    /// information); the normal equations may refuse more (their Cholesky
    /// fails first), never less.
    fn solve_all(&self) -> Result<[T; N], SolveError>;
    /// `(ΦᵀΦ)⁻¹`, or `None` when a direction has no information.
    fn unscaled_covariance(&self) -> Option<[[T; N]; N]>;
    /// `Σ(y − φ·x)²` at the least-squares solution `x`.
    fn residual_sum_of_squares_at(&self, x: &[T; N]) -> T;
}

impl<T: Real, const N: usize> Information<T, N> for QrRls<T, N> {
    fn solve_all(&self) -> Result<[T; N], SolveError> {
        self.solve()
    }
    fn unscaled_covariance(&self) -> Option<[[T; N]; N]> {
        self.covariance()
    }
    fn residual_sum_of_squares_at(&self, _x: &[T; N]) -> T {
        self.residual_sum_of_squares()
    }
}

impl<T: Real, const N: usize> Information<T, N> for NormalEquations<T, N> {
    fn solve_all(&self) -> Result<[T; N], SolveError> {
        let x = self.solve()?;
        // The square-root form's diagonal, |R_ii| = L_ii of ΦᵀΦ's Cholesky
        // factor, held to the same rank tolerance.
        let d = self.square_root_diagonal().ok_or(SolveError::IllConditioned { index: 0 })?;
        let max = d.iter().fold(T::ZERO, |m, &v| m.max(v));
        let tol = max * rank_tolerance::<T>();
        match d.iter().position(|v| !(*v > tol)) {
            Some(i) => Err(SolveError::IllConditioned { index: i as u8 }),
            None => Ok(x),
        }
    }
    fn unscaled_covariance(&self) -> Option<[[T; N]; N]> {
        self.covariance()
    }
    fn residual_sum_of_squares_at(&self, x: &[T; N]) -> T {
        // yᵀy − 2xᵀΦᵀy + xᵀΦᵀΦx, the upper triangle doubled.
        let mut quad = T::ZERO;
        let mut cross = T::ZERO;
        for i in 0..N {
            let mut row = T::ZERO;
            for j in i + 1..N {
                row += self.ata[i][j] * x[j];
            }
            quad += x[i] * (self.ata[i][i] * x[i] + T::from_f64(2.0) * row);
            cross += x[i] * self.atb[i];
        }
        (self.btb - T::from_f64(2.0) * cross + quad).max(T::ZERO)
    }
}

/// `√(a² + b²)` without overflow for large inputs.
fn hypot<T: Real>(a: T, b: T) -> T {
    let (a, b) = (a.abs(), b.abs());
    let (big, small) = if a > b { (a, b) } else { (b, a) };
    if big == T::ZERO {
        return T::ZERO;
    }
    let r = small / big;
    big * (T::ONE + r * r).sqrt()
}

/// Batch least squares through the normal equations (paper 000, eq 16).
#[derive(Debug, Clone)]
pub struct NormalEquations<T, const N: usize> {
    ata: [[T; N]; N],
    atb: [T; N],
    btb: T,
    count: u32,
}

impl<T: Real, const N: usize> Default for NormalEquations<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, const N: usize> NormalEquations<T, N> {
    /// Empty.
    pub fn new() -> Self {
        Self { ata: [[T::ZERO; N]; N], atb: [T::ZERO; N], btb: T::ZERO, count: 0 }
    }

    /// Samples accumulated.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Adds the equation `φ·x ≈ y`; non-finite input is refused (`false`).
    pub fn update(&mut self, phi: &[T; N], y: T) -> bool {
        if !y.is_finite() || !phi.iter().all(|v| v.is_finite()) {
            return false;
        }
        // The upper triangle only (the lower is its mirror, made at the
        // solve: the same products summed in the same order, bit for bit).
        for i in 0..N {
            let p = phi[i];
            for j in i..N {
                self.ata[i][j] += p * phi[j];
            }
            self.atb[i] += p * y;
        }
        self.btb += y * y;
        self.count = self.count.saturating_add(1);
        true
    }

    /// The equations from their sums: `ΦᵀΦ` (its upper triangle is read),
    /// `Φᵀz`, `zᵀz` and the number of equations, for a caller that sums
    /// them in a form of its own ([`crate::attitude_fit`]: each sample's
    /// rows through their structure).
    pub fn from_sums(ata_upper: [[T; N]; N], atb: [T; N], btb: T, count: u32) -> Self {
        Self { ata: ata_upper, atb, btb, count }
    }

    /// `x̂ = (ΦᵀΦ)⁻¹ Φᵀz`.
    pub fn solve(&self) -> Result<[T; N], SolveError> {
        self.solve_leading(N)
    }

    /// `(ΦᵀΦ)⁻¹`, the unscaled covariance of the estimate (as
    /// [`QrRls::covariance`], to rounding: the inverse of the Jacobi-scaled
    /// matrix's Cholesky factor, column by column). `None` when a direction
    /// has no information or too few samples were added.
    pub fn covariance(&self) -> Option<[[T; N]; N]> {
        if (self.count as usize) < N {
            return None;
        }
        let (d, l) = self.scaled_cholesky()?;
        // L⁻¹ (lower triangular) by forward substitution, then
        // (ΦᵀΦ)⁻¹ = D·L⁻ᵀL⁻¹·D.
        let mut inv = [[T::ZERO; N]; N];
        for j in 0..N {
            for i in j..N {
                let mut s = if i == j { T::ONE } else { T::ZERO };
                for k in j..i {
                    s -= l[i][k] * inv[k][j];
                }
                inv[i][j] = s / l[i][i];
            }
        }
        let mut cov = [[T::ZERO; N]; N];
        for i in 0..N {
            for j in 0..N {
                let mut s = T::ZERO;
                for k in i.max(j)..N {
                    s += inv[k][i] * inv[k][j];
                }
                cov[i][j] = s * d[i] * d[j];
            }
        }
        cov.iter().flatten().all(|v| v.is_finite()).then_some(cov)
    }

    /// `|R_ii|` of the square-root form (the diagonal of ΦᵀΦ's Cholesky
    /// factor, found through the Jacobi-scaled matrix); `None` when it is
    /// not positive definite.
    fn square_root_diagonal(&self) -> Option<[T; N]> {
        let (d, l) = self.scaled_cholesky()?;
        Some(core::array::from_fn(|i| l[i][i] / d[i]))
    }

    /// The Jacobi scaling `D = diag(1/√(ΦᵀΦ)ᵢᵢ)` and the Cholesky factor of
    /// `D·ΦᵀΦ·D` (the upper triangle read); `None` when a direction has no
    /// information or the scaled matrix is not positive definite.
    fn scaled_cholesky(&self) -> Option<([T; N], [[T; N]; N])> {
        let mut d = [T::ONE; N];
        for (i, di) in d.iter_mut().enumerate() {
            let a = self.ata[i][i];
            if !(a > T::ZERO) {
                return None;
            }
            *di = T::ONE / a.sqrt();
        }
        let mut a = self.ata;
        for i in 0..N {
            for j in 0..N {
                let v = if j >= i { self.ata[i][j] } else { self.ata[j][i] };
                a[i][j] = v * d[i] * d[j];
            }
        }
        crate::linalg::cholesky(&a).ok().map(|l| (d, l))
    }

    /// The estimate of the model made of the first `k` columns only.
    pub fn solve_leading(&self, k: usize) -> Result<[T; N], SolveError> {
        let k = k.min(N);
        if (self.count as usize) < k {
            return Err(SolveError::TooFewSamples { have: self.count, need: k as u32 });
        }
        // Diagonal scaling (Jacobi preconditioning) before Cholesky, and a
        // per-parameter check that mirrors QrRls::solve. Columns past `k` are
        // replaced by the identity so they solve to zero.
        let mut d = [T::ONE; N];
        for (i, di) in d.iter_mut().enumerate().take(k) {
            let a = self.ata[i][i];
            if !(a > T::ZERO) {
                return Err(SolveError::IllConditioned { index: i as u8 });
            }
            *di = T::ONE / a.sqrt();
        }
        let mut a = self.ata;
        for i in 1..N {
            for j in 0..i {
                a[i][j] = a[j][i];
            }
        }
        let mut b = self.atb;
        for i in 0..N {
            for j in 0..N {
                if i < k && j < k {
                    a[i][j] *= d[i] * d[j];
                } else {
                    a[i][j] = if i == j { T::ONE } else { T::ZERO };
                }
            }
            b[i] = if i < k { b[i] * d[i] } else { T::ZERO };
        }
        let y = cholesky_solve(&a, &b).map_err(|i| SolveError::IllConditioned { index: i as u8 })?;
        let mut x = [T::ZERO; N];
        for i in 0..N {
            x[i] = y[i] * d[i];
        }
        Ok(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
    }

    /// The normal equations' covariance: a hand inverse, and the square-root
    /// form's on random rows.
    #[test]
    fn the_normal_equations_covariance_is_the_inverse_information() {
        // Rows (1, 0), (1, 1), (1, 2): ΦᵀΦ = [[3, 3], [3, 5]], inverse [[5, −3], [−3, 3]] / 6.
        let mut ne = NormalEquations::<f64, 2>::new();
        for t in [0.0, 1.0, 2.0] {
            ne.update(&[1.0, t], 0.0);
        }
        let cov = ne.covariance().unwrap();
        let hand = [[5.0 / 6.0, -0.5], [-0.5, 0.5]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((cov[i][j] - hand[i][j]).abs() < 1e-15, "{cov:?}");
            }
        }
        let (mut qr, mut ne) = (QrRls::<f64, 5>::new(), NormalEquations::<f64, 5>::new());
        let mut seed = 11;
        for _ in 0..200 {
            let phi = [lcg(&mut seed), 3.0 * lcg(&mut seed), lcg(&mut seed), 0.01 * lcg(&mut seed), 1.0];
            qr.update(&phi, lcg(&mut seed));
            ne.update(&phi, 0.0);
        }
        let (a, b) = (qr.covariance().unwrap(), ne.covariance().unwrap());
        for i in 0..5 {
            for j in 0..5 {
                // Measured: 2e-14 of the diagonal.
                assert!((a[i][j] - b[i][j]).abs() < 1e-12 * (a[i][i] * a[j][j]).sqrt(), "{i} {j}: {} {}", a[i][j], b[i][j]);
            }
        }
        // No information on a direction: none.
        let mut flat = NormalEquations::<f64, 2>::new();
        for _ in 0..3 {
            flat.update(&[1.0, 0.0], 1.0);
        }
        assert!(flat.covariance().is_none());
    }

    /// The normal equations read back as the square-root form: the same
    /// estimate, residual sum of squares and refusals as [`QrRls`] (an
    /// independent factorisation) on noisy random rows.
    #[test]
    fn the_normal_equations_read_back_as_the_square_root_form() {
        let (mut qr, mut ne) = (QrRls::<f64, 5>::new(), NormalEquations::<f64, 5>::new());
        let mut seed = 5;
        for _ in 0..300 {
            let phi = [lcg(&mut seed), 2.0 * lcg(&mut seed), lcg(&mut seed), 0.05 * lcg(&mut seed), 1.0];
            let y = 0.3 * phi[0] - 1.5 * phi[1] + 0.01 * lcg(&mut seed);
            qr.update(&phi, y);
            ne.update(&phi, y);
        }
        let (xq, xn) = (Information::solve_all(&qr).unwrap(), Information::solve_all(&ne).unwrap());
        for i in 0..5 {
            // Measured: 5e-15.
            assert!((xq[i] - xn[i]).abs() < 1e-13, "{i}: {} {}", xq[i], xn[i]);
        }
        let (rq, rn) = (qr.residual_sum_of_squares_at(&xq), ne.residual_sum_of_squares_at(&xn));
        // The noise's RSS is about 300 · 0.01² / 3 = 0.01 (0.0105); the two
        // agree to 3.5e-11 relative (the normal equations' cancellation).
        assert!((rq - rn).abs() < 2e-10 * rq, "{rq} {rn}");
        // A column with a millionth of the others' information left (the
        // square-root form's |R_ii| under its rank tolerance): both refuse it.
        let (mut qr, mut ne) = (QrRls::<f64, 2>::new(), NormalEquations::<f64, 2>::new());
        for t in [0.0, 1.0, 2.0, 3.0] {
            let phi = [1.0 + t, 1.0 + t + 1e-15 * t * t];
            qr.update(&phi, t);
            ne.update(&phi, t);
        }
        assert!(matches!(Information::solve_all(&qr), Err(SolveError::IllConditioned { .. })));
        assert!(matches!(Information::solve_all(&ne), Err(SolveError::IllConditioned { .. })));
    }

    #[test]
    fn exact_data_is_recovered_by_both() {
        let truth = [0.5, -1.25, 2.0, 0.125];
        let mut qr = QrRls::<f64, 4>::new();
        let mut ne = NormalEquations::<f64, 4>::new();
        let mut seed = 7;
        for _ in 0..50 {
            let phi = [lcg(&mut seed), lcg(&mut seed), lcg(&mut seed), 1.0];
            let y: f64 = phi.iter().zip(truth).map(|(a, b)| a * b).sum();
            assert!(qr.update(&phi, y));
            assert!(ne.update(&phi, y));
        }
        for (a, b) in qr.solve().unwrap().iter().zip(truth) {
            assert!((a - b).abs() < 1e-12);
        }
        for (a, b) in ne.solve().unwrap().iter().zip(truth) {
            assert!((a - b).abs() < 1e-12);
        }
        assert!(qr.residual_sum_of_squares() < 1e-20);
    }

    #[test]
    fn collinear_regressors_are_reported_not_solved() {
        let mut qr = QrRls::<f64, 3>::new();
        let mut ne = NormalEquations::<f64, 3>::new();
        let mut seed = 3;
        for _ in 0..20 {
            let a = lcg(&mut seed);
            let phi = [a, 2.0 * a, 1.0];
            qr.update(&phi, a);
            ne.update(&phi, a);
        }
        assert_eq!(qr.solve(), Err(SolveError::IllConditioned { index: 1 }));
        assert!(matches!(ne.solve(), Err(SolveError::IllConditioned { .. })));
        assert_eq!(QrRls::<f64, 3>::new().solve(), Err(SolveError::TooFewSamples { have: 0, need: 3 }));
    }

    #[test]
    fn forgetting_tracks_a_parameter_change() {
        let mut forgetting = QrRls::<f64, 2>::new();
        let mut remembering = QrRls::<f64, 2>::new();
        let mut seed = 11;
        for k in 0..400 {
            let truth = if k < 200 { [1.0, 0.0] } else { [3.0, 1.0] };
            let phi = [lcg(&mut seed), 1.0];
            let y = phi[0] * truth[0] + truth[1];
            forgetting.forget(0.95);
            forgetting.update(&phi, y);
            remembering.update(&phi, y);
        }
        // The old regime's weight is 0.95^200 ≈ 3.5e-5 of the new one's.
        let x = forgetting.solve().unwrap();
        assert!((x[0] - 3.0).abs() < 1e-3 && (x[1] - 1.0).abs() < 1e-3, "{x:?}");
        let y = remembering.solve().unwrap();
        assert!((y[0] - 3.0).abs() > 0.5, "without forgetting the old data drag the estimate: {y:?}");
    }

    #[test]
    fn non_finite_rows_are_refused() {
        let mut qr = QrRls::<f32, 2>::new();
        assert!(!qr.update(&[f32::NAN, 1.0], 1.0));
        assert!(!qr.update(&[1.0, 1.0], f32::INFINITY));
        assert_eq!(qr.count(), 0);
    }

    proptest! {
        /// The square-root form in f32 agrees with the f64 normal equations
        /// on noisy, well-posed problems, and the residual it tracks equals
        /// the residual of its solution.
        #[test]
        fn f32_qr_matches_f64_reference(seed in 0u64..1000, noise in 0.0..0.1f64) {
            let mut s = seed + 1;
            let truth = [0.3, -0.7, 1.1, 0.05, -0.2];
            let mut qr = QrRls::<f32, 5>::new();
            let mut ne = NormalEquations::<f64, 5>::new();
            let mut rows = Vec::new();
            for _ in 0..300 {
                let phi = [lcg(&mut s), lcg(&mut s), lcg(&mut s) * lcg(&mut s), lcg(&mut s), 1.0];
                let y: f64 = phi.iter().zip(truth).map(|(a, b)| a * b).sum::<f64>() + noise * lcg(&mut s);
                let phi32 = phi.map(|v| v as f32);
                qr.update(&phi32, y as f32);
                ne.update(&phi32.map(f64::from), f64::from(y as f32));
                rows.push((phi32.map(f64::from), f64::from(y as f32)));
            }
            let a = qr.solve().unwrap();
            let b = ne.solve().unwrap();
            for (x, y) in a.iter().zip(b) {
                prop_assert!((f64::from(*x) - y).abs() < 2e-5, "{a:?} vs {b:?}");
            }
            let rss: f64 = rows.iter().map(|(p, y)| (y - p.iter().zip(b).map(|(u, v)| u * v).sum::<f64>()).powi(2)).sum();
            prop_assert!((f64::from(qr.residual_sum_of_squares()) - rss).abs() <= 1e-3 * rss + 1e-6);
        }
    }
}
