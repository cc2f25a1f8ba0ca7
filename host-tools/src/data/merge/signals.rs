//! What both logs see of the vehicle's motion, as signals the clock search
//! compares: the navigation's attitude as the entries of the rotation body
//! → NED ([`AttitudeSeries`], interpolated between rows by a cubic, so the
//! lag can be any fraction of a row) — with a heading (the AHRS's, or the
//! GPS course where there is one), or without: the third row of the
//! rotation, the down direction in the body, is the tilt alone
//! ([`tilt_features`]); and the rates of turn the two logs see
//! ([`RateViews`]), across the field and, without the heading's rate,
//! across the vertical too.

use calib_core::heading::Tilt;

use super::super::board_log::BoardLog;
use super::super::nav_log::NavLog;
use super::super::pairing::{bracket, wrap180};

/// The model's regressors: the nine entries of the rotation body → NED and a 1.
pub(super) const FEATURES: usize = 10;

/// The tilt model's regressors: the products `g_i·y_j` of the down
/// direction in the body and the raw field, and `g_i`.
pub(super) const TILT_FEATURES: usize = 12;

/// The down direction in the body, `Rᵀ·e_D`, from the attitude's
/// regressors (the rotation's third row: entries 2, 5 and 8, whatever the
/// heading).
pub(super) fn down(x: &[f64; FEATURES]) -> [f64; 3] {
    [x[2], x[5], x[8]]
}

/// The tilt model's regressors of the down direction `g` (or its rate: the
/// regressors are linear in `g`) and the raw field `y`.
pub(super) fn tilt_features(g: [f64; 3], y: &[f64; 3]) -> [f64; TILT_FEATURES] {
    let mut z = [0.0; TILT_FEATURES];
    for i in 0..3 {
        for j in 0..3 {
            z[3 * i + j] = g[i] * y[j];
        }
        z[9 + i] = g[i];
    }
    z
}

/// The regressors of one attitude: the rotation body → NED of roll, pitch,
/// heading in degrees (Z-Y-X), its columns `R·e_k = R_z(ψ)·level(e_k)`
/// (calib-core's levelling), then a 1. NaN when an angle is missing.
pub(super) fn attitude_features(roll_deg: f64, pitch_deg: f64, heading_deg: f64) -> [f64; FEATURES] {
    let tilt = Tilt::new(roll_deg.to_radians(), pitch_deg.to_radians());
    let (sy, cy) = heading_deg.to_radians().sin_cos();
    let mut x = [1.0; FEATURES];
    for k in 0..3 {
        let mut e = [0.0; 3];
        e[k] = 1.0;
        let [a, b, c] = tilt.level(e);
        x[3 * k..3 * k + 3].copy_from_slice(&[cy * a - sy * b, sy * a + cy * b, c]);
    }
    x
}

/// A sampled vector series read between its samples by a cubic (Hermite,
/// centred slopes): value and rate at any time. Samples more than
/// `max_gap_s` apart are not interpolated across; a sample with a NaN
/// first entry is missing.
pub(super) struct Cubic<const N: usize> {
    t_s: Vec<f64>,
    x: Vec<[f64; N]>,
    max_gap_s: f64,
}

impl<const N: usize> Cubic<N> {
    /// From sample times and values.
    pub(super) fn new(t_s: Vec<f64>, x: Vec<[f64; N]>, max_gap_s: f64) -> Self {
        Self { t_s, x, max_gap_s }
    }

    /// The samples.
    pub(super) fn rows(&self) -> impl Iterator<Item = &[f64; N]> {
        self.x.iter()
    }

    /// The slope at sample `j` from its neighbours (one-sided at an end or
    /// a gap); `None` when sample `j` is missing.
    fn slope(&self, j: usize) -> Option<[f64; N]> {
        let ok = |k: usize| self.x.get(k).is_some_and(|x| x[0].is_finite());
        if !ok(j) {
            return None;
        }
        let near = |k: usize| ok(k) && (self.t_s[k] - self.t_s[j]).abs() <= self.max_gap_s;
        let lo = if j > 0 && near(j - 1) { j - 1 } else { j };
        let hi = if near(j + 1) { j + 1 } else { j };
        if lo == hi {
            return Some([0.0; N]);
        }
        let dt = self.t_s[hi] - self.t_s[lo];
        Some(std::array::from_fn(|a| (self.x[hi][a] - self.x[lo][a]) / dt))
    }

    /// The value and its rate (per second) at time `t`; `None` outside the
    /// series, in a gap or next to a missing sample.
    pub(super) fn at(&self, t: f64) -> Option<([f64; N], [f64; N])> {
        let b = bracket(&self.t_s, t, self.max_gap_s)?;
        let (x0, m0) = (self.x[b.lo], self.slope(b.lo)?);
        if b.lo == b.hi {
            return Some((x0, m0));
        }
        let (x1, m1) = (self.x[b.hi], self.slope(b.hi)?);
        let h = self.t_s[b.hi] - self.t_s[b.lo];
        let s = b.weight;
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
        let (d00, d10, d01, d11) = (6.0 * s2 - 6.0 * s, 3.0 * s2 - 4.0 * s + 1.0, -6.0 * s2 + 6.0 * s, 3.0 * s2 - 2.0 * s);
        let x = std::array::from_fn(|a| h00 * x0[a] + h10 * h * m0[a] + h01 * x1[a] + h11 * h * m1[a]);
        let dx = std::array::from_fn(|a| (d00 * x0[a] + d10 * h * m0[a] + d01 * x1[a] + d11 * h * m1[a]) / h);
        Some((x, dx))
    }
}

/// The navigation's attitude regressors ([`attitude_features`]) at its
/// rows, read between them by a cubic.
pub(super) type AttitudeSeries = Cubic<FEATURES>;

/// The attitude series of a navigation log with `heading_deg` (a row
/// with no heading is missing).
pub(super) fn attitude_series(nav: &NavLog, heading_deg: &[f64], max_gap_s: f64) -> AttitudeSeries {
    let x = (0..nav.t_s.len()).map(|i| attitude_features(nav.roll_deg[i], nav.pitch_deg[i], heading_deg.get(i).copied().unwrap_or(f64::NAN))).collect();
    Cubic::new(nav.t_s.clone(), x, max_gap_s)
}

/// The attitude series of a navigation log with the heading taken as 0:
/// its down direction ([`down`]) is the tilt, whatever the heading.
pub(super) fn tilt_series(nav: &NavLog, max_gap_s: f64) -> AttitudeSeries {
    let x = (0..nav.t_s.len()).map(|i| attitude_features(nav.roll_deg[i], nav.pitch_deg[i], 0.0)).collect();
    Cubic::new(nav.t_s.clone(), x, max_gap_s)
}

/// The board's usable raw field (saturated samples missing), read between
/// samples by a cubic.
pub(super) fn field_series(board: &BoardLog, max_gap_s: f64) -> Cubic<3> {
    let x = (0..board.t_s.len()).map(|i| if board.saturated(i) || !board.mag[i].iter().all(|v| v.is_finite()) { [f64::NAN; 3] } else { board.mag[i] }).collect();
    Cubic::new(board.t_s.clone(), x, max_gap_s)
}

/// A vector signal on a uniform grid (NaN where not available).
pub(super) struct Signal {
    pub(super) t0_s: f64,
    pub(super) dt_s: f64,
    pub(super) v: Vec<[f64; 3]>,
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

    /// Grid points over `[from, to]`.
    pub(super) fn points(&self, from: f64, to: f64) -> usize {
        self.index_range(from, to).len()
    }

    /// RMS of the vectors' length over `[from, to]`.
    pub(super) fn rms(&self, from: f64, to: f64) -> f64 {
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

fn unit(v: [f64; 3]) -> [f64; 3] {
    let n = dot(v, v).sqrt();
    if n > 0.0 && n.is_finite() {
        v.map(|x| x / n)
    } else {
        [f64::NAN; 3]
    }
}

/// Half the baseline of the rate differences, s (both signals alike).
const RATE_HALF_BASE_S: f64 = 0.25;

/// Per axis, the centre and half-range of the raw field between its 1 % and
/// 99 % quantiles: a rough hard- and soft-iron correction so that the raw
/// field's direction turns nearly as the body does. An axis whose range is
/// under a third of the widest one (too few attitudes to tell its bias) is
/// left as it is, scaled like the widest.
pub(super) fn rough_normalisation(mag: &[[f64; 3]]) -> [(f64, f64); 3] {
    let ranges = [0, 1, 2].map(|k| {
        let mut v: Vec<f64> = mag.iter().map(|m| m[k]).filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return (0.0, 1.0);
        }
        let (lo, hi) = match (calib_core::series::quantile(&mut v, 0.01), calib_core::series::quantile(&mut v, 0.99)) {
            (Some(lo), Some(hi)) => (lo, hi),
            _ => return (0.0, 1.0),
        };
        (0.5 * (lo + hi), 0.5 * (hi - lo))
    });
    let widest = ranges.iter().map(|r| r.1).fold(0.0, f64::max);
    if widest.is_nan() || widest <= 0.0 {
        return [(0.0, 1.0); 3];
    }
    ranges.map(|(c, h)| if h >= widest / 3.0 { (c, h) } else { (0.0, widest) })
}

/// The number of grid points of `dt` over a log's span.
fn grid_len(t_s: &[f64], dt: f64) -> usize {
    let (t0, t1) = (t_s[0], *t_s.last().unwrap_or(&t_s[0]));
    ((t1 - t0) / dt).floor() as usize + 1
}

/// The board's view of the turns: the field's direction `u` and the part of
/// the body rate across it, `−u × du/dt` (rad/s), on a grid of `dt`.
fn board_signals(log: &BoardLog, dt: f64, max_gap_s: f64) -> (Signal, Signal) {
    let (t0, n) = (log.t_s[0], grid_len(&log.t_s, dt));
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

/// The gyro's body rate on a grid of `dt`, averaged over the board's
/// difference baseline.
fn gyro_rate(log: &NavLog, g: &[&[f64]; 3], dt: f64, max_gap_s: f64) -> Vec<[f64; 3]> {
    let (t0, n) = (log.t_s[0], grid_len(&log.t_s, dt));
    let k = ((RATE_HALF_BASE_S / dt).round() as usize).max(1);
    let w: Vec<[f64; 3]> = (0..n).map(|i| bracket(&log.t_s, t0 + i as f64 * dt, max_gap_s).map_or([f64::NAN; 3], |b| [b.lerp(g[0]), b.lerp(g[1]), b.lerp(g[2])])).collect();
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
}

/// The body rate from the rates of roll, pitch and (when logged) heading
/// (Z-Y-X kinematics) on a grid of `dt`, and the down direction in the body.
fn euler_rate(log: &NavLog, dt: f64, max_gap_s: f64) -> (Vec<[f64; 3]>, Vec<[f64; 3]>) {
    let (t0, n) = (log.t_s[0], grid_len(&log.t_s, dt));
    let k = ((RATE_HALF_BASE_S / dt).round() as usize).max(1);
    let at = |i: usize| bracket(&log.t_s, t0 + i as f64 * dt, max_gap_s);
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
    let rates = (0..n)
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
        .collect();
    let down = (0..n)
        .map(|i| {
            let (r, p) = (roll[i].to_radians(), pitch[i].to_radians());
            [-p.sin(), r.sin() * p.cos(), r.cos() * p.cos()]
        })
        .collect();
    (rates, down)
}

/// The body rate, rad/s, on a grid of `dt`: from the gyro when logged,
/// otherwise from the rates of roll, pitch and heading; and, when that
/// rate lacks the heading's (no gyro, no heading), the down direction in
/// the body: the heading's rate is a rate about it.
fn nav_signal(log: &NavLog, dt: f64, max_gap_s: f64) -> (Signal, Option<Signal>) {
    let gyro = log.gyro_rad_s();
    let gyro_usable = gyro.is_some_and(|g| g[0].iter().filter(|v| v.is_finite()).count() * 2 > g[0].len());
    let grid = |v| Signal { t0_s: log.t_s[0], dt_s: dt, v };
    match (gyro, gyro_usable) {
        (Some(g), true) => (grid(gyro_rate(log, &g, dt, max_gap_s)), None),
        _ => {
            let (rates, down) = euler_rate(log, dt, max_gap_s);
            (grid(rates), log.heading_deg.is_none().then(|| grid(down)))
        }
    }
}

/// The board's and the navigation's views of the turns, on one grid.
pub(super) struct RateViews {
    dirs: Signal,
    /// The board's rate across the field.
    pub(super) board: Signal,
    /// The navigation's body rate.
    pub(super) nav: Signal,
    /// The navigation's down direction in the body, when its rate lacks
    /// the heading's.
    nav_down: Option<Signal>,
}

impl RateViews {
    /// Both views on a grid of `dt`.
    pub(super) fn new(board: &BoardLog, nav: &NavLog, dt: f64, board_gap_s: f64, nav_gap_s: f64) -> Self {
        let (dirs, b) = board_signals(board, dt, board_gap_s);
        let (nav, nav_down) = nav_signal(nav, dt, nav_gap_s);
        Self { dirs, board: b, nav, nav_down }
    }

    /// How well the board's rate across the field over `[from, to]` (board
    /// clock) matches the navigation's body rate across the same field,
    /// `lag` later (`t_nav = t_board + lag`): Σ a·b / √(Σ|a|² Σ|b|²), 1 when
    /// identical; and the number of pairs. When the navigation's rate lacks
    /// the heading's (`ω = ω_rp + ψ̇·g`, `g` the down direction), only the
    /// part across both the field and the vertical is compared, along
    /// `n = u × g`: there `ω·n = ω_rp·n` whatever the heading does.
    pub(super) fn correlation(&self, lag: f64, from: f64, to: f64) -> (f64, usize) {
        self.correlation_thinned(lag, from, to, 1)
    }

    /// [`Self::correlation`] over every `stride`-th grid point.
    pub(super) fn correlation_thinned(&self, lag: f64, from: f64, to: f64, stride: usize) -> (f64, usize) {
        let (mut n, mut sab, mut saa, mut sbb) = (0usize, 0.0, 0.0, 0.0);
        for i in self.board.index_range(from, to).step_by(stride.max(1)) {
            let (a, u) = (self.board.v[i], self.dirs.v[i]);
            if !a[0].is_finite() {
                continue;
            }
            let tn = self.board.t0_s + i as f64 * self.board.dt_s + lag;
            let w = self.nav.value_at(tn);
            if !w[0].is_finite() {
                continue;
            }
            let (a, b) = match &self.nav_down {
                Some(down) => {
                    let across = unit(cross(u, down.value_at(tn)));
                    if !across[0].is_finite() {
                        continue;
                    }
                    let (an, bn) = (dot(a, across), dot(w, across));
                    (across.map(|x| x * an), across.map(|x| x * bn))
                }
                None => {
                    let along = dot(w, u);
                    (a, [0, 1, 2].map(|k| w[k] - along * u[k]))
                }
            };
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The regressors against the Z-Y-X rotation multiplied out by hand
    /// (`R = R_z(ψ) R_y(θ) R_x(φ)`, column-major here).
    #[test]
    fn the_features_are_the_rotation_body_to_ned() {
        let (r, p, y) = (20f64.to_radians(), -35f64.to_radians(), 250f64.to_radians());
        let (sr, cr, sp, cp, sy, cy) = (r.sin(), r.cos(), p.sin(), p.cos(), y.sin(), y.cos());
        let m = [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr, sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr, -sp, cp * sr, cp * cr];
        let x = attitude_features(20.0, -35.0, 250.0);
        for k in 0..3 {
            for row in 0..3 {
                assert!((x[3 * k + row] - m[3 * row + k]).abs() < 1e-12, "R[{row}][{k}]");
            }
        }
        assert_eq!(x[9], 1.0);
    }

    /// A constant-rate turn sampled at 1 Hz, read between rows: the cubic
    /// follows cos/sin of the heading within 1e-4 (linear interpolation:
    /// 3e-4 at 2°/s) and its rate within 1 %.
    #[test]
    fn the_attitude_is_interpolated_between_rows_with_its_rate() {
        let t: Vec<f64> = (0..100).map(f64::from).collect();
        let nav = NavLog { roll_deg: vec![0.0; 100], pitch_deg: vec![0.0; 100], t_s: t.clone(), ..NavLog::default() };
        let heading: Vec<f64> = t.iter().map(|t| (2.0 * t) % 360.0).collect();
        let s = attitude_series(&nav, &heading, 1.5);
        for tq in [10.3, 50.5, 77.9] {
            let (x, dx) = s.at(tq).unwrap();
            let h = (2.0 * tq).to_radians();
            assert!((x[0] - h.cos()).abs() < 1e-4 && (x[1] - h.sin()).abs() < 1e-4, "{tq}: {x:?}");
            let w = 2f64.to_radians();
            assert!((dx[0] + w * h.sin()).abs() < 0.01 * w && (dx[1] - w * h.cos()).abs() < 0.01 * w, "{tq}: {dx:?}");
        }
        assert!(s.at(-0.5).is_none() && s.at(99.5).is_none());
    }
}
