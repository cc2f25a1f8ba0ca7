//! Quality metrics of a field calibration, kept apart from the fits (as
//! MotionCal does): how well the calibrated magnitudes match the reference,
//! how much of the sphere of field directions the data visited, and how much
//! each body axis was exercised. [`Gates`] turns them into a verdict, so a
//! weak calibration is refused with a reason instead of being returned.

use crate::cal::FieldCal;
use crate::fit::FitError;
use crate::heading::Vec3;
use crate::Real;

/// Latitude bands of the direction mask (equal-area: equal steps in z).
pub const COVERAGE_BANDS: u32 = 6;
/// Longitude sectors per band.
pub const COVERAGE_SECTORS: u32 = 12;
/// Bins of the direction mask.
pub const COVERAGE_BINS: u32 = COVERAGE_BANDS * COVERAGE_SECTORS;

/// Which of [`COVERAGE_BINS`] equal-area cells of the unit sphere the
/// calibrated field directions have visited.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CoverageMask {
    bits: u128,
}

impl CoverageMask {
    /// Nothing visited.
    pub const fn new() -> Self {
        Self { bits: 0 }
    }

    /// The bin of a direction (need not be unit length); `None` for a zero or
    /// non-finite vector.
    pub fn bin<T: Real>(v: Vec3<T>) -> Option<u32> {
        let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        if !(n > T::ZERO) || !n.is_finite() {
            return None;
        }
        let z = (v[2] / n).max(-T::ONE).min(T::ONE);
        let band = ((z + T::ONE) / T::from_f64(2.0) * T::from_u32(COVERAGE_BANDS)).to_u32();
        let lon = v[1].atan2(v[0]) + T::PI; // [0, 2π]
        let sector = (lon / T::TAU * T::from_u32(COVERAGE_SECTORS)).to_u32();
        Some(band.min(COVERAGE_BANDS - 1) * COVERAGE_SECTORS + sector.min(COVERAGE_SECTORS - 1))
    }

    /// Marks the bin of `v` visited.
    pub fn add<T: Real>(&mut self, v: Vec3<T>) {
        if let Some(b) = Self::bin(v) {
            self.bits |= 1u128 << b;
        }
    }

    /// Bins visited.
    pub fn count(&self) -> u32 {
        self.bits.count_ones()
    }

    /// Percent of bins visited (0–100).
    pub fn percent(&self) -> u8 {
        (self.count() * 100 / COVERAGE_BINS) as u8
    }

    /// The raw bit mask (bit `band·12 + sector`).
    pub fn bits(&self) -> u128 {
        self.bits
    }
}

/// Running statistics of the calibrated magnitude against the reference.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Quality<T> {
    /// Samples assessed.
    pub samples: u32,
    /// Mean of `|h| − F`, nT.
    pub residual_mean_nt: T,
    /// RMS of `|h| − F`, nT.
    pub residual_rms_nt: T,
    /// Largest `||h| − F|`, nT.
    pub residual_max_nt: T,
    /// RMS residual as a percentage of `F`.
    pub residual_rms_pct: T,
    /// Percent of field-direction bins visited.
    pub coverage_pct: u8,
    /// The direction mask itself.
    pub coverage: CoverageMask,
    /// Standard deviation of each component of the calibrated unit field
    /// direction (≈ 0.577 each for a full tumble, ≈ 0 for an axis that never
    /// saw the field change).
    pub axis_spread: Vec3<T>,
}

/// Assesses a calibration on the samples it is meant for.
pub fn assess<T: Real>(cal: &FieldCal<T>, samples: &[Vec3<T>], field_nt: T) -> Quality<T> {
    let mut coverage = CoverageMask::new();
    let (mut n, mut sum, mut sum_sq, mut max) = (0u32, T::ZERO, T::ZERO, T::ZERO);
    let (mut s1, mut s2) = ([T::ZERO; 3], [T::ZERO; 3]);
    for raw in samples {
        let h = cal.apply(*raw);
        let m = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
        if !m.is_finite() || m == T::ZERO {
            continue;
        }
        let r = m - field_nt;
        n += 1;
        sum += r;
        sum_sq += r * r;
        max = max.max(r.abs());
        coverage.add(h);
        for k in 0..3 {
            let u = h[k] / m;
            s1[k] += u;
            s2[k] += u * u;
        }
    }
    let nn = T::from_f64(f64::from(n.max(1)));
    let rms = (sum_sq / nn).sqrt();
    let mut spread = [T::ZERO; 3];
    for k in 0..3 {
        let mean = s1[k] / nn;
        spread[k] = (s2[k] / nn - mean * mean).max(T::ZERO).sqrt();
    }
    Quality {
        samples: n,
        residual_mean_nt: sum / nn,
        residual_rms_nt: rms,
        residual_max_nt: max,
        residual_rms_pct: rms / field_nt * T::from_f64(100.0),
        coverage_pct: coverage.percent(),
        coverage,
        axis_spread: spread,
    }
}

/// Thresholds a calibration must pass to be returned.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gates<T> {
    /// Least percentage of direction bins visited.
    pub min_coverage_pct: u8,
    /// Largest RMS magnitude residual, percent of the field.
    pub max_residual_pct: T,
}

impl<T: Real> Gates<T> {
    /// The largest RMS magnitude residual a calibration may keep, percent
    /// of the field.
    pub const MAX_RESIDUAL_PCT: f64 = 2.0;

    /// The gates of a model that needs `min_coverage_pct` of the direction
    /// bins, with the residual at most [`Self::MAX_RESIDUAL_PCT`]. Each
    /// model's coverage is data in the host's model registry (host-tools'
    /// `compute::MODELS`), beside the rest of what is known of the model.
    pub fn with_coverage(min_coverage_pct: u8) -> Self {
        Self { min_coverage_pct, max_residual_pct: T::from_f64(Self::MAX_RESIDUAL_PCT) }
    }

    /// The verdict.
    pub fn check(&self, q: &Quality<T>) -> Result<(), FitError> {
        if q.coverage_pct < self.min_coverage_pct {
            return Err(FitError::InsufficientCoverage { covered_pct: q.coverage_pct });
        }
        if !(q.residual_rms_pct <= self.max_residual_pct) {
            let per_mille = (q.residual_rms_pct * T::from_f64(10.0)).to_f64().clamp(0.0, 65535.0) as u16;
            return Err(FitError::ResidualTooLarge { rms_per_mille: per_mille });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::conformance::SplitMix64;

    /// The full model's coverage gate (the host registry's).
    const FULL_COVERAGE_PCT: u8 = 40;

    #[test]
    fn a_full_tumble_covers_every_bin_and_spreads_every_axis() {
        let mut rng = SplitMix64::new(1);
        let cal = FieldCal::<f64>::identity();
        let data: Vec<[f64; 3]> = (0..5000).map(|_| rng.direction().map(|v| v * 48_000.0)).collect();
        let q = assess(&cal, &data, 48_000.0);
        assert_eq!(q.coverage_pct, 100);
        assert!(q.residual_rms_nt < 1e-9);
        for k in 0..3 {
            assert!((q.axis_spread[k] - 1.0 / 3f64.sqrt()).abs() < 0.02, "{:?}", q.axis_spread);
        }
        assert_eq!(Gates::with_coverage(FULL_COVERAGE_PCT).check(&q), Ok(()));
    }

    #[test]
    fn a_cap_of_directions_is_refused_for_the_full_model() {
        let mut rng = SplitMix64::new(2);
        let data: Vec<[f64; 3]> = (0..5000)
            .map(|_| rng.direction())
            .filter(|d| d[2] < -0.5)
            .map(|d| d.map(|v| v * 48_000.0))
            .collect();
        let q = assess(&FieldCal::identity(), &data, 48_000.0);
        assert!(q.coverage_pct <= 34, "{}", q.coverage_pct);
        assert_eq!(
            Gates::with_coverage(FULL_COVERAGE_PCT).check(&q),
            Err(FitError::InsufficientCoverage { covered_pct: q.coverage_pct })
        );
    }

    #[test]
    fn residual_statistics_are_exact_for_known_offsets() {
        let data = [[48_010.0, 0.0, 0.0], [0.0, 47_990.0, 0.0], [0.0, 0.0, 48_030.0]];
        let q = assess(&FieldCal::identity(), &data, 48_000.0);
        assert!((q.residual_mean_nt - 10.0).abs() < 1e-9);
        assert!((q.residual_rms_nt - (1100.0f64 / 3.0).sqrt()).abs() < 1e-9);
        assert!((q.residual_max_nt - 30.0).abs() < 1e-9);
        let strict = Gates { min_coverage_pct: 0, max_residual_pct: 0.01 };
        assert!(matches!(strict.check(&q), Err(FitError::ResidualTooLarge { rms_per_mille: 0 })));
    }

    #[test]
    fn bins_are_equal_area() {
        // Uniform directions fill each bin with about the same count.
        let mut rng = SplitMix64::new(3);
        let mut counts = [0u32; COVERAGE_BINS as usize];
        for _ in 0..72_000 {
            counts[CoverageMask::bin(rng.direction()).unwrap() as usize] += 1;
        }
        for c in counts {
            assert!((850..1150).contains(&c), "{counts:?}");
        }
    }
}
