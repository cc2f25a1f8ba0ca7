//! The inclination the dip test compares with: the reference's, or learned
//! from the samples judged ok — freely without a reference inclination,
//! within `Tuning::inclination_allowance_rad` of one (a wrong calibration
//! must not teach the monitor a dip of its own).

use super::tuning::{Reference, Tuning};
use crate::Real;

/// Samples of a learned inclination averaged in at once.
pub const INCLINATION_BLOCK: u8 = 8;

/// The cosine of an angle in ±90° from its sine (clamped, never 0).
#[inline(always)]
pub(crate) fn cos_of_sin<T: Real>(sin: T) -> T {
    let s = sin.max(-T::ONE).min(T::ONE);
    (T::ONE - s * s).max(T::EPSILON).sqrt()
}

/// The inclination in use and its learner: a running mean of the sine of
/// the dip over the samples judged ok, its memory capped at
/// `Tuning::inclination_memory` samples.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(super) struct Inclination<T> {
    /// sin of the reference (or learned) inclination, and the dip
    /// residual's gain `F / (σ_F cos I)`.
    pub(super) sin_incl: T,
    pub(super) dip_gain: T,
    /// Samples averaged into a learned inclination (0: none yet).
    weight: T,
    /// The sines of the dip waiting to be averaged in, and their count (the
    /// mean is updated every [`INCLINATION_BLOCK`] samples).
    sum: T,
    pending: u8,
    /// The bounds of a learned sin I (the reference's allowance; ±1
    /// without a reference).
    sin_lo: T,
    sin_hi: T,
}

impl<T: Real> Inclination<T> {
    /// The reference's inclination (full weight), or none yet (no dip
    /// test: a zero gain, until one is learned).
    #[inline(always)]
    pub(super) fn new(r: &Reference<T>, t: &Tuning<T>) -> Self {
        let (sin_incl, cos_incl, weight) = match r.inclination_rad {
            Some(i) => (i.sin(), i.cos(), t.inclination_memory),
            None => (T::ZERO, T::ONE, T::ZERO),
        };
        // No inclination yet: no dip test (a zero gain) until one is learned.
        let dip_gain = if r.inclination_rad.is_some() {
            r.field_nt / (r.field_sigma_nt * cos_incl)
        } else {
            T::ZERO
        };
        let half_pi = T::PI / T::from_f64(2.0);
        let (sin_lo, sin_hi) = match r.inclination_rad {
            Some(i) => (
                (i - t.inclination_allowance_rad).max(-half_pi).sin(),
                (i + t.inclination_allowance_rad).min(half_pi).sin(),
            ),
            None => (-T::ONE, T::ONE),
        };
        Self {
            sin_incl,
            dip_gain,
            weight,
            sum: T::ZERO,
            pending: 0,
            sin_lo,
            sin_hi,
        }
    }

    /// sin of the inclination in use (`None` before one is learned).
    #[inline(always)]
    pub(super) fn sin_inclination(&self) -> Option<T> {
        (self.weight > T::ZERO).then_some(self.sin_incl)
    }

    /// Running mean of the sine of the dip over the samples judged ok,
    /// taken in blocks of [`INCLINATION_BLOCK`] samples (the same mean,
    /// a tenth of the per-sample cost).
    #[inline(always)]
    pub(super) fn learn(&mut self, sin_dip: T, r: &Reference<T>, t: &Tuning<T>) {
        self.sum += sin_dip;
        self.pending += 1;
        if self.pending >= INCLINATION_BLOCK {
            self.absorb(r, t);
        }
    }

    /// Adds the pending block to the running mean (weight capped at
    /// `Tuning::inclination_memory` samples) and updates the dip gain.
    #[inline(never)]
    fn absorb(&mut self, r: &Reference<T>, t: &Tuning<T>) {
        let n = T::from_u32(u32::from(self.pending));
        self.weight = (self.weight + n).min(t.inclination_memory.max(n));
        // A weighted mean of values in [−1, 1] stays there (up to rounding,
        // which `cos_of_sin` absorbs).
        self.sin_incl += (self.sum - n * self.sin_incl) / self.weight;
        self.sin_incl = self.sin_incl.max(self.sin_lo).min(self.sin_hi);
        self.dip_gain = r.field_nt / (r.field_sigma_nt * cos_of_sin(self.sin_incl));
        self.sum = T::ZERO;
        self.pending = 0;
    }
}
