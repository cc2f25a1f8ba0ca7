//! Propagating a fit's parameter covariance to a derived quantity (a
//! heading): first order, `σ² = gᵀ C g` with `g` the numerical gradient of
//! the quantity with respect to the parameters. The gyro-aided fit and the
//! joint back-stepping refinement both predict their heading error with it.

use crate::Real;

/// The 1σ of `f(x)` when `x` has covariance `cov` (already scaled by the
/// residual variance): `√(gᵀ C g)`, with `g` by forward differences of step
/// `1e-4·(|xᵢ| + 0.1)`. `f` returns an angle: differences are wrapped to
/// (−π, π]. Parameters whose covariance row is zero (held fixed) are
/// skipped.
pub fn angle_sigma<T: Real, const N: usize>(x: &[T; N], cov: &[[T; N]; N], f: impl Fn(&[T; N]) -> T) -> T {
    let base = f(x);
    let mut grad = [T::ZERO; N];
    for (i, g) in grad.iter_mut().enumerate() {
        if cov[i][i] == T::ZERO {
            continue;
        }
        let eps = T::from_f64(1e-4) * (x[i].abs() + T::from_f64(0.1));
        let mut xp = *x;
        xp[i] += eps;
        *g = crate::heading::wrap_pi(f(&xp) - base) / eps;
    }
    let mut var = T::ZERO;
    for i in 0..N {
        if grad[i] == T::ZERO {
            continue;
        }
        for j in 0..N {
            var += grad[i] * cov[i][j] * grad[j];
        }
    }
    var.max(T::ZERO).sqrt()
}

/// The inverse of a symmetric positive-definite matrix, by Jacobi scaling
/// and one Cholesky solve per column; `None` when it is not positive
/// definite.
pub fn spd_inverse<T: Real, const N: usize>(a: &[[T; N]; N]) -> Option<[[T; N]; N]> {
    let mut scale = [T::ONE; N];
    for (k, s) in scale.iter_mut().enumerate() {
        if !(a[k][k] > T::ZERO) {
            return None;
        }
        *s = T::ONE / a[k][k].sqrt();
    }
    let mut scaled = *a;
    for i in 0..N {
        for j in 0..N {
            scaled[i][j] *= scale[i] * scale[j];
        }
    }
    let mut inv = [[T::ZERO; N]; N];
    for j in 0..N {
        let mut e = [T::ZERO; N];
        e[j] = T::ONE;
        let col = crate::linalg::cholesky_solve(&scaled, &e).ok()?;
        for i in 0..N {
            inv[i][j] = col[i] * scale[i] * scale[j];
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sigma_of_an_angle_follows_the_linearised_covariance() {
        // atan2(y, x) at (1, 1): gradient (−½, ½); with var(x) = 4e-4,
        // var(y) = 1e-4 and cov 1e-4: σ² = ¼(4 + 1 − 2)e-4 = 0.75e-4.
        let x = [1.0, 1.0];
        let cov = [[4e-4, 1e-4], [1e-4, 1e-4]];
        let s = angle_sigma(&x, &cov, |p| p[1].atan2(p[0]));
        assert!((s - 0.75e-4f64.sqrt()).abs() < 1e-5, "{s}");
    }

    #[test]
    fn the_inverse_of_a_badly_scaled_spd_matrix() {
        let a = [[4e6, 2e2, 0.0], [2e2, 3.0, 0.01], [0.0, 0.01, 2e-4]];
        let inv = spd_inverse(&a).unwrap();
        for i in 0..3 {
            for j in 0..3 {
                let v: f64 = (0..3).map(|k| a[i][k] * inv[k][j]).sum();
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-9, "{i}{j}: {v}");
            }
        }
        assert!(spd_inverse(&[[1.0, 2.0], [2.0, 1.0]]).is_none());
    }
}
