//! The gyro-aided fit made robust: the equations of [`calib_core::gyro`]
//! (over each window of integrated rotation `A·r_j − R·(A·r_i) + (I − R)·c
//! = 0`, and the levelled vertical `lᵀ(A·r − c) = Z`), solved by
//! iteratively reweighted least squares with Huber weights, started from
//! a given calibration (the attitude-aided fit's, where there is one), with
//! the gyro's bias and lag as the plain batch fit estimated them. Windows
//! where the gyro and the field disagree (a fast turn's integration error,
//! a disturbance in the room) lose weight instead of bending the fit.
//!
//! With the world model's inclination ([`DipMeasurement`]) the calibrated
//! field's dip is one more equation, weighted as the attitude-aided fit
//! weighs its dip prior: the world model's σ against the data's own
//! information on the dip, raised by how far contiguous blocks of the
//! recording scatter beyond it ([`calib_core::attitude_fit::world::block_inflation`]);
//! a tiny σ holds the dip.

use calib_core::cal::FieldCal;
use calib_core::fit::Normalization;
use calib_core::gyro::{GyroConfig, GyroSample, WindowChain};
use calib_core::heading::Tilt;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};

/// Unknowns: `A` without `A₀₀ = 1` (8), `c` (3), `Z`.
const N: usize = 12;

/// Huber's constant, in robust standard deviations of each kind of
/// equation.
pub const HUBER_K: f64 = 1.345;
/// Most reweighting passes.
pub const PASSES: usize = 8;
/// The passes stop once one moves no unknown by more than this (normalised
/// units: `A`'s entries near 1, `c` and `Z` in field radii). Each pass
/// shrinks the step 7–10× on the bench's swing and the BROAD trials (from
/// about 1e-3 after the first), so what is left then is about 1e-9.
pub const SETTLED: f64 = 1e-8;

/// One row of `Φ` and its target.
type Row = ([f64; N], f64);

/// The equations of a recording: each window's three rows, and each
/// levelled-vertical row, in the samples' order.
struct Equations {
    kinematic: Vec<[Row; 3]>,
    attitude: Vec<Row>,
    /// The index of the sample each window ends at, and of each attitude
    /// row's sample (the blocks of the dip's inflation; kept only for a
    /// fit that weighs the dip).
    kinematic_at: Vec<usize>,
    attitude_at: Vec<usize>,
    /// Samples seen.
    samples: usize,
}

/// The equations of every window and attitude row of `samples`, normalised
/// with `norm`; the windows' rotations from calib-core's [`WindowChain`]
/// (the batch fit's: a few matrix products a sample instead of one a
/// window step).
fn equations(samples: &[GyroSample<f64>], norm: &Normalization<f64>, cfg: &GyroConfig<f64>, positions: bool) -> Equations {
    let capacity = if positions { samples.len() } else { 0 };
    let mut out = Equations { kinematic: Vec::with_capacity(samples.len()), attitude: Vec::with_capacity(samples.len()), kinematic_at: Vec::with_capacity(capacity), attitude_at: Vec::with_capacity(capacity), samples: samples.len() };
    let mut chain = WindowChain::new();
    for (at, s) in samples.iter().enumerate() {
        let finite = s.t_s.is_finite() && s.raw.iter().chain(s.rate_rad_s.iter()).all(|v| v.is_finite());
        if !finite {
            chain.reset();
            continue;
        }
        let r = norm.apply(s.raw);
        if let Some((ri, rj, rot)) = chain.push(s, r, cfg) {
            let rot = Matrix3::from_fn(|i, j| rot[i][j]);
            let col = |row: usize, c: usize| -> Vector3<f64> {
                let mut ej = Vector3::zeros();
                ej[row] = rj[c];
                let mut ei = Vector3::zeros();
                ei[row] = ri[c];
                ej - rot * ei
            };
            let u0 = col(0, 0);
            let mut rows = [([0.0; N], 0.0); 3];
            for (m, out_row) in rows.iter_mut().enumerate() {
                let mut phi = [0.0; N];
                for (idx, (row, c)) in ENTRIES.iter().enumerate() {
                    phi[idx] = col(*row, *c)[m];
                }
                for nn in 0..3 {
                    let i_minus_r = if m == nn { 1.0 } else { 0.0 } - rot[(m, nn)];
                    phi[8 + nn] = -i_minus_r;
                }
                *out_row = (phi, -u0[m]);
            }
            out.kinematic.push(rows);
            if positions {
                out.kinematic_at.push(at);
            }
        }
        let w = cfg.attitude_weight;
        if s.roll_rad.is_finite() && s.pitch_rad.is_finite() && w > 0.0 {
            let [_, _, l] = Tilt::new(s.roll_rad, s.pitch_rad).matrix();
            let mut phi = [0.0; N];
            for (idx, (row, c)) in ENTRIES.iter().enumerate() {
                phi[idx] = w * l[*row] * r[*c];
            }
            for nn in 0..3 {
                phi[8 + nn] = -w * l[nn];
            }
            phi[11] = -w;
            out.attitude.push((phi, -w * l[0] * r[0]));
            if positions {
                out.attitude_at.push(at);
            }
        }
    }
    out
}

/// `A`'s entries among the unknowns, in order (`A₀₀ = 1` is not one).
const ENTRIES: [(usize, usize); 8] = [(0, 1), (0, 2), (1, 0), (1, 1), (1, 2), (2, 0), (2, 1), (2, 2)];

/// The residual norm of a group of rows at `x`, per row.
fn residual(rows: &[Row], x: &SVector<f64, N>) -> f64 {
    rows.iter().map(|(phi, y)| (SVector::<f64, N>::from_column_slice(phi).dot(x) - y).powi(2)).sum::<f64>().sqrt() / (rows.len() as f64).sqrt()
}

/// Adds `w·φφᵀ` to the lower triangle of `ata` (what the Cholesky factor
/// reads; each entry `(w·φ_i)·φ_j` as the outer product gives it) and
/// `w·y·φ` to `atb`, for each row.
fn add_rows(ata: &mut [[f64; N]; N], atb: &mut SVector<f64, N>, rows: &[Row], w: f64) {
    for (phi, y) in rows {
        for i in 0..N {
            let wp = w * phi[i];
            for j in 0..=i {
                ata[i][j] += wp * phi[j];
            }
        }
        *atb += w * *y * SVector::<f64, N>::from_column_slice(phi);
    }
}

/// Huber's weight of a residual `r` against the robust scale `s`.
fn huber_weight(r: f64, s: Option<f64>) -> f64 {
    match s {
        Some(s) if s > 0.0 && r > HUBER_K * s => HUBER_K * s / r,
        _ => 1.0,
    }
}

/// The unknowns of a calibration `h = M·(raw − b)` in `norm`'s units
/// (`A₀₀ = 1`), `Z` the mean levelled vertical.
fn unknowns_of(cal: &FieldCal<f64>, norm: &Normalization<f64>, samples: &[GyroSample<f64>]) -> Option<SVector<f64, N>> {
    let m00 = cal.matrix[0][0];
    if !(m00.abs() > 0.0) {
        return None;
    }
    let a = Matrix3::from_fn(|i, j| cal.matrix[i][j] / m00);
    let d = Vector3::from_fn(|i, _| (cal.bias[i] - norm.centre[i]) / norm.scale);
    let c = a * d;
    let mut x = SVector::<f64, N>::zeros();
    for (idx, (row, col)) in ENTRIES.iter().enumerate() {
        x[idx] = a[(*row, *col)];
    }
    x[8] = c[0];
    x[9] = c[1];
    x[10] = c[2];
    let (mut sum, mut count) = (0.0, 0.0);
    for s in samples.iter().filter(|s| s.roll_rad.is_finite() && s.pitch_rad.is_finite() && s.raw.iter().all(|v| v.is_finite())) {
        let r = norm.apply(s.raw);
        let h = a * Vector3::new(r[0], r[1], r[2]) - c;
        sum += Tilt::new(s.roll_rad, s.pitch_rad).level([h[0], h[1], h[2]])[2];
        count += 1.0;
    }
    x[11] = if count > 0.0 { sum / count } else { 0.0 };
    Some(x)
}

/// The world model's inclination as a measurement of the gyro-aided fit:
/// the fitted dip `asin(Z / rms|A·r − c|)` (what the scale set afterwards
/// makes the levelled vertical over the intensity) against it, weighted
/// against what the data can tell ([`refine`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DipMeasurement {
    /// The reference's inclination, rad.
    pub inclination_rad: f64,
    /// Its 1σ, rad (a tiny one holds the dip at it).
    pub sigma_rad: f64,
}

/// What the dip measurement did to the gyro-aided fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DipShaped {
    /// The fitted dip, rad.
    pub dip_rad: f64,
    /// The share (0–1) of the fitted dip the measurement set: how much the
    /// dip moves per unit move of the reference's inclination.
    pub share: f64,
    /// How far the data overstated their information on the dip (≥ 1,
    /// [`calib_core::attitude_fit::world::block_inflation`] over
    /// [`DIP_BLOCKS`] contiguous blocks): the factor the measurement's
    /// weight was raised by.
    pub inflation: f64,
    /// The dip the data give alone (the robust fit without the
    /// measurement), rad.
    pub data_dip_rad: f64,
    /// Its 1σ, rad: the data's formal one raised by the inflation.
    pub data_sigma_rad: f64,
}

/// The robust fit's answer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refined {
    /// The calibration, scaled to the reference intensity.
    pub cal: FieldCal<f64>,
    /// What the dip measurement did, when one was given.
    pub dip: Option<DipShaped>,
}

/// The dip-held fit of a recording, fitted beside its free one
/// ([`refine`]) and handed to the held candidate's fit of the
/// same rows, which then is not refitted; `None` inside where it failed.
pub type HeldShare = std::sync::OnceLock<Option<Refined>>;

/// Contiguous blocks the data's information on the dip is checked over:
/// the attitude-aided fit's ([`calib_core::attitude_fit::DIP_BLOCKS`]).
pub const DIP_BLOCKS: usize = calib_core::attitude_fit::DIP_BLOCKS as usize;

/// `Σr`, `Σr·rᵀ` and the count of the finite normalised readings, and
/// `Σl·rᵀ`, `Σl` and the count of those with an attitude (`l` the
/// levelling's third row): the RMS of `|A·r − c|` (the scale's) and the
/// mean levelled vertical `lᵀ(A·r − c)`, with their gradients, without a
/// pass over the samples.
struct Moments {
    count: f64,
    sum: Vector3<f64>,
    sum_sq: Matrix3<f64>,
    levelled: f64,
    l_sum: Vector3<f64>,
    l_r: Matrix3<f64>,
}

impl Moments {
    fn of(samples: &[GyroSample<f64>], norm: &Normalization<f64>) -> Self {
        let mut m = Moments { count: 0.0, sum: Vector3::zeros(), sum_sq: Matrix3::zeros(), levelled: 0.0, l_sum: Vector3::zeros(), l_r: Matrix3::zeros() };
        for s in samples.iter().filter(|s| s.raw.iter().all(|v| v.is_finite())) {
            let r = Vector3::from(norm.apply(s.raw));
            m.count += 1.0;
            m.sum += r;
            m.sum_sq += r * r.transpose();
            if s.roll_rad.is_finite() && s.pitch_rad.is_finite() {
                let [_, _, l] = Tilt::new(s.roll_rad, s.pitch_rad).matrix();
                let l = Vector3::from(l);
                m.levelled += 1.0;
                m.l_sum += l;
                m.l_r += l * r.transpose();
            }
        }
        m
    }
}

/// The dip of the calibrated field at `x`, `asin(v̄ / rms)` (rad: `v̄` the
/// mean levelled vertical, `rms` the RMS intensity, both of `A·r − c`
/// over the readings, so what the calibrated recording shows), and its
/// gradient over the unknowns; `None` where it is not defined (no
/// attitude, no field, `|v̄| ≥ rms`).
fn dip_and_gradient(x: &SVector<f64, N>, m: &Moments) -> Option<(f64, SVector<f64, N>)> {
    let (a, c) = matrix_and_offset(x);
    let n = m.count;
    if !(n > 0.0 && m.levelled > 0.0) {
        return None;
    }
    // rms² = (tr(A S Aᵀ) − 2 cᵀA Σr + N|c|²)/N.
    let a_s = a * m.sum_sq;
    let a_sum = a * m.sum;
    let ms = (a_s.component_mul(&a).sum() - 2.0 * c.dot(&a_sum) + n * c.norm_squared()) / n;
    if !(ms > 0.0) {
        return None;
    }
    let rms = ms.sqrt();
    // v̄ = (Σ lᵀA r − Σlᵀc)/N_l = (tr(Aᵀ·Σl rᵀ)... entrywise) / N_l.
    let vertical = (a.component_mul(&m.l_r).sum() - m.l_sum.dot(&c)) / m.levelled;
    let q = vertical / rms;
    if !(q.abs() < 1.0) {
        return None;
    }
    let cos = (1.0 - q * q).sqrt();
    // ∂dip = (∂v̄ − q·∂rms)/(rms·cos), ∂rms = ∂rms²/(2 rms):
    // ∂rms²/∂A_ij = 2((A S)_ij − c_i Σr_j)/N, ∂rms²/∂c_i = 2(N c_i − (A Σr)_i)/N;
    // ∂v̄/∂A_ij = (Σl rᵀ)_ij/N_l, ∂v̄/∂c_i = −Σl_i/N_l.
    let (kv, kr) = (1.0 / (rms * cos * m.levelled), -q / (rms * cos) / (rms * n));
    let mut g = SVector::<f64, N>::zeros();
    for (idx, (row, col)) in ENTRIES.iter().enumerate() {
        g[idx] = kv * m.l_r[(*row, *col)] + kr * (a_s[(*row, *col)] - c[*row] * m.sum[*col]);
    }
    for i in 0..3 {
        g[8 + i] = -kv * m.l_sum[i] + kr * (n * c[i] - a_sum[i]);
    }
    Some((q.asin(), g))
}

/// `A` (with `A₀₀ = 1`) and `c` of the unknowns.
fn matrix_and_offset(x: &SVector<f64, N>) -> (Matrix3<f64>, Vector3<f64>) {
    let mut a = Matrix3::identity();
    for (idx, (row, col)) in ENTRIES.iter().enumerate() {
        a[(*row, *col)] = x[idx];
    }
    (a, Vector3::new(x[8], x[9], x[10]))
}

/// The dip measurement's row at `x`, linearised: `√κ·σ/σ_I·(∇dip·x' −
/// (I − dip + ∇dip·x))`, `σ²` the data rows' variance, so that against the
/// data's formal information it weighs as the world model's σ against the
/// data's real one (as the attitude-aided fit's dip prior).
fn dip_row(x: &SVector<f64, N>, m: &Moments, dip: &DipMeasurement, weight: f64) -> Option<Row> {
    let (d, g) = dip_and_gradient(x, m)?;
    let w = weight / dip.sigma_rad;
    let phi: [f64; N] = core::array::from_fn(|i| w * g[i]);
    Some((phi, w * (g.dot(x) + dip.inclination_rad - d)))
}

/// The residuals and Huber weights of one pass at `x`, and the weighted
/// normal equations (lower triangle): `base` (every row at unit weight)
/// with `(w − 1)·φφᵀ` added for each row Huber's weight takes down.
struct Pass<'a> {
    eq: &'a Equations,
    base_ata: [[f64; N]; N],
    base_atb: SVector<f64, N>,
    res_k: Vec<f64>,
    res_a: Vec<f64>,
    scratch: Vec<f64>,
    /// The robust scales of the last [`Pass::at`].
    scales: (Option<f64>, Option<f64>),
}

impl<'a> Pass<'a> {
    fn new(eq: &'a Equations) -> Self {
        // Every row at unit weight, once: a pass adds `(w − 1)·φφᵀ` for the
        // rows Huber's weight takes down (about a tenth of them) instead of
        // every row's `w·φφᵀ`.
        let (mut base_ata, mut base_atb) = ([[0.0; N]; N], SVector::<f64, N>::zeros());
        for rows in &eq.kinematic {
            add_rows(&mut base_ata, &mut base_atb, rows, 1.0);
        }
        add_rows(&mut base_ata, &mut base_atb, &eq.attitude, 1.0);
        Self { eq, base_ata, base_atb, res_k: vec![0.0; eq.kinematic.len()], res_a: vec![0.0; eq.attitude.len()], scratch: Vec::new(), scales: (None, None) }
    }

    /// The weighted normal equations at `x`.
    fn at(&mut self, x: &SVector<f64, N>) -> ([[f64; N]; N], SVector<f64, N>) {
        let eq = self.eq;
        // Each group's residual norm per row at the pass's `x` (computed
        // once a pass, for the scale and the weights), and a copy the
        // median reorders.
        for (r, rows) in self.res_k.iter_mut().zip(&eq.kinematic) {
            *r = residual(rows, x);
        }
        for (r, row) in self.res_a.iter_mut().zip(&eq.attitude) {
            *r = residual(core::slice::from_ref(row), x);
        }
        // Robust scale of each kind: 1.4826 × the median residual norm (per
        // row of the group).
        let scratch = &mut self.scratch;
        let mut scale = |res: &[f64]| {
            scratch.clear();
            scratch.extend_from_slice(res);
            calib_core::series::median(scratch).map(|m| 1.4826 * m)
        };
        let (sk, sa) = (scale(&self.res_k), scale(&self.res_a));
        self.scales = (sk, sa);
        let (mut ata, mut atb) = (self.base_ata, self.base_atb);
        for (rows, &r) in eq.kinematic.iter().zip(&self.res_k) {
            let w = huber_weight(r, sk);
            if w < 1.0 {
                add_rows(&mut ata, &mut atb, rows, w - 1.0);
            }
        }
        for (row, &r) in eq.attitude.iter().zip(&self.res_a) {
            let w = huber_weight(r, sa);
            if w < 1.0 {
                add_rows(&mut ata, &mut atb, core::slice::from_ref(row), w - 1.0);
            }
        }
        (ata, atb)
    }

    /// Every row with its Huber weight and the sample it belongs to, at the
    /// `x` of the last [`Pass::at`].
    fn weighted_rows(&self) -> impl Iterator<Item = (&Row, f64, usize)> + '_ {
        let (sk, sa) = self.scales;
        let eq = self.eq;
        let kinematic = eq.kinematic.iter().zip(&self.res_k).zip(&eq.kinematic_at).flat_map(move |((rows, &r), &at)| rows.iter().map(move |row| (row, huber_weight(r, sk), at)));
        let attitude = eq.attitude.iter().zip(&self.res_a).zip(&eq.attitude_at).map(move |((row, &r), &at)| (row, huber_weight(r, sa), at));
        kinematic.chain(attitude)
    }
}

/// The symmetric matrix of a lower triangle.
fn symmetric(ata: &[[f64; N]; N]) -> SMatrix<f64, N, N> {
    SMatrix::<f64, N, N>::from_fn(|i, j| if j <= i { ata[i][j] } else { ata[j][i] })
}

/// Reweighting passes from `x` until one moves no unknown by more than
/// [`SETTLED`] (at most [`PASSES`]); `extra` adds rows at each pass's `x`
/// (the dip measurement's, re-linearised). Returns the solution and the
/// data's weighted normal equations of the last pass (without `extra`'s
/// rows; `pass` holds that pass's residuals and weights): within
/// [`SETTLED`] of the solution, where the dip's information is read
/// without another pass over the rows.
fn passes(pass: &mut Pass<'_>, mut x: SVector<f64, N>, extra: impl Fn(&SVector<f64, N>) -> Option<Row>) -> Option<(SVector<f64, N>, [[f64; N]; N])> {
    let mut last = None;
    for _ in 0..PASSES {
        let (data_ata, mut atb) = pass.at(&x);
        let mut ata = data_ata;
        if let Some(row) = extra(&x) {
            add_rows(&mut ata, &mut atb, core::slice::from_ref(&row), 1.0);
        }
        let next = symmetric(&ata).cholesky()?.solve(&atb);
        let moved = (next - x).amax();
        x = next;
        last = Some(data_ata);
        if moved < SETTLED {
            break;
        }
    }
    Some((x, last?))
}

/// The data's variance per unit-weight row (`Σ w·r² / (rows − unknowns)`),
/// the inflation of their information on the dip over [`DIP_BLOCKS`]
/// contiguous blocks of samples, and the dip's formal variance, at `x`
/// with the weights and the matrix `ata` of the last [`Pass::at`] (the
/// pass that settled on `x`, within [`SETTLED`] of it):
/// `(σ², inflation, the dip's formal variance)`.
fn dip_information(pass: &Pass<'_>, ata: &[[f64; N]; N], x: &SVector<f64, N>, gradient: &SVector<f64, N>) -> Option<(f64, f64, f64)> {
    let inverse = symmetric(ata).cholesky()?.inverse();
    let v = inverse * gradient;
    let (mut wrss, mut rows) = (0.0, 0usize);
    let mut pulls = [0.0; DIP_BLOCKS];
    let mut formal = 0.0;
    let samples = pass.eq.samples.max(1);
    for ((phi, y), w, at) in pass.weighted_rows() {
        let phi = SVector::<f64, N>::from_column_slice(phi);
        let r = phi.dot(x) - y;
        let g = v.dot(&phi);
        wrss += w * r * r;
        rows += 1;
        if let Some(p) = pulls.get_mut((at * DIP_BLOCKS / samples).min(DIP_BLOCKS - 1)) {
            *p += g * w * r;
        }
        formal += g * g * w;
    }
    let sigma2 = wrss / rows.saturating_sub(N).max(1) as f64;
    Some((sigma2, calib_core::attitude_fit::world::block_inflation(&pulls, sigma2 * formal), sigma2 * gradient.dot(&v)))
}

/// What the data alone tell of the dip at the settled free solution `x`
/// (the pass that settled on it, `ata` its matrix): read once, and shared
/// by every dip measurement fitted from `x` ([`with_dip`]).
struct DataDip {
    /// The data's dip, rad, and its gradient in the unknowns.
    dip_rad: f64,
    /// The data's variance per unit-weight row.
    sigma2: f64,
    /// How far the data overstate their information on the dip.
    inflation: f64,
    /// The dip's formal variance.
    formal: f64,
}

impl DataDip {
    /// `None` where the dip is not defined (no attitude) or the equations
    /// fail.
    fn at(pass: &Pass<'_>, x: &SVector<f64, N>, ata: &[[f64; N]; N], moments: &Moments) -> Option<Self> {
        let (dip_rad, gradient) = dip_and_gradient(x, moments)?;
        let (sigma2, inflation, formal) = dip_information(pass, ata, x, &gradient)?;
        Some(Self { dip_rad, sigma2, inflation, formal })
    }
}

/// The passes from the settled free solution `x` with the dip measurement
/// added ([`refine`]), and what it did; `None` where the equations fail.
/// Every [`Pass::at`] recomputes the residuals and weights at its own `x`,
/// so each measurement's passes are the same whichever was fitted before.
fn with_dip(pass: &mut Pass<'_>, x: SVector<f64, N>, data: &DataDip, moments: &Moments, dip: &DipMeasurement) -> Option<(SVector<f64, N>, DipShaped)> {
    let DataDip { dip_rad: data_dip_rad, sigma2, inflation, formal } = *data;
    let data_sigma_rad = (formal * inflation).max(0.0).sqrt();
    let weight = (inflation * sigma2).sqrt();
    let (x, mut ata) = passes(pass, x, |x| dip_row(x, moments, dip, weight))?;
    // The share: the dip's variance with the measurement (at the last
    // pass's weights) against the measurement's own, as inflated.
    let (dip_rad, gradient) = dip_and_gradient(&x, moments)?;
    let mut atb = SVector::<f64, N>::zeros();
    add_rows(&mut ata, &mut atb, core::slice::from_ref(&dip_row(&x, moments, dip, weight)?), 1.0);
    let variance = sigma2 * gradient.dot(&(symmetric(&ata).cholesky()?.inverse() * gradient));
    let share = (variance * inflation / (dip.sigma_rad * dip.sigma_rad)).clamp(0.0, 1.0);
    Some((x, DipShaped { dip_rad, share, inflation, data_dip_rad, data_sigma_rad }))
}

/// The robust fit from `start`; `None` when the equations do not determine
/// the unknowns or the matrix turns over. With `dip`, the world model's
/// inclination is a measurement of the fitted dip: once the passes have
/// settled without it, its weight is set against the data's formal
/// information on the dip raised by how far the data overstate it (the
/// blocks' pulls, as the attitude-aided fit's), and the passes go on with
/// its row re-linearised at each.
///
/// With `held` (the dip held at the world model's), the same fit with it
/// in `dip`'s place beside it, from the same equations and dip-free
/// passes (`None` in the pair where it fails): each answer the same to the
/// bit as with its measurement alone, the held one at the cost of its own
/// passes only.
pub fn refine(samples: &[GyroSample<f64>], cfg: &GyroConfig<f64>, field_nt: f64, start: &FieldCal<f64>, dip: Option<&DipMeasurement>, held: Option<&DipMeasurement>) -> Option<(Refined, Option<Option<Refined>>)> {
    let finite: Vec<[f64; 3]> = samples.iter().map(|s| s.raw).filter(|r| r.iter().all(|v| v.is_finite())).collect();
    let norm = Normalization::from_raw_iter(finite.iter().copied())?;
    let usable = |d: Option<&DipMeasurement>| d.filter(|d| d.sigma_rad > 0.0 && d.inclination_rad.is_finite()).copied();
    let (dip, held) = (usable(dip), held.map(|h| usable(Some(h))));
    let weighs = dip.is_some() || held.flatten().is_some();
    let eq = equations(samples, &norm, cfg, weighs);
    if eq.kinematic.len() < 4 {
        return None;
    }
    let mut pass = Pass::new(&eq);
    let (free, ata) = passes(&mut pass, unknowns_of(start, &norm, samples)?, |_| None)?;
    let moments = weighs.then(|| Moments::of(samples, &norm));
    let data = moments.as_ref().and_then(|m| DataDip::at(&pass, &free, &ata, m));
    let mut answer = |dip: Option<DipMeasurement>| -> Option<Refined> {
        let (x, shaped) = match (dip, &data, &moments) {
            (Some(dip), Some(data), Some(moments)) => with_dip(&mut pass, free, data, moments, &dip).map_or((free, None), |(x, how)| (x, Some(how))),
            _ => (free, None),
        };
        scaled(&x, shaped, &norm, &finite, field_nt)
    };
    let refined = answer(dip)?;
    let held = held.map(&mut answer);
    Some((refined, held))
}

/// The calibration of the unknowns `x` (normalised with `norm`), scaled so
/// that the `finite` readings' RMS intensity is `field_nt` (as calib-core's
/// estimate); `None` where the matrix turns over.
fn scaled(x: &SVector<f64, N>, dip: Option<DipShaped>, norm: &Normalization<f64>, finite: &[[f64; 3]], field_nt: f64) -> Option<Refined> {
    let (a, c) = matrix_and_offset(x);
    if !(a.determinant() > 0.0) {
        return None;
    }
    let rms = (finite.iter().map(|raw| (a * Vector3::from(norm.apply(*raw)) - c).norm_squared()).sum::<f64>() / finite.len() as f64).sqrt();
    if !(rms > 0.0) {
        return None;
    }
    let k = field_nt / rms;
    let b = a.try_inverse()? * c;
    Some(Refined {
        cal: FieldCal {
            bias: [0, 1, 2].map(|i| norm.centre[i] + norm.scale * b[i]),
            matrix: [0, 1, 2].map(|i| [0, 1, 2].map(|j| a[(i, j)] * k / norm.scale)),
        },
        dip,
    })
}

/// [`refine`] on a recording, with the plain gyro-aided fit's gyro bias
/// and lag (`plain`), the rates read `given_lag_s` earlier (as the plain
/// fit read them).
/// With `held`, the held fit beside it ([`refine`]).
pub fn refine_recording(rec: &crate::data::Recording, field_nt: f64, given_lag_s: f64, plain: &crate::doc::results::GyroQuality, start: &FieldCal<f64>, dip: Option<&DipMeasurement>, held: Option<&DipMeasurement>) -> Option<(Refined, Option<Option<Refined>>)> {
    let t = rec.t_s.as_ref()?;
    let rates = super::gyro::rates_at_lag(t, &rec.gyro_rad_s()?, given_lag_s);
    let step_s = crate::data::pairing::median_step_s(t)?;
    let nan = vec![f64::NAN; rec.len()];
    let (roll, pitch) = (rec.roll_deg.as_ref().unwrap_or(&nan), rec.pitch_deg.as_ref().unwrap_or(&nan));
    let samples: Vec<GyroSample<f64>> = (0..rec.len())
        .map(|i| GyroSample { t_s: t[i], raw: rec.mag[i], rate_rad_s: rates[i], roll_rad: roll[i].to_radians(), pitch_rad: pitch[i].to_radians() })
        .collect();
    let mut cfg = GyroConfig::new(1.5 * step_s);
    cfg.window_steps = ((super::gyro::WINDOW_S / step_s).round() as usize).clamp(1, calib_core::gyro::MAX_WINDOW_STEPS);
    cfg.attitude_weight = super::gyro::ATTITUDE_WEIGHT;
    cfg.gyro_bias_rad_s = plain.gyro_bias_rad_s;
    cfg.gyro_lag_s = plain.gyro_lag_s - given_lag_s;
    refine(&samples, &cfg, field_nt, start, dip, held)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compute::gyro::{fit_gyro_recording, GyroLag};
    use crate::data::Recording;

    /// A swing at ±15° / ±5° turning at 1/12 rad/s, 5 Hz, built from the
    /// kinematics; the raw field is the truth's through bias (300, −200,
    /// 100) and per-axis scale. Every 37th row the gyro's z reads 0.5
    /// rad/s too much (a glitch: each spoils the windows across it).
    fn swing_with_glitches() -> Recording {
        let mut rec = crate::compute::gyro::tests::swing_recording(0.2, 3000, 0.0, 0.0);
        for (i, gz) in rec.gz_rad_s.iter_mut().flatten().enumerate() {
            if i % 37 == 0 {
                *gz += 0.5;
            }
        }
        rec
    }

    /// The dip's gradient against central differences of the dip itself,
    /// at a calibration off the truth (measured: within 2e-9 of the largest
    /// entry).
    #[test]
    fn the_dips_gradient_is_its_derivative() {
        let rec = crate::compute::gyro::tests::swing_recording(0.2, 600, 0.0, 0.0);
        let samples: Vec<GyroSample<f64>> = (0..rec.len())
            .map(|i| GyroSample {
                t_s: rec.t_s.as_ref().unwrap()[i],
                raw: rec.mag[i],
                rate_rad_s: [0.0; 3],
                roll_rad: rec.roll_deg.as_ref().unwrap()[i].to_radians(),
                pitch_rad: rec.pitch_deg.as_ref().unwrap()[i].to_radians(),
            })
            .collect();
        let norm = Normalization::from_raw_iter(samples.iter().map(|s| s.raw)).unwrap();
        let m = Moments::of(&samples, &norm);
        let x = SVector::<f64, N>::from_column_slice(&[0.02, -0.01, 0.03, 1.1, 0.01, -0.02, 0.015, 0.95, 0.05, -0.04, 0.03, 0.7]);
        let (_, g) = dip_and_gradient(&x, &m).unwrap();
        let h = 1e-6;
        for k in 0..N {
            let (mut up, mut down) = (x, x);
            up[k] += h;
            down[k] -= h;
            let numeric = (dip_and_gradient(&up, &m).unwrap().0 - dip_and_gradient(&down, &m).unwrap().0) / (2.0 * h);
            assert!((numeric - g[k]).abs() < 1e-7 * g.amax(), "unknown {k}: {numeric} against {}", g[k]);
        }
    }

    #[test]
    fn glitches_of_the_gyro_bend_the_reweighted_fit_less_than_half_as_much_as_the_plain_one() {
        let rec = swing_with_glitches();
        let (plain, q) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Given(0.0)).unwrap();
        let robust = refine_recording(&rec, 48_000.0, 0.0, &q, &plain, None, None).unwrap().0.cal;
        // The truth (the simulation's): bias (300, −200, 100) raw.
        let err = |c: &FieldCal<f64>| (c.bias[0] - 300.0).abs().max((c.bias[1] + 200.0).abs()).max((c.bias[2] - 100.0).abs());
        eprintln!("bias error: plain {:.2} raw, reweighted {:.2} raw", err(&plain), err(&robust));
        // Measured: plain 85.9 raw, reweighted 37.3 raw.
        assert!(err(&robust) < 0.5 * err(&plain), "{} {}", err(&robust), err(&plain));
    }

    /// The held fit fitted beside the free one is the held fit fitted
    /// alone, to the bit, and the free one is unchanged by it (`auto` takes
    /// either for the other): on a swing whose dip the data do not hold at
    /// the reference's (held at 50°, away from the swing's own).
    #[test]
    fn the_held_fit_beside_the_free_one_is_the_held_fit_alone() {
        let rec = swing_with_glitches();
        let (plain, q) = fit_gyro_recording(&rec, 48_000.0, GyroLag::Given(0.0)).unwrap();
        let dip = DipMeasurement { inclination_rad: 50f64.to_radians(), sigma_rad: 1f64.to_radians() };
        let held = DipMeasurement { sigma_rad: 0.001f64.to_radians(), ..dip };
        let (free, beside) = refine_recording(&rec, 48_000.0, 0.0, &q, &plain, Some(&dip), Some(&held)).unwrap();
        let alone = refine_recording(&rec, 48_000.0, 0.0, &q, &plain, Some(&held), None).unwrap().0;
        let free_alone = refine_recording(&rec, 48_000.0, 0.0, &q, &plain, Some(&dip), None).unwrap().0;
        assert_eq!(beside, Some(Some(alone)));
        assert_eq!(free, free_alone);
        // Not the same fit twice: held, the dip moved.
        let (held_dip, free_dip) = (alone.dip.unwrap().dip_rad, free.dip.unwrap().dip_rad);
        assert!((held_dip - 50f64.to_radians()).abs() < (free_dip - 50f64.to_radians()).abs(), "{held_dip} {free_dip}");
    }
}
