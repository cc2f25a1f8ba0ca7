//! Whether the clock search's answer is unique.
//!
//! Each shared signal gives a score at every lag searched (how well the
//! logs agree there; higher is better). At lags far from the true one the
//! two logs are unrelated, and the score only wanders: by chance, partial
//! matches of a motion that repeats, the noise. That wander is measured on
//! the curve itself, robustly — the median and the median absolute
//! deviation (×1.4826, a normal σ) over all the lags searched, which the
//! few lags near the true one hardly move — and each signal's curve is put
//! in those units ([`standardise`]) and the signals' curves added: a signal
//! with a sharp peak over a quiet null counts for much, one whose score
//! wanders as high at many lags for little.
//!
//! The answer is judged on the sum, standardised again ([`find_peak`]): its
//! highest point must stand above the second-highest peak outside its own
//! lobe (the lags around it still above half its height) by at least
//! [`MIN_MARGIN_SIGMA`] null σ, and above the median by at least
//! [`MIN_HEIGHT_SIGMA`]. Why that rule: the score of a peak is uncertain by
//! about the null's σ (the same noise and chance matches that make the
//! null wander also move the peaks), so two peaks within a few σ of each
//! other could trade places with other noise — the logs cannot tell them
//! apart, whatever their height; while a peak well clear of every other is
//! the offset whatever its height, so no fixed threshold on the agreement
//! itself (a correlation of 0.3, a share of the field explained) is asked
//! for. A motion that repeats within the search window (a diver's regular
//! swing, circles at a steady rate) gives two or more peaks of the same
//! height, and is refused, naming both offsets.

/// The best lag must beat the runner-up outside its lobe by this many null σ.
pub(super) const MIN_MARGIN_SIGMA: f64 = 3.0;

/// … and stand this many null σ above the median lag.
pub(super) const MIN_HEIGHT_SIGMA: f64 = 6.0;

/// The normal σ of a median absolute deviation.
const MAD_TO_SIGMA: f64 = 1.4826;

/// The median and the null σ (1.4826 × the median absolute deviation) of
/// the finite values; `None` with fewer than 5 of them or no spread.
fn null_spread(values: &[f64]) -> Option<(f64, f64)> {
    let mut finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.len() < 5 {
        return None;
    }
    let median = calib_core::series::median(&mut finite)?;
    let mut dev: Vec<f64> = finite.iter().map(|v| (v - median).abs()).collect();
    let sigma = MAD_TO_SIGMA * calib_core::series::median(&mut dev)?;
    (sigma > 0.0 && sigma.is_finite()).then_some((median, sigma))
}

/// A score curve in units of its own null: `(score − median) / σ` (NaN
/// stays NaN); `None` when the curve has no spread to measure.
pub(super) fn standardise(score: &[f64]) -> Option<Vec<f64>> {
    let (median, sigma) = null_spread(score)?;
    Some(score.iter().map(|s| (s - median) / sigma).collect())
}

/// The sum of standardised curves, lag by lag (a signal missing at a lag
/// adds nothing there; NaN where every signal is missing).
pub(super) fn combine(curves: &[Vec<f64>]) -> Vec<f64> {
    let n = curves.iter().map(Vec::len).max().unwrap_or(0);
    (0..n)
        .map(|k| {
            let present: Vec<f64> = curves
                .iter()
                .filter_map(|c| c.get(k).copied())
                .filter(|v| v.is_finite())
                .collect();
            if present.is_empty() {
                f64::NAN
            } else {
                present.iter().sum()
            }
        })
        .collect()
}

/// The highest point of a combined curve and how unique it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Peak {
    /// Its index.
    pub(super) k: usize,
    /// Its lobe: the indices around it still above half its height over the median.
    pub(super) lobe: (usize, usize),
    /// Its height over the runner-up, null σ (infinite without a runner-up).
    pub(super) margin_sigma: f64,
    /// Its height over the median, null σ.
    pub(super) height_sigma: f64,
    /// The second-highest peak outside the lobe: a point at least as high
    /// as its neighbours (an end of the curve counts).
    pub(super) runner_up: Option<usize>,
}

impl Peak {
    /// Unique by the module's rule.
    pub(super) fn is_unique(&self) -> bool {
        self.margin_sigma >= MIN_MARGIN_SIGMA && self.height_sigma >= MIN_HEIGHT_SIGMA
    }
}

/// The peak of `z` (see the module's text); `None` when `z` has no finite
/// value or no spread.
pub(super) fn find_peak(z: &[f64]) -> Option<Peak> {
    let (median, sigma) = null_spread(z)?;
    let (k, &top) = z
        .iter()
        .enumerate()
        .filter(|(_, v)| v.is_finite())
        .max_by(|a, b| a.1.total_cmp(b.1))?;
    let half = 0.5 * (top + median);
    let above = |j: usize| z[j].is_finite() && z[j] > half;
    let (mut lo, mut hi) = (k, k);
    while lo > 0 && above(lo - 1) {
        lo -= 1;
    }
    while hi + 1 < z.len() && above(hi + 1) {
        hi += 1;
    }
    let at = |j: Option<usize>| {
        j.and_then(|j| z.get(j))
            .copied()
            .filter(|v| v.is_finite())
            .unwrap_or(f64::NEG_INFINITY)
    };
    let runner_up = (0..z.len())
        .filter(|&j| {
            (j < lo || j > hi)
                && z[j].is_finite()
                && z[j] >= at(j.checked_sub(1))
                && z[j] >= at(Some(j + 1))
        })
        .max_by(|&a, &b| z[a].total_cmp(&z[b]));
    let margin_sigma = runner_up.map_or(f64::INFINITY, |j| (top - z[j]) / sigma);
    Some(Peak {
        k,
        lobe: (lo, hi),
        margin_sigma,
        height_sigma: (top - median) / sigma,
        runner_up,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A curve of unit-σ noise (a fixed pseudo-random sequence) with peaks
    /// of the given heights at the given indices, each three points wide.
    fn curve(peaks: &[(usize, f64)]) -> Vec<f64> {
        let mut state = 12345u64;
        let mut z: Vec<f64> = (0..400)
            .map(|_| {
                // Twelve uniforms: close enough to a normal deviate.
                (0..12)
                    .map(|_| {
                        state = state
                            .wrapping_mul(6364136223846793005)
                            .wrapping_add(1442695040888963407);
                        (state >> 11) as f64 / (1u64 << 53) as f64
                    })
                    .sum::<f64>()
                    - 6.0
            })
            .collect();
        for &(k, h) in peaks {
            z[k] += h;
            z[k - 1] += 0.6 * h;
            z[k + 1] += 0.6 * h;
        }
        z
    }

    #[test]
    fn a_peak_well_clear_of_the_rest_is_unique_whatever_its_height() {
        let p = find_peak(&curve(&[(200, 12.0)])).unwrap();
        assert!(p.is_unique() && (p.k as i64 - 200).abs() <= 1, "{p:?}");
        // The runner-up is a chance peak of the noise, a few σ high.
        assert!(p.margin_sigma > 5.0, "{p:?}");
    }

    #[test]
    fn two_peaks_of_the_same_height_are_not_unique_and_both_are_named() {
        let p = find_peak(&curve(&[(100, 12.0), (300, 12.0)])).unwrap();
        assert!(!p.is_unique(), "{p:?}");
        let mut both = [p.k, p.runner_up.unwrap()];
        both.sort();
        assert!(
            (both[0] as i64 - 100).abs() <= 1 && (both[1] as i64 - 300).abs() <= 1,
            "{p:?}"
        );
    }

    #[test]
    fn noise_alone_has_no_peak_to_accept() {
        let p = find_peak(&curve(&[])).unwrap();
        assert!(!p.is_unique(), "{p:?}");
    }

    #[test]
    fn curves_add_in_units_of_their_own_null() {
        // The same shape at two scales standardises to the same curve.
        let a = curve(&[(200, 12.0)]);
        let b: Vec<f64> = a.iter().map(|v| 1e-3 * v + 5.0).collect();
        let (za, zb) = (standardise(&a).unwrap(), standardise(&b).unwrap());
        assert!(za.iter().zip(&zb).all(|(x, y)| (x - y).abs() < 1e-9));
        let sum = combine(&[za.clone(), vec![f64::NAN; 400]]);
        assert_eq!(sum[17], za[17]);
        assert!(standardise(&[1.0; 50]).is_none(), "no spread");
    }
}
