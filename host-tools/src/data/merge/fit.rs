//! The two least-squares problems of the clock search: the raw field as a
//! linear function of the attitude ([`FieldFit`]), and a straight line
//! through the windows' lags ([`line_fit`]).

use super::signals::FEATURES;

/// The normal equations of `raw = C·x + b` over rows (`x` the attitude's
/// rotation entries and a 1, [`super::signals::attitude_features`]). Any
/// linear sensor in a constant field is of that form (`raw = A·Rᵀ·f + b`
/// is linear in the entries of R), so no calibration, inclination or
/// declination need be known; it fits exactly only when the clocks are
/// aligned.
#[derive(Clone)]
pub(super) struct FieldFit {
    xtx: [[f64; FEATURES]; FEATURES],
    xty: [[f64; FEATURES]; 3],
    sy: [f64; 3],
    yy: f64,
    /// Rows added.
    pub(super) n: usize,
}

impl FieldFit {
    pub(super) fn new() -> Self {
        Self { xtx: [[0.0; FEATURES]; FEATURES], xty: [[0.0; FEATURES]; 3], sy: [0.0; 3], yy: 0.0, n: 0 }
    }

    /// Adds a row: the attitude's regressors `x` and the raw field `y`.
    pub(super) fn add(&mut self, x: &[f64; FEATURES], y: [f64; 3]) {
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
        self.yy += y[0] * y[0] + y[1] * y[1] + y[2] * y[2];
        self.n += 1;
    }

    fn matrix(&self) -> [[f64; FEATURES]; FEATURES] {
        // The upper triangle, mirrored.
        let mut m: [[f64; FEATURES]; FEATURES] = std::array::from_fn(|a| std::array::from_fn(|c| self.xtx[a.min(c)][a.max(c)]));
        // A little ridge: vec(R) has only three degrees of freedom.
        let trace: f64 = (0..FEATURES).map(|a| m[a][a]).sum();
        for (a, row) in m.iter_mut().enumerate() {
            row[a] += 1e-9 * trace;
        }
        m
    }

    /// The coefficients `C` (rows: field axes) and the residual sum of
    /// squares; `None` when the normal equations cannot be solved.
    pub(super) fn solve(&self) -> Option<([[f64; FEATURES]; 3], f64)> {
        let m = self.matrix();
        let mut ssr = self.yy;
        let mut coef = [[0.0; FEATURES]; 3];
        for (k, rhs) in self.xty.iter().enumerate() {
            let beta = calib_core::linalg::cholesky_solve(&m, rhs).ok()?;
            ssr -= beta.iter().zip(rhs).map(|(b, r)| b * r).sum::<f64>();
            coef[k] = beta;
        }
        Some((coef, ssr.max(0.0)))
    }

    /// The part of the field's spread the attitude leaves unexplained,
    /// `(SSR / (n − p)) / (SST / (n − 1))` (0 perfect, about 1 when the
    /// attitude explains nothing); `None` with too few rows.
    pub(super) fn unexplained(&self) -> Option<f64> {
        if self.n < 3 * FEATURES {
            return None;
        }
        let n = self.n as f64;
        let sst = self.yy - self.sy.iter().map(|s| s * s).sum::<f64>() / n;
        let (_, ssr) = self.solve()?;
        (sst > 0.0).then(|| (ssr / (n - FEATURES as f64)) / (sst / (n - 1.0)))
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
