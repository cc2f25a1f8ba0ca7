//! What the vehicle sends the board: the attitude for the heading
//! ([`RequestBody::Attitude`](magcal_protocol::RequestBody::Attitude)), plus the body rates for the gyro-aided fit
//! ([`RequestBody::Motion`](magcal_protocol::RequestBody::Motion)) or the thrusters' current for the current term
//! ([`RequestBody::AttitudeEnv`](magcal_protocol::RequestBody::AttitudeEnv)). Each is checked here once and is stale
//! after [`ATTITUDE_TIMEOUT_MS`].

use calib_core::heading::Tilt;
use magcal_protocol::{DeviceError, ATTITUDE_TIMEOUT_MS, MAX_MOTOR_CURRENT_A};

use super::InputRequest;

/// The largest body rate a [`RequestBody::Motion`](magcal_protocol::RequestBody::Motion) may carry, rad/s
/// (2 000°/s, a MEMS gyro's widest range).
const MAX_RATE_RAD_S: f32 = 35.0;

/// Body rates and attitude from the AHRS ([`RequestBody::Motion`](magcal_protocol::RequestBody::Motion)), with the
/// board time they arrived.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Motion {
    pub(super) roll_rad: f32,
    pub(super) pitch_rad: f32,
    pub(super) rate_rad_s: [f32; 3],
    pub(super) at_ms: u32,
}

/// The latest inputs, each with the board time it arrived.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Inputs {
    /// The tilt (its trigonometry once per attitude, not once per sample).
    attitude: Option<(Tilt<f32>, u32)>,
    motion: Option<Motion>,
    /// The motor current from [`RequestBody::AttitudeEnv`](magcal_protocol::RequestBody::AttitudeEnv), A.
    current: Option<(f32, u32)>,
}

/// A message's time `at_ms` is still fresh at `now_ms`.
pub(super) fn fresh(at_ms: u32, now_ms: u32) -> bool {
    now_ms.wrapping_sub(at_ms) <= ATTITUDE_TIMEOUT_MS
}

/// Roll within ±π and pitch within ±π/2, both finite.
fn attitude_ok(roll_rad: f32, pitch_rad: f32) -> bool {
    roll_rad.is_finite() && pitch_rad.is_finite() && roll_rad.abs() <= core::f32::consts::PI && pitch_rad.abs() <= core::f32::consts::FRAC_PI_2
}

impl Inputs {
    /// Takes an `Attitude`, `Motion` or `AttitudeEnv` request; refuses one
    /// out of range ([`DeviceError::BadArgument`]).
    pub(super) fn accept(&mut self, req: InputRequest, now_ms: u32) -> Result<(), DeviceError> {
        let (roll_rad, pitch_rad, extra_ok) = match req {
            InputRequest::Attitude { roll_rad, pitch_rad } => (roll_rad, pitch_rad, true),
            InputRequest::Motion { roll_rad, pitch_rad, rate_rad_s } => (roll_rad, pitch_rad, rate_rad_s.iter().all(|w| w.is_finite() && w.abs() <= MAX_RATE_RAD_S)),
            InputRequest::AttitudeEnv { roll_rad, pitch_rad, motor_current_a } => (roll_rad, pitch_rad, motor_current_a.is_finite() && motor_current_a.abs() <= MAX_MOTOR_CURRENT_A),
        };
        if !(attitude_ok(roll_rad, pitch_rad) && extra_ok) {
            return Err(DeviceError::BadArgument);
        }
        self.attitude = Some((Tilt::new(roll_rad, pitch_rad), now_ms));
        match req {
            InputRequest::Motion { rate_rad_s, .. } => self.motion = Some(Motion { roll_rad, pitch_rad, rate_rad_s, at_ms: now_ms }),
            InputRequest::AttitudeEnv { motor_current_a, .. } => self.current = Some((motor_current_a, now_ms)),
            InputRequest::Attitude { .. } => {}
        }
        Ok(())
    }

    /// The tilt, if fresh.
    pub(super) fn tilt(&self, now_ms: u32) -> Option<Tilt<f32>> {
        self.attitude.filter(|&(_, t)| fresh(t, now_ms)).map(|(tilt, _)| tilt)
    }

    /// The motor current, A, if fresh.
    pub(super) fn current_a(&self, now_ms: u32) -> Option<f32> {
        self.current.filter(|&(_, t)| fresh(t, now_ms)).map(|(i, _)| i)
    }

    /// The latest body rates and attitude, fresh or not (the fit checks).
    pub(super) fn motion(&self) -> Option<Motion> {
        self.motion
    }
}
