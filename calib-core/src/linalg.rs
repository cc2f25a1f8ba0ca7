//! Small fixed-size linear algebra: no allocation, no panics, const-generic
//! sizes. Everything the fits need and nothing more.

use crate::Real;

/// A 3×3 matrix, row major.
pub type Mat3<T> = [[T; 3]; 3];

/// The identity.
pub fn identity3<T: Real>() -> Mat3<T> {
    let (o, z) = (T::ONE, T::ZERO);
    [[o, z, z], [z, o, z], [z, z, o]]
}

/// `m · v`. Always inlined: an outlined call costs the Cortex-M4F's
/// per-sample path its argument and result copies.
#[inline(always)]
pub fn mul_mat_vec<T: Real>(m: &Mat3<T>, v: [T; 3]) -> [T; 3] {
    let row = |r: &[T; 3]| r[0] * v[0] + r[1] * v[1] + r[2] * v[2];
    [row(&m[0]), row(&m[1]), row(&m[2])]
}

/// `a · b`.
pub fn mul_mat<T: Real>(a: &Mat3<T>, b: &Mat3<T>) -> Mat3<T> {
    let mut m = [[T::ZERO; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j];
        }
    }
    m
}

/// `mᵀ`.
pub fn transpose<T: Real>(m: &Mat3<T>) -> Mat3<T> {
    [[m[0][0], m[1][0], m[2][0]], [m[0][1], m[1][1], m[2][1]], [m[0][2], m[1][2], m[2][2]]]
}

/// Determinant.
pub fn det3<T: Real>(m: &Mat3<T>) -> T {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse, or `None` when singular (|det| below `T::EPSILON` times the
/// scale of the matrix cubed) or not finite.
pub fn inverse3<T: Real>(m: &Mat3<T>) -> Option<Mat3<T>> {
    let det = det3(m);
    let scale = m.iter().flatten().fold(T::ZERO, |a, &x| a.max(x.abs()));
    if !det.is_finite() || scale == T::ZERO || det.abs() <= T::EPSILON * scale * scale * scale {
        return None;
    }
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    let adj = [
        [c(1, 1, 2, 2), -c(0, 1, 2, 2), c(0, 1, 1, 2)],
        [-c(1, 0, 2, 2), c(0, 0, 2, 2), -c(0, 0, 1, 2)],
        [c(1, 0, 2, 1), -c(0, 0, 2, 1), c(0, 0, 1, 1)],
    ];
    let mut inv = adj;
    for x in inv.iter_mut().flatten() {
        *x /= det;
    }
    Some(inv)
}

/// Solves `A x = b` for symmetric positive-definite `A` by Cholesky
/// factorisation. `Err(i)` when pivot `i` shows `A` is not (numerically)
/// positive definite.
pub fn cholesky_solve<T: Real, const N: usize>(a: &[[T; N]; N], b: &[T; N]) -> Result<[T; N], usize> {
    let l = cholesky(a)?;
    // L y = b
    let mut y = [T::ZERO; N];
    for i in 0..N {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i][k] * y[k];
        }
        y[i] = s / l[i][i];
    }
    // Lᵀ x = y
    let mut x = [T::ZERO; N];
    for i in (0..N).rev() {
        let mut s = y[i];
        for k in i + 1..N {
            s -= l[k][i] * x[k];
        }
        x[i] = s / l[i][i];
    }
    match x.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(i),
        None => Ok(x),
    }
}

/// Lower-triangular Cholesky factor `L` with `A = L Lᵀ`, or `Err(i)` when
/// pivot `i` is not above `N·ε·max|A_ii|` (not positive definite).
pub fn cholesky<T: Real, const N: usize>(a: &[[T; N]; N]) -> Result<[[T; N]; N], usize> {
    let max_diag = (0..N).fold(T::ZERO, |m, i| m.max(a[i][i].abs()));
    let tol = T::from_f64(N as f64) * T::EPSILON * max_diag;
    let mut l = [[T::ZERO; N]; N];
    for i in 0..N {
        for j in 0..=i {
            let mut s = a[i][j];
            for k in 0..j {
                s -= l[i][k] * l[j][k];
            }
            if i == j {
                if !(s > tol) {
                    return Err(i);
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    Ok(l)
}

/// Eigen-decomposition of a symmetric matrix by cyclic Jacobi rotations.
/// Returns the eigenvalues in ascending order and the eigenvectors as the
/// matching columns of the second matrix. `None` if the input is not finite.
pub fn symmetric_eigen<T: Real, const N: usize>(a: &[[T; N]; N]) -> Option<([T; N], [[T; N]; N])> {
    if !a.iter().flatten().all(|x| x.is_finite()) {
        return None;
    }
    let mut m = *a;
    let mut v = [[T::ZERO; N]; N];
    for (i, row) in v.iter_mut().enumerate() {
        row[i] = T::ONE;
    }
    for _sweep in 0..64 {
        let off: T = (0..N).flat_map(|p| (p + 1..N).map(move |q| (p, q))).fold(T::ZERO, |s, (p, q)| s + m[p][q] * m[p][q]);
        let scale: T = (0..N).fold(T::ZERO, |s, i| s + m[i][i] * m[i][i]);
        if off <= T::EPSILON * T::EPSILON * scale || off == T::ZERO {
            break;
        }
        for p in 0..N {
            for q in p + 1..N {
                if m[p][q] == T::ZERO {
                    continue;
                }
                // Rotation that zeroes m[p][q].
                let theta = (m[q][q] - m[p][p]) / (T::from_f64(2.0) * m[p][q]);
                let sign = if theta >= T::ZERO { T::ONE } else { -T::ONE };
                let t = sign / (theta.abs() + (theta * theta + T::ONE).sqrt());
                let c = T::ONE / (t * t + T::ONE).sqrt();
                let s = t * c;
                for k in 0..N {
                    let (mkp, mkq) = (m[k][p], m[k][q]);
                    m[k][p] = c * mkp - s * mkq;
                    m[k][q] = s * mkp + c * mkq;
                }
                for k in 0..N {
                    let (mpk, mqk) = (m[p][k], m[q][k]);
                    m[p][k] = c * mpk - s * mqk;
                    m[q][k] = s * mpk + c * mqk;
                }
                for row in v.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    // Sort ascending (selection sort on indices; N is tiny).
    let mut values = [T::ZERO; N];
    for (i, val) in values.iter_mut().enumerate() {
        *val = m[i][i];
    }
    let mut vectors = v;
    for i in 0..N {
        let mut k = i;
        for j in i + 1..N {
            if values[j] < values[k] {
                k = j;
            }
        }
        if k != i {
            values.swap(i, k);
            for row in vectors.iter_mut() {
                row.swap(i, k);
            }
        }
    }
    Some((values, vectors))
}

/// Symmetric positive-definite square root `S` with `S·S = A`, or `None`
/// when `A` has an eigenvalue that is not positive.
pub fn spd_sqrt3<T: Real>(a: &Mat3<T>) -> Option<Mat3<T>> {
    let (vals, vecs) = symmetric_eigen(a)?;
    if !(vals[0] > T::ZERO) {
        return None;
    }
    let roots = [vals[0].sqrt(), vals[1].sqrt(), vals[2].sqrt()];
    let mut s = [[T::ZERO; 3]; 3];
    for (i, row) in s.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).fold(T::ZERO, |acc, k| acc + vecs[i][k] * roots[k] * vecs[j][k]);
        }
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn inverse_times_matrix_is_identity() {
        let m = [[2.0, 0.3, -0.1], [0.1, 1.5, 0.2], [-0.4, 0.05, 0.9]];
        let inv = inverse3(&m).unwrap();
        let p = mul_mat(&m, &inv);
        for i in 0..3 {
            for j in 0..3 {
                assert!((p[i][j] - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        assert!(inverse3(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 1.0, 1.0]]).is_none());
    }

    #[test]
    fn cholesky_solves_and_refuses_indefinite() {
        let a = [[4.0, 2.0, 0.4], [2.0, 3.0, 0.5], [0.4, 0.5, 2.0]];
        let x = cholesky_solve(&a, &[1.0, 2.0, 3.0]).unwrap();
        for i in 0..3 {
            let r: f64 = (0..3).map(|k| a[i][k] * x[k]).sum();
            assert!((r - [1.0, 2.0, 3.0][i]).abs() < 1e-14);
        }
        assert_eq!(cholesky(&[[1.0, 2.0], [2.0, 1.0]]), Err(1));
    }

    #[test]
    fn jacobi_recovers_a_known_spectrum() {
        // A = Q diag(1, 4, 9) Qᵀ with Q a rotation about z by 30° then x by 20°.
        let (s, c) = (0.5f64, 0.75f64.sqrt());
        let rz = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let (s2, c2) = (20f64.to_radians().sin(), 20f64.to_radians().cos());
        let rx = [[1.0, 0.0, 0.0], [0.0, c2, -s2], [0.0, s2, c2]];
        let q = mul_mat(&rx, &rz);
        let d = [[1.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 9.0]];
        let a = mul_mat(&mul_mat(&q, &d), &transpose(&q));
        let (vals, _) = symmetric_eigen(&a).unwrap();
        for (v, want) in vals.iter().zip([1.0, 4.0, 9.0]) {
            assert!((v - want).abs() < 1e-12, "{vals:?}");
        }
        let r = spd_sqrt3(&a).unwrap();
        let rr = mul_mat(&r, &r);
        for i in 0..3 {
            for j in 0..3 {
                assert!((rr[i][j] - a[i][j]).abs() < 1e-12);
            }
        }
    }
}
