//! Order statistics and interpolation of sampled series: the one home of
//! the median, the quantile and the linear (and angular) interpolation the
//! crates use. No allocation: the order statistics rearrange the caller's
//! slice.

use crate::heading::{wrap_pi, wrap_two_pi};
use crate::Real;

/// The `q`-quantile (0 ≤ q ≤ 1) by nearest rank: the element of rank
/// `round((n − 1)·q)` in ascending order. Rearranges `values`. `None` when
/// `values` is empty, holds a NaN, or `q` is outside [0, 1].
pub fn quantile<T: Real>(values: &mut [T], q: T) -> Option<T> {
    if values.is_empty() || values.iter().any(|v| v.partial_cmp(v).is_none()) || !(q >= T::ZERO && q <= T::ONE) {
        return None;
    }
    let last = values.len() - 1;
    // round half up of a non-negative number (no `round` in `core`).
    let rank = ((last as f64) * q.to_f64() + 0.5) as usize;
    let rank = rank.min(last);
    let (_, v, _) = values.select_nth_unstable_by(rank, |a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Equal));
    Some(*v)
}

/// The median: the element of rank `⌊n/2⌋` (the upper of the two middle
/// ones for an even count: always one of the samples). Rearranges
/// `values`; `None` when empty or holding a NaN.
pub fn median<T: Real>(values: &mut [T]) -> Option<T> {
    // round((n − 1)/2) = ⌊n/2⌋.
    quantile(values, T::from_f64(0.5))
}

/// Where a time falls in a non-decreasing series of sample times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Bracket<T> {
    /// Exactly at sample `i`.
    At(usize),
    /// Between samples `i` and `i + 1`, at fraction `f` of the way.
    Between(usize, T),
}

/// Brackets `at_s` in `times_s` (non-decreasing). `None` outside the span
/// (never extrapolated) or across a gap longer than `max_gap_s`.
pub fn bracket<T: Real>(times_s: &[T], at_s: T, max_gap_s: T) -> Option<Bracket<T>> {
    let i = times_s.partition_point(|&t| t < at_s);
    let t1 = *times_s.get(i)?;
    if t1 == at_s {
        return Some(Bracket::At(i));
    }
    let t0 = *times_s.get(i.checked_sub(1)?)?;
    if !(t1 - t0 <= max_gap_s) {
        return None;
    }
    Some(Bracket::Between(i - 1, (at_s - t0) / (t1 - t0)))
}

/// Linear interpolation of `values` (sampled at `times_s`) at `at_s`;
/// `None` outside, across a gap longer than `max_gap_s`, or next to a
/// non-finite value.
pub fn interp_linear<T: Real>(times_s: &[T], values: &[T], at_s: T, max_gap_s: T) -> Option<T> {
    let n = times_s.len().min(values.len());
    match bracket(times_s.get(..n)?, at_s, max_gap_s)? {
        Bracket::At(i) => values.get(i).copied().filter(|v| v.is_finite()),
        Bracket::Between(i, f) => {
            let (v0, v1) = (*values.get(i)?, *values.get(i + 1)?);
            (v0.is_finite() && v1.is_finite()).then(|| v0 + f * (v1 - v0))
        }
    }
}

/// Interpolation of an angle (rad) along the shorter arc, wrapped to
/// [0, 2π) between samples (a sample hit exactly is returned as stored);
/// `None` as for [`interp_linear`].
pub fn interp_angle<T: Real>(times_s: &[T], angles_rad: &[T], at_s: T, max_gap_s: T) -> Option<T> {
    let n = times_s.len().min(angles_rad.len());
    match bracket(times_s.get(..n)?, at_s, max_gap_s)? {
        Bracket::At(i) => angles_rad.get(i).copied().filter(|v| v.is_finite()),
        Bracket::Between(i, f) => {
            let (h0, h1) = (*angles_rad.get(i)?, *angles_rad.get(i + 1)?);
            (h0.is_finite() && h1.is_finite()).then(|| wrap_two_pi(h0 + f * wrap_pi(h1 - h0)))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn median_and_quantiles_by_nearest_rank() {
        // numpy.quantile(..., method="nearest") on [1, 2, 3, 4, 5]: 0.25 → 2, 0.9 → 5.
        let mut v = [5.0f64, 1.0, 4.0, 2.0, 3.0];
        assert_eq!(median(&mut v), Some(3.0));
        assert_eq!(quantile(&mut v, 0.25), Some(2.0));
        assert_eq!(quantile(&mut v, 0.9), Some(5.0));
        assert_eq!(quantile(&mut v, 0.0), Some(1.0));
        // Even count: the upper middle sample.
        let mut w = [4.0f32, 1.0, 3.0, 2.0];
        assert_eq!(median(&mut w), Some(3.0));
    }

    #[test]
    fn empty_or_nan_input_has_no_median() {
        assert_eq!(median::<f64>(&mut []), None);
        assert_eq!(median(&mut [1.0, f64::NAN]), None);
        assert_eq!(quantile(&mut [1.0], 1.5), None);
    }

    #[test]
    fn interpolation_between_inside_and_not_across_gaps() {
        let t = [0.0, 1.0, 2.0, 10.0];
        let v = [0.0, 10.0, 20.0, 30.0];
        assert_eq!(interp_linear(&t, &v, 1.25, 2.0), Some(12.5));
        assert_eq!(interp_linear(&t, &v, 2.0, 2.0), Some(20.0));
        assert_eq!(interp_linear(&t, &v, 5.0, 2.0), None);
        assert_eq!(interp_linear(&t, &v, -0.1, 2.0), None);
        // 350° → 10°: half way is 0°, not 180°.
        let h = [350f64.to_radians(), 10f64.to_radians()];
        let mid = interp_angle(&t[..2], &h, 0.5, 2.0).unwrap_or(f64::NAN);
        assert!(mid.min(core::f64::consts::TAU - mid) < 1e-12, "{mid}");
    }
}
