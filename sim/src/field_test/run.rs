//! The out-and-back run: its parameters, the autopilot's profile (legs,
//! surface turn, dolphin dives, crab into the current) and the loop that
//! plays it through the kinematics and the sensor.

use std::f64::consts::TAU;

use serde::{Deserialize, Serialize};

use host_tools::geomag::Site;

use super::kinematics::{Kinematics, Motion};
use super::rows::{Row, RowEnv, Rows};
use super::{check_rate, FieldTest, SensorModel, SimError, Simulation, Truth};
use crate::effects::Effects;

/// The longest leg the simulator runs, m (100 km: a day's survey line).
pub const MAX_LEG_M: f64 = 100_000.0;
// The refusal states it in words.
const _: () = assert!(MAX_LEG_M == 100_000.0);

/// The fastest speed through water the simulator runs, m/s (about 20 kn).
pub const MAX_SPEED_MPS: f64 = 10.0;
// The refusal states it in words.
const _: () = assert!(MAX_SPEED_MPS == 10.0);

/// Parameters of an out-and-back run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunParams {
    /// Course of the outbound leg, degrees true.
    pub course_out_deg: f64,
    /// Course of the return leg, degrees true.
    pub course_back_deg: f64,
    /// Length of each leg, metres.
    pub leg_m: f64,
    /// Speed through the water, m/s.
    pub speed_mps: f64,
    /// Speed of the current, m/s.
    pub current_mps: f64,
    /// Direction the current flows towards, degrees true.
    pub current_to_deg: f64,
    /// Delay of the GPS course behind the truth, seconds.
    pub gps_delay_s: f64,
    /// GPS course noise, degrees (1σ).
    pub gps_noise_deg: f64,
    /// Time submerged between surfacings, seconds.
    pub submerged_s: f64,
    /// Time at the surface each time, seconds.
    pub surface_s: f64,
    /// Speed through the water on the return leg, m/s (`None`: `speed_mps`;
    /// cruise speed differs between legs when the autopilot's setpoint does).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speed_back_mps: Option<f64>,
    /// Time spent circling at the surface before the outbound leg, s (0:
    /// none). The vehicle turns to starboard one full circle every
    /// [`CIRCLE_PERIOD_S`] at `speed_mps`, ending on the outbound course,
    /// with the GPS course over ground all along; then the legs with their
    /// dives, as without.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub circles_s: f64,
    /// How fast the vehicle can change its pitch and roll, degrees per
    /// second (`None`: at once — the original profile, whose dives start
    /// with a step of pitch within one sample). A real vehicle pitches into
    /// a dive over seconds; the steps give a clock search features no
    /// vehicle shows.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_attitude_rate_deg_s: Option<f64>,
    /// The waves' roll at the surface, degrees (amplitude, 6 s period; the
    /// pitch half of it at 7 s): 4° in paper 000's run, 1° in a calm sea.
    #[serde(default = "default_wave_roll_deg", skip_serializing_if = "is_default_wave_roll")]
    pub wave_roll_deg: f64,
}

/// Paper 000's waves, degrees of roll at the surface.
const PAPER_WAVE_ROLL_DEG: f64 = 4.0;

fn default_wave_roll_deg() -> f64 {
    PAPER_WAVE_ROLL_DEG
}

fn is_default_wave_roll(v: &f64) -> bool {
    *v == PAPER_WAVE_ROLL_DEG
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

/// One circle at the surface before the legs ([`RunParams::circles_s`])
/// takes this long, s: a turning circle of about 29 m (three vehicle
/// lengths, a small AUV's) at 2 m/s, 8°/s of yaw.
pub const CIRCLE_PERIOD_S: f64 = 45.0;

/// Standard gravity, m/s² (the bank of a coordinated turn).
const G_MPS2: f64 = 9.806_65;

impl RunParams {
    /// Paper 000's run: 62° / −117°, 7 km legs, dolphin 1000 s / 50 s, GPS 2 s late.
    pub fn paper_like() -> Self {
        Self {
            course_out_deg: 62.0,
            course_back_deg: -117.0,
            leg_m: 7000.0,
            speed_mps: 2.0,
            current_mps: 0.1,
            current_to_deg: 150.0,
            gps_delay_s: 2.0,
            gps_noise_deg: 0.3,
            submerged_s: 1000.0,
            surface_s: 50.0,
            speed_back_mps: None,
            circles_s: 0.0,
            max_attitude_rate_deg_s: None,
            wave_roll_deg: PAPER_WAVE_ROLL_DEG,
        }
    }

    /// Paper 000's run in a calm sea (1° of roll at the surface) after
    /// `circles_s` of circles at the surface ([`Self::circles_s`]), pitch
    /// and roll changing at most 2°/s (a dive is entered over 6 s): the
    /// shape of a run whose navigation log has no heading but the GPS
    /// course. The surface circles turn through every heading while roll
    /// and pitch hardly move; the legs hold two headings and dive.
    pub fn circles_then_legs(circles_s: f64) -> Self {
        Self { circles_s, max_attitude_rate_deg_s: Some(2.0), wave_roll_deg: 1.0, ..Self::paper_like() }
    }

    /// A second run for validation: other courses, so headings not used in
    /// the calibration are checked too.
    pub fn validation() -> Self {
        Self { course_out_deg: 150.0, course_back_deg: 330.0, leg_m: 4000.0, current_to_deg: 40.0, ..Self::paper_like() }
    }
}

/// Which of the two runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunKind {
    /// The calibration run.
    Run,
    /// The validation run.
    Validation,
}

impl From<RunKind> for FieldTest {
    fn from(kind: RunKind) -> Self {
        match kind {
            RunKind::Run => FieldTest::Run,
            RunKind::Validation => FieldTest::Validation,
        }
    }
}

/// The autopilot's plan of a run: two legs, a surface turn of [`Self::TURN_S`]
/// between them, dolphin dives on the legs.
struct Profile<'a> {
    params: &'a RunParams,
    speed_back_mps: f64,
    leg_s: f64,
    total_s: f64,
    cycle_s: f64,
    /// Course change over the turn, through the shorter side, degrees.
    sweep_deg: f64,
    /// The current the autopilot crabs into: speed (m/s), towards (degrees).
    current: (f64, f64),
}

impl<'a> Profile<'a> {
    const TURN_S: f64 = 90.0;

    /// The plan, or why the parameters cannot make a run.
    fn new(params: &'a RunParams, effects: &Effects) -> Result<Self, SimError> {
        let speed_back_mps = params.speed_back_mps.unwrap_or(params.speed_mps);
        if !(params.leg_m > 0.0 && params.speed_mps > 0.0 && speed_back_mps > 0.0 && params.submerged_s > 0.0 && params.surface_s > 0.0) {
            return Err(SimError::Parameter { what: "leg length, speeds and dolphin times", got: format!("{} m, {} / {speed_back_mps} m/s, {} / {} s", params.leg_m, params.speed_mps, params.submerged_s, params.surface_s), allowed: "positive" });
        }
        if !(0.0..=45.0).contains(&params.wave_roll_deg) {
            return Err(SimError::Parameter { what: "the waves' roll, degrees", got: format!("{}", params.wave_roll_deg), allowed: "within 0…45°" });
        }
        if !(params.circles_s >= 0.0 && params.circles_s <= 100.0 * CIRCLE_PERIOD_S) {
            return Err(SimError::Parameter { what: "the circles' time, s", got: format!("{}", params.circles_s), allowed: "within 0 s and a hundred circles" });
        }
        if params.max_attitude_rate_deg_s.is_some_and(|r| !(r > 0.0 && r.is_finite())) {
            return Err(SimError::Parameter { what: "the attitude rate limit, °/s", got: format!("{:?}", params.max_attitude_rate_deg_s), allowed: "positive" });
        }
        if params.leg_m > MAX_LEG_M {
            return Err(SimError::Parameter { what: "a leg, m", got: format!("{}", params.leg_m), allowed: "at most 100000 m (the simulator's limit)" });
        }
        if params.speed_mps > MAX_SPEED_MPS || speed_back_mps > MAX_SPEED_MPS {
            return Err(SimError::Parameter { what: "the speeds out and back, m/s", got: format!("{} / {speed_back_mps}", params.speed_mps), allowed: "at most 10 m/s (the simulator's limit)" });
        }
        if !(params.course_out_deg.is_finite() && params.course_back_deg.is_finite()) {
            return Err(SimError::Parameter { what: "the courses out and back, degrees", got: format!("{} / {}", params.course_out_deg, params.course_back_deg), allowed: "finite" });
        }
        let current = effects.water_current.as_ref().map_or((params.current_mps, params.current_to_deg), |w| (w.current_mps, w.current_to_deg));
        if !current.1.is_finite() {
            return Err(SimError::Parameter { what: "the current's direction, degrees", got: format!("{}", current.1), allowed: "finite" });
        }
        if !(current.0 >= 0.0 && current.0 < params.speed_mps.min(speed_back_mps) && params.gps_delay_s >= 0.0 && params.gps_delay_s < 60.0) {
            return Err(SimError::Parameter { what: "the current and the GPS delay", got: format!("{} m/s, {} s", current.0, params.gps_delay_s), allowed: "slower than the vehicle, and within 0…60 s" });
        }
        let leg_s = params.leg_m / params.speed_mps;
        let leg_back_s = params.leg_m / speed_back_mps;
        let total_s = params.circles_s + if params.speed_back_mps.is_none() { 2.0 * leg_s + Self::TURN_S } else { leg_s + Self::TURN_S + leg_back_s };
        let sweep_deg = calib_core::heading::wrap_pi((params.course_back_deg - params.course_out_deg).to_radians()).to_degrees();
        Ok(Self { params, speed_back_mps, leg_s, total_s, cycle_s: params.submerged_s + params.surface_s, sweep_deg, current })
    }

    /// The motion at `t`: course, surfacing, speed, pitch (dive after each
    /// surfacing, climb before the next), and the heading that holds the
    /// course over ground against the cross-current (crab angle
    /// `asin(c⊥/V)`, which changes sign on the reciprocal leg); and the roll
    /// (degrees).
    fn at(&self, t: f64) -> (Motion, f64) {
        if t < self.params.circles_s {
            return self.circling(t);
        }
        // The legs' clock starts after the circles (the run without circles unchanged).
        let t = t - self.params.circles_s;
        let (p, leg_s, turn_s, cycle) = (self.params, self.leg_s, Self::TURN_S, self.cycle_s);
        let (course, surfaced, turning) = if t < leg_s {
            (p.course_out_deg, (t % cycle) < p.surface_s, false)
        } else if t < leg_s + turn_s {
            (p.course_out_deg + self.sweep_deg * (t - leg_s) / turn_s, true, true)
        } else {
            let tb = t - leg_s - turn_s;
            (p.course_back_deg, (tb % cycle) < p.surface_s, false)
        };
        let speed = if t < leg_s + turn_s / 2.0 { p.speed_mps } else { self.speed_back_mps };
        let phase = if t < leg_s { t % cycle } else if turning { 0.0 } else { (t - leg_s - turn_s) % cycle };
        let pitch = if surfaced {
            0.5 * p.wave_roll_deg * (TAU * t / 7.0).sin()
        } else if phase < p.surface_s + 40.0 {
            -12.0
        } else if phase > cycle - 40.0 {
            12.0
        } else {
            0.5 * (TAU * t / 60.0).sin()
        };
        let roll = if surfaced { p.wave_roll_deg * (TAU * t / 6.0).sin() } else { 1.0 * (TAU * t / 45.0).sin() };
        let (current_mps, current_to_deg) = self.current;
        let cross = current_mps * (current_to_deg - course).to_radians().sin();
        let crab = (cross / speed).clamp(-0.5, 0.5).asin().to_degrees();
        let heading = course - crab + if turning { 0.0 } else { 1.5 * (TAU * t / 90.0).sin() };
        (Motion { surfaced, speed_mps: speed, pitch_deg: pitch, heading_deg: heading, crab_deg: crab }, roll)
    }
}

impl Profile<'_> {
    /// The motion while circling at the surface (`t` before
    /// [`RunParams::circles_s`]): the course over ground turning to starboard
    /// at 360° per [`CIRCLE_PERIOD_S`], reaching the outbound course as the
    /// circles end; the heading crabbed into the current as on the legs;
    /// the roll the bank of a coordinated turn, `atan(v·ω/g)`, plus the
    /// waves' rolling, the pitch the waves' (as at a surfacing).
    fn circling(&self, t: f64) -> (Motion, f64) {
        let p = self.params;
        let rate_rad_s = TAU / CIRCLE_PERIOD_S;
        let course = p.course_out_deg + (t - p.circles_s) * rate_rad_s.to_degrees();
        let (current_mps, current_to_deg) = self.current;
        let cross = current_mps * (current_to_deg - course).to_radians().sin();
        let crab = (cross / p.speed_mps).clamp(-0.5, 0.5).asin().to_degrees();
        let bank_deg = (p.speed_mps * rate_rad_s / G_MPS2).atan().to_degrees();
        let roll = bank_deg + p.wave_roll_deg * (TAU * t / 6.0).sin();
        let pitch = 0.5 * p.wave_roll_deg * (TAU * t / 7.0).sin();
        (Motion { surfaced: true, speed_mps: p.speed_mps, pitch_deg: pitch, heading_deg: course - crab, crab_deg: crab }, roll)
    }
}

/// An out-and-back run with the dolphin profile.
pub fn run(sensor: &SensorModel, site: &Site, params: &RunParams, seed: u64, rate_hz: f64, kind: RunKind) -> Result<Simulation, SimError> {
    run_with(sensor, site, params, seed, rate_hz, kind, &Effects::none())
}

/// An out-and-back run with real-vehicle effects.
///
/// Without the current effect the kinematics are the original ones: the
/// autopilot crabs into `params`' current and the GPS course is the
/// heading plus the crab angle. With it, `params`' current is replaced by
/// the [`WaterModel`](crate::effects::WaterModel)'s (see
/// [`super::kinematics`]).
#[allow(clippy::too_many_arguments)]
pub fn run_with(sensor: &SensorModel, site: &Site, params: &RunParams, seed: u64, rate_hz: f64, kind: RunKind, effects: &Effects) -> Result<Simulation, SimError> {
    let profile = Profile::new(params, effects)?;
    check_rate(rate_hz, profile.total_s)?;
    let mut b = Rows::new(Truth::new(kind.into(), seed, sensor, site, Some(*params))?, sensor, seed, effects);
    let dt = 1.0 / rate_hz;
    let n = (profile.total_s / dt) as usize;
    let delay_rows = (params.gps_delay_s / dt).round() as usize;
    let mut track = Kinematics::new(site.lat_deg, site.lon_deg, effects.water_current.as_ref(), delay_rows, params.gps_noise_deg, n);
    if let (Some(thermal), Some(thrusters)) = (&effects.temperature, &effects.thrusters) {
        let bus: f64 = thrusters.currents_a(params.speed_mps, 0.0).iter().sum();
        b.sensor_temp_c = Some(thermal.equilibrium_c(0.0, bus));
    }
    let mut depth_m: f64 = 0.0;
    let mut last_heading: Option<f64> = None;
    let mut last_tilt: Option<(f64, f64)> = None;
    for k in 0..n {
        let t = k as f64 * dt;
        let (mut motion, mut roll) = profile.at(t);
        // The vehicle follows the autopilot's pitch and roll no faster than it can.
        if let (Some(rate), Some((r0, p0))) = (params.max_attitude_rate_deg_s, last_tilt) {
            let step = rate * dt;
            roll = r0 + (roll - r0).clamp(-step, step);
            motion.pitch_deg = p0 + (motion.pitch_deg - p0).clamp(-step, step);
        }
        last_tilt = Some((roll, motion.pitch_deg));
        let heading = motion.heading_deg;
        let yaw_rate_deg_s = last_heading.map_or(0.0, |h: f64| calib_core::heading::wrap_pi((heading - h).to_radians()).to_degrees() / dt);
        last_heading = Some(heading);
        let mut env = RowEnv { depth_m, speed_mps: motion.speed_mps, ..RowEnv::default() };
        if let Some(thrusters) = &effects.thrusters {
            env.currents_a = thrusters.currents_a(motion.speed_mps, yaw_rate_deg_s);
        }
        let gps_draw = (motion.surfaced && k >= delay_rows).then(|| b.noise.sensor.gauss());
        let observed = track.observe(k, &motion, gps_draw, &mut b.noise.effects);
        env.course_deg = observed.course_deg;
        env.logged_lat_lon = observed.logged_lat_lon;
        let (lat_deg, lon_deg) = track.position_deg();
        let row = Row { t_s: t, lat_deg, lon_deg, attitude_deg: [roll, motion.pitch_deg, heading], running: true, reference_deg: observed.reference_deg };
        b.push(&row, &env)?;
        track.advance(&motion, &observed, dt);
        depth_m = if motion.surfaced { 0.0 } else { (depth_m - motion.speed_mps * motion.pitch_deg.to_radians().sin() * dt).max(0.0) };
    }
    b.truth_mut().turnaround_s = Some(params.circles_s + profile.leg_s + Profile::TURN_S / 2.0);
    Ok(b.finish())
}
