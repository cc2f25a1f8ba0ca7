//! The simulated vehicle: the simulator's swing test, run and validation run
//! played into the QEMU board's sensor feed (USART2: the field at the
//! bridges) in lock-step with the board's samples, as a
//! [`host_tools::session::Vehicle`]. The session does not know it is
//! simulated; the true heading of every step comes with the validation run.

use std::io::Write;

use host_tools::board::{ClientError, FeedWriter};
use host_tools::geomag::Site;
use host_tools::session::{Phase, SessionError, Step, Vehicle};

use crate::field_test::{self, RunParams, SensorModel, Simulation};

/// How long the simulated field tests are (the demo drives them through the
/// QEMU board in lock-step, one feed frame per sample).
#[derive(Debug, Clone, Copy, serde::Serialize)]
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
}

impl SimPlan {
    /// `cargo xtask demo`: the paper's swing test, 3 km legs.
    pub fn demo() -> Self {
        Self { swing_rate_hz: 0.5, run_leg_m: 3000.0, run_rate_hz: 0.5, validation_leg_m: 1500.0, validation_rate_hz: 0.5, submerged_s: 1000.0, surface_s: 50.0, seed: 7 }
    }

    /// The test suite's shortened scenario.
    pub fn short() -> Self {
        Self { swing_rate_hz: 0.25, run_leg_m: 1500.0, run_rate_hz: 0.5, validation_leg_m: 750.0, validation_rate_hz: 0.25, submerged_s: 300.0, surface_s: 40.0, seed: 7 }
    }
}

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
        let sensor = SensorModel::board_like();
        let dolphin = |p: RunParams| RunParams { submerged_s: plan.submerged_s, surface_s: plan.surface_s, ..p };
        let swing = field_test::swing(&sensor, site, plan.seed, plan.swing_rate_hz)?;
        let run = field_test::run(&sensor, site, &dolphin(RunParams { leg_m: plan.run_leg_m, ..RunParams::paper_like() }), plan.seed + 1, plan.run_rate_hz, "run")?;
        let validation = field_test::run(&sensor, site, &dolphin(RunParams { leg_m: plan.validation_leg_m, ..RunParams::validation() }), plan.seed + 2, plan.validation_rate_hz, "validation")?;
        Ok(Self { plan, feed, manoeuvres: [swing, run, validation], current: None, next: 0 })
    }

    /// The simulation of a manoeuvre (with its truth).
    pub fn simulation(&self, phase: Phase) -> &Simulation {
        &self.manoeuvres[slot(phase)]
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
        };
        // The simulator's `mag` column is the field at the bridges in nT;
        // its `temp_c` the sensor's temperature, which the board's ADC model
        // turns into the thermistor's voltage (the board measures it).
        let temp_c = Some(col(&r.temp_c)).filter(|t| t.is_finite()).map(|t| t as f32);
        let seq = self.feed.send_env(r.mag[i].map(|v| v as f32), BRIDGE_OFFSETS_COUNTS, temp_c)?;
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
        format!(
            "simulated (magcal-sim, board-like sensor, seed {}): swing test at {} Hz; run {} m legs at {} Hz; validation {} m legs at {} Hz; dolphin {} s submerged / {} s at the surface",
            p.seed, p.swing_rate_hz, p.run_leg_m, p.run_rate_hz, p.validation_leg_m, p.validation_rate_hz, p.submerged_s, p.surface_s
        )
    }
}
