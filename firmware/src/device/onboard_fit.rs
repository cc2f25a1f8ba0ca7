//! The on-board fit: a recursive field fit (sphere, axis, full) or the
//! gyro-aided one, fed the corrected samples, with its coverage and the
//! residual of its current estimate; the `FitStart` / `FitStop` /
//! `FitQuery` requests.
//!
//! The four fits answer through one interface, [`Estimator`]: the model is
//! chosen once, at [`OnboardFit::new`], and every use after that goes
//! through [`Rls::estimator`] / [`Rls::estimator_mut`].

use calib_core::cal::FieldCal;
use calib_core::fit::{AxisRls, FitError, FullRls, Model, Normalization, RecursiveFit, SphereRls};
use calib_core::gyro::{GyroConfig, GyroFit, GyroSample, MAX_WINDOW_STEPS};
use calib_core::quality::CoverageMask;
use magcal_protocol::{Coefficients, DeviceError, FitReport, OnboardModel};

use super::FitRequest;

use super::coefficients::{validate, FIELD_RANGE_NT};
use super::inputs::{fresh, Motion};
use super::Device;
use crate::acquisition::COUNTS_PER_NT;

/// The gyro-aided fit's integration window on the board, s (as the host's
/// `host_tools::compute::gyro::WINDOW_S`).
const GYRO_WINDOW_S: f32 = 0.7;

/// Samples kept for the fit's residual.
const RECENT: usize = 32;

/// What the board asks of a running fit.
trait Estimator {
    /// Absorbs a (plausible) sample at `now_ms`, with the AHRS's latest
    /// motion; `false` when the fit refuses it.
    fn absorb(&mut self, raw: [f32; 3], motion: Option<Motion>, now_ms: u32) -> bool;
    /// Samples absorbed (the gyro fit: kinematic windows).
    fn count(&self) -> u32;
    /// The current estimate for reference intensity `field_nt`.
    fn estimate(&self, field_nt: f32) -> Result<FieldCal<f32>, FitError>;
}

impl<M: Model<N>, const N: usize> Estimator for RecursiveFit<f32, M, N> {
    fn absorb(&mut self, raw: [f32; 3], _: Option<Motion>, _: u32) -> bool {
        self.push(raw)
    }
    fn count(&self) -> u32 {
        RecursiveFit::count(self)
    }
    fn estimate(&self, field_nt: f32) -> Result<FieldCal<f32>, FitError> {
        RecursiveFit::estimate(self, field_nt)
    }
}

/// The gyro-aided fit with the board time it started (its samples' times
/// count from there, so `f32` keeps millisecond resolution).
struct GyroRun {
    fit: GyroFit<f32>,
    start_ms: u32,
}

impl Estimator for GyroRun {
    fn absorb(&mut self, raw: [f32; 3], motion: Option<Motion>, now_ms: u32) -> bool {
        // Without fresh rates the sample breaks the chain of integrated
        // rotations (NaN rates are refused by the fit).
        let (rate_rad_s, roll_rad, pitch_rad) = match motion.filter(|m| fresh(m.at_ms, now_ms)) {
            Some(m) => (m.rate_rad_s, m.roll_rad, m.pitch_rad),
            None => ([f32::NAN; 3], f32::NAN, f32::NAN),
        };
        let t_s = now_ms.wrapping_sub(self.start_ms) as f32 / 1000.0;
        self.fit.push(&GyroSample { t_s, raw, rate_rad_s, roll_rad, pitch_rad })
    }
    fn count(&self) -> u32 {
        self.fit.kinematic_windows()
    }
    fn estimate(&self, field_nt: f32) -> Result<FieldCal<f32>, FitError> {
        self.fit.estimate(field_nt).map(|e| e.cal)
    }
}

/// The fit chosen at the start (no heap: one variant per model).
enum Rls {
    Sphere(SphereRls<f32>),
    Axis(AxisRls<f32>),
    Full(FullRls<f32>),
    Gyro(GyroRun),
}

impl Rls {
    fn estimator(&self) -> &dyn Estimator {
        match self {
            Rls::Sphere(r) => r,
            Rls::Axis(r) => r,
            Rls::Full(r) => r,
            Rls::Gyro(g) => g,
        }
    }

    fn estimator_mut(&mut self) -> &mut dyn Estimator {
        match self {
            Rls::Sphere(r) => r,
            Rls::Axis(r) => r,
            Rls::Full(r) => r,
            Rls::Gyro(g) => g,
        }
    }
}

/// A fit in progress (or stopped, its last state readable).
pub(super) struct OnboardFit {
    model: OnboardModel,
    field_nt: f32,
    /// The normalisation's centre, raw counts (the bias in use at the start).
    centre: [f32; 3],
    rls: Rls,
    coverage: CoverageMask,
    running: bool,
    /// The latest samples, for the residual of the current estimate.
    recent: heapless::Deque<[f32; 3], RECENT>,
    /// Samples refused as implausible.
    rejected: u32,
}

impl OnboardFit {
    /// A fit of an on-board model (the wire type holds no other). The
    /// gyro-aided fit integrates the rates of [`RequestBody::Motion`](magcal_protocol::RequestBody::Motion)
    /// between output samples (`output_rate_hz`).
    fn new(model: OnboardModel, field_nt: f32, centre: [f32; 3], output_rate_hz: u8, now_ms: u32) -> Self {
        let norm = Normalization { centre, scale: field_nt * COUNTS_PER_NT };
        let rls = match model {
            OnboardModel::Sphere => Rls::Sphere(SphereRls::new(norm)),
            OnboardModel::Axis => Rls::Axis(AxisRls::new(norm)),
            OnboardModel::Full => Rls::Full(FullRls::new(norm)),
            OnboardModel::Gyro => {
                let period_s = 1.0 / f32::from(output_rate_hz.max(1));
                let mut cfg = GyroConfig::new(3.0 * period_s);
                cfg.window_steps = ((GYRO_WINDOW_S / period_s + 0.5) as usize).clamp(1, MAX_WINDOW_STEPS);
                Rls::Gyro(GyroRun { fit: GyroFit::new(norm, cfg), start_ms: now_ms })
            }
        };
        Self { model, field_nt, centre, rls, coverage: CoverageMask::new(), running: true, recent: heapless::Deque::new(), rejected: 0 }
    }

    /// Absorbs a sample if running; refuses (`false`) one whose distance
    /// from the fit's centre is implausible for the reference field (a dead
    /// channel, a stuck feed, a magnet held against the hull) or that the
    /// fit itself refuses.
    pub(super) fn push(&mut self, raw: [f32; 3], motion: Option<Motion>, now_ms: u32) -> bool {
        let c = self.centre;
        let d = [raw[0] - c[0], raw[1] - c[1], raw[2] - c[2]];
        let r = calib_core::real::sqrt_f32(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        let expected = self.field_nt * COUNTS_PER_NT;
        if !(r > 0.5 * expected && r < 2.0 * expected && self.rls.estimator_mut().absorb(raw, motion, now_ms)) {
            self.rejected = self.rejected.saturating_add(1);
            return false;
        }
        self.coverage.add(d);
        if self.recent.is_full() {
            self.recent.pop_front();
        }
        let _ = self.recent.push_back(raw);
        true
    }

    /// Absorbing samples now.
    pub(super) fn running(&self) -> bool {
        self.running
    }

    /// RMS of |h| − F over the latest samples with the current estimate.
    fn residual_rms_nt(&self, est: &FieldCal<f32>) -> f32 {
        let (mut ss, mut n) = (0.0f32, 0u32);
        for raw in self.recent.iter() {
            let h = est.apply(*raw);
            let r = calib_core::real::sqrt_f32(h[0] * h[0] + h[1] * h[1] + h[2] * h[2]) - self.field_nt;
            ss += r * r;
            n += 1;
        }
        if n == 0 { 0.0 } else { calib_core::real::sqrt_f32(ss / n as f32) }
    }

    /// The report: progress, and the estimate (with the terms of `in_use`
    /// the fit does not estimate) when it passes the physical checks.
    fn report(&self, in_use: &Coefficients) -> FitReport {
        let fitted = self.rls.estimator().estimate(self.field_nt).ok();
        let residual_rms_nt = fitted.as_ref().map(|e| self.residual_rms_nt(e)).unwrap_or(0.0);
        let estimate = fitted
            .map(|cal| Coefficients { bias: cal.bias, matrix: cal.matrix, field_nt: self.field_nt, ..*in_use })
            .filter(|c| validate(c).is_ok());
        FitReport {
            running: self.running,
            model: Some(self.model),
            samples: self.rls.estimator().count(),
            coverage_pct: self.coverage.percent(),
            residual_rms_nt,
            estimate,
        }
    }
}

impl Device {
    fn fit_report(&self) -> FitReport {
        match &self.fit {
            None => FitReport { running: false, model: None, samples: 0, coverage_pct: 0, residual_rms_nt: 0.0, estimate: None },
            Some(f) => f.report(self.bank.coefficients()),
        }
    }

    /// The on-board fit: start, stop, query; each answers the fit's report.
    pub(super) fn handle_fit(&mut self, req: FitRequest, now_ms: u32) -> Result<FitReport, DeviceError> {
        match req {
            FitRequest::Start { model, field_nt } => {
                if !(field_nt >= FIELD_RANGE_NT.0 && field_nt <= FIELD_RANGE_NT.1) {
                    return Err(DeviceError::BadArgument);
                }
                self.fit = Some(OnboardFit::new(model, field_nt, self.bank.calibration().field.bias, self.output_rate_hz(), now_ms));
            }
            FitRequest::Stop => {
                if let Some(f) = &mut self.fit {
                    f.running = false;
                }
            }
            FitRequest::Query => {}
        }
        Ok(self.fit_report())
    }
}
