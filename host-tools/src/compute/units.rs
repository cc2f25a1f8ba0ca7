//! The units of a recording: guessed against the reference field, and
//! checked against a calibration's (µT against nT, gauss, another sensor's
//! counts are refused, not fitted).

use super::error::ComputeError;
use crate::data::Recording;
use crate::doc::CalDoc;

/// What units raw magnitudes of radius `radius_raw` suggest for a field of
/// `field_nt` (a hint recorded in the quality report).
pub fn units_guess(radius_raw: f64, field_nt: f64) -> String {
    let ratio = field_nt / radius_raw;
    let near = |k: f64| ratio > 0.7 * k && ratio < 1.4 * k;
    if near(1.0) {
        "nT".into()
    } else if near(1e3) {
        "µT".into()
    } else if near(1e5) {
        "gauss".into()
    } else {
        format!("counts (≈ {:.4} nT per unit)", ratio)
    }
}

/// The median of the finite values ([`calib_core::series::median`]), or NaN
/// when there are none (the caller turns that into `NoSamples`).
fn median_or_nan(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    calib_core::series::median(&mut v).unwrap_or(f64::NAN)
}

/// Refuses a recording whose magnitudes, through the calibration, are far
/// from the calibration's field: the units of the recording and of the
/// calibration differ (µT against nT, gauss, another sensor's counts).
pub fn check_units(rec: &Recording, doc: &CalDoc) -> Result<(), ComputeError> {
    let cal = doc.field_cal();
    let m = median_or_nan(rec.mag.iter().map(|r| {
        let h = cal.apply(*r);
        (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()
    }).collect());
    if !m.is_finite() {
        return Err(ComputeError::NoSamples);
    }
    if (m / doc.field_nt - 1.0).abs() > 0.25 {
        let raw_r = median_or_nan(rec.mag.iter().map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()).collect());
        return Err(ComputeError::Units { through_cal_nt: m, cal_field_nt: doc.field_nt, raw_magnitude: raw_r, raw_units_guess: units_guess(raw_r, doc.field_nt) });
    }
    Ok(())
}

