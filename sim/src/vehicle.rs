//! The simulated vehicle: the simulator's swing test, run and validation run
//! played into the QEMU board's sensor feed (USART2: the field at the
//! bridges) in lock-step with the board's samples, as a
//! [`host_tools::session::Vehicle`]. The session does not know it is
//! simulated; the true heading of every step comes with the validation run.

use std::io::Write;

use host_tools::board::{ClientError, FeedWriter};
use host_tools::geomag::Site;
use host_tools::session::{Phase, SessionError, Step, Vehicle};

use crate::effects::Effects;
use crate::field_test::{self, RunKind, RunParams, SensorModel, Simulation};

/// How long the simulated field tests are (the demo drives them through the
/// QEMU board in lock-step, one feed frame per sample), and which
/// real-vehicle effects they have.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SimPlan {
    /// Swing-test sample rate, Hz.
    pub swing_rate_hz: f64,
    /// Calibration run: leg length, m.
    pub run_leg_m: f64,
    /// Calibration run: sample rate, Hz.
    pub run_rate_hz: f64,
    /// Validation run: leg length, m.
    pub validation_leg_m: f64,
    /// Validation run: sample rate, Hz.
    pub validation_rate_hz: f64,
    /// Dolphin profile: time submerged, s.
    pub submerged_s: f64,
    /// Dolphin profile: time at the surface, s.
    pub surface_s: f64,
    /// Seed.
    pub seed: u64,
    /// The real-vehicle effects of the swing test, the run and the
    /// validation run ([`Effects::none`]: the simulator's original model).
    pub effects: Effects,
}

impl SimPlan {
    /// `cargo xtask demo`: the paper's swing test, 3 km legs.
    pub fn demo() -> Self {
        Self { swing_rate_hz: 0.5, run_leg_m: 3000.0, run_rate_hz: 0.5, validation_leg_m: 1500.0, validation_rate_hz: 0.5, submerged_s: 1000.0, surface_s: 50.0, seed: 7, effects: Effects::none() }
    }

    /// The test suite's shortened scenario.
    pub fn short() -> Self {
        Self { swing_rate_hz: 0.25, run_leg_m: 1500.0, run_rate_hz: 0.5, validation_leg_m: 750.0, validation_rate_hz: 0.25, submerged_s: 300.0, surface_s: 40.0, seed: 7, effects: Effects::none() }
    }

    /// The same plan with `effects` on.
    pub fn with_effects(self, effects: Effects) -> Self {
        Self { effects, ..self }
    }

    /// The run and validation parameters: the plan's legs and dolphin
    /// profile; with effects on, the speeds of the effects scenarios
    /// ([`crate::scenario::effects_runs`]: a survey AUV at 1.2 / 0.9 m/s on
    /// the run and 1.0 / 1.3 m/s on the validation, so the thrusters'
    /// current differs between legs, and no current of the run's own — the
    /// current effect brings the water's).
    pub fn run_params(&self) -> (RunParams, RunParams) {
        let (run, validation) = if self.effects.is_none() { (RunParams::paper_like(), RunParams::validation()) } else { crate::scenario::effects_runs() };
        let plan = |p: RunParams, leg_m: f64| RunParams { leg_m, submerged_s: self.submerged_s, surface_s: self.surface_s, ..p };
        (plan(run, self.run_leg_m), plan(validation, self.validation_leg_m))
    }

    /// The plan's swing test, run and validation run for the board-like
    /// sensor at `site`, with the plan's effects.
    pub fn simulate(&self, site: &Site) -> Result<[Simulation; 3], field_test::SimError> {
        let sensor = SensorModel::board_like();
        let e = &self.effects;
        let (run_params, validation_params) = self.run_params();
        let swing = field_test::swing_with(&sensor, site, self.seed, self.swing_rate_hz, 55.0, 10.0, e)?;
        let run = field_test::run_with(&sensor, site, &run_params, self.seed + 1, self.run_rate_hz, RunKind::Run, e)?;
        let validation = field_test::run_with(&sensor, site, &validation_params, self.seed + 2, self.validation_rate_hz, RunKind::Validation, e)?;
        Ok([swing, run, validation])
    }
}

/// The effects of the test suite's short session (`cargo xtask test`): all
/// but the crustal anomaly. The chain takes IGRF as the field's intensity,
/// so with the anomaly its |F| is off the true local field by tens of nT
/// (52 nT on the short plan, against the test's 30 nT bound); the demo runs
/// all five and reports that.
pub const SHORT_TEST_EFFECTS: &str = "thrusters,temperature,ahrs,current";

/// Bridge offsets the QEMU ADC model adds (removed by set/reset), counts.
pub const BRIDGE_OFFSETS_COUNTS: [f32; 3] = [120_000.0, -95_000.0, 33_000.0];

/// The simulator's field tests played into the QEMU board.
pub struct SimVehicle<W> {
    plan: SimPlan,
    feed: FeedWriter<W>,
    manoeuvres: [Simulation; 3],
    current: Option<usize>,
    next: usize,
}

impl<W: Write> SimVehicle<W> {
    /// Simulates the plan's swing test, run and validation run for the
    /// board-like sensor at `site`, to be played into `feed`.
    pub fn new(plan: SimPlan, site: &Site, feed: FeedWriter<W>) -> Result<Self, field_test::SimError> {
        let manoeuvres = plan.simulate(site)?;
        Ok(Self { plan, feed, manoeuvres, current: None, next: 0 })
    }

    /// The simulation of a manoeuvre (with its truth).
    pub fn simulation(&self, phase: Phase) -> &Simulation {
        &self.manoeuvres[slot(phase)]
    }
}

/// The magnitude of the true local field at step `i`, nT (with the
/// anomaly effect, IGRF plus the crustal bodies; NaN otherwise, when IGRF
/// at the logged position is the truth).
fn true_field_nt(sim: &Simulation, i: usize) -> f64 {
    let at = |name: &str| sim.effect_column(name).and_then(|c| c.get(i).copied());
    match (at("true_field_n_nt"), at("true_field_e_nt"), at("true_field_d_nt")) {
        (Some(n), Some(e), Some(d)) => (n * n + e * e + d * d).sqrt(),
        _ => f64::NAN,
    }
}

fn slot(phase: Phase) -> usize {
    match phase {
        Phase::Swing => 0,
        Phase::Run => 1,
        Phase::Validation => 2,
    }
}

impl<W: Write> Vehicle for SimVehicle<W> {
    fn begin(&mut self, phase: Phase) -> Result<bool, SessionError> {
        self.current = Some(slot(phase));
        self.next = 0;
        Ok(true)
    }

    fn next_step(&mut self) -> Result<Option<Step>, ClientError> {
        let Some(sim) = self.current.and_then(|k| self.manoeuvres.get(k)) else { return Ok(None) };
        let r = &sim.recording;
        let i = self.next;
        if i >= r.len() {
            return Ok(None);
        }
        self.next += 1;
        let col = |c: &Option<Vec<f64>>| c.as_ref().and_then(|v| v.get(i).copied()).unwrap_or(f64::NAN);
        let step = Step {
            t_s: col(&r.t_s),
            roll_deg: col(&r.roll_deg),
            pitch_deg: col(&r.pitch_deg),
            ref_heading_deg: col(&r.ref_heading_deg),
            lat_deg: col(&r.lat_deg),
            lon_deg: col(&r.lon_deg),
            true_heading_deg: sim.true_heading_deg.get(i).copied().unwrap_or(f64::NAN),
            feed_seq: None,
            rate_rad_s: [col(&r.gx_rad_s), col(&r.gy_rad_s), col(&r.gz_rad_s)],
            // Sent to the board with the attitude (when the session sends it).
            motor_current_a: col(&r.motor_current_a),
            speed_mps: col(&r.speed_mps),
            true_field_nt: true_field_nt(sim, i),
        };
        // The simulator's `mag` column of the board-like sensor is the field
        // at the bridges in nT with every effect already in it once (the
        // thrusters' field, the bridge gain of the sensor's temperature,
        // the anomaly): the board's ADC model only adds its chain gain and
        // the bridge offsets. The temperature fed is the sensor's own
        // (`sensor_temp_c`, the truth): the board's thermistor next to the
        // sensor measures it, so the recorded `temp_c` is the board's
        // reading, not the simulator's logged column with its own
        // thermistor error.
        let temp_c = sim.effect_column("sensor_temp_c").and_then(|c| c.get(i).copied()).filter(|t| t.is_finite()).map(|t| t as f32);
        let field_nt = r.mag.get(i).copied().unwrap_or([f64::NAN; 3]);
        let seq = self.feed.send_env(field_nt.map(|v| v as f32), BRIDGE_OFFSETS_COUNTS, temp_c)?;
        Ok(Some(Step { feed_seq: Some(seq), ..step }))
    }

    fn len_hint(&self) -> Option<usize> {
        self.current.and_then(|k| self.manoeuvres.get(k)).map(|s| s.recording.len())
    }

    fn repeat(&mut self) -> Result<(), ClientError> {
        self.feed.resend()
    }

    fn sends_attitude(&self) -> bool {
        false
    }

    fn describe(&self) -> String {
        let p = &self.plan;
        let effects = p.effects.list();
        let effects = if effects.is_empty() { "none".to_string() } else { effects.iter().map(|e| e.name()).collect::<Vec<_>>().join(", ") };
        format!(
            "simulated (magcal-sim, board-like sensor, seed {}): swing test at {} Hz; run {} m legs at {} Hz; validation {} m legs at {} Hz; dolphin {} s submerged / {} s at the surface; effects: {effects}",
            p.seed, p.swing_rate_hz, p.run_leg_m, p.run_rate_hz, p.validation_leg_m, p.validation_rate_hz, p.submerged_s, p.surface_s
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field_test::paper_site;
    use crate::scenario;
    use host_tools::compute::{self, ChainOptions};

    /// The recording as the session records it from the board: the
    /// temperature column is the board's thermistor reading of the fed
    /// sensor temperature (`sensor_temp_c`), not the simulator's logged one.
    fn as_the_board_records(sim: &Simulation) -> Simulation {
        let mut out = sim.clone();
        if let Some(t) = sim.effect_column("sensor_temp_c") {
            out.recording.temp_c = Some(t.to_vec());
        }
        out
    }

    /// The effects reach the field fed to the bridges once: the fed field
    /// (the `mag` column of the board-like sensor) is the outside field
    /// through `D`, plus the hard iron, the thrusters' dipoles through `D`,
    /// all times the bridge gain of the sensor's temperature — recomputed
    /// here from the effect models' own truth columns, noise (3 nT) aside.
    #[test]
    fn the_fed_field_carries_each_effect_once() {
        let site = paper_site();
        let plan = SimPlan::short().with_effects(Effects::all());
        let [_, run, _] = plan.simulate(&site).unwrap();
        let e = Effects::all();
        let (thermal, thrusters) = (e.temperature.unwrap(), e.thrusters.unwrap());
        let sensor = SensorModel::board_like();
        let col = |n: &str| run.effect_column(n).unwrap().to_vec();
        let (fnn, fe, fd, temp) = (col("true_field_n_nt"), col("true_field_e_nt"), col("true_field_d_nt"), col("sensor_temp_c"));
        let (i0, i1) = (col("thruster_0_a"), col("thruster_1_a"));
        let mut worst: f64 = 0.0;
        for i in (0..run.recording.len()).step_by(7) {
            let h = calib_core::heading::ned_to_body([fnn[i], fe[i], fd[i]], run.true_roll_deg[i].to_radians(), run.true_pitch_deg[i].to_radians(), run.true_heading_deg[i].to_radians());
            let th = thrusters.field_nt(&[i0[i], i1[i]]);
            let gain = thermal.gain(temp[i]);
            for (k, (d, g)) in sensor.gain_raw_per_nt.iter().zip(gain).enumerate() {
                let expected = g * (d[0] * (h[0] + th[0]) + d[1] * (h[1] + th[1]) + d[2] * (h[2] + th[2]) + sensor.bias_raw[k]);
                worst = worst.max((run.recording.mag[i][k] - expected).abs());
            }
        }
        // Noise 3 nT (1σ) plus rounding: measured worst 10.3 nT over ~640
        // values (3.4σ); a missing or doubled effect is 20–300 nT.
        assert!(worst < 20.0, "fed field departs from the physics by {worst} nT");
    }

    /// The chain as the session runs it on a plan; (observed validation
    /// true-heading RMS °, predicted °, field error nT against the true
    /// local field with the anomaly, else against IGRF).
    fn chain_on(plan: SimPlan) -> (f64, f64, f64) {
        let site = paper_site();
        let [swing, run, validation] = plan.simulate(&site).unwrap().map(|s| as_the_board_records(&s));
        assert!(run.recording.speed_mps.is_some() == plan.effects.water_current.is_some());
        let chain = compute::calibrate(&swing.recording, &run.recording, &site, &ChainOptions::default()).unwrap();
        let observed = scenario::heading_rms_deg(&chain.final_doc, &validation);
        let predicted = chain.final_doc.quality.predicted_heading_rms_deg.unwrap();
        let field = scenario::field_error_true_nt(&chain.final_doc, &validation).unwrap_or_else(|| scenario::field_error_nt(&chain.final_doc, &validation));
        (observed, predicted, field)
    }

    /// The test suite's short session ([`SHORT_TEST_EFFECTS`]: all but the
    /// anomaly) offline, the temperature as the board reads it.
    #[test]
    fn the_short_test_plan_meets_the_test_bounds_offline() {
        let plan = SimPlan::short().with_effects(Effects::parse(SHORT_TEST_EFFECTS).unwrap());
        let (observed, predicted, field) = chain_on(plan);
        eprintln!("short plan, {SHORT_TEST_EFFECTS}: observed {observed:.3}° predicted {predicted:.3}° field vs IGRF {field:.1} nT");
        // Measured: 0.266° (predicted 0.155°), 16.0 nT; `cargo xtask test`'s bounds are 0.35° and 30 nT.
        assert!(observed < 0.35 && predicted > 0.0 && predicted < observed * 3.0, "{observed} {predicted}");
        assert!(field < 30.0, "{field}");
    }

    /// The demo's plan with all five effects offline: the heading holds; the
    /// field against the true local field does not (the chain's |F|
    /// reference is IGRF, which the anomaly makes 100–300 nT wrong).
    #[test]
    fn the_demo_plan_with_all_effects_offline() {
        let (observed, predicted, field) = chain_on(SimPlan::demo().with_effects(Effects::all()));
        eprintln!("demo plan, all effects: observed {observed:.3}° predicted {predicted:.3}° field vs truth {field:.1} nT");
        // Measured: 0.304° (predicted 0.275°), 123 nT against the true field.
        assert!(observed < 0.5 && predicted > 0.0 && predicted < observed * 3.0, "{observed} {predicted}");
        assert!(field.is_finite() && field < 250.0, "{field}");
    }
}
