//! The simulator's random generators and the order they are drawn in.
//!
//! Three generators, each seeded from the simulation's seed, so that
//! switching an effect or the gyro on leaves every other number as it was:
//!
//! * the sensor's ([`Noise::sensor`], the seed itself): the swing test's
//!   starting yaw (one uniform), then per row the GPS course noise (one
//!   normal, only at the surface once a delayed course exists — drawn in
//!   both kinematic models, so the magnetometer's noise is the same with
//!   and without the water current), the magnetometer's three axes, the
//!   AHRS roll and pitch;
//! * the effects' ([`Noise::effects`]): per row the GPS velocity (two) and
//!   position fixes (two) of the water current, the logged bus current, the
//!   thermistor, the speed log — each only when its effect is on;
//! * the gyro's ([`gyro_generator`]): per row x, y, z.

use calib_core::conformance::SplitMix64;

/// The sensor's and the effects' generators.
pub(super) struct Noise {
    /// The sensor, the AHRS and the GPS course.
    pub sensor: SplitMix64,
    /// The effects' own noise.
    pub effects: SplitMix64,
}

impl Noise {
    /// Both generators for a seed.
    pub fn new(seed: u64) -> Self {
        Self { sensor: SplitMix64::new(seed), effects: SplitMix64::new(seed ^ 0x4546_4645_4354_5321) }
    }
}

/// The gyro's generator for a seed.
pub(super) fn gyro_generator(seed: u64) -> SplitMix64 {
    SplitMix64::new(seed ^ 0x6779_726F)
}
