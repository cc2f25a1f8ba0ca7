//! The out-and-back refinement of paper 000: the paper's corrections of the
//! horizontal and vertical channels, and our joint least squares, on a run
//! with a turnaround; the turnaround found from the headings.

use calib_core::cal::ModelKind;

use super::swing::magnetic_headings;
use super::units::check_units;
use super::error::ComputeError;
use calib_core::backstep::{JointConfig, JointSolution, Leg, RunSample, SwingSample};

use crate::doc::caldoc::{CurrentBlock, TemperatureBlock};
use crate::doc::results::{BackstepMethod, BackstepQuality, Correction, Estimate3, JointDetails, JointEstimates, RunStatsDoc, TraceEntry};
use crate::data::Recording;
use crate::doc::CalDoc;
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
    /// Motor current of each sample, A (`None`: not recorded, thrusters off).
    pub current_a: Option<Vec<f64>>,
    /// Temperature of each sample, °C (`None`: not recorded).
    pub temp_c: Option<Vec<f64>>,
}

impl SwingMagnitudes {
    /// The complete samples of a swing-test recording, with its
    /// `motor_current_a` and `temp_c` columns when present.
    pub fn from_recording(rec: &Recording, field_nt: f64) -> Self {
        let (rows, raw) = rec.complete_mag();
        let pick = |c: &Option<Vec<f64>>| c.as_ref().map(|v| rows.iter().map(|&i| v.get(i).copied().unwrap_or(f64::NAN)).collect());
        Self { raw, field_nt, current_a: pick(&rec.motor_current_a), temp_c: pick(&rec.temp_c) }
    }

    fn samples(&self) -> Vec<SwingSample<f64>> {
        let at = |c: &Option<Vec<f64>>, i: usize| c.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(f64::NAN);
        self.raw.iter().enumerate().map(|(i, &raw)| SwingSample { raw, current_a: at(&self.current_a, i), temp_c: at(&self.temp_c, i) }).collect()
    }
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
    /// Joint: thresholds and priors of the environment terms (`ref_c`
    /// `None`: the median temperature of the run).
    pub joint: JointConfig<f64>,
    /// Joint: the length of a hypothetical surface circle for the guidance, s.
    pub circle_s: f64,
    /// Joint: a dedicated thrust test (hold heading, step the thrusters),
    /// with `motor_current_a`, roll and pitch: its rows join the run's. Hold
    /// two headings about 90° apart: at one, the thrusters' field across the
    /// horizontal field turns the heading without changing the residuals.
    pub thrust_test: Option<Recording>,
}

impl BackstepOptions {
    /// Defaults: joint solver, turnaround found automatically, 300 s windows,
    /// 60 s skipped either side of the turn.
    pub fn new(reference: RunReference) -> Self {
        Self {
            method: BackstepMethod::Joint,
            reference,
            turnaround_s: None,
            window_s: 300.0,
            exclude_s: 60.0,
            swing: None,
            max_iterations: 10,
            joint: JointConfig::default(),
            circle_s: 120.0,
            thrust_test: None,
        }
    }
}

/// What the back-stepping found.
#[derive(Debug, Clone)]
pub struct BackstepReport {
    /// The turnaround time used, seconds.
    pub turnaround_s: f64,
    /// Run statistics with the input calibration.
    pub before: calib_core::backstep::RunStats<f64>,
    /// And with the result (its current and temperature terms applied).
    pub after: calib_core::backstep::RunStats<f64>,
    /// The joint solver's full solution (covariance-based predictions).
    pub joint: Option<JointSolution<f64>>,
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
    use calib_core::backstep::{paper_backstep, run_stats, AxisCoefficients};
    // The document's own problem first, before any work on the recording.
    if opts.method == BackstepMethod::Paper && AxisCoefficients::from_field_cal(&doc.field_cal()).is_none() {
        return Err(ComputeError::PaperNeedsAxis { model: doc.model.name() });
    }
    let t = rec.t_s.as_ref().ok_or(ComputeError::NeedsColumn("t"))?;
    rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    check_units(rec, doc)?;
    let headings = magnetic_headings(rec, doc)?;
    let turnaround = match opts.turnaround_s {
        Some(s) => s,
        None => find_turnaround(t, &headings, opts.window_s).ok_or(ComputeError::NoTurnaround)?,
    };
    let samples = run_samples(rec, &opts.reference, Some((turnaround, opts.window_s, opts.exclude_s)))?;
    let thrust = match &opts.thrust_test {
        Some(tt) => {
            if !tt.motor_current_a.as_ref().is_some_and(|c| c.iter().any(|v| v.is_finite())) {
                return Err(ComputeError::ThrustTestNoCurrent);
            }
            run_samples(tt, &opts.reference, None)?
        }
        None => Vec::new(),
    };
    let before = run_stats(&doc.field_cal(), &samples)?;
    let mut trace = Vec::new();
    let mut joint: Option<JointSolution<f64>> = None;
    // The joint refinement's run statistics, computed once for its trace.
    let mut joint_after = None;
    let (kind, cal, extra) = match opts.method {
        BackstepMethod::Paper => {
            let start = AxisCoefficients::from_field_cal(&doc.field_cal()).ok_or(ComputeError::PaperNeedsAxis { model: doc.model.name() })?;
            let end = paper_backstep(&start, &samples, opts.max_iterations, 20.0, 50.0, &mut |e| trace.push(paper_trace_entry(&e)))?;
            (ModelKind::Axis, end.field_cal(), None)
        }
        BackstepMethod::Joint => {
            let swing = opts.swing.as_ref().map(SwingMagnitudes::samples).unwrap_or_default();
            let swing_f = opts.swing.as_ref().map_or(1.0, |m| m.field_nt);
            trace.push(TraceEntry { iteration: 0, correction: Correction::Start, bias: None, scale: None, matrix: None, stats: RunStatsDoc::from(&before) });
            let mut cfg = opts.joint;
            if cfg.ref_c.is_none() {
                cfg.ref_c = median(samples.iter().chain(&thrust).map(|s| s.temp_c).chain(swing.iter().map(|s| s.temp_c)));
            }
            let all: Vec<RunSample<f64>> = samples.iter().chain(&thrust).copied().collect();
            let r = calib_core::backstep::joint_refine_env(&doc.field_cal(), &all, &swing, swing_f, &cfg)?;
            let s = run_stats(&r.running, &corrected(&samples, &r))?;
            trace.push(TraceEntry {
                iteration: r.iterations,
                correction: Correction::JointLeastSquares,
                bias: Some(r.running.bias),
                scale: None,
                matrix: Some(r.running.matrix),
                stats: RunStatsDoc::from(&s),
            });
            let details = JointDetails { running_bias_raw: r.running_bias, resting_bias_raw: r.resting.bias, swing_samples: swing.len() };
            let running = r.running;
            joint = Some(r);
            joint_after = Some(s);
            (ModelKind::Full, running, Some(details))
        }
    };
    let after = match joint_after {
        Some(s) => s,
        None => run_stats(&cal, &samples)?,
    };
    let (_, f_ref) = calib_core::backstep::reference_means(&samples);
    let mut out = CalDoc::new(kind, &cal, f_ref, doc.quality.clone());
    out.declination_deg = doc.declination_deg;
    let estimates = joint.as_ref().map(|r| {
        if r.current_estimated {
            out.current = Some(CurrentBlock { bias_per_a: r.env.bias_per_a });
        }
        if r.temperature_estimated {
            out.temperature = Some(TemperatureBlock { ref_c: r.env.ref_c, gain_per_c: r.env.gain_per_c });
        }
        out.quality.predicted_heading_rms_deg = Some(r.predicted_heading_rms_rad.to_degrees());
        joint_estimates(r, circle_samples(t, opts.circle_s))
    });
    out.swing = None; // a swing fit made with the old field calibration no longer applies
    out.quality.backstep = Some(BackstepQuality {
        method: opts.method,
        turnaround_s: turnaround,
        samples: samples.len(),
        before: RunStatsDoc::from(&before),
        after: RunStatsDoc::from(&after),
        details: extra,
        estimates,
    });
    out.trace = Some(trace);
    // The reference goes on, judged again on the run with the new matrix.
    if let Some(mut r) = doc.reference.clone() {
        r.check_calibration(&out.field_cal(), rec, None);
        out.reference = Some(r);
    }
    out.quality.expected_heading_rms_deg = super::apply::expected_heading_rms_deg(&out);
    Ok((out, BackstepReport { turnaround_s: turnaround, before, after, joint }))
}

/// The samples of a recording with attitude, with their reference field.
/// `legs` = (turnaround, window, excluded either side), s: rows within the
/// exclusion are left out (the turn itself), the windows either side marked;
/// `None` (a thrust test): every row, [`Leg::Other`].
fn run_samples(rec: &Recording, reference: &RunReference, legs: Option<(f64, f64, f64)>) -> Result<Vec<RunSample<f64>>, ComputeError> {
    let roll = rec.roll_deg.as_ref().ok_or(ComputeError::NeedsColumn("roll_deg"))?;
    let pitch = rec.pitch_deg.as_ref().ok_or(ComputeError::NeedsColumn("pitch_deg"))?;
    let t = rec.t_s.as_ref();
    // Positions are measured from the site (IGRF's reference) or else from
    // the recording's first fix.
    let origin = match reference {
        RunReference::Igrf(site) => Some((site.lat_deg, site.lon_deg)),
        RunReference::Given { .. } => first_fix(rec),
    };
    let mut samples = Vec::with_capacity(rec.len());
    for i in 0..rec.len() {
        let raw = rec.mag[i];
        if !raw.iter().all(|v| v.is_finite()) || !roll[i].is_finite() || !pitch[i].is_finite() {
            continue;
        }
        let (h_ref, z_ref) = match reference {
            RunReference::Given { h_nt, z_nt } => (*h_nt, *z_nt),
            RunReference::Igrf(site) => {
                let lat = rec.lat_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(site.lat_deg);
                let lon = rec.lon_deg.as_ref().and_then(|c| c.get(i).copied()).filter(|v| v.is_finite()).unwrap_or(site.lon_deg);
                let f = site.field_at(lat, lon)?;
                (f.horizontal_nt(), f.down_nt)
            }
        };
        let mut leg = Leg::Other;
        if let (Some((turnaround, window_s, exclude_s)), Some(t)) = (legs, t) {
            let dt = t.get(i).copied().unwrap_or(f64::NAN) - turnaround;
            if dt < -exclude_s && dt >= -exclude_s - window_s {
                leg = Leg::Out;
            } else if dt > exclude_s && dt <= exclude_s + window_s {
                leg = Leg::Back;
            }
            // The turn itself (heading sweeping through, vehicle at the surface) is left out of the fits.
            if !(dt.abs() > exclude_s) {
                continue;
            }
        }
        let col = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(f64::NAN);
        samples.push(RunSample {
            raw,
            roll_rad: roll[i].to_radians(),
            pitch_rad: pitch[i].to_radians(),
            h_ref_nt: h_ref,
            z_ref_nt: z_ref,
            leg,
            current_a: col(&rec.motor_current_a),
            temp_c: col(&rec.temp_c),
            position_m: position_m(rec, i, origin),
        });
    }
    Ok(samples)
}

/// The first row with a finite `lat_deg` and `lon_deg`.
fn first_fix(rec: &Recording) -> Option<(f64, f64)> {
    let (lat, lon) = (rec.lat_deg.as_ref()?, rec.lon_deg.as_ref()?);
    lat.iter().zip(lon).find(|(a, b)| a.is_finite() && b.is_finite()).map(|(a, b)| (*a, *b))
}

/// Row `i`'s logged position north and east of `origin` (lat, lon), m;
/// NaN without a position.
fn position_m(rec: &Recording, i: usize, origin: Option<(f64, f64)>) -> [f64; 2] {
    let at = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(f64::NAN);
    let (lat, lon) = (at(&rec.lat_deg), at(&rec.lon_deg));
    match origin {
        Some((lat0, lon0)) if lat.is_finite() && lon.is_finite() => calib_core::water_current::local_north_east_m(lat, lon, lat0, lon0),
        _ => [f64::NAN; 2],
    }
}

/// The run samples with the solution's current and temperature terms
/// applied to the raw field (for statistics with the field calibration).
fn corrected(samples: &[calib_core::backstep::RunSample<f64>], r: &JointSolution<f64>) -> Vec<calib_core::backstep::RunSample<f64>> {
    use calib_core::cal::Environment;
    samples
        .iter()
        .map(|s| {
            let env = Environment {
                current_a: if r.current_estimated { s.current_a } else { 0.0 },
                temp_c: if r.temperature_estimated { s.temp_c } else { r.env.ref_c },
            };
            calib_core::backstep::RunSample { raw: r.env.correct_raw(s.raw, &env), ..*s }
        })
        .collect()
}

/// The median of the finite values ([`calib_core::series::median`]).
fn median(values: impl Iterator<Item = f64>) -> Option<f64> {
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    calib_core::series::median(&mut v)
}

/// Samples in a circle of `circle_s` seconds at the run's median rate.
fn circle_samples(t: &[f64], circle_s: f64) -> usize {
    let dt = crate::data::pairing::median_step_s(t).unwrap_or(1.0);
    ((circle_s / dt).round() as usize).clamp(36, 100_000)
}

/// Most hypothetical circles the guidance considers.
const MAX_CIRCLES: usize = 5;

/// What more coverage would buy: the predicted heading RMS (degrees) with
/// 1 … 5 more level surface circles of `samples_per_circle` samples each,
/// and one sentence ("coverage so far predicts 0.60°; 3 more surface
/// circles would bring it to 0.30°").
pub fn coverage_guidance(r: &JointSolution<f64>, samples_per_circle: usize) -> (Vec<f64>, String) {
    let now = r.predicted_heading_rms_rad.to_degrees();
    let with: Vec<f64> =
        (1..=MAX_CIRCLES).map(|n| r.predicted_with(r.level_turn(samples_per_circle * n)).map_or(f64::NAN, |(_, rms)| rms.to_degrees())).collect();
    let d = deg_text;
    let sentence = match with.iter().position(|w| *w <= 0.5 * now) {
        Some(i) => format!("coverage so far predicts {}; {} more surface circle{} would bring it to {}", d(now), i + 1, if i == 0 { "" } else { "s" }, d(with[i])),
        None if with.first().is_some_and(|w| *w < 0.9 * now) => {
            format!("coverage so far predicts {}; one more surface circle would bring it to {}, {MAX_CIRCLES} to {}", d(now), d(with[0]), d(with[MAX_CIRCLES - 1]))
        }
        None => format!("coverage so far predicts {}; more surface circles would not improve it (the remaining error is not one a circle determines)", d(now)),
    };
    (with, sentence)
}

/// An angle in degrees with two significant digits (at least two decimals).
fn deg_text(v: f64) -> String {
    let decimals = if v > 0.0 && v.is_finite() { (1.0 - v.log10().floor()).clamp(2.0, 6.0) as usize } else { 2 };
    format!("{v:.decimals$}°")
}

/// The quality block's estimates from a joint solution.
fn joint_estimates(r: &JointSolution<f64>, samples_per_circle: usize) -> JointEstimates {
    let (with, guidance) = coverage_guidance(r, samples_per_circle);
    let deg2 = |v: [f64; 2]| v.map(f64::to_degrees);
    JointEstimates {
        bias_per_a_raw: r.current_estimated.then_some(Estimate3 { value: r.env.bias_per_a, sigma: r.sigma.bias_per_a }),
        gain_per_c: r.temperature_estimated.then_some(Estimate3 { value: r.env.gain_per_c, sigma: r.sigma.gain_per_c }),
        ref_c: r.env.ref_c,
        bias_raw: Estimate3 { value: r.resting.bias, sigma: r.sigma.bias },
        running_bias_raw: Estimate3 { value: r.running_bias, sigma: r.sigma.running_bias },
        matrix_sigma: r.sigma.matrix,
        local_inclination_offset_deg: r.local_inclination_offset_rad.to_degrees(),
        local_inclination_sigma_deg: r.sigma.local_inclination_rad.to_degrees(),
        local_hz_nt: [r.reference_hz_nt[0] + r.local_offset_hz_nt[0], r.reference_hz_nt[1] + r.local_offset_hz_nt[1]],
        intensity_sigma_nt: r.intensity_sigma_nt,
        misalignment_deg: r.misalignment_estimated.then_some(deg2(r.misalignment_rad)),
        misalignment_sigma_deg: r.misalignment_estimated.then_some(deg2(r.sigma.misalignment_rad)),
        residual_rms_nt: r.residual_rms_nt,
        heading_sigma_deg: r.heading_sigma_rad.iter().map(|v| v.to_degrees()).collect(),
        predicted_heading_rms_deg: r.predicted_heading_rms_rad.to_degrees(),
        predicted_with_circles_deg: with,
        guidance,
        notes: r.notes.iter().flatten().map(|n| n.to_string()).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use calib_core::cal::FieldCal;
    use calib_core::heading::ned_to_body;

    /// Raw counts from the physics: `g(T) ⊙ (D·h + b + c·I)`, written here
    /// apart from the estimator.
    const D: [[f64; 3]; 3] = [[0.19556, 0.003, 0.004], [0.003, 0.09001, -0.002], [0.0035, -0.002, 0.16142]];
    const B: [f64; 3] = [-1865.0, 1385.0, -903.0];
    const C_PER_A: [f64; 3] = [4.0, -3.0, 8.0];
    const K_PER_C: [f64; 3] = [0.003, -0.002, 0.0025];
    const T0_C: f64 = 16.0;
    const FIELD_NED: [f64; 3] = [27_450.0, 0.0, 40_289.0];

    fn raw(h: [f64; 3], current_a: f64, temp_c: f64) -> [f64; 3] {
        let r = calib_core::linalg::mul_mat_vec(&D, h);
        [0, 1, 2].map(|i| (1.0 + K_PER_C[i] * (temp_c - T0_C)) * (r[i] + B[i] + C_PER_A[i] * current_a))
    }

    fn recording(current: impl Fn(usize) -> f64, temp: impl Fn(usize) -> f64) -> Recording {
        let mut rec = Recording::default();
        let (mut t, mut roll, mut pitch, mut cur, mut tmp) = (vec![], vec![], vec![], vec![], vec![]);
        for k in 0..4000usize {
            let course: f64 = if k < 2000 { 62.0 } else { 242.0 };
            let yaw = (course + 10.0 * (k as f64 * 0.004).sin()).to_radians();
            let (r, p) = (3.0 * (k as f64 * 0.05).sin(), 8.0 * (k as f64 * 0.003).sin());
            let h = ned_to_body(FIELD_NED, r.to_radians(), p.to_radians(), yaw);
            rec.mag.push(raw(h, current(k), temp(k)));
            t.push(k as f64);
            roll.push(r);
            pitch.push(p);
            cur.push(current(k));
            tmp.push(temp(k));
        }
        rec.t_s = Some(t);
        rec.roll_deg = Some(roll);
        rec.pitch_deg = Some(pitch);
        rec.motor_current_a = Some(cur);
        rec.temp_c = Some(tmp);
        rec
    }

    fn step1() -> CalDoc {
        let s = [D[0][0] * 1.01, D[1][1] * 0.99, D[2][2] * 1.02];
        let cal = FieldCal { bias: [B[0] + 30.0, B[1] - 20.0, B[2] + 40.0], matrix: [[1.0 / s[0], 0.0, 0.0], [0.0, 1.0 / s[1], 0.0], [0.0, 0.0, 1.0 / s[2]]] };
        CalDoc::new(ModelKind::Axis, &cal, (FIELD_NED[0].powi(2) + FIELD_NED[2].powi(2)).sqrt(), Default::default())
    }

    fn options() -> BackstepOptions {
        let mut o = BackstepOptions::new(RunReference::Given { h_nt: FIELD_NED[0], z_nt: FIELD_NED[2] });
        o.turnaround_s = Some(2000.0);
        o
    }

    #[test]
    fn the_document_gets_the_current_and_temperature_blocks_and_the_prediction() {
        let rec = recording(|k| [2.0, 8.0, 14.0, 5.0][(k / 400) % 4], |k| T0_C + 4.0 * (k as f64 * std::f64::consts::TAU / 1700.0).sin());
        let (doc, report) = backstep_recording(&rec, &step1(), &options()).unwrap();
        let c = doc.current.expect("current block").bias_per_a;
        let t = doc.temperature.expect("temperature block");
        // Noise-free data; the reference temperature is the data's median
        // (the gains hold relative to it: k/(1 + k·(ref − T₀)), 0.2 % off k).
        // Measured: c within 0.2 %, k within 5e-6/°C.
        for i in 0..3 {
            assert!((c[i] - C_PER_A[i]).abs() < 0.01 * C_PER_A[i].abs(), "{c:?}");
            assert!((t.gain_per_c[i] - K_PER_C[i]).abs() < 2e-5, "{:?}", t.gain_per_c);
        }
        // (over the samples fitted: the turn, ±60 s around 2000 s, is left out)
        let mut temps: Vec<f64> = rec.temp_c.clone().unwrap().into_iter().enumerate().filter(|(k, _)| (*k as f64 - 2000.0).abs() > 60.0).map(|(_, v)| v).collect();
        temps.sort_by(f64::total_cmp);
        assert_eq!(t.ref_c, temps[temps.len() / 2]);
        let q = doc.quality.backstep.as_ref().unwrap();
        let e = q.estimates.as_ref().unwrap();
        assert_eq!(e.heading_sigma_deg.len(), 24);
        assert!(e.guidance.starts_with("coverage so far predicts"), "{}", e.guidance);
        assert!(doc.quality.predicted_heading_rms_deg.is_some_and(|p| p > 0.0 && p < 1.0));
        assert!(report.after.step_nt.abs() < 5.0, "{:?}", report.after);
        // The document round-trips with its new blocks and quality.
        let back: CalDoc = serde_json::from_str(&serde_json::to_string(&doc).unwrap()).unwrap();
        assert!(back.current.is_some() && back.temperature.is_some());
        assert_eq!(back.quality.backstep.and_then(|b| b.estimates).map(|e| e.notes), Some(e.notes.clone()));
    }

    #[test]
    fn a_constant_current_gets_no_block_and_says_why() {
        let rec = recording(|_| 8.0, |_| T0_C);
        let (doc, _) = backstep_recording(&rec, &step1(), &options()).unwrap();
        assert!(doc.current.is_none() && doc.temperature.is_none());
        let notes = &doc.quality.backstep.as_ref().unwrap().estimates.as_ref().unwrap().notes;
        assert!(notes.iter().any(|n| n.contains("motor current never varied")), "{notes:?}");
        assert!(notes.iter().any(|n| n.contains("temperature was constant")), "{notes:?}");
    }

    #[test]
    fn guidance_angles_keep_two_significant_digits() {
        assert_eq!(deg_text(0.6), "0.60°");
        assert_eq!(deg_text(0.0004057), "0.00041°");
        assert_eq!(deg_text(12.34), "12.34°");
    }

    #[test]
    fn a_thrust_test_separates_the_current_a_constant_run_cannot() {
        let run = recording(|_| 8.0, |_| T0_C);
        // Hold heading, level, and step the thrusters 0 → 14 A; at 130° then
        // at 220°. (At one heading only the thrusters' field across the
        // horizontal field changes the heading, not the residuals: held at
        // 130° alone, x came out 3.6 % off.)
        let mut tt = Recording::default();
        let steps = [0.0, 4.0, 8.0, 14.0, 0.0, 10.0];
        let cur: Vec<f64> = (0..600).map(|k| steps[k / 100]).collect();
        tt.mag = cur
            .iter()
            .enumerate()
            .map(|(k, &i)| raw(ned_to_body(FIELD_NED, 0.0, 0.0, if k < 300 { 130f64 } else { 220.0 }.to_radians()), i, T0_C))
            .collect();
        tt.t_s = Some((0..600).map(f64::from).collect());
        tt.roll_deg = Some(vec![0.0; 600]);
        tt.pitch_deg = Some(vec![0.0; 600]);
        tt.motor_current_a = Some(cur);
        let mut o = options();
        o.thrust_test = Some(tt.clone());
        let (doc, _) = backstep_recording(&run, &step1(), &o).unwrap();
        let c = doc.current.expect("the thrust test separates the current").bias_per_a;
        // Noise-free, two headings: measured within 1e-8 relative.
        for i in 0..3 {
            assert!((c[i] - C_PER_A[i]).abs() < 1e-4 * C_PER_A[i].abs(), "{c:?}");
        }
        tt.motor_current_a = None;
        o.thrust_test = Some(tt);
        let err = backstep_recording(&run, &step1(), &o).unwrap_err().to_string();
        assert!(err.contains("thrust test has no motor_current_a"), "{err}");
    }
}
