//! Simulator of paper 000's field tests, writing recordings in the
//! INTERFACES.md CSV format with the ground truth beside them.
//!
//! * `swing` ([`swing`]): a diver turns the vehicle in the water — roll-only,
//!   then roll + pitch, then roll + pitch + yaw segments (paper Table 2), yaw
//!   −180…180°, roll ±55°, pitch ±10°; thrusters off.
//! * `run` / `validation` ([`run`]): an out-and-back run (62° / −117° by
//!   default) with the dolphin profile (~1000 s submerged, ~50 s at the
//!   surface), a surface turn at the far end, GPS course over ground only at
//!   the surface and delayed, a current (the autopilot crabs into it, so
//!   course over ground is not heading); thrusters and electronics on,
//!   adding a running-only bias. Optionally ([`RunParams::circles_s`],
//!   [`RunParams::circles_then_legs`]) circles at the surface first, every
//!   heading with the GPS course, before the legs and their dives.
//!
//! The sensor ([`SensorModel`]): `raw = D·h + b (+ b_run while running) +
//! noise`, quantised to whole counts. `D` carries scale, the steel hull's
//! soft iron, misalignment and paper 001's non-orthogonality. The field is
//! IGRF-14 along the track. Attitude from the AHRS is the truth plus noise
//! and a small bias.
//!
//! The real-vehicle effects of [`crate::effects`] ([`swing_with`],
//! [`run_with`]; each switchable, none by default) go beyond that model:
//! thruster dipoles scaling with current, the bridge gain's temperature
//! drift with a thermal lag, a crustal anomaly on top of IGRF, an AHRS
//! misaligned to the magnetometer, a water current with kinematically
//! consistent GPS, a steel structure passed at a few metres, a payload
//! switched on mid-run. Their true values go into [`Truth::effects`].
//!
//! The gyro ([`GyroModel`], [`Simulation::with_gyro`]): the body rates of the
//! true attitude history (Z-Y-X Euler-angle kinematics), seen through a
//! slightly misaligned triad, plus a constant bias and white noise.
//!
//! One concern per module: `swing` and `run` the manoeuvres (the run's two
//! ways of moving over the ground in `kinematics`), `sensor` the
//! magnetometer, `gyro` the gyro, `noise` the random generators and their
//! draw order, `rows` the assembly of one row from the true state and the
//! effects, `truth` what the simulator knows, `simulation` the result and
//! its files.

mod gyro;
mod kinematics;
mod noise;
mod rows;
mod run;
mod sensor;
mod simulation;
mod swing;
mod truth;

use host_tools::data::RecordingError;
use host_tools::geomag::{GeomagError, Site};

pub use gyro::GyroModel;
pub use run::{run, run_with, RunKind, RunParams, CIRCLE_PERIOD_S, MAX_LEG_M, MAX_SPEED_MPS};
pub use sensor::SensorModel;
pub use simulation::{truth_path, Simulation};
pub use swing::{swing, swing_limited, swing_with, SWING_SEGMENTS_S, THRUST_TEST_STEP_S};
pub use truth::{AnomalyTruth, CurrentTruth, EffectsTruth, FieldSample, FieldTest, PayloadTruth, StructureTruth, TemperatureTruth, ThrusterTruth, Truth};

/// Why a simulation could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The output could not be written ([`host_tools::files`]).
    #[error(transparent)]
    Output(#[from] host_tools::files::OutputError),
    /// The reference field could not be computed.
    #[error("{0}")]
    Field(#[from] GeomagError),
    /// Writing the recording failed.
    #[error("{0}")]
    Recording(#[from] RecordingError),
    /// A parameter is outside what the simulator (or the physics it
    /// writes) allows.
    #[error("{what} ({got}) must be {allowed}")]
    Parameter {
        /// Which parameter.
        what: &'static str,
        /// The value given, as given.
        got: String,
        /// What it must be.
        allowed: &'static str,
    },
    /// The recording would be longer than the simulator writes.
    #[error("{duration_s:.0} s at {rate_hz} Hz would be {rows:.3e} rows; the simulator writes at most {max_rows:.0e} rows (shorten the legs or lower the rate)")]
    TooManyRows {
        /// The recording's length, s.
        duration_s: f64,
        /// Its rate, Hz.
        rate_hz: f64,
        /// Its rows.
        rows: f64,
        /// The most rows written.
        max_rows: f64,
    },
    /// The sensor's gain matrix cannot be inverted.
    #[error("the sensor's gain matrix is singular")]
    SingularSensor,
    /// The truth document could not be encoded.
    #[error("the truth document could not be encoded as JSON: {0}")]
    Truth(#[source] serde_json::Error),
}

/// The southern Caspian Sea in 2021, where IGRF-14 gives within ~1 % of
/// paper 000's site values (Hh 27 473, Hz 40 247, F 48 730 nT).
pub fn paper_site() -> Site {
    Site { lat_deg: 36.9, lon_deg: 50.6, decimal_year: 2021.0 }
}

/// The most rows one simulated recording may have: 10⁶, about 55 h at
/// 5 Hz; with every effect's truth columns ~500 B a row, so at most ~0.5 GB
/// of CSV and ~0.3 GB of memory.
pub const MAX_ROWS: f64 = 1e6;

/// The sample rate must be one a magnetometer gives, and the recording no
/// longer than [`MAX_ROWS`].
fn check_rate(rate_hz: f64, duration_s: f64) -> Result<(), SimError> {
    if !(0.1..=1000.0).contains(&rate_hz) {
        return Err(SimError::Parameter { what: "the rate, Hz", got: format!("{rate_hz}"), allowed: "within 0.1 … 1000 Hz (the sensor's range)" });
    }
    let rows = duration_s * rate_hz;
    if rows > MAX_ROWS {
        return Err(SimError::TooManyRows { duration_s, rate_hz, rows, max_rows: MAX_ROWS });
    }
    Ok(())
}
