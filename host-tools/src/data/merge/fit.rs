//! The least-squares problems of the clock search: the raw field as a
//! linear function of the attitude ([`FieldFit`]), the field's tilt against
//! the navigation's ([`TiltFit`]), and a straight line through the windows'
//! lags ([`line_fit`]).

use super::signals::{FEATURES, TILT_FEATURES};

/// The normal equations of `y = C·x` over rows, `P` regressors and `K`
/// outputs, with a little ridge.
#[derive(Clone)]
pub(super) struct LinFit<const P: usize, const K: usize> {
    xtx: [[f64; P]; P],
    xty: [[f64; P]; K],
    sy: [f64; K],
    yy: f64,
    /// Rows added.
    pub(super) n: usize,
}

/// The normal equations of `raw = C·x + b` over rows (`x` the attitude's
/// rotation entries and a 1, [`super::signals::attitude_features`]). Any
/// linear sensor in a constant field is of that form (`raw = A·Rᵀ·f + b`
/// is linear in the entries of R), so no calibration, inclination or
/// declination need be known; it fits exactly only when the clocks are
/// aligned.
pub(super) type FieldFit = LinFit<FEATURES, 3>;

/// The normal equations of `1 = β·z` over rows, `z` the products of the
/// navigation's down direction in the body `g` with the (normalised) raw
/// field `y`, and `g` itself ([`super::signals::tilt_features`]). The field
/// `h = M·y + c` of any linear sensor has a constant component along the
/// down direction (the field's vertical, `g·h = f_D`), and
/// `g·(M·y + c) = Σ M_ij g_i y_j + Σ c_i g_i` is linear in `z`: the heading
/// need not be known, nor the calibration; it fits exactly only when the
/// clocks are aligned and the vehicle tilts (`f_D` scaled to 1).
pub(super) type TiltFit = LinFit<TILT_FEATURES, 1>;

impl<const P: usize, const K: usize> LinFit<P, K> {
    pub(super) fn new() -> Self {
        Self { xtx: [[0.0; P]; P], xty: [[0.0; P]; K], sy: [0.0; K], yy: 0.0, n: 0 }
    }

    /// Adds a row: the regressors `x` and the outputs `y`.
    pub(super) fn add(&mut self, x: &[f64; P], y: [f64; K]) {
        for (a, row) in self.xtx.iter_mut().enumerate() {
            for (c, v) in row.iter_mut().enumerate().skip(a) {
                *v += x[a] * x[c];
            }
        }
        for ((rhs, s), yk) in self.xty.iter_mut().zip(&mut self.sy).zip(y) {
            for (r, xa) in rhs.iter_mut().zip(x) {
                *r += xa * yk;
            }
            *s += yk;
        }
        self.yy += y.iter().map(|v| v * v).sum::<f64>();
        self.n += 1;
    }

    fn matrix(&self) -> [[f64; P]; P] {
        // The upper triangle, mirrored.
        let mut m: [[f64; P]; P] = std::array::from_fn(|a| std::array::from_fn(|c| self.xtx[a.min(c)][a.max(c)]));
        // A little ridge: vec(R) has only three degrees of freedom.
        let trace: f64 = (0..P).map(|a| m[a][a]).sum();
        for (a, row) in m.iter_mut().enumerate() {
            row[a] += 1e-9 * trace;
        }
        m
    }

    /// The coefficients `C` (rows: outputs) and the residual sum of
    /// squares; `None` when the normal equations cannot be solved.
    pub(super) fn solve(&self) -> Option<([[f64; P]; K], f64)> {
        let m = self.matrix();
        let mut ssr = self.yy;
        let mut coef = [[0.0; P]; K];
        for (k, rhs) in self.xty.iter().enumerate() {
            let beta = calib_core::linalg::cholesky_solve(&m, rhs).ok()?;
            ssr -= beta.iter().zip(rhs).map(|(b, r)| b * r).sum::<f64>();
            coef[k] = beta;
        }
        Some((coef, ssr.max(0.0)))
    }

    /// The residuals' mean square per output and degree of freedom,
    /// `SSR / (K·(n − P))`; `None` with too few rows (fewer than 3·P).
    pub(super) fn mean_square_residual(&self) -> Option<f64> {
        if self.n < 3 * P {
            return None;
        }
        let (_, ssr) = self.solve()?;
        Some(ssr / (K * (self.n - P)) as f64)
    }

    /// The part of the outputs' spread the regressors leave unexplained,
    /// `(SSR / (n − p)) / (SST / (n − 1))` (0 perfect, about 1 when they
    /// explain nothing); `None` with too few rows or outputs that do not
    /// vary.
    pub(super) fn unexplained(&self) -> Option<f64> {
        if self.n < 3 * P {
            return None;
        }
        let n = self.n as f64;
        let sst = self.yy - self.sy.iter().map(|s| s * s).sum::<f64>() / n;
        let (_, ssr) = self.solve()?;
        (sst > 0.0).then(|| (ssr / (n - P as f64)) / (sst / (n - 1.0)))
    }
}

/// The instrumental-variables equations of `1 = β·z` over rows:
/// `Σ w·zᵀ β = Σ w`, the instruments `w` correlated with the regressors'
/// signal but not with their noise. Least squares on noisy regressors
/// shrinks the coefficients the noise multiplies (errors in variables):
/// the tilt model's regressors carry the AHRS's roll and pitch noise, of
/// the size of a calm vehicle's tilt changes, and least squares then
/// mistakes how the field answers a tilt — by several times in the
/// directions a calm run barely tilts, enough to shift the windows' lags
/// by tens of ms, more on one leg than on the other. With the tilt of the
/// neighbouring navigation rows as instruments (white noise: independent
/// of this row's), the equations are unbiased.
pub(super) struct InstrumentFit<const P: usize> {
    wtz: [[f64; P]; P],
    wt1: [f64; P],
    /// Rows added.
    pub(super) n: usize,
}

impl<const P: usize> InstrumentFit<P> {
    pub(super) fn new() -> Self {
        Self { wtz: [[0.0; P]; P], wt1: [0.0; P], n: 0 }
    }

    /// Adds a row: the instruments `w` and the regressors `z` (target 1).
    pub(super) fn add(&mut self, w: &[f64; P], z: &[f64; P]) {
        for (row, wa) in self.wtz.iter_mut().zip(w) {
            for (v, zc) in row.iter_mut().zip(z) {
                *v += wa * zc;
            }
        }
        for (r, wa) in self.wt1.iter_mut().zip(w) {
            *r += wa;
        }
        self.n += 1;
    }

    /// The coefficients; `None` with fewer than 3·P rows or equations
    /// that cannot be solved.
    pub(super) fn solve(&self) -> Option<[f64; P]> {
        if self.n < 3 * P {
            return None;
        }
        let a = nalgebra::DMatrix::from_fn(P, P, |r, c| self.wtz[r][c]);
        let b = nalgebra::DVector::from_column_slice(&self.wt1);
        let x = a.lu().solve(&b)?;
        let beta: [f64; P] = std::array::from_fn(|k| x[k]);
        beta.iter().all(|v| v.is_finite()).then_some(beta)
    }
}

/// The field a fitted model predicts from the regressors.
pub(super) fn predict(coef: &[[f64; FEATURES]; 3], x: &[f64; FEATURES]) -> [f64; 3] {
    coef.map(|c| c.iter().zip(x).map(|(a, b)| a * b).sum())
}

/// A straight line through the windows' lags.
#[derive(Debug, Clone, Copy)]
pub(super) struct LineFit {
    /// The line at `t_ref`, s.
    pub(super) offset_s: f64,
    /// Its slope (s/s).
    pub(super) slope: f64,
    /// 1σ of `offset_s`, s.
    pub(super) offset_sigma_s: f64,
    /// 1σ of `slope`.
    pub(super) slope_sigma: f64,
    /// The slope was fitted (three windows or more).
    pub(super) slope_fitted: bool,
    /// χ² per degree of freedom of the windows about the line (their
    /// scatter against their own σ; the σ above are scaled up by it when
    /// it exceeds 1).
    pub(super) chi2_dof: f64,
    t_ref: f64,
}

impl LineFit {
    /// The line at `t`.
    pub(super) fn at(&self, t: f64) -> f64 {
        self.offset_s + self.slope * (t - self.t_ref)
    }
}

/// Weighted least squares `lag = offset + slope·(t − t_ref)` through
/// `(t, lag, σ)` points. The σ are scaled by √(χ²/dof) when the points
/// scatter more than their own σ say (Birge ratio): the windows' σ assume
/// white residuals, their scatter does not. With fewer than three points
/// the slope is 0 and the offset the weighted mean.
pub(super) fn line_fit(points: &[(f64, f64, f64)], t_ref: f64) -> LineFit {
    let w: Vec<f64> = points.iter().map(|p| 1.0 / (p.2 * p.2)).collect();
    let sw: f64 = w.iter().sum();
    let tm = points.iter().zip(&w).map(|(p, w)| w * p.0).sum::<f64>() / sw;
    let lm = points.iter().zip(&w).map(|(p, w)| w * p.1).sum::<f64>() / sw;
    let n = points.len();
    if n < 3 {
        let chi2: f64 = points.iter().zip(&w).map(|(p, w)| w * (p.1 - lm).powi(2)).sum();
        let scale = if n == 2 { chi2.max(1.0) } else { 1.0 };
        let sigma = (scale / sw).sqrt();
        return LineFit { offset_s: lm, slope: 0.0, offset_sigma_s: sigma, slope_sigma: 0.0, slope_fitted: false, chi2_dof: if n == 2 { chi2 } else { f64::NAN }, t_ref };
    }
    let sxx: f64 = points.iter().zip(&w).map(|(p, w)| w * (p.0 - tm).powi(2)).sum();
    let sxy: f64 = points.iter().zip(&w).map(|(p, w)| w * (p.0 - tm) * (p.1 - lm)).sum();
    let slope = sxy / sxx;
    let chi2: f64 = points.iter().zip(&w).map(|(p, w)| w * (p.1 - lm - slope * (p.0 - tm)).powi(2)).sum();
    let chi2_dof = chi2 / (n - 2) as f64;
    let scale = chi2_dof.max(1.0);
    LineFit {
        offset_s: lm + slope * (t_ref - tm),
        slope,
        offset_sigma_s: (scale * (1.0 / sw + (t_ref - tm).powi(2) / sxx)).sqrt(),
        slope_sigma: (scale / sxx).sqrt(),
        slope_fitted: true,
        chi2_dof,
        t_ref,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line through exact points comes back exactly; σ from the points'
    /// own σ (χ² = 0 is not scaled down); scatter beyond their σ scales it up.
    #[test]
    fn the_line_and_its_sigma() {
        let pts: Vec<(f64, f64, f64)> = (0..10).map(|i| (100.0 * i as f64, 2.0 + 1e-4 * 100.0 * i as f64, 0.01)).collect();
        let f = line_fit(&pts, 0.0);
        assert!((f.offset_s - 2.0).abs() < 1e-12 && (f.slope - 1e-4).abs() < 1e-15);
        // σ of the intercept of 10 equally weighted points at 0…900 s,
        // σ 10 ms each: √(1/10 + 450²/825 000) · 10 ms = 5.9 ms.
        assert!((f.offset_sigma_s - 0.01 * (0.1f64 + 450.0 * 450.0 / 825_000.0).sqrt()).abs() < 1e-9, "{f:?}");
        let noisy: Vec<(f64, f64, f64)> = pts.iter().enumerate().map(|(i, p)| (p.0, p.1 + if i % 2 == 0 { 0.05 } else { -0.05 }, p.2)).collect();
        assert!(line_fit(&noisy, 0.0).offset_sigma_s > 4.0 * f.offset_sigma_s);
    }
}
