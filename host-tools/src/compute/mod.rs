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

pub(crate) mod apply;
pub(crate) mod auto;
pub(crate) mod attitude;
pub(crate) mod backstep;
pub(crate) mod card;
pub(crate) mod chain;
pub(crate) mod compass;
pub(crate) mod dip_held;
pub(crate) mod error;
pub(crate) mod fit;
pub(crate) mod gyro;
pub(crate) mod gyro_robust;
pub(crate) mod heading_judge;
pub(crate) mod models;
pub(crate) mod ortho;
pub(crate) mod reference;
pub(crate) mod swing;
pub(crate) mod truth;
pub(crate) mod units;

pub use backstep::{backstep_recording, coverage_guidance, find_turnaround, BackstepOptions, BackstepReport, RunReference, SwingMagnitudes};
pub use error::{ComputeError, GyroError};
pub use chain::{axis_step, calibrate, gyro_step, heading_noise_deg, refine, Chain, ChainOptions, FirstStep};
pub use fit::{fit_recording, FitOptions};
pub use gyro::GyroLag;
pub use ortho::{ortho_recording, OrthoSolver};
pub use swing::{magnetic_headings, swing_recording, swing_recording_with, WaterCurrentMode, Delay};
pub use units::{check_units, units_guess};
pub use apply::{
    apply_recording, choose_inclination, choose_north, document_inclination_deg, gate_curve, robust_offset_deg, score, summarize, write_applied, Applied, ApplyError,
    ApplyOptions, ApplySummary, InclinationSource, IntegrityScore,
};
pub use attitude::attitude_samples;
pub use auto::{fit_auto, fit_auto_judged, table_text, YawJudge, FOLDS};
pub use card::{
    check_reference_column, compass_card, deviation_card, read_reference_column, CardError, DeviationCard, STEP_DEG_RANGE,
};
pub use compass::{apply_compass, swing_compass, write_compass_applied, DeclinationSource};
pub use models::{gates, ModelEntry, MODELS};
pub use reference::{check_given_field, given_disagreement, shown, world_field_for};
pub use truth::{
    calibrated_fields_nt, field_rms_against_nt, field_rms_nt, heading_rms_after_offset_deg, heading_rms_deg, true_headings_rad, Rms,
};
