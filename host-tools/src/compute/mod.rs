//! The computation: calib-core's fits run on recordings, with the quality
//! reports and the gates that refuse a weak calibration. One place for each
//! step, and one [`chain`] (axis fit → back-stepping → swing fit) that the
//! session, the simulator's scenario harness, the bench and the CLI all call.
//!
//! * [`fit`]: field (ellipsoid) fits; [`attitude`]: the attitude-aided fit (no gyro, no tumble); [`units`]: the recording's units;
//! * [`backstep`]: the out-and-back refinement (the paper's and ours);
//! * [`swing`]: the Fourier heading fit against a reference heading;
//! * [`ortho`]: paper 001's non-orthogonality and gains;
//! * [`chain`]: the whole calibration from a swing test and a run;
//! * [`truth`]: heading and field errors against a known heading (validation);
//! * [`card`]: the deviation card, heading error by heading before and after.

use calib_core::fit::FitError;
use calib_core::ortho::OrthoError;
use calib_core::swing::SwingError;

pub mod apply;
pub mod attitude;
pub mod backstep;
pub mod card;
pub mod chain;
pub mod fit;
pub mod gyro;
pub mod ortho;
pub mod swing;
pub mod truth;
pub mod units;

pub use backstep::{backstep_recording, coverage_guidance, find_turnaround, BackstepOptions, BackstepReport, RunReference, SwingMagnitudes};
pub use chain::{axis_step, calibrate, gyro_step, heading_noise_deg, refine, Chain, ChainOptions, FirstStep};
pub use fit::{fit_recording, FitOptions};
pub use ortho::{ortho_recording, OrthoSolver};
pub use swing::{magnetic_headings, swing_recording, swing_recording_with, CurrentMode, Delay};
pub use units::{check_units, units_guess};
pub use crate::data::results::BackstepMethod;

/// Why a computation on a recording failed.
#[derive(Debug, thiserror::Error)]
pub enum ComputeError {
    /// The recording has no complete magnetometer rows.
    #[error("no row has all of mx, my, mz")]
    NoSamples,
    /// A column the command needs is absent.
    #[error("the recording has no `{0}` column, which this command needs")]
    NeedsColumn(&'static str),
    /// The field fit refused the data.
    #[error("{0}")]
    Fit(FitError),
    /// The swing fit refused the data.
    #[error("{0}")]
    Swing(SwingError),
    /// The non-orthogonality identification refused the data.
    #[error("{0}")]
    Ortho(OrthoError),
    /// The reference intensity is missing or not positive.
    #[error("give the reference field intensity with --field-nt (nT) or --lat/--lon/--date")]
    NoReference,
    /// The recording's magnitudes cannot be in the units the reference says.
    #[error("{0}")]
    Units(String),
    /// The back-stepping could not run.
    #[error("{0}")]
    Backstep(String),
    /// The gyro-aided fit cannot use the recording.
    #[error("{0}")]
    Gyro(String),
    /// Too little of the sphere of field directions for the model; `advice`
    /// names the models the recording's columns allow.
    #[error("only {covered_pct}% of field directions were visited: too little of the sphere for this model (a vehicle that cannot tumble: {advice})")]
    Coverage {
        /// Percent of the direction bins visited.
        covered_pct: u8,
        /// What to do with this recording.
        advice: String,
    },
    /// The attitude-aided fit cannot use the recording.
    #[error("{0}")]
    Attitude(String),
    /// The reference field could not be computed.
    #[error("{0}")]
    Geomag(#[from] crate::geomag::GeomagError),
}

impl From<FitError> for ComputeError {
    fn from(e: FitError) -> Self {
        ComputeError::Fit(e)
    }
}
impl From<SwingError> for ComputeError {
    fn from(e: SwingError) -> Self {
        ComputeError::Swing(e)
    }
}
impl From<OrthoError> for ComputeError {
    fn from(e: OrthoError) -> Self {
        ComputeError::Ortho(e)
    }
}

