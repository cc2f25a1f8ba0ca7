//! Errors against a known heading and the reference field: what a
//! validation run measures. One implementation for the session (the board's
//! own headings against the simulator's truth) and the scenario harness
//! (a calibration applied to a simulated run).

use calib_core::heading::wrap_pi;

use crate::data::{CalDoc, Recording};
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
/// recording (field, tilt from the recording's roll and pitch, swing,
/// declination); NaN where a column is missing.
pub fn true_headings_rad(doc: &CalDoc, rec: &Recording) -> Vec<f64> {
    let cal = doc.calibration();
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else {
        return vec![f64::NAN; rec.len()];
    };
    rec.mag.iter().zip(roll.iter().zip(pitch)).map(|(m, (r, p))| cal.apply(*m, r.to_radians(), p.to_radians()).true_heading_rad).collect()
}

/// RMS of |h| − IGRF (nT) over `(h_nt, row)` pairs, IGRF taken at the row's
/// `lat_deg`/`lon_deg` at the site's date; rows without a position are left out.
pub fn field_rms_nt(fields: impl IntoIterator<Item = ([f64; 3], usize)>, rec: &Recording, site: &Site) -> Rms {
    let (mut ss, mut n) = (0.0, 0);
    for (h, i) in fields {
        let (Some(lat), Some(lon)) = (rec.lat_deg.as_ref().and_then(|c| c.get(i)), rec.lon_deg.as_ref().and_then(|c| c.get(i))) else { continue };
        let Ok(f) = site.field_at(*lat, *lon) else { continue };
        let e = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt() - f.total_nt();
        if e.is_finite() {
            ss += e * e;
            n += 1;
        }
    }
    Rms::from_sum(ss, n)
}
