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
    /// The back-stepping could not run.
    #[error("{0}")]
    Backstep(String),
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

fn quality_json(q: &Quality<f64>, skipped_rows: usize, warnings: &[String], units: &str) -> serde_json::Value {
    json!({
        "input_units_guess": units,
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
    // Which units the raw data look like (the fit works in any).
    let radius = opts.field_nt / ((cal.matrix[0][0].abs() + cal.matrix[1][1].abs() + cal.matrix[2][2].abs()) / 3.0);
    let units = units_guess(radius, opts.field_nt);
    Ok(CalDoc::new(kind, &cal, opts.field_nt, quality_json(&q, skipped, &warnings, &units)))
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

/// The median of a slice (NaN-free), or NaN when empty.
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Refuses a recording whose magnitudes, through the calibration, are far
/// from the calibration's field: the units of the recording and of the
/// calibration differ (µT against nT, gauss, another sensor's counts).
pub fn check_units(rec: &Recording, doc: &CalDoc) -> Result<(), PipelineError> {
    let cal = doc.field_cal();
    let m = median(rec.mag.iter().map(|r| {
        let h = cal.apply(*r);
        (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt()
    }).collect());
    if !m.is_finite() {
        return Err(PipelineError::NoSamples);
    }
    if (m / doc.field_nt - 1.0).abs() > 0.25 {
        let raw_r = median(rec.mag.iter().map(|r| (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt()).collect());
        return Err(PipelineError::Units(format!(
            "through this calibration the recording's field is {m:.0} nT, not the calibration's {:.0} nT: the recording and the calibration are in different units (the raw magnitudes, ≈ {raw_r:.4}, look like {})",
            doc.field_nt,
            units_guess(raw_r, doc.field_nt)
        )));
    }
    Ok(())
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
    check_units(rec, doc)?;
    let reference_deg = rec.ref_heading_deg.as_ref().ok_or(PipelineError::NeedsColumn("ref_heading_deg"))?;
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
    out.swing = Some(SwingDoc { a: s.a, b: s.b, c: s.c, d: s.d, e: s.e });
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

/// Which back-stepping solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BackstepMethod {
    /// Paper 000's corrections (axis model only).
    Paper,
    /// Our joint least-squares refinement (the default).
    Joint,
}

/// The reference field for the run.
#[derive(Debug, Clone, Copy)]
pub enum RunReference {
    /// IGRF-14 at each row's `lat_deg`/`lon_deg` (or at `lat/lon` where a
    /// row has none), at decimal year `year`.
    Igrf {
        /// Fallback latitude, degrees.
        lat_deg: f64,
        /// Fallback longitude, degrees.
        lon_deg: f64,
        /// Decimal year.
        year: f64,
    },
    /// Fixed horizontal and down components, nT.
    Given {
        /// Horizontal intensity, nT.
        h_nt: f64,
        /// Down component, nT.
        z_nt: f64,
    },
}

/// Options of the back-stepping command.
#[derive(Debug, Clone)]
pub struct BackstepOptions {
    /// Solver.
    pub method: BackstepMethod,
    /// Reference field.
    pub reference: RunReference,
    /// Time of the turnaround, seconds (`None`: found from the headings).
    pub turnaround_s: Option<f64>,
    /// Length of the windows either side of the turnaround, seconds.
    pub window_s: f64,
    /// Time skipped either side of the turnaround (the turn itself), seconds.
    pub exclude_s: f64,
    /// Swing-test samples (thrusters off) and their reference intensity, for the joint solver.
    pub swing: Option<(Vec<[f64; 3]>, f64)>,
    /// Paper: most iterations.
    pub max_iterations: u8,
}

impl BackstepOptions {
    /// Defaults: joint solver, turnaround found automatically, 300 s windows,
    /// 60 s skipped either side of the turn.
    pub fn new(reference: RunReference) -> Self {
        Self { method: BackstepMethod::Joint, reference, turnaround_s: None, window_s: 300.0, exclude_s: 60.0, swing: None, max_iterations: 10 }
    }
}

/// What the back-stepping found.
#[derive(Debug, Clone)]
pub struct BackstepReport {
    /// The turnaround time used, seconds.
    pub turnaround_s: f64,
    /// Run statistics with the input calibration.
    pub before: calib_core::backstep::RunStats<f64>,
    /// And with the result.
    pub after: calib_core::backstep::RunStats<f64>,
}

/// Finds the turnaround: the time where the mean heading of the `window_s`
/// before and after differ most (and by more than 90°).
pub fn find_turnaround(t: &[f64], heading_rad: &[f64], window_s: f64) -> Option<f64> {
    let n = t.len().min(heading_rad.len());
    let (mut ps, mut pc) = (vec![0.0; n + 1], vec![0.0; n + 1]);
    for i in 0..n {
        let (s, c) = if heading_rad[i].is_finite() { heading_rad[i].sin_cos() } else { (0.0, 0.0) };
        ps[i + 1] = ps[i] + s;
        pc[i + 1] = pc[i] + c;
    }
    let mut best = (0.0, None);
    for i in 0..n {
        let lo = t.partition_point(|&x| x < t[i] - window_s);
        let hi = t.partition_point(|&x| x <= t[i] + window_s);
        if i - lo < 10 || hi - i < 10 || t[i] - t[lo] < 0.9 * window_s || t[hi - 1] - t[i] < 0.9 * window_s {
            continue;
        }
        let before = (ps[i] - ps[lo]).atan2(pc[i] - pc[lo]);
        let after = (ps[hi] - ps[i]).atan2(pc[hi] - pc[i]);
        let d = calib_core::heading::wrap_pi(after - before).abs();
        if d > best.0 {
            best = (d, Some(t[i]));
        }
    }
    (best.0 > std::f64::consts::FRAC_PI_2).then_some(best.1).flatten()
}

fn backstep_trace_json(e: &calib_core::backstep::TraceEntry<f64>) -> serde_json::Value {
    const NAMES: [&str; 4] = ["start", "horizontal scale (Hh ratio)", "sz for no step", "bz from magnitude"];
    let name = NAMES[usize::from(e.correction.min(3))];
    json!({
        "iteration": e.iteration,
        "correction": name,
        "bias": e.coefficients.bias,
        "scale": e.coefficients.scale,
        "step_nt": e.stats.step_nt,
        "hh_nt": e.stats.hh_nt,
        "hz_nt": e.stats.hz_nt,
        "f_nt": e.stats.f_nt,
        "f_error_rms_nt": e.stats.f_error_rms_nt,
    })
}

fn stats_json(s: &calib_core::backstep::RunStats<f64>) -> serde_json::Value {
    json!({"step_nt": s.step_nt, "hh_nt": s.hh_nt, "hz_nt": s.hz_nt, "f_nt": s.f_nt, "f_error_rms_nt": s.f_error_rms_nt})
}

/// Refines a calibration on an out-and-back run.
pub fn backstep_recording(rec: &Recording, doc: &CalDoc, opts: &BackstepOptions) -> Result<(CalDoc, BackstepReport), PipelineError> {
    use calib_core::backstep::{joint_refine, paper_backstep, run_stats, AxisCoefficients, JointWeights, Leg, RunSample};
    let t = rec.t_s.as_ref().ok_or(PipelineError::NeedsColumn("t"))?;
    let roll = rec.roll_deg.as_ref().ok_or(PipelineError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(PipelineError::NeedsColumn("pitch_deg"))?;
    check_units(rec, doc)?;
    let headings = magnetic_headings(rec, doc)?;
    let turnaround = match opts.turnaround_s {
        Some(s) => s,
        None => find_turnaround(t, &headings, opts.window_s).ok_or_else(|| {
            PipelineError::Backstep("no turnaround found (no 180° change of heading): give it with --turnaround-s".into())
        })?,
    };
    let mut samples = Vec::with_capacity(rec.len());
    for i in 0..rec.len() {
        let raw = rec.mag[i];
        if !raw.iter().all(|v| v.is_finite()) || !roll[i].is_finite() || !pitch[i].is_finite() {
            continue;
        }
        let (h_ref, z_ref) = match opts.reference {
            RunReference::Given { h_nt, z_nt } => (h_nt, z_nt),
            RunReference::Igrf { lat_deg, lon_deg, year } => {
                let lat = rec.lat_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(lat_deg);
                let lon = rec.lon_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(lon_deg);
                let f = crate::igrf::igrf14(lat, lon, 0.0, year).map_err(|e| PipelineError::Backstep(e.to_string()))?;
                (f.horizontal_nt(), f.down_nt)
            }
        };
        let dt = t[i] - turnaround;
        let leg = if dt < -opts.exclude_s && dt >= -opts.exclude_s - opts.window_s {
            Leg::Out
        } else if dt > opts.exclude_s && dt <= opts.exclude_s + opts.window_s {
            Leg::Back
        } else {
            Leg::Other
        };
        // The turn itself (heading sweeping through, vehicle at the surface) is left out of the fits.
        if dt.abs() <= opts.exclude_s {
            continue;
        }
        samples.push(RunSample { raw, roll_rad: roll[i].to_radians(), pitch_rad: pitch[i].to_radians(), h_ref_nt: h_ref, z_ref_nt: z_ref, leg });
    }
    let bs = |e: calib_core::backstep::BackstepError| PipelineError::Backstep(e.to_string());
    let before = run_stats(&doc.field_cal(), &samples).map_err(bs)?;
    let mut trace = Vec::new();
    let (kind, cal, extra) = match opts.method {
        BackstepMethod::Paper => {
            let start = AxisCoefficients::from_field_cal(&doc.field_cal()).ok_or_else(|| {
                PipelineError::Backstep("the paper's back-stepping corrects the axis model: fit with --model axis first".into())
            })?;
            let end = paper_backstep(&start, &samples, opts.max_iterations, 20.0, 50.0, &mut |e| trace.push(backstep_trace_json(&e))).map_err(bs)?;
            (ModelKind::Axis, end.field_cal(), json!({}))
        }
        BackstepMethod::Joint => {
            let (swing, swing_f): (&[[f64; 3]], f64) = match &opts.swing {
                Some((s, f)) => (s.as_slice(), *f),
                None => (&[], 1.0),
            };
            trace.push(json!({"iteration": 0, "correction": "start", "step_nt": before.step_nt, "hh_nt": before.hh_nt, "hz_nt": before.hz_nt, "f_nt": before.f_nt, "f_error_rms_nt": before.f_error_rms_nt}));
            let r = joint_refine(&doc.field_cal(), &samples, swing, swing_f, &JointWeights::default()).map_err(bs)?;
            let s = run_stats(&r.running, &samples).map_err(bs)?;
            trace.push(json!({"iteration": r.iterations, "correction": "joint least squares", "bias": r.running.bias, "matrix": r.running.matrix, "step_nt": s.step_nt, "hh_nt": s.hh_nt, "hz_nt": s.hz_nt, "f_nt": s.f_nt, "f_error_rms_nt": s.f_error_rms_nt}));
            (ModelKind::Full, r.running, json!({"running_bias": r.running_bias, "resting_bias": r.resting.bias, "swing_samples": swing.len()}))
        }
    };
    let after = run_stats(&cal, &samples).map_err(bs)?;
    let (_, f_ref) = calib_core::backstep::reference_means(&samples);
    let mut out = CalDoc::new(kind, &cal, f_ref, doc.quality.clone());
    out.declination_deg = doc.declination_deg;
    out.swing = None; // a swing fit made with the old field calibration no longer applies
    if !out.quality.is_object() {
        out.quality = json!({});
    }
    out.quality["backstep"] = json!({
        "method": match opts.method { BackstepMethod::Paper => "paper", BackstepMethod::Joint => "joint" },
        "turnaround_s": turnaround,
        "samples": samples.len(),
        "before": stats_json(&before),
        "after": stats_json(&after),
        "details": extra,
    });
    out.trace = Some(json!(trace));
    Ok((out, BackstepReport { turnaround_s: turnaround, before, after }))
}
