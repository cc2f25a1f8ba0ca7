//! The gyro-propagated heading: a two-state Kalman filter (heading, gyro
//! yaw-rate bias) propagated with the yaw rate and updated with the
//! headings judged ok; its innovation is the monitor's third test.

use super::tuning::Tuning;
use crate::Real;

/// Wraps an angle within (−3π, 3π] to (−π, π] with two compares instead of
/// `floor` (libm's is software on the Cortex-M4F): every angle here is a
/// heading in [0, 2π) or (−π, π] plus a small step, or a difference of two.
#[inline(always)]
pub(super) fn wrap_near<T: Real>(a: T) -> T {
    if a > T::PI {
        a - T::TAU
    } else if a <= -T::PI {
        a + T::TAU
    } else {
        a
    }
}

/// The gyro-propagated heading: a two-state Kalman filter.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(super) struct GyroHeading<T> {
    /// The predicted heading, radians in (−π, π].
    pub(super) heading_rad: T,
    /// The gyro's yaw-rate bias, rad/s.
    pub(super) bias_rad_s: T,
    /// The covariance of (heading, bias): rad², rad²/s, rad²/s².
    pub(super) p00: T,
    pub(super) p01: T,
    pub(super) p11: T,
    /// The yaw rate of the previous sample with body rates, rad/s: a step
    /// is integrated with the mean of its two ends' rates (the trapezoid
    /// rule; the rate at one end alone is off by half the rate's change
    /// times the step: 1.75° a step at 29 Hz where the rate reverses by
    /// 100°/s a sample, as on the BROAD trials).
    pub(super) last_rate_rad_s: T,
    /// Anchored on a field heading (otherwise nothing is predicted).
    pub(super) anchored: bool,
}

impl<T: Real> GyroHeading<T> {
    /// Not anchored yet, the bias's variance `bias_var_rad2_s2` (rad²/s²).
    #[inline(always)]
    pub(super) fn unanchored(bias_var_rad2_s2: T) -> Self {
        Self {
            heading_rad: T::ZERO,
            bias_rad_s: T::ZERO,
            p00: T::ZERO,
            p01: T::ZERO,
            p11: bias_var_rad2_s2,
            last_rate_rad_s: T::ZERO,
            anchored: false,
        }
    }

    /// Propagates the heading over `dt_s` with the yaw rate (the step's
    /// mean rate: [`GyroHeading::step_rate`]).
    /// Returns the step's turn `|ψ̇ Δt|`, rad.
    #[inline(always)]
    pub(super) fn predict(&mut self, yaw_rate_rad_s: T, dt_s: T, tuning: &Tuning<T>) -> T {
        let turn = (yaw_rate_rad_s * dt_s).abs();
        self.heading_rad = wrap_near(self.heading_rad + (yaw_rate_rad_s - self.bias_rad_s) * dt_s);
        // 2·p01 as p01 + p01 (the same bits, one constant fewer).
        self.p00 += dt_s * (dt_s * self.p11 - (self.p01 + self.p01))
            + tuning.heading_walk_rad2_s * dt_s
            + tuning.scale_var_per_rad * turn;
        self.p01 -= dt_s * self.p11;
        self.p11 += tuning.bias_walk_rad2_s3 * dt_s;
        turn
    }

    /// The mean yaw rate over the step that ends with a sample of yaw rate
    /// `yaw_rate_rad_s` (the trapezoid rule with the previous sample's),
    /// which becomes the previous one. Called on every sample with body
    /// rates, anchored or not, so the previous rate is the last sample's.
    #[inline(always)]
    pub(super) fn step_rate(&mut self, yaw_rate_rad_s: T) -> T {
        let mean = (yaw_rate_rad_s + self.last_rate_rad_s) * T::from_f64(0.5);
        self.last_rate_rad_s = yaw_rate_rad_s;
        mean
    }

    /// The Kalman update with a heading innovation of variance `s`.
    #[inline(always)]
    pub(super) fn update(&mut self, innovation_rad: T, s: T) {
        let (k0, k1) = (self.p00 / s, self.p01 / s);
        self.heading_rad = wrap_near(self.heading_rad + k0 * innovation_rad);
        self.bias_rad_s += k1 * innovation_rad;
        let (p00, p01) = (self.p00, self.p01);
        self.p00 = p00 - k0 * p00;
        self.p01 = p01 - k0 * p01;
        self.p11 -= k1 * p01;
    }

    /// Anchors the prediction on a heading of variance `var_rad2`.
    #[inline(never)]
    pub(super) fn anchor(&mut self, heading_rad: T, var_rad2: T) {
        self.heading_rad = wrap_near(heading_rad);
        self.p00 = var_rad2;
        self.p01 = T::ZERO;
        self.anchored = true;
    }
}
