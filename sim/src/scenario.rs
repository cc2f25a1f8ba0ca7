//! Paper 000's field test, simulated end to end with ground truth: swing
//! test → axis fit against IGRF → back-stepping on an out-and-back run (the
//! paper's and ours) → swing (Fourier) fit against the delayed GPS course →
//! true-heading and field errors on a separate validation run. The chain is
//! host-tools' own ([`host_tools::compute::chain`]); the errors against truth
//! are [`host_tools::compute`]'s. Used by the acceptance tests and by
//! `cargo xtask bench`.

use host_tools::compute::{self, ChainOptions, ComputeError, WaterCurrentMode, Delay, FirstStep};
use host_tools::doc::BackstepMethod;
use host_tools::doc::CalDoc;
use host_tools::geomag::Site;

use crate::effects::{Effect, Effects};
use crate::field_test::{self, paper_site, GyroModel, RunKind, RunParams, SensorModel, SimError, Simulation};

/// Why a scenario could not be evaluated.
#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    /// The simulator refused its parameters.
    #[error("simulation: {0}")]
    Sim(#[from] SimError),
    /// A step of the chain refused the simulated data.
    #[error("chain: {0}")]
    Compute(#[from] ComputeError),
}

/// True-heading RMS error (degrees) of a calibration on a simulated run.
pub fn heading_rms_deg(doc: &CalDoc, sim: &Simulation) -> f64 {
    let headings = compute::true_headings_rad(doc, &sim.recording);
    compute::heading_rms_deg(headings.into_iter().zip(sim.true_heading_deg.iter().copied())).rms
}

/// The white-noise part of a calibration's true-heading error on a
/// simulated run, °: `RMS(e_i − e_{i−1})/√2` over consecutive rows.
pub fn heading_noise_deg(doc: &CalDoc, sim: &Simulation) -> f64 {
    let errors: Vec<f64> = compute::true_headings_rad(doc, &sim.recording)
        .into_iter()
        .zip(sim.true_heading_deg.iter())
        .map(|(h, t)| calib_core::heading::wrap_pi(h - t.to_radians()))
        .collect();
    let (mut ss, mut n) = (0.0, 0usize);
    for w in errors.windows(2) {
        let d = calib_core::heading::wrap_pi(w[1] - w[0]);
        if d.is_finite() {
            ss += d * d;
            n += 1;
        }
    }
    if n == 0 {
        return f64::NAN;
    }
    (ss / n as f64 / 2.0).sqrt().to_degrees()
}

/// RMS of |h| − IGRF over a simulated run (every tenth row), nT; the
/// document's current and temperature terms applied.
pub fn field_error_nt(doc: &CalDoc, sim: &Simulation) -> f64 {
    let rec = &sim.recording;
    let h = compute::calibrated_fields_nt(doc, rec);
    let fields = (0..rec.len()).step_by(10).map(|i| (h[i], i));
    compute::field_rms_nt(fields, rec, &sim.truth.site).rms
}

/// RMS of |h| − |true local field| over a simulated run with the anomaly
/// effect (every tenth row), nT: the error against the field the vehicle
/// was really in, not IGRF. `None` without the simulator's true-field columns.
pub fn field_error_true_nt(doc: &CalDoc, sim: &Simulation) -> Option<f64> {
    let (n, e, d) = (sim.effect_column("true_field_n_nt")?, sim.effect_column("true_field_e_nt")?, sim.effect_column("true_field_d_nt")?);
    let h = compute::calibrated_fields_nt(doc, &sim.recording);
    let r = compute::field_rms_against_nt((0..h.len()).step_by(10).map(|i| (h[i], (n[i].powi(2) + e[i].powi(2) + d[i].powi(2)).sqrt())));
    (r.samples > 0).then_some(r.rms)
}

/// The crustal anomaly's declination along a simulated run (the true local
/// field's against IGRF's at each row), rad; `None` without the simulator's
/// true-field columns.
fn anomaly_declination_rad(sim: &Simulation) -> Option<Vec<f64>> {
    let (n, e) = (sim.effect_column("true_field_n_nt")?, sim.effect_column("true_field_e_nt")?);
    let rec = &sim.recording;
    let lat = sim.effect_column("true_lat_deg").or(rec.lat_deg.as_deref())?;
    let lon = sim.effect_column("true_lon_deg").or(rec.lon_deg.as_deref())?;
    let year = sim.truth.site.decimal_year;
    (0..n.len().min(e.len()).min(lat.len()).min(lon.len()))
        .map(|i| {
            let f = host_tools::geomag::igrf14(lat[i], lon[i], 0.0, year).ok()?;
            Some(calib_core::heading::wrap_pi(e[i].atan2(n[i]) - f.east_nt.atan2(f.north_nt)))
        })
        .collect()
}

/// The crustal anomaly's mean declination along the calibration run, rad,
/// and its declination at each row of the validation run, rad; `None`
/// without the simulator's true-field columns.
fn anomaly_declination_and_run_mean_rad(run: &Simulation, validation: &Simulation) -> Option<(f64, Vec<f64>)> {
    let on_run = anomaly_declination_rad(run)?;
    let run_mean = on_run.iter().sum::<f64>() / on_run.len().max(1) as f64;
    Some((run_mean, anomaly_declination_rad(validation)?))
}

/// RMS over the validation run of the crustal anomaly's declination beyond
/// its mean along the calibration run, °: the true-heading error no
/// calibration removes (the swing fit against the run's GPS course takes
/// the run's mean into the heading offset; a magnetometer cannot see the
/// rest). From the simulator's true-field columns and IGRF at the true
/// positions; `None` without the anomaly's columns (no anomaly: no local
/// declination).
pub fn anomaly_declination_beyond_run_mean_deg(run: &Simulation, validation: &Simulation) -> Option<f64> {
    let (run_mean, on_val) = anomaly_declination_and_run_mean_rad(run, validation)?;
    let (mut ss, mut n) = (0.0, 0usize);
    for d in on_val.iter().map(|d| d - run_mean).filter(|d| d.is_finite()) {
        ss += d * d;
        n += 1;
    }
    (n > 0).then(|| (ss / n as f64).sqrt().to_degrees())
}

/// The true calibration of the running vehicle, from the simulator's truth
/// of the calibration run: the sensor's own matrix (`D⁻¹`) and biases (the
/// hull's and the running vehicle's), and the declination IGRF's at the
/// site plus the crustal anomaly's mean along the run (what a swing fit
/// against the run's GPS course takes into the heading offset). No current
/// or temperature terms: on a run with those effects it is the static part.
pub fn true_calibration_doc(run: &Simulation) -> CalDoc {
    let truth = &run.truth;
    let sensor = &truth.sensor;
    let cal = calib_core::cal::FieldCal { bias: [0, 1, 2].map(|k| sensor.bias_raw[k] + sensor.running_bias_raw[k]), matrix: truth.ideal_matrix_nt_per_raw };
    let mut doc = CalDoc::new(calib_core::cal::ModelKind::Full, &cal, truth.field_nt, Default::default());
    let run_mean_deg = anomaly_declination_rad(run).map_or(0.0, |d| (d.iter().sum::<f64>() / d.len().max(1) as f64).to_degrees());
    doc.declination_deg = Some(truth.declination_deg + run_mean_deg);
    doc
}

/// The true-heading floor of a validation run: what the true calibration
/// scores there ([`heading_floor`]).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct HeadingFloor {
    /// The floor, °: `white_noise_deg ⊕ declination_deg` (in quadrature).
    pub floor_deg: f64,
    /// The validation heading error's white-noise part with the true
    /// calibration ([`heading_noise_deg`] of [`true_calibration_doc`]), °.
    pub white_noise_deg: f64,
    /// The crustal anomaly's declination along the validation track beyond
    /// its mean along the calibration run, RMS
    /// ([`anomaly_declination_beyond_run_mean_deg`]), °; 0 without the anomaly.
    pub declination_deg: f64,
}

/// The true-heading floor of a validation run, from the simulator's truth
/// only (never from an estimator): the white heading noise
/// ([`heading_noise_deg`] with [`true_calibration_doc`]) in quadrature with
/// the RMS of the crustal anomaly's declination along the validation track
/// beyond its mean along the calibration run
/// ([`anomaly_declination_beyond_run_mean_deg`]; 0 without the anomaly).
/// No calibration scores a lower true-heading RMS on that validation run
/// except by errors that happen to cancel the declination.
pub fn heading_floor(run: &Simulation, validation: &Simulation) -> HeadingFloor {
    let white_noise_deg = heading_noise_deg(&true_calibration_doc(run), validation);
    let declination_deg = anomaly_declination_beyond_run_mean_deg(run, validation).unwrap_or(0.0);
    HeadingFloor { floor_deg: white_noise_deg.hypot(declination_deg), white_noise_deg, declination_deg }
}

/// The validation true-heading RMS with the crustal anomaly's declination
/// taken out, °: each row's error plus the anomaly's declination there,
/// minus its mean over the calibration run (which the swing fit against
/// the run's GPS course takes into the heading offset). This is the
/// calibration's own error: a magnetometer cannot see the declination, so
/// even the true calibration has the rest, the anomaly's declination along
/// the validation track beyond the run's mean, in its true-heading error.
/// `None` without the anomaly's true-field columns.
pub fn heading_rms_local_declination_deg(doc: &CalDoc, run: &Simulation, validation: &Simulation) -> Option<f64> {
    let (run_mean, on_val) = anomaly_declination_and_run_mean_rad(run, validation)?;
    let headings = compute::true_headings_rad(doc, &validation.recording);
    let (mut ss, mut n) = (0.0, 0usize);
    for ((h, t), d) in headings.iter().zip(&validation.true_heading_deg).zip(&on_val) {
        let e = calib_core::heading::wrap_pi(h - t.to_radians() + d - run_mean);
        if e.is_finite() {
            ss += e * e;
            n += 1;
        }
    }
    (n > 0).then(|| (ss / n as f64).sqrt().to_degrees())
}

/// What the chain achieved on one simulated field test.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct Outcome {
    /// Turnaround step with the paper's axis fit of the swing test (step 1), nT.
    pub step_axis_fit_nt: f64,
    /// Turnaround step after the paper's back-stepping, nT.
    pub step_paper_nt: f64,
    /// Turnaround step after our back-stepping, nT.
    pub step_ours_nt: f64,
    /// Validation true-heading RMS of step 1 + swing fit, °.
    pub heading_rms_axis_fit_deg: f64,
    /// Validation true-heading RMS of the paper's chain, °.
    pub heading_rms_paper_deg: f64,
    /// Validation true-heading RMS of our chain, °.
    pub heading_rms_ours_deg: f64,
    /// Validation |F| − IGRF RMS after the paper's back-stepping, nT.
    pub field_error_paper_nt: f64,
    /// Validation |F| − IGRF RMS after ours, nT.
    pub field_error_ours_nt: f64,
    /// The GPS delay our chain estimated, s.
    pub gps_delay_ours_s: f64,
}

/// Runs the whole chain on a simulated vehicle: swing test, axis fit, both
/// back-steppings, swing fits, validation.
pub fn evaluate(name: &str, sensor: SensorModel, seed: u64) -> Result<Outcome, ScenarioError> {
    evaluate_with(name, sensor, seed, &Effects::none(), &RunParams::paper_like(), &RunParams::validation())
}

/// The runs of the effects scenarios: a slower survey AUV whose cruise
/// speed differs between legs and missions (calibration run 1.2 / 0.9 m/s
/// on 5 km legs, validation 1.0 / 1.3 m/s on 4 km legs) and no current of
/// their own, so that with every effect off the GPS course is the heading
/// (today's error model) and the current effect alone brings the crab.
pub fn effects_runs() -> (RunParams, RunParams) {
    let run = RunParams { leg_m: 5000.0, speed_mps: 1.2, speed_back_mps: Some(0.9), current_mps: 0.0, ..RunParams::paper_like() };
    let validation = RunParams { leg_m: 4000.0, speed_mps: 1.0, speed_back_mps: Some(1.3), current_mps: 0.0, ..RunParams::validation() };
    (run, validation)
}

/// The effects scenarios for the bench and the tests: none, each of the
/// five alone, all five together (names: `none`, the effect's name, `all`).
pub fn effects_scenarios() -> Vec<(&'static str, Effects)> {
    let mut out = vec![("none", Effects::none())];
    out.extend(Effect::ALL.iter().map(|&e| (e.name(), Effects::of(&[e]))));
    out.push(("all", Effects::all()));
    out
}

/// Today's chain on the effects runs ([`effects_runs`]) with the given
/// effects on (the swing test, the calibration run and the validation run
/// all have them).
pub fn evaluate_effects(name: &str, sensor: SensorModel, seed: u64, effects: &Effects) -> Result<Outcome, ScenarioError> {
    let (run, validation) = effects_runs();
    evaluate_with(name, sensor, seed, effects, &run, &validation)
}

/// The whole chain with effects and run parameters of one's own.
pub fn evaluate_with(name: &str, sensor: SensorModel, seed: u64, effects: &Effects, run: &RunParams, validation: &RunParams) -> Result<Outcome, ScenarioError> {
    let site = paper_site();
    let swing = field_test::swing_with(&sensor, &site, seed, 5.0, 55.0, 10.0, effects)?;
    let run = field_test::run_with(&sensor, &site, run, seed + 100, 2.0, RunKind::Run, effects)?;
    let validation = field_test::run_with(&sensor, &site, validation, seed + 200, 2.0, RunKind::Validation, effects)?;

    let step1 = compute::axis_step(&swing.recording, &site)?;
    let delay = Delay::Estimate { min_s: 0.0, max_s: 5.0 };
    let paper = compute::refine(step1.clone(), &swing.recording, &run.recording, &site, &ChainOptions { method: BackstepMethod::Paper, delay, ..Default::default() })?;
    let ours = compute::refine(step1.clone(), &swing.recording, &run.recording, &site, &ChainOptions { method: BackstepMethod::Joint, delay, ..Default::default() })?;
    let (axis_swung, _, _) = compute::swing_recording(&run.recording, &step1, delay)?;
    let o = Outcome {
        step_axis_fit_nt: paper.backstep.before.step_nt,
        step_paper_nt: paper.backstep.after.step_nt,
        step_ours_nt: ours.backstep.after.step_nt,
        heading_rms_axis_fit_deg: heading_rms_deg(&axis_swung, &validation),
        heading_rms_paper_deg: heading_rms_deg(&paper.final_doc, &validation),
        heading_rms_ours_deg: heading_rms_deg(&ours.final_doc, &validation),
        field_error_paper_nt: field_error_nt(&paper.backstepped, &validation),
        field_error_ours_nt: field_error_nt(&ours.backstepped, &validation),
        gps_delay_ours_s: ours.delay_s,
    };
    eprintln!(
        "{name} seed {seed}: turnaround step {:.0} nT (axis fit) → {:.1} (paper) / {:.1} (ours); validation true-heading RMS {:.2}° / {:.2}° / {:.2}°; field error vs IGRF {:.1} / {:.1} nT (paper / ours); GPS delay {:.2} s",
        o.step_axis_fit_nt, o.step_paper_nt, o.step_ours_nt, o.heading_rms_axis_fit_deg, o.heading_rms_paper_deg, o.heading_rms_ours_deg, o.field_error_paper_nt, o.field_error_ours_nt, o.gps_delay_ours_s
    );
    Ok(o)
}

/// A swing test of limited roll and pitch, with or without a gyro.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct LimitedSwing {
    /// Roll amplitude, degrees.
    pub roll_amp_deg: f64,
    /// Pitch amplitude, degrees.
    pub pitch_amp_deg: f64,
    /// The swing test records a gyro and the chain starts with the
    /// gyro-aided fit (otherwise the paper's axis fit).
    pub gyro: bool,
}

/// What the chain achieved after a limited swing test.
#[derive(Debug, Clone, serde::Serialize)]
pub struct LimitedOutcome {
    /// The swing test.
    pub swing: LimitedSwing,
    /// Validation true-heading RMS of our chain, ° (`None` when refused).
    pub heading_rms_deg: Option<f64>,
    /// Validation |F| − IGRF RMS after the back-stepping, nT.
    pub field_error_nt: Option<f64>,
    /// Why the chain refused, when it did.
    pub refused: Option<String>,
}

/// Our chain (joint back-stepping) after a swing test of the given roll and
/// pitch amplitudes; with a gyro ([`GyroModel::mems`]) the chain starts with
/// the gyro-aided fit. A refusal is an outcome, not an error.
pub fn evaluate_limited(sensor: SensorModel, seed: u64, swing_kind: LimitedSwing) -> Result<LimitedOutcome, ScenarioError> {
    let site = paper_site();
    let mut swing = field_test::swing_limited(&sensor, &site, seed, 5.0, swing_kind.roll_amp_deg, swing_kind.pitch_amp_deg)?;
    if swing_kind.gyro {
        swing = swing.with_gyro(&GyroModel::mems(), seed);
    }
    let run = field_test::run(&sensor, &site, &RunParams::paper_like(), seed + 100, 2.0, RunKind::Run)?;
    let validation = field_test::run(&sensor, &site, &RunParams::validation(), seed + 200, 2.0, RunKind::Validation)?;
    let first_step = if swing_kind.gyro { FirstStep::Gyro } else { FirstStep::Axis };
    let outcome = match compute::calibrate(&swing.recording, &run.recording, &site, &ChainOptions { first_step, ..Default::default() }) {
        Ok(chain) => LimitedOutcome {
            swing: swing_kind,
            heading_rms_deg: Some(heading_rms_deg(&chain.final_doc, &validation)),
            field_error_nt: Some(field_error_nt(&chain.backstepped, &validation)),
            refused: None,
        },
        Err(e) => LimitedOutcome { swing: swing_kind, heading_rms_deg: None, field_error_nt: None, refused: Some(e.to_string()) },
    };
    eprintln!(
        "swing ±{}° roll / ±{}° pitch, {}: {}",
        swing_kind.roll_amp_deg,
        swing_kind.pitch_amp_deg,
        if swing_kind.gyro { "gyro-aided" } else { "axis fit" },
        match (&outcome.heading_rms_deg, &outcome.refused) {
            (Some(h), _) => format!("validation true-heading RMS {h:.3}°, field error {:.1} nT", outcome.field_error_nt.unwrap_or(f64::NAN)),
            (None, Some(r)) => format!("refused: {r}"),
            _ => String::new(),
        }
    );
    Ok(outcome)
}

/// One chain compared on the effects scenarios: ours with every new model,
/// ours with one model switched off, or the paper's method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Variant {
    /// Our chain with every model (the default [`ChainOptions`]).
    Full,
    /// The thrusters' per-ampere vector off (a constant running bias instead).
    NoCurrentTerm,
    /// The temperature gains off.
    NoTemperatureTerm,
    /// The local field's inclination held at IGRF's.
    NoLocalField,
    /// The AHRS misalignment held at zero.
    NoMisalignment,
    /// GPS course used as heading (the water current not removed).
    NoWaterCurrent,
    /// The local field's gradient along the track held at zero (the chain
    /// before the gradient term).
    NoFieldGradient,
    /// The paper's back-stepping (and the swing fit against raw course, as
    /// the paper does).
    Paper,
}

impl Variant {
    /// Every variant, the full chain first.
    pub const ALL: [Variant; 8] = [
        Variant::Full,
        Variant::NoCurrentTerm,
        Variant::NoTemperatureTerm,
        Variant::NoLocalField,
        Variant::NoMisalignment,
        Variant::NoWaterCurrent,
        Variant::NoFieldGradient,
        Variant::Paper,
    ];

    /// A short label for tables.
    pub fn label(self) -> &'static str {
        match self {
            Variant::Full => "ours, all models",
            Variant::NoCurrentTerm => "ours, current term off",
            Variant::NoTemperatureTerm => "ours, temperature term off",
            Variant::NoLocalField => "ours, local field off",
            Variant::NoMisalignment => "ours, misalignment off",
            Variant::NoWaterCurrent => "ours, water current off",
            Variant::NoFieldGradient => "ours, field gradient off",
            Variant::Paper => "paper's method",
        }
    }

    /// The chain's options for this variant.
    pub fn options(self) -> ChainOptions {
        let mut o = ChainOptions::default();
        match self {
            Variant::Full => {}
            Variant::NoCurrentTerm => o.joint.terms.motor_current = false,
            Variant::NoTemperatureTerm => o.joint.terms.temperature = false,
            Variant::NoLocalField => o.joint.terms.local_field = false,
            Variant::NoMisalignment => o.joint.terms.misalignment = false,
            Variant::NoWaterCurrent => o.water_current = WaterCurrentMode::Off,
            Variant::NoFieldGradient => o.joint.terms.field_gradient = false,
            Variant::Paper => {
                o.method = BackstepMethod::Paper;
                o.water_current = WaterCurrentMode::Off;
            }
        }
        o
    }
}

/// What one chain achieved on one effects scenario, against the truth.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct EffectsOutcome {
    /// Validation true-heading RMS, °.
    pub heading_rms_deg: f64,
    /// The same with the crustal anomaly's declination along the tracks
    /// taken out ([`heading_rms_local_declination_deg`]): the calibration's
    /// own error, °. `None` without the anomaly.
    pub heading_rms_local_declination_deg: Option<f64>,
    /// The validation heading error's white-noise part, °: from the
    /// differences of consecutive errors (`RMS(e_i − e_{i−1})/√2`), what no
    /// calibration removes (sensor and AHRS noise sample by sample).
    pub heading_noise_deg: f64,
    /// The rest of the heading RMS, `√(RMS² − noise²)`, °: what a
    /// calibration's error (and the local field) leaves, the part the
    /// covariance predicts.
    pub heading_systematic_deg: f64,
    /// Validation |F| error against the true local field (RMS), nT; `None`
    /// without the anomaly effect (the true field is then IGRF's, see
    /// `field_error_igrf_nt`).
    pub field_error_true_nt: Option<f64>,
    /// Validation |F| − IGRF RMS, nT.
    pub field_error_igrf_nt: f64,
    /// |estimated − true per-ampere vector| / |true|, % (`None` without the
    /// thruster effect or when the chain estimated no per-ampere vector).
    pub current_vector_error_pct: Option<f64>,
    /// Largest per-axis |estimated − true gain change|, %/°C (`None`
    /// without the temperature effect or when no gains were estimated).
    pub gain_error_pct_per_c: Option<f64>,
    /// The heading RMS the chain predicts ([`host_tools::compute::Chain::predicted_heading_rms_deg`]:
    /// the back-stepping's covariance and the run's white heading noise), °.
    pub predicted_heading_rms_deg: Option<f64>,
    /// The back-stepping's covariance alone, °.
    pub predicted_calibration_deg: Option<f64>,
    /// The run's white heading noise as the chain measured it, °.
    pub run_heading_noise_deg: Option<f64>,
    /// Observed (validation) over predicted heading RMS.
    pub observed_over_predicted: Option<f64>,
    /// The GPS delay used, s (truth 2 s).
    pub gps_delay_s: f64,
}

/// The simulated data of one effects scenario: swing test, calibration
/// run, validation run ([`effects_runs`]).
pub struct EffectsData {
    /// The swing test.
    pub swing: Simulation,
    /// The calibration (out-and-back) run.
    pub run: Simulation,
    /// The validation run.
    pub validation: Simulation,
}

impl EffectsData {
    /// The validation run's true-heading floor ([`heading_floor`]): from
    /// the truth only, the same whichever chain is run on the data.
    pub fn floor(&self) -> HeadingFloor {
        heading_floor(&self.run, &self.validation)
    }
}

/// Simulates one effects scenario (the seeds as [`evaluate_effects`] uses them).
pub fn effects_data(sensor: &SensorModel, seed: u64, effects: &Effects) -> Result<EffectsData, ScenarioError> {
    effects_data_at(sensor, &paper_site(), seed, effects)
}

/// Simulates one effects scenario at a site of one's own (the runs of
/// [`effects_runs`] start there; the seeds as [`effects_data`]).
pub fn effects_data_at(sensor: &SensorModel, site: &Site, seed: u64, effects: &Effects) -> Result<EffectsData, ScenarioError> {
    let site = *site;
    let (run, validation) = effects_runs();
    Ok(EffectsData {
        swing: field_test::swing_with(sensor, &site, seed, 5.0, 55.0, 10.0, effects)?,
        run: field_test::run_with(sensor, &site, &run, seed + 100, 2.0, RunKind::Run, effects)?,
        validation: field_test::run_with(sensor, &site, &validation, seed + 200, 2.0, RunKind::Validation, effects)?,
    })
}

/// Runs one chain variant on simulated effects data and scores it against
/// the truth.
pub fn evaluate_variant(data: &EffectsData, variant: Variant) -> Result<EffectsOutcome, ComputeError> {
    evaluate_options(data, &variant.options())
}

/// The five effects at one of [`crate::varied::varied_sites`] with
/// magnitudes drawn by `seed` ([`crate::varied::varied_effects`]),
/// simulated with the seeds of [`effects_data`].
pub fn varied_effects_data(sensor: &SensorModel, site: &Site, seed: u64) -> Result<EffectsData, ScenarioError> {
    let effects = crate::varied::varied_effects(site, seed)?;
    effects_data_at(sensor, site, seed, &effects)
}

/// The chain with options of one's own on simulated effects data (at the
/// data's own site), scored against the truth.
pub fn evaluate_options(data: &EffectsData, options: &ChainOptions) -> Result<EffectsOutcome, ComputeError> {
    let site = data.swing.truth.site;
    let chain = compute::calibrate(&data.swing.recording, &data.run.recording, &site, options)?;
    let heading_rms_deg = heading_rms_deg(&chain.final_doc, &data.validation);
    let heading_noise_deg = heading_noise_deg(&chain.final_doc, &data.validation);
    let truth = data.run.truth.effects.as_ref();
    let joint = chain.backstep.joint.as_ref();
    let current_vector_error_pct = match (truth.and_then(|t| t.thrusters.as_ref()), joint) {
        (Some(t), Some(j)) if j.current_estimated => {
            let (est, tru) = (j.env.bias_per_a, t.raw_per_a);
            let diff = ((est[0] - tru[0]).powi(2) + (est[1] - tru[1]).powi(2) + (est[2] - tru[2]).powi(2)).sqrt();
            let norm = (tru[0].powi(2) + tru[1].powi(2) + tru[2].powi(2)).sqrt();
            Some(100.0 * diff / norm)
        }
        _ => None,
    };
    let gain_error_pct_per_c = match (truth.and_then(|t| t.temperature.as_ref()), joint) {
        (Some(t), Some(j)) if j.temperature_estimated => {
            Some(100.0 * (0..3).map(|k| (j.env.gain_per_c[k] - t.gain_per_c[k]).abs()).fold(0.0, f64::max))
        }
        _ => None,
    };
    let predicted_heading_rms_deg = chain.predicted_heading_rms_deg.filter(|p| p.is_finite() && *p > 0.0);
    Ok(EffectsOutcome {
        heading_rms_deg,
        heading_rms_local_declination_deg: heading_rms_local_declination_deg(&chain.final_doc, &data.run, &data.validation),
        heading_noise_deg,
        heading_systematic_deg: (heading_rms_deg.powi(2) - heading_noise_deg.powi(2)).max(0.0).sqrt(),
        field_error_true_nt: field_error_true_nt(&chain.backstepped, &data.validation),
        field_error_igrf_nt: field_error_nt(&chain.backstepped, &data.validation),
        current_vector_error_pct,
        gain_error_pct_per_c,
        predicted_heading_rms_deg,
        predicted_calibration_deg: chain.backstepped.quality.predicted_heading_rms_deg,
        run_heading_noise_deg: chain.heading_noise_deg,
        observed_over_predicted: predicted_heading_rms_deg.map(|p| heading_rms_deg / p),
        gps_delay_s: chain.delay_s,
    })
}
