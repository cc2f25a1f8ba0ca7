//! The merged rows: each board sample with the navigation columns
//! interpolated to its time on the navigation clock ([`super::super::pairing`]:
//! angles the short way round, GPS only where both neighbours have it,
//! nothing beyond the navigation log or across its long gaps).

use super::super::pairing::{bracket, Bracket, ClockMap};
use super::super::table::{col, column_spec, merged_columns, Column, ColumnSet, Interp};
use super::super::Recording;
use super::{median_interval, BoardLog, MergedExtra, NavLog};

/// What the rows left out or left without something.
pub(super) struct Counts {
    /// Board samples before or after the navigation log.
    pub(super) outside: usize,
    /// Rows in a gap of the navigation log.
    pub(super) in_gaps: usize,
    /// Rows whose field was saturated.
    pub(super) saturated: usize,
}

/// A navigation column at each row's bracket (NaN without one), as the
/// registry says it is resampled.
fn resampled(c: &Column, values: &[f64], brackets: &[Option<Bracket>]) -> Vec<f64> {
    let at = |b: &Option<Bracket>| {
        b.map_or(f64::NAN, |b| match c.interp {
            Interp::Linear => b.lerp(values),
            Interp::Angle180 => b.lerp_angle_deg(values, false),
            Interp::Heading360 => b.lerp_angle_deg(values, true),
        })
    };
    brackets.iter().map(at).collect()
}

/// The board samples within the navigation log's span, on the navigation
/// clock of `map`, with the navigation columns interpolated to them: each
/// row's bracket found once, then each column the registry merges
/// ([`merged_columns`]) that the navigation log has, resampled in one pass.
/// Navigation rows more than `max_gap_s` apart are not interpolated
/// between ([`super::MergeOptions::max_nav_gap_s`]; nor beyond five of the
/// log's median steps, at least 1 s).
pub(super) fn rows(board: &BoardLog, nav: &NavLog, map: &ClockMap, max_gap_s: f64) -> (Recording, MergedExtra, Counts) {
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0).min(max_gap_s);
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let mut counts = Counts { outside: 0, in_gaps: 0, saturated: 0 };
    let (mut t_s, mut mag, mut t_board_s, mut brackets, mut kept) = (vec![], vec![], vec![], vec![], vec![]);
    for (i, (&tb, &m)) in board.t_s.iter().zip(&board.mag).enumerate() {
        let tn = map.to_nav(tb);
        if !(tn >= n0 && tn <= n1) {
            counts.outside += 1;
            continue;
        }
        let b = bracket(&nav.t_s, tn, nav_gap);
        if b.is_none() {
            counts.in_gaps += 1;
        }
        let bad = board.saturated(i);
        if bad {
            counts.saturated += 1;
        }
        mag.push(if bad { [f64::NAN; 3] } else { m });
        t_s.push(tn);
        t_board_s.push(tb);
        brackets.push(b);
        kept.push(i);
    }
    let mut rec = Recording { t_s: Some(t_s), mag, ..Recording::default() };
    for c in merged_columns() {
        if let (Some(values), Some(slot)) = (nav.column(c.name), rec.column_slot(c.name)) {
            *slot = Some(resampled(c, values, &brackets));
        }
    }
    rec.temp_c = board.temp_c.as_ref().map(|c| kept.iter().map(|&i| c.get(i).copied().unwrap_or(f64::NAN)).collect());
    let heading_deg = match (&nav.heading_deg, column_spec(col::HEADING_DEG)) {
        (Some(values), Some(c)) => Some(resampled(c, values, &brackets)),
        _ => None,
    };
    (rec, MergedExtra { t_board_s, heading_deg }, counts)
}
