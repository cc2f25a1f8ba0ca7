//! `magcal merge`: one recording from the board's field log and the
//! vehicle's navigation log, kept on two different clocks.
//!
//! One room per job: the logs' formats ([`super::board_log`],
//! [`super::nav_log`]); what both logs see of the motion ([`signals`]); the
//! least squares ([`fit`]); every shared signal scored at every lag
//! ([`coarse`]: attitude with a heading, the GPS course, the tilt, the
//! rates of turn); whether the best lag is unique ([`judge`]: it must beat
//! every other peak by several σ of the scores' spread at unrelated lags,
//! at any height); the clock search ([`align`]: then window by window with
//! sub-row interpolation, a line through the windows for offset and drift
//! with an honest σ); the rows on the navigation clock ([`resample`]:
//! angles the short way round, GPS only where both neighbours have it,
//! nothing beyond the navigation log or across its long gaps); why two
//! logs could not be merged ([`error`]); the logs' time checked around the
//! search ([`checks`]: a span the grids cannot hold, a clock jump).

use std::path::Path;

use serde::{Deserialize, Serialize};

pub use super::board_log::{BoardLog, HEALTH_AFTER_GAP, HEALTH_SATURATED};
pub use super::nav_log::NavLog;
use super::pairing::ClockMap;
use super::recording::RecordingError;
use super::table::{col, ColumnMap};
use super::Recording;

mod align;
mod checks;
mod coarse;
mod error;
mod fine;
mod fit;
mod judge;
mod resample;
mod signals;

use checks::{check_span, jump, median_interval, no_overlap, with_jump};
pub use error::{MergeError, NoRotation};

/// A signal both logs share, as the clock search uses it (`--json`:
/// `"attitude"`, `"course"`, `"tilt"`, `"rates"`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SharedSignal {
    /// The raw field against the attitude with the navigation's heading.
    Attitude,
    /// The raw field against the attitude with the GPS course as heading,
    /// where there is one (no heading column); late by the GPS's delay.
    Course,
    /// The raw field's component along the navigation's down direction
    /// (roll and pitch alone: constant only when the clocks are aligned).
    Tilt,
    /// The measured field's rate of rotation against the navigation's body
    /// rate (across the field; without the heading's rate, across the
    /// vertical too).
    Rates,
}

/// How the clocks are found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Clock {
    /// Estimated from the data: `t_nav − t_board` is searched within
    /// `center_s ± max_offset_s`.
    Estimate {
        /// Centre of the search, s.
        center_s: f64,
        /// Half-width of the search, s.
        max_offset_s: f64,
    },
    /// Given: `t_nav = t_board + offset_s + drift_ppm·10⁻⁶·(t_board − first board time)`.
    Given {
        /// Offset at the board log's first sample, s.
        offset_s: f64,
        /// Drift, ppm.
        drift_ppm: f64,
    },
}

impl Default for Clock {
    fn default() -> Self {
        Clock::Estimate { center_s: 0.0, max_offset_s: 120.0 }
    }
}

/// The clocks found and what was merged (`magcal merge --json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MergeReport {
    /// `t_nav − t_board` at the board log's first sample, s.
    pub offset_s: f64,
    /// 1σ of `offset_s`, s (0 when given).
    pub offset_sigma_s: f64,
    /// How much faster the navigation clock runs, ppm.
    pub drift_ppm: f64,
    /// 1σ of `drift_ppm` (0 when given or not fitted).
    pub drift_sigma_ppm: f64,
    /// The board time the offset refers to (the board log's first), s.
    pub board_ref_s: f64,
    /// The clocks were estimated from the data (not given).
    pub estimated: bool,
    /// The drift was fitted (enough windows); otherwise taken as given or 0.
    pub drift_fitted: bool,
    /// Windows whose offsets the line was fitted to.
    pub windows_used: usize,
    /// How well the logs agree at the offset found, 1 = perfectly: the
    /// share of the raw field's spread the attitude explains (timed by the
    /// attitude), the share of an unrelated offset's tilt misfit removed
    /// (timed by the tilt), or the correlation of the two rates of turn.
    /// A judge of the data, not of the offset: a unique peak is accepted
    /// at any height.
    pub peak_correlation: f64,
    /// The signals both logs share that the search scored (empty when the
    /// clocks were given).
    #[serde(default)]
    pub signals: Vec<SharedSignal>,
    /// The signal the windows were timed with (`None` when given).
    #[serde(default)]
    pub timed_by: Option<SharedSignal>,
    /// How much better the logs agree at the offset found than at the
    /// runner-up, in σ of the agreement's spread at unrelated offsets
    /// (at least 3 to be accepted; `None` when given or with no other peak).
    #[serde(default)]
    pub margin_sigma: Option<f64>,
    /// The runner-up's offset, s (`None` when given or with no other peak).
    #[serde(default)]
    pub runner_up_offset_s: Option<f64>,
    /// Rows written (board samples within the navigation log's span).
    pub rows: usize,
    /// Board samples in the board log.
    pub board_samples: usize,
    /// Board samples before or after the navigation log (not written: never
    /// extrapolated).
    pub board_samples_outside_nav: usize,
    /// Rows in a gap of the navigation log (written without navigation).
    pub rows_in_nav_gaps: usize,
    /// Rows whose field was saturated (written without a field).
    pub saturated_rows: usize,
    /// The navigation rows' median interval, s.
    pub nav_interval_s: f64,
    /// The board samples' median interval, s.
    pub board_interval_s: f64,
    /// The longest gap of the navigation log interpolated across, s
    /// (longer gaps' rows are written without navigation and counted in
    /// `rows_in_nav_gaps`).
    #[serde(default)]
    pub nav_gap_limit_s: f64,
    /// What was converted or not checked, in words (a log's time unit, a
    /// given offset the data could not check).
    #[serde(default)]
    pub notes: Vec<String>,
    /// What the data leave weak and was kept, in words (an offset found
    /// at its search window's end; a given offset the data disagree with,
    /// kept as weak results are allowed).
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// The longest gap of the navigation log interpolated across by default,
/// s: a vehicle's roll and pitch change by degrees within a second or two
/// (a wave's or a glider's roll period is a few seconds), so a straight
/// line across a longer gap makes attitude up (a 0.1 Hz navigation log
/// interpolated across its 10 s steps was 9.6° RMS off in roll).
pub const MAX_NAV_GAP_S: f64 = 2.0;

/// A given offset may differ from the one the data show by this much, s
/// (a coarse search step, twice)…
pub const MIN_OFFSET_ALLOWANCE_S: f64 = 0.5;
/// …or this many of the found offset's σ, whichever is larger.
pub const OFFSET_ALLOWANCE_SIGMA: f64 = 5.0;
/// The half-width of the search around a given offset that checks it, s
/// (the default search window's).
pub const OFFSET_CHECK_WINDOW_S: f64 = 120.0;
/// An offset found within this of an end of the offsets searched is "at
/// the window's edge", s (four coarse steps: the peak's lobe reaches it).
pub const WINDOW_EDGE_S: f64 = 1.0;
/// The clock search's grids may hold this many points per log row…
pub const GRID_POINTS_PER_ROW: f64 = 64.0;
/// …beyond this many (a floor for short logs with pauses).
pub const GRID_POINTS_FLOOR: f64 = 1e6;
/// A step this many times a log's median step, and at least
/// [`JUMP_MIN_S`], is named as a possible clock jump when the search fails.
pub const JUMP_RATIO: f64 = 20.0;
/// The shortest step named as a possible clock jump, s.
pub const JUMP_MIN_S: f64 = 5.0;

/// What `merge` may keep, and how far it interpolates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MergeOptions {
    /// The longest gap of the navigation log interpolated across, s
    /// ([`MAX_NAV_GAP_S`]); never beyond five of the log's median steps
    /// (at least 1 s), the rule for a log's dropouts.
    pub max_nav_gap_s: f64,
    /// Keep a given offset the data disagree with (said in the report's
    /// warnings).
    pub allow_weak: bool,
    /// Refuse an offset found at its search window's edge (otherwise kept
    /// and said).
    pub strict: bool,
}

impl Default for MergeOptions {
    fn default() -> Self {
        Self { max_nav_gap_s: MAX_NAV_GAP_S, allow_weak: false, strict: false }
    }
}

/// Merges a board log and a navigation log into one recording on the
/// navigation clock (`t` = the board sample's time mapped to the navigation
/// clock), with `speed_mps`, `motor_current_a` and `temp_c` when the logs
/// have them. Extra columns (ignored by the recording reader but kept for
/// users): `t_board`, `heading_deg` — see [`Merged::extra_columns`].
pub fn merge(board: &BoardLog, nav: &NavLog, clock: Clock) -> Result<Merged, MergeError> {
    merge_with(board, nav, clock, &MergeOptions::default())
}

/// [`merge`] with `opts`: the navigation interpolated across gaps up to
/// `opts.max_nav_gap_s`; a given offset checked against the offset the
/// data show within [`OFFSET_CHECK_WINDOW_S`] of it (refused beyond
/// [`MIN_OFFSET_ALLOWANCE_S`] or [`OFFSET_ALLOWANCE_SIGMA`] σ unless
/// `opts.allow_weak`, then said); an offset found within
/// [`WINDOW_EDGE_S`] of the end of the offsets searched said (refused
/// when `opts.strict`); a failed search across a log's clock jump names
/// the jump; a log whose span its rows cannot fill refused before any grid
/// is made.
pub fn merge_with(board: &BoardLog, nav: &NavLog, clock: Clock, opts: &MergeOptions) -> Result<Merged, MergeError> {
    if board.t_s.is_empty() || nav.t_s.is_empty() {
        return Err(MergeError::EmptyLog { board_rows: board.t_s.len(), nav_rows: nav.t_s.len() });
    }
    let (mut notes, mut warnings) = (Vec::new(), Vec::new());
    let estimate = |center_s: f64, max_offset_s: f64| -> Result<align::Alignment, MergeError> {
        check_span("board", &board.t_s)?;
        check_span("navigation", &nav.t_s)?;
        align::estimate_clock(board, nav, center_s, max_offset_s).map_err(|e| with_jump(e, board, nav))
    };
    let b_mid = 0.5 * (board.t_s[0] + board.t_s[board.t_s.len() - 1]);
    let alignment = match clock {
        Clock::Estimate { center_s, max_offset_s } => {
            let found = estimate(center_s, max_offset_s)?;
            if let Some(search) = &found.search {
                let at = found.clock.to_nav(b_mid) - b_mid;
                let (lo, hi) = search.range;
                if lo > center_s - max_offset_s || hi < center_s + max_offset_s {
                    notes.push(format!(
                        "the search window {center_s} ± {max_offset_s} s reaches beyond the offsets at which the logs overlap (at least 20 s and half the shorter log): searched {lo:.2} … {hi:.2} s"
                    ));
                }
                let end = if (at - lo).abs() < (hi - at).abs() { lo } else { hi };
                if (at - end).abs() <= WINDOW_EDGE_S {
                    let text = format!(
                        "the clock offset found, {at:.3} s (navigation − board, mid-log), is within {WINDOW_EDGE_S} s of the end of the offsets searched ({lo:.2} … {hi:.2} s: the window {center_s} ± {max_offset_s} s where the logs overlap): the logs may agree better beyond it"
                    );
                    if opts.strict {
                        return Err(MergeError::AtWindowEdge(text));
                    }
                    warnings.push(text);
                }
            }
            found
        }
        Clock::Given { offset_s, drift_ppm } => {
            if !(offset_s.is_finite() && drift_ppm.is_finite() && drift_ppm.abs() < 1e5) {
                return Err(MergeError::BadGivenClock { offset_s, drift_ppm });
            }
            let clock = ClockMap { offset_s, drift_ppm, board_ref_s: board.t_s[0] };
            let given_mid = clock.to_nav(b_mid) - b_mid;
            match estimate(given_mid, OFFSET_CHECK_WINDOW_S) {
                Ok(found) => {
                    let ends = [board.t_s[0], board.t_s[board.t_s.len() - 1]];
                    let diff_s = ends.iter().map(|&t| (clock.to_nav(t) - found.clock.to_nav(t)).abs()).fold(0.0, f64::max);
                    let allowance_s = MIN_OFFSET_ALLOWANCE_S.max(OFFSET_ALLOWANCE_SIGMA * found.offset_sigma_s);
                    if !(diff_s <= allowance_s) {
                        let e = MergeError::GivenOffsetDisagrees { given_s: given_mid, found_s: found.clock.to_nav(b_mid) - b_mid, sigma_s: found.offset_sigma_s, diff_s, allowance_s };
                        if !opts.allow_weak {
                            return Err(e);
                        }
                        warnings.push(format!("{e}: kept as weak results are allowed"));
                    }
                }
                Err(e) => notes.push(format!("the clock offset given could not be checked against the data ({e})")),
            }
            align::Alignment { clock, offset_sigma_s: 0.0, drift_sigma_ppm: 0.0, drift_fitted: false, windows: 0, agreement: f64::NAN, search: None }
        }
    };
    let max_gap_s = if opts.max_nav_gap_s > 0.0 { opts.max_nav_gap_s } else { MAX_NAV_GAP_S };
    let (recording, extra, counts) = resample::rows(board, nav, &alignment.clock, max_gap_s);
    if recording.mag.is_empty() {
        return Err(no_overlap(board, nav, format!("with the clock offset {:.3} s (navigation − board) no board sample falls within the navigation log", alignment.clock.offset_s)));
    }
    for (log, t) in [("navigation", &nav.t_s), ("board", &board.t_s)] {
        if let Some((i, step_s, ratio)) = jump(t) {
            warnings.push(format!(
                "the {log} log's time steps from {:.3} s to {:.3} s after data row {} ({step_s:.3} s, {ratio:.0}× its median step): a clock jump or a gap; the clock offset holds on both sides only if it is a gap",
                t[i],
                t[i + 1],
                i + 1
            ));
        }
    }
    let nav_step = median_interval(&nav.t_s);
    if nav_step > max_gap_s {
        notes.push(format!(
            "the navigation log's median step {nav_step:.3} s is longer than the {max_gap_s} s interpolated across: the board samples between its rows are written without navigation ({} rows)",
            counts.in_gaps
        ));
    }
    let map = alignment.clock;
    let report = MergeReport {
        offset_s: map.offset_s,
        offset_sigma_s: alignment.offset_sigma_s,
        drift_ppm: map.drift_ppm,
        drift_sigma_ppm: alignment.drift_sigma_ppm,
        board_ref_s: map.board_ref_s,
        estimated: matches!(clock, Clock::Estimate { .. }),
        drift_fitted: alignment.drift_fitted,
        windows_used: alignment.windows,
        peak_correlation: if alignment.agreement.is_finite() { alignment.agreement } else { 0.0 },
        signals: alignment.search.as_ref().map_or(vec![], |s| s.signals.clone()),
        timed_by: alignment.search.as_ref().map(|s| s.timed_by),
        margin_sigma: alignment.search.as_ref().and_then(|s| s.margin_sigma),
        runner_up_offset_s: alignment.search.as_ref().and_then(|s| s.runner_up_s),
        rows: recording.mag.len(),
        board_samples: board.t_s.len(),
        board_samples_outside_nav: counts.outside,
        rows_in_nav_gaps: counts.in_gaps,
        saturated_rows: counts.saturated,
        nav_interval_s: median_interval(&nav.t_s),
        board_interval_s: median_interval(&board.t_s),
        nav_gap_limit_s: max_gap_s,
        notes,
        warnings,
    };
    Ok(Merged { recording, extra, report })
}

/// The merged columns the recording format has no field for.
#[derive(Debug, Clone, Default)]
pub struct MergedExtra {
    /// The sample's time on the board's clock, s.
    pub t_board_s: Vec<f64>,
    /// The AHRS's heading, degrees.
    pub heading_deg: Option<Vec<f64>>,
}

/// A merged recording and its report.
#[derive(Debug, Clone)]
pub struct Merged {
    /// The recording (INTERFACES.md columns), `t` on the navigation clock.
    pub recording: Recording,
    /// Columns beyond the recording's fields.
    pub extra: MergedExtra,
    /// The clocks and counts.
    pub report: MergeReport,
}

impl Merged {
    /// The extra columns by name, as [`Recording::write_with_extra`] takes them.
    pub fn extra_columns(&self) -> Vec<(&'static str, &[f64])> {
        let e = &self.extra;
        let mut cols: Vec<(&'static str, &[f64])> = vec![(col::T_BOARD, &e.t_board_s)];
        if let Some(c) = &e.heading_deg {
            cols.push((col::HEADING_DEG, c));
        }
        cols
    }

    /// Writes the recording with its extra columns.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        self.recording.write_with_extra(path, &self.extra_columns())
    }
}

/// Reads both logs and merges them (see [`merge`]).
pub fn merge_files(board: &Path, nav: &Path, clock: Clock) -> Result<Merged, MergeError> {
    merge_files_mapped(board, nav, &ColumnMap::default(), clock)
}

/// [`merge_files`] with the navigation log under its own column names and
/// units (`nav_columns`).
pub fn merge_files_mapped(board: &Path, nav: &Path, nav_columns: &ColumnMap, clock: Clock) -> Result<Merged, MergeError> {
    merge_files_with(board, &ColumnMap::default(), nav, nav_columns, clock, &MergeOptions::default())
}

/// [`merge_files_mapped`] with the board log's mapping too and `opts`
/// ([`merge_with`]). Each log's `t` in ms or µs (found from its step by
/// [`super::intake::time_unit`] unless its mapping gives the unit) is
/// converted to seconds and said in the report's notes, or refused when
/// its step does not tell.
pub fn merge_files_with(board: &Path, board_columns: &ColumnMap, nav: &Path, nav_columns: &ColumnMap, clock: Clock, opts: &MergeOptions) -> Result<Merged, MergeError> {
    let (mut b, mut n) = (BoardLog::read_mapped(board, board_columns)?, NavLog::read_mapped(nav, nav_columns)?);
    let mut notes = Vec::new();
    if board_columns.unit(col::T).is_none() {
        notes.extend(super::intake::convert_time(&mut b.t_s, board)?);
    }
    if nav_columns.unit(col::T).is_none() {
        notes.extend(super::intake::convert_time(&mut n.t_s, nav)?);
    }
    let mut merged = merge_with(&b, &n, clock, opts)?;
    notes.append(&mut merged.report.notes);
    merged.report.notes = notes;
    Ok(merged)
}

#[cfg(test)]
mod tests;
