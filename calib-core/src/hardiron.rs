//! On-line estimate of a new hard iron: the field offset `δ` (nT, body
//! frame) that a payload or a magnetised part added after calibration, so
//! that the true field is `h − δ` with `h` the stored calibration's output.
//!
//! Recursive weighted least squares in information form with exponential
//! forgetting (time constant `tau_s`), three kinds of rows, all linear in δ:
//!
//! - **gyro-aided** (Troni & Whitcomb 2013; MAGYC, Rodríguez-Martínez &
//!   Troni 2024): a field fixed in the world turns in the body frame against
//!   the body rate, `ḣ = −ω × (h − δ)`, so with the mid-point `m` of two
//!   samples `[ω]× δ = (h₁ − h₀)/Δt + ω × m`; its information
//!   `[ω]×ᵀ[ω]× = |ω|² I − ω ωᵀ` needs no reference field at all;
//! - **magnitude**: `|h − δ| = F`, linearised about the current estimate
//!   (`u = (h − δ̂)/|h − δ̂|`, `uᵀ δ = uᵀ h − F`);
//! - **attitude-aided**: the levelled vertical `c·(h − δ) = F sin I` with `c`
//!   the levelling's third row, when the attitude and an inclination are known.
//!
//! The covariance is the inverse information scaled by the magnitude rows'
//! observed normalised residual variance (at least 1), so a model that does
//! not fit (the distortion is not a pure offset) reports a large σ and the
//! guard in [`crate::online`] does not apply it.
//!
//! State: 25 numbers (the inverse kept for the estimate); a sample costs
//! about 60 multiply-adds and one 3×3 inverse.

use crate::heading::{Tilt, Vec3};
use crate::linalg::{inverse3, Mat3};
use crate::Real;

/// The estimate and its 1σ.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HardIron<T> {
    /// The new offset, nT, body frame (subtract it from the calibrated field).
    pub offset_nt: Vec3<T>,
    /// 1σ per axis, nT.
    pub sigma_nt: Vec3<T>,
    /// RMS of `(|h − δ| − F) / σ_F` over the memory (about 1 when the
    /// offset explains the misfit).
    pub residual_rms_z: T,
}

/// The recursive estimator.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HardIronEstimator<T> {
    /// Information matrix, upper triangle `xx xy xz yy yz zz`, 1/nT².
    info: [T; 6],
    /// Information vector, 1/nT.
    eta: [T; 3],
    offset_nt: Vec3<T>,
    /// The information matrix's inverse at the last update (`None` while
    /// it is singular): the estimate's covariance before scaling.
    inverse: Option<Mat3<T>>,
    prev_field_nt: Vec3<T>,
    has_prev: bool,
    /// Forgotten sum of squared normalised magnitude residuals, and its weight.
    chi2: T,
    weight: T,
    tau_s: T,
}

impl<T: Real> HardIronEstimator<T> {
    /// An estimator with memory `tau_s` seconds (non-positive or non-finite
    /// memory falls back to 60 s).
    pub fn new(tau_s: T) -> Self {
        let tau_s = if tau_s.is_finite() && tau_s > T::ZERO { tau_s } else { T::from_f64(60.0) };
        Self { info: [T::ZERO; 6], eta: [T::ZERO; 3], offset_nt: [T::ZERO; 3], inverse: None, prev_field_nt: [T::ZERO; 3], has_prev: false, chi2: T::ZERO, weight: T::ZERO, tau_s }
    }

    /// Forgets everything.
    pub fn reset(&mut self) {
        *self = Self::new(self.tau_s);
    }

    #[inline(always)]
    fn add_row(&mut self, a: Vec3<T>, y: T, w: T) {
        let i = &mut self.info;
        i[0] += w * a[0] * a[0];
        i[1] += w * a[0] * a[1];
        i[2] += w * a[0] * a[2];
        i[3] += w * a[1] * a[1];
        i[4] += w * a[1] * a[2];
        i[5] += w * a[2] * a[2];
        for k in 0..3 {
            self.eta[k] += w * a[k] * y;
        }
    }

    fn info_matrix(&self) -> Mat3<T> {
        let i = &self.info;
        [[i[0], i[1], i[2]], [i[1], i[3], i[4]], [i[2], i[4], i[5]]]
    }

    /// Adds one sample: the stored calibration's field `field_nt`, the
    /// attitude and body rates when known, the time since the previous
    /// sample, the reference intensity and its scatter, the sine of the
    /// inclination when known, and the longest step the gyro is integrated
    /// over.
    #[allow(clippy::too_many_arguments)]
    pub fn update(&mut self, field_nt: Vec3<T>, tilt: Option<&Tilt<T>>, rate_rad_s: Option<Vec3<T>>, dt_s: T, reference_nt: T, sigma_nt: T, sin_incl: Option<T>, max_gap_s: T) {
        let h = field_nt;
        if !(h.iter().all(|v| v.is_finite()) && sigma_nt > T::ZERO) {
            return;
        }
        let dt = if dt_s.is_finite() && dt_s > T::ZERO { dt_s } else { T::ZERO };
        let keep = (T::ONE - dt / self.tau_s).max(T::ZERO);
        for v in self.info.iter_mut().chain(self.eta.iter_mut()) {
            *v *= keep;
        }
        self.chi2 *= keep;
        self.weight *= keep;
        let w = T::ONE / (sigma_nt * sigma_nt);
        // Magnitude, about the current estimate.
        let c = [h[0] - self.offset_nt[0], h[1] - self.offset_nt[1], h[2] - self.offset_nt[2]];
        let n = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        if n > sigma_nt {
            let u = [c[0] / n, c[1] / n, c[2] / n];
            self.add_row(u, u[0] * h[0] + u[1] * h[1] + u[2] * h[2] - reference_nt, w);
            let r = (n - reference_nt) / sigma_nt;
            self.chi2 += r * r;
            self.weight += T::ONE;
        }
        // The levelled vertical.
        if let (Some(t), Some(s)) = (tilt, sin_incl) {
            let a = [-t.sin_pitch, t.cos_pitch * t.sin_roll, t.cos_pitch * t.cos_roll];
            self.add_row(a, a[0] * h[0] + a[1] * h[1] + a[2] * h[2] - reference_nt * s, w);
        }
        // The gyro: [ω]× δ = Δh/Δt + ω × m.
        if let Some(om) = rate_rad_s {
            if self.has_prev && dt > T::ZERO && dt <= max_gap_s && om.iter().all(|v| v.is_finite()) {
                let p = self.prev_field_nt;
                let half = T::from_f64(0.5);
                let m = [(h[0] + p[0]) * half, (h[1] + p[1]) * half, (h[2] + p[2]) * half];
                let y = [
                    (h[0] - p[0]) / dt + om[1] * m[2] - om[2] * m[1],
                    (h[1] - p[1]) / dt + om[2] * m[0] - om[0] * m[2],
                    (h[2] - p[2]) / dt + om[0] * m[1] - om[1] * m[0],
                ];
                // Noise of a difference of two samples over Δt.
                let wk = w * dt * dt * half;
                let o2 = om[0] * om[0] + om[1] * om[1] + om[2] * om[2];
                let i = &mut self.info;
                i[0] += wk * (o2 - om[0] * om[0]);
                i[1] -= wk * om[0] * om[1];
                i[2] -= wk * om[0] * om[2];
                i[3] += wk * (o2 - om[1] * om[1]);
                i[4] -= wk * om[1] * om[2];
                i[5] += wk * (o2 - om[2] * om[2]);
                // [ω]×ᵀ y = y × ω.
                self.eta[0] += wk * (y[1] * om[2] - y[2] * om[1]);
                self.eta[1] += wk * (y[2] * om[0] - y[0] * om[2]);
                self.eta[2] += wk * (y[0] * om[1] - y[1] * om[0]);
            }
        }
        self.prev_field_nt = h;
        self.has_prev = true;
        self.inverse = inverse3(&self.info_matrix());
        if let Some(inv) = &self.inverse {
            let e = &self.eta;
            let d = [0, 1, 2].map(|r| inv[r][0] * e[0] + inv[r][1] * e[1] + inv[r][2] * e[2]);
            if d.iter().all(|v| v.is_finite()) {
                self.offset_nt = d;
            }
        }
    }

    /// The current estimate with its 1σ, or `None` while the information
    /// does not determine all three components.
    pub fn estimate(&self) -> Option<HardIron<T>> {
        let inv = self.inverse?;
        if !(inv[0][0] > T::ZERO && inv[1][1] > T::ZERO && inv[2][2] > T::ZERO && self.weight > T::from_f64(3.0)) {
            return None;
        }
        let scale = (self.chi2 / self.weight).max(T::ONE);
        let sigma_nt = [0, 1, 2].map(|k| (inv[k][k] * scale).sqrt());
        let residual_rms_z = (self.chi2 / self.weight).sqrt();
        Some(HardIron { offset_nt: self.offset_nt, sigma_nt, residual_rms_z })
    }
}
