//! The field-test simulator of magcal, apart from the product: written from
//! the physics of the vehicle and the sensor, not from the estimators'
//! equations, with ground truth beside every recording.
//!
//! * [`effects`]: five real-vehicle effects the fit's model lacks
//!   (thrusters, temperature, crustal anomaly, AHRS misalignment, water
//!   current), each switchable, and two disturbances for integrity checks
//!   (a steel pier passed at a few metres, a payload switched on mid-run);
//! * [`field_test`]: paper 000's swing test and out-and-back runs
//!   (`magcal simulate`); [`field_test_kind`]: which of them a recording is
//!   (named by both, so `effects` and `field_test` do not import each other
//!   for it: the dependency runs one way, `field_test` → `effects`);
//! * [`logs`]: a field test as a board log and a navigation log on two
//!   clocks (`magcal merge`'s inputs, its tests and benchmark);
//! * [`varied`]: the five effects at other sites and with magnitudes drawn
//!   by seed from stated ranges;
//! * [`scenario`]: the whole chain on simulated field tests against the
//!   truth (acceptance tests, `cargo xtask bench`);
//! * [`vehicle`]: the simulated vehicle that plays the field tests into the
//!   QEMU board for `magcal session --sim-feed` and `cargo xtask demo`.
//!
//! It depends on `host-tools` (recordings, the reference field, the chain,
//! the session's `Vehicle` trait); `host-tools` does not depend on it.
#![deny(missing_docs)]

pub mod effects;
pub mod field_test;
pub mod field_test_kind;
pub mod logs;
pub mod scenario;
pub mod varied;
pub mod vehicle;

pub use effects::{Effect, Effects};
pub use field_test::{paper_site, RunParams, SensorModel, SimError, Simulation, Truth};
pub use scenario::{evaluate, Outcome, ScenarioError};
pub use vehicle::{SimPlan, SimVehicle, SHORT_TEST_EFFECTS};
