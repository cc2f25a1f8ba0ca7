//! The attitude-aided fit ([`calib_core::attitude_fit`]) on a recording: for
//! a vehicle with an AHRS (roll, pitch) and no gyro that cannot tumble.
//! Reads `roll_deg, pitch_deg`; says which parameters the data leave weak.

use calib_core::attitude_fit::{fit_attitude_in, fit_attitude_near, scratch_len, AttitudeConfig, AttitudeEstimate, AttitudeSample};
use calib_core::cal::FieldCal;

use super::error::ComputeError;
use crate::data::intake::levelled_samples;
use crate::data::Recording;

/// A hard-iron 1σ above this fraction of the field (in raw units) is
/// reported as weakly determined (the gyro-aided fit's threshold).
const WEAK_BIAS_FRACTION: f64 = 0.005;
/// A matrix entry's 1σ above this (relative to the mean gain) is reported.
const WEAK_MATRIX_REL: f64 = 0.01;
/// A predicted heading error above this is reported, degrees.
const WEAK_HEADING_DEG: f64 = 1.0;

/// The samples of a recording for the attitude-aided fit: rows without a
/// complete reading or attitude are left out by the fit itself.
pub fn attitude_samples(rec: &Recording) -> Result<Vec<AttitudeSample<f64>>, ComputeError> {
    let roll = rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    if roll.iter().chain(pitch).filter(|v| v.is_finite()).any(|v| v.abs() > 180.0) {
        return Err(ComputeError::AttitudeNotDegrees);
    }
    Ok(levelled_samples(rec, roll, pitch, 1.0))
}

/// What the fit leaves weakly determined, in words.
pub fn weakly_determined(est: &AttitudeEstimate<f64>, field_nt: f64) -> Vec<String> {
    let mut weak = Vec::new();
    let mean_gain = (est.cal.matrix[0][0] + est.cal.matrix[1][1] + est.cal.matrix[2][2]) / 3.0;
    let radius_raw = field_nt / mean_gain.abs();
    for (k, axis) in ["x", "y", "z"].iter().enumerate() {
        let sigma = est.bias_sigma_raw[k];
        if !(sigma <= WEAK_BIAS_FRACTION * radius_raw) {
            weak.push(format!("the {axis} hard iron is weakly determined: 1σ {sigma:.1} raw units ({:.1} % of the field); more roll and pitch would tie it", 100.0 * sigma / radius_raw));
        }
    }
    for (k, name) in ["xx", "xy", "xz", "yx", "yy", "yz", "zx", "zy", "zz"].iter().enumerate() {
        let sigma = est.matrix_sigma_rel[k];
        if !(sigma <= WEAK_MATRIX_REL) {
            weak.push(format!("the matrix's {name} entry is weakly determined: 1σ {:.1} % of the mean gain", 100.0 * sigma));
        }
    }
    let predicted_deg = est.predicted_heading_rms_rad.to_degrees();
    if !(predicted_deg <= WEAK_HEADING_DEG) {
        weak.push(format!("the fit's own uncertainty predicts {predicted_deg:.2}° of heading error (1σ): turn through more headings, rolls and pitches"));
    }
    weak
}

/// Fits the attitude-aided calibration; the magnitude is scaled to
/// `field_nt`. From `near` where given (a calibration close to this
/// recording's: [`calib_core::attitude_fit::fit_attitude_near`]).
pub fn fit_attitude_recording(rec: &Recording, field_nt: f64, cfg: &AttitudeConfig<f64>, near: Option<&FieldCal<f64>>) -> Result<AttitudeEstimate<f64>, ComputeError> {
    let samples = attitude_samples(rec)?;
    let mut scratch = vec![0.0; scratch_len(samples.len())];
    Ok(match near {
        Some(near) => fit_attitude_near(&samples, field_nt, cfg, &mut scratch, near),
        None => fit_attitude_in(&samples, field_nt, cfg, &mut scratch),
    }?)
}
