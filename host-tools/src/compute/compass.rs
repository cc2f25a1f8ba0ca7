//! Heading-only compasses: paper 000's swing (A–E) fitted to a compass's
//! own heading against a reference (a true heading, or GPS course with its
//! delay and, where the speed through water is known, the water current),
//! and that swing applied — the same fit as the magnetometer's
//! ([`super::swing`]), on the compass's heading instead of one computed from
//! the field.
//!
//! The compass's rows and the reference's need not pair up (a log of NMEA
//! sentences has one row each): the compass heading is interpolated to
//! every row's time, along the shorter arc, across gaps no longer than the
//! interpolation gap of [`super::swing`].

use calib_core::heading::wrap_pi;
use calib_core::series::interp_angle;
use calib_core::swing::{heading_at, SwingFit};
use serde::{Deserialize, Serialize};

use super::error::ComputeError;
use super::swing::{fit_swing_inputs, interpolation_gap_s, Delay, SwingInputs, WaterCurrentMode};
use crate::data::compass::CompassLog;
use crate::doc::compass::CompassDoc;
use crate::doc::caldoc::DocForm;
use crate::doc::results::Quality;
use crate::data::table::col;

/// Where the declination between the compass and a true reference came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DeclinationSource {
    /// Given by the user (or the world model at the site).
    Given,
    /// The median of the log's own `variation_deg` (HDG, RMC).
    Log,
    /// None: A holds the declination, the corrected heading is true.
    InA,
}

/// The compass heading at every row of the log (interpolated where the row
/// is another sentence's), rad; NaN where the compass has no sample within
/// the interpolation gap.
pub fn compass_headings_rad(log: &CompassLog) -> Vec<f64> {
    let (ct, ch): (Vec<f64>, Vec<f64>) = log.t_s.iter().zip(&log.compass_heading_deg).filter(|(t, h)| t.is_finite() && h.is_finite()).map(|(t, h)| (*t, h.to_radians())).unzip();
    let gap = interpolation_gap_s(&ct);
    log.t_s.iter().map(|&t| interp_angle(&ct, &ch, t, gap).unwrap_or(f64::NAN)).collect()
}

/// The largest scatter (median absolute deviation) of reference − compass
/// at which the reference is taken for the compass's own heading, degrees.
/// An independent reference scatters by its own noise and the deviation
/// (GPS course: 0.3–1°; a GNSS compass: 0.1–0.3°); the compass's heading
/// plus a constant (its `HDT`), written to 0.1°, by 0.
pub const SELF_REFERENCE_SCATTER_DEG: f64 = 0.05;

/// The fewest reference samples on which [`SELF_REFERENCE_SCATTER_DEG`] is judged.
const SELF_REFERENCE_MIN_PAIRS: usize = 10;

/// Refuses a compass log that cannot be judged as it is:
/// `compass_heading_deg` in radians (every value within ±2π, spanning more
/// than 1), or a reference that is the compass's own heading plus a
/// constant (the scatter of reference − compass below
/// [`SELF_REFERENCE_SCATTER_DEG`]: e.g. the compass's own `HDT`).
pub fn check_compass_log(log: &CompassLog) -> Result<(), ComputeError> {
    let finite: Vec<f64> = log.compass_heading_deg.iter().copied().filter(|h| h.is_finite()).collect();
    let (min, max) = finite.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &h| (lo.min(h), hi.max(h)));
    let two_pi = std::f64::consts::TAU;
    if !finite.is_empty() && min >= -two_pi && max <= two_pi && max - min > 1.0 {
        return Err(ComputeError::CompassLooksLikeRadians { count: finite.len(), min, max, span: max - min });
    }
    let Some(reference) = log.ref_heading_deg.as_deref() else { return Ok(()) };
    let headings = compass_headings_rad(log);
    let diff: Vec<f64> = reference.iter().zip(&headings).filter(|(r, h)| r.is_finite() && h.is_finite()).map(|(r, h)| wrap_pi(r.to_radians() - h)).collect();
    if diff.len() < SELF_REFERENCE_MIN_PAIRS {
        return Ok(());
    }
    // About the circular mean, so that a difference near ±180° stays whole.
    let (s, c) = diff.iter().fold((0.0, 0.0), |(s, c), d| (s + d.sin(), c + d.cos()));
    let centre = s.atan2(c);
    let mut spread: Vec<f64> = diff.iter().map(|d| wrap_pi(d - centre).to_degrees()).collect();
    let median = calib_core::series::median(&mut spread.clone()).unwrap_or(0.0);
    let offset = wrap_pi(centre + median.to_radians()).to_degrees();
    let mut deviations: Vec<f64> = spread.iter_mut().map(|v| (*v - median).abs()).collect();
    let scatter = calib_core::series::median(&mut deviations).unwrap_or(f64::INFINITY);
    if scatter < SELF_REFERENCE_SCATTER_DEG {
        return Err(ComputeError::ReferenceIsTheCompass { offset_deg: offset, scatter_deg: scatter, pairs: diff.len() });
    }
    Ok(())
}

/// Fits the swing of a heading-only compass against the log's
/// `ref_heading_deg`; `declination_deg` given, or else the log's stated
/// variation, or else none (A then holds it, said in the warnings).
pub fn swing_compass(log: &CompassLog, declination_deg: Option<f64>, delay: Delay, water_current: WaterCurrentMode) -> Result<(CompassDoc, SwingFit<f64>, f64, DeclinationSource), ComputeError> {
    let reference_deg = log.ref_heading_deg.as_deref().ok_or(ComputeError::NeedsColumn(col::REF_HEADING_DEG))?;
    check_compass_log(log)?;
    let (declination, source) = match (declination_deg, log.stated_variation_deg()) {
        (Some(d), _) => (Some(d), DeclinationSource::Given),
        (None, Some(v)) => (Some(v), DeclinationSource::Log),
        (None, None) => (None, DeclinationSource::InA),
    };
    let headings = compass_headings_rad(log);
    let inputs = SwingInputs {
        t: &log.t_s,
        headings: &headings,
        reference_deg,
        declination_rad: declination.unwrap_or(0.0).to_radians(),
        speed_mps: log.speed_mps.as_deref(),
        lat_deg: log.lat_deg.as_deref(),
        lon_deg: log.lon_deg.as_deref(),
        turns_when_steady_is_short: true,
    };
    let (fit, mut quality, delay_s) = fit_swing_inputs(&inputs, delay, water_current)?;
    match source {
        DeclinationSource::Given => {}
        DeclinationSource::Log => quality.warnings.push(format!("declination {:+.2}° from the log's own variation (median)", declination.unwrap_or(0.0))),
        DeclinationSource::InA => quality.warnings.push(
            "no declination given and none in the log: A holds the declination, so the corrected heading is true, not magnetic; give the declination (or the site) to keep them apart".into(),
        ),
    }
    let doc = CompassDoc { format_version: crate::doc::caldoc::FORMAT_VERSION, form: DocForm::HeadingOnly, swing: fit.swing, declination_deg: declination, quality: Quality { swing: Some(quality), ..Quality::default() } };
    Ok((doc, fit, delay_s, source))
}

/// The reference delay a compass document was fitted with, s (0 without).
pub fn doc_delay_s(doc: &CompassDoc) -> f64 {
    doc.quality.swing.as_ref().map_or(0.0, |q| q.delay_s)
}

/// One reference sample against the compass: the reference, degrees true,
/// and the compass heading at its time less the document's delay, rad,
/// before and after the correction (both with the declination).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompassPair {
    /// Row of the reference sample.
    pub row: usize,
    /// The reference, degrees true.
    pub reference_deg: f64,
    /// The compass heading plus the declination, rad.
    pub before_rad: f64,
    /// The corrected heading, rad true.
    pub after_rad: f64,
}

/// Every reference sample of the log with the compass heading at its time
/// (less the document's delay), and the count of reference samples without
/// one (outside the compass's samples or across a gap).
pub fn compass_pairs(log: &CompassLog, doc: &CompassDoc) -> Result<(Vec<CompassPair>, usize), ComputeError> {
    let reference = log.ref_heading_deg.as_deref().ok_or(ComputeError::NeedsColumn(col::REF_HEADING_DEG))?;
    let headings = compass_headings_rad(log);
    let gap = interpolation_gap_s(&log.t_s);
    let decl = doc.declination_deg.unwrap_or(0.0).to_radians();
    let delay = doc_delay_s(doc);
    let (mut pairs, mut missing) = (Vec::new(), 0);
    for (row, &r) in reference.iter().enumerate() {
        if !r.is_finite() {
            continue;
        }
        let Some(&t) = log.t_s.get(row) else { continue };
        let Some(h) = heading_at(&log.t_s, &headings, t - delay, gap) else {
            missing += 1;
            continue;
        };
        pairs.push(CompassPair { row, reference_deg: r, before_rad: h + decl, after_rad: h + doc.swing.correction_rad(h) + decl });
    }
    Ok((pairs, missing))
}

/// What `apply` measured on a compass log against its reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CompassApplySummary {
    /// Rows of the log.
    pub rows: usize,
    /// Rows with a compass heading (and so a corrected one).
    pub corrected_rows: usize,
    /// Reference samples with a compass heading at their time.
    pub reference_pairs: usize,
    /// Reference − compass heading (with the declination), ° RMS.
    pub before_rms_deg: Option<f64>,
    /// Reference − corrected heading, ° RMS.
    pub after_rms_deg: Option<f64>,
}

/// The log's compass headings corrected (degrees true, NaN where the
/// compass has none) and the summary against the reference when the log
/// has one.
pub fn apply_compass(log: &CompassLog, doc: &CompassDoc) -> Result<(Vec<f64>, CompassApplySummary), ComputeError> {
    check_compass_log(log)?;
    let corrected: Vec<f64> = log.compass_heading_deg.iter().map(|&h| if h.is_finite() { doc.corrected_deg(h) } else { f64::NAN }).collect();
    let (pairs, _) = if log.ref_heading_deg.is_some() { compass_pairs(log, doc)? } else { (Vec::new(), 0) };
    let rms = |f: fn(&CompassPair) -> f64| -> Option<f64> {
        (!pairs.is_empty()).then(|| (pairs.iter().map(|p| wrap_pi(p.reference_deg.to_radians() - f(p)).powi(2)).sum::<f64>() / pairs.len() as f64).sqrt().to_degrees())
    };
    let summary = CompassApplySummary {
        rows: log.len(),
        corrected_rows: corrected.iter().filter(|h| h.is_finite()).count(),
        reference_pairs: pairs.len(),
        before_rms_deg: rms(|p| p.before_rad),
        after_rms_deg: rms(|p| p.after_rad),
    };
    Ok((corrected, summary))
}

/// Writes `apply`'s output for a compass log: `t`, `compass_heading_deg`,
/// `heading_deg` (corrected, true), atomically.
pub fn write_compass_applied(path: &std::path::Path, log: &CompassLog, corrected_deg: &[f64]) -> Result<(), crate::data::table::TableError> {
    let header = [col::T, col::COMPASS_HEADING_DEG, col::HEADING_DEG];
    let at = |c: &[f64], i: usize| c.get(i).copied().unwrap_or(f64::NAN);
    let rows = (0..log.len()).map(|i| vec![at(&log.t_s, i), at(&log.compass_heading_deg, i), at(corrected_deg, i)]);
    crate::data::table::write_table(path, &header, rows)
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_core::conformance::SplitMix64;

    /// A level boat's compass written from the ship's magnetism (Archibald
    /// Smith's model, not the swing's Fourier series): the body field is
    /// the soft iron `[[1 + a, b], [d, 1 + e]]` times the Earth's horizontal
    /// field in body axes, plus the permanent field `(P, Q)`; the compass
    /// reads `atan2(−y, x)` of it, with 0.3° of noise, to 0.1°. The boat
    /// runs 14 legs of 4 min, each 137° from the last (so each half of the
    /// log holds seven headings spread round the compass), turning at 3°/s
    /// between them, at 3 m/s in still water; the GPS course (1 Hz, 0.5°
    /// of noise, 1.5 s late) is the true heading. Declination +3°.
    fn boat_log(seed: u64) -> (CompassLog, f64) {
        let (h_nt, declination_deg) = (18_000.0f64, 3.0f64);
        let (a, b, d, e, p_nt, q_nt) = (-0.04, 0.03, -0.02, 0.05, 1_500.0, -2_200.0);
        let compass_of = |psi_mag: f64| {
            let (x, y) = (h_nt * psi_mag.cos(), -h_nt * psi_mag.sin());
            let (bx, by) = ((1.0 + a) * x + b * y + p_nt, d * x + (1.0 + e) * y + q_nt);
            (-by).atan2(bx)
        };
        // True heading through the legs and turns, rad.
        let legs: Vec<f64> = (0..14).map(|k| (20.0 + 137.0 * k as f64).to_radians()).collect();
        let turn_rate = 3f64.to_radians();
        let mut plan = vec![(0.0, legs[0])];
        let mut t = 0.0;
        for w in legs.windows(2) {
            t += 240.0;
            let change = wrap_pi(w[1] - w[0]);
            plan.push((t, w[0]));
            t += change.abs() / turn_rate;
            plan.push((t, w[0] + change));
        }
        let end = t + 240.0;
        plan.push((end, *legs.last().unwrap()));
        let truth = |t: f64| {
            let k = plan.windows(2).position(|w| t <= w[1].0).unwrap_or(plan.len() - 2);
            let ((t0, h0), (t1, h1)) = (plan[k], plan[k + 1]);
            h0 + (h1 - h0) * ((t - t0) / (t1 - t0).max(1e-9)).clamp(0.0, 1.0)
        };
        let mut rng = SplitMix64::new(seed);
        let mut log = CompassLog { ref_heading_deg: Some(vec![]), ..CompassLog::default() };
        // The compass at 4 Hz, the GPS at 1 Hz, each its own row.
        for k in 0..(end * 4.0) as usize {
            let t = k as f64 * 0.25;
            let psi_mag = truth(t) - declination_deg.to_radians();
            let reading = (compass_of(psi_mag).to_degrees() + 0.3 * rng.gauss()).rem_euclid(360.0);
            log.t_s.push(t);
            log.compass_heading_deg.push((reading * 10.0).round() / 10.0 % 360.0);
            log.ref_heading_deg.as_mut().unwrap().push(f64::NAN);
            if k % 4 == 0 {
                log.t_s.push(t);
                log.compass_heading_deg.push(f64::NAN);
                let course = (truth(t - 1.5).to_degrees() + 0.5 * rng.gauss()).rem_euclid(360.0);
                log.ref_heading_deg.as_mut().unwrap().push(course);
            }
        }
        (log, declination_deg)
    }

    #[test]
    fn a_boats_compass_is_swung_on_legs_and_judged_on_the_half_it_did_not_see() {
        let (log, declination_deg) = boat_log(7);
        let estimate = Delay::Estimate { min_s: -5.0, max_s: 5.0 };
        let (doc, fit, delay_s, source) = swing_compass(&log, Some(declination_deg), estimate, WaterCurrentMode::Off).unwrap();
        assert_eq!(source, DeclinationSource::Given);
        assert_eq!(fit.terms.count(), 5);
        // Measured: delay 1.41 s; 6.41° → 0.57° RMS in-sample; held out
        // 6.41° → 0.59° (the course noise 0.5°, the compass's 0.3°, and
        // what five terms leave of this ship's magnetism).
        assert!((delay_s - 1.5).abs() < 0.2, "{delay_s}");
        let q = doc.quality.swing.as_ref().unwrap();
        let h = q.held_out.expect("held out");
        assert!(h.before_rms_deg > 5.0 && h.after_rms_deg < 1.0, "{h:?}");
        // Applied to another run of the same boat: the corrected heading
        // against the course.
        let (other, _) = boat_log(8);
        let (corrected, summary) = apply_compass(&other, &doc).unwrap();
        assert_eq!(summary.corrected_rows, corrected.iter().filter(|h| h.is_finite()).count());
        let (before, after) = (summary.before_rms_deg.unwrap(), summary.after_rms_deg.unwrap());
        assert!(before > 5.0 && after < 1.0, "{before} → {after}");
        // Without the declination (none given, none in the log) A holds it:
        // the corrected heading is the same true heading.
        let (in_a, _, _, source) = swing_compass(&log, None, estimate, WaterCurrentMode::Off).unwrap();
        assert_eq!(source, DeclinationSource::InA);
        assert!(in_a.declination_deg.is_none());
        let q = in_a.quality.swing.as_ref().unwrap();
        assert!(q.warnings.iter().any(|w| w.contains("A holds the declination")), "{:?}", q.warnings);
        for c in [10.0, 100.0, 250.0] {
            let diff = wrap_pi((in_a.corrected_deg(c) - doc.corrected_deg(c)).to_radians()).to_degrees();
            assert!(diff.abs() < 0.1, "{c}: {diff}");
        }
    }

    /// The compass's own heading plus a constant as the reference, and
    /// the compass in radians: refused by name; the boat's own course (its
    /// noise 0.5°, the compass's 0.3°) is not taken for the compass.
    #[test]
    fn a_compass_is_not_judged_by_itself_nor_read_in_radians() {
        let (log, _) = boat_log(3);
        check_compass_log(&log).unwrap();
        let mut own = log.clone();
        let headings = compass_headings_rad(&log);
        own.ref_heading_deg = Some(log.ref_heading_deg.as_ref().unwrap().iter().zip(&headings).map(|(r, h)| if r.is_finite() { ((h.to_degrees() + 4.2) * 10.0).round() / 10.0 } else { f64::NAN }).collect());
        let e = swing_compass(&own, None, Delay::Given(0.0), WaterCurrentMode::Off).unwrap_err();
        assert!(matches!(e, ComputeError::ReferenceIsTheCompass { offset_deg, .. } if (offset_deg - 4.2).abs() < 0.06), "{e}");
        let mut radians = log.clone();
        radians.compass_heading_deg.iter_mut().for_each(|h| *h = h.to_radians());
        assert!(matches!(swing_compass(&radians, None, Delay::Given(0.0), WaterCurrentMode::Off), Err(ComputeError::CompassLooksLikeRadians { .. })));
    }

    #[test]
    fn a_compass_log_without_a_reference_is_refused_by_name() {
        let (mut log, _) = boat_log(1);
        log.ref_heading_deg = None;
        let e = swing_compass(&log, None, Delay::Given(0.0), WaterCurrentMode::Off).unwrap_err();
        assert!(e.to_string().contains("ref_heading_deg"), "{e}");
    }
}
