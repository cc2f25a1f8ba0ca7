//! The clock search: `t_nav = t_board + offset + drift·(t_board − t₀)`
//! from every signal both logs share.
//!
//! Coarse ([`super::coarse`]): each shared signal — the attitude with the
//! navigation's heading, the GPS course where there is one, the tilt
//! (always), the rates of turn — is scored at every lag of the search
//! range; the scores, each in units of its own spread at unrelated lags,
//! are added, and the sum's peak is accepted only when it is unique
//! ([`super::judge`]: it beats every other peak by several σ of that
//! spread), at any height.
//!
//! Fine, with one model whose lag is exact on the navigation clock — the
//! attitude with the AHRS heading, otherwise the tilt (the course is late
//! by the GPS's unknown delay and only picks the peak): the model fitted
//! at the coarse lag ([`super::fit`]: exact only when the clocks are
//! aligned, whatever the sensor's calibration), each window of the overlap
//! gets its own lag by Gauss–Newton on the cubic between navigation rows
//! (any fraction of a row) and a σ from its residuals and how fast its
//! prediction moves; a weighted line through the windows gives the offset
//! and drift, their σ scaled up by the windows' scatter about the line.
//! Model and windows are iterated. Every attitude change counts — turns
//! and their ends, rolls, dive and climb pitch changes, wiggles on a
//! straight leg — weighted by how much it moves the field. When neither
//! model has motion to time (a level vehicle, no heading, a gyro), the
//! rates' correlation is refined window by window instead.

use super::super::board_log::BoardLog;
use super::super::nav_log::NavLog;
use super::super::pairing::ClockMap;
use super::coarse::{self, Curve, Model, COARSE_STEP_S, MIN_ATTITUDE_SPREAD, MIN_OVERLAP_S, MIN_RATE_SPREAD_RAD_S, MIN_TILT_SPREAD};
use super::fine::{self, robust_line, AtNavRows, OnGrid};
use super::fit::LineFit;
use super::judge::{self, Peak, MIN_HEIGHT_SIGMA, MIN_MARGIN_SIGMA};
use super::signals::{attitude_series, field_series, rough_normalisation, tilt_series, Cubic, RateViews, FEATURES};
use super::{median_interval, no_overlap, MergeError, NoRotation, SharedSignal};

/// The logs must overlap by [`MIN_OVERLAP_S`] and at least this share of
/// the shorter log.
const MIN_OVERLAP_SHARE: f64 = 0.5;
/// The most the two clocks may drift apart, ppm (crystals: ±100).
const MAX_DRIFT_PPM: f64 = 1000.0;

/// How the clock search judged its answer.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Search {
    /// The signals scored ([`super::coarse`]).
    pub(super) signals: Vec<SharedSignal>,
    /// The one the fine stage timed the windows with.
    pub(super) timed_by: SharedSignal,
    /// The peak's margin over the runner-up, null σ (`None`: no other peak).
    pub(super) margin_sigma: Option<f64>,
    /// The runner-up's offset, s.
    pub(super) runner_up_s: Option<f64>,
    /// The offsets searched (`t_nav − t_board`), s: the window, cut to
    /// where the logs overlap.
    pub(super) range: (f64, f64),
}

/// What the alignment found.
#[derive(Debug, Clone)]
pub(super) struct Alignment {
    pub(super) clock: ClockMap,
    pub(super) offset_sigma_s: f64,
    pub(super) drift_sigma_ppm: f64,
    pub(super) drift_fitted: bool,
    pub(super) windows: usize,
    /// How well the logs agree at the offset found (1 = perfectly).
    pub(super) agreement: f64,
    /// How the answer was judged (`None`: the clocks were given).
    pub(super) search: Option<Search>,
}

impl Alignment {
    fn from_line(line: &LineFit, clock: ClockMap, windows: usize, agreement: f64) -> Self {
        Self { clock, offset_sigma_s: line.offset_sigma_s, drift_sigma_ppm: line.slope_sigma * 1e6, drift_fitted: line.slope_fitted, windows, agreement, search: None }
    }
}

/// The lags (`t_nav − t_board`) to search: the window `center ± max`
/// where the logs would share at least [`MIN_OVERLAP_S`] and half the
/// shorter log (a short overlap is explained by any attitude).
fn search_range(board: &BoardLog, nav: &NavLog, center_s: f64, max_offset_s: f64) -> Result<(f64, f64), MergeError> {
    if !(max_offset_s.is_finite() && max_offset_s >= 0.0 && center_s.is_finite()) {
        return Err(MergeError::BadSearchWindow { center_s, max_offset_s });
    }
    if max_offset_s < 2.0 * COARSE_STEP_S {
        return Err(MergeError::SearchWindowTooNarrow { center_s, max_offset_s, min_s: 2.0 * COARSE_STEP_S });
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
fn field_grid(board: &BoardLog, field: &Cubic<3>, step_s: f64) -> Vec<(f64, [f64; 3])> {
    let gap_s = board_gap_s(board);
    let b0 = board.t_s[0];
    let mut out = Vec::new();
    // Interval by interval, so a long gap costs nothing.
    for w in board.t_s.windows(2).filter(|w| w[1] - w[0] <= gap_s) {
        let (k0, k1) = (((w[0] - b0) / step_s).ceil() as usize, ((w[1] - b0) / step_s).ceil() as usize);
        out.extend((k0..k1).map(|k| b0 + k as f64 * step_s).filter_map(|t| field.at(t).map(|(y, _)| (t, y))));
    }
    out
}

/// The longest board interval read across, s.
fn board_gap_s(board: &BoardLog) -> f64 {
    (5.0 * median_interval(&board.t_s)).max(0.5)
}

/// The board's usable raw field, centred and scaled per axis (by its
/// spread's middle and half-range, [`rough_normalisation`]): both models
/// are affine in it, so nothing changes but the tilt fit's conditioning.
fn normalised_field(board: &BoardLog) -> Cubic<3> {
    let norm = rough_normalisation(&board.mag);
    let mag = board.mag.iter().map(|y| [0, 1, 2].map(|a| (y[a] - norm[a].0) / norm[a].1)).collect();
    field_series(&BoardLog { mag, ..board.clone() }, board_gap_s(board))
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

/// Grid of the rates' fine correlation, s.
pub(super) const RATE_FINE_DT_S: f64 = 0.02;
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

/// The fine stage on the rates alone (neither model has motion to time):
/// the rates' correlation window by window on a fine grid around the
/// coarse lag `lag0`, a line through the windows.
fn fine_by_rates(board: &BoardLog, nav: &NavLog, lag0: f64) -> Result<Alignment, MergeError> {
    let (b0, b1) = (board.t_s[0], *board.t_s.last().unwrap_or(&board.t_s[0]));
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let board_gap = (5.0 * median_interval(&board.t_s)).max(0.5);
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let (from, to) = (b0.max(n0 - lag0), b1.min(n1 - lag0));
    let fine = RateViews::new(board, nav, RATE_FINE_DT_S, board_gap, nav_gap);
    let windows = (((to - from) / 120.0).floor() as usize).clamp(1, 16);
    let width = (to - from) / windows as f64;
    let half = ((0.3 + 2e-4 * (to - from)) / RATE_LAG_STEP_S).ceil() as i64;
    let mut best_r: f64 = f64::NAN;
    let points: Vec<(f64, f64, f64)> = (0..windows)
        .filter_map(|w| {
            let (a, b) = (from + w as f64 * width, from + (w + 1) as f64 * width);
            if fine.board.rms(a, b) < MIN_RATE_SPREAD_RAD_S {
                return None;
            }
            let rs: Vec<(f64, f64)> = (-half..=half).map(|s| lag0 + s as f64 * RATE_LAG_STEP_S).map(|l| (l, fine.correlation(l, a, b).0)).collect();
            let (k, lag, r) = correlation_peak(&rs, RATE_LAG_STEP_S)?;
            best_r = best_r.max(r);
            (r >= 0.5 && k > 0 && k + 1 < rs.len()).then_some((0.5 * (a + b), lag, RATE_LAG_STEP_S / 12f64.sqrt()))
        })
        .collect();
    if points.is_empty() {
        return Err(MergeError::NoRotation(NoRotation::NoSharedWindow));
    }
    let (line, used) = robust_line(&points, b0);
    Ok(Alignment::from_line(&line, ClockMap { offset_s: line.offset_s, drift_ppm: line.slope * 1e6, board_ref_s: b0 }, used, best_r))
}

/// A course good enough to score: on at least [`MIN_COURSE_ROWS`]
/// navigation rows, turning at least as much as an attitude must.
const MIN_COURSE_ROWS: usize = 3 * FEATURES * 10;

/// The index of the highest score of `curve` within `radius` indices of
/// `k` (the fine model's own peak near the combined one), refined by a
/// parabola, as a lag.
fn own_peak(curve: &[f64], lags: &[f64], k: usize, radius: usize) -> Option<f64> {
    if curve.len() != lags.len() || lags.is_empty() {
        return None;
    }
    let lo = k.saturating_sub(radius);
    let hi = (k + radius).min(curve.len() - 1);
    let (j, &top) = (lo..=hi).map(|j| (j, &curve[j])).filter(|(_, v)| v.is_finite()).max_by(|a, b| a.1.total_cmp(b.1))?;
    let vertex = match (j.checked_sub(1).and_then(|i| curve.get(i)), curve.get(j + 1)) {
        (Some(a), Some(c)) if a.is_finite() && c.is_finite() => parabolic_vertex(*a, top, *c),
        _ => 0.0,
    };
    Some(lags[j] + vertex * COARSE_STEP_S)
}

/// Finds the clocks with `t_nav − t_board` searched within
/// `center_s ± max_offset_s` from every signal both logs share (see the
/// module's text); refused when no signal moves, when the best offset is
/// at an end of the window, or when it is not unique.
pub(super) fn estimate_clock(board: &BoardLog, nav: &NavLog, center_s: f64, max_offset_s: f64) -> Result<Alignment, MergeError> {
    let range = search_range(board, nav, center_s, max_offset_s)?;
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let slower_s = median_interval(&nav.t_s).max(median_interval(&board.t_s));
    let step_s = (slower_s / GRID_PER_INTERVAL).min(median_interval(&board.t_s));
    let field = normalised_field(board);
    let rows = field_grid(board, &field, step_s);
    // Grid points per independent sample (their noise is shared).
    let rows_per_nav = slower_s / step_s;
    let lags = coarse::lags(range);

    // The signals the logs share, each if it moves.
    let ahrs = nav.heading_deg.as_deref().map(|h| attitude_series(nav, h, nav_gap));
    let ahrs_spread = ahrs.as_ref().map_or(0.0, coarse::attitude_spread);
    let ahrs = ahrs.filter(|_| ahrs_spread >= MIN_ATTITUDE_SPREAD);
    let course_rows = nav.ref_heading_deg.as_deref().map_or(0, |c| c.iter().filter(|v| v.is_finite()).count());
    let course = match (&nav.heading_deg, &nav.ref_heading_deg) {
        (None, Some(c)) if course_rows >= MIN_COURSE_ROWS => Some(attitude_series(nav, c, nav_gap)).filter(|s| coarse::attitude_spread(s) >= MIN_ATTITUDE_SPREAD),
        _ => None,
    };
    let tilt = tilt_series(nav, nav_gap);
    let tilt_spread = coarse::tilt_spread(&tilt);
    let tilt = Some(tilt).filter(|_| tilt_spread >= MIN_TILT_SPREAD);
    let mut curves: Vec<Curve> = Vec::new();
    if let Some(s) = &ahrs {
        curves.push(coarse::model_curve(SharedSignal::Attitude, Model::Attitude, &rows, s, &lags, 1.0));
    }
    if let Some(s) = &course {
        curves.push(coarse::course_curve(&rows, s, &lags, course_rows as f64 / nav.t_s.len().max(1) as f64));
    }
    if let Some(s) = &tilt {
        curves.push(coarse::model_curve(SharedSignal::Tilt, Model::Tilt, &rows, s, &lags, 1.0));
    }
    let rates = coarse::rate_curve(board, nav, &lags);
    let have_rates = rates.is_some();
    curves.extend(rates);
    let standardised: Vec<(SharedSignal, Vec<f64>)> = curves.iter().filter_map(|c| judge::standardise(&c.score).map(|z| (c.signal, z))).collect();
    if standardised.is_empty() {
        return Err(MergeError::NoRotation(NoRotation::TooSteady {
            attitude_spread_deg: ahrs_spread.to_degrees(),
            attitude_needed_deg: MIN_ATTITUDE_SPREAD.to_degrees(),
            tilt_spread_deg: tilt_spread.to_degrees(),
            tilt_needed_deg: MIN_TILT_SPREAD.to_degrees(),
            rates_flat: have_rates,
        }));
    }
    let z = judge::combine(&standardised.iter().map(|(_, z)| z.clone()).collect::<Vec<_>>());
    let window = (center_s, max_offset_s);
    let peak = judge::find_peak(&z).ok_or(MergeError::NoRotation(NoRotation::FlatAgreement))?;
    judge_peak(&peak, &lags, window)?;

    // The fine stage, with the model whose lag is exact.
    let b0 = board.t_s[0];
    let own = |signal: SharedSignal| {
        let curve = curves.iter().find(|c| c.signal == signal).map(|c| c.score.as_slice()).unwrap_or(&[]);
        let radius = (peak.lobe.1 - peak.lobe.0).max((2.0 / COARSE_STEP_S) as usize);
        own_peak(curve, &lags, peak.k, radius).unwrap_or(lags[peak.k])
    };
    let (mut found, timed_by) = if let Some(s) = &ahrs {
        let f = fine::fine(&mut OnGrid::new(Model::Attitude, &rows, s, rows_per_nav), own(SharedSignal::Attitude), b0)?;
        (Alignment::from_line(&f.line, f.clock, f.windows, 1.0 - f.misfit), SharedSignal::Attitude)
    } else if let Some(s) = &tilt {
        let f = fine::fine(&mut AtNavRows::new(&nav.t_s, s, &field, nav_gap), own(SharedSignal::Tilt), b0)?;
        // The share of an unrelated lag's misfit (the coarse curve's median) left.
        let null = curves.iter().find(|c| c.signal == SharedSignal::Tilt).and_then(|c| {
            let mut v: Vec<f64> = c.score.iter().copied().filter(|v| v.is_finite()).collect();
            calib_core::series::median(&mut v)
        });
        (Alignment::from_line(&f.line, f.clock, f.windows, null.map_or(f64::NAN, |m| 1.0 - f.misfit * m.exp())), SharedSignal::Tilt)
    } else {
        (fine_by_rates(board, nav, own(SharedSignal::Rates))?, SharedSignal::Rates)
    };
    if !(found.clock.drift_ppm.abs() <= MAX_DRIFT_PPM) {
        return Err(MergeError::DriftTooLarge { drift_ppm: found.clock.drift_ppm, max_drift_ppm: MAX_DRIFT_PPM });
    }
    found.search = Some(Search {
        signals: standardised.iter().map(|(s, _)| *s).collect(),
        timed_by,
        margin_sigma: peak.margin_sigma.is_finite().then_some(peak.margin_sigma),
        runner_up_s: peak.runner_up.map(|j| lags[j]),
        range,
    });
    Ok(found)
}

/// The refusals of a peak: at an end of the lags searched (the offset may
/// lie beyond), not above the null, not unique. `window`: the search's
/// centre and half-width, s.
fn judge_peak(peak: &Peak, lags: &[f64], window: (f64, f64)) -> Result<(), MergeError> {
    let (center_s, max_offset_s) = window;
    let best_s = lags[peak.k];
    if peak.k == 0 || peak.k + 1 == lags.len() {
        return Err(MergeError::OutsideWindow { best_s, center_s, max_offset_s });
    }
    if peak.is_unique() {
        return Ok(());
    }
    if peak.height_sigma < MIN_HEIGHT_SIGMA {
        return Err(MergeError::NoAgreement { best_s, height_sigma: peak.height_sigma, min_height_sigma: MIN_HEIGHT_SIGMA, center_s, max_offset_s });
    }
    // High enough, so beaten on the margin: there is a runner-up.
    let runner_up_s = peak.runner_up.map_or(best_s, |j| lags[j]);
    Err(MergeError::NotUnique { best_s, runner_up_s, margin_sigma: peak.margin_sigma, min_margin_sigma: MIN_MARGIN_SIGMA, center_s, max_offset_s })
}
