//! The out-and-back refinement of paper 000: the paper's corrections of the
//! horizontal and vertical channels, and our joint least squares, on a run
//! with a turnaround; the turnaround found from the headings.

use calib_core::cal::ModelKind;

use super::swing::magnetic_headings;
use super::units::check_units;
use super::ComputeError;
use crate::data::results::{BackstepMethod, BackstepQuality, Correction, JointDetails, RunStatsDoc, TraceEntry};
use crate::data::{CalDoc, Recording};
use crate::geomag::Site;

/// The reference field for the run.
#[derive(Debug, Clone, Copy)]
pub enum RunReference {
    /// IGRF-14 at each row's `lat_deg`/`lon_deg` (at the site where a row
    /// has none), at the site's date.
    Igrf(Site),
    /// Fixed horizontal and down components, nT.
    Given {
        /// Horizontal intensity, nT.
        h_nt: f64,
        /// Down component, nT.
        z_nt: f64,
    },
}

/// The swing test's raw samples with their reference intensity: magnitudes
/// with thrusters off, which let the joint solver separate the running-only
/// bias.
#[derive(Debug, Clone)]
pub struct SwingMagnitudes {
    /// Raw samples, input units.
    pub raw: Vec<[f64; 3]>,
    /// Reference intensity, nT.
    pub field_nt: f64,
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
    /// Swing-test magnitudes for the joint solver (thrusters off).
    pub swing: Option<SwingMagnitudes>,
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

fn paper_trace_entry(e: &calib_core::backstep::TraceEntry<f64>) -> TraceEntry {
    TraceEntry {
        iteration: e.iteration,
        correction: Correction::from_paper_code(e.correction),
        bias: Some(e.coefficients.bias),
        scale: Some(e.coefficients.scale),
        matrix: None,
        stats: RunStatsDoc::from(&e.stats),
    }
}

/// Refines a calibration on an out-and-back run.
pub fn backstep_recording(rec: &Recording, doc: &CalDoc, opts: &BackstepOptions) -> Result<(CalDoc, BackstepReport), ComputeError> {
    use calib_core::backstep::{joint_refine, paper_backstep, run_stats, AxisCoefficients, JointWeights, Leg, RunSample};
    let t = rec.t_s.as_ref().ok_or(ComputeError::NeedsColumn("t"))?;
    let roll = rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    check_units(rec, doc)?;
    let headings = magnetic_headings(rec, doc)?;
    let turnaround = match opts.turnaround_s {
        Some(s) => s,
        None => find_turnaround(t, &headings, opts.window_s).ok_or_else(|| {
            ComputeError::Backstep("no turnaround found (no 180° change of heading): give it with --turnaround-s".into())
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
            RunReference::Igrf(site) => {
                let lat = rec.lat_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(site.lat_deg);
                let lon = rec.lon_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(site.lon_deg);
                let f = site.field_at(lat, lon)?;
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
    let bs = |e: calib_core::backstep::BackstepError| ComputeError::Backstep(e.to_string());
    let before = run_stats(&doc.field_cal(), &samples).map_err(bs)?;
    let mut trace = Vec::new();
    let (kind, cal, extra) = match opts.method {
        BackstepMethod::Paper => {
            let start = AxisCoefficients::from_field_cal(&doc.field_cal()).ok_or_else(|| {
                ComputeError::Backstep("the paper's back-stepping corrects the axis model: fit with --model axis first".into())
            })?;
            let end = paper_backstep(&start, &samples, opts.max_iterations, 20.0, 50.0, &mut |e| trace.push(paper_trace_entry(&e))).map_err(bs)?;
            (ModelKind::Axis, end.field_cal(), None)
        }
        BackstepMethod::Joint => {
            let (swing, swing_f): (&[[f64; 3]], f64) = match &opts.swing {
                Some(m) => (m.raw.as_slice(), m.field_nt),
                None => (&[], 1.0),
            };
            trace.push(TraceEntry { iteration: 0, correction: Correction::Start, bias: None, scale: None, matrix: None, stats: RunStatsDoc::from(&before) });
            let r = joint_refine(&doc.field_cal(), &samples, swing, swing_f, &JointWeights::default()).map_err(bs)?;
            let s = run_stats(&r.running, &samples).map_err(bs)?;
            trace.push(TraceEntry {
                iteration: r.iterations,
                correction: Correction::JointLeastSquares,
                bias: Some(r.running.bias),
                scale: None,
                matrix: Some(r.running.matrix),
                stats: RunStatsDoc::from(&s),
            });
            (ModelKind::Full, r.running, Some(JointDetails { running_bias_raw: r.running_bias, resting_bias_raw: r.resting.bias, swing_samples: swing.len() }))
        }
    };
    let after = run_stats(&cal, &samples).map_err(bs)?;
    let (_, f_ref) = calib_core::backstep::reference_means(&samples);
    let mut out = CalDoc::new(kind, &cal, f_ref, doc.quality.clone());
    out.declination_deg = doc.declination_deg;
    out.swing = None; // a swing fit made with the old field calibration no longer applies
    out.quality.backstep = Some(BackstepQuality {
        method: opts.method,
        turnaround_s: turnaround,
        samples: samples.len(),
        before: RunStatsDoc::from(&before),
        after: RunStatsDoc::from(&after),
        details: extra,
    });
    out.trace = Some(trace);
    Ok((out, BackstepReport { turnaround_s: turnaround, before, after }))
}
