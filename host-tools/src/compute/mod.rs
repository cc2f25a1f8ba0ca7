//! The computation: calib-core's fits run on recordings, with the quality
//! reports and the gates that refuse a weak calibration. One place for each
//! step, and one [`chain`] (axis fit → back-stepping → swing fit) that the
//! session, the simulator's scenario harness, the bench and the CLI all call.
//!
//! * [`auto`]: `fit --model auto`, every allowed model judged on held-out blocks;
//! * [`models`]: the registry of field models (help, needed columns, how `auto` treats each);
//! * [`fit`]: field (ellipsoid) fits; [`attitude`]: the attitude-aided fit (no gyro, no tumble); [`units`]: the recording's units;
//! * [`backstep`]: the out-and-back refinement (the paper's and ours);
//! * [`swing`]: the Fourier heading fit against a reference heading; [`compass`]: the same for a heading-only compass;
//! * [`ortho`]: paper 001's non-orthogonality and gains;
//! * [`chain`]: the whole calibration from a swing test and a run;
//! * [`truth`]: heading and field errors against a known heading (validation);
//! * [`card`]: the deviation card, heading error by heading before and after;
//! * [`reference`]: the world model's field at the site, the independent reference a fit is judged by;
//! * [`error`]: [`ComputeError`], why a computation refused a recording.

pub mod apply;
pub mod auto;
pub mod attitude;
pub mod backstep;
pub mod card;
pub mod chain;
pub mod compass;
pub mod dip_held;
pub mod error;
pub mod fit;
pub mod gyro;
pub mod gyro_robust;
pub mod heading_judge;
pub mod models;
pub mod ortho;
pub mod reference;
pub mod swing;
pub mod truth;
pub mod units;

pub use backstep::{backstep_recording, coverage_guidance, find_turnaround, BackstepOptions, BackstepReport, RunReference, SwingMagnitudes};
pub use error::{ComputeError, GyroError};
pub use chain::{axis_step, calibrate, gyro_step, heading_noise_deg, refine, Chain, ChainOptions, FirstStep};
pub use fit::{fit_recording, FitOptions};
pub use gyro::GyroLag;
pub use ortho::{ortho_recording, OrthoSolver};
pub use swing::{magnetic_headings, swing_recording, swing_recording_with, WaterCurrentMode, Delay};
pub use units::{check_units, units_guess};
