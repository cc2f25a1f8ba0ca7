//! Why two logs could not be merged: [`MergeError`], and [`NoRotation`]
//! when the logs show no turns to align the clocks on.

use super::{GRID_POINTS_FLOOR, GRID_POINTS_PER_ROW, MIN_OFFSET_ALLOWANCE_S, OFFSET_ALLOWANCE_SIGMA};
use crate::data::intake::IntakeError;
use crate::data::recording::RecordingError;

/// Why two logs could not be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A log could not be read (missing column, time running backwards, a
    /// cell that is not a number, …).
    #[error(transparent)]
    Log(#[from] RecordingError),
    /// The logs share no time.
    #[error("the logs do not overlap: board {board_start_s:.3}…{board_end_s:.3} s, navigation {nav_start_s:.3}…{nav_end_s:.3} s; {detail}")]
    NoOverlap {
        /// First board time, s (board clock).
        board_start_s: f64,
        /// Last board time, s.
        board_end_s: f64,
        /// First navigation time, s (navigation clock).
        nav_start_s: f64,
        /// Last navigation time, s.
        nav_end_s: f64,
        /// With which offsets.
        detail: String,
    },
    /// Nothing turned, or the two logs do not see the same turns.
    #[error("no rotation to align the clocks on: {0} (turn the vehicle while both log, or give the clock offset)")]
    NoRotation(NoRotation),
    /// The logs agree best at an end of the searched offsets: the true
    /// offset may lie beyond.
    #[error("the logs agree best at a clock offset of {best_s:.2} s, the end of the search window {center_s} ± {max_offset_s} s: the true offset may lie outside it (centre the window on the approximate offset, or widen it)")]
    OutsideWindow {
        /// The best offset searched, s.
        best_s: f64,
        /// The window's centre, s.
        center_s: f64,
        /// The window's half-width, s.
        max_offset_s: f64,
    },
    /// The logs agree no better at the best offset of the search window
    /// than chance does at others: the true offset lies outside the
    /// window, or the logs do not see the same motion.
    #[error("at the best clock offset searched ({best_s:.2} s) the logs agree only {height_sigma:.1} σ better than at unrelated offsets ({min_height_sigma} σ needed): the true offset lies outside the search window {center_s} ± {max_offset_s} s (centre it on the approximate offset, or widen it), or the two logs do not see the same motion (or give the clock offset)")]
    NoAgreement {
        /// The best offset searched, s.
        best_s: f64,
        /// Its agreement over the median offset's, in σ of the agreement's
        /// spread over the offsets searched.
        height_sigma: f64,
        /// The least accepted, σ.
        min_height_sigma: f64,
        /// The window's centre, s.
        center_s: f64,
        /// The window's half-width, s.
        max_offset_s: f64,
    },
    /// Two offsets agree about equally well: the motion repeats within the
    /// search window (a regular swing, steady circles), and the logs cannot
    /// tell which offset is the true one.
    #[error("the logs agree about as well at a clock offset of {best_s:.2} s as at {runner_up_s:.2} s (the first better by only {margin_sigma:.1} σ of the agreement's spread at unrelated offsets; {min_margin_sigma} σ needed): the motion repeats within the search window {center_s} ± {max_offset_s} s, or the true offset lies outside it; centre a narrower window on the right one, or give the clock offset")]
    NotUnique {
        /// The best offset, s.
        best_s: f64,
        /// The runner-up's, s.
        runner_up_s: f64,
        /// How much better the best agrees, σ.
        margin_sigma: f64,
        /// The least accepted, σ.
        min_margin_sigma: f64,
        /// The window's centre, s.
        center_s: f64,
        /// The window's half-width, s.
        max_offset_s: f64,
    },
    /// The windows' offsets drift apart faster than clocks do: they do not
    /// follow one clock.
    #[error("the windows' offsets drift by {drift_ppm:.0} ppm, more than clocks do ({max_drift_ppm} ppm): the logs do not see the same motion throughout (or give the clock offset)")]
    DriftTooLarge {
        /// The drift fitted, ppm.
        drift_ppm: f64,
        /// The most accepted, ppm.
        max_drift_ppm: f64,
    },
    /// The offset search is not a range.
    #[error("the offset search {center_s} ± {max_offset_s} s is not a range")]
    BadSearchWindow {
        /// Its centre, s.
        center_s: f64,
        /// Its half-width, s.
        max_offset_s: f64,
    },
    /// The offset search is too narrow to tell where the logs agree best.
    #[error("the offset search {center_s} ± {max_offset_s} s is narrower than ± {min_s} s: too narrow to tell where the logs agree best (give the offset itself to use it as given)")]
    SearchWindowTooNarrow {
        /// Its centre, s.
        center_s: f64,
        /// Its half-width, s.
        max_offset_s: f64,
        /// The narrowest half-width searched, s.
        min_s: f64,
    },
    /// A log has no rows.
    #[error("a log has no rows (board {board_rows}, navigation {nav_rows})")]
    EmptyLog {
        /// The board log's rows.
        board_rows: usize,
        /// The navigation log's rows.
        nav_rows: usize,
    },
    /// A log's `t` is in a unit its step does not make clear.
    #[error(transparent)]
    Time(#[from] IntakeError),
    /// A log spans more time than its rows can fill on the search's grids
    /// (`t` in another unit than it is read in, or a clock that jumps).
    #[error("the {log} log spans {span_s:.6e} s over {rows} rows (median step {median_step_s} s; its largest step {largest_step_s:.6e} s after data row {row}): more time than its rows can fill on the clock search's grids (at most {GRID_POINTS_FLOOR:e} + {GRID_POINTS_PER_ROW} × rows steps of {grid_step_s} s); is `t` in the unit it is read in, or does its clock jump there?")]
    SpanTooLong {
        /// `"board"` or `"navigation"`.
        log: &'static str,
        /// Its span, s.
        span_s: f64,
        /// Its rows.
        rows: usize,
        /// Its median step, s.
        median_step_s: f64,
        /// Its largest step, s.
        largest_step_s: f64,
        /// The 1-based data row the largest step follows.
        row: usize,
        /// The grid's step, s.
        grid_step_s: f64,
    },
    /// The clock search failed across a step of one log's time far longer
    /// than its others: a clock jump (or a gap after which the clocks
    /// differ).
    #[error("the {log} log's time steps from {from_s:.3} s to {to_s:.3} s after data row {row} ({step_s:.3} s, {ratio:.0}× its median step): a clock jump (or a gap after which the clocks differ), and the logs cannot share one offset across it; merge the parts on either side of it separately. The search said: {source}")]
    ClockJump {
        /// `"board"` or `"navigation"`.
        log: &'static str,
        /// The 1-based data row before the step.
        row: usize,
        /// The time before the step, s.
        from_s: f64,
        /// The time after it, s.
        to_s: f64,
        /// The step, s.
        step_s: f64,
        /// The step over the log's median step.
        ratio: f64,
        /// What the search said.
        source: Box<MergeError>,
    },
    /// A given clock offset disagrees with what the data show.
    #[error("the clock offset given, {given_s:.3} s (navigation − board), disagrees with the data: the logs agree best at {found_s:.3} ± {sigma_s:.3} s, {diff_s:.3} s away (allowed: {allowance_s:.3} s, the larger of {MIN_OFFSET_ALLOWANCE_S} s and {OFFSET_ALLOWANCE_SIGMA} σ); check its sign and its size, or leave it out to use the offset found")]
    GivenOffsetDisagrees {
        /// The offset given at the board log's middle, s.
        given_s: f64,
        /// The offset the data show there, s.
        found_s: f64,
        /// Its 1σ, s.
        sigma_s: f64,
        /// The largest difference over the board log, s.
        diff_s: f64,
        /// The allowance, s.
        allowance_s: f64,
    },
    /// The offset found lies at an end of the offsets searched, and the
    /// search is strict.
    #[error("{0} (refused as strict)")]
    AtWindowEdge(String),
    /// A given clock is not usable numbers.
    #[error("offset {offset_s} s / drift {drift_ppm} ppm: not usable numbers")]
    BadGivenClock {
        /// The offset given, s.
        offset_s: f64,
        /// The drift given, ppm.
        drift_ppm: f64,
    },
}

/// Why the logs show no rotation to align on.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum NoRotation {
    /// No window of the overlap has rotation both logs see alike.
    #[error("no window of the overlap has rotation that both logs see alike")]
    NoSharedWindow,
    /// The navigation's attitude and tilt hardly change, and the rates of
    /// turn do not help.
    #[error("the navigation's attitude changes by {attitude_spread_deg:.2}° RMS ({attitude_needed_deg:.1}° needed) and its tilt by {tilt_spread_deg:.2}° ({tilt_needed_deg:.1}° needed), and {}", if *.rates_flat { "the rates of turn agree equally at every offset" } else { "the rates of turn are below 0.3°/s RMS in a log" })]
    TooSteady {
        /// The attitude's RMS change, degrees.
        attitude_spread_deg: f64,
        /// What it needs, degrees.
        attitude_needed_deg: f64,
        /// The tilt's RMS change, degrees.
        tilt_spread_deg: f64,
        /// What it needs, degrees.
        tilt_needed_deg: f64,
        /// The rates of turn were there but agree equally everywhere (else
        /// they were too small).
        rates_flat: bool,
    },
    /// The combined agreement is the same at every offset.
    #[error("the logs agree equally at every offset searched")]
    FlatAgreement,
    /// The attitude does not vary enough to fit the field to it.
    #[error("the attitude does not vary enough to fit the field to it")]
    AttitudeTooSmallToFit,
    /// Too few windows with shared motion.
    #[error("only {0} window(s) of the overlap have motion that both logs see")]
    TooFewWindows(usize),
    /// The fine alignment never settled.
    #[error("no window converged")]
    NoWindowConverged,
}
