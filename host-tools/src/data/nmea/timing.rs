//! The time rule ([`super::TIME_RULE`]): date jumps, the day of a time of
//! day, and the sentences without a time spread between timed ones.

use super::importer::Kept;
use super::{NmeaReport, MAX_DATE_JUMP_S, MAX_SPREAD_GAP_S};

/// `hh:mm:ss[.sss]`.
pub(super) fn clock_text(tod_s: f64) -> String {
    let ms = (tod_s * 1000.0).round() as i64;
    let (h, m, s, frac) = (ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000);
    if frac == 0 {
        format!("{h:02}:{m:02}:{s:02}")
    } else {
        format!("{h:02}:{m:02}:{s:02}.{frac:03}")
    }
}

/// The dated sentences (`RMC`, `ZDA` with a date) that jump: more than
/// [`MAX_DATE_JUMP_S`] from the dated sentences before and after them,
/// which agree with each other (at the log's ends: from the one neighbour,
/// which agrees with its own next). One bad date is refused alone; a
/// genuine pause (the neighbours apart too) is kept.
fn date_jumps(kept: &[Kept]) -> Vec<bool> {
    let dated: Vec<(usize, f64)> = kept
        .iter()
        .enumerate()
        .filter_map(|(i, k)| match k.sentence.stamp() {
            Some((tod, Some(d))) => Some((i, d.days_since_epoch() as f64 * 86_400.0 + tod)),
            _ => None,
        })
        .collect();
    let far = |a: f64, b: f64| (a - b).abs() > MAX_DATE_JUMP_S;
    let mut out = vec![false; kept.len()];
    for (j, &(i, t)) in dated.iter().enumerate() {
        let at = |k: usize| dated.get(k).map(|d| d.1);
        let prev = j.checked_sub(1).and_then(at);
        let next = at(j + 1);
        out[i] = match (prev, next) {
            (Some(p), Some(n)) => far(t, p) && far(t, n) && !far(p, n),
            (None, Some(n)) => far(t, n) && at(j + 2).is_some_and(|m| !far(n, m)),
            (Some(p), None) => far(t, p) && j.checked_sub(2).and_then(at).is_some_and(|m| !far(p, m)),
            (None, None) => false,
        };
    }
    out
}

/// Each kept sentence's time, seconds since the epoch (or since day 0 of a
/// log without a date); `None` where it cannot be timed. Counts what is not
/// used.
pub(super) fn times(kept: &[Kept], report: &mut NmeaReport) -> (Vec<Option<f64>>, bool) {
    let jumps = date_jumps(kept);
    report.date_jumps = jumps.iter().filter(|&&j| j).count();
    let first_dated = kept.iter().zip(&jumps).filter(|(_, &j)| !j).find_map(|(k, _)| k.sentence.stamp().and_then(|(tod, d)| d.map(|d| (d.days_since_epoch(), tod))));
    let half_day = 43_200.0;
    // Anchors: the timed sentences, on one time line.
    let mut anchor: Vec<Option<f64>> = vec![None; kept.len()];
    let mut dropped = vec![false; kept.len()];
    let (mut current, mut last): (Option<(i64, f64)>, Option<f64>) = (None, None);
    for (i, k) in kept.iter().enumerate() {
        let Some((tod, date)) = k.sentence.stamp() else { continue };
        if jumps[i] {
            dropped[i] = true;
            continue;
        }
        let day = match (date, current, first_dated) {
            (Some(d), _, _) => d.days_since_epoch(),
            (None, Some((day, prev_tod)), _) | (None, None, Some((day, prev_tod))) => {
                if tod < prev_tod - half_day {
                    day + 1
                } else if tod > prev_tod + half_day {
                    day - 1
                } else {
                    day
                }
            }
            (None, None, None) => 0,
        };
        let t = day as f64 * 86_400.0 + tod;
        if last.is_some_and(|l| t < l) {
            report.time_backwards += 1;
            dropped[i] = true;
            continue;
        }
        current = Some((day, tod));
        last = Some(t);
        anchor[i] = Some(t);
    }
    // The sentences without a time, spread between the anchors around them.
    let mut out = anchor.clone();
    let mut prev: Option<f64> = None;
    let mut pending: Vec<usize> = Vec::new();
    for i in 0..kept.len() {
        if dropped[i] {
            continue;
        }
        let Some(t1) = anchor[i] else {
            pending.push(i);
            continue;
        };
        match prev {
            None => report.untimed_before_first_time += pending.len(),
            Some(t0) if t1 - t0 > MAX_SPREAD_GAP_S => report.untimed_in_gaps += pending.len(),
            Some(t0) => {
                let n = pending.len() as f64;
                for (k, &j) in pending.iter().enumerate() {
                    out[j] = Some(if t1 == t0 { t0 } else { t0 + (t1 - t0) * (k as f64 + 1.0) / (n + 1.0) });
                }
            }
        }
        pending.clear();
        prev = Some(t1);
    }
    report.untimed_after_last_time += pending.len();
    (out, first_dated.is_some())
}
