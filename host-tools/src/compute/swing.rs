//! The swing (Fourier heading) fit against a reference heading, with the
//! reference's delay given or estimated.

use calib_core::heading::magnetic_heading_rad;
use calib_core::swing::{aligned_pairs, estimate_delay, fit_swing, SwingFit, SwingTerms};

use super::units::check_units;
use super::ComputeError;
use crate::data::results::SwingQuality;
use crate::data::{CalDoc, Recording};

/// How to treat the reference's delay.
#[derive(Debug, Clone, Copy)]
pub enum Delay {
    /// Known delay, seconds.
    Given(f64),
    /// Estimate it within `[0, max_s]`.
    Estimate {
        /// Upper bound of the search, seconds.
        max_s: f64,
    },
}

/// Longest gap in the magnetometer record across which a heading is
/// interpolated, seconds (at least; slower recordings allow 2.5 sample
/// intervals).
pub const MAX_INTERPOLATION_GAP_S: f64 = 1.0;

/// Reference samples taken while the heading turns faster than this are not
/// used for the Fourier terms, °/s.
pub const MAX_SWING_TURN_RATE_DEG_S: f64 = 1.0;

/// The heading's rate of turn at row `i` (central difference), °/s.
fn turn_rate_deg_s(t: &[f64], heading_rad: &[f64], i: usize) -> f64 {
    let (a, b) = (i.saturating_sub(1), (i + 1).min(t.len().saturating_sub(1)));
    match (t.get(a), t.get(b), heading_rad.get(a), heading_rad.get(b)) {
        (Some(ta), Some(tb), Some(ha), Some(hb)) if tb > ta => calib_core::heading::wrap_pi(hb - ha).abs().to_degrees() / (tb - ta),
        _ => f64::INFINITY,
    }
}

/// The interpolation gap allowed for a recording's sample spacing.
fn interpolation_gap_s(t: &[f64]) -> f64 {
    let mut dts: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).filter(|d| *d > 0.0).collect();
    dts.sort_by(f64::total_cmp);
    let median = dts.get(dts.len() / 2).copied().unwrap_or(0.0);
    MAX_INTERPOLATION_GAP_S.max(2.5 * median)
}

/// The magnetic headings (field calibration and tilt compensation, no swing)
/// of every row, NaN where a column is missing.
pub fn magnetic_headings(rec: &Recording, doc: &CalDoc) -> Result<Vec<f64>, ComputeError> {
    let roll = rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    let cal = doc.field_cal();
    Ok(rec
        .mag
        .iter()
        .zip(roll.iter().zip(pitch))
        .map(|(m, (r, p))| magnetic_heading_rad(cal.apply(*m), r.to_radians(), p.to_radians()))
        .collect())
}

/// Fits the swing correction and returns the document with it.
pub fn swing_recording(rec: &Recording, doc: &CalDoc, delay: Delay) -> Result<(CalDoc, SwingFit<f64>, f64), ComputeError> {
    let t = rec.t_s.as_ref().ok_or(ComputeError::NeedsColumn("t"))?;
    check_units(rec, doc)?;
    let reference_deg = rec.ref_heading_deg.as_ref().ok_or(ComputeError::NeedsColumn("ref_heading_deg"))?;
    let headings = magnetic_headings(rec, doc)?;
    // The swing acts on the magnetic heading: compare with the reference
    // (true) less the declination.
    let decl = doc.declination_deg.unwrap_or(0.0).to_radians();
    let reference: Vec<f64> = reference_deg.iter().map(|d| d.to_radians() - decl).collect();
    let gap = interpolation_gap_s(t);
    // The delay shows only while turning, so it is estimated on everything;
    // the Fourier terms are fitted on steady headings only — in a turn the
    // course over ground lags and slips against the heading.
    let delay_s = match delay {
        Delay::Given(s) => s,
        Delay::Estimate { max_s } => estimate_delay(t, &headings, t, &reference, max_s, 0.1, gap)?.delay_s,
    };
    let steady: Vec<f64> = reference
        .iter()
        .enumerate()
        .map(|(i, &r)| if turn_rate_deg_s(t, &headings, i) <= MAX_SWING_TURN_RATE_DEG_S { r } else { f64::NAN })
        .collect();
    let turning = reference.iter().zip(&steady).filter(|(r, s)| r.is_finite() && !s.is_finite()).count();
    let fit = fit_swing(aligned_pairs(t, &headings, t, &steady, delay_s, gap))?;
    let mut out = doc.clone();
    let s = fit.swing;
    out.swing = Some(s);
    let mut warnings: Vec<String> = Vec::new();
    if turning > 0 {
        warnings.push(format!("{turning} reference samples taken while turning faster than {MAX_SWING_TURN_RATE_DEG_S}°/s were used for the delay only"));
    }
    match fit.terms {
        SwingTerms::Full => {}
        SwingTerms::FirstHarmonic => warnings.push(format!(
            "headings visited {} of 12 compass sectors: fitted A, B, C only (D = E = 0)",
            fit.sectors.count()
        )),
        SwingTerms::ConstantOnly => warnings.push(format!(
            "headings visited {} of 12 compass sectors: fitted the constant A only",
            fit.sectors.count()
        )),
    }
    if (fit.swing.a - fit.a_only_rad).abs() > 0.05 {
        warnings.push(format!(
            "A of the full fit ({:.2}°) is far from the A-only fit ({:.2}°): the calibration or the data are suspect",
            fit.swing.a.to_degrees(),
            fit.a_only_rad.to_degrees()
        ));
    }
    out.quality.swing = Some(SwingQuality {
        terms: fit.terms,
        samples: fit.samples,
        delay_s,
        delay_estimated: matches!(delay, Delay::Estimate { .. }),
        a_only_rad: fit.a_only_rad,
        before_rms_deg: fit.before_rms_rad.to_degrees(),
        after_rms_deg: fit.residual_rms_rad.to_degrees(),
        warnings,
    });
    Ok((out, fit, delay_s))
}

