//! The coarse search: every signal both logs share, scored at every lag of
//! the search range on one grid ([`COARSE_STEP_S`]), the whole overlap.
//!
//! * attitude (the navigation log's heading): the raw field fitted to the
//!   rotation body → NED ([`super::fit::FieldFit`]); score `−ln` of the
//!   share of the field's spread left unexplained;
//! * course (no heading, a GPS course where there is one — at the surface):
//!   the same fit on the rows with a course; the course is late on the
//!   navigation clock by the GPS's own delay and off the heading by the
//!   crab angle, so its score at a lag is its best over the lags up to
//!   [`COURSE_DELAY_MAX_S`] later — it tells which peak, never where in it;
//! * tilt (always: roll and pitch): the field's component along the down
//!   direction is constant ([`super::fit::TiltFit`]); score `−ln` of the
//!   residuals' mean square;
//! * rates: the rate of rotation of the measured field against the
//!   navigation's body rate ([`RateViews`]); score the correlation.
//!
//! A signal the logs do not show enough of (no heading, no tilt, no turn)
//! is left out; the others go to [`super::judge`].

use super::super::board_log::BoardLog;
use super::super::nav_log::NavLog;
use super::super::pairing::ClockMap;
use super::fit::{predict, FieldFit, TiltFit};
use super::signals::{down, tilt_features, AttitudeSeries, RateViews, FEATURES, TILT_FEATURES};
use super::{median_interval, SharedSignal};

/// Lag step of the coarse search, s (refined by a parabola).
pub(super) const COARSE_STEP_S: f64 = 0.25;
/// Work budget of a model's coarse search: lags × rows.
const COARSE_BUDGET: f64 = 4e6;
/// The longest a GPS course may lag the attitude on the navigation clock, s.
pub(super) const COURSE_DELAY_MAX_S: f64 = 5.0;
/// Grid of the rate correlation, s.
pub(super) const RATE_COARSE_DT_S: f64 = 0.1;
/// Work budget of the rates' coarse search: lags × grid points.
const RATE_BUDGET: f64 = 2e7;
/// The least overlap to align on, s.
pub(super) const MIN_OVERLAP_S: f64 = 20.0;

/// Below this RMS change of attitude (about 1°, in rotation entries),
/// nothing turned.
pub(super) const MIN_ATTITUDE_SPREAD: f64 = 0.017;
/// Below this RMS change of the down direction (about 0.6°), nothing tilted.
pub(super) const MIN_TILT_SPREAD: f64 = 0.01;
/// Below this RMS rate of turn, nothing turned (about 0.3°/s).
pub(super) const MIN_RATE_SPREAD_RAD_S: f64 = 0.005;

/// The RMS spread about their mean of the entries `pick` takes from the
/// series' rows (about the RMS angle turned, rad).
fn spread(series: &AttitudeSeries, pick: impl Fn(&[f64; FEATURES]) -> Vec<f64>) -> f64 {
    let rows: Vec<Vec<f64>> = series
        .rows()
        .filter(|x| x[0].is_finite())
        .map(&pick)
        .collect();
    if rows.len() < 2 {
        return 0.0;
    }
    let n = rows.len() as f64;
    let var: f64 = (0..rows[0].len())
        .map(|a| {
            let m = rows.iter().map(|x| x[a]).sum::<f64>() / n;
            rows.iter().map(|x| (x[a] - m).powi(2)).sum::<f64>() / n
        })
        .sum();
    (var / 2.0).sqrt()
}

/// The RMS spread of the rotation's entries (about the RMS angle turned, rad).
pub(super) fn attitude_spread(series: &AttitudeSeries) -> f64 {
    spread(series, |x| x[..FEATURES - 1].to_vec())
}

/// The RMS spread of the down direction (about the RMS tilt change, rad).
pub(super) fn tilt_spread(series: &AttitudeSeries) -> f64 {
    spread(series, |x| down(x).to_vec()) * std::f64::consts::SQRT_2
}

/// The lags searched: `range` on the [`COARSE_STEP_S`] grid.
pub(super) fn lags(range: (f64, f64)) -> Vec<f64> {
    let steps = ((range.1 - range.0) / COARSE_STEP_S).floor() as usize + 1;
    (0..steps)
        .map(|s| range.0 + s as f64 * COARSE_STEP_S)
        .collect()
}

/// Which model a fitted signal uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Model {
    /// `raw = C·vec(R) + b`.
    Attitude,
    /// `1 = β·(g ⊗ raw, g)`.
    Tilt,
}

/// The model's misfit over `rows` with the navigation `map`ped: the
/// unexplained share of the field's spread (attitude) or the residuals'
/// mean square (tilt); `None` with too few rows, or a tilt fit in a frame
/// that is not the body's ([`Fitted::in_body_frame`]).
pub(super) fn misfit(
    model: Model,
    rows: &[(f64, [f64; 3])],
    series: &AttitudeSeries,
    map: &ClockMap,
) -> Option<f64> {
    Fitted::fit(model, rows, series, map)
        .filter(|(f, _)| f.in_body_frame())
        .map(|(_, m)| m)
}

/// A diagonal entry of the tilt model's matrix smaller than this share of
/// the largest is too poorly known for its sign to count.
const FRAME_SIGN_SHARE: f64 = 0.1;

/// A fitted model: what it predicts of a board row from the navigation's
/// attitude regressors.
#[derive(Debug, Clone, Copy)]
pub(super) enum Fitted {
    /// `raw = C·x`: three residuals a row.
    Attitude([[f64; FEATURES]; 3]),
    /// `1 = β·z(g, raw)`: one residual a row.
    Tilt([f64; TILT_FEATURES]),
}

impl Fitted {
    /// The model fitted over `rows` with the navigation `map`ped, and its
    /// misfit ([`misfit`]'s); `None` when it cannot be solved.
    pub(super) fn fit(
        model: Model,
        rows: &[(f64, [f64; 3])],
        series: &AttitudeSeries,
        map: &ClockMap,
    ) -> Option<(Self, f64)> {
        match model {
            Model::Attitude => {
                let mut fit = FieldFit::new();
                for (t, y) in rows {
                    if let Some((x, _)) = series.at(map.to_nav(*t)) {
                        fit.add(&x, *y);
                    }
                }
                let (coef, _) = fit.solve()?;
                Some((Self::Attitude(coef), fit.unexplained()?))
            }
            Model::Tilt => {
                let mut fit = TiltFit::new();
                for (t, y) in rows {
                    if let Some((x, _)) = series.at(map.to_nav(*t)) {
                        fit.add(&tilt_features(down(&x), y), [1.0]);
                    }
                }
                let ([beta], _) = fit.solve()?;
                Some((Self::Tilt(beta), fit.mean_square_residual()?))
            }
        }
    }

    /// Whether the fit reads the field in the body frame. The board logs
    /// the raw field in the body frame (`docs/INTERFACES.md`): each axis
    /// a positive gain of the body axis' field, give or take a little soft
    /// iron and misalignment; so the tilt model's matrix `M` (`h = M·y + c`
    /// scaled by `1/f_D`) has a diagonal of one sign (`f_D`'s). At a wrong
    /// lag a motion that repeats can be matched by a mirrored frame — the
    /// roll half a swing later is the roll with its sign flipped, and a row
    /// of `M` flipped fits it as well as the true lag — which no board
    /// reads: such a fit is not a match. Entries too poorly known
    /// ([`FRAME_SIGN_SHARE`]) are not counted. The attitude model needs no
    /// such test (its field is fitted against the whole rotation).
    pub(super) fn in_body_frame(&self) -> bool {
        match self {
            Self::Attitude(_) => true,
            Self::Tilt(beta) => {
                let diag = [beta[0], beta[4], beta[8]];
                let largest = diag.iter().map(|v| v.abs()).fold(0.0, f64::max);
                let counted = diag
                    .iter()
                    .filter(|v| v.abs() >= FRAME_SIGN_SHARE * largest);
                let (positive, negative) =
                    counted.fold(
                        (0, 0),
                        |(p, n), v| if *v > 0.0 { (p + 1, n) } else { (p, n + 1) },
                    );
                largest > 0.0 && (positive == 0 || negative == 0)
            }
        }
    }

    /// The residuals of board row `y` against the attitude regressors `x`
    /// (`dx` their rate), the rates of the prediction (per second of lag),
    /// and how many of the three entries are used.
    pub(super) fn residual(
        &self,
        x: &[f64; FEATURES],
        dx: &[f64; FEATURES],
        y: &[f64; 3],
    ) -> ([f64; 3], [f64; 3], usize) {
        match self {
            Self::Attitude(coef) => {
                // The constant's rate is 0, so `predict` of the rates is the field's rate.
                let (p, g) = (predict(coef, x), predict(coef, dx));
                ([0, 1, 2].map(|k| y[k] - p[k]), g, 3)
            }
            Self::Tilt(beta) => {
                let dot =
                    |z: [f64; TILT_FEATURES]| z.iter().zip(beta).map(|(a, b)| a * b).sum::<f64>();
                let (p, g) = (
                    dot(tilt_features(down(x), y)),
                    dot(tilt_features(down(dx), y)),
                );
                ([1.0 - p, 0.0, 0.0], [g, 0.0, 0.0], 1)
            }
        }
    }
}

/// A signal's scores over the lags (NaN where it cannot be scored).
pub(super) struct Curve {
    /// Which signal.
    pub(super) signal: SharedSignal,
    /// Its score at each lag of [`lags`]; higher is better.
    pub(super) score: Vec<f64>,
}

/// A model's curve: `−ln misfit` at every lag, on `rows` thinned to the
/// work budget (`share`: the part of the rows the series covers, so that
/// about as many are used whatever it covers).
pub(super) fn model_curve(
    signal: SharedSignal,
    model: Model,
    rows: &[(f64, [f64; 3])],
    series: &AttitudeSeries,
    lags: &[f64],
    share: f64,
) -> Curve {
    let keep = (COARSE_BUDGET / lags.len().max(1) as f64).clamp(300.0, 2000.0);
    let stride = ((rows.len() as f64 * share.clamp(1e-3, 1.0) / keep).ceil() as usize).max(1);
    let thin: Vec<(f64, [f64; 3])> = rows.iter().step_by(stride).copied().collect();
    let score: Vec<f64> = lags
        .iter()
        .map(|&lag| {
            misfit(model, &thin, series, &ClockMap::offset(lag))
                .filter(|m| *m > 0.0)
                .map_or(f64::NAN, |m| -m.ln())
        })
        .collect();
    Curve { signal, score }
}

/// A course's curve: at each lag, its best score over the lags up to
/// [`COURSE_DELAY_MAX_S`] later (the course is late by an unknown delay).
pub(super) fn course_curve(
    rows: &[(f64, [f64; 3])],
    series: &AttitudeSeries,
    lags: &[f64],
    share: f64,
) -> Curve {
    let raw = model_curve(
        SharedSignal::Course,
        Model::Attitude,
        rows,
        series,
        lags,
        share,
    )
    .score;
    let span = (COURSE_DELAY_MAX_S / COARSE_STEP_S).round() as usize;
    let score = (0..raw.len())
        .map(|k| {
            raw[k..(k + span + 1).min(raw.len())]
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(f64::NAN, f64::max)
        })
        .collect();
    Curve {
        signal: SharedSignal::Course,
        score,
    }
}

/// The rates' curve: the correlation of the two logs' rates of turn over
/// the whole overlap at every lag; `None` when either log turns too little.
pub(super) fn rate_curve(board: &BoardLog, nav: &NavLog, lags: &[f64]) -> Option<Curve> {
    let (b0, b1) = (board.t_s[0], *board.t_s.last().unwrap_or(&board.t_s[0]));
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let board_gap = (5.0 * median_interval(&board.t_s)).max(0.5);
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);
    let views = RateViews::new(board, nav, RATE_COARSE_DT_S, board_gap, nav_gap);
    if views.board.rms(b0, b1) < MIN_RATE_SPREAD_RAD_S
        || views.nav.rms(n0, n1) < MIN_RATE_SPREAD_RAD_S
    {
        return None;
    }
    // Thinned to the work budget (the grid is finer than the rates change).
    let stride = (views.board.points(b0, b1) as f64 * lags.len() as f64 / RATE_BUDGET)
        .ceil()
        .max(1.0) as usize;
    let min_pairs = (MIN_OVERLAP_S / RATE_COARSE_DT_S) as usize / stride;
    let score = lags
        .iter()
        .map(|&lag| {
            let (r, n) = views.correlation_thinned(lag, b0, b1, stride);
            if n >= min_pairs {
                r
            } else {
                f64::NAN
            }
        })
        .collect();
    Some(Curve {
        signal: SharedSignal::Rates,
        score,
    })
}
