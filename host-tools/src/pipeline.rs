//! What `magcal fit`, `swing` and `ortho` do with a recording: calib-core's
//! fits, run on files, with the quality report and the gates that refuse a
//! weak calibration. The binary only parses arguments and prints.

use calib_core::cal::ModelKind;
use calib_core::fit::{fit_batch, Axis, FitError, Full, Sphere};
use calib_core::heading::magnetic_heading_rad;
use calib_core::ortho::{self, OrthoError, Triangular};
use calib_core::quality::{assess, Gates, Quality};
use calib_core::swing::{aligned_pairs, estimate_delay, fit_swing, SwingError, SwingFit, SwingTerms};
use serde_json::json;

use crate::caldoc::{CalDoc, SwingDoc};
use crate::recording::Recording;

/// Why a command on a recording failed.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
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
    #[error("give the reference field intensity with --field-nt (nT) or --lat/--lon/--date")]
    NoReference,
    /// The recording's magnitudes cannot be in the units the reference says.
    #[error("{0}")]
    Units(String),
}

impl From<FitError> for PipelineError {
    fn from(e: FitError) -> Self {
        PipelineError::Fit(e)
    }
}
impl From<SwingError> for PipelineError {
    fn from(e: SwingError) -> Self {
        PipelineError::Swing(e)
    }
}
impl From<OrthoError> for PipelineError {
    fn from(e: OrthoError) -> Self {
        PipelineError::Ortho(e)
    }
}

/// Options of a field fit.
#[derive(Debug, Clone, Copy)]
pub struct FitOptions {
    /// Which model.
    pub model: ModelKind,
    /// Reference intensity, nT.
    pub field_nt: f64,
    /// Samples at or beyond this |raw| are saturated.
    pub saturation: Option<f64>,
    /// Return coefficients even when the quality gates fail (with warnings).
    pub allow_weak: bool,
}

fn quality_json(q: &Quality<f64>, skipped_rows: usize, warnings: &[String]) -> serde_json::Value {
    json!({
        "samples": q.samples,
        "skipped_rows": skipped_rows,
        "residual_rms_nt": q.residual_rms_nt,
        "residual_rms_pct": q.residual_rms_pct,
        "residual_mean_nt": q.residual_mean_nt,
        "residual_max_nt": q.residual_max_nt,
        "coverage_pct": q.coverage_pct,
        "axis_spread": q.axis_spread,
        "warnings": warnings,
    })
}

/// Fits a field calibration to a recording.
pub fn fit_recording(rec: &Recording, opts: &FitOptions) -> Result<CalDoc, PipelineError> {
    if !(opts.field_nt > 0.0 && opts.field_nt.is_finite()) {
        return Err(PipelineError::NoReference);
    }
    let (_, samples) = rec.complete_mag();
    if samples.is_empty() {
        return Err(PipelineError::NoSamples);
    }
    calib_core::fit::check_samples(&samples, 1, opts.saturation)?;
    let fitted = match opts.model {
        ModelKind::Sphere => fit_batch::<Sphere, 4, f64>(&samples, opts.field_nt),
        ModelKind::Axis => fit_batch::<Axis, 6, f64>(&samples, opts.field_nt),
        ModelKind::Full | ModelKind::Triangular => fit_batch::<Full, 9, f64>(&samples, opts.field_nt),
    };
    let cal = fitted.map_err(|e| explain_failure(e, &samples, opts))?;
    let mut warnings = Vec::new();
    let q = assess(&cal, &samples, opts.field_nt);
    if let Err(e) = Gates::for_model(opts.model).check(&q) {
        if !opts.allow_weak {
            return Err(e.into());
        }
        warnings.push(format!("quality gate failed but --allow-weak was given: {e}"));
    }
    let skipped = rec.len() - samples.len();
    if skipped > 0 {
        warnings.push(format!("{skipped} rows without a complete mx, my, mz were skipped"));
    }
    let (kind, cal) = if opts.model == ModelKind::Triangular {
        let (tri, gain) = ortho::from_field_cal(&cal)?;
        (ModelKind::Triangular, ortho::to_field_cal(&tri, gain, cal.bias))
    } else {
        (opts.model, cal)
    };
    Ok(CalDoc::new(kind, &cal, opts.field_nt, quality_json(&q, skipped, &warnings)))
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
    if q.coverage_pct < Gates::<f64>::for_model(opts.model).min_coverage_pct {
        FitError::InsufficientCoverage { covered_pct: q.coverage_pct }
    } else {
        e
    }
}

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
/// interpolated, seconds.
pub const MAX_INTERPOLATION_GAP_S: f64 = 1.0;

/// The magnetic headings (field calibration and tilt compensation, no swing)
/// of every row, NaN where a column is missing.
pub fn magnetic_headings(rec: &Recording, doc: &CalDoc) -> Result<Vec<f64>, PipelineError> {
    let roll = rec.roll_deg.as_ref().ok_or(PipelineError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(PipelineError::NeedsColumn("pitch_deg"))?;
    let cal = doc.field_cal();
    Ok(rec
        .mag
        .iter()
        .zip(roll.iter().zip(pitch))
        .map(|(m, (r, p))| magnetic_heading_rad(cal.apply(*m), r.to_radians(), p.to_radians()))
        .collect())
}

/// Fits the swing correction and returns the document with it.
pub fn swing_recording(rec: &Recording, doc: &CalDoc, delay: Delay) -> Result<(CalDoc, SwingFit<f64>, f64), PipelineError> {
    let t = rec.t_s.as_ref().ok_or(PipelineError::NeedsColumn("t"))?;
    let reference_deg = rec.ref_heading_deg.as_ref().ok_or(PipelineError::NeedsColumn("ref_heading_deg"))?;
    let headings = magnetic_headings(rec, doc)?;
    // The swing acts on the magnetic heading: compare with the reference
    // (true) less the declination.
    let decl = doc.declination_deg.unwrap_or(0.0).to_radians();
    let reference: Vec<f64> = reference_deg.iter().map(|d| d.to_radians() - decl).collect();
    let delay_s = match delay {
        Delay::Given(s) => s,
        Delay::Estimate { max_s } => estimate_delay(t, &headings, t, &reference, max_s, 0.1, MAX_INTERPOLATION_GAP_S)?.delay_s,
    };
    let fit = fit_swing(aligned_pairs(t, &headings, t, &reference, delay_s, MAX_INTERPOLATION_GAP_S))?;
    let mut out = doc.clone();
    let s = fit.swing;
    out.swing = Some(SwingDoc { a: s.a, b: s.b, c: s.c, d: s.d, e: s.e });
    let mut warnings: Vec<String> = Vec::new();
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
    let mut quality = doc.quality.clone();
    if !quality.is_object() {
        quality = json!({});
    }
    quality["swing"] = json!({
        "terms": fit.terms.count(),
        "samples": fit.samples,
        "delay_s": delay_s,
        "delay_estimated": matches!(delay, Delay::Estimate { .. }),
        "a_only_rad": fit.a_only_rad,
        "before_rms_deg": fit.before_rms_rad.to_degrees(),
        "after_rms_deg": fit.residual_rms_rad.to_degrees(),
        "warnings": warnings,
    });
    out.quality = quality;
    Ok((out, fit, delay_s))
}

/// Which paper-001 solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OrthoSolver {
    /// The paper's pairwise-norm Levenberg–Marquardt on q1…q5.
    Pairwise,
    /// Linear fit of the metric, then upper-triangular factorisation.
    Linear,
}

/// Identifies the non-orthogonality and gains. `bias`: the hard iron to
/// remove first (`None`: estimated with a full-ellipsoid fit).
pub fn ortho_recording(rec: &Recording, solver: OrthoSolver, bias: Option<[f64; 3]>) -> Result<(Triangular<f64>, [f64; 3]), PipelineError> {
    let (_, samples) = rec.complete_mag();
    if samples.is_empty() {
        return Err(PipelineError::NoSamples);
    }
    let bias = match bias {
        Some(b) => b,
        // The bias does not depend on the reference intensity: use 1.
        None => fit_batch::<Full, 9, f64>(&samples, 1.0)?.bias,
    };
    let tri = match solver {
        OrthoSolver::Pairwise => ortho::identify_pairwise(&samples, bias)?,
        OrthoSolver::Linear => ortho::identify_linear(&samples, bias)?,
    };
    Ok((tri, bias))
}
