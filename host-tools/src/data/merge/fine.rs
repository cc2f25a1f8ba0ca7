//! The fine stage: from the coarse lag, the model fitted, each window of
//! the overlap gets its own lag by Gauss–Newton (any fraction of a row)
//! and a σ from its residuals and how fast its prediction moves; a
//! weighted line through the windows gives offset and drift; model and
//! windows are iterated.
//!
//! Two ways of reading the logs against each other ([`Timed`]):
//!
//! * [`OnGrid`] (the attitude with the AHRS heading): both logs read
//!   between their samples by a cubic on a common grid of the board clock,
//!   several points per slower sample, so that the noise, which
//!   interpolation halves midway between samples, weighs alike at every
//!   lag;
//! * [`AtNavRows`] (the tilt): at the navigation's own rows, the board's
//!   field (whose noise is small) read between its samples, each row one
//!   independent sample for the σ. The tilt's timing rests on changes of
//!   roll and pitch that in a calm run are a few times the AHRS's noise, so
//!   the model is fitted with the neighbouring rows' tilt as instruments
//!   ([`InstrumentFit`]: least squares shrinks how the field answers a tilt
//!   — several-fold in the directions a calm run barely tilts — and that
//!   shifted the 1 Hz run of circles and dives by 60 ms on average, the
//!   same way on every seed); the prediction's rate is the tilt's slope at
//!   the row, whose noise (the neighbours' difference) is independent of
//!   the row's own.

use calib_core::lsq::lm::{self, Acceptance, LmOptions, LmProblem, LmStop, Linearisation};

use super::super::pairing::ClockMap;
use super::coarse::{Fitted, Model};
use super::fit::{line_fit, InstrumentFit, LineFit};
use super::signals::{down, tilt_features, AttitudeSeries, Cubic, FEATURES, TILT_FEATURES};
use super::{MergeError, NoRotation};

/// A window of the fine stage is about this long, s …
const WINDOW_S: f64 = 60.0;
/// … and there are this many windows at least and at most.
const WINDOWS: (usize, usize) = (4, 24);
/// The first pass searches each window's lag this far around the coarse
/// one (the coarse step, and 100 ppm over three hours), s …
const WINDOW_SEARCH_S: f64 = 1.5;
/// … in steps of, s.
const WINDOW_SEARCH_STEP_S: f64 = 0.05;
/// Gauss–Newton iterations of a window's lag, at most.
const GN_ITERATIONS: u32 = 20;
/// Fewest rows a window's lag is fitted from.
const MIN_WINDOW_ROWS: usize = 2 * FEATURES;

/// What the fine stage times: rows read against each other at any lag.
pub(super) trait Timed {
    /// Fits the model with the navigation `map`ped; its misfit
    /// ([`super::coarse::misfit`]'s), `None` when it cannot be solved.
    fn refit(&mut self, map: &ClockMap) -> Option<f64>;
    /// The rows' board times under `map` (non-decreasing).
    fn board_times(&self, map: &ClockMap) -> Vec<f64>;
    /// Row `i`'s residuals at `lag` relative to `map` (`t_nav =
    /// map.to_nav(t_board) + lag`), the prediction's rates per second of
    /// lag, and how many of the three entries are used; `None` when the
    /// row cannot be read there.
    fn residual(&self, i: usize, map: &ClockMap, lag: f64) -> Option<([f64; 3], [f64; 3], usize)>;
    /// Rows per independent sample (their noise is shared).
    fn rows_per_sample(&self) -> f64;
}

/// Both logs on a grid of the board clock ([`Fitted`] on the attitude).
pub(super) struct OnGrid<'a> {
    rows: &'a [(f64, [f64; 3])],
    series: &'a AttitudeSeries,
    model: Model,
    fitted: Option<Fitted>,
    rows_per_sample: f64,
}

impl<'a> OnGrid<'a> {
    /// `rows`: (board time, normalised raw field) on the grid; `series`:
    /// the attitude; `rows_per_sample`: grid points per slower sample.
    pub(super) fn new(
        model: Model,
        rows: &'a [(f64, [f64; 3])],
        series: &'a AttitudeSeries,
        rows_per_sample: f64,
    ) -> Self {
        Self {
            rows,
            series,
            model,
            fitted: None,
            rows_per_sample,
        }
    }
}

impl Timed for OnGrid<'_> {
    fn refit(&mut self, map: &ClockMap) -> Option<f64> {
        let (fitted, misfit) = Fitted::fit(self.model, self.rows, self.series, map)?;
        self.fitted = Some(fitted);
        Some(misfit)
    }

    fn board_times(&self, _: &ClockMap) -> Vec<f64> {
        self.rows.iter().map(|r| r.0).collect()
    }

    fn residual(&self, i: usize, map: &ClockMap, lag: f64) -> Option<([f64; 3], [f64; 3], usize)> {
        let (t, y) = self.rows.get(i)?;
        let (x, dx) = self.series.at(map.to_nav(*t) + lag)?;
        Some(self.fitted.as_ref()?.residual(&x, &dx, y))
    }

    fn rows_per_sample(&self) -> f64 {
        self.rows_per_sample
    }
}

/// The tilt at the navigation's rows, the board's field read between its
/// samples.
pub(super) struct AtNavRows<'a> {
    /// Navigation time, down direction and its rate (the cubic's slope at
    /// the row) of each row with an attitude.
    rows: Vec<(f64, [f64; 3], [f64; 3])>,
    /// The board's normalised raw field.
    field: &'a Cubic<3>,
    /// Rows further apart are not neighbours, s.
    max_gap_s: f64,
    beta: Option<[f64; TILT_FEATURES]>,
}

impl<'a> AtNavRows<'a> {
    /// The rows of `series` (the tilt series: one row per navigation row)
    /// at times `t_nav_s`, against the board's normalised field.
    pub(super) fn new(
        t_nav_s: &[f64],
        series: &AttitudeSeries,
        field: &'a Cubic<3>,
        max_gap_s: f64,
    ) -> Self {
        let rows = t_nav_s
            .iter()
            .filter_map(|&t| series.at(t).map(|(x, dx)| (t, down(&x), down(&dx))))
            .collect();
        Self {
            rows,
            field,
            max_gap_s,
            beta: None,
        }
    }

    /// Row `i`'s field and its rate at `lag` relative to `map`.
    fn field_at(&self, i: usize, map: &ClockMap, lag: f64) -> Option<([f64; 3], [f64; 3])> {
        let (t, _, _) = self.rows.get(i)?;
        self.field.at(map.to_board(*t - lag))
    }
}

impl Timed for AtNavRows<'_> {
    fn refit(&mut self, map: &ClockMap) -> Option<f64> {
        let mut fit = InstrumentFit::new();
        for i in 1..self.rows.len().saturating_sub(1) {
            let (prev, next) = (self.rows[i - 1].1, self.rows[i + 1].1);
            let near = self.rows[i + 1].0 - self.rows[i - 1].0 <= 2.0 * self.max_gap_s;
            if let (true, Some((y, _))) = (near, self.field_at(i, map, 0.0)) {
                let instrument = [0, 1, 2].map(|a| 0.5 * (prev[a] + next[a]));
                fit.add(
                    &tilt_features(instrument, &y),
                    &tilt_features(self.rows[i].1, &y),
                );
            }
        }
        let beta = fit.solve()?;
        self.beta = Some(beta);
        // The residuals' mean square.
        let (mut ssr, mut n) = (0.0, 0usize);
        for i in 0..self.rows.len() {
            if let Some((r, _, _)) = self.residual(i, map, 0.0) {
                ssr += r[0] * r[0];
                n += 1;
            }
        }
        (n > TILT_FEATURES).then(|| ssr / (n - TILT_FEATURES) as f64)
    }

    fn board_times(&self, map: &ClockMap) -> Vec<f64> {
        self.rows.iter().map(|r| map.to_board(r.0)).collect()
    }

    fn residual(&self, i: usize, map: &ClockMap, lag: f64) -> Option<([f64; 3], [f64; 3], usize)> {
        let beta = self.beta.as_ref()?;
        let (y, _) = self.field_at(i, map, lag)?;
        let (_, g, dg) = self.rows[i];
        let dot = |z: [f64; TILT_FEATURES]| z.iter().zip(beta).map(|(a, b)| a * b).sum::<f64>();
        // The prediction's rate from the navigation's side: `g·h` is
        // constant along the motion, so moving the navigation later by a
        // second changes the prediction by `β·z(ġ, y)` — the tilt's rate,
        // the cubic's slope at the row, whose noise is independent of the
        // row's own (the neighbours' difference).
        Some((
            [1.0 - dot(tilt_features(g, &y)), 0.0, 0.0],
            [dot(tilt_features(dg, &y)), 0.0, 0.0],
            1,
        ))
    }

    fn rows_per_sample(&self) -> f64 {
        1.0
    }
}

/// One window's residuals against its lag, for the crate's one solver
/// ([`calib_core::lsq::lm`]), run as Gauss–Newton: the rows' residuals and
/// the prediction's rates at a lag, with the sums the σ needs.
struct WindowLag<'a> {
    timed: &'a dyn Timed,
    rows: std::ops::Range<usize>,
    map: &'a ClockMap,
    /// Where the search started: a lag more than 1 s from it has run away.
    start: f64,
    /// At the last linearisation: Σr², entries used and rows read.
    last: (f64, usize, usize),
}

impl LmProblem<f64, 1> for WindowLag<'_> {
    fn linearise(&mut self, p: &[f64; 1]) -> Option<Linearisation<f64, 1>> {
        let lag = p[0];
        if !((lag - self.start).abs() <= 1.0) {
            return None;
        }
        let mut lin = Linearisation::zero();
        let (mut entries, mut n) = (0usize, 0usize);
        for i in self.rows.clone() {
            let Some((r, g, used)) = self.timed.residual(i, self.map, lag) else {
                continue;
            };
            // `g` is the prediction's rate: ∂r/∂lag = −g.
            for k in 0..used {
                lin.add_row(&[-g[k]], r[k]);
            }
            n += 1;
            entries += used;
        }
        if n < MIN_WINDOW_ROWS || !(lin.jtj[0][0] > 0.0) {
            return None;
        }
        self.last = (lin.cost, entries, n);
        Some(lin)
    }

    fn cost(&mut self, p: &[f64; 1]) -> Option<f64> {
        self.linearise(p).map(|l| l.cost)
    }
}

/// One window's lag relative to `map` (Gauss–Newton, the model held) and
/// its σ: the residual's variance over how fast the prediction moves, each
/// independent sample counted once. `None` when the window has too few
/// rows, no motion, or the lag runs away (more than 1 s from `start`).
fn window_lag(timed: &dyn Timed, rows: std::ops::Range<usize>, map: &ClockMap, start: f64) -> Option<(f64, f64)> {
    let mut problem = WindowLag { timed, rows, map, start, last: (0.0, 0, 0) };
    // Undamped Gauss–Newton: every step taken, converged when one is below
    // 20 µs.
    let mut opts = LmOptions::marquardt(0.0);
    opts.acceptance = Acceptance::Always;
    opts.min_damping = 0.0;
    opts.max_iterations = GN_ITERATIONS;
    opts.step_tolerance = 2e-5;
    let out = lm::solve(&mut problem, &[start], &opts);
    let lag = out.params[0];
    // At the solution: its sums, and (after the iterations ran out) the
    // step still to take, which must be small (the lag moves linearly
    // when the model was fitted at other lags; the outer iterations
    // finish it).
    let lin = problem.linearise(&[lag])?;
    let converged = match out.stop {
        LmStop::SmallStep => true,
        LmStop::MaxIterations => (lin.jtr[0] / lin.jtj[0][0]).abs() < 1e-3,
        _ => false,
    };
    let (srr, entries, _) = problem.last;
    (converged && entries > 1).then(|| (lag, (srr / (entries - 1) as f64 * timed.rows_per_sample().max(1.0) / lin.jtj[0][0]).sqrt()))
}

/// The window's misfit (the residuals' mean square) at the lags of
/// `±WINDOW_SEARCH_S` (rows thinned), the best one: where Gauss–Newton
/// starts. Sharp attitude changes sampled once a second leave a misfit with
/// a minimum every row, and Gauss–Newton alone finds the nearest.
fn window_start(timed: &dyn Timed, rows: std::ops::Range<usize>, map: &ClockMap) -> f64 {
    let stride = rows.len().div_ceil(600).max(1);
    let steps = (WINDOW_SEARCH_S / WINDOW_SEARCH_STEP_S).round() as i64;
    let misfit = |lag: f64| {
        let (mut s, mut n) = (0.0, 0usize);
        for i in rows.clone().step_by(stride) {
            if let Some((r, _, used)) = timed.residual(i, map, lag) {
                s += r[..used].iter().map(|v| v * v).sum::<f64>();
                n += 1;
            }
        }
        if n > FEATURES {
            s / n as f64
        } else {
            f64::NAN
        }
    };
    (-steps..=steps)
        .map(|k| k as f64 * WINDOW_SEARCH_STEP_S)
        .map(|l| (l, misfit(l)))
        .filter(|p| p.1.is_finite())
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map_or(0.0, |p| p.0)
}

/// The windows' lags relative to `map`: (board time of the window's
/// middle, lag, σ); each window's search starts at its best lag within
/// `±WINDOW_SEARCH_S` when `search`, at 0 otherwise.
fn window_lags(timed: &dyn Timed, map: &ClockMap, search: bool) -> Vec<(f64, f64, f64)> {
    let times = timed.board_times(map);
    let inside: Vec<usize> = (0..times.len())
        .filter(|&i| timed.residual(i, map, 0.0).is_some())
        .collect();
    let (Some(&first), Some(&last)) = (inside.first(), inside.last()) else {
        return vec![];
    };
    let (t0, t1) = (times[first], times[last]);
    let k = (((t1 - t0) / WINDOW_S).round() as usize).clamp(WINDOWS.0, WINDOWS.1);
    let width = (t1 - t0) / k as f64;
    (0..k)
        .filter_map(|w| {
            let (a, b) = (t0 + w as f64 * width, t0 + (w + 1) as f64 * width);
            let i0 = times.partition_point(|t| *t < a);
            let i1 = times.partition_point(|t| *t < b || (w + 1 == k && *t <= b));
            let start = if search {
                window_start(timed, i0..i1, map)
            } else {
                0.0
            };
            window_lag(timed, i0..i1, map, start).map(|(lag, s)| (0.5 * (a + b), lag, s))
        })
        .collect()
}

/// The line through the windows, again without the windows far off it
/// (a wrong minimum).
pub(super) fn robust_line(points: &[(f64, f64, f64)], t_ref: f64) -> (LineFit, usize) {
    let fit = line_fit(points, t_ref);
    if points.len() < 4 {
        return (fit, points.len());
    }
    let scale = fit.chi2_dof.max(1.0).sqrt();
    let kept: Vec<(f64, f64, f64)> = points
        .iter()
        .copied()
        .filter(|p| (p.1 - fit.at(p.0)).abs() <= 4.0 * p.2 * scale)
        .collect();
    if kept.len() < 3 || kept.len() == points.len() {
        return (fit, points.len());
    }
    (line_fit(&kept, t_ref), kept.len())
}

/// What the fine stage found: the line through the windows, the clocks,
/// the windows used and the model's last misfit.
pub(super) struct Fine {
    pub(super) line: LineFit,
    pub(super) clock: ClockMap,
    pub(super) windows: usize,
    pub(super) misfit: f64,
}

/// The fine stage (see the module's text) from the coarse lag `lag0`,
/// the offset referred to the board time `b0`.
pub(super) fn fine(timed: &mut dyn Timed, lag0: f64, b0: f64) -> Result<Fine, MergeError> {
    let mut map = ClockMap {
        offset_s: lag0,
        drift_ppm: 0.0,
        board_ref_s: b0,
    };
    let mut last = None;
    for iteration in 0..5 {
        let misfit = timed.refit(&map).ok_or(MergeError::NoRotation(NoRotation::AttitudeTooSmallToFit))?;
        let points = window_lags(timed, &map, iteration == 0);
        if points.len() < 2 {
            return Err(MergeError::NoRotation(NoRotation::TooFewWindows(points.len())));
        }
        let (line, used) = robust_line(&points, b0);
        map.offset_s += line.offset_s;
        map.drift_ppm += line.slope * 1e6;
        last = Some(Fine {
            line,
            clock: map,
            windows: used,
            misfit,
        });
        if line.offset_s.abs() < 1e-5 && line.slope.abs() < 1e-8 {
            break;
        }
    }
    last.ok_or(MergeError::NoRotation(NoRotation::NoWindowConverged))
}
