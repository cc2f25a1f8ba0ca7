//! Field (ellipsoid) calibration fits: ALGORITHMS.md §2 (paper 000, eqs 9–18).
//!
//! Three models, each a linear regression on the (normalised) raw field:
//!
//! | model | unknowns | regression |
//! |---|---|---|
//! | [`Sphere`] | 4 | `|h|² = 2b·h + (r² − |b|²)` |
//! | [`Axis`] (the paper's) | 6 | eqs 12–16: `hx² = −x1 hy² − x2 hz² + 2x3 hx + 2x4 hy + 2x5 hz + x6`, extraction eq 17 |
//! | [`Full`] | 9 | general quadric with trace(A) fixed: `|h|² = u1(x²+y²−2z²) + u2(x²−2y²+z²) + 2u3 xy + 2u4 xz + 2u5 yz + 2u6 x + 2u7 y + 2u8 z + u9` |
//!
//! Each runs as a batch solve ([`fit_batch`], normal equations in the
//! caller's precision — use `f64` as the reference) or sample by sample
//! ([`RecursiveFit`], square-root RLS that stays accurate in `f32`). Before
//! regression the raw field is centred and scaled ([`Normalization`]) so the
//! regressors are O(1) whatever the sensor's units; the coefficients are
//! mapped back to raw units on extraction.
//!
//! The fit is a pure function of the data; quality metrics and the gates that
//! refuse a weak calibration live in [`crate::quality`].

use crate::cal::{FieldCal, ModelKind};
use crate::heading::Vec3;
use crate::linalg::{inverse3, mul_mat_vec, spd_sqrt3, Mat3};
use crate::lsq::{NormalEquations, QrRls, SolveError};
use crate::Real;

/// Why a fit produced no coefficients.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FitError {
    /// Not enough samples for the model.
    TooFewSamples {
        /// Samples given.
        have: u32,
        /// Samples needed.
        need: u32,
    },
    /// Sample `index` has a NaN or infinite component.
    NonFinite {
        /// Index of the sample.
        index: u32,
    },
    /// Sample `index` is at or beyond the sensor's saturation level.
    Saturated {
        /// Index of the sample.
        index: u32,
    },
    /// The reference field intensity is not a positive finite number.
    BadReference,
    /// The data do not determine parameter `parameter` of the regression: the
    /// vehicle was not turned through enough attitudes (e.g. rotation about
    /// one axis only).
    InsufficientExcitation {
        /// Index of the undetermined regression parameter.
        parameter: u8,
    },
    /// The solution has a non-positive squared scale on `axis` (0 = x): the
    /// "complex parameters" of paper 000 Table 2, case 1. Data not rich enough.
    ImpossibleScale {
        /// Axis whose squared scale came out ≤ 0.
        axis: u8,
    },
    /// The fitted quadric is not an ellipsoid (not positive definite).
    NotAnEllipsoid,
    /// Too small a part of the sphere of field directions was visited.
    InsufficientCoverage {
        /// Percent of the direction bins that were visited.
        covered_pct: u8,
    },
    /// The calibrated magnitudes scatter too much about the reference.
    ResidualTooLarge {
        /// RMS residual in per mille of the reference field.
        rms_per_mille: u16,
    },
}

impl From<SolveError> for FitError {
    fn from(e: SolveError) -> Self {
        match e {
            SolveError::TooFewSamples { have, need } => FitError::TooFewSamples { have, need },
            SolveError::IllConditioned { index } => FitError::InsufficientExcitation { parameter: index },
        }
    }
}

impl core::fmt::Display for FitError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FitError::TooFewSamples { have, need } => write!(f, "too few samples: {have}, the model needs at least {need}"),
            FitError::NonFinite { index } => write!(f, "sample {index} is NaN or infinite"),
            FitError::Saturated { index } => write!(f, "sample {index} is saturated"),
            FitError::BadReference => f.write_str("the reference field intensity must be a positive number of nT"),
            FitError::InsufficientExcitation { parameter } => write!(
                f,
                "insufficient excitation: the attitudes recorded do not determine regression parameter {parameter}; turn the vehicle through more headings, rolls and pitches"
            ),
            FitError::ImpossibleScale { axis } => write!(
                f,
                "impossible (negative) squared scale on the {} axis: the data are not rich enough for this model (paper 000, Table 2)",
                ["x", "y", "z"].get(usize::from(*axis)).unwrap_or(&"?")
            ),
            FitError::NotAnEllipsoid => f.write_str("the fitted surface is not an ellipsoid: the data do not constrain a full calibration"),
            FitError::InsufficientCoverage { covered_pct } => write!(
                f,
                "only {covered_pct}% of field directions were visited: too little of the sphere for this model (a vehicle that cannot tumble: the attitude-aided model needs only roll and pitch, the gyro-aided model the gyro)"
            ),
            FitError::ResidualTooLarge { rms_per_mille } => write!(
                f,
                "calibrated magnitudes scatter by {:.1}% RMS about the reference: the data do not fit the model",
                f64::from(*rms_per_mille) / 10.0
            ),
        }
    }
}

/// Affine map applied to raw samples before regression: `(raw − centre)/scale`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Normalization<T> {
    /// Subtracted first (raw units).
    pub centre: Vec3<T>,
    /// Then divided by (raw units, > 0).
    pub scale: T,
}

impl<T: Real> Normalization<T> {
    /// Normalises one sample.
    pub fn apply(&self, raw: Vec3<T>) -> Vec3<T> {
        [(raw[0] - self.centre[0]) / self.scale, (raw[1] - self.centre[1]) / self.scale, (raw[2] - self.centre[2]) / self.scale]
    }

    /// Centre at the mean of the samples, scale by their RMS distance from
    /// it. `None` for empty, non-finite or all-equal input.
    pub fn from_samples(samples: &[Vec3<T>]) -> Option<Self> {
        Self::from_raw_iter(samples.iter().copied())
    }

    /// As [`Self::from_samples`] over any re-iterable source (walked twice).
    pub fn from_raw_iter<I: Iterator<Item = Vec3<T>> + Clone>(samples: I) -> Option<Self> {
        let n = T::from_f64(samples.clone().count() as f64);
        let mut mean = [T::ZERO; 3];
        for s in samples.clone() {
            for k in 0..3 {
                mean[k] += s[k];
            }
        }
        for m in mean.iter_mut() {
            *m /= n;
        }
        let mut ss = T::ZERO;
        for s in samples {
            for k in 0..3 {
                let d = s[k] - mean[k];
                ss += d * d;
            }
        }
        let scale = (ss / n).sqrt();
        (scale > T::ZERO && scale.is_finite() && mean.iter().all(|m| m.is_finite())).then_some(Self { centre: mean, scale })
    }
}

/// A regression model of the field calibration with `N` unknowns.
pub trait Model<const N: usize> {
    /// Which model this is.
    const KIND: ModelKind;
    /// Regressors and target for one normalised sample.
    fn row<T: Real>(h: Vec3<T>) -> ([T; N], T);
    /// Coefficients (normalised units) from the regression solution.
    fn extract<T: Real>(x: &[T; N], field_nt: T) -> Result<FieldCal<T>, FitError>;
}

/// Bias and a single scale.
#[derive(Debug, Clone, Copy)]
pub struct Sphere;
/// Paper 000's axis-aligned ellipsoid (eqs 12–17).
#[derive(Debug, Clone, Copy)]
pub struct Axis;
/// Full ellipsoid: bias and a symmetric matrix.
#[derive(Debug, Clone, Copy)]
pub struct Full;

fn two<T: Real>() -> T {
    T::from_f64(2.0)
}

impl Model<4> for Sphere {
    const KIND: ModelKind = ModelKind::Sphere;
    fn row<T: Real>(h: Vec3<T>) -> ([T; 4], T) {
        let [x, y, z] = h;
        ([two::<T>() * x, two::<T>() * y, two::<T>() * z, T::ONE], x * x + y * y + z * z)
    }
    fn extract<T: Real>(x: &[T; 4], field_nt: T) -> Result<FieldCal<T>, FitError> {
        let b = [x[0], x[1], x[2]];
        let r2 = x[3] + b[0] * b[0] + b[1] * b[1] + b[2] * b[2];
        if !(r2 > T::ZERO) {
            return Err(FitError::ImpossibleScale { axis: 0 });
        }
        let g = field_nt / r2.sqrt();
        let z = T::ZERO;
        Ok(FieldCal { bias: b, matrix: [[g, z, z], [z, g, z], [z, z, g]] })
    }
}

impl Model<6> for Axis {
    const KIND: ModelKind = ModelKind::Axis;
    fn row<T: Real>(h: Vec3<T>) -> ([T; 6], T) {
        // Eq 13: z = Ĥx², φ = [−Ĥy², −Ĥz², 2Ĥx, 2Ĥy, 2Ĥz, 1].
        let [x, y, z] = h;
        ([-(y * y), -(z * z), two::<T>() * x, two::<T>() * y, two::<T>() * z, T::ONE], x * x)
    }
    fn extract<T: Real>(x: &[T; 6], field_nt: T) -> Result<FieldCal<T>, FitError> {
        let s = axis_scales(x, field_nt)?;
        let zr = T::ZERO;
        Ok(FieldCal {
            bias: s.bias,
            matrix: [[T::ONE / s.scale[0], zr, zr], [zr, T::ONE / s.scale[1], zr], [zr, zr, T::ONE / s.scale[2]]],
        })
    }
}

/// Bias and scale factors of the paper's axis model (eq 17), with
/// `H = (Ĥ − b)/s` per axis (eq 18).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AxisScales<T> {
    /// `bx, by, bz`.
    pub bias: Vec3<T>,
    /// `sx, sy, sz` (raw units per nT when the samples are raw).
    pub scale: Vec3<T>,
}

/// Eq 17: `bx = x3, by = x4/x1, bz = x5/x2`,
/// `sx² = (x6 + bx² + x1 by² + x2 bz²)/H²`, `sy² = sx²/x1`, `sz² = sx²/x2`.
pub fn axis_scales<T: Real>(x: &[T; 6], field_nt: T) -> Result<AxisScales<T>, FitError> {
    if !(x[0] > T::ZERO) {
        return Err(FitError::ImpossibleScale { axis: 1 });
    }
    if !(x[1] > T::ZERO) {
        return Err(FitError::ImpossibleScale { axis: 2 });
    }
    let bias = [x[2], x[3] / x[0], x[4] / x[1]];
    let sx2 = (x[5] + bias[0] * bias[0] + x[0] * bias[1] * bias[1] + x[1] * bias[2] * bias[2]) / (field_nt * field_nt);
    if !(sx2 > T::ZERO) {
        return Err(FitError::ImpossibleScale { axis: 0 });
    }
    let (sy2, sz2) = (sx2 / x[0], sx2 / x[1]);
    Ok(AxisScales { bias, scale: [sx2.sqrt(), sy2.sqrt(), sz2.sqrt()] })
}

impl Model<9> for Full {
    const KIND: ModelKind = ModelKind::Full;
    fn row<T: Real>(h: Vec3<T>) -> ([T; 9], T) {
        let [x, y, z] = h;
        let (xx, yy, zz) = (x * x, y * y, z * z);
        let t = two::<T>();
        ([xx + yy - t * zz, xx - t * yy + zz, t * x * y, t * x * z, t * y * z, t * x, t * y, t * z, T::ONE], xx + yy + zz)
    }
    fn extract<T: Real>(u: &[T; 9], field_nt: T) -> Result<FieldCal<T>, FitError> {
        let t = two::<T>();
        // hᵀAh + 2gᵀh + c = 0 with trace(A) = 3.
        let a: Mat3<T> = [
            [T::ONE - u[0] - u[1], -u[2], -u[3]],
            [-u[2], T::ONE - u[0] + t * u[1], -u[4]],
            [-u[3], -u[4], T::ONE + t * u[0] - u[1]],
        ];
        let g = [-u[5], -u[6], -u[7]];
        let c = -u[8];
        let inv = inverse3(&a).ok_or(FitError::NotAnEllipsoid)?;
        let centre = mul_mat_vec(&inv, g).map(|v| -v);
        let ac = mul_mat_vec(&a, centre);
        let k = centre[0] * ac[0] + centre[1] * ac[1] + centre[2] * ac[2] - c;
        if !(k > T::ZERO) {
            return Err(FitError::NotAnEllipsoid);
        }
        // (h − b)ᵀ A (h − b) = k  ⇒  |M(h − b)| = F with MᵀM = A·F²/k.
        let f2k = field_nt * field_nt / k;
        let mut q = a;
        for v in q.iter_mut().flatten() {
            *v *= f2k;
        }
        let m = spd_sqrt3(&q).ok_or(FitError::NotAnEllipsoid)?;
        Ok(FieldCal { bias: centre, matrix: m })
    }
}

/// Maps coefficients found on normalised samples back to raw units.
pub fn denormalize<T: Real>(cal: &FieldCal<T>, norm: &Normalization<T>) -> FieldCal<T> {
    let mut matrix = cal.matrix;
    for v in matrix.iter_mut().flatten() {
        *v /= norm.scale;
    }
    let bias = [
        norm.centre[0] + norm.scale * cal.bias[0],
        norm.centre[1] + norm.scale * cal.bias[1],
        norm.centre[2] + norm.scale * cal.bias[2],
    ];
    FieldCal { bias, matrix }
}

/// Checks the input of a fit: finite, not saturated, enough of it.
pub fn check_samples<T: Real>(samples: &[Vec3<T>], need: usize, saturation_abs: Option<T>) -> Result<(), FitError> {
    for (i, s) in samples.iter().enumerate() {
        let index = u32::try_from(i).unwrap_or(u32::MAX);
        if !s.iter().all(|v| v.is_finite()) {
            return Err(FitError::NonFinite { index });
        }
        if let Some(limit) = saturation_abs {
            if s.iter().any(|v| v.abs() >= limit) {
                return Err(FitError::Saturated { index });
            }
        }
    }
    if samples.len() < need {
        return Err(FitError::TooFewSamples { have: u32::try_from(samples.len()).unwrap_or(u32::MAX), need: need as u32 });
    }
    Ok(())
}

/// Batch fit (the reference): normal equations over all samples, in the
/// precision `T` (use `f64`). `field_nt` is the reference intensity (IGRF).
pub fn fit_batch<M: Model<N>, const N: usize, T: Real>(samples: &[Vec3<T>], field_nt: T) -> Result<FieldCal<T>, FitError> {
    if !(field_nt > T::ZERO && field_nt.is_finite()) {
        return Err(FitError::BadReference);
    }
    check_samples(samples, N, None)?;
    let norm = Normalization::from_samples(samples).ok_or(FitError::InsufficientExcitation { parameter: 0 })?;
    let mut ne = NormalEquations::<T, N>::new();
    for s in samples {
        let (phi, y) = M::row(norm.apply(*s));
        ne.update(&phi, y);
    }
    let x = ne.solve()?;
    Ok(denormalize(&M::extract(&x, field_nt)?, &norm))
}

/// A field fit that absorbs one sample at a time (square-root RLS). Runs on
/// the MCU in `f32`.
#[derive(Debug, Clone)]
pub struct RecursiveFit<T, M, const N: usize> {
    norm: Normalization<T>,
    rls: QrRls<T, N>,
    forgetting: T,
    rejected: u32,
    _model: core::marker::PhantomData<M>,
}

impl<T: Real, M: Model<N>, const N: usize> RecursiveFit<T, M, N> {
    /// A fit whose regressors are normalised with `norm`: centre it near the
    /// expected bias (e.g. the coefficients in use) and scale it by the
    /// expected radius in raw units, so the regressors stay O(1).
    pub fn new(norm: Normalization<T>) -> Self {
        Self { norm, rls: QrRls::new(), forgetting: T::ONE, rejected: 0, _model: core::marker::PhantomData }
    }

    /// Exponential forgetting: each new sample discounts the past by
    /// `lambda` (0 < λ ≤ 1; 1 = remember everything).
    pub fn with_forgetting(mut self, lambda: T) -> Self {
        if lambda > T::ZERO && lambda <= T::ONE {
            self.forgetting = lambda;
        }
        self
    }

    /// The normalisation in use.
    pub fn normalization(&self) -> &Normalization<T> {
        &self.norm
    }

    /// Absorbs one raw sample; a non-finite sample is counted and ignored.
    pub fn push(&mut self, raw: Vec3<T>) -> bool {
        let (phi, y) = M::row(self.norm.apply(raw));
        if self.forgetting < T::ONE {
            self.rls.forget(self.forgetting);
        }
        let ok = self.rls.update(&phi, y);
        if !ok {
            self.rejected = self.rejected.saturating_add(1);
        }
        ok
    }

    /// Samples absorbed.
    pub fn count(&self) -> u32 {
        self.rls.count()
    }

    /// Samples refused (non-finite).
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// Per-parameter information (|R_ii|), for convergence displays.
    pub fn information(&self) -> [T; N] {
        self.rls.information_diagonal()
    }

    /// The current estimate in raw units for reference intensity `field_nt`.
    pub fn estimate(&self, field_nt: T) -> Result<FieldCal<T>, FitError> {
        if !(field_nt > T::ZERO && field_nt.is_finite()) {
            return Err(FitError::BadReference);
        }
        let x = self.rls.solve()?;
        Ok(denormalize(&M::extract(&x, field_nt)?, &self.norm))
    }
}

/// Recursive sphere fit.
pub type SphereRls<T> = RecursiveFit<T, Sphere, 4>;
/// Recursive axis-aligned (paper) fit.
pub type AxisRls<T> = RecursiveFit<T, Axis, 6>;
/// Recursive full-ellipsoid fit.
pub type FullRls<T> = RecursiveFit<T, Full, 9>;

#[cfg(test)]
pub(crate) mod tests;
