//! Why a computation on a recording failed: one typed error for the
//! compute module, carrying the numbers behind each refusal. The messages
//! say what is wrong with the data; the command line adds which of its
//! options would fix it (the library knows no flags).

use calib_core::backstep::BackstepError;
use calib_core::fit::FitError;
use calib_core::ortho::OrthoError;
use calib_core::swing::SwingError;

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
    #[error("no reference field intensity (it must be a positive number of nT)")]
    NoReference,
    /// The recording's magnitudes cannot be in the units the calibration says.
    #[error(
        "through this calibration the recording's field is {through_cal_nt:.0} nT, not the calibration's {cal_field_nt:.0} nT: the recording and the calibration are in different units (the raw magnitudes, ≈ {raw_magnitude:.4}, look like {raw_units_guess})"
    )]
    Units {
        /// The recording's median magnitude through the calibration, nT.
        through_cal_nt: f64,
        /// The calibration's reference field, nT.
        cal_field_nt: f64,
        /// The recording's median raw magnitude, raw units.
        raw_magnitude: f64,
        /// What units those raw magnitudes look like.
        raw_units_guess: String,
    },
    /// No turnaround was found in the run (and none was given).
    #[error("no turnaround found (no 180° change of heading)")]
    NoTurnaround,
    /// The paper's back-stepping was asked of a calibration that is not the axis model.
    #[error("the paper's back-stepping corrects the axis model, and this calibration ({model}) is not one")]
    PaperNeedsAxis {
        /// The calibration's model.
        model: &'static str,
    },
    /// The thrust test has no motor current.
    #[error("the thrust test has no motor_current_a: it cannot show the thrusters' field")]
    ThrustTestNoCurrent,
    /// The back-stepping could not run.
    #[error("{0}")]
    Backstep(BackstepError),
    /// The gyro-aided fit cannot use the recording.
    #[error(transparent)]
    Gyro(#[from] GyroError),
    /// Too little of the sphere of field directions for the model; `advice`
    /// names the models the recording's columns allow.
    #[error("only {covered_pct}% of field directions were visited: too little of the sphere for this model (a vehicle that cannot tumble: {advice})")]
    Coverage {
        /// Percent of the direction bins visited.
        covered_pct: u8,
        /// What to do with this recording.
        advice: &'static str,
    },
    /// The calibrated field disagrees with the independent reference (the
    /// world model at the site) beyond its allowance.
    #[error("the calibration disagrees with the reference field: {disagreement}")]
    Disagrees {
        /// The numbers, in words.
        disagreement: String,
    },
    /// `fit --model auto`: no candidate was accepted with a held-out error
    /// below the limit.
    #[error("no model fits this recording with a held-out error below {limit_deg}° ({table})")]
    NoModel {
        /// The limit no candidate's held-out error was below, degrees.
        limit_deg: f64,
        /// Every candidate and why it was not kept.
        table: String,
    },
    /// `fit --model auto`: candidates were judged, but none has both its
    /// held-out error and its own expected error below the limit.
    #[error("no model is kept: {why} (--allow-weak keeps it; every candidate: {table})")]
    NoModelQualifies {
        /// The best candidate's numbers and the limit, in words.
        why: String,
        /// Every candidate and why it was not kept.
        table: String,
    },
    /// The attitude-aided fit's roll or pitch is beyond 180: not degrees.
    #[error("roll_deg or pitch_deg exceeds 180: the attitude columns must be in degrees")]
    AttitudeNotDegrees,
    /// The fitted coefficients are no sensor's (refused before any document).
    #[error("the fitted coefficients are unusable: {0}")]
    Unusable(&'static str),
    /// `roll_deg`, `pitch_deg` hold radians.
    #[error(transparent)]
    AnglesLookLikeRadians(#[from] crate::data::intake::AnglesLookLikeRadians),
    /// A compass log's reference is the compass's own heading (plus a
    /// constant): it cannot judge the compass.
    #[error(
        "ref_heading_deg is the compass's own heading: it differs from compass_heading_deg by {offset_deg:+.2}° with a scatter of {scatter_deg:.3}° (median absolute deviation over {pairs} samples), where an independent reference scatters by tenths of a degree at least; a compass cannot be judged by itself — the reference must be another instrument (a GNSS compass, a gyrocompass) or the GPS course"
    )]
    ReferenceIsTheCompass {
        /// The median of reference − compass, degrees.
        offset_deg: f64,
        /// Its median absolute deviation, degrees.
        scatter_deg: f64,
        /// The samples compared.
        pairs: usize,
    },
    /// A compass log's heading column holds radians.
    #[error("compass_heading_deg looks like radians: all {count} values lie within ±2π ({min:.3} to {max:.3}) yet span {span:.2}, where a compass swung in degrees goes round to 360; the column must be in degrees")]
    CompassLooksLikeRadians {
        /// The values looked at.
        count: usize,
        /// The smallest.
        min: f64,
        /// The largest.
        max: f64,
        /// max − min.
        span: f64,
    },
    /// The reference field could not be computed.
    #[error("{0}")]
    Geomag(#[from] crate::geomag::GeomagError),
}

/// Why the gyro-aided fit cannot use a recording.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum GyroError {
    /// The `t` column does not advance.
    #[error("the `t` column does not advance: no rotation can be integrated")]
    TimeNotAdvancing,
    /// No lag on the search grid lets the fit run.
    #[error("no lag within ±{max_lag_s} s lets the gyro-aided fit run")]
    NoLag {
        /// The search's half-width, s.
        max_lag_s: f64,
    },
    /// The lag given is not within ±1 s.
    #[error("a gyro lag of {lag_s} s: expected a lag within ±1 s")]
    LagOutOfRange {
        /// The lag given, s.
        lag_s: f64,
    },
    /// The rates are too large to be in rad/s.
    #[error("gx, gy, gz exceed {max_rad_s} rad/s (2 000°/s): the gyro columns must be in rad/s")]
    NotRadPerS {
        /// The largest rate a MEMS gyro measures, rad/s.
        max_rad_s: f64,
    },
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
impl From<BackstepError> for ComputeError {
    fn from(e: BackstepError) -> Self {
        ComputeError::Backstep(e)
    }
}
