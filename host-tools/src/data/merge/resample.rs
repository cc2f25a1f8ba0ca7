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

fn push(col: &mut Option<Vec<f64>>, v: f64) {
    if let Some(c) = col.as_mut() {
        c.push(v);
    }
}

/// An empty recording with the columns the logs have: every column of the
/// registry's that both logs hold ([`merged_columns`]) and the navigation
/// log has, and the board's temperature.
fn empty(board: &BoardLog, nav: &NavLog) -> (Recording, MergedExtra) {
    let mut rec = Recording { t_s: Some(vec![]), ..Recording::default() };
    for c in merged_columns().filter(|c| nav.column(c.name).is_some()) {
        if let Some(slot) = rec.column_slot(c.name) {
            *slot = Some(Vec::new());
        }
    }
    let opt = |c: &Option<Vec<f64>>| c.as_ref().map(|_| Vec::new());
    rec.temp_c = opt(&board.temp_c);
    (rec, MergedExtra { t_board_s: vec![], heading_deg: opt(&nav.heading_deg) })
}

/// A navigation column at bracket `b` (NaN without one), as the registry
/// says it is resampled.
fn resampled(c: &Column, values: &[f64], b: Option<Bracket>) -> f64 {
    b.map_or(f64::NAN, |b| match c.interp {
        Interp::Linear => b.lerp(values),
        Interp::Angle180 => b.lerp_angle_deg(values, false),
        Interp::Heading360 => b.lerp_angle_deg(values, true),
    })
}

/// Appends the navigation columns at bracket `b` (NaN without one).
fn push_nav(rec: &mut Recording, extra: &mut MergedExtra, nav: &NavLog, b: Option<Bracket>) {
    for c in merged_columns() {
        if let (Some(values), Some(Some(out))) = (nav.column(c.name), rec.column_slot(c.name)) {
            out.push(resampled(c, values, b));
        }
    }
    if let (Some(values), Some(c)) = (&nav.heading_deg, column_spec(col::HEADING_DEG)) {
        push(&mut extra.heading_deg, resampled(c, values, b));
    }
}

/// The board samples within the navigation log's span, on the navigation
/// clock of `map`, with the navigation columns interpolated to them.
pub(super) fn rows(board: &BoardLog, nav: &NavLog, map: &ClockMap) -> (Recording, MergedExtra, Counts) {
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let (mut rec, mut extra) = empty(board, nav);
    let mut counts = Counts { outside: 0, in_gaps: 0, saturated: 0 };
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
        rec.mag.push(if bad { [f64::NAN; 3] } else { m });
        push(&mut rec.t_s, tn);
        push_nav(&mut rec, &mut extra, nav, b);
        extra.t_board_s.push(tb);
        board.temp_c.as_ref().inspect(|c| push(&mut rec.temp_c, c[i]));
    }
    (rec, extra, counts)
}
