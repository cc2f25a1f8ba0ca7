//! `magcal merge`: one recording from the board's field log and the
//! vehicle's navigation log, kept on two different clocks.
//!
//! The clock offset and drift are found from the data: the magnetometer sees
//! the vehicle turn (the angular rate of the raw field's direction) at the
//! same moments as the AHRS (the body rate from its gyro, or from the rates
//! of its roll, pitch and heading). The two rate signals are
//! cross-correlated, first over the whole logs on a coarse grid within the
//! search range, then window by window on a fine grid around that; a
//! straight line through the windows' offsets gives the offset and the drift,
//! and its residuals their uncertainty. The navigation columns are then
//! interpolated to the board's sample times ([`super::pairing`]: angles the
//! short way round, GPS only where both neighbours have it, nothing beyond
//! the navigation log or across its long gaps).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::pairing::{bracket, wrap180, Bracket, ClockMap};
use super::recording::{read_table, RecordingError};
use super::Recording;

/// Why two logs could not be merged.
#[derive(Debug, thiserror::Error)]
pub enum MergeError {
    /// A log could not be read (missing column, time running backwards, a
    /// cell that is not a number, …).
    #[error(transparent)]
    Log(#[from] RecordingError),
    /// The logs share no time.
    #[error("the logs do not overlap: board {board_start_s:.3}…{board_end_s:.3} s, navigation {nav_start_s:.3}…{nav_end_s:.3} s; {detail}")]
    NoOverlap {
        /// First board time, s (board clock).
        board_start_s: f64,
        /// Last board time, s.
        board_end_s: f64,
        /// First navigation time, s (navigation clock).
        nav_start_s: f64,
        /// Last navigation time, s.
        nav_end_s: f64,
        /// With which offsets.
        detail: String,
    },
    /// Nothing turned, or the two logs do not see the same turns.
    #[error("no rotation to align the clocks on: {0} (turn the vehicle while both log, or give --offset-s)")]
    NoRotation(String),
    /// An option is out of range.
    #[error("{0}")]
    Option(String),
}

/// The board's log: raw field samples on the board's clock.
#[derive(Debug, Clone, Default)]
pub struct BoardLog {
    /// `t`, seconds on the board's clock.
    pub t_s: Vec<f64>,
    /// `mx, my, mz`, raw sensor units.
    pub mag: Vec<[f64; 3]>,
    /// `temp_c`, °C, when logged.
    pub temp_c: Option<Vec<f64>>,
    /// `health`: 0 good, bit 0 a channel saturated, bit 1 the first sample
    /// after a link drop (when logged).
    pub health: Option<Vec<f64>>,
}

/// `health` bit: a channel was saturated (the raw field is not usable).
pub const HEALTH_SATURATED: u32 = 1;
/// `health` bit: the first sample after a gap (a link drop) in the log.
pub const HEALTH_AFTER_GAP: u32 = 2;

/// The navigation computer's log on its own clock.
#[derive(Debug, Clone, Default)]
pub struct NavLog {
    /// `t`, seconds on the navigation clock.
    pub t_s: Vec<f64>,
    /// `roll_deg`.
    pub roll_deg: Vec<f64>,
    /// `pitch_deg`.
    pub pitch_deg: Vec<f64>,
    /// `heading_deg`: the AHRS's heading, when logged.
    pub heading_deg: Option<Vec<f64>>,
    /// `ref_heading_deg`: GPS course (at the surface) or a reference heading.
    pub ref_heading_deg: Option<Vec<f64>>,
    /// `lat_deg`.
    pub lat_deg: Option<Vec<f64>>,
    /// `lon_deg`.
    pub lon_deg: Option<Vec<f64>>,
    /// `gx, gy, gz`, rad/s.
    pub gyro_rad_s: Option<[Vec<f64>; 3]>,
    /// `speed_mps`.
    pub speed_mps: Option<Vec<f64>>,
    /// `motor_current_a`.
    pub motor_current_a: Option<Vec<f64>>,
}


impl BoardLog {
    /// Reads a board log: `t, mx, my, mz` required, `temp_c`, `health` optional.
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        let mut t = read_table(path, &["t", "mx", "my", "mz"], &["temp_c", "health"])?;
        let (mx, my, mz) = (t.take("mx").unwrap_or_default(), t.take("my").unwrap_or_default(), t.take("mz").unwrap_or_default());
        Ok(Self {
            t_s: t.take("t").unwrap_or_default(),
            mag: mx.into_iter().zip(my).zip(mz).map(|((x, y), z)| [x, y, z]).collect(),
            temp_c: t.take("temp_c"),
            health: t.take("health"),
        })
    }

    /// Writes the log in the columns [`BoardLog::read`] reads.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let csv_err = |source| RecordingError::Csv { path: path.into(), source };
        let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
        let mut header = vec!["t", "mx", "my", "mz"];
        if self.temp_c.is_some() {
            header.push("temp_c");
        }
        if self.health.is_some() {
            header.push("health");
        }
        w.write_record(&header).map_err(csv_err)?;
        let cell = |v: f64| if v.is_finite() { format!("{v}") } else { String::new() };
        for (i, (t, m)) in self.t_s.iter().zip(&self.mag).enumerate() {
            let mut row = vec![format!("{t}"), cell(m[0]), cell(m[1]), cell(m[2])];
            for c in [&self.temp_c, &self.health].into_iter().flatten() {
                row.push(cell(c.get(i).copied().unwrap_or(f64::NAN)));
            }
            w.write_record(&row).map_err(csv_err)?;
        }
        w.flush().map_err(|source| RecordingError::Io { path: path.into(), source })
    }
}

impl NavLog {
    /// Reads a navigation log: `t, roll_deg, pitch_deg` required; the rest
    /// optional (see `docs/INTERFACES.md`).
    pub fn read(path: &Path) -> Result<Self, RecordingError> {
        let optional = ["heading_deg", "ref_heading_deg", "lat_deg", "lon_deg", "gx", "gy", "gz", "speed_mps", "motor_current_a"];
        let mut t = read_table(path, &["t", "roll_deg", "pitch_deg"], &optional)?;
        let gyro = match (t.take("gx"), t.take("gy"), t.take("gz")) {
            (Some(x), Some(y), Some(z)) => Some([x, y, z]),
            _ => None,
        };
        Ok(Self {
            t_s: t.take("t").unwrap_or_default(),
            roll_deg: t.take("roll_deg").unwrap_or_default(),
            pitch_deg: t.take("pitch_deg").unwrap_or_default(),
            heading_deg: t.take("heading_deg"),
            ref_heading_deg: t.take("ref_heading_deg"),
            lat_deg: t.take("lat_deg"),
            lon_deg: t.take("lon_deg"),
            gyro_rad_s: gyro,
            speed_mps: t.take("speed_mps"),
            motor_current_a: t.take("motor_current_a"),
        })
    }

    /// Writes the log in the columns [`NavLog::read`] reads.
    pub fn write(&self, path: &Path) -> Result<(), RecordingError> {
        let mut cols: Vec<(&str, &Vec<f64>)> = vec![("t", &self.t_s), ("roll_deg", &self.roll_deg), ("pitch_deg", &self.pitch_deg)];
        for (name, c) in [
            ("heading_deg", &self.heading_deg),
            ("ref_heading_deg", &self.ref_heading_deg),
            ("lat_deg", &self.lat_deg),
            ("lon_deg", &self.lon_deg),
            ("speed_mps", &self.speed_mps),
            ("motor_current_a", &self.motor_current_a),
        ] {
            if let Some(c) = c {
                cols.push((name, c));
            }
        }
        if let Some([x, y, z]) = &self.gyro_rad_s {
            cols.extend([("gx", x), ("gy", y), ("gz", z)]);
        }
        let csv_err = |source| RecordingError::Csv { path: path.into(), source };
        let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
        w.write_record(cols.iter().map(|(n, _)| *n)).map_err(csv_err)?;
        for i in 0..self.t_s.len() {
            let row = cols.iter().map(|(_, c)| c.get(i).copied().filter(|v| v.is_finite()).map_or(String::new(), |v| format!("{v}")));
            w.write_record(row).map_err(csv_err)?;
        }
        w.flush().map_err(|source| RecordingError::Io { path: path.into(), source })
    }
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
    /// Correlation of the two rate signals at the coarse offset (1 = identical).
    pub peak_correlation: f64,
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
}

/// A vector signal on a uniform grid (NaN where not available).
struct Signal {
    t0_s: f64,
    dt_s: f64,
    v: Vec<[f64; 3]>,
}

impl Signal {
    fn value_at(&self, t: f64) -> [f64; 3] {
        let x = (t - self.t0_s) / self.dt_s;
        if x.is_nan() || x < 0.0 {
            return [f64::NAN; 3];
        }
        let i = x.floor() as usize;
        if i + 1 >= self.v.len() {
            return if i + 1 == self.v.len() && x == i as f64 { self.v[i] } else { [f64::NAN; 3] };
        }
        let w = x - i as f64;
        let (a, b) = (self.v[i], self.v[i + 1]);
        [0, 1, 2].map(|k| a[k] * (1.0 - w) + b[k] * w)
    }

    fn index_range(&self, from: f64, to: f64) -> std::ops::Range<usize> {
        let i0 = ((from - self.t0_s) / self.dt_s).ceil().max(0.0) as usize;
        let i1 = (((to - self.t0_s) / self.dt_s).floor() + 1.0).max(0.0) as usize;
        i0.min(self.v.len())..i1.min(self.v.len())
    }

    /// RMS of the vectors' length over `[from, to]`.
    fn rms(&self, from: f64, to: f64) -> f64 {
        let (mut s, mut n) = (0.0, 0usize);
        for v in &self.v[self.index_range(from, to)] {
            let q = dot(*v, *v);
            if q.is_finite() {
                s += q;
                n += 1;
            }
        }
        if n == 0 {
            0.0
        } else {
            (s / n as f64).sqrt()
        }
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn median_interval(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// Half the baseline of the rate differences, s (both signals alike).
const RATE_HALF_BASE_S: f64 = 0.25;

/// Per axis, the centre and half-range of the raw field between its 1 % and
/// 99 % quantiles: a rough hard- and soft-iron correction so that the raw
/// field's direction turns nearly as the body does. An axis whose range is
/// under a third of the widest one (too few attitudes to tell its bias) is
/// left as it is, scaled like the widest.
fn rough_normalisation(mag: &[[f64; 3]]) -> [(f64, f64); 3] {
    let ranges = [0, 1, 2].map(|k| {
        let mut v: Vec<f64> = mag.iter().map(|m| m[k]).filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return (0.0, 1.0);
        }
        v.sort_by(f64::total_cmp);
        let (lo, hi) = (v[v.len() / 100], v[v.len() - 1 - v.len() / 100]);
        (0.5 * (lo + hi), 0.5 * (hi - lo))
    });
    let widest = ranges.iter().map(|r| r.1).fold(0.0, f64::max);
    if widest.is_nan() || widest <= 0.0 {
        return [(0.0, 1.0); 3];
    }
    ranges.map(|(c, h)| if h >= widest / 3.0 { (c, h) } else { (0.0, widest) })
}

/// The board's view of the turns: the field's direction `u` and the part of
/// the body rate across it, `−u × du/dt` (rad/s), on a grid of `dt`.
fn board_signals(log: &BoardLog, dt: f64, max_gap_s: f64) -> (Signal, Signal) {
    let (t0, t1) = (log.t_s[0], *log.t_s.last().unwrap_or(&log.t_s[0]));
    let n = ((t1 - t0) / dt).floor() as usize + 1;
    let norm = rough_normalisation(&log.mag);
    let cols: [Vec<f64>; 3] = [0, 1, 2].map(|k| log.mag.iter().map(|m| (m[k] - norm[k].0) / norm[k].1).collect());
    let dirs: Vec<[f64; 3]> = (0..n)
        .map(|i| match bracket(&log.t_s, t0 + i as f64 * dt, max_gap_s) {
            Some(b) => unit([b.lerp(&cols[0]), b.lerp(&cols[1]), b.lerp(&cols[2])]),
            None => [f64::NAN; 3],
        })
        .collect();
    let k = ((RATE_HALF_BASE_S / dt).round() as usize).max(1);
    let rate = (0..n)
        .map(|i| {
            if i < k || i + k >= n {
                return [f64::NAN; 3];
            }
            let du = [0, 1, 2].map(|a| (dirs[i + k][a] - dirs[i - k][a]) / (2.0 * k as f64 * dt));
            cross(dirs[i], du).map(|x| -x)
        })
        .collect();
    (Signal { t0_s: t0, dt_s: dt, v: dirs }, Signal { t0_s: t0, dt_s: dt, v: rate })
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = dot(v, v).sqrt();
    if n > 0.0 && n.is_finite() {
        v.map(|x| x / n)
    } else {
        [f64::NAN; 3]
    }
}

/// The body rate, rad/s, on a grid of `dt`: from the gyro when logged
/// (averaged over the board's difference baseline), otherwise from the
/// rates of roll, pitch and (when logged) heading (Z-Y-X kinematics).
fn nav_signal(log: &NavLog, dt: f64, max_gap_s: f64) -> Signal {
    let (t0, t1) = (log.t_s[0], *log.t_s.last().unwrap_or(&log.t_s[0]));
    let n = ((t1 - t0) / dt).floor() as usize + 1;
    let k = ((RATE_HALF_BASE_S / dt).round() as usize).max(1);
    let at = |i: usize| bracket(&log.t_s, t0 + i as f64 * dt, max_gap_s);
    let gyro_usable = log.gyro_rad_s.as_ref().is_some_and(|g| g[0].iter().filter(|v| v.is_finite()).count() * 2 > g[0].len());
    let v = if let (true, Some(g)) = (gyro_usable, &log.gyro_rad_s) {
        let w: Vec<[f64; 3]> = (0..n).map(|i| at(i).map_or([f64::NAN; 3], |b| [b.lerp(&g[0]), b.lerp(&g[1]), b.lerp(&g[2])])).collect();
        (0..n)
            .map(|i| {
                if i < k || i + k >= n {
                    return [f64::NAN; 3];
                }
                let mut s = [0.0; 3];
                for v in &w[i - k..=i + k] {
                    for a in 0..3 {
                        s[a] += v[a];
                    }
                }
                s.map(|x| x / (2 * k + 1) as f64)
            })
            .collect()
    } else {
        // Angles on the grid, unwrapped so that differences are rates.
        let series = |values: &[f64], angle: bool| -> Vec<f64> {
            let mut out: Vec<f64> = (0..n).map(|i| at(i).map_or(f64::NAN, |b| if angle { b.lerp_angle_deg(values, false) } else { b.lerp(values) })).collect();
            if angle {
                let (mut last, mut turns) = (f64::NAN, 0.0);
                for v in out.iter_mut().filter(|v| v.is_finite()) {
                    if last.is_finite() {
                        turns += wrap180(*v - last) - (*v - last);
                    }
                    last = *v;
                    *v += turns;
                }
            }
            out
        };
        let roll = series(&log.roll_deg, true);
        let pitch = series(&log.pitch_deg, false);
        let heading = log.heading_deg.as_deref().map(|h| series(h, true));
        (0..n)
            .map(|i| {
                if i < k || i + k >= n {
                    return [f64::NAN; 3];
                }
                let d = |v: &[f64]| (v[i + k] - v[i - k]).to_radians() / (2.0 * k as f64 * dt);
                let (rd, pd) = (d(&roll), d(&pitch));
                let yd = heading.as_deref().map_or(0.0, d);
                let yd = if yd.is_finite() { yd } else { 0.0 };
                let (r, p) = (roll[i].to_radians(), pitch[i].to_radians());
                [rd - yd * p.sin(), pd * r.cos() + yd * r.sin() * p.cos(), -pd * r.sin() + yd * r.cos() * p.cos()]
            })
            .collect()
    };
    Signal { t0_s: t0, dt_s: dt, v }
}

/// The board's and the navigation's views of the turns, on one grid.
struct Views {
    dirs: Signal,
    board: Signal,
    nav: Signal,
}

impl Views {
    fn new(board: &BoardLog, nav: &NavLog, dt: f64, board_gap_s: f64, nav_gap_s: f64) -> Self {
        let (dirs, b) = board_signals(board, dt, board_gap_s);
        Self { dirs, board: b, nav: nav_signal(nav, dt, nav_gap_s) }
    }

    /// How well the board's rate across the field over `[from, to]` (board
    /// clock) matches the navigation's body rate across the same field,
    /// `lag` later (`t_nav = t_board + lag`): Σ a·b / √(Σ|a|² Σ|b|²), 1 when
    /// identical; and the number of pairs.
    fn correlation(&self, lag: f64, from: f64, to: f64) -> (f64, usize) {
        let (mut n, mut sab, mut saa, mut sbb) = (0usize, 0.0, 0.0, 0.0);
        for i in self.board.index_range(from, to) {
            let (a, u) = (self.board.v[i], self.dirs.v[i]);
            if !a[0].is_finite() {
                continue;
            }
            let w = self.nav.value_at(self.board.t0_s + i as f64 * self.board.dt_s + lag);
            if !w[0].is_finite() {
                continue;
            }
            let along = dot(w, u);
            let b = [0, 1, 2].map(|k| w[k] - along * u[k]);
            n += 1;
            sab += dot(a, b);
            saa += dot(a, a);
            sbb += dot(b, b);
        }
        if n < 3 || !(saa > 0.0 && sbb > 0.0) {
            return (f64::NAN, n);
        }
        (sab / (saa * sbb).sqrt(), n)
    }
}

/// The rotation body → NED of roll, pitch, heading in degrees (Z-Y-X), row-major.
fn rotation(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> [f64; 9] {
    let (sr, cr) = roll_deg.to_radians().sin_cos();
    let (sp, cp) = pitch_deg.to_radians().sin_cos();
    let (sy, cy) = heading_deg.to_radians().sin_cos();
    [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr]
}

/// How badly the navigation's attitude `lag` later explains the board's raw
/// field over `[from, to]` (board clock): the residual sum of squares of
/// the least-squares fit `raw = C·vec(R) + b`. Any linear sensor in a
/// constant field is of that form (`raw = A·Rᵀ·f + b` is linear in the
/// entries of R), so no calibration, inclination or declination need be
/// known; the fit is exact only when the clocks are aligned. `None` when the
/// window has too few rows.
fn direction_misfit(board: &BoardLog, nav: &NavLog, heading: &[f64], lag: f64, from: f64, to: f64, nav_gap_s: f64) -> Option<(f64, usize)> {
    let mut xtx = [[0.0f64; 10]; 10];
    let mut xty = [[0.0f64; 10]; 3];
    let mut yy = 0.0;
    let mut n = 0usize;
    let i0 = board.t_s.partition_point(|&t| t < from);
    let i1 = board.t_s.partition_point(|&t| t <= to);
    for i in i0..i1 {
        let y = board.mag[i];
        if !y.iter().all(|v| v.is_finite()) {
            continue;
        }
        let Some(b) = bracket(&nav.t_s, board.t_s[i] + lag, nav_gap_s) else { continue };
        let (r, p, h) = (b.lerp_angle_deg(&nav.roll_deg, false), b.lerp(&nav.pitch_deg), b.lerp_angle_deg(heading, true));
        if !(r.is_finite() && p.is_finite() && h.is_finite()) {
            continue;
        }
        let rot = rotation(r, p, h);
        let mut x = [1.0; 10];
        x[..9].copy_from_slice(&rot);
        for a in 0..10 {
            for (c, xc) in x.iter().enumerate() {
                xtx[a][c] += x[a] * xc;
            }
            for k in 0..3 {
                xty[k][a] += x[a] * y[k];
            }
        }
        yy += dot(y, y);
        n += 1;
    }
    if n < 50 {
        return None;
    }
    // A little ridge: vec(R) has only three degrees of freedom.
    let trace: f64 = (0..10).map(|a| xtx[a][a]).sum();
    for (a, row) in xtx.iter_mut().enumerate() {
        row[a] += 1e-9 * trace;
    }
    let mut ssr = yy;
    for rhs in &xty {
        let beta = calib_core::linalg::cholesky_solve(&xtx, rhs).ok()?;
        ssr -= beta.iter().zip(rhs).map(|(b, r)| b * r).sum::<f64>();
    }
    Some((ssr.max(0.0), n))
}

/// The lag in `lag0 ± half_s` (step `step_s`) whose attitude explains the
/// board's field best over `[from, to]`, refined by a parabola; `None` when
/// the best is at the edge or the window cannot tell.
#[allow(clippy::too_many_arguments)]
fn best_direction_lag(board: &BoardLog, nav: &NavLog, heading: &[f64], lag0: f64, half_s: f64, step_s: f64, from: f64, to: f64, nav_gap_s: f64) -> Option<f64> {
    let steps = (half_s / step_s).ceil() as i64;
    let misfit: Vec<(f64, f64)> = (-steps..=steps)
        .map(|s| {
            let lag = lag0 + s as f64 * step_s;
            (lag, direction_misfit(board, nav, heading, lag, from, to, nav_gap_s).map_or(f64::NAN, |m| m.0))
        })
        .collect();
    let (k, &(lag, m)) = misfit.iter().enumerate().filter(|(_, (_, m))| m.is_finite()).min_by(|a, b| a.1 .1.total_cmp(&b.1 .1))?;
    if k == 0 || k + 1 == misfit.len() {
        return None;
    }
    let (a, c) = (misfit[k - 1].1, misfit[k + 1].1);
    if !(a.is_finite() && c.is_finite()) || a - m < 1e-3 * m.max(1e-300) || c - m < 1e-3 * m.max(1e-300) {
        return None;
    }
    Some(lag + parabolic_vertex(-a, -m, -c) * step_s)
}

/// Below this RMS rate of turn, nothing turned (about 0.3°/s).
const MIN_RATE_SPREAD_RAD_S: f64 = 0.005;
/// Below this correlation at the best offset, the logs do not see the same turns.
const MIN_CORRELATION: f64 = 0.3;
/// The least overlap to align on, s.
const MIN_OVERLAP_S: f64 = 20.0;
/// Coarse and fine grids, s.
const COARSE_DT_S: f64 = 0.1;
const FINE_DT_S: f64 = 0.02;
/// Lag step of the fine search, s (refined by a parabola).
const FINE_LAG_STEP_S: f64 = 0.01;

/// What the alignment found.
#[derive(Debug, Clone, Copy)]
struct Alignment {
    clock: ClockMap,
    offset_sigma_s: f64,
    drift_sigma_ppm: f64,
    drift_fitted: bool,
    windows: usize,
    peak_correlation: f64,
}

fn no_overlap(board: &BoardLog, nav: &NavLog, detail: String) -> MergeError {
    MergeError::NoOverlap {
        board_start_s: board.t_s[0],
        board_end_s: *board.t_s.last().unwrap_or(&board.t_s[0]),
        nav_start_s: nav.t_s[0],
        nav_end_s: *nav.t_s.last().unwrap_or(&nav.t_s[0]),
        detail,
    }
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

fn estimate_clock(board: &BoardLog, nav: &NavLog, center_s: f64, max_offset_s: f64) -> Result<Alignment, MergeError> {
    if !(max_offset_s.is_finite() && max_offset_s >= 0.0 && center_s.is_finite()) {
        return Err(MergeError::Option(format!("the offset search {center_s} ± {max_offset_s} s is not a range")));
    }
    let (b0, b1) = (board.t_s[0], *board.t_s.last().unwrap_or(&board.t_s[0]));
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
    let overlap_at = |lag: f64| (b1.min(n1 - lag) - b0.max(n0 - lag)).max(0.0);
    let best_overlap = [center_s - max_offset_s, center_s + max_offset_s, n0 - b0, n1 - b1]
        .into_iter()
        .filter(|l| (l - center_s).abs() <= max_offset_s + 1e-9)
        .map(overlap_at)
        .fold(0.0, f64::max);
    if best_overlap < MIN_OVERLAP_S {
        return Err(no_overlap(
            board,
            nav,
            format!("with clock offsets (navigation − board) within {center_s} ± {max_offset_s} s they share less than {MIN_OVERLAP_S} s (give --offset-s, or --approx-offset-s / --max-offset-s)"),
        ));
    }
    let board_gap = (5.0 * median_interval(&board.t_s)).max(0.5);
    let nav_gap = (5.0 * median_interval(&nav.t_s)).max(1.0);

    // Coarse: the whole logs on a 0.1 s grid, every lag of the search range.
    let coarse_views = Views::new(board, nav, COARSE_DT_S, board_gap, nav_gap);
    let (sb, sn) = (coarse_views.board.rms(b0, b1), coarse_views.nav.rms(n0, n1));
    if sb < MIN_RATE_SPREAD_RAD_S || sn < MIN_RATE_SPREAD_RAD_S {
        return Err(MergeError::NoRotation(format!(
            "the RMS rate of turn is {:.2}°/s (board, across the field) and {:.2}°/s (navigation); at least {:.2}°/s is needed in both",
            sb.to_degrees(),
            sn.to_degrees(),
            MIN_RATE_SPREAD_RAD_S.to_degrees()
        )));
    }
    let steps = (max_offset_s / COARSE_DT_S).round() as i64;
    let min_pairs = (MIN_OVERLAP_S / COARSE_DT_S) as usize;
    let mut coarse: Vec<(f64, f64)> = Vec::with_capacity(2 * steps as usize + 1);
    for s in -steps..=steps {
        let lag = center_s + s as f64 * COARSE_DT_S;
        let (r, n) = coarse_views.correlation(lag, b0, b1);
        coarse.push((lag, if n >= min_pairs { r } else { f64::NAN }));
    }
    let (k_best, &(lag0, r0)) = coarse
        .iter()
        .enumerate()
        .filter(|(_, (_, r))| r.is_finite())
        .max_by(|a, b| a.1 .1.total_cmp(&b.1 .1))
        .ok_or_else(|| MergeError::NoRotation("no offset in the search range leaves rotation in both logs".into()))?;
    if r0 < MIN_CORRELATION {
        return Err(MergeError::NoRotation(format!(
            "the best correlation of the two logs' rates of turn is {r0:.2} (at {lag0:.1} s), below {MIN_CORRELATION}: they do not see the same turns"
        )));
    }
    let lag0 = if k_best > 0 && k_best + 1 < coarse.len() {
        let (a, c) = (coarse[k_best - 1].1, coarse[k_best + 1].1);
        if a.is_finite() && c.is_finite() {
            lag0 + parabolic_vertex(a, r0, c) * COARSE_DT_S
        } else {
            lag0
        }
    } else {
        lag0
    };

    // Fine: windows of the overlap on a 20 ms grid, lags around the coarse one.
    let (from, to) = (b0.max(n0 - lag0), b1.min(n1 - lag0));
    let span = to - from;
    let fine = Views::new(board, nav, FINE_DT_S, board_gap, nav_gap);
    let windows = ((span / 120.0).floor() as usize).clamp(1, 16);
    let width = span / windows as f64;
    let half_search = 0.3 + 2e-4 * span;
    let lag_steps = (half_search / FINE_LAG_STEP_S).ceil() as i64;
    let mut local: Vec<(f64, f64)> = Vec::new();
    for w in 0..windows {
        let (a, b) = (from + w as f64 * width, from + (w + 1) as f64 * width);
        if fine.board.rms(a, b) < MIN_RATE_SPREAD_RAD_S {
            continue;
        }
        let refined = match nav.heading_deg.as_deref() {
            // With a heading: the lag whose attitude explains the raw field
            // best, searched coarsely then finely.
            Some(heading) => best_direction_lag(board, nav, heading, lag0, half_search, 0.04, a, b, nav_gap)
                .and_then(|l| best_direction_lag(board, nav, heading, l, 0.05, 0.005, a, b, nav_gap)),
            // Without: the peak of the rates' correlation.
            None => {
                let rs: Vec<(f64, f64)> = (-lag_steps..=lag_steps)
                    .map(|s| {
                        let lag = lag0 + s as f64 * FINE_LAG_STEP_S;
                        (lag, fine.correlation(lag, a, b).0)
                    })
                    .collect();
                let Some((k, &(lag, r))) = rs.iter().enumerate().filter(|(_, (_, r))| r.is_finite()).max_by(|x, y| x.1 .1.total_cmp(&y.1 .1)) else { continue };
                if r < 0.5 || k == 0 || k + 1 == rs.len() || !rs[k - 1].1.is_finite() || !rs[k + 1].1.is_finite() {
                    continue;
                }
                Some(lag + parabolic_vertex(rs[k - 1].1, r, rs[k + 1].1) * FINE_LAG_STEP_S)
            }
        };
        if let Some(l) = refined {
            local.push((0.5 * (a + b), l));
        }
    }
    if local.is_empty() {
        return Err(MergeError::NoRotation("no window of the overlap has rotation that both logs see alike".into()));
    }
    let fit = line_fit(&local, b0);
    // Drop windows far off the line (a wrong peak) and fit again.
    let local: Vec<(f64, f64)> = if local.len() >= 4 {
        let tol = (5.0 * fit.residual_mad_s * 1.4826).max(0.02);
        local.iter().copied().filter(|(t, l)| (l - fit.at(*t)).abs() <= tol).collect()
    } else {
        local
    };
    let fit = line_fit(&local, b0);
    Ok(Alignment {
        clock: ClockMap { offset_s: fit.offset_s, drift_ppm: fit.slope * 1e6, board_ref_s: b0 },
        offset_sigma_s: fit.offset_sigma_s,
        drift_sigma_ppm: fit.slope_sigma * 1e6,
        drift_fitted: fit.slope_fitted,
        windows: local.len(),
        peak_correlation: r0,
    })
}

/// A straight line through the windows' offsets.
struct LineFit {
    offset_s: f64,
    slope: f64,
    offset_sigma_s: f64,
    slope_sigma: f64,
    slope_fitted: bool,
    residual_mad_s: f64,
    t_ref: f64,
}

impl LineFit {
    fn at(&self, t: f64) -> f64 {
        self.offset_s + self.slope * (t - self.t_ref)
    }
}

/// Least squares `lag = offset + slope·(t − t_ref)`; with fewer than three
/// points the slope is 0 and the offset the mean, its σ the points' spread
/// (or one fine lag step for a single window).
fn line_fit(points: &[(f64, f64)], t_ref: f64) -> LineFit {
    let n = points.len() as f64;
    let tm = points.iter().map(|p| p.0).sum::<f64>() / n;
    let lm = points.iter().map(|p| p.1).sum::<f64>() / n;
    let mad = |resid: Vec<f64>| {
        let mut r: Vec<f64> = resid.into_iter().map(f64::abs).collect();
        r.sort_by(f64::total_cmp);
        r.get(r.len() / 2).copied().unwrap_or(0.0)
    };
    if points.len() < 3 {
        let sigma = if points.len() == 2 { (points[0].1 - points[1].1).abs() / 2.0 } else { FINE_LAG_STEP_S };
        return LineFit { offset_s: lm, slope: 0.0, offset_sigma_s: sigma.max(FINE_LAG_STEP_S / 12f64.sqrt()), slope_sigma: 0.0, slope_fitted: false, residual_mad_s: mad(points.iter().map(|p| p.1 - lm).collect()), t_ref };
    }
    let sxx: f64 = points.iter().map(|p| (p.0 - tm).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - tm) * (p.1 - lm)).sum();
    let slope = sxy / sxx;
    let offset = lm + slope * (t_ref - tm);
    let resid: Vec<f64> = points.iter().map(|p| p.1 - (lm + slope * (p.0 - tm))).collect();
    let s2 = resid.iter().map(|r| r * r).sum::<f64>() / (n - 2.0);
    // Never claim better than the fine grid's own resolution.
    let s = s2.sqrt().max(FINE_LAG_STEP_S / 12f64.sqrt() / n.sqrt());
    LineFit {
        offset_s: offset,
        slope,
        offset_sigma_s: s * (1.0 / n + (t_ref - tm).powi(2) / sxx).sqrt(),
        slope_sigma: s / sxx.sqrt(),
        slope_fitted: true,
        residual_mad_s: mad(resid),
        t_ref,
    }
}

/// Merges a board log and a navigation log into one recording on the
/// navigation clock (`t` = the board sample's time mapped to the navigation
/// clock), with `speed_mps`, `motor_current_a` and `temp_c` when the logs
/// have them. Extra columns (ignored by the recording reader but kept for
/// users): `t_board`, `heading_deg` — see [`Merged::extra_columns`].
pub fn merge(board: &BoardLog, nav: &NavLog, clock: Clock) -> Result<Merged, MergeError> {
    let b0 = board.t_s[0];
    let alignment = match clock {
        Clock::Estimate { center_s, max_offset_s } => estimate_clock(board, nav, center_s, max_offset_s)?,
        Clock::Given { offset_s, drift_ppm } => {
            if !(offset_s.is_finite() && drift_ppm.is_finite() && drift_ppm.abs() < 1e5) {
                return Err(MergeError::Option(format!("offset {offset_s} s / drift {drift_ppm} ppm: not usable numbers")));
            }
            Alignment { clock: ClockMap { offset_s, drift_ppm, board_ref_s: b0 }, offset_sigma_s: 0.0, drift_sigma_ppm: 0.0, drift_fitted: false, windows: 0, peak_correlation: f64::NAN }
        }
    };
    let map = alignment.clock;
    let nav_interval = median_interval(&nav.t_s);
    let nav_gap = (5.0 * nav_interval).max(1.0);
    let (n0, n1) = (nav.t_s[0], *nav.t_s.last().unwrap_or(&nav.t_s[0]));
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
    let mut extra = MergedExtra { t_board_s: vec![], heading_deg: opt(&nav.heading_deg) };
    let (mut outside, mut in_gaps, mut saturated) = (0usize, 0usize, 0usize);
    for (i, (&tb, &m)) in board.t_s.iter().zip(&board.mag).enumerate() {
        let tn = map.to_nav(tb);
        if !(tn >= n0 && tn <= n1) {
            outside += 1;
            continue;
        }
        let b: Option<Bracket> = bracket(&nav.t_s, tn, nav_gap);
        if b.is_none() {
            in_gaps += 1;
        }
        let lerp = |c: &[f64]| b.map_or(f64::NAN, |b| b.lerp(c));
        let angle = |c: &[f64], heading: bool| b.map_or(f64::NAN, |b| b.lerp_angle_deg(c, heading));
        let health = board.health.as_ref().map_or(0.0, |h| h[i]);
        let bad = health.is_finite() && (health as u32) & HEALTH_SATURATED != 0;
        if bad {
            saturated += 1;
        }
        rec.mag.push(if bad { [f64::NAN; 3] } else { m });
        push(&mut rec.t_s, tn);
        push(&mut rec.roll_deg, angle(&nav.roll_deg, false));
        push(&mut rec.pitch_deg, lerp(&nav.pitch_deg));
        if let Some(c) = &nav.ref_heading_deg {
            push(&mut rec.ref_heading_deg, angle(c, true));
        }
        if let (Some(la), Some(lo)) = (&nav.lat_deg, &nav.lon_deg) {
            push(&mut rec.lat_deg, lerp(la));
            push(&mut rec.lon_deg, lerp(lo));
        } else {
            nav.lat_deg.as_ref().inspect(|c| push(&mut rec.lat_deg, lerp(c)));
            nav.lon_deg.as_ref().inspect(|c| push(&mut rec.lon_deg, lerp(c)));
        }
        if let Some([x, y, z]) = &nav.gyro_rad_s {
            push(&mut rec.gx_rad_s, lerp(x));
            push(&mut rec.gy_rad_s, lerp(y));
            push(&mut rec.gz_rad_s, lerp(z));
        }
        extra.t_board_s.push(tb);
        nav.heading_deg.as_ref().inspect(|c| push(&mut extra.heading_deg, angle(c, true)));
        nav.speed_mps.as_ref().inspect(|c| push(&mut rec.speed_mps, lerp(c)));
        nav.motor_current_a.as_ref().inspect(|c| push(&mut rec.motor_current_a, lerp(c)));
        board.temp_c.as_ref().inspect(|c| push(&mut rec.temp_c, c[i]));
    }
    if rec.mag.is_empty() {
        return Err(no_overlap(board, nav, format!("with the clock offset {:.3} s (navigation − board) no board sample falls within the navigation log", map.offset_s)));
    }
    let report = MergeReport {
        offset_s: map.offset_s,
        offset_sigma_s: alignment.offset_sigma_s,
        drift_ppm: map.drift_ppm,
        drift_sigma_ppm: alignment.drift_sigma_ppm,
        board_ref_s: map.board_ref_s,
        estimated: matches!(clock, Clock::Estimate { .. }),
        drift_fitted: alignment.drift_fitted,
        windows_used: alignment.windows,
        peak_correlation: if alignment.peak_correlation.is_finite() { alignment.peak_correlation } else { 0.0 },
        rows: rec.mag.len(),
        board_samples: board.t_s.len(),
        board_samples_outside_nav: outside,
        rows_in_nav_gaps: in_gaps,
        saturated_rows: saturated,
        nav_interval_s: nav_interval,
        board_interval_s: median_interval(&board.t_s),
    };
    Ok(Merged { recording: rec, extra, report })
}

fn push(col: &mut Option<Vec<f64>>, v: f64) {
    if let Some(c) = col.as_mut() {
        c.push(v);
    }
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
    pub fn extra_columns(&self) -> Vec<(&'static str, &Vec<f64>)> {
        let e = &self.extra;
        let mut cols = vec![("t_board", &e.t_board_s)];
        if let Some(c) = &e.heading_deg {
            cols.push(("heading_deg", c));
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
    let (b, n) = (BoardLog::read(board)?, NavLog::read(nav)?);
    merge(&b, &n, clock)
}



#[cfg(test)]
mod tests {
    use super::*;

    /// A vehicle turning in a constant field (NED nT): navigation at 10 Hz
    /// on its clock from `nav_start_s` for `len_s`, the board at 50 Hz on
    /// a clock `offset_s` behind (`t_nav = t_board + offset_s`), a linear
    /// sensor with hard iron.
    fn logs(offset_s: f64, nav_start_s: f64, len_s: f64, turning: bool) -> (BoardLog, NavLog) {
        let att = |t: f64| {
            if turning {
                (20.0 * (0.3 * t).sin(), 8.0 * (0.17 * t).sin(), (90.0 * (0.05 * t).sin() + 30.0 * (0.23 * t + 1.0).sin()).rem_euclid(360.0))
            } else {
                (1.0, -2.0, 100.0)
            }
        };
        let f = [20_000.0, 1_000.0, 40_000.0];
        let field = |t: f64| {
            let (r, p, h) = att(t);
            let m = rotation(r, p, h);
            // Rᵀ·f, then gains and hard iron.
            let body = [0, 1, 2].map(|c| m[c] * f[0] + m[3 + c] * f[1] + m[6 + c] * f[2]);
            [0.2 * body[0] + 1500.0, 0.09 * body[1] - 700.0, 0.16 * body[2] + 300.0]
        };
        let nav_t: Vec<f64> = (0..(len_s * 10.0) as usize).map(|k| nav_start_s + k as f64 * 0.1).collect();
        let nav = NavLog {
            roll_deg: nav_t.iter().map(|&t| att(t).0).collect(),
            pitch_deg: nav_t.iter().map(|&t| att(t).1).collect(),
            heading_deg: Some(nav_t.iter().map(|&t| att(t).2).collect()),
            // GPS at the surface only: the first 30 s.
            ref_heading_deg: Some(nav_t.iter().map(|&t| if t < nav_start_s + 30.0 { att(t).2 } else { f64::NAN }).collect()),
            t_s: nav_t,
            ..NavLog::default()
        };
        let board_t: Vec<f64> = (0..((len_s + 40.0) * 50.0) as usize).map(|k| nav_start_s - offset_s - 20.0 + k as f64 * 0.02).collect();
        let board = BoardLog { mag: board_t.iter().map(|&t| field(t + offset_s)).collect(), t_s: board_t, temp_c: None, health: None };
        (board, nav)
    }

    #[test]
    fn the_offset_is_found_and_nothing_is_extrapolated() {
        let (board, nav) = logs(-47.3, 500.0, 300.0, true);
        let m = merge(&board, &nav, Clock::default()).unwrap();
        let r = &m.report;
        // Noise-free logs: measured within 0.1 ms.
        assert!((r.offset_s + 47.3).abs() < 0.002 && r.drift_ppm.abs() < 10.0, "{r:?}");
        // 20 s of board samples before and after the navigation log are left out.
        assert!((r.board_samples_outside_nav as f64 - 40.0 * 50.0).abs() < 10.0, "{r:?}");
        let rec = &m.recording;
        let t = rec.t_s.as_ref().unwrap();
        assert!(t[0] >= nav.t_s[0] && *t.last().unwrap() <= *nav.t_s.last().unwrap());
        // GPS course only while both neighbours have it: the first 30 s.
        let gps = rec.ref_heading_deg.as_ref().unwrap();
        assert!(t.iter().zip(gps).all(|(t, g)| g.is_finite() == (*t <= nav.t_s[0] + 29.9 + 1e-6)), "GPS where it was");
        // Headings interpolated the short way round stay within 0…360.
        assert!(m.extra.heading_deg.as_ref().unwrap().iter().all(|h| (0.0..360.0).contains(h)));
    }

    #[test]
    fn a_given_offset_is_used_as_given() {
        let (board, nav) = logs(12.0, 0.0, 100.0, false);
        let m = merge(&board, &nav, Clock::Given { offset_s: 12.0, drift_ppm: 0.0 }).unwrap();
        assert!(!m.report.estimated && m.report.offset_s == 12.0);
        assert_eq!(m.recording.roll_deg.as_ref().unwrap()[0], 1.0);
    }

    #[test]
    fn logs_that_do_not_overlap_are_refused() {
        let (board, mut nav) = logs(0.0, 0.0, 100.0, true);
        for t in nav.t_s.iter_mut() {
            *t += 5000.0;
        }
        let e = merge(&board, &nav, Clock::default()).unwrap_err();
        assert!(matches!(e, MergeError::NoOverlap { .. }), "{e}");
        assert!(e.to_string().contains("do not overlap"), "{e}");
        let e = merge(&board, &nav, Clock::Given { offset_s: 0.0, drift_ppm: 0.0 }).unwrap_err();
        assert!(matches!(e, MergeError::NoOverlap { .. }), "{e}");
    }

    #[test]
    fn logs_without_rotation_are_refused() {
        let (board, nav) = logs(3.0, 0.0, 200.0, false);
        let e = merge(&board, &nav, Clock::default()).unwrap_err();
        assert!(matches!(e, MergeError::NoRotation(_)), "{e}");
        assert!(e.to_string().contains("--offset-s"), "{e}");
    }

    fn read_board(text: &str) -> Result<BoardLog, RecordingError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.csv");
        std::fs::write(&p, text).unwrap();
        BoardLog::read(&p)
    }

    fn read_nav(text: &str) -> Result<NavLog, RecordingError> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("nav.csv");
        std::fs::write(&p, text).unwrap();
        NavLog::read(&p)
    }

    #[test]
    fn missing_columns_and_time_running_backwards_are_refused() {
        let e = read_board("t,mx,my\n0,1,2\n").unwrap_err();
        assert!(matches!(e, RecordingError::MissingColumn { column: "mz", .. }), "{e}");
        let e = read_board("mx,my,mz\n0,1,2\n").unwrap_err();
        assert!(matches!(e, RecordingError::MissingColumn { column: "t", .. }), "{e}");
        let e = read_nav("t,roll_deg,heading_deg\n0,1,2\n").unwrap_err();
        assert!(matches!(e, RecordingError::MissingColumn { column: "pitch_deg", .. }), "{e}");
        let e = read_board("t,mx,my,mz\n0.0,1,2,3\n0.02,1,2,3\n0.01,1,2,3\n").unwrap_err();
        assert!(matches!(e, RecordingError::TimeBackwards { line: 4, .. }), "{e}");
        let e = read_nav("t,roll_deg,pitch_deg\n5,0,0\n4,0,0\n").unwrap_err();
        assert!(matches!(e, RecordingError::TimeBackwards { line: 3, .. }), "{e}");
        let e = read_board("t,mx,my,mz\n,1,2,3\n").unwrap_err();
        assert!(matches!(e, RecordingError::BadNumber { .. }), "a row without a time: {e}");
        // Optional columns are read; empty cells are absent.
        let b = read_board("t,mx,my,mz,temp_c,health\n0,1,2,3,20.5,0\n0.01,,2,3,,1\n").unwrap();
        let temp = b.temp_c.as_ref().unwrap();
        assert!(temp[0] == 20.5 && temp[1].is_nan());
        assert!(b.mag[1][0].is_nan() && b.health.as_ref().unwrap()[1] == 1.0);
    }

    #[test]
    fn saturated_samples_are_written_without_a_field() {
        let (mut board, nav) = logs(0.0, 0.0, 60.0, false);
        let mut health = vec![0.0; board.t_s.len()];
        health[2000] = HEALTH_SATURATED as f64;
        board.health = Some(health);
        let m = merge(&board, &nav, Clock::Given { offset_s: 0.0, drift_ppm: 0.0 }).unwrap();
        assert_eq!(m.report.saturated_rows, 1);
        assert_eq!(m.recording.mag.iter().filter(|v| v[0].is_nan()).count(), 1);
    }
}
