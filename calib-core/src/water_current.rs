//! The water current from surface GPS fixes, and GPS course turned into
//! heading before the swing fit.
//!
//! GPS course over ground is not heading: the ground velocity is
//! `v_g = s·(cos ψ, sin ψ) + c` (north, east) with `s` the speed through
//! water, `ψ` the true heading and `c` the current. In 0.1–0.3 m/s of
//! current a vehicle at 0.5–1.5 m/s crabs by 4–30°, and a swing fit against
//! course imports the current into its first harmonic (the crab angle is
//! `≈ (c_E cos ψ − c_N sin ψ)/s`, a first harmonic in ψ).
//!
//! **The current.** Integrating the model, each fix `p(t)` (local north/east
//! metres) minus the water track `W(t) = ∫ s·u(ψ) dt` is `p₀ + c·t`: within a
//! stretch of consecutive fixes (a *segment*, its own `p₀`) the current is
//! the slope of `p − W` against time, pooled over segments
//! ([`CurrentAccumulator`]). A constant heading error rotates the water
//! track, which on a straight leg looks exactly like a current across it;
//! over a circle it averages out, so the estimate needs the headings at the
//! fixes to go round ([`MAX_HEADING_RESULTANT`], [`CurrentError::NoCircle`]).
//!
//! **The heading.** With the current known, the water velocity is
//! `v_g − c`, and from the course `χ` and the speed through water the ground
//! speed `g` solves `|g·u(χ) − c| = s`; the heading is the direction of
//! `g·u(χ) − c` ([`heading_from_course`]).
//!
//! **Both at once.** The water track uses the magnetometer heading, which
//! the swing fit corrects: [`fit_swing_in_current`] starts from the swing
//! fit against raw course, estimates the current with the corrected
//! headings, turns course into heading, refits, and repeats. A first-harmonic
//! heading error `δ` biases the water-track current by `s·δ/2` in the
//! matching direction and the converted reference then carries half of
//! `δ`, so each round halves what is left of it; the loop stops when the
//! current moves by less than [`CONVERGED_MPS`].

use crate::swing::{fit_swing, heading_at, SwingError, SwingFit};
use crate::cal::Swing;
use crate::heading::{wrap_pi, wrap_two_pi};
use crate::Real;

/// Mean Earth radius for the local north/east plane, m.
pub const EARTH_RADIUS_M: f64 = 6_371_000.0;

/// Largest resultant `|Σ s·u(ψ)| / Σ s` of the water velocity at the fixes
/// for the current to be estimated: 0 for whole circles, 1 for a straight
/// leg, 0.30 for three quarters of a circle at constant speed.
pub const MAX_HEADING_RESULTANT: f64 = 0.35;

/// Fewest GPS fixes for a current estimate.
pub const MIN_FIXES: u32 = 20;

/// Shortest total time spanned by the segments' fixes, s.
pub const MIN_SPAN_S: f64 = 30.0;

/// Slowest speed through water at which course says anything about heading,
/// m/s (a vehicle drifting with the current has no crab angle to remove).
pub const MIN_SPEED_MPS: f64 = 0.1;

/// The alternation stops when the current moves less than this, m/s.
pub const CONVERGED_MPS: f64 = 1e-5;

/// Most rounds of the current/swing alternation.
pub const MAX_ROUNDS: u32 = 40;

/// Why the current could not be estimated.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CurrentError {
    /// Too few GPS fixes with a speed through water and a heading.
    TooFewFixes {
        /// Fixes usable.
        have: u32,
        /// Fixes needed.
        need: u32,
    },
    /// The fixes span too little time within their segments.
    TooShort {
        /// Total time spanned by the segments, s.
        span_s: f64,
        /// Time needed, s.
        need_s: f64,
    },
    /// The heading did not go round while the GPS was there: a heading
    /// error and a current cannot be told apart.
    NoCircle {
        /// `|Σ s·u(ψ)| / Σ s` at the fixes (0 for circles, 1 for a line).
        resultant: f64,
    },
}

impl core::fmt::Display for CurrentError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            CurrentError::TooFewFixes { have, need } => write!(
                f,
                "GPS too sparse for the water current: {have} surface fixes with speed through water and heading, at least {need} needed"
            ),
            CurrentError::TooShort { span_s, need_s } => write!(
                f,
                "GPS too sparse for the water current: the runs of consecutive surface fixes span {span_s:.0} s, at least {need_s:.0} s needed"
            ),
            CurrentError::NoCircle { resultant } => write!(
                f,
                "no circle at the surface: the heading did not go round while GPS was available (resultant {resultant:.2}, at most {MAX_HEADING_RESULTANT} needed), so the current cannot be told from a heading error; swim a full circle at the surface"
            ),
        }
    }
}

/// A current estimate.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CurrentEstimate<T> {
    /// The current towards north and east, m/s.
    pub current_ne_mps: [T; 2],
    /// Its 1σ, m/s, from the scatter of the fixes about the fitted tracks
    /// only (fixes taken as independent: correlated GPS errors, and what the
    /// swing fit leaves of the heading's first harmonic, `≈ s·δ/2`, are not
    /// in it).
    pub sigma_ne_mps: [T; 2],
    /// Fixes used.
    pub fixes: u32,
    /// Segments (runs of consecutive fixes) used.
    pub segments: u32,
    /// `|Σ s·u(ψ)| / Σ s` at the fixes.
    pub heading_resultant: T,
}

/// Local north/east metres of a position from a reference position
/// (equirectangular: adequate over the few kilometres of a calibration).
pub fn local_north_east_m<T: Real>(lat_deg: T, lon_deg: T, lat0_deg: T, lon0_deg: T) -> [T; 2] {
    let k = T::from_f64(EARTH_RADIUS_M) * T::PI / T::from_f64(180.0);
    let lat0 = lat0_deg * T::PI / T::from_f64(180.0);
    [(lat_deg - lat0_deg) * k, (lon_deg - lon0_deg) * k * lat0.cos()]
}

/// Per-axis regression sums of one segment (times relative to its first fix).
#[derive(Debug, Clone, Copy)]
struct Segment<T> {
    n: u32,
    t0: T,
    st: T,
    stt: T,
    sy: [T; 2],
    sty: [T; 2],
    syy: [T; 2],
}

impl<T: Real> Segment<T> {
    fn empty() -> Self {
        Self { n: 0, t0: T::ZERO, st: T::ZERO, stt: T::ZERO, sy: [T::ZERO; 2], sty: [T::ZERO; 2], syy: [T::ZERO; 2] }
    }
}

/// Accumulates surface fixes against the water track and estimates the
/// current: one pooled slope of `p − W` against time, with an intercept per
/// segment.
#[derive(Debug, Clone, Copy)]
pub struct CurrentAccumulator<T> {
    seg: Segment<T>,
    last_fix_t: T,
    max_fix_gap_s: T,
    // Pooled within-segment sums.
    sxx: T,
    sxy: [T; 2],
    syy: [T; 2],
    span_s: T,
    fixes: u32,
    segments: u32,
    water_sum: [T; 2],
    speed_sum: T,
}

impl<T: Real> CurrentAccumulator<T> {
    /// Empty; consecutive fixes more than `max_fix_gap_s` apart start a new
    /// segment.
    pub fn new(max_fix_gap_s: T) -> Self {
        Self {
            seg: Segment::empty(),
            last_fix_t: T::NAN,
            max_fix_gap_s,
            sxx: T::ZERO,
            sxy: [T::ZERO; 2],
            syy: [T::ZERO; 2],
            span_s: T::ZERO,
            fixes: 0,
            segments: 0,
            water_sum: [T::ZERO; 2],
            speed_sum: T::ZERO,
        }
    }

    /// Ends the current segment (the next fix starts a new one): call it
    /// when the water track cannot be continued (a missing speed or heading).
    pub fn break_segment(&mut self) {
        let s = self.seg;
        self.seg = Segment::empty();
        self.last_fix_t = T::NAN;
        if s.n < 2 {
            return;
        }
        let n = T::from_f64(f64::from(s.n));
        let sxx = s.stt - s.st * s.st / n;
        if !(sxx > T::ZERO) {
            return;
        }
        self.sxx += sxx;
        for k in 0..2 {
            self.sxy[k] += s.sty[k] - s.st * s.sy[k] / n;
            self.syy[k] += s.syy[k] - s.sy[k] * s.sy[k] / n;
        }
        self.span_s += (T::from_f64(12.0) * sxx / n).sqrt();
        self.segments += 1;
    }

    /// Adds a fix at `t_s` (the time the position describes): position and
    /// water track in local north/east metres, and the water velocity
    /// `s·u(ψ)` then (for the heading-diversity check).
    pub fn push_fix(&mut self, t_s: T, fix_ne_m: [T; 2], water_track_ne_m: [T; 2], water_velocity_ne_mps: [T; 2]) -> bool {
        let y = [fix_ne_m[0] - water_track_ne_m[0], fix_ne_m[1] - water_track_ne_m[1]];
        if !(t_s.is_finite() && y[0].is_finite() && y[1].is_finite()) {
            return false;
        }
        if !(t_s - self.last_fix_t <= self.max_fix_gap_s) {
            self.break_segment();
        }
        if self.seg.n == 0 {
            self.seg.t0 = t_s;
        }
        let tr = t_s - self.seg.t0;
        let s = &mut self.seg;
        s.n += 1;
        s.st += tr;
        s.stt += tr * tr;
        for k in 0..2 {
            s.sy[k] += y[k];
            s.sty[k] += tr * y[k];
            s.syy[k] += y[k] * y[k];
        }
        self.last_fix_t = t_s;
        self.fixes += 1;
        let [wn, we] = water_velocity_ne_mps;
        if wn.is_finite() && we.is_finite() {
            self.water_sum[0] += wn;
            self.water_sum[1] += we;
            self.speed_sum += (wn * wn + we * we).sqrt();
        }
        true
    }

    /// The current, once the fixes are all in (closes the last segment).
    pub fn estimate(&mut self) -> Result<CurrentEstimate<T>, CurrentError> {
        self.break_segment();
        if self.fixes < MIN_FIXES {
            return Err(CurrentError::TooFewFixes { have: self.fixes, need: MIN_FIXES });
        }
        if !(self.span_s.to_f64() >= MIN_SPAN_S) {
            return Err(CurrentError::TooShort { span_s: self.span_s.to_f64(), need_s: MIN_SPAN_S });
        }
        let resultant = if self.speed_sum > T::ZERO {
            (self.water_sum[0] * self.water_sum[0] + self.water_sum[1] * self.water_sum[1]).sqrt() / self.speed_sum
        } else {
            T::ONE
        };
        if !(resultant.to_f64() <= MAX_HEADING_RESULTANT) {
            return Err(CurrentError::NoCircle { resultant: resultant.to_f64() });
        }
        let c = [self.sxy[0] / self.sxx, self.sxy[1] / self.sxx];
        // Degrees of freedom: fixes less one intercept per segment and the slope.
        let dof = T::from_f64(f64::from(self.fixes.saturating_sub(self.segments + 1).max(1)));
        let sigma = [0, 1].map(|k| {
            let rss = (self.syy[k] - self.sxy[k] * self.sxy[k] / self.sxx).max(T::ZERO);
            (rss / dof / self.sxx).sqrt()
        });
        Ok(CurrentEstimate {
            current_ne_mps: c,
            sigma_ne_mps: sigma,
            fixes: self.fixes,
            segments: self.segments,
            heading_resultant: resultant,
        })
    }
}

/// The heading (true, radians) that with speed through water `speed_mps`
/// and the current gives the course over ground `course_rad`: the direction
/// of `g·u(χ) − c` with `|g·u(χ) − c| = s`, `g ≥ 0`. `None` when the vehicle
/// is too slow ([`MIN_SPEED_MPS`]) or the current is faster than the vehicle
/// across this course (no such heading).
pub fn heading_from_course<T: Real>(course_rad: T, speed_mps: T, current_ne_mps: [T; 2]) -> Option<T> {
    if !(speed_mps >= T::from_f64(MIN_SPEED_MPS)) || !course_rad.is_finite() {
        return None;
    }
    let (un, ue) = (course_rad.cos(), course_rad.sin());
    let [cn, ce] = current_ne_mps;
    let along = un * cn + ue * ce;
    let disc = along * along - (cn * cn + ce * ce) + speed_mps * speed_mps;
    if !(disc >= T::ZERO) {
        return None;
    }
    let g = along + disc.sqrt();
    if g < T::ZERO {
        return None;
    }
    Some(wrap_two_pi((g * ue - ce).atan2(g * un - cn)))
}

/// A recording's columns for the swing fit in a current. All slices are
/// indexed by row; NaN marks a missing value.
#[derive(Debug, Clone, Copy)]
pub struct SurfaceTrack<'a, T> {
    /// Sample times, non-decreasing, s.
    pub t_s: &'a [T],
    /// Magnetometer heading (field-calibrated, tilt-compensated, no swing), rad.
    pub mag_heading_rad: &'a [T],
    /// Speed through water, m/s.
    pub speed_mps: &'a [T],
    /// GPS position, local north metres (NaN without a fix).
    pub north_m: &'a [T],
    /// GPS position, local east metres.
    pub east_m: &'a [T],
    /// GPS course over ground, true, rad (NaN where it is not to be used
    /// for the swing terms, e.g. while turning).
    pub course_rad: &'a [T],
    /// Declination: true heading = magnetic heading + declination, rad.
    pub declination_rad: T,
    /// Delay of the GPS (course and position) behind the magnetometer, s.
    pub delay_s: T,
    /// Longest gap across which the magnetometer heading and the speed are
    /// interpolated, s.
    pub max_gap_s: T,
    /// Consecutive fixes further apart than this start a new segment, s.
    pub max_fix_gap_s: T,
}

/// The current with the magnetometer heading corrected by `swing` (and the
/// declination) for the water track.
pub fn estimate_current<T: Real>(track: &SurfaceTrack<'_, T>, swing: &Swing<T>) -> Result<CurrentEstimate<T>, CurrentError> {
    let mut acc = CurrentAccumulator::new(track.max_fix_gap_s);
    let water_velocity = |i: usize| -> Option<[T; 2]> {
        let (h, s) = (*track.mag_heading_rad.get(i)?, *track.speed_mps.get(i)?);
        if !(h.is_finite() && s.is_finite()) {
            return None;
        }
        let psi = swing.apply(h) + track.declination_rad;
        Some([s * psi.cos(), s * psi.sin()])
    };
    let fix = |j: usize| -> Option<(T, [T; 2])> {
        let (t, n, e) = (*track.t_s.get(j)?, *track.north_m.get(j)?, *track.east_m.get(j)?);
        (t.is_finite() && n.is_finite() && e.is_finite()).then_some((t - track.delay_s, [n, e]))
    };
    let rows = track.t_s.len();
    let half = T::from_f64(0.5);
    // The water track W integrated row by row (trapezoids); a missing speed
    // or heading, or a gap, restarts it and the fixes' segment.
    let mut prev: Option<(T, [T; 2], [T; 2])> = None; // (t, W, s·u(ψ)) at the previous row
    let mut j = 0usize; // next row whose fix is to be placed
    for (i, &ti) in track.t_s.iter().enumerate() {
        let cur = water_velocity(i).map(|v| match prev {
            Some((tp, wp, vp)) if ti >= tp && ti - tp <= track.max_gap_s => {
                let dt = ti - tp;
                (ti, [wp[0] + half * dt * (vp[0] + v[0]), wp[1] + half * dt * (vp[1] + v[1])], v)
            }
            _ => (ti, [T::ZERO; 2], v),
        });
        let continuous = matches!((prev, cur), (Some((tp, ..)), Some(_)) if ti >= tp && ti - tp <= track.max_gap_s);
        if !continuous {
            acc.break_segment();
        }
        // Place every fix whose position time falls in (t_prev, t_i].
        while j < rows {
            let Some((at, p)) = fix(j) else {
                j += 1;
                continue;
            };
            if at > ti {
                break;
            }
            match (prev, cur) {
                (Some((tp, wp, vp)), Some((_, wc, vc))) if continuous && at >= tp => {
                    let f = if ti > tp { (at - tp) / (ti - tp) } else { T::ONE };
                    let w_at = [wp[0] + f * (wc[0] - wp[0]), wp[1] + f * (wc[1] - wp[1])];
                    let v_at = [vp[0] + f * (vc[0] - vp[0]), vp[1] + f * (vc[1] - vp[1])];
                    acc.push_fix(at, p, w_at, v_at);
                }
                (_, Some((_, wc, vc))) if at == ti => {
                    acc.push_fix(at, p, wc, vc);
                }
                _ => {}
            }
            j += 1;
        }
        prev = cur;
    }
    acc.estimate()
}

/// The swing fit against course turned into heading, and the current.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CurrentSwingFit<T> {
    /// The swing fit against heading (course less the crab angle).
    pub fit: SwingFit<T>,
    /// The current the fit was converted with.
    pub current: CurrentEstimate<T>,
    /// The swing fit against raw course (today's fit, for comparison).
    pub course_fit: SwingFit<T>,
    /// Rounds of the current/swing alternation.
    pub rounds: u32,
    /// Whether the current settled within [`CONVERGED_MPS`].
    pub converged: bool,
}

/// Why the swing fit in a current failed.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CurrentSwingError<T> {
    /// The swing fit itself (against raw course) failed.
    Swing(SwingError),
    /// The current could not be estimated; `course_fit` is the fit against
    /// raw course, the fallback.
    Current {
        /// Why.
        error: CurrentError,
        /// The swing fit against raw course.
        course_fit: SwingFit<T>,
    },
}

/// The swing pairs `(magnetometer heading, reference)` with the reference
/// the course turned into magnetic heading with `current`.
pub fn heading_pairs<'a, T: Real>(track: &'a SurfaceTrack<'a, T>, current_ne_mps: [T; 2]) -> impl Iterator<Item = (T, T)> + Clone + 'a {
    track.t_s.iter().zip(track.course_rad.iter()).filter_map(move |(&t, &course)| {
        if !(t.is_finite() && course.is_finite()) {
            return None;
        }
        let at = t - track.delay_s;
        let h = heading_at(track.t_s, track.mag_heading_rad, at, track.max_gap_s)?;
        let s = crate::series::interp_linear(track.t_s, track.speed_mps, at, track.max_gap_s)?;
        let psi = heading_from_course(course, s, current_ne_mps)?;
        Some((h, wrap_pi(psi - track.declination_rad)))
    })
}

/// The swing fit with course turned into heading: alternates the current
/// (water track with the swing-corrected heading) and the swing fit against
/// the converted course until the current settles (see the module's notes).
pub fn fit_swing_in_current<T: Real>(track: &SurfaceTrack<'_, T>) -> Result<CurrentSwingFit<T>, CurrentSwingError<T>> {
    let raw = track.t_s.iter().zip(track.course_rad.iter()).map(|(&t, &c)| (t, wrap_pi(c - track.declination_rad)));
    let course_fit = fit_swing(raw.clone().filter_map(|(t, r)| {
        heading_at(track.t_s, track.mag_heading_rad, t - track.delay_s, track.max_gap_s).map(|h| (h, r))
    }))
    .map_err(CurrentSwingError::Swing)?;
    let mut swing = course_fit.swing;
    let mut last: Option<[T; 2]> = None;
    let mut rounds = 0u32;
    let mut converged = false;
    let mut result: Option<(SwingFit<T>, CurrentEstimate<T>)> = None;
    while rounds < MAX_ROUNDS {
        rounds += 1;
        let current = match estimate_current(track, &swing) {
            Ok(c) => c,
            Err(error) => return Err(CurrentSwingError::Current { error, course_fit }),
        };
        let fit = fit_swing(heading_pairs(track, current.current_ne_mps)).map_err(CurrentSwingError::Swing)?;
        swing = fit.swing;
        let c = current.current_ne_mps;
        result = Some((fit, current));
        if let Some(l) = last {
            let moved = ((c[0] - l[0]) * (c[0] - l[0]) + (c[1] - l[1]) * (c[1] - l[1])).sqrt();
            if moved.to_f64() < CONVERGED_MPS {
                converged = true;
                break;
            }
        }
        last = Some(c);
    }
    match result {
        Some((fit, current)) => Ok(CurrentSwingFit { fit, current, course_fit, rounds, converged }),
        None => Err(CurrentSwingError::Swing(SwingError::TooFewSamples { have: 0, need: 5 })),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's Table 7 coefficients (ALGORITHMS.md §3).
    const PAPER: Swing<f64> = Swing { a: 0.14199, b: -0.01101, c: 0.01071, d: 0.00610, e: 0.05528 };
    const DECL_RAD: f64 = 0.05;
    const CURRENT: [f64; 2] = [0.20, -0.12];

    /// The magnetometer heading whose swing correction is the true magnetic
    /// heading (fixed point of ψ = ψ̂ + δψ(ψ̂)).
    fn distorted(true_rad: f64) -> f64 {
        let mut h = true_rad;
        for _ in 0..60 {
            h = true_rad - PAPER.correction_rad(h);
        }
        wrap_two_pi(h)
    }

    /// Deterministic Gaussian noise (LCG + Box–Muller).
    struct Noise(u64);
    impl Noise {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((self.0 >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        }
        fn gauss(&mut self) -> f64 {
            let (u, v) = (self.uniform(), self.uniform());
            (-2.0 * u.ln()).sqrt() * (core::f64::consts::TAU * v).cos()
        }
    }

    struct Run {
        t: Vec<f64>,
        mag: Vec<f64>,
        speed: Vec<f64>,
        north: Vec<f64>,
        east: Vec<f64>,
        course: Vec<f64>,
    }

    /// A vehicle at the surface turning slowly (`rate_rad_s`), speed through
    /// water 0.8–1.2 m/s, in `CURRENT`; GPS (position σ 1.5 m, course σ 0.5°)
    /// every `gps_every` rows reports the state `delay_s` earlier. The
    /// positions are integrated from the heading, the speed and the current
    /// in 0.01 s steps.
    fn surface_run(duration_s: f64, rate_rad_s: f64, gps_every: usize, delay_s: f64, seed: u64) -> Run {
        let heading = |t: f64| 0.3 + rate_rad_s * t;
        let speed = |t: f64| 1.0 + 0.2 * (t / 97.0).sin();
        let ground = |t: f64| {
            let (s, psi) = (speed(t), heading(t));
            [s * psi.cos() + CURRENT[0], s * psi.sin() + CURRENT[1]]
        };
        let mut noise = Noise(seed);
        let dt = 0.5;
        let n = (duration_s / dt) as usize;
        // True positions at every 0.01 s, from t = −delay.
        let mut pos = vec![[0.0f64; 2]];
        let h = 0.01;
        let steps = ((duration_s + delay_s) / h) as usize + 2;
        for k in 0..steps {
            let t = -delay_s + k as f64 * h;
            let (a, b) = (ground(t), ground(t + h));
            let p = pos[k];
            pos.push([p[0] + 0.5 * h * (a[0] + b[0]), p[1] + 0.5 * h * (a[1] + b[1])]);
        }
        let pos_at = |t: f64| pos[((t + delay_s) / h).round() as usize];
        let mut r = Run { t: vec![], mag: vec![], speed: vec![], north: vec![], east: vec![], course: vec![] };
        for k in 0..n {
            let t = k as f64 * dt;
            r.t.push(t);
            r.mag.push(distorted(wrap_two_pi(heading(t) - DECL_RAD)));
            r.speed.push(speed(t));
            if k % gps_every == 0 {
                let p = pos_at(t - delay_s);
                let g = ground(t - delay_s);
                r.north.push(p[0] + 1.5 * noise.gauss());
                r.east.push(p[1] + 1.5 * noise.gauss());
                r.course.push(wrap_two_pi(g[1].atan2(g[0]) + 0.5f64.to_radians() * noise.gauss()));
            } else {
                r.north.push(f64::NAN);
                r.east.push(f64::NAN);
                r.course.push(f64::NAN);
            }
        }
        r
    }

    fn track(r: &Run, delay_s: f64) -> SurfaceTrack<'_, f64> {
        SurfaceTrack {
            t_s: &r.t,
            mag_heading_rad: &r.mag,
            speed_mps: &r.speed,
            north_m: &r.north,
            east_m: &r.east,
            course_rad: &r.course,
            declination_rad: DECL_RAD,
            delay_s,
            max_gap_s: 1.0,
            max_fix_gap_s: 5.0,
        }
    }

    #[test]
    fn the_crab_angle_is_removed_by_geometry() {
        // Heading 90° at 1 m/s in a 0.3 m/s current to the north: ground
        // velocity (0.3, 1), course atan2(1, 0.3).
        let course = 1.0f64.atan2(0.3);
        let psi = heading_from_course(course, 1.0, [0.3, 0.0]).unwrap();
        assert!((psi - core::f64::consts::FRAC_PI_2).abs() < 1e-12, "{psi}");
        assert_eq!(heading_from_course(0.0, 0.05, [0.0, 0.0]), None, "too slow");
        assert_eq!(heading_from_course(core::f64::consts::PI, 0.5, [2.0, 0.0]), None, "current faster than the vehicle");
    }

    #[test]
    fn current_and_all_five_swing_terms_from_surface_circles() {
        // Two slow circles (0.5°/s, 1440 s) with GPS at 1 Hz, 2 s late.
        let run = surface_run(1440.0, 0.5f64.to_radians(), 2, 2.0, 7);
        let tr = track(&run, 2.0);
        let res = fit_swing_in_current(&tr).unwrap();
        let c = res.current;
        // Measured: error 4e-4 and 5e-4 m/s (north, east); the 1σ from the
        // position scatter alone is 1e-4 m/s (what is left of the swing
        // fit's first harmonic, ≈ 1e-3 rad, biases the water track by s·δ/2).
        for k in 0..2 {
            assert!((c.current_ne_mps[k] - CURRENT[k]).abs() < 2e-3, "{c:?}");
            assert!(c.sigma_ne_mps[k] > 2e-5 && c.sigma_ne_mps[k] < 5e-4, "{c:?}");
        }
        assert!(res.converged, "{} rounds", res.rounds);
        assert_eq!(res.fit.terms, crate::swing::SwingTerms::Full);
        let err = |s: &Swing<f64>| {
            s.to_array().iter().zip(PAPER.to_array()).map(|(a, b)| (a - b).abs()).fold(0.0f64, f64::max)
        };
        let (with, without) = (err(&res.fit.swing), err(&res.course_fit.swing));
        // Measured: largest term error 9e-4 rad (C) with the current
        // removed; 0.19 rad (B, the crab angle ≈ |c|/s) against raw course.
        assert!(with < 2e-3, "{:?}", res.fit.swing);
        assert!(without > 0.1, "{:?}", res.course_fit.swing);
        assert!(with < without / 50.0);
    }

    #[test]
    fn a_straight_leg_cannot_separate_the_current() {
        let run = surface_run(600.0, 0.0, 2, 0.0, 3);
        match fit_swing_in_current(&track(&run, 0.0)) {
            Err(CurrentSwingError::Current { error: CurrentError::NoCircle { resultant }, .. }) => assert!(resultant > 0.99),
            // A straight leg also leaves the swing fit with A only, which is fine.
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn sparse_gps_is_named() {
        // A fix every 60 s: 24 fixes but segments of one fix each.
        let run = surface_run(1440.0, 0.5f64.to_radians(), 120, 0.0, 5);
        let err = estimate_current(&track(&run, 0.0), &PAPER).unwrap_err();
        assert!(matches!(err, CurrentError::TooShort { .. }), "{err:?}");
        // Fewer fixes than needed.
        let run = surface_run(300.0, 0.5f64.to_radians(), 60, 0.0, 5);
        let err = estimate_current(&track(&run, 0.0), &PAPER).unwrap_err();
        assert_eq!(err, CurrentError::TooFewFixes { have: 10, need: MIN_FIXES });
    }
}
