//! The swing test: a diver turns the vehicle in the water (paper 000,
//! Table 2), optionally followed by a thrust test.

use std::f64::consts::TAU;

use host_tools::geomag::Site;

use super::rows::{Row, RowEnv, Rows};
use super::{check_rate, FieldTest, SensorModel, SimError, Simulation, Truth};
use crate::effects::Effects;

/// Segment boundaries of the swing test, seconds from its start (paper
/// Table 2: roll only, roll + pitch, roll + pitch + yaw).
pub const SWING_SEGMENTS_S: [(f64, f64, &str); 3] = [(0.0, 300.0, "roll"), (300.0, 730.0, "roll+pitch"), (730.0, 1330.0, "roll+pitch+yaw")];

/// How long each step of the thrust test lasts, s.
pub const THRUST_TEST_STEP_S: f64 = 40.0;

/// The swing test: the vehicle turned by a diver, thrusters off (roll ±55°,
/// pitch ±10°, as in paper 000).
pub fn swing(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64) -> Result<Simulation, SimError> {
    swing_limited(sensor, site, seed, rate_hz, 55.0, 10.0)
}

/// The swing test with other roll and pitch amplitudes, degrees (a vehicle
/// that cannot be rolled far: ±15° / ±5°).
pub fn swing_limited(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64, roll_amp_deg: f64, pitch_amp_deg: f64) -> Result<Simulation, SimError> {
    swing_with(sensor, site, seed, rate_hz, roll_amp_deg, pitch_amp_deg, &Effects::none())
}

/// The diver's attitude at `t` (roll, pitch, yaw; degrees): roll all the
/// time, pitch from the second segment, yaw held in the first two segments
/// and then turned all round (−180…180°) at 3°/s, back and forth, starting
/// from the held yaw (a vehicle does not jump: the gyro sees every degree).
fn diver_attitude_deg(t: f64, roll_amp_deg: f64, pitch_amp_deg: f64, yaw0: f64) -> [f64; 3] {
    let roll = roll_amp_deg * (TAU * t / 37.0).sin();
    let pitch = if t >= SWING_SEGMENTS_S[1].0 { pitch_amp_deg * (TAU * t / 23.0).sin() } else { 0.0 };
    let yaw = if t >= SWING_SEGMENTS_S[2].0 {
        let u = (t - SWING_SEGMENTS_S[2].0) * 3.0;
        let tri = (u % 720.0 - 360.0).abs() - 180.0; // 180 → −180 → 180 triangle
        yaw0 + tri
    } else {
        yaw0 + 180.0
    };
    [roll, pitch, yaw]
}

/// The swing test with real-vehicle effects. The vehicle is held at the
/// surface (0.5 m) at the site, thrusters off (0 A) — unless the thrusters
/// effect asks for a thrust test: then, after the yaw segment, the heading
/// is held and every thruster's current steps through
/// `thrust_test_steps_a`, [`THRUST_TEST_STEP_S`] each. With the
/// temperature effect the sensor starts `swing_start_excess_c` warm.
pub fn swing_with(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64, roll_amp_deg: f64, pitch_amp_deg: f64, effects: &Effects) -> Result<Simulation, SimError> {
    let steps: &[f64] = effects.thrusters.as_ref().map_or(&[], |m| &m.thrust_test_steps_a);
    let end = SWING_SEGMENTS_S[2].1;
    check_rate(rate_hz, end + steps.len() as f64 * THRUST_TEST_STEP_S)?;
    if !((0.0..=90.0).contains(&roll_amp_deg) && (0.0..=60.0).contains(&pitch_amp_deg)) {
        return Err(SimError::Parameter { what: "the swing's roll and pitch amplitudes, degrees", got: format!("{roll_amp_deg} / {pitch_amp_deg}"), allowed: "within 0…90° / 0…60°" });
    }
    let mut b = Rows::new(Truth::new(FieldTest::Swing, seed, sensor, site, None)?, sensor, seed, effects);
    let depth_m = if effects.is_none() { 0.0 } else { 0.5 };
    let n_thrusters = effects.thrusters.as_ref().map_or(0, |m| m.thrusters.len());
    if let Some(thermal) = &effects.temperature {
        b.sensor_temp_c = Some(thermal.equilibrium_c(depth_m, 0.0) + thermal.swing_start_excess_c);
    }
    let dt = 1.0 / rate_hz;
    let yaw0 = 360.0 * b.noise.sensor.uniform();
    let n = (end / dt) as usize;
    let n_test = (steps.len() as f64 * THRUST_TEST_STEP_S / dt) as usize;
    for k in 0..n + n_test {
        let t = k as f64 * dt;
        // Held in place: no speed through water, no course over ground.
        let mut env = RowEnv { currents_a: vec![0.0; n_thrusters], depth_m, course_deg: f64::NAN, ..RowEnv::default() };
        let row = |attitude_deg, running| Row { t_s: t, lat_deg: site.lat_deg, lon_deg: site.lon_deg, attitude_deg, running, reference_deg: f64::NAN };
        if k >= n {
            // Thrust test: heading held, the vehicle rocking a little.
            let step = (((t - end) / THRUST_TEST_STEP_S) as usize).min(steps.len().saturating_sub(1));
            let current = steps.get(step).copied().unwrap_or(0.0);
            env.currents_a = vec![current; n_thrusters];
            let roll = 2.0 * (TAU * t / 6.0).sin();
            let pitch = 1.0 * (TAU * t / 8.0).sin();
            b.push(&row([roll, pitch, yaw0 + 180.0], current > 0.0), &env)?;
            continue;
        }
        b.push(&row(diver_attitude_deg(t, roll_amp_deg, pitch_amp_deg, yaw0), false), &env)?;
    }
    Ok(b.finish())
}
