//! The calibration chain of paper 000, improved: the axis fit of the swing
//! test against IGRF (step 1), the back-stepping on the out-and-back run, and
//! the swing fit against the run's (delayed) GPS course. The session, the
//! simulator's scenario harness and the bench all call this; the CLI runs
//! the same steps one command at a time (`fit`, `backstep`, `swing`).

use calib_core::backstep::JointConfig;
use calib_core::cal::ModelKind;

use super::backstep::{backstep_recording, BackstepOptions, BackstepReport, RunReference, SwingMagnitudes};
use super::fit::{fit_recording, FitOptions};
use super::swing::{swing_recording_with, CurrentMode, Delay};
use super::ComputeError;
use crate::data::results::BackstepMethod;
use crate::data::{CalDoc, Recording};
use crate::geomag::Site;

/// Which fit of the swing test starts the chain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FirstStep {
    /// Paper 000's axis fit against IGRF (needs roll ±55°, pitch ±10°).
    #[default]
    Axis,
    /// The gyro-aided fit ([`calib_core::gyro`]), scaled to IGRF: for a
    /// swing test with a gyro and limited roll and pitch.
    Gyro,
}

/// How the chain runs.
#[derive(Debug, Clone, Copy)]
pub struct ChainOptions {
    /// The back-stepping solver.
    pub method: BackstepMethod,
    /// The GPS course's delay.
    pub delay: Delay,
    /// The fit of the swing test.
    pub first_step: FirstStep,
    /// The joint back-stepping's thresholds, priors and which environment
    /// terms it may estimate ([`calib_core::backstep::JointTerms`]).
    pub joint: JointConfig<f64>,
    /// Whether the swing fit removes the water current from GPS course.
    pub current: CurrentMode,
}

impl Default for ChainOptions {
    /// The axis fit; our joint back-stepping with every environment term;
    /// the GPS delay estimated within 0…5 s; the water current removed.
    fn default() -> Self {
        Self {
            method: BackstepMethod::Joint,
            delay: Delay::Estimate { max_s: 5.0 },
            first_step: FirstStep::Axis,
            joint: JointConfig::default(),
            current: CurrentMode::Auto,
        }
    }
}

/// Every calibration the chain produced.
#[derive(Debug, Clone)]
pub struct Chain {
    /// Step 1: the axis fit of the swing test, with IGRF's declination.
    pub step1: CalDoc,
    /// After the back-stepping.
    pub backstepped: CalDoc,
    /// The back-stepping's report.
    pub backstep: BackstepReport,
    /// After the swing fit: what goes to the board.
    pub final_doc: CalDoc,
    /// The GPS delay used (given or estimated), s.
    pub delay_s: f64,
}

/// Step 1: the paper's axis fit of the swing test against IGRF at the site,
/// with the site's declination.
pub fn axis_step(swing: &Recording, site: &Site) -> Result<CalDoc, ComputeError> {
    let field = site.field()?;
    let mut step1 = fit_recording(swing, &FitOptions { model: ModelKind::Axis, field_nt: field.total_nt(), saturation: None, allow_weak: false, gyro_lag_s: 0.0 })?;
    step1.declination_deg = Some(field.declination_deg());
    Ok(step1)
}

/// Step 1 with a gyro: the gyro-aided fit of the swing test, scaled to
/// IGRF's intensity at the site, with the site's declination.
pub fn gyro_step(swing: &Recording, site: &Site) -> Result<CalDoc, ComputeError> {
    let field = site.field()?;
    let mut step1 = fit_recording(swing, &FitOptions { model: ModelKind::Gyro, field_nt: field.total_nt(), saturation: None, allow_weak: false, gyro_lag_s: 0.0 })?;
    step1.declination_deg = Some(field.declination_deg());
    Ok(step1)
}

/// Steps 2 and 3 from a step-1 calibration: back-stepping on the run (with
/// the swing test's magnitudes), then the swing fit on the run.
pub fn refine(step1: CalDoc, swing: &Recording, run: &Recording, site: &Site, opts: &ChainOptions) -> Result<Chain, ComputeError> {
    let mut backstep_opts = BackstepOptions::new(RunReference::Igrf(*site));
    backstep_opts.method = opts.method;
    backstep_opts.joint = opts.joint;
    if opts.method == BackstepMethod::Joint {
        backstep_opts.swing = Some(SwingMagnitudes::from_recording(swing, site.field()?.total_nt()));
    }
    let (backstepped, backstep) = backstep_recording(run, &step1, &backstep_opts)?;
    let (final_doc, _, delay_s) = swing_recording_with(run, &backstepped, opts.delay, opts.current)?;
    Ok(Chain { step1, backstepped, backstep, final_doc, delay_s })
}

/// The whole chain: [`axis_step`] (or [`gyro_step`]) then [`refine`].
pub fn calibrate(swing: &Recording, run: &Recording, site: &Site, opts: &ChainOptions) -> Result<Chain, ComputeError> {
    let step1 = match opts.first_step {
        FirstStep::Axis => axis_step(swing, site)?,
        FirstStep::Gyro => gyro_step(swing, site)?,
    };
    refine(step1, swing, run, site, opts)
}
