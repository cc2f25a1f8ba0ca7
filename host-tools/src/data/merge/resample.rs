//! The merged rows: each board sample with the navigation columns
//! interpolated to its time on the navigation clock ([`super::super::pairing`]:
//! angles the short way round, GPS only where both neighbours have it,
//! nothing beyond the navigation log or across its long gaps).

use super::super::pairing::{bracket, Bracket, ClockMap};
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

/// An empty recording with the columns the logs have.
fn empty(board: &BoardLog, nav: &NavLog) -> (Recording, MergedExtra) {
    let mut rec = Recording { t_s: Some(vec![]), roll_deg: Some(vec![]), pitch_deg: Some(vec![]), ..Recording::default() };
    let opt = |c: &Option<Vec<f64>>| c.as_ref().map(|_| Vec::new());
    rec.ref_heading_deg = opt(&nav.ref_heading_deg);
    rec.lat_deg = opt(&nav.lat_deg);
    rec.lon_deg = opt(&nav.lon_deg);
    if nav.gyro_rad_s.is_some() {
        (rec.gx_rad_s, rec.gy_rad_s, rec.gz_rad_s) = (Some(vec![]), Some(vec![]), Some(vec![]));
    }
    rec.speed_mps = opt(&nav.speed_mps);
    rec.motor_current_a = opt(&nav.motor_current_a);
    rec.temp_c = opt(&board.temp_c);
    (rec, MergedExtra { t_board_s: vec![], heading_deg: opt(&nav.heading_deg) })
}

/// Appends the navigation columns at bracket `b` (NaN without one).
fn push_nav(rec: &mut Recording, extra: &mut MergedExtra, nav: &NavLog, b: Option<Bracket>) {
    let lerp = |c: &[f64]| b.map_or(f64::NAN, |b| b.lerp(c));
    let angle = |c: &[f64], heading: bool| b.map_or(f64::NAN, |b| b.lerp_angle_deg(c, heading));
    push(&mut rec.roll_deg, angle(&nav.roll_deg, false));
    push(&mut rec.pitch_deg, lerp(&nav.pitch_deg));
    if let Some(c) = &nav.ref_heading_deg {
        push(&mut rec.ref_heading_deg, angle(c, true));
    }
    nav.lat_deg.as_ref().inspect(|c| push(&mut rec.lat_deg, lerp(c)));
    nav.lon_deg.as_ref().inspect(|c| push(&mut rec.lon_deg, lerp(c)));
    if let Some([x, y, z]) = &nav.gyro_rad_s {
        push(&mut rec.gx_rad_s, lerp(x));
        push(&mut rec.gy_rad_s, lerp(y));
        push(&mut rec.gz_rad_s, lerp(z));
    }
    nav.heading_deg.as_ref().inspect(|c| push(&mut extra.heading_deg, angle(c, true)));
    nav.speed_mps.as_ref().inspect(|c| push(&mut rec.speed_mps, lerp(c)));
    nav.motor_current_a.as_ref().inspect(|c| push(&mut rec.motor_current_a, lerp(c)));
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
