//! The clock search: `t_nav = t_board + offset + drift·(t_board − t₀)`
//! from what both logs see.
//!
//! With the navigation's heading, the raw field is fitted as a linear
//! function of the attitude ([`super::fit::FieldFit`]): exact only when the
//! clocks are aligned, whatever the sensor's calibration. Every attitude
//! change counts — turns and their starts and ends, rolls, dive and climb
//! pitch changes, wiggles on a straight leg — weighted by how much it moves
//! the field. A coarse search over the whole window finds the lag that
//! explains the field best; then, with the model fitted at that lag, each
//! window of the overlap gets its own lag by Gauss–Newton on the cubic
//! between navigation rows (any fraction of a row) and a σ from its
//! residuals and how fast its field turns; a weighted line through the
//! windows gives the offset and drift, their σ scaled up by the windows'
//! scatter about the line. Model and windows are iterated.
//!
//! Without a heading, the rates of turn are correlated instead
//! ([`super::signals::RateViews`]).

use super::super::board_log::BoardLog;
use super::super::nav_log::NavLog;
use super::super::pairing::ClockMap;
use super::fit::{line_fit, predict, FieldFit, LineFit};
use super::signals::{attitude_series, field_series, AttitudeSeries, RateViews, FEATURES};
use super::{median_interval, no_overlap, MergeError};

/// The least overlap to align on, s.
const MIN_OVERLAP_S: f64 = 20.0;
/// … and at least this share of the shorter log.
const MIN_OVERLAP_SHARE: f64 = 0.5;
/// The most the two clocks may drift apart, ppm (crystals: ±100).
const MAX_DRIFT_PPM: f64 = 1000.0;
/// Lag step of the coarse search, s (refined by a parabola).
const COARSE_STEP_S: f64 = 0.25;
/// Work budget of the coarse search: lags × rows.
const COARSE_BUDGET: f64 = 4e6;
/// A window of the fine stage is about this long, s …
const WINDOW_S: f64 = 60.0;
/// … and there are this many windows at least and at most.
const WINDOWS: (usize, usize) = (4, 24);
/// The best lag must leave at most this fraction of the median lag's
/// unexplained spread, or the logs do not see the same motion.
const MAX_CONTRAST: f64 = 0.3;
/// … and at most this fraction of the next best local minimum's.
const MAX_SECOND_RATIO: f64 = 0.5;

/// Below this RMS change of attitude (about 1°, in rotation entries),
/// nothing turned.
const MIN_ATTITUDE_SPREAD: f64 = 0.017;

/// The RMS spread of the navigation's rotation entries about their mean
/// (about the RMS angle turned, rad).
fn attitude_spread(series: &AttitudeSeries) -> f64 {
    let rows: Vec<&[f64; FEATURES]> = series.rows().filter(|x| x[0].is_finite()).collect();
    if rows.len() < 2 {
        return 0.0;
    }
    let n = rows.len() as f64;
    let var: f64 = (0..FEATURES - 1)
        .map(|a| {
            let m = rows.iter().map(|x| x[a]).sum::<f64>() / n;
            rows.iter().map(|x| (x[a] - m).powi(2)).sum::<f64>() / n
        })
        .sum();
    (var / 2.0).sqrt()
}

/// The first pass searches each window's lag this far around the coarse
/// one (the coarse step, and 100 ppm over three hours), s …
const WINDOW_SEARCH_S: f64 = 1.5;
/// … in steps of, s.
const WINDOW_SEARCH_STEP_S: f64 = 0.05;
/// Gauss–Newton iterations of a window's lag, at most.
const GN_ITERATIONS: usize = 20;

/// What the alignment found.
#[derive(Debug, Clone, Copy)]
pub(super) struct Alignment {
    pub(super) clock: ClockMap,
    pub(super) offset_sigma_s: f64,
    pub(super) drift_sigma_ppm: f64,
    pub(super) drift_fitted: bool,
    pub(super) windows: usize,
    /// How well the logs agree at the offset found (1 = perfectly).
    pub(super) agreement: f64,
}

impl Alignment {
    fn from_line(line: &LineFit, clock: ClockMap, windows: usize, agreement: f64) -> Self {
        Self { clock, offset_sigma_s: line.offset_sigma_s, drift_sigma_ppm: line.slope_sigma * 1e6, drift_fitted: line.slope_fitted, windows, agreement }
    }
}

/// The lags (`t_nav − t_board`) to search: the window `center ± max`
/// where the logs would share at least [`MIN_OVERLAP_S`] and half the
/// shorter log (a short overlap is explained by any attitude).
fn search_range(board: &BoardLog, nav: &NavLog, center_s: f64, max_offset_s: f64) -> Result<(f64, f64), MergeError> {
    if !(max_offset_s.is_finite() && max_offset_s >= 0.0 && center_s.is_finite()) {
        return Err(MergeError::Option(format!("the offset search {center_s} ± {max_offset_s} s is not a range")));
    }
    if max_offset_s < 2.0 * COARSE_STEP_S {
        return Err(MergeError::Option(format!(
            "the offset search {center_s} ± {max_offset_s} s is narrower than ± {} s: too narrow to tell where the logs agree best (give the offset itself to use it as given)",
            2.0 * COARSE_STEP_S
        )));
    }
    let (b0, b1) = (board.t_s[0], *board.t_s.last().unwrap_or(&board.t_s[0]));
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let overlap = MIN_OVERLAP_S.max(MIN_OVERLAP_SHARE * (b1 - b0).min(n1 - n0));
    let lo = (center_s - max_offset_s).max(n0 - b1 + overlap);
    let hi = (center_s + max_offset_s).min(n1 - b0 - overlap);
    if !(hi >= lo) {
        return Err(no_overlap(
            board,
            nav,
            format!("with clock offsets (navigation − board) within {center_s} ± {max_offset_s} s they share less than {overlap:.1} s (at least {MIN_OVERLAP_S} s and half the shorter log; give the offset, or centre and widen the search)"),
        ));
    }
    Ok((lo, hi))
}

/// Points per the slower log's sample interval on the comparison grid.
const GRID_PER_INTERVAL: f64 = 5.0;

/// The board's field on a uniform grid of its clock, read between samples
/// by a cubic: (board time, raw field). Both logs are read at every phase
/// between their samples alike, so their noise, which interpolation
/// halves midway between samples, weighs the same at every lag (compared
/// at the board's samples, logs at the same rate would prefer a lag of
/// half a sample wherever the motion is weaker than the noise).
fn field_grid(board: &BoardLog, step_s: f64) -> Vec<(f64, [f64; 3])> {
    let gap_s = (5.0 * median_interval(&board.t_s)).max(0.5);
    let field = field_series(board, gap_s);
    let b0 = board.t_s[0];
    let mut out = Vec::new();
    // Interval by interval, so a long gap costs nothing.
    for w in board.t_s.windows(2).filter(|w| w[1] - w[0] <= gap_s) {
        let (k0, k1) = (((w[0] - b0) / step_s).ceil() as usize, ((w[1] - b0) / step_s).ceil() as usize);
        out.extend((k0..k1).map(|k| b0 + k as f64 * step_s).filter_map(|t| field.at(t).map(|(y, _)| (t, y))));
    }
    out
}

/// The field model over `rows` with the navigation `lag` later.
fn field_fit(rows: &[(f64, [f64; 3])], series: &AttitudeSeries, map: &ClockMap) -> FieldFit {
    let mut fit = FieldFit::new();
    for (t, y) in rows {
        if let Some((x, _)) = series.at(map.to_nav(*t)) {
            fit.add(&x, *y);
        }
    }
    fit
}

/// The parabola's vertex through three equally spaced values, as a
/// fraction of the step from the middle one (−0.5…0.5).
fn parabolic_vertex(a: f64, b: f64, c: f64) -> f64 {
    let den = a - 2.0 * b + c;
    if den < 0.0 {
        (0.5 * (a - c) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    }
}

/// The coarse search: every lag of `range` on a [`COARSE_STEP_S`] grid,
/// the whole overlap (rows thinned to the work budget); the lag whose
/// attitude leaves the least of the field unexplained, refined by a
/// parabola, and that fraction. Refused when the best is at an end of the
/// range (the offset may lie beyond it) or not clearly better than most.
fn coarse_lag(rows: &[(f64, [f64; 3])], series: &AttitudeSeries, range: (f64, f64), window: (f64, f64)) -> Result<(f64, f64), MergeError> {
    let steps = ((range.1 - range.0) / COARSE_STEP_S).floor() as usize + 1;
    let keep = (COARSE_BUDGET / steps as f64).clamp(300.0, 2000.0) as usize;
    let stride = rows.len().div_ceil(keep).max(1);
    let thin: Vec<(f64, [f64; 3])> = rows.iter().step_by(stride).copied().collect();
    let misfit: Vec<f64> = (0..steps)
        .map(|s| field_fit(&thin, series, &ClockMap::offset(range.0 + s as f64 * COARSE_STEP_S)).unexplained().unwrap_or(f64::NAN))
        .collect();
    let (k, &best) = misfit.iter().enumerate().filter(|(_, m)| m.is_finite()).min_by(|a, b| a.1.total_cmp(b.1)).ok_or_else(|| {
        MergeError::NoRotation("no offset in the search range leaves enough rows with both a field and an attitude".into())
    })?;
    let lag = range.0 + k as f64 * COARSE_STEP_S;
    if k == 0 || k + 1 == steps {
        return Err(MergeError::OutsideWindow { best_s: lag, center_s: 0.5 * (window.0 + window.1), max_offset_s: 0.5 * (window.1 - window.0) });
    }
    let mut finite: Vec<f64> = misfit.iter().copied().filter(|m| m.is_finite()).collect();
    // Never empty: `best` is one of them.
    let median = calib_core::series::median(&mut finite).unwrap_or(best);
    // Another local minimum nearly as good: a motion that repeats.
    let second = (1..steps - 1).filter(|&j| j.abs_diff(k) > 1 && misfit[j] <= misfit[j - 1] && misfit[j] <= misfit[j + 1]).map(|j| misfit[j]).fold(f64::INFINITY, f64::min);
    if !(best <= MAX_CONTRAST * median && best <= MAX_SECOND_RATIO * second) {
        let (center_s, max_offset_s) = (0.5 * (window.0 + window.1), 0.5 * (window.1 - window.0));
        let detail = format!(
            "at the best clock offset searched ({lag:.2} s) the attitude leaves {:.1} % of the field's spread unexplained, against {:.1} % at other offsets",
            100.0 * best,
            100.0 * median.min(second)
        );
        return Err(MergeError::NoAgreement { detail, center_s, max_offset_s });
    }
    let (a, c) = (misfit[k - 1], misfit[k + 1]);
    let vertex = if a.is_finite() && c.is_finite() { parabolic_vertex(-a, -best, -c) } else { 0.0 };
    Ok((lag + vertex * COARSE_STEP_S, 1.0 - best))
}

/// One window's lag relative to `map` (Gauss–Newton on the cubic between
/// navigation rows, the model `coef` held) and its σ: the residual's
/// variance over how fast the predicted field moves, each navigation row
/// counted once (`rows_per_nav` board rows share its noise). `None` when
/// the window has too few rows, no motion, or the lag runs away.
fn window_lag(rows: &[(f64, [f64; 3])], series: &AttitudeSeries, coef: &[[f64; FEATURES]; 3], map: &ClockMap, rows_per_nav: f64, start: f64) -> Option<(f64, f64)> {
    let mut lag = start;
    for it in 0..GN_ITERATIONS {
        let (mut sgr, mut sgg, mut srr, mut n) = (0.0, 0.0, 0.0, 0usize);
        for (t, y) in rows {
            let Some((x, dx)) = series.at(map.to_nav(*t) + lag) else { continue };
            // The constant's rate is 0, so `predict` of the rates is the field's rate.
            let (p, g) = (predict(coef, &x), predict(coef, &dx));
            for k in 0..3 {
                let r = y[k] - p[k];
                sgr += g[k] * r;
                sgg += g[k] * g[k];
                srr += r * r;
            }
            n += 1;
        }
        if n < 2 * FEATURES || !(sgg > 0.0) {
            return None;
        }
        let step = (sgr / sgg).clamp(-0.5, 0.5);
        lag += step;
        if (lag - start).abs() > 1.0 {
            return None;
        }
        // Converged, or close enough at the last iteration (the lag moves
        // linearly when the model was fitted at other lags; the outer
        // iterations finish it).
        if step.abs() < 2e-5 || (it + 1 == GN_ITERATIONS && step.abs() < 1e-3) {
            let s2 = srr / (3 * n - 1) as f64;
            return Some((lag, (s2 * rows_per_nav.max(1.0) / sgg).sqrt()));
        }
    }
    None
}

/// The window's misfit `Σ|raw − C·x(t + lag)|²` at the lags of
/// `±WINDOW_SEARCH_S` (rows thinned), the best one: where Gauss–Newton
/// starts. Sharp attitude changes sampled once a second leave a misfit with
/// a minimum every row, and Gauss–Newton alone finds the nearest.
fn window_start(rows: &[(f64, [f64; 3])], series: &AttitudeSeries, coef: &[[f64; FEATURES]; 3], map: &ClockMap) -> f64 {
    let stride = rows.len().div_ceil(600).max(1);
    let steps = (WINDOW_SEARCH_S / WINDOW_SEARCH_STEP_S).round() as i64;
    let misfit = |lag: f64| {
        let (mut s, mut n) = (0.0, 0usize);
        for (t, y) in rows.iter().step_by(stride) {
            if let Some((x, _)) = series.at(map.to_nav(*t) + lag) {
                let p = predict(coef, &x);
                s += (0..3).map(|k| (y[k] - p[k]).powi(2)).sum::<f64>();
                n += 1;
            }
        }
        if n > FEATURES { s / n as f64 } else { f64::NAN }
    };
    (-steps..=steps).map(|k| k as f64 * WINDOW_SEARCH_STEP_S).map(|l| (l, misfit(l))).filter(|p| p.1.is_finite()).min_by(|a, b| a.1.total_cmp(&b.1)).map_or(0.0, |p| p.0)
}

/// The windows' lags relative to `map`: (board time of the window's
/// middle, lag, σ); each window's search starts at its best lag within
/// `±WINDOW_SEARCH_S` when `search`, at 0 otherwise.
fn window_lags(rows: &[(f64, [f64; 3])], series: &AttitudeSeries, coef: &[[f64; FEATURES]; 3], map: &ClockMap, rows_per_nav: f64, search: bool) -> Vec<(f64, f64, f64)> {
    let inside: Vec<(f64, [f64; 3])> = rows.iter().copied().filter(|(t, _)| series.at(map.to_nav(*t)).is_some()).collect();
    let (Some(first), Some(last)) = (inside.first(), inside.last()) else { return vec![] };
    let span = last.0 - first.0;
    let k = ((span / WINDOW_S).round() as usize).clamp(WINDOWS.0, WINDOWS.1);
    let width = span / k as f64;
    (0..k)
        .filter_map(|w| {
            let (a, b) = (first.0 + w as f64 * width, first.0 + (w + 1) as f64 * width);
            let i0 = inside.partition_point(|r| r.0 < a);
            let i1 = inside.partition_point(|r| r.0 < b || (w + 1 == k && r.0 <= b));
            let w = &inside[i0..i1];
            let start = if search { window_start(w, series, coef, map) } else { 0.0 };
            window_lag(w, series, coef, map, rows_per_nav, start).map(|(lag, s)| (0.5 * (a + b), lag, s))
        })
        .collect()
}

/// The line through the windows, again without the windows far off it
/// (a wrong minimum).
fn robust_line(points: &[(f64, f64, f64)], t_ref: f64) -> (LineFit, usize) {
    let fit = line_fit(points, t_ref);
    if points.len() < 4 {
        return (fit, points.len());
    }
    let scale = fit.chi2_dof.max(1.0).sqrt();
    let kept: Vec<(f64, f64, f64)> = points.iter().copied().filter(|p| (p.1 - fit.at(p.0)).abs() <= 4.0 * p.2 * scale).collect();
    if kept.len() < 3 || kept.len() == points.len() {
        return (fit, points.len());
    }
    (line_fit(&kept, t_ref), kept.len())
}

/// The clocks from the field against the attitude (see the module's text).
fn estimate_by_attitude(board: &BoardLog, nav: &NavLog, heading: &[f64], range: (f64, f64), window: (f64, f64)) -> Result<Alignment, MergeError> {
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let series = attitude_series(nav, heading, nav_gap);
    let spread = attitude_spread(&series);
    if spread < MIN_ATTITUDE_SPREAD {
        return Err(MergeError::NoRotation(format!(
            "the navigation's attitude changes by {:.2}° RMS over its log; at least {:.1}° is needed",
            spread.to_degrees(),
            MIN_ATTITUDE_SPREAD.to_degrees()
        )));
    }
    let slower_s = median_interval(&nav.t_s).max(median_interval(&board.t_s));
    let step_s = (slower_s / GRID_PER_INTERVAL).min(median_interval(&board.t_s));
    let rows = field_grid(board, step_s);
    let (lag0, _) = coarse_lag(&rows, &series, range, window)?;
    let b0 = board.t_s[0];
    // Grid points per independent sample (their noise is shared).
    let rows_per_nav = slower_s / step_s;
    let mut map = ClockMap { offset_s: lag0, drift_ppm: 0.0, board_ref_s: b0 };
    let mut last = None;
    for iteration in 0..5 {
        let fit = field_fit(&rows, &series, &map);
        let (coef, _) = fit.solve().ok_or_else(|| MergeError::NoRotation("the attitude does not vary enough to fit the field to it".into()))?;
        let points = window_lags(&rows, &series, &coef, &map, rows_per_nav, iteration == 0);
        if points.len() < 2 {
            return Err(MergeError::NoRotation(format!("only {} window(s) of the overlap have motion that both logs see", points.len())));
        }
        let (line, used) = robust_line(&points, b0);
        map.offset_s += line.offset_s;
        map.drift_ppm += line.slope * 1e6;
        let agreement = 1.0 - fit.unexplained().unwrap_or(1.0);
        last = Some(Alignment::from_line(&line, map, used, agreement));
        if line.offset_s.abs() < 1e-5 && line.slope.abs() < 1e-8 {
            break;
        }
    }
    let found = last.ok_or_else(|| MergeError::NoRotation("no window converged".into()))?;
    if !(found.clock.drift_ppm.abs() <= MAX_DRIFT_PPM) {
        let detail = format!("the windows' offsets drift by {:.0} ppm, more than clocks do ({MAX_DRIFT_PPM} ppm)", found.clock.drift_ppm);
        return Err(MergeError::NoAgreement { detail, center_s: 0.5 * (window.0 + window.1), max_offset_s: 0.5 * (window.1 - window.0) });
    }
    Ok(found)
}

/// Below this RMS rate of turn, nothing turned (about 0.3°/s).
const MIN_RATE_SPREAD_RAD_S: f64 = 0.005;
/// Below this correlation at the best offset, the logs do not see the same turns.
const MIN_CORRELATION: f64 = 0.3;
/// Coarse and fine grids of the rate correlation, s.
const RATE_COARSE_DT_S: f64 = 0.1;
const RATE_FINE_DT_S: f64 = 0.02;
/// Lag step of the fine rate correlation, s (refined by a parabola).
const RATE_LAG_STEP_S: f64 = 0.01;

/// The lag of the best correlation in `lags` (refined by a parabola) and
/// that correlation; `None` at an end of `lags` or with no finite value.
fn correlation_peak(lags: &[(f64, f64)], step: f64) -> Option<(usize, f64, f64)> {
    let (k, &(lag, r)) = lags.iter().enumerate().filter(|(_, (_, r))| r.is_finite()).max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))?;
    if k == 0 || k + 1 == lags.len() || !lags[k - 1].1.is_finite() || !lags[k + 1].1.is_finite() {
        return Some((k, lag, r));
    }
    Some((k, lag + parabolic_vertex(lags[k - 1].1, r, lags[k + 1].1) * step, r))
}

/// The clocks from the rates of turn (no heading in the navigation log):
/// the rates' correlation over the whole logs on a coarse grid, then window
/// by window on a fine grid, a line through the windows.
fn estimate_by_rates(board: &BoardLog, nav: &NavLog, range: (f64, f64), window: (f64, f64)) -> Result<Alignment, MergeError> {
    let (b0, b1) = (board.t_s[0], *board.t_s.last().unwrap_or(&board.t_s[0]));
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let board_gap = (5.0 * median_interval(&board.t_s)).max(0.5);
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let coarse = RateViews::new(board, nav, RATE_COARSE_DT_S, board_gap, nav_gap);
    let (sb, sn) = (coarse.board.rms(b0, b1), coarse.nav.rms(n0, n1));
    if sb < MIN_RATE_SPREAD_RAD_S || sn < MIN_RATE_SPREAD_RAD_S {
        return Err(MergeError::NoRotation(format!(
            "the RMS rate of turn is {:.2}°/s (board, across the field) and {:.2}°/s (navigation); at least {:.2}°/s is needed in both",
            sb.to_degrees(),
            sn.to_degrees(),
            MIN_RATE_SPREAD_RAD_S.to_degrees()
        )));
    }
    let steps = ((range.1 - range.0) / RATE_COARSE_DT_S).floor() as usize + 1;
    let min_pairs = (MIN_OVERLAP_S / RATE_COARSE_DT_S) as usize;
    let lags: Vec<(f64, f64)> = (0..steps)
        .map(|s| {
            let lag = range.0 + s as f64 * RATE_COARSE_DT_S;
            let (r, n) = coarse.correlation(lag, b0, b1);
            (lag, if n >= min_pairs { r } else { f64::NAN })
        })
        .collect();
    let (k, lag0, r0) = correlation_peak(&lags, RATE_COARSE_DT_S).ok_or_else(|| MergeError::NoRotation("no offset in the search range leaves rotation in both logs".into()))?;
    if k == 0 || k + 1 == lags.len() {
        return Err(MergeError::OutsideWindow { best_s: lag0, center_s: 0.5 * (window.0 + window.1), max_offset_s: 0.5 * (window.1 - window.0) });
    }
    if r0 < MIN_CORRELATION {
        return Err(MergeError::NoRotation(format!(
            "the best correlation of the two logs' rates of turn is {r0:.2} (at {lag0:.1} s), below {MIN_CORRELATION}: they do not see the same turns (or the true offset lies outside the search window)"
        )));
    }
    let (from, to) = (b0.max(n0 - lag0), b1.min(n1 - lag0));
    let fine = RateViews::new(board, nav, RATE_FINE_DT_S, board_gap, nav_gap);
    let windows = (((to - from) / 120.0).floor() as usize).clamp(1, 16);
    let width = (to - from) / windows as f64;
    let half = ((0.3 + 2e-4 * (to - from)) / RATE_LAG_STEP_S).ceil() as i64;
    let points: Vec<(f64, f64, f64)> = (0..windows)
        .filter_map(|w| {
            let (a, b) = (from + w as f64 * width, from + (w + 1) as f64 * width);
            if fine.board.rms(a, b) < MIN_RATE_SPREAD_RAD_S {
                return None;
            }
            let rs: Vec<(f64, f64)> = (-half..=half).map(|s| lag0 + s as f64 * RATE_LAG_STEP_S).map(|l| (l, fine.correlation(l, a, b).0)).collect();
            let (k, lag, r) = correlation_peak(&rs, RATE_LAG_STEP_S)?;
            (r >= 0.5 && k > 0 && k + 1 < rs.len()).then_some((0.5 * (a + b), lag, RATE_LAG_STEP_S / 12f64.sqrt()))
        })
        .collect();
    if points.is_empty() {
        return Err(MergeError::NoRotation("no window of the overlap has rotation that both logs see alike".into()));
    }
    let (line, used) = robust_line(&points, b0);
    Ok(Alignment::from_line(&line, ClockMap { offset_s: line.offset_s, drift_ppm: line.slope * 1e6, board_ref_s: b0 }, used, r0))
}

/// Finds the clocks with `t_nav − t_board` searched within
/// `center_s ± max_offset_s`: from the field against the attitude when the
/// navigation log has a heading, from the rates of turn otherwise.
pub(super) fn estimate_clock(board: &BoardLog, nav: &NavLog, center_s: f64, max_offset_s: f64) -> Result<Alignment, MergeError> {
    let range = search_range(board, nav, center_s, max_offset_s)?;
    let window = (center_s - max_offset_s, center_s + max_offset_s);
    match nav.heading_deg.as_deref() {
        Some(heading) => estimate_by_attitude(board, nav, heading, range, window),
        None => estimate_by_rates(board, nav, range, window),
    }
}
