//! Pairing two streams by time: the board's field samples (on the board's
//! clock) with the navigation computer's rows (on its own clock). One module
//! for `magcal merge` (offline logs) and the live session
//! (`session::record`): the clock map between the two, where a time
//! falls among a stream's samples, interpolation (angles wrapped), and the
//! live nearest-sample pairer.
//!
//! Nothing here extrapolates: a time outside a stream's span, or in a gap
//! longer than the caller allows, has no value (NaN / `None`).

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

/// The map from the board's clock to the navigation clock:
/// `t_nav = t_board + offset_s + drift_ppm·10⁻⁶·(t_board − board_ref_s)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ClockMap {
    /// `t_nav − t_board` at `board_ref_s`, seconds.
    pub offset_s: f64,
    /// How much faster the navigation clock runs, parts per million.
    pub drift_ppm: f64,
    /// The board time the offset refers to, seconds (board clock).
    pub board_ref_s: f64,
}

impl ClockMap {
    /// A constant offset (no drift).
    pub fn offset(offset_s: f64) -> Self {
        Self { offset_s, drift_ppm: 0.0, board_ref_s: 0.0 }
    }

    /// The navigation time of a board time.
    pub fn to_nav(self, t_board_s: f64) -> f64 {
        t_board_s + self.offset_s + self.drift_ppm * 1e-6 * (t_board_s - self.board_ref_s)
    }

    /// The board time of a navigation time (the inverse of [`ClockMap::to_nav`]).
    pub fn to_board(self, t_nav_s: f64) -> f64 {
        let k = 1.0 + self.drift_ppm * 1e-6;
        (t_nav_s - self.offset_s + self.drift_ppm * 1e-6 * self.board_ref_s) / k
    }
}

/// Where a time falls among a stream's sample times: the samples before and
/// after it (`lo == hi` on an exact hit) and the weight of `hi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bracket {
    /// The sample at or before the time.
    pub lo: usize,
    /// The sample at or after the time.
    pub hi: usize,
    /// Weight of `hi` in a linear interpolation, 0…1.
    pub weight: f64,
}

impl Bracket {
    /// The nearer of the two samples.
    pub fn nearest(&self) -> usize {
        if self.weight > 0.5 {
            self.hi
        } else {
            self.lo
        }
    }

    /// Linear interpolation of `values`; NaN when either neighbour is NaN
    /// (a GPS course present only at the surface stays absent elsewhere).
    pub fn lerp(&self, values: &[f64]) -> f64 {
        let (a, b) = (values[self.lo], values[self.hi]);
        if self.lo == self.hi {
            return a;
        }
        a + (b - a) * self.weight
    }

    /// Interpolation of an angle in degrees the short way round, wrapped to
    /// 0…360 (`heading = true`) or −180…180 (roll). NaN when either
    /// neighbour is NaN.
    pub fn lerp_angle_deg(&self, values: &[f64], heading: bool) -> f64 {
        let (a, b) = (values[self.lo], values[self.hi]);
        let v = a + wrap180(b - a) * self.weight;
        if heading {
            v.rem_euclid(360.0)
        } else {
            wrap180(v)
        }
    }
}

/// An angle difference wrapped to −180…180 degrees (the degree twin of
/// [`calib_core::heading::wrap_pi`], kept in degrees so that degree columns
/// are not round-tripped through radians).
pub fn wrap180(deg: f64) -> f64 {
    (deg + 180.0).rem_euclid(360.0) - 180.0
}

/// The median of a stream's positive sample intervals, s (the one home of
/// "the recording's sample spacing"); `None` with fewer than two distinct
/// times. The median is [`calib_core::series::median`].
pub fn median_step_s(times_s: &[f64]) -> Option<f64> {
    let mut steps: Vec<f64> = times_s.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    calib_core::series::median(&mut steps)
}

/// Where `t` falls in the non-decreasing `times`. `None` outside the span
/// (never extrapolated) or when the two neighbours are more than
/// `max_gap_s` apart.
pub fn bracket(times: &[f64], t: f64, max_gap_s: f64) -> Option<Bracket> {
    // The one bracketing rule is calib-core's; this is its host form.
    Some(match calib_core::series::bracket(times, t, max_gap_s)? {
        calib_core::series::Bracket::At(i) => Bracket { lo: i, hi: i, weight: 0.0 },
        calib_core::series::Bracket::Between(lo, weight) => Bracket { lo, hi: lo + 1, weight },
    })
}

/// Live pairing by time: samples arrive in board-time order and each
/// navigation row takes the sample nearest its time on the board's clock,
/// never an older one than the previous row took. Memory and lag stay
/// bounded however much faster the board streams than the navigation
/// arrives: samples older than the one taken are dropped.
#[derive(Debug, Clone)]
pub struct TimePairer<S> {
    queue: VecDeque<(f64, S)>,
    /// Samples dropped without being paired (the board streams faster than
    /// the navigation).
    pub skipped: u64,
}

impl<S> Default for TimePairer<S> {
    fn default() -> Self {
        Self { queue: VecDeque::new(), skipped: 0 }
    }
}

impl<S> TimePairer<S> {
    /// An empty pairer.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a sample taken at `t_board_s` (board clock, non-decreasing).
    pub fn push(&mut self, t_board_s: f64, sample: S) {
        self.queue.push_back((t_board_s, sample));
    }

    /// The board time of the newest sample held.
    pub fn newest_s(&self) -> Option<f64> {
        self.queue.back().map(|(t, _)| *t)
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        self.queue.len()
    }

    /// No sample held.
    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }

    /// Forgets every sample (after a reconnect the stream starts afresh).
    pub fn clear(&mut self) {
        self.queue.clear();
    }

    /// The sample nearest `target_board_s` once a sample at or after it has
    /// arrived (`None`: wait for more). The sample returned and all older
    /// ones leave the queue.
    pub fn take_nearest(&mut self, target_board_s: f64) -> Option<(f64, S)> {
        let times: Vec<f64> = self.queue.iter().map(|(t, _)| *t).collect();
        let hi = times.partition_point(|&x| x < target_board_s);
        if hi == times.len() {
            return None;
        }
        let pick = match bracket(&times, target_board_s, f64::INFINITY) {
            Some(b) => b.nearest(),
            None => hi, // before the first sample held: the first one
        };
        self.skipped += pick as u64;
        self.queue.drain(..pick);
        self.queue.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_clock_map_inverts() {
        let m = ClockMap { offset_s: -42.5, drift_ppm: 87.0, board_ref_s: 1000.0 };
        for t in [0.0, 1000.0, 5321.25] {
            assert!((m.to_board(m.to_nav(t)) - t).abs() < 1e-9);
        }
        // 87 ppm over 1000 s is 87 ms.
        assert!((m.to_nav(2000.0) - (2000.0 - 42.5 + 0.087)).abs() < 1e-12);
    }

    #[test]
    fn brackets_never_extrapolate_or_bridge_long_gaps() {
        let t = [0.0, 1.0, 2.0, 10.0];
        assert_eq!(bracket(&t, -0.1, 5.0), None);
        assert_eq!(bracket(&t, 10.1, 5.0), None);
        assert_eq!(bracket(&t, 5.0, 5.0), None, "8 s gap");
        assert_eq!(bracket(&t, 1.0, 5.0), Some(Bracket { lo: 1, hi: 1, weight: 0.0 }));
        let b = bracket(&t, 1.25, 5.0).unwrap();
        assert_eq!((b.lo, b.hi, b.weight), (1, 2, 0.25));
        assert_eq!(b.lerp(&[0.0, 10.0, 20.0, 0.0]), 12.5);
        assert!(b.lerp(&[0.0, 10.0, f64::NAN, 0.0]).is_nan(), "absent in a neighbour: absent");
    }

    #[test]
    fn angles_interpolate_the_short_way_round() {
        let b = Bracket { lo: 0, hi: 1, weight: 0.25 };
        // 350° → 10°: a quarter of the way is 355°, not 260°.
        assert!((b.lerp_angle_deg(&[350.0, 10.0], true) - 355.0).abs() < 1e-12);
        let b = Bracket { lo: 0, hi: 1, weight: 0.75 };
        assert!((b.lerp_angle_deg(&[350.0, 10.0], true) - 5.0).abs() < 1e-12);
        // Roll through ±180°: three quarters of the 20° from 170° is 185° = −175°.
        assert!((b.lerp_angle_deg(&[170.0, -170.0], false) + 175.0).abs() < 1e-12);
        let b = Bracket { lo: 0, hi: 1, weight: 0.5 };
        assert!((b.lerp_angle_deg(&[175.0, -165.0], false) + 175.0).abs() < 1e-12);
    }

    #[test]
    fn the_pairer_takes_the_nearest_and_drops_older_samples() {
        let mut p = TimePairer::new();
        for k in 0..10 {
            p.push(k as f64 * 0.01, k);
        }
        assert_eq!(p.take_nearest(0.5), None, "no sample at or after 0.5 s yet");
        assert_eq!(p.take_nearest(0.034), Some((0.03, 3)));
        assert_eq!(p.len(), 6);
        assert_eq!(p.skipped, 3);
        assert_eq!(p.take_nearest(0.066), Some((0.07, 7)));
        assert_eq!(p.take_nearest(0.0), Some((0.08, 8)), "never older than the last taken");
    }
}
