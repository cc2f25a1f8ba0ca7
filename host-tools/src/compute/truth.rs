//! Errors against a known heading and the reference field: what a
//! validation run measures. One implementation for the session (the board's
//! own headings against the simulator's truth) and the scenario harness
//! (a calibration applied to a simulated run).

use calib_core::cal::Environment;
use calib_core::heading::{wrap_pi, Tilt};

use crate::data::Recording;
use crate::doc::CalDoc;
use crate::geomag::Site;

/// An RMS error and the samples behind it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rms {
    /// The RMS (NaN with no samples), in the unit of the function that made it.
    pub rms: f64,
    /// Samples counted.
    pub samples: usize,
}

impl Rms {
    fn from_sum(sum_sq: f64, samples: usize) -> Self {
        Self { rms: if samples == 0 { f64::NAN } else { (sum_sq / samples as f64).sqrt() }, samples }
    }
}

/// RMS of the wrapped heading error over `(measured_rad, truth_deg)` pairs,
/// in degrees; pairs with a non-finite side are left out.
pub fn heading_rms_deg(pairs: impl IntoIterator<Item = (f64, f64)>) -> Rms {
    let (mut ss, mut n) = (0.0, 0);
    for (measured_rad, truth_deg) in pairs {
        let e = wrap_pi(measured_rad - truth_deg.to_radians());
        if e.is_finite() {
            ss += e * e;
            n += 1;
        }
    }
    let r = Rms::from_sum(ss, n);
    Rms { rms: r.rms.to_degrees(), ..r }
}

/// As [`heading_rms_deg`] after removing the one constant offset that fits
/// best (the circular mean of the errors), as a declination or a mounting
/// offset would: for a reference whose north is not the calibration's
/// (a lab's optical frame, a magnetic reference). Returns the RMS and the
/// offset removed, degrees.
pub fn heading_rms_after_offset_deg(pairs: impl IntoIterator<Item = (f64, f64)>) -> (Rms, f64) {
    let errors: Vec<f64> = pairs.into_iter().map(|(m, t)| wrap_pi(m - t.to_radians())).filter(|e| e.is_finite()).collect();
    let offset = errors.iter().map(|e| e.sin()).sum::<f64>().atan2(errors.iter().map(|e| e.cos()).sum::<f64>());
    let ss: f64 = errors.iter().map(|e| wrap_pi(e - offset).powi(2)).sum();
    let r = Rms::from_sum(ss, errors.len());
    (Rms { rms: r.rms.to_degrees(), ..r }, offset.to_degrees())
}

/// The true heading (rad) that a calibration gives at every row of a
/// recording (current and temperature terms from the rows' `motor_current_a`
/// and `temp_c` when the document has them, field, tilt from the rows' roll
/// and pitch, swing, declination); NaN where a column it needs is missing
/// (callers that must not skip rows check [`CalDoc::needed_columns`]).
pub fn true_headings_rad(doc: &CalDoc, rec: &Recording) -> Vec<f64> {
    let cal = doc.calibration();
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else {
        return vec![f64::NAN; rec.len()];
    };
    let envs = environments(doc, rec);
    rec.mag
        .iter()
        .zip(roll.iter().zip(pitch))
        .zip(envs)
        .map(|((m, (r, p)), env)| cal.apply_tilt_env(*m, &Tilt::new(r.to_radians(), p.to_radians()), &env).true_heading_rad)
        .collect()
}

/// The calibrated field (nT) at every row: the document's current and
/// temperature terms from the rows' `motor_current_a`/`temp_c`, then the
/// field calibration; NaN where a column the blocks need is missing.
pub fn calibrated_fields_nt(doc: &CalDoc, rec: &Recording) -> Vec<[f64; 3]> {
    let cal = doc.calibration();
    rec.mag.iter().zip(environments(doc, rec)).map(|(m, env)| cal.field.apply(cal.env.correct_raw(*m, &env))).collect()
}

/// Each row's current and temperature as the document's blocks need them:
/// the rows' columns where the document has the block (NaN where the
/// column is missing or empty), the neutral value (0 A, the reference
/// temperature) where it has not.
pub fn environments(doc: &CalDoc, rec: &Recording) -> Vec<Environment<f64>> {
    let terms = doc.env_terms();
    let col = |has: bool, c: &Option<Vec<f64>>, neutral: f64, i: usize| match (has, c) {
        (false, _) => neutral,
        (true, Some(c)) => c.get(i).copied().unwrap_or(f64::NAN),
        (true, None) => f64::NAN,
    };
    (0..rec.len())
        .map(|i| Environment {
            current_a: col(doc.current.is_some(), &rec.motor_current_a, 0.0, i),
            temp_c: col(doc.temperature.is_some(), &rec.temp_c, terms.ref_c, i),
        })
        .collect()
}

/// RMS of |h| − IGRF (nT) over `(h_nt, row)` pairs, IGRF taken at the row's
/// `lat_deg`/`lon_deg` at the site's date; rows without a position are left out.
pub fn field_rms_nt(fields: impl IntoIterator<Item = ([f64; 3], usize)>, rec: &Recording, site: &Site) -> Rms {
    field_rms_against_nt(fields.into_iter().filter_map(|(h, i)| {
        let (lat, lon) = (rec.lat_deg.as_ref()?.get(i)?, rec.lon_deg.as_ref()?.get(i)?);
        Some((h, site.field_at(*lat, *lon).ok()?.total_nt()))
    }))
}

/// RMS of `|field| − reference` over `(field_nt, reference_nt)` pairs, nT;
/// pairs with a non-finite side are left out.
pub fn field_rms_against_nt(pairs: impl IntoIterator<Item = ([f64; 3], f64)>) -> Rms {
    let (mut ss, mut n) = (0.0, 0);
    for (h, reference_nt) in pairs {
        let e = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() - reference_nt;
        if e.is_finite() {
            ss += e * e;
            n += 1;
        }
    }
    Rms::from_sum(ss, n)
}
