//! Swinging (heading) calibration: ALGORITHMS.md §3 (paper 000, eqs 19–21, 31).
//!
//! `δψ = ψ_ref − ψ̂ = A + B sin ψ̂ + C cos ψ̂ + D sin 2ψ̂ + E cos 2ψ̂`, fitted by
//! least squares on wrapped differences. The five columns are ordered so the
//! nested models (A; A, B, C; all five) come from one accumulator: headings
//! that visit too few sectors of the compass cannot determine the second
//! harmonic (or the first), and then only the terms the data determine are
//! fitted, and the result says so ([`SwingTerms`]).
//!
//! The reference is GPS course over ground, only at the surface and about
//! 2 s late: [`aligned_pairs`] pairs each reference sample with the
//! magnetometer heading `delay` seconds earlier, and [`estimate_delay`]
//! finds the delay that best explains the data.


use crate::cal::Swing;
use crate::heading::{wrap_pi, wrap_two_pi};
use crate::lsq::{LeastSquares, NormalEquations, QrRls, SolveError};
use crate::Real;

/// Which terms a swing fit could determine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SwingTerms {
    /// Only the constant A (headings in a narrow range).
    ConstantOnly = 1,
    /// A, B, C (the first harmonic).
    FirstHarmonic = 3,
    /// All five terms.
    Full = 5,
}

impl SwingTerms {
    /// Number of coefficients fitted.
    pub fn count(self) -> usize {
        self as usize
    }
}

/// Why a swing fit failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SwingError {
    /// Fewer usable (finite, aligned) heading pairs than needed.
    TooFewSamples {
        /// Pairs available.
        have: u32,
        /// Pairs needed.
        need: u32,
    },
    /// The data do not determine the chosen terms.
    IllConditioned,
    /// The heading hardly changes while the reference is available, so a
    /// delay between reference and magnetometer cannot be measured.
    DelayUnobservable,
    /// Delay search parameters are not positive and finite.
    BadDelayRange,
}

impl From<SolveError> for SwingError {
    fn from(e: SolveError) -> Self {
        match e {
            SolveError::TooFewSamples { have, need } => SwingError::TooFewSamples { have, need },
            SolveError::IllConditioned { .. } => SwingError::IllConditioned,
        }
    }
}

impl core::fmt::Display for SwingError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SwingError::TooFewSamples { have, need } => {
                write!(f, "too few heading/reference pairs: {have}, at least {need} needed")
            }
            SwingError::IllConditioned => f.write_str("the headings recorded do not determine the swing terms"),
            SwingError::DelayUnobservable => f.write_str(
                "the heading hardly changes while the reference is available: the reference delay cannot be estimated; give it with --delay-s",
            ),
            SwingError::BadDelayRange => f.write_str("the delay search range must be finite and not empty, with a positive step"),
        }
    }
}

/// Compass sectors for deciding which terms the data determine.
pub const SECTORS: u32 = 12;

/// How the headings are spread round the compass.
///
/// Two measures decide which Fourier terms the data determine:
/// * sectors: a 30° sector counts as *visited* only when it holds a fair
///   share of the pairs ([`MIN_SECTOR_SHARE`]) — a turn swept through at the
///   surface gives a few pairs in many sectors but determines nothing there;
/// * spread of each harmonic: the smaller eigenvalue of the covariance of
///   `(cos kψ, sin kψ)` (0.5 for headings all round, 0 when the k-th
///   harmonic's phasors lie on a line). Reciprocal legs give 0 for k = 1:
///   on an out-and-back run the current's crab angle (course over ground −
///   heading) flips sign between the legs exactly as a first-harmonic
///   deviation would, so such data determine A only.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct HeadingSectors {
    counts: [u32; SECTORS as usize],
    /// Σ cos kψ, Σ sin kψ, Σ cos² kψ, Σ sin² kψ, Σ cos kψ sin kψ for k = 1, 2
    /// (`f32`: a decision statistic, and cheap on the MCU).
    moments: [[f32; 5]; 2],
}

/// Smallest harmonic spread (see [`HeadingSectors`]) for a harmonic to be fitted.
pub const MIN_HARMONIC_SPREAD: f64 = 0.08;

/// Share of all pairs a sector needs to count as visited: about ¾ of what an
/// even swing through the compass puts in each of the 12 sectors (8.3 %), so
/// a turn swept through once does not count.
pub const MIN_SECTOR_SHARE: f64 = 0.06;

impl HeadingSectors {
    /// Counts a heading.
    pub fn add<T: Real>(&mut self, heading_rad: T) {
        let (s1, c1) = (heading_rad.sin(), heading_rad.cos());
        self.add_phasor(heading_rad, s1, c1);
    }

    /// Counts a heading whose sine and cosine are already known.
    pub fn add_phasor<T: Real>(&mut self, heading_rad: T, sin_heading: T, cos_heading: T) {
        let s = (wrap_two_pi(heading_rad) / T::TAU * T::from_f64(f64::from(SECTORS))).to_f64() as usize;
        if let Some(c) = self.counts.get_mut(s.min(SECTORS as usize - 1)) {
            *c = c.saturating_add(1);
        }
        let (s1, c1) = (sin_heading.to_f64() as f32, cos_heading.to_f64() as f32);
        let phasors = [(s1, c1), (2.0 * s1 * c1, c1 * c1 - s1 * s1)];
        for (m, (sn, cs)) in self.moments.iter_mut().zip(phasors) {
            m[0] += cs;
            m[1] += sn;
            m[2] += cs * cs;
            m[3] += sn * sn;
            m[4] += cs * sn;
        }
    }

    /// Spread of harmonic `k` (1 or 2): the smaller eigenvalue of the
    /// covariance of `(cos kψ, sin kψ)`.
    pub fn harmonic_spread(&self, k: usize) -> f64 {
        let n = f64::from(self.total());
        let Some(m) = self.moments.get(k.wrapping_sub(1)) else { return 0.0 };
        if n < 1.0 {
            return 0.0;
        }
        let m = m.map(f64::from);
        let (mc, ms) = (m[0] / n, m[1] / n);
        let (a, d, b) = (m[2] / n - mc * mc, m[3] / n - ms * ms, m[4] / n - mc * ms);
        let (tr, det) = (a + d, a * d - b * b);
        (tr / 2.0 - libm::sqrt((tr * tr / 4.0 - det).max(0.0))).max(0.0)
    }

    /// Pairs counted.
    pub fn total(&self) -> u32 {
        self.counts.iter().fold(0u32, |a, &c| a.saturating_add(c))
    }

    /// Bit mask of the sectors holding at least [`MIN_SECTOR_SHARE`] of the
    /// pairs (and at least 3).
    pub fn visited_mask(&self) -> u16 {
        let min = (f64::from(self.total()) * MIN_SECTOR_SHARE).max(3.0);
        let mut mask = 0u16;
        for (k, &c) in self.counts.iter().enumerate() {
            if f64::from(c) >= min {
                mask |= 1 << k;
            }
        }
        mask
    }

    /// Sectors visited.
    pub fn count(&self) -> u32 {
        self.visited_mask().count_ones()
    }

    /// The widest run of unvisited sectors, in sectors.
    pub fn largest_gap(&self) -> u32 {
        let mask = self.visited_mask();
        if mask == 0 {
            return SECTORS;
        }
        let (mut best, mut run) = (0, 0);
        for k in 0..2 * SECTORS {
            if mask & (1 << (k % SECTORS)) == 0 {
                run += 1;
                best = best.max(run.min(SECTORS));
            } else {
                run = 0;
            }
        }
        best
    }

    /// The terms these headings determine: all five need at least half the
    /// compass with no gap over 90° and both harmonics spread; the first
    /// harmonic needs three sectors, no gap over 180° and its spread (two
    /// reciprocal legs are not enough, see above).
    pub fn determinable_terms(&self) -> SwingTerms {
        let (n, gap) = (self.count(), self.largest_gap());
        let (s1, s2) = (self.harmonic_spread(1), self.harmonic_spread(2));
        if n >= 6 && gap <= 3 && s1 >= MIN_HARMONIC_SPREAD && s2 >= MIN_HARMONIC_SPREAD {
            SwingTerms::Full
        } else if n >= 3 && gap <= 6 && s1 >= MIN_HARMONIC_SPREAD {
            SwingTerms::FirstHarmonic
        } else {
            SwingTerms::ConstantOnly
        }
    }
}

/// Regressors of eq 20 for one heading.
pub fn swing_row<T: Real>(heading_rad: T) -> [T; 5] {
    let (s1, c1) = (heading_rad.sin(), heading_rad.cos());
    let two = T::from_f64(2.0);
    [T::ONE, s1, c1, two * s1 * c1, c1 * c1 - s1 * s1]
}

/// A swing fit and what it could determine.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SwingFit<T> {
    /// The coefficients (terms not determined are zero).
    pub swing: Swing<T>,
    /// Which terms were fitted.
    pub terms: SwingTerms,
    /// The A-only sanity fit: circular mean of the wrapped differences.
    pub a_only_rad: T,
    /// Pairs used.
    pub samples: u32,
    /// RMS of the wrapped residual after correction, radians.
    pub residual_rms_rad: T,
    /// RMS of the wrapped difference before correction, radians.
    pub before_rms_rad: T,
    /// Compass sectors visited.
    pub sectors: HeadingSectors,
}

/// Accumulates heading pairs sample by sample over either least-squares
/// engine ([`NormalEquations`] for the batch reference, [`QrRls`] for the
/// recursive `f32` form).
#[derive(Debug, Clone)]
pub struct SwingAccumulator<T, E> {
    ls: E,
    sectors: HeadingSectors,
    sum_sin: T,
    sum_cos: T,
    sum_sq: T,
}

/// Batch swing fit (normal equations).
pub type SwingBatch<T> = SwingAccumulator<T, NormalEquations<T, 5>>;
/// Recursive swing fit (square-root RLS).
pub type SwingRls<T> = SwingAccumulator<T, QrRls<T, 5>>;

impl<T: Real, E: LeastSquares<T, 5> + Default> Default for SwingAccumulator<T, E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real, E: LeastSquares<T, 5> + Default> SwingAccumulator<T, E> {
    /// Empty.
    pub fn new() -> Self {
        Self { ls: E::default(), sectors: HeadingSectors::default(), sum_sin: T::ZERO, sum_cos: T::ZERO, sum_sq: T::ZERO }
    }

    /// Adds one pair: `heading_rad` from the (field-calibrated) magnetometer
    /// and the reference heading, both in radians. Non-finite pairs are
    /// refused (`false`).
    pub fn push(&mut self, heading_rad: T, reference_rad: T) -> bool {
        if !heading_rad.is_finite() || !reference_rad.is_finite() {
            return false;
        }
        let d = wrap_pi(reference_rad - heading_rad);
        let row = swing_row(heading_rad);
        if !self.ls.update(&row, d) {
            return false;
        }
        self.sectors.add_phasor(heading_rad, row[1], row[2]);
        self.sum_sin += d.sin();
        self.sum_cos += d.cos();
        self.sum_sq += d * d;
        true
    }

    /// Pairs absorbed.
    pub fn count(&self) -> u32 {
        self.ls.count()
    }

    /// The fit with the terms the headings determine. `residual_rms_rad` is
    /// left at zero here; [`fit_swing`] fills it from a second pass.
    pub fn estimate(&self) -> Result<SwingFit<T>, SwingError> {
        let n = self.ls.count();
        if n < 5 {
            return Err(SwingError::TooFewSamples { have: n, need: 5 });
        }
        let mut terms = self.sectors.determinable_terms();
        let x = loop {
            match self.ls.solve_leading(terms.count()) {
                Ok(x) => break x,
                Err(_) if terms == SwingTerms::Full => terms = SwingTerms::FirstHarmonic,
                Err(_) if terms == SwingTerms::FirstHarmonic => terms = SwingTerms::ConstantOnly,
                Err(e) => return Err(e.into()),
            }
        };
        let nn = T::from_f64(f64::from(n));
        Ok(SwingFit {
            swing: Swing::from_array(x),
            terms,
            a_only_rad: self.sum_sin.atan2(self.sum_cos),
            samples: n,
            residual_rms_rad: T::ZERO,
            before_rms_rad: (self.sum_sq / nn).sqrt(),
            sectors: self.sectors,
        })
    }
}

/// Batch swing fit over `(heading, reference)` pairs, with the residual RMS
/// after correction.
pub fn fit_swing<T: Real, I>(pairs: I) -> Result<SwingFit<T>, SwingError>
where
    I: IntoIterator<Item = (T, T)> + Clone,
{
    let mut acc = SwingBatch::<T>::new();
    for (h, r) in pairs.clone() {
        acc.push(h, r);
    }
    let mut fit = acc.estimate()?;
    let (mut n, mut ss) = (0u32, T::ZERO);
    for (h, r) in pairs {
        if h.is_finite() && r.is_finite() {
            let e = wrap_pi(r - fit.swing.apply(h));
            ss += e * e;
            n += 1;
        }
    }
    fit.residual_rms_rad = (ss / T::from_f64(f64::from(n.max(1)))).sqrt();
    Ok(fit)
}

/// The magnetometer heading at time `at_s`, interpolated along the shorter
/// arc between the neighbouring samples. `times_s` must be non-decreasing.
/// `None` outside the recording or across a gap longer than `max_gap_s`.
pub fn heading_at<T: Real>(times_s: &[T], headings_rad: &[T], at_s: T, max_gap_s: T) -> Option<T> {
    crate::series::interp_angle(times_s, headings_rad, at_s, max_gap_s)
}

/// Pairs each finite reference sample at `t` with the magnetometer heading
/// at `t − delay_s`.
pub fn aligned_pairs<'a, T: Real>(
    mag_t: &'a [T],
    mag_heading: &'a [T],
    ref_t: &'a [T],
    ref_heading: &'a [T],
    delay_s: T,
    max_gap_s: T,
) -> impl Iterator<Item = (T, T)> + Clone + 'a {
    ref_t.iter().zip(ref_heading.iter()).filter_map(move |(&t, &r)| {
        if !r.is_finite() || !t.is_finite() {
            return None;
        }
        heading_at(mag_t, mag_heading, t - delay_s, max_gap_s).map(|h| (h, r))
    })
}

/// Result of the delay search.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DelayEstimate<T> {
    /// The delay of the reference behind the magnetometer, seconds.
    pub delay_s: T,
    /// Residual RMS of the swing fit at that delay, radians.
    pub residual_rms_rad: T,
}

/// Finds the reference delay in `[min_delay_s, max_delay_s]` that minimises
/// the swing fit's residual: a wrong delay shifts the reference against the
/// magnetometer while the vehicle turns, and no Fourier term can absorb that.
/// A negative delay is a reference ahead of the heading: a damped compass
/// lags a GPS course taken on straight legs. The scan uses `step_s`; the
/// minimum is refined by a parabola through its neighbours.
pub fn estimate_delay<T: Real>(
    mag_t: &[T],
    mag_heading: &[T],
    ref_t: &[T],
    ref_heading: &[T],
    (min_delay_s, max_delay_s): (T, T),
    step_s: T,
    max_gap_s: T,
) -> Result<DelayEstimate<T>, SwingError> {
    if !(max_delay_s > min_delay_s && step_s > T::ZERO && min_delay_s.is_finite() && max_delay_s.is_finite() && step_s.is_finite()) {
        return Err(SwingError::BadDelayRange);
    }
    let steps = ((max_delay_s - min_delay_s) / step_s).to_f64().min(10_000.0) as u32;
    let rms_at = |d: T| fit_swing(aligned_pairs(mag_t, mag_heading, ref_t, ref_heading, d, max_gap_s)).map(|f| f.residual_rms_rad);
    let at = |k: u32| min_delay_s + step_s * T::from_f64(f64::from(k));
    let (mut best_k, mut best, mut worst) = (0u32, T::from_f64(f64::INFINITY), T::ZERO);
    for k in 0..=steps {
        let r = rms_at(at(k))?;
        if r < best {
            best = r;
            best_k = k;
        }
        worst = worst.max(r);
    }
    // A flat curve means the delay does not change the residual: the heading
    // did not turn while the reference was there.
    if !(worst - best > T::from_f64(0.05) * best + T::from_f64(1e-4)) {
        return Err(SwingError::DelayUnobservable);
    }
    let mut delay = at(best_k);
    if best_k > 0 && best_k < steps {
        let (l, r) = (rms_at(delay - step_s)?, rms_at(delay + step_s)?);
        let denom = l - T::from_f64(2.0) * best + r;
        if denom > T::ZERO {
            let shift = (l - r) / (T::from_f64(2.0) * denom);
            delay += step_s * shift.max(-T::ONE).min(T::ONE);
        }
    }
    let residual = rms_at(delay)?;
    Ok(DelayEstimate { delay_s: delay, residual_rms_rad: residual })
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    /// The paper's Table 7 coefficients.
    const PAPER: Swing<f64> = Swing { a: 0.14199, b: -0.01101, c: 0.01071, d: 0.00610, e: 0.05528 };

    /// The magnetometer heading ψ̂ that the swing correction maps to the true
    /// heading ψ: solves ψ = ψ̂ + δψ(ψ̂) by fixed-point iteration.
    fn distorted(true_rad: f64, s: &Swing<f64>) -> f64 {
        let mut h = true_rad;
        for _ in 0..60 {
            h = true_rad - s.correction_rad(h);
        }
        wrap_two_pi(h)
    }

    #[test]
    fn recovers_the_papers_table_7_coefficients_exactly() {
        let pairs: Vec<(f64, f64)> = (0..360).map(|k| {
            let psi = (k as f64).to_radians();
            (distorted(psi, &PAPER), psi)
        }).collect();
        let fit = fit_swing(pairs.iter().copied()).unwrap();
        assert_eq!(fit.terms, SwingTerms::Full);
        for (a, b) in fit.swing.to_array().iter().zip(PAPER.to_array()) {
            assert!((a - b).abs() < 1e-9, "{:?}", fit.swing);
        }
        assert!(fit.residual_rms_rad < 1e-9);
        // The A-only sanity fit lands near A (the paper: ≈ 7.5° offset).
        assert!((fit.a_only_rad - PAPER.a).abs() < 0.01);
    }

    #[test]
    fn recursive_f32_matches_batch() {
        let mut rls = SwingRls::<f32>::new();
        let mut pairs = Vec::new();
        for k in 0..720 {
            let psi = (k as f64 * 0.5).to_radians();
            let h = distorted(psi, &PAPER);
            rls.push(h as f32, psi as f32);
            pairs.push((h, psi));
        }
        let a = rls.estimate().unwrap();
        let b = fit_swing(pairs.iter().copied()).unwrap();
        for (x, y) in a.swing.to_array().iter().zip(b.swing.to_array()) {
            assert!((f64::from(*x) - y).abs() < 1e-5);
        }
    }

    #[test]
    fn narrow_headings_fit_only_what_they_determine() {
        // Headings within 60°: only A.
        let narrow: Vec<(f64, f64)> = (0..200).map(|k| {
            let psi = 1.0 + (k as f64 / 200.0) * PI / 3.0;
            (distorted(psi, &PAPER), psi)
        }).collect();
        let fit = fit_swing(narrow.iter().copied()).unwrap();
        assert_eq!(fit.terms, SwingTerms::ConstantOnly);
        assert_eq!(fit.swing.b, 0.0);
        // Out-and-back legs 180° apart with a little weaving: A only (the
        // current's crab angle would alias into B and C).
        let legs: Vec<(f64, f64)> = (0..400).map(|k| {
            let base = if k % 2 == 0 { 62f64 } else { -117f64 };
            let psi = (base + 10.0 * ((k as f64) * 0.37).sin()).to_radians();
            (distorted(psi, &PAPER), psi)
        }).collect();
        let fit = fit_swing(legs.iter().copied()).unwrap();
        assert_eq!(fit.terms, SwingTerms::ConstantOnly);
        // Four courses, a square: the first harmonic.
        let square: Vec<(f64, f64)> = (0..400).map(|k| {
            let psi = (f64::from((k % 4) as u8) * 90.0 + 20.0 + 5.0 * ((k as f64) * 0.37).sin()).to_radians();
            (distorted(psi, &PAPER), psi)
        }).collect();
        assert_eq!(fit_swing(square.iter().copied()).unwrap().terms, SwingTerms::FirstHarmonic);
    }

    #[test]
    fn sector_gaps_wrap_around_north() {
        let mut s = HeadingSectors::default();
        for deg in [350.0f64, 10.0, 40.0] {
            for _ in 0..10 {
                s.add(deg.to_radians());
            }
        }
        assert_eq!(s.count(), 3);
        assert_eq!(s.largest_gap(), 9);
        // A sweep through other sectors with a few pairs each does not count.
        for deg in (60..300).step_by(30) {
            s.add(f64::from(deg).to_radians());
        }
        assert_eq!(s.count(), 3);
    }

    #[test]
    fn interpolation_takes_the_short_way_round() {
        let t = [0.0, 1.0];
        let h = [350f64.to_radians(), 10f64.to_radians()];
        let mid = heading_at(&t, &h, 0.5, 2.0).unwrap();
        assert!(wrap_pi(mid - 0.0).abs() < 1e-12);
        assert!(heading_at(&t, &h, 1.5, 2.0).is_none());
        assert!(heading_at(&t, &h, 0.5, 0.5).is_none(), "gap longer than allowed");
    }

    /// A vehicle turning at varying rates, reference delayed by `delay`.
    fn turning_run(delay: f64) -> (Vec<f64>, Vec<f64>, Vec<f64>, Vec<f64>) {
        let dt = 0.1;
        let (mut mt, mut mh, mut rt, mut rh) = (vec![], vec![], vec![], vec![]);
        let truth = |t: f64| wrap_two_pi(0.8 * t + 0.6 * (0.3 * t).sin());
        for k in 0..3000 {
            let t = k as f64 * dt;
            mt.push(t);
            mh.push(distorted(truth(t), &PAPER));
            // Reference only at the "surface" (every other 30 s), delayed.
            if ((t / 30.0) as u32).is_multiple_of(2) {
                rt.push(t);
                rh.push(truth(t - delay));
            } else {
                rt.push(t);
                rh.push(f64::NAN);
            }
        }
        (mt, mh, rt, rh)
    }

    #[test]
    fn the_reference_delay_is_estimated() {
        let (mt, mh, rt, rh) = turning_run(2.0);
        let est = estimate_delay(&mt, &mh, &rt, &rh, (0.0, 5.0), 0.25, 1.0).unwrap();
        assert!((est.delay_s - 2.0).abs() < 0.05, "{est:?}");
        let fit = fit_swing(aligned_pairs(&mt, &mh, &rt, &rh, est.delay_s, 1.0)).unwrap();
        for (a, b) in fit.swing.to_array().iter().zip(PAPER.to_array()) {
            assert!((a - b).abs() < 2e-3, "{:?}", fit.swing);
        }
        // Ignoring the delay leaves a large residual.
        let naive = fit_swing(aligned_pairs(&mt, &mh, &rt, &rh, 0.0, 1.0)).unwrap();
        assert!(naive.residual_rms_rad > 10.0 * fit.residual_rms_rad.max(1e-4));
    }

    #[test]
    fn a_reference_ahead_of_the_heading_is_a_negative_delay() {
        // The reference 1.5 s *ahead* (a damped compass behind a course):
        // the run's reference taken at t + 1.5 s, searched over ±5 s.
        let (mt, mh, rt, _) = turning_run(0.0);
        let (_, _, _, rh) = turning_run(-1.5);
        let est = estimate_delay(&mt, &mh, &rt, &rh, (-5.0, 5.0), 0.25, 1.0).unwrap();
        assert!((est.delay_s + 1.5).abs() < 0.05, "{est:?}");
        // Searched over [0, 5] only, the edge.
        assert_eq!(estimate_delay(&mt, &mh, &rt, &rh, (0.0, 5.0), 0.25, 1.0).unwrap().delay_s, 0.0);
        assert_eq!(estimate_delay(&mt, &mh, &rt, &rh, (1.0, 1.0), 0.25, 1.0), Err(SwingError::BadDelayRange));
    }

    #[test]
    fn a_straight_run_cannot_reveal_the_delay() {
        let t: Vec<f64> = (0..1000).map(|k| k as f64 * 0.1).collect();
        let h = vec![1.0; 1000];
        assert_eq!(estimate_delay(&t, &h, &t, &h, (0.0, 5.0), 0.25, 1.0), Err(SwingError::DelayUnobservable));
    }
}
