//! The board's `u32` millisecond clock unwrapped across its wrap-around.

/// What [`BoardClock::unwrap`] made of a `t_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ClockStep {
    /// Milliseconds since the board's boot, unwrapped.
    Ms(u64),
    /// Not after the last time (a repeated or reordered sample).
    Stale,
    /// The clock went back by less than half its range: the board restarted.
    Restarted,
}

/// A step back of less than this is a repeated sample, not a restart, ms.
const STALE_MS: u32 = 50;

/// The board's `u32` millisecond clock unwrapped into a `u64`: a step
/// backwards by more than half the counter's range is a wrap-around (the
/// counter passed 2³² − 1), a smaller one a restart (its uptime starts
/// again from 0) unless it is under 50 ms (a repeated sample).
#[derive(Debug, Clone, Copy, Default)]
pub struct BoardClock {
    last: Option<u64>,
}

impl BoardClock {
    /// The unwrapped time of `t_ms`, the sample after the last one taken.
    pub fn unwrap(&mut self, t_ms: u32) -> ClockStep {
        let Some(last) = self.last else {
            self.last = Some(u64::from(t_ms));
            return ClockStep::Ms(u64::from(t_ms));
        };
        let last_low = last as u32;
        let ahead = t_ms.wrapping_sub(last_low);
        if ahead == 0 {
            ClockStep::Stale
        } else if ahead < 1 << 31 {
            let now = last + u64::from(ahead);
            self.last = Some(now);
            ClockStep::Ms(now)
        } else if last_low.wrapping_sub(t_ms) < STALE_MS {
            // A hair behind: a repeated sample.
            ClockStep::Stale
        } else {
            ClockStep::Restarted
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counter's wrap-around continues the time; a small step back is
    /// a stale sample; a large one (not a wrap) a restart.
    #[test]
    fn the_board_clock_unwraps_and_tells_a_restart() {
        let mut c = BoardClock::default();
        assert_eq!(c.unwrap(u32::MAX - 14), ClockStep::Ms(u64::from(u32::MAX) - 14));
        // 2³² − 15 + 20 ms = 2³² + 5 ms.
        assert_eq!(c.unwrap(5), ClockStep::Ms((1u64 << 32) + 5));
        assert_eq!(c.unwrap(15), ClockStep::Ms((1u64 << 32) + 15));
        assert_eq!(c.unwrap(15), ClockStep::Stale);
        assert_eq!(c.unwrap(5), ClockStep::Stale);
        assert_eq!(c.unwrap(25), ClockStep::Ms((1u64 << 32) + 25));
        let mut d = BoardClock::default();
        assert_eq!(d.unwrap(3_600_000), ClockStep::Ms(3_600_000));
        assert_eq!(d.unwrap(3_599_990), ClockStep::Stale);
        assert_eq!(d.unwrap(1_200), ClockStep::Restarted);
    }
}
