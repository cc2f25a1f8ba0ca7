//! The logs' time checked around the clock search: a span the search's
//! grids cannot hold is refused before any grid is made; a failed search
//! across a clock jump names the jump; logs that share no time are said
//! with their spans.

use super::{align, BoardLog, MergeError, NavLog, GRID_POINTS_FLOOR, GRID_POINTS_PER_ROW, JUMP_MIN_S, JUMP_RATIO};

/// The largest step of `t`: (0-based index before it, step).
fn largest_step(t: &[f64]) -> Option<(usize, f64)> {
    t.windows(2).map(|w| w[1] - w[0]).enumerate().max_by(|a, b| a.1.total_cmp(&b.1))
}

/// Refuses a log whose span the clock search's grids (steps of
/// [`align::RATE_FINE_DT_S`]) could not hold in memory proportional to
/// its rows ([`GRID_POINTS_PER_ROW`], [`GRID_POINTS_FLOOR`]).
pub(super) fn check_span(log: &'static str, t: &[f64]) -> Result<(), MergeError> {
    let (Some(first), Some(last)) = (t.first(), t.last()) else { return Ok(()) };
    let span_s = last - first;
    let grid_step_s = align::RATE_FINE_DT_S;
    if span_s / grid_step_s <= GRID_POINTS_FLOOR + GRID_POINTS_PER_ROW * t.len() as f64 {
        return Ok(());
    }
    let (i, largest_step_s) = largest_step(t).unwrap_or((0, span_s));
    Err(MergeError::SpanTooLong { log, span_s, rows: t.len(), median_step_s: median_interval(t), largest_step_s, row: i + 1, grid_step_s })
}

/// A log's largest step when it is far longer than its others
/// ([`JUMP_RATIO`], [`JUMP_MIN_S`]): (0-based row before it, step s, step
/// over the median step).
pub(super) fn jump(t: &[f64]) -> Option<(usize, f64, f64)> {
    let median = median_interval(t);
    let (i, step) = largest_step(t)?;
    (step >= JUMP_MIN_S && step >= JUMP_RATIO * median).then_some((i, step, step / median))
}

/// A failed search with the logs' clock jump named, when one has a step
/// far longer than its others ([`JUMP_RATIO`], [`JUMP_MIN_S`]).
pub(super) fn with_jump(e: MergeError, board: &BoardLog, nav: &NavLog) -> MergeError {
    if !matches!(e, MergeError::OutsideWindow { .. } | MergeError::NoAgreement { .. } | MergeError::NotUnique { .. } | MergeError::DriftTooLarge { .. } | MergeError::NoRotation(_)) {
        return e;
    }
    let jump = |log: &'static str, t: &[f64]| jump(t).map(|(i, step, ratio)| (log, i, step, ratio, t[i], t[i + 1]));
    match [jump("navigation", &nav.t_s), jump("board", &board.t_s)].into_iter().flatten().max_by(|a, b| a.3.total_cmp(&b.3)) {
        Some((log, i, step_s, ratio, from_s, to_s)) => MergeError::ClockJump { log, row: i + 1, from_s, to_s, step_s, ratio, source: Box::new(e) },
        None => e,
    }
}

/// The median interval, s; NaN with fewer than two distinct times.
pub(super) fn median_interval(t: &[f64]) -> f64 {
    crate::data::pairing::median_step_s(t).unwrap_or(f64::NAN)
}

pub(super) fn no_overlap(board: &BoardLog, nav: &NavLog, detail: String) -> MergeError {
    MergeError::NoOverlap {
        board_start_s: board.t_s[0],
        board_end_s: *board.t_s.last().unwrap_or(&board.t_s[0]),
        nav_start_s: nav.t_s[0],
        nav_end_s: *nav.t_s.last().unwrap_or(&nav.t_s[0]),
        detail,
    }
}
