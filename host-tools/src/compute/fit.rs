//! Field (ellipsoid) fits on a recording: sphere, the paper's axis model,
//! the full ellipsoid and paper 001's triangular form, with the quality
//! gates that refuse a weak calibration.

use calib_core::attitude_fit::{AttitudeConfig, AttitudeEstimate};
use calib_core::cal::{FieldCal, ModelKind};
use calib_core::fit::{fit_batch, Axis, FitError, Full, Sphere};
use calib_core::ortho;
use calib_core::quality::{assess, Quality};

use super::gyro::GyroLag;
use super::units::units_guess;
use super::error::ComputeError;
use crate::doc::results::{FitQuality, GyroQuality, Quality as ResultsQuality};
use crate::data::Recording;
use crate::doc::CalDoc;
use crate::doc::reference::{DipConstraint, Reference, ReferenceSource, HELD_DIP_SIGMA_DEG, REFUSE_SIGMAS};

/// Options of a field fit.
#[derive(Debug, Clone)]
pub struct FitOptions {
    /// Which model.
    pub model: ModelKind,
    /// Reference intensity, nT.
    pub field_nt: f64,
    /// Samples at or beyond this |raw| are saturated.
    pub saturation: Option<f64>,
    /// Return coefficients even when the quality gates fail (with warnings).
    pub allow_weak: bool,
    /// Gyro model: the magnetometer's lag behind the gyro.
    pub gyro_lag: GyroLag,
    /// The world model's field at the site ([`Reference::world_model`]):
    /// its inclination is a measurement of the levelled fits' dip (the
    /// attitude-aided and the gyro-aided fits'), and the result is
    /// checked against it (refused beyond the allowance unless `allow_weak`).
    /// `None`: only the intensity `field_nt` is known.
    pub reference: Option<Reference>,
}

fn fit_quality(q: &Quality<f64>, skipped_rows: usize, warnings: Vec<String>, units: String) -> FitQuality {
    FitQuality {
        input_units_guess: units,
        samples: q.samples,
        skipped_rows,
        residual_rms_nt: q.residual_rms_nt,
        residual_rms_pct: q.residual_rms_pct,
        residual_mean_nt: q.residual_mean_nt,
        residual_max_nt: q.residual_max_nt,
        coverage_pct: q.coverage_pct,
        axis_spread: q.axis_spread,
        warnings,
    }
}

/// Which of a fit's checks a caller has made already or judges otherwise
/// (`fit --model auto`: the attitude columns' units once for every
/// candidate and fold, held-out data instead of the in-sample magnitude
/// gate for the models that do not rest on the magnitude).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Checks {
    /// Refuse roll and pitch that look like radians (levelling models).
    pub attitude_units: bool,
    /// Refuse an in-sample magnitude scatter above the model's gate.
    pub magnitude_gate: bool,
    /// Write the whole document. Off for a held-out fold fitted with weak
    /// results allowed, of which only the calibration and the reference's
    /// inclination are read: the in-sample quality, the gates (which could
    /// only warn) and the expected heading error are left out, and so is the
    /// reference check where the reference already gives the inclination
    /// (without one the check supplies it). Every other check, and the
    /// calibration, are the same.
    pub document: bool,
}

impl Checks {
    /// Every check: what [`fit_recording`] makes.
    pub const ALL: Checks = Checks { attitude_units: true, magnitude_gate: true, document: true };
}

/// Fits a field calibration to a recording.
pub fn fit_recording(rec: &Recording, opts: &FitOptions) -> Result<CalDoc, ComputeError> {
    fit_with(rec, opts, Checks::ALL)
}

/// [`fit_recording`] with the checks `checks` leaves on.
pub(crate) fn fit_with(rec: &Recording, opts: &FitOptions, checks: Checks) -> Result<CalDoc, ComputeError> {
    fit_with_given(rec, opts, checks, Given::default())
}

/// What a caller already has that a fit of `rec` can use instead of
/// finding it again (`fit --model auto`: each candidate's folds).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Given<'a> {
    /// For the gyro model: the plain gyro fit of `rec` with the options'
    /// field and lag ([`super::gyro::fit_gyro_recording`]'s result, which
    /// is then not asked for again).
    pub plain_gyro: Option<&'a (FieldCal<f64>, GyroQuality)>,
    /// For the gyro model with a site: the dip-held robust fit of `rec`.
    /// The free fit fills it (fitted beside its own, from the same
    /// equations); the held fit takes it when filled, else fits its own.
    pub gyro_held: Option<&'a super::gyro_robust::HeldShare>,
    /// For the attitude model with a site: the whole recording's fit that
    /// weighs the reference's dip at its σ. The free fit of `rec` fills it;
    /// the held one reads where the data alone put the dip from it when
    /// filled, else fits it again.
    pub attitude_free: Option<&'a std::sync::OnceLock<AttitudeEstimate<f64>>>,
    /// For the attitude model: a calibration near `rec`'s (the whole
    /// recording's fit, for a fold of most of its rows), where the
    /// iterations start ([`calib_core::attitude_fit::fit_attitude_near`]:
    /// the same point, fewer steps).
    pub attitude_near: Option<&'a FieldCal<f64>>,
}

/// [`fit_with`] with what the caller has already ([`Given`]).
pub(crate) fn fit_with_given(rec: &Recording, opts: &FitOptions, checks: Checks, given: Given<'_>) -> Result<CalDoc, ComputeError> {
    if !(opts.field_nt > 0.0 && opts.field_nt.is_finite()) {
        return Err(ComputeError::NoReference);
    }
    let (_, samples) = rec.complete_mag();
    if samples.is_empty() {
        return Err(ComputeError::NoSamples);
    }
    calib_core::fit::check_samples(&samples, 1, opts.saturation)?;
    if checks.attitude_units && super::models::entry(opts.model).levelled {
        crate::data::intake::check_attitude_units(rec, opts.field_nt)?;
    }
    let mut warnings = Vec::new();
    let mut gyro_quality = None;
    let mut attitude_predicted_deg = None;
    // The dip the fit itself estimated, with its 1σ, degrees.
    let mut fit_dip: Option<(f64, f64)> = None;
    // How the reference's inclination shaped the fit.
    let mut constraint: Option<DipConstraint> = None;
    // A dip held where the data alone say otherwise (why).
    let mut held_contradicted: Option<String> = None;
    // Whether that is read: not for a fold whose weak results are allowed
    // (its document is written before, [`fold_document`]).
    let judges_held = checks.document || !opts.allow_weak;
    // The world model's inclination, its 1σ and whether it is held: a
    // measurement of every levelled fit's dip, weighted against what the
    // data can tell, or held where asked.
    let world = opts.reference.as_ref().filter(|r| r.independent_inclination()).and_then(|r| Some((r.inclination_deg?, r.inclination_sigma_deg?, r.dip_held())));
    let dip_sigma_deg = |(_, s, held): (f64, f64, bool)| if held { HELD_DIP_SIGMA_DEG } else { s };
    let cal = match opts.model {
        ModelKind::Sphere => fit_batch::<Sphere, 4, f64>(&samples, opts.field_nt),
        ModelKind::Axis => fit_batch::<Axis, 6, f64>(&samples, opts.field_nt),
        ModelKind::Full | ModelKind::Triangular => fit_batch::<Full, 9, f64>(&samples, opts.field_nt),
        ModelKind::Gyro => {
            let (plain, q) = match given.plain_gyro {
                Some(given) => given.clone(),
                None => super::gyro::fit_gyro_recording(rec, opts.field_nt, opts.gyro_lag)?,
            };
            // Huber-reweighted from the plain solution, with its gyro bias
            // and lag (an estimated lag: the rates read at all of it).
            let given_lag_s = match opts.gyro_lag {
                super::gyro::GyroLag::Given(lag_s) => lag_s,
                super::gyro::GyroLag::Estimate => q.gyro_lag_s,
            };
            let measured = |sigma_deg: f64| world.map(|w| super::gyro_robust::DipMeasurement { inclination_rad: w.0.to_radians(), sigma_rad: sigma_deg.to_radians() });
            let dip = world.and_then(|w| measured(dip_sigma_deg(w)));
            let refined = match (world, given.gyro_held) {
                // The held fit, fitted already beside the free one.
                (Some((_, _, true)), Some(share)) if share.get().is_some() => share.get().copied().flatten(),
                // The free fit, with the held one beside it for its candidate.
                (Some((_, _, false)), Some(share)) => {
                    let held = measured(HELD_DIP_SIGMA_DEG);
                    super::gyro_robust::refine_recording(rec, opts.field_nt, given_lag_s, &q, &plain, dip.as_ref(), held.as_ref()).map(|(refined, held)| {
                        if let Some(held) = held {
                            let _ = share.set(held);
                        }
                        refined
                    })
                }
                _ => super::gyro_robust::refine_recording(rec, opts.field_nt, given_lag_s, &q, &plain, dip.as_ref(), None).map(|(refined, _)| refined),
            };
            let (cal, shaped) = match refined {
                Some(refined) => (refined.cal, refined.dip),
                None => (plain, None),
            };
            if let (Some((i, s, held)), Some(d)) = (world, shaped) {
                constraint = Some(DipConstraint::shaped(held, d.share, d.inflation, d.dip_rad.to_degrees(), i, s));
                held_contradicted = (held && judges_held).then(|| contradicted_by_data(i, d.data_dip_rad.to_degrees(), d.data_sigma_rad.to_degrees(), dip_bias_deg(ModelKind::Gyro, rec))).flatten();
            } else if world.is_some() {
                warnings.push("the world model's dip did not shape the gyro-aided fit (no roll and pitch to level with, or its robust refinement failed): the dip is the data's alone".to_string());
            }
            fit_dip = Some((shaped.map_or(q.inclination_deg(opts.field_nt), |d| d.dip_rad.to_degrees()), 0.0));
            warnings.extend(q.weakly_determined.iter().cloned());
            gyro_quality = Some(q);
            Ok(cal)
        }
        ModelKind::Attitude => {
            let mut cfg = AttitudeConfig::new();
            cfg.dip_prior = world.map(|w| (w.0.to_radians(), dip_sigma_deg(w).to_radians()));
            let est = super::attitude::fit_attitude_recording(rec, opts.field_nt, &cfg, given.attitude_near)?;
            if let (Some((_, _, false)), Some(cell), None) = (world, given.attitude_free, given.attitude_near) {
                let _ = cell.set(est);
            }
            // Held: where the data alone put the dip, from the fit that
            // weighs the reference at its own σ.
            if let Some((i, s, true)) = world.filter(|_| judges_held) {
                held_contradicted = attitude_data_dip(rec, opts.field_nt, i, s, given.attitude_free.and_then(|c| c.get())).and_then(|(d, sd)| contradicted_by_data(i, d, sd, dip_bias_deg(ModelKind::Attitude, rec)));
            }
            fit_dip = Some((est.dip_rad.to_degrees(), est.dip_sigma_rad.to_degrees()));
            constraint = world.map(|(i, s, held)| DipConstraint::shaped(held, est.dip_prior_share, est.dip_data_inflation, est.dip_rad.to_degrees(), i, s));
            warnings.extend(super::attitude::weakly_determined(&est, opts.field_nt));
            attitude_predicted_deg = Some(est.predicted_heading_rms_rad.to_degrees());
            Ok(est.cal)
        }
    }
    .map_err(|e| with_advice(explain_failure(e, &samples, opts), rec))?;
    if !checks.document && opts.allow_weak {
        return fold_document(cal, rec, opts, fit_dip, constraint);
    }
    let q = assess(&cal, &samples, opts.field_nt);
    let mut gates = super::models::gates(opts.model);
    if !checks.magnitude_gate && q.residual_rms_pct > gates.max_residual_pct {
        warnings.push(format!("magnitudes scatter by {:.1} % in sample: judged on held-out data instead", q.residual_rms_pct));
        gates.max_residual_pct = f64::INFINITY;
    }
    // A failed gate kept (weak results allowed) is marked in the document,
    // so every reader refuses it unless weak results are allowed there too.
    let mut allowed_weak = Vec::new();
    if let Err(e) = gates.check(&q) {
        let e = with_advice(e, rec);
        if !opts.allow_weak {
            return Err(e);
        }
        warnings.push(format!("quality gate failed, kept because weak results were allowed: {e}"));
        allowed_weak.push(format!("{} fit: quality gate failed: {e}", opts.model.name()));
    }
    if let Some(why) = held_contradicted {
        if !opts.allow_weak {
            return Err(ComputeError::Disagrees { disagreement: why });
        }
        warnings.push(format!("kept because weak results were allowed: {why}"));
        allowed_weak.push(format!("{} fit: {why}", opts.model.name()));
    }
    cal.validate(crate::doc::caldoc::MAX_BIAS_ABS).map_err(|e| ComputeError::Unusable(crate::doc::caldoc::cal_error_text(e)))?;
    let mut reference = judge_against_reference(&cal, rec, opts, fit_dip, &mut warnings)?;
    reference.constraint = constraint;
    let skipped = rec.len() - samples.len();
    if skipped > 0 {
        warnings.push(format!("{skipped} rows without a complete mx, my, mz were skipped"));
    }
    let (kind, cal) = in_model_form(cal, opts.model)?;
    // Which units the raw data look like (the fit works in any).
    let radius = opts.field_nt / ((cal.matrix[0][0].abs() + cal.matrix[1][1].abs() + cal.matrix[2][2].abs()) / 3.0);
    let units = units_guess(radius, opts.field_nt);
    let predicted_heading_rms_deg = gyro_quality.as_ref().map(|g| g.predicted_heading_rms_deg).or(attitude_predicted_deg);
    let quality = ResultsQuality { fit: Some(fit_quality(&q, skipped, warnings, units)), gyro: gyro_quality, predicted_heading_rms_deg, allowed_weak, ..Default::default() };
    let mut doc = CalDoc::new(kind, &cal, opts.field_nt, quality);
    doc.reference = Some(reference);
    doc.quality.expected_heading_rms_deg = super::apply::expected_heading_rms_deg(&doc);
    Ok(doc)
}

/// The fitted calibration in the model's form: the triangular model's
/// through paper 001's factorisation, every other as fitted.
fn in_model_form(cal: calib_core::cal::FieldCal<f64>, model: ModelKind) -> Result<(ModelKind, calib_core::cal::FieldCal<f64>), ComputeError> {
    if model == ModelKind::Triangular {
        let (tri, gain) = ortho::from_field_cal(&cal)?;
        Ok((ModelKind::Triangular, ortho::to_field_cal(&tri, gain, cal.bias)))
    } else {
        Ok((model, cal))
    }
}

/// [`fit_with_given`]'s document for a held-out fold ([`Checks::document`]
/// off): the calibration validated and in the model's form, with its
/// reference (checked only where the check must supply the inclination).
fn fold_document(cal: calib_core::cal::FieldCal<f64>, rec: &Recording, opts: &FitOptions, fit_dip: Option<(f64, f64)>, constraint: Option<DipConstraint>) -> Result<CalDoc, ComputeError> {
    cal.validate(crate::doc::caldoc::MAX_BIAS_ABS).map_err(|e| ComputeError::Unusable(crate::doc::caldoc::cal_error_text(e)))?;
    let mut reference = match &opts.reference {
        Some(r) if r.inclination_deg.is_some() => r.clone(),
        _ => judge_against_reference(&cal, rec, opts, fit_dip, &mut Vec::new())?,
    };
    reference.constraint = constraint;
    let (kind, cal) = in_model_form(cal, opts.model)?;
    let mut doc = CalDoc::new(kind, &cal, opts.field_nt, ResultsQuality::default());
    doc.reference = Some(reference);
    Ok(doc)
}

/// Why a dip held at the reference's `inclination_deg` contradicts the
/// data: they alone put it at `data_dip_deg`, and it lies beyond
/// [`REFUSE_SIGMAS`] of their own σ from it. That σ is their 1σ
/// `data_sigma_deg` (their block scatter counted) with `bias_deg`, what the
/// data's dip can be off beyond that scatter ([`dip_bias_deg`]), in
/// quadrature. A dip the data tell is theirs: a room's or a hull's real one
/// (the BROAD lab, 1.6° off IGRF-14, which the gyro-aided fit tells to
/// 0.1–0.3°), or a wrong site's world model (BROAD trial 02 with a site 12°
/// of dip away: held there, its validation heading was 12° off). Holding
/// the dip is the alternative only where the data cannot tell it.
fn contradicted_by_data(inclination_deg: f64, data_dip_deg: f64, data_sigma_deg: f64, bias_deg: f64) -> Option<String> {
    let apart = (data_dip_deg - inclination_deg).abs();
    let sigma = data_sigma_deg.hypot(bias_deg);
    let counted = if bias_deg > 0.0 { "their scatter and the tilt sensor's errors counted" } else { "their scatter counted" };
    (!(apart <= REFUSE_SIGMAS * sigma)).then(|| {
        format!(
            "the dip is held at the reference's {inclination_deg:.2}°, where the data alone put it at {data_dip_deg:.2}° ± {sigma:.2}° (1σ, {counted}): {:.1}σ apart, so holding it contradicts them",
            apart / sigma
        )
    })
}

/// What a levelled fit's data-alone dip can be off beyond its scatter,
/// degrees.
/// - Infinite where the recording's tilt does not vary beyond its sensor's
///   noise ([`tilt_variance_deg2`] at most twice [`tilt_noise_deg2`]): the
///   data tell the vertical scale and hard iron from the dip only through
///   how the tilt varies, and a regression on a tilt whose variation is
///   mostly noise is diluted by half or more, so their dip is biased
///   beyond any scatter (a simulated ±0.2° swing: 43° off, at 1.3° of
///   scatter).
/// - The attitude-aided fit, which levels every reading with the tilt
///   sensor's roll and pitch and fits the calibration to the levelled
///   field, takes the sensor's errors into its dip:
///   [`ATTITUDE_DIP_FLOOR_DEG`]. (On BROAD's five trials in one lab its
///   data-alone dip spreads over 68.8–71.8°, the gyro-aided fit's over
///   68.7–70.0°, each at ±0.1–0.3° of its own; a glider at sea puts it
///   0.3–1.7° from IGRF at ±0.2°.)
/// - Otherwise 0: the data's own scatter says it. (The gyro-aided fit
///   calibrates from the rotation the gyro sees and only measures the dip
///   with the tilt; a wrong site must be refused on BROAD, where its data
///   alone put the dip 0.7–2.0° from IGRF at ±0.1–0.3°, and held at IGRF's
///   it headed worse on every trial.)
fn dip_bias_deg(model: ModelKind, rec: &Recording) -> f64 {
    if !(tilt_variance_deg2(rec) > 2.0 * tilt_noise_deg2(rec)) {
        return f64::INFINITY;
    }
    if model == ModelKind::Attitude { ATTITUDE_DIP_FLOOR_DEG } else { 0.0 }
}

/// [`dip_bias_deg`]'s floor for the attitude-aided fit, degrees. Chosen
/// leave-one-dataset-out over BROAD trials 02, 03, 05, 06, 09 (with the
/// lab's site and with one 12° of dip away), Seaglider SG236 and SG180
/// (each calibrated on its first dives and on its last, with its site and
/// with one 14° of dip away) and simulated swings of ±0.5° to ±10° roll
/// (their site and one 12° of dip away): the held fit must stay eligible
/// where it heads (a glider: levels) better than the free one, and be
/// refused at every wrong site. That leaves 1.25–3.28°: BROAD 02 with the
/// lab's site (the data alone 3.9° from IGRF's at ±0.32°; held 2.98° on the
/// validation part, free 4.19°) below, a ±0.5° swing at a wrong site (9.9°
/// at ±0.26°; held 4.15° by true heading, free 0.72°) above. 2° is its
/// middle; each fold's middle keeps its left-out dataset on the right side.
/// Without the floor a glider whose dives cannot tell the dip (SG236 dives
/// 4–5: 1.7° from IGRF's at ±0.19°) loses its held fit (0.66° of dip
/// scatter on the other dives, the free fit 0.96°). Where the held fit
/// heads worse at the right site (BROAD 03, 06, 09 with the lab's: 0.8–1.9°
/// apart) it stays eligible, and the held-out judge chooses.
const ATTITUDE_DIP_FLOOR_DEG: f64 = 2.0;

/// The variance of roll plus that of pitch over the rows that have both,
/// degrees² (NaN without two such rows).
fn tilt_variance_deg2(rec: &Recording) -> f64 {
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else { return f64::NAN };
    let rows = || roll.iter().zip(pitch).filter(|(r, p)| r.is_finite() && p.is_finite());
    let n = rows().count() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (mr, mp) = rows().fold((0.0, 0.0), |(a, b), (r, p)| (a + r / n, b + p / n));
    rows().map(|(r, p)| (r - mr) * (r - mr) + (p - mp) * (p - mp)).sum::<f64>() / n
}

/// The tilt sensor's white-noise variance, roll plus pitch, degrees²:
/// from the median of successive rows' squared differences (a row's roll
/// and pitch differences are each twice the noise's variance, their
/// squares' sum over it χ² with two degrees of freedom, median `2 ln 2`),
/// robust to the jumps where a recording was cut. Real motion between rows
/// counts as noise: a slowly sampled recording's is overstated. NaN
/// without two rows.
fn tilt_noise_deg2(rec: &Recording) -> f64 {
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else { return f64::NAN };
    let rows: Vec<(f64, f64)> = roll.iter().zip(pitch).filter(|(r, p)| r.is_finite() && p.is_finite()).map(|(r, p)| (*r, *p)).collect();
    let mut d: Vec<f64> = rows.windows(2).map(|w| (w[1].0 - w[0].0).powi(2) + (w[1].1 - w[0].1).powi(2)).collect();
    if d.is_empty() {
        return f64::NAN;
    }
    let mid = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    *median / (2.0 * std::f64::consts::LN_2)
}

/// Where the attitude-aided fit's data alone put the dip and its 1σ (their
/// block scatter counted), degrees: the fit that weighs the reference's
/// inclination `inclination_deg` at its σ `sigma_deg`, less the share the
/// reference set ([`calib_core::attitude_fit::world::data_alone_dip`]).
/// `None` where that fit fails or the reference set all of the dip: the
/// data cannot tell it. `weighed`: that fit, where the caller has it.
fn attitude_data_dip(rec: &Recording, field_nt: f64, inclination_deg: f64, sigma_deg: f64, weighed: Option<&AttitudeEstimate<f64>>) -> Option<(f64, f64)> {
    let est = match weighed {
        Some(est) => *est,
        None => {
            let mut cfg = AttitudeConfig::new();
            cfg.dip_prior = Some((inclination_deg.to_radians(), sigma_deg.to_radians()));
            super::attitude::fit_attitude_recording(rec, field_nt, &cfg, None).ok()?
        }
    };
    let (dip, sigma) = calib_core::attitude_fit::world::data_alone_dip(&est, inclination_deg.to_radians())?;
    Some((dip.to_degrees(), sigma.to_degrees()))
}

/// The reference the fit is judged against and written with: the world
/// model's at the site when given (a disagreement beyond the allowance
/// refuses the fit, or with `allow_weak` is kept as a warning and in the
/// document), else the user's intensity with the dip the calibrated
/// recording shows (the monitor's reference for later recordings).
fn judge_against_reference(cal: &calib_core::cal::FieldCal<f64>, rec: &Recording, opts: &FitOptions, fit_dip: Option<(f64, f64)>, warnings: &mut Vec<String>) -> Result<Reference, ComputeError> {
    let mut reference = match &opts.reference {
        Some(r) => r.clone(),
        None => Reference::user_intensity(opts.field_nt),
    };
    let check = reference.check_calibration(cal, rec, fit_dip);
    if !check.agrees {
        if !opts.allow_weak {
            return Err(ComputeError::Disagrees { disagreement: check.disagreement });
        }
        warnings.push(format!("kept because weak results were allowed: {}", check.disagreement));
    }
    if reference.inclination_deg.is_none() {
        if let Some(dip) = check.inclination_deg {
            reference.source = ReferenceSource::CalibrationData;
            reference.inclination_deg = Some(dip);
            reference.inclination_sigma_deg = Some(fit_dip.map_or(0.0, |d| d.1).max(MIN_DATA_DIP_SIGMA_DEG));
        }
    }
    Ok(reference)
}

/// The smallest 1σ given to a dip estimated from the calibration recording,
/// degrees (the fits' covariances go far below what a later recording can hold to).
const MIN_DATA_DIP_SIGMA_DEG: f64 = 0.1;

/// A coverage refusal names the models that do not rest on coverage and
/// that the recording's columns allow: the attitude-aided one when it has
/// roll and pitch, the gyro-aided one when it has the gyro.
fn with_advice(e: FitError, rec: &Recording) -> ComputeError {
    let FitError::InsufficientCoverage { covered_pct } = e else { return e.into() };
    let attitude = rec.roll_deg.is_some() && rec.pitch_deg.is_some();
    let gyro = rec.gyro_rad_s().is_some();
    let advice = match (attitude, gyro) {
        (true, true) => "use the attitude-aided model (`attitude`: roll_deg, pitch_deg) or the gyro-aided model (`gyro`: gx, gy, gz)",
        (true, false) => "use the attitude-aided model (`attitude`), which needs only the roll_deg, pitch_deg this recording has",
        (false, true) => "use the gyro-aided model (`gyro`), with the gx, gy, gz this recording has",
        (false, false) => "record the AHRS roll and pitch (roll_deg, pitch_deg) and use the attitude-aided model (`attitude`)",
    };
    ComputeError::Coverage { covered_pct, advice }
}

/// When a model cannot be fitted, the usual cause is data that visit too
/// little of the sphere; say so when the directions around a sphere fit's
/// centre show it, since that tells the operator what to do.
fn explain_failure(e: FitError, samples: &[[f64; 3]], opts: &FitOptions) -> FitError {
    if matches!(e, FitError::TooFewSamples { .. } | FitError::NonFinite { .. } | FitError::Saturated { .. } | FitError::BadReference) {
        return e;
    }
    let Ok(sphere) = fit_batch::<Sphere, 4, f64>(samples, opts.field_nt) else {
        return e;
    };
    let q = assess(&sphere, samples, opts.field_nt);
    if q.coverage_pct < super::models::entry(opts.model).min_coverage_pct {
        FitError::InsufficientCoverage { covered_pct: q.coverage_pct }
    } else {
        e
    }
}

#[cfg(test)]
mod held_dip_tests {
    use super::{contradicted_by_data, dip_bias_deg, tilt_noise_deg2, tilt_variance_deg2};
    use crate::data::Recording;
    use calib_core::cal::ModelKind;

    /// BROAD trial 02 with the lab's site (IGRF-14 67.94°): the data alone
    /// 69.73° ± 0.30°, 6σ of their own from IGRF's; with a wrong site
    /// (56.10°), 46σ: holding either contradicts them. Data whose σ takes
    /// the held dip within 3σ: nothing to say.
    #[test]
    fn a_held_dip_is_refused_where_the_data_alone_put_it_elsewhere() {
        let why = contradicted_by_data(67.94, 69.73, 0.30, 0.0).expect("contradicted");
        assert!(why.contains("6.0σ apart") && why.contains("69.73°") && why.contains("67.94°") && why.contains("their scatter counted"), "{why}");
        assert!(contradicted_by_data(56.10, 69.73, 0.30, 0.0).is_some());
        assert!(contradicted_by_data(67.94, 68.50, 0.30, 0.0).is_none());
        assert!(contradicted_by_data(56.10, 50.71, 2.0, 0.0).is_none());
        assert!(contradicted_by_data(56.10, f64::NAN, 2.0, 0.0).is_some());
    }

    /// What the data's dip can be off beyond its scatter joins it in
    /// quadrature. SG236 dives 4–5 with its site (IGRF-14 67.82°): the
    /// data alone 69.56° ± 0.19°, 9σ of their own, but within 3 ×
    /// √(0.19² + 2²) = 6.03° once the tilt sensor's 2° are counted; with a
    /// site of 53.68°, 15.63° apart is 15.63/2.009 = 7.8σ. Data that
    /// cannot tell the dip (an infinite bias) contradict nothing.
    #[test]
    fn the_data_dips_bias_widens_what_contradicts_a_held_dip() {
        assert!(contradicted_by_data(67.82, 69.56, 0.19, 0.0).is_some());
        assert!(contradicted_by_data(67.82, 69.56, 0.19, 2.0).is_none());
        let why = contradicted_by_data(53.68, 69.31, 0.23, 2.0).expect("contradicted");
        assert!(why.contains("7.8σ apart") && why.contains("± 2.01°") && why.contains("the tilt sensor's errors counted"), "{why}");
        assert!(contradicted_by_data(56.10, 13.24, 1.26, f64::INFINITY).is_none());
    }

    fn tilts(roll_deg: Vec<f64>, pitch_deg: Vec<f64>) -> Recording {
        Recording { roll_deg: Some(roll_deg), pitch_deg: Some(pitch_deg), ..Recording::default() }
    }

    /// By hand. Roll 0, 1, 2, 3, 4 (pitch 0): variance (4 + 1 + 0 + 1 + 4)/5
    /// = 2; every step 1, so the noise is 1/(2 ln 2) = 0.721: the tilt
    /// varies beyond its noise, and the bias is the model's floor (the
    /// gyro-aided fit's 0, the attitude-aided fit's 2°). Roll alternating
    /// ±1: variance 1, every step 2, noise 4/(2 ln 2) = 2.885: all noise,
    /// the data cannot tell the dip. A NaN row is skipped; no tilt: NaN.
    #[test]
    fn the_bias_is_infinite_where_the_tilt_varies_no_more_than_its_noise() {
        let ramp = tilts(vec![0.0, 1.0, f64::NAN, 2.0, 3.0, 4.0], vec![0.0; 6]);
        assert!((tilt_variance_deg2(&ramp) - 2.0).abs() < 1e-12);
        assert!((tilt_noise_deg2(&ramp) - 1.0 / (2.0 * std::f64::consts::LN_2)).abs() < 1e-12);
        assert_eq!(dip_bias_deg(ModelKind::Gyro, &ramp), 0.0);
        assert_eq!(dip_bias_deg(ModelKind::Attitude, &ramp), 2.0);
        let noise = tilts(vec![1.0, -1.0, 1.0, -1.0], vec![0.0; 4]);
        assert!((tilt_variance_deg2(&noise) - 1.0).abs() < 1e-12);
        assert!((tilt_noise_deg2(&noise) - 4.0 / (2.0 * std::f64::consts::LN_2)).abs() < 1e-12);
        assert_eq!(dip_bias_deg(ModelKind::Gyro, &noise), f64::INFINITY);
        assert_eq!(dip_bias_deg(ModelKind::Attitude, &Recording::default()), f64::INFINITY);
    }
}
