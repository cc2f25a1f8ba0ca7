//! Simulator of paper 000's field tests, writing recordings in the
//! INTERFACES.md CSV format with the ground truth beside them.
//!
//! * `swing`: a diver turns the vehicle in the water — roll-only, then
//!   roll + pitch, then roll + pitch + yaw segments (paper Table 2), yaw
//!   −180…180°, roll ±55°, pitch ±10°; thrusters off.
//! * `run` / `validation`: an out-and-back run (62° / −117° by default) with
//!   the dolphin profile (~1000 s submerged, ~50 s at the surface), a surface
//!   turn at the far end, GPS course over ground only at the surface and
//!   delayed, a current (the autopilot crabs into it, so course over ground
//!   is not heading); thrusters and electronics on, adding a
//!   running-only bias.
//!
//! The sensor: `raw = D·h + b (+ b_run while running) + noise`, quantised to
//! whole counts. `D` carries scale, the steel hull's soft iron, misalignment
//! and paper 001's non-orthogonality. The field is IGRF-14 along the track.
//! Attitude from the AHRS is the truth plus noise and a small bias.
//!
//! The real-vehicle effects of [`crate::effects`] ([`swing_with`],
//! [`run_with`]; each switchable, none by default) go beyond that model:
//! thruster dipoles scaling with current, the bridge gain's temperature
//! drift with a thermal lag, a crustal anomaly on top of IGRF, an AHRS
//! misaligned to the magnetometer, a water current with kinematically
//! consistent GPS. Their true values go into [`Truth::effects`].
//!
//! The gyro ([`GyroModel`], [`Simulation::with_gyro`]): the body rates of the
//! true attitude history (Z-Y-X Euler-angle kinematics), seen through a
//! slightly misaligned triad, plus a constant bias and white noise.

use std::path::Path;

use calib_core::conformance::SplitMix64;
use calib_core::heading::wrap_two_pi;
use calib_core::linalg::{mul_mat, mul_mat_vec, Mat3};
use calib_core::ortho::{gamma, OrthoAngles};
use serde::{Deserialize, Serialize};

use host_tools::data::recording::{Recording, RecordingError};
use host_tools::geomag::{self, GeomagError, Site};

use crate::effects::{euler_dcm, Effect, Effects, Thruster, M_PER_DEG_LAT};

/// Why a simulation could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The reference field could not be computed.
    #[error("{0}")]
    Field(#[from] GeomagError),
    /// Writing the recording failed.
    #[error("{0}")]
    Recording(#[from] RecordingError),
    /// Writing the truth file failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A parameter is out of range.
    #[error("{0}")]
    Parameter(String),
}

/// The magnetometer in its hull.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SensorModel {
    /// Raw units per nT, including soft iron, misalignment, non-orthogonality.
    pub gain_raw_per_nt: Mat3<f64>,
    /// Hard iron, raw units.
    pub bias_raw: [f64; 3],
    /// Extra bias while thrusters and electronics run, raw units.
    pub running_bias_raw: [f64; 3],
    /// White noise per axis, nT (1σ).
    pub noise_nt: f64,
    /// AHRS roll/pitch noise, degrees (1σ).
    pub ahrs_noise_deg: f64,
    /// AHRS roll and pitch bias, degrees.
    pub ahrs_bias_deg: [f64; 2],
}

impl SensorModel {
    /// A paper-like sensor: the scale factors of paper 000's step-1 fit, mild
    /// soft iron, paper 001's non-orthogonality (scaled down), hard iron of
    /// the paper's magnitude, and thrusters that add a few hundred nT, mostly
    /// horizontal, only while running — the disturbance the paper's
    /// out-and-back correction was designed for.
    pub fn paper_like() -> Self {
        Self::with_soft_iron([[1.0, 0.01, 0.004], [0.01, 1.0, -0.003], [0.004, -0.003, 1.0]], [40.0, -30.0, 20.0])
    }

    /// A steel hull that couples the vertical channel to the horizontal ones
    /// (2 % and 1.2 %), with a running bias mostly along z: the swing test
    /// cannot see the coupling, and the turnaround step it causes is not one
    /// that a change of `sz` can remove.
    pub fn hull_coupled() -> Self {
        Self::with_soft_iron([[1.0, 0.015, 0.02], [0.015, 1.0, -0.012], [0.02, -0.012, 1.0]], [12.0, -9.0, 45.0])
    }

    /// The QEMU board's vehicle, in nT at the bridges (the board's own chain
    /// gain turns them into ADC counts): a steel hull's soft iron and
    /// non-orthogonality near identity, hard iron of a few thousand nT and a
    /// running-only bias of a few hundred. Fed through USART2 by the demo.
    pub fn board_like() -> Self {
        let soft_iron = [[1.04, 0.02, 0.012], [0.02, 0.95, -0.01], [0.012, -0.01, 1.02]];
        let nonorth = gamma(&OrthoAngles { theta_rad: 0.01, phi_rad: 0.015, psi_rad: -0.008, k_xz: 0.99, k_yz: 1.01 });
        Self {
            gain_raw_per_nt: mul_mat(&nonorth, &soft_iron),
            bias_raw: [1500.0, -2300.0, 800.0],
            running_bias_raw: [220.0, -160.0, 120.0],
            noise_nt: 3.0,
            ahrs_noise_deg: 0.15,
            ahrs_bias_deg: [0.05, -0.05],
        }
    }

    fn with_soft_iron(soft_iron: Mat3<f64>, running_bias: [f64; 3]) -> Self {
        let scale = [[0.19556, 0.0, 0.0], [0.0, 0.09001, 0.0], [0.0, 0.0, 0.16142]];
        let nonorth = gamma(&OrthoAngles { theta_rad: 0.01, phi_rad: 0.015, psi_rad: -0.008, k_xz: 1.0, k_yz: 1.0 });
        Self {
            gain_raw_per_nt: mul_mat(&mul_mat(&scale, &nonorth), &soft_iron),
            bias_raw: [-1865.0, 1385.0, -903.0],
            running_bias_raw: running_bias,
            noise_nt: 3.0,
            ahrs_noise_deg: 0.15,
            ahrs_bias_deg: [0.05, -0.05],
        }
    }

    /// Raw counts with the thrusters' field at the sensor (nT, body) added
    /// to the outside field, and the bridge gain of each axis applied to
    /// everything the bridge sees (outside field, hull's hard iron, running
    /// bias, thrusters); the electronics' noise is not scaled. With no
    /// thruster field and unit gains, the simulator's original sensor.
    fn measure_env(&self, h_body: [f64; 3], thruster_nt: [f64; 3], bridge_gain: [f64; 3], running: bool, rng: &mut SplitMix64) -> [f64; 3] {
        let h = [h_body[0] + thruster_nt[0], h_body[1] + thruster_nt[1], h_body[2] + thruster_nt[2]];
        let r = mul_mat_vec(&self.gain_raw_per_nt, h);
        let mut out = [0.0; 3];
        for k in 0..3 {
            let gain = self.gain_raw_per_nt[k][k].abs();
            let b = self.bias_raw[k] + if running { self.running_bias_raw[k] } else { 0.0 };
            out[k] = (bridge_gain[k] * (r[k] + b) + self.noise_nt * gain * rng.gauss()).round();
        }
        out
    }
}

/// The southern Caspian Sea in 2021, where IGRF-14 gives within ~1 % of
/// paper 000's site values (Hh 27 473, Hz 40 247, F 48 730 nT).
pub fn paper_site() -> Site {
    Site { lat_deg: 36.9, lon_deg: 50.6, decimal_year: 2021.0 }
}

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
}

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
        }
    }

    /// A second run for validation: other courses, so headings not used in
    /// the calibration are checked too.
    pub fn validation() -> Self {
        Self { course_out_deg: 150.0, course_back_deg: 330.0, leg_m: 4000.0, current_to_deg: 40.0, ..Self::paper_like() }
    }
}

/// What the simulator knows and the recording does not.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Truth {
    /// Scenario name.
    pub scenario: String,
    /// Seed.
    pub seed: u64,
    /// The sensor.
    pub sensor: SensorModel,
    /// The site.
    pub site: Site,
    /// Run parameters (runs only).
    pub run: Option<RunParams>,
    /// Time of the turnaround (runs only), seconds.
    pub turnaround_s: Option<f64>,
    /// IGRF-14 at the start: horizontal, down, total, declination.
    pub field_h_nt: f64,
    /// Down component, nT.
    pub field_z_nt: f64,
    /// Total intensity, nT.
    pub field_nt: f64,
    /// Declination, degrees.
    pub declination_deg: f64,
    /// The calibration matrix that undoes the sensor (`D⁻¹`, nT per raw
    /// unit; its bias is the sensor's `bias_raw`), for reference.
    pub ideal_matrix_nt_per_raw: Mat3<f64>,
    /// The real-vehicle effects that were on, with their true values in an
    /// estimator's terms (absent when none was on).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub effects: Option<EffectsTruth>,
}

/// The effects' true values, in the terms an estimator reports.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct EffectsTruth {
    /// The effects that were on.
    pub on: Vec<Effect>,
    /// Their parameters.
    pub models: Effects,
    /// Thruster interference.
    pub thrusters: Option<ThrusterTruth>,
    /// Temperature.
    pub temperature: Option<TemperatureTruth>,
    /// The true local field.
    pub anomaly: Option<AnomalyTruth>,
    /// AHRS misalignment: the AHRS frame is the magnetometer's turned by
    /// `Rx(roll) Ry(pitch)`, degrees.
    pub ahrs_misalignment_deg: Option<[f64; 2]>,
    /// The water current.
    pub current: Option<CurrentTruth>,
}

/// The thrusters' interference, raw units per ampere at the reference
/// temperature (multiply by the bridge gain at other temperatures).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ThrusterTruth {
    /// Each thruster's field at the sensor, nT per A of its own current, body frame.
    pub field_nt_per_a: Vec<[f64; 3]>,
    /// Each thruster's interference, raw units per A of its own current (`D·field`).
    pub raw_per_a_each: Vec<[f64; 3]>,
    /// Raw units per A of the logged bus current when the thrusters share
    /// it equally (straight running): the mean of `raw_per_a_each`. This is
    /// what a linear `bias_per_a` fit should find.
    pub raw_per_a: [f64; 3],
    /// Two thrusters: raw units per A of the difference `I₀ − I₁` beyond the
    /// equal split, `(raw₀ − raw₁)/2` — the part no single per-ampere
    /// vector can model (differential thrust in turns).
    pub raw_per_a_differential: Option<[f64; 3]>,
    /// Where the linear model `raw_per_a · motor_current_a` is not exact.
    pub nonlinear: String,
    /// Range of the true bus current over the recording, A.
    pub bus_current_a_range: [f64; 2],
}

/// The temperature effect.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TemperatureTruth {
    /// Temperature at which `D` and `b` hold, °C.
    pub ref_c: f64,
    /// Relative gain change per °C, per axis (the calibration document's `gain_per_c`).
    pub gain_per_c: [f64; 3],
    /// The sensor's time constant, s.
    pub tau_s: f64,
    /// Range of the true sensor temperature, °C.
    pub sensor_c_range: [f64; 2],
    /// Thermistor offset: `temp_c` reads this much above the sensor, °C.
    pub thermistor_offset_c: f64,
    /// The reference in the terms of the `temp_c` column (`ref_c` plus the
    /// thermistor's offset): what a fit of `gain_per_c` against `temp_c`
    /// should report as its `ref_c`, °C.
    pub ref_c_thermistor: f64,
}

/// The true field at one point of the track.
#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
pub struct FieldSample {
    /// Time, s.
    pub t_s: f64,
    /// True latitude, degrees.
    pub lat_deg: f64,
    /// True longitude, degrees.
    pub lon_deg: f64,
    /// Depth, m.
    pub depth_m: f64,
    /// True field north, nT.
    pub north_nt: f64,
    /// True field east, nT.
    pub east_nt: f64,
    /// True field down, nT.
    pub down_nt: f64,
    /// True intensity, nT.
    pub total_nt: f64,
    /// IGRF-14's intensity there, nT.
    pub igrf_total_nt: f64,
}

/// The true local field along the track.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AnomalyTruth {
    /// At the first row.
    pub at_start: FieldSample,
    /// Every 60 s along the track.
    pub profile: Vec<FieldSample>,
    /// Range of |true| − |IGRF| over the recording, nT.
    pub intensity_anomaly_nt_range: [f64; 2],
}

/// The water current.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CurrentTruth {
    /// Current towards north, m/s.
    pub north_mps: f64,
    /// Current towards east, m/s.
    pub east_mps: f64,
    /// Range of the crab angle (course over ground − heading) over the
    /// rows, degrees (runs only: the swing test does not move).
    pub crab_deg_range: Option<[f64; 2]>,
}

/// A simulated recording with its truth. The true heading and attitude of
/// every row are in `true_heading_deg` etc.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The recording (INTERFACES.md columns).
    pub recording: Recording,
    /// True heading (degrees, true north) of every row.
    pub true_heading_deg: Vec<f64>,
    /// True roll, degrees.
    pub true_roll_deg: Vec<f64>,
    /// True pitch, degrees.
    pub true_pitch_deg: Vec<f64>,
    /// Whether the thrusters ran at each row.
    pub running: Vec<bool>,
    /// The effects' truth columns (written beside the recording):
    /// `true_field_{n,e,d}_nt`, `sensor_temp_c`, `bus_current_a`,
    /// `thruster_{k}_a`, `depth_m`, `true_lat_deg`, `true_lon_deg`,
    /// `true_course_deg`, `water_speed_mps`, as the effects need them.
    pub effect_columns: Vec<(String, Vec<f64>)>,
    /// The truth.
    pub truth: Truth,
}

impl Simulation {
    /// An effect truth column by name.
    pub fn effect_column(&self, name: &str) -> Option<&[f64]> {
        self.effect_columns.iter().find(|(n, _)| n == name).map(|(_, c)| c.as_slice())
    }
}

fn truth_for(scenario: &str, seed: u64, sensor: &SensorModel, site: &Site, run: Option<RunParams>) -> Result<Truth, SimError> {
    let f = geomag::igrf14(site.lat_deg, site.lon_deg, 0.0, site.decimal_year)?;
    let ideal = calib_core::linalg::inverse3(&sensor.gain_raw_per_nt).ok_or_else(|| SimError::Parameter("sensor matrix is singular".into()))?;
    Ok(Truth {
        scenario: scenario.into(),
        seed,
        sensor: *sensor,
        site: *site,
        run,
        turnaround_s: None,
        field_h_nt: f.horizontal_nt(),
        field_z_nt: f.down_nt,
        field_nt: f.total_nt(),
        declination_deg: f.declination_deg(),
        ideal_matrix_nt_per_raw: ideal,
        effects: None,
    })
}

/// What a row's effects need from its manoeuvre.
#[derive(Debug, Clone, Default)]
struct RowEnv {
    /// Each thruster's current, A (thrusters effect).
    currents_a: Vec<f64>,
    /// Depth, m.
    depth_m: f64,
    /// Speed through water, m/s.
    speed_mps: f64,
    /// The position the vehicle logs (GPS fix or dead reckoning) when it is
    /// not the true one (current effect).
    logged_lat_lon: Option<(f64, f64)>,
    /// True course over ground, degrees (current effect).
    course_deg: f64,
}

struct Builder<'a> {
    sim: Simulation,
    sensor: &'a SensorModel,
    rng: SplitMix64,
    effects: &'a Effects,
    /// The effects' own noise, so the sensor's is the same with and without them.
    erng: SplitMix64,
    origin: Site,
    sensor_temp_c: Option<f64>,
    last_t: Option<f64>,
}

impl<'a> Builder<'a> {
    fn new(truth: Truth, sensor: &'a SensorModel, seed: u64, effects: &'a Effects) -> Self {
        let origin = truth.site;
        Self { sim: empty(truth), sensor, rng: SplitMix64::new(seed), effects, erng: SplitMix64::new(seed ^ 0x4546_4645_4354_5321), origin, sensor_temp_c: None, last_t: None }
    }

    fn column(&mut self, name: &str, v: f64) {
        match self.sim.effect_columns.iter_mut().find(|(n, _)| n == name) {
            Some((_, c)) => c.push(v),
            None => self.sim.effect_columns.push((name.to_string(), vec![v])),
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn push(&mut self, t: f64, lat: f64, lon: f64, year: f64, attitude_deg: [f64; 3], running: bool, reference_deg: f64, env: &RowEnv) -> Result<(), SimError> {
        let [roll, pitch, yaw] = attitude_deg;
        let f = geomag::igrf14(lat, lon, 0.0, year)?;
        let mut field_ned = [f.north_nt, f.east_nt, f.down_nt];
        if let Some(anomaly) = &self.effects.anomaly {
            let north_m = (lat - self.origin.lat_deg) * M_PER_DEG_LAT;
            let east_m = (lon - self.origin.lon_deg) * M_PER_DEG_LAT * lat.to_radians().cos();
            let a = anomaly.field_nt(north_m, east_m, env.depth_m);
            for k in 0..3 {
                field_ned[k] += a[k];
            }
            self.column("true_field_n_nt", field_ned[0]);
            self.column("true_field_e_nt", field_ned[1]);
            self.column("true_field_d_nt", field_ned[2]);
        }
        // The body frame by the simulator's own direction-cosine matrices, not
        // calib-core's rotation: a convention error there would show here.
        let h = mul_mat_vec(&euler_dcm(roll, pitch, yaw), field_ned);
        let mut thruster_nt = [0.0; 3];
        let mut bus_a = 0.0;
        let mut running_bias = running;
        if let Some(thrusters) = &self.effects.thrusters {
            // The thrusters' dipoles replace the constant running bias.
            running_bias = false;
            thruster_nt = thrusters.field_nt(&env.currents_a);
            bus_a = env.currents_a.iter().sum();
            let logged = bus_a + thrusters.current_noise_a * self.erng.gauss();
            push(&mut self.sim.recording.motor_current_a, logged);
            self.column("bus_current_a", bus_a);
            for (k, i) in env.currents_a.iter().enumerate() {
                self.column(&format!("thruster_{k}_a"), *i);
            }
        }
        let mut bridge_gain = [1.0; 3];
        if let Some(thermal) = &self.effects.temperature {
            let target = thermal.equilibrium_c(env.depth_m, bus_a);
            // Starts where the manoeuvre put it (or at equilibrium), then lags.
            let temp = match (self.sensor_temp_c, self.last_t) {
                (Some(temp), Some(t0)) => thermal.step(temp, target, t - t0),
                (Some(temp), None) => temp,
                (None, _) => target,
            };
            self.sensor_temp_c = Some(temp);
            bridge_gain = thermal.gain(temp);
            let logged = temp + thermal.thermistor_offset_c + thermal.thermistor_noise_c * self.erng.gauss();
            push(&mut self.sim.recording.temp_c, logged);
            self.column("sensor_temp_c", temp);
        }
        if self.effects.temperature.is_some() || self.effects.anomaly.is_some() || self.effects.current.is_some() {
            self.column("depth_m", env.depth_m);
        }
        self.last_t = Some(t);
        let raw = self.sensor.measure_env(h, thruster_nt, bridge_gain, running_bias, &mut self.rng);
        let (ahrs_roll, ahrs_pitch) = match &self.effects.ahrs {
            Some(m) => {
                let [r, p, _] = m.reported_deg(roll, pitch, yaw);
                (r, p)
            }
            None => (roll, pitch),
        };
        let (logged_lat, logged_lon) = env.logged_lat_lon.unwrap_or((lat, lon));
        if let Some(water) = &self.effects.current {
            let logged = env.speed_mps * water.speed_log_scale + water.speed_log_noise_mps * self.erng.gauss();
            push(&mut self.sim.recording.speed_mps, logged);
            self.column("water_speed_mps", env.speed_mps);
            self.column("true_lat_deg", lat);
            self.column("true_lon_deg", lon);
            self.column("true_course_deg", env.course_deg);
        }
        let n = self.sensor.ahrs_noise_deg;
        let r = &mut self.sim.recording;
        r.mag.push(raw);
        push(&mut r.t_s, t);
        push(&mut r.roll_deg, ahrs_roll + self.sensor.ahrs_bias_deg[0] + n * self.rng.gauss());
        push(&mut r.pitch_deg, ahrs_pitch + self.sensor.ahrs_bias_deg[1] + n * self.rng.gauss());
        push(&mut r.ref_heading_deg, reference_deg);
        push(&mut r.lat_deg, logged_lat);
        push(&mut r.lon_deg, logged_lon);
        self.sim.true_heading_deg.push(wrap_two_pi(yaw.to_radians()).to_degrees());
        self.sim.true_roll_deg.push(roll);
        self.sim.true_pitch_deg.push(pitch);
        self.sim.running.push(running);
        Ok(())
    }

    /// Fills the effects' truth from the rows.
    fn finish(mut self) -> Simulation {
        if self.effects.is_none() {
            return self.sim;
        }
        let e = self.effects;
        let range = |c: Option<&[f64]>| {
            c.map(|c| c.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| [lo.min(v), hi.max(v)])).unwrap_or([f64::NAN; 2])
        };
        let thrusters = e.thrusters.as_ref().map(|m| {
            let d = &self.sensor.gain_raw_per_nt;
            let field: Vec<[f64; 3]> = m.thrusters.iter().map(Thruster::field_nt_per_a).collect();
            let raw: Vec<[f64; 3]> = field.iter().map(|f| mul_mat_vec(d, *f)).collect();
            let n = raw.len().max(1) as f64;
            let mean = [0, 1, 2].map(|k| raw.iter().map(|r| r[k]).sum::<f64>() / n);
            let differential = (raw.len() == 2).then(|| [0, 1, 2].map(|k| (raw[0][k] - raw[1][k]) / 2.0));
            ThrusterTruth {
                field_nt_per_a: field,
                raw_per_a_each: raw,
                raw_per_a: mean,
                raw_per_a_differential: differential,
                nonlinear: "the field is linear in each thruster's current; the logged bus current explains it with raw_per_a only while the thrusters share it equally: in turns the differential thrust adds raw_per_a_differential·(I₀ − I₁); the bridge gain multiplies it at temperatures away from ref_c; the logged current has noise".into(),
                bus_current_a_range: range(self.sim.effect_column("bus_current_a")),
            }
        });
        let temperature = e.temperature.as_ref().map(|m| TemperatureTruth {
            ref_c: m.ref_c,
            gain_per_c: m.gain_per_c,
            tau_s: m.tau_s,
            sensor_c_range: range(self.sim.effect_column("sensor_temp_c")),
            thermistor_offset_c: m.thermistor_offset_c,
            ref_c_thermistor: m.ref_c + m.thermistor_offset_c,
        });
        let anomaly = if e.anomaly.is_some() { self.field_samples() } else { None };
        let current = e.current.as_ref().map(|w| {
            let [north_mps, east_mps] = w.current_ne_mps();
            let crab = self.sim.effect_column("true_course_deg").map(|c| {
                c.iter().zip(&self.sim.true_heading_deg).map(|(c, h)| calib_core::heading::wrap_pi((c - h).to_radians()).to_degrees()).collect::<Vec<_>>()
            });
            let crab_deg_range = crab.filter(|c| c.iter().all(|v| v.is_finite())).map(|c| range(Some(&c)));
            CurrentTruth { north_mps, east_mps, crab_deg_range }
        });
        self.sim.truth.effects = Some(EffectsTruth {
            on: e.list(),
            models: e.clone(),
            thrusters,
            temperature,
            anomaly,
            ahrs_misalignment_deg: e.ahrs.map(|m| [m.roll_deg, m.pitch_deg]),
            current,
        });
        self.sim
    }

    fn field_samples(&self) -> Option<AnomalyTruth> {
        let s = &self.sim;
        let t = s.recording.t_s.as_ref()?;
        let (n, e, d) = (s.effect_column("true_field_n_nt")?, s.effect_column("true_field_e_nt")?, s.effect_column("true_field_d_nt")?);
        let lat = s.effect_column("true_lat_deg").map(<[f64]>::to_vec).or_else(|| s.recording.lat_deg.clone())?;
        let lon = s.effect_column("true_lon_deg").map(<[f64]>::to_vec).or_else(|| s.recording.lon_deg.clone())?;
        let depth = s.effect_column("depth_m")?;
        let sample = |i: usize| {
            let igrf = geomag::igrf14(lat[i], lon[i], 0.0, self.origin.decimal_year).map(|f| f.total_nt()).unwrap_or(f64::NAN);
            FieldSample {
                t_s: t[i],
                lat_deg: lat[i],
                lon_deg: lon[i],
                depth_m: depth[i],
                north_nt: n[i],
                east_nt: e[i],
                down_nt: d[i],
                total_nt: (n[i] * n[i] + e[i] * e[i] + d[i] * d[i]).sqrt(),
                igrf_total_nt: igrf,
            }
        };
        let mut profile = vec![];
        let mut next_t = f64::NEG_INFINITY;
        let mut lo_hi = [f64::INFINITY, f64::NEG_INFINITY];
        for (i, &ti) in t.iter().enumerate() {
            if ti >= next_t {
                let f = sample(i);
                lo_hi = [lo_hi[0].min(f.total_nt - f.igrf_total_nt), lo_hi[1].max(f.total_nt - f.igrf_total_nt)];
                profile.push(f);
                next_t = ti + 60.0;
            }
        }
        Some(AnomalyTruth { at_start: sample(0), profile, intensity_anomaly_nt_range: lo_hi })
    }
}

fn push(col: &mut Option<Vec<f64>>, v: f64) {
    col.get_or_insert_with(Vec::new).push(v);
}

fn empty(truth: Truth) -> Simulation {
    Simulation {
        recording: Recording::default(),
        true_heading_deg: vec![],
        true_roll_deg: vec![],
        true_pitch_deg: vec![],
        running: vec![],
        effect_columns: vec![],
        truth,
    }
}

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

/// The swing test with real-vehicle effects. The vehicle is held at the
/// surface (0.5 m) at the site, thrusters off (0 A) — unless the thrusters
/// effect asks for a thrust test: then, after the yaw segment, the heading
/// is held and every thruster's current steps through
/// `thrust_test_steps_a`, [`THRUST_TEST_STEP_S`] each. With the
/// temperature effect the sensor starts `swing_start_excess_c` warm.
pub fn swing_with(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64, roll_amp_deg: f64, pitch_amp_deg: f64, effects: &Effects) -> Result<Simulation, SimError> {
    check_rate(rate_hz)?;
    if !((0.0..=90.0).contains(&roll_amp_deg) && (0.0..=60.0).contains(&pitch_amp_deg)) {
        return Err(SimError::Parameter(format!("swing amplitudes roll {roll_amp_deg}°, pitch {pitch_amp_deg}° are outside 0…90° / 0…60°")));
    }
    let mut b = Builder::new(truth_for("swing", seed, sensor, site, None)?, sensor, seed, effects);
    let depth_m = if effects.is_none() { 0.0 } else { 0.5 };
    let n_thrusters = effects.thrusters.as_ref().map_or(0, |m| m.thrusters.len());
    if let Some(thermal) = &effects.temperature {
        b.sensor_temp_c = Some(thermal.equilibrium_c(depth_m, 0.0) + thermal.swing_start_excess_c);
    }
    let steps: &[f64] = effects.thrusters.as_ref().map_or(&[], |m| &m.thrust_test_steps_a);
    let dt = 1.0 / rate_hz;
    let end = SWING_SEGMENTS_S[2].1;
    let yaw0 = 360.0 * b.rng.uniform();
    let n = (end / dt) as usize;
    let n_test = (steps.len() as f64 * THRUST_TEST_STEP_S / dt) as usize;
    for k in 0..n + n_test {
        let t = k as f64 * dt;
        // Held in place: no speed through water, no course over ground.
        let mut env = RowEnv { currents_a: vec![0.0; n_thrusters], depth_m, course_deg: f64::NAN, ..RowEnv::default() };
        if k >= n {
            // Thrust test: heading held, the vehicle rocking a little.
            let step = (((t - end) / THRUST_TEST_STEP_S) as usize).min(steps.len().saturating_sub(1));
            let current = steps.get(step).copied().unwrap_or(0.0);
            env.currents_a = vec![current; n_thrusters];
            let roll = 2.0 * (std::f64::consts::TAU * t / 6.0).sin();
            let pitch = 1.0 * (std::f64::consts::TAU * t / 8.0).sin();
            b.push(t, site.lat_deg, site.lon_deg, site.decimal_year, [roll, pitch, yaw0 + 180.0], current > 0.0, f64::NAN, &env)?;
            continue;
        }
        let roll = roll_amp_deg * (std::f64::consts::TAU * t / 37.0).sin();
        let pitch = if t >= SWING_SEGMENTS_S[1].0 { pitch_amp_deg * (std::f64::consts::TAU * t / 23.0).sin() } else { 0.0 };
        // Yaw: held in the first two segments, then turned all round
        // (−180…180°) at 3°/s, back and forth, starting from the held yaw
        // (a vehicle does not jump: the gyro sees every degree).
        let yaw = if t >= SWING_SEGMENTS_S[2].0 {
            let u = (t - SWING_SEGMENTS_S[2].0) * 3.0;
            let tri = (u % 720.0 - 360.0).abs() - 180.0; // 180 → −180 → 180 triangle
            yaw0 + tri
        } else {
            yaw0 + 180.0
        };
        b.push(t, site.lat_deg, site.lon_deg, site.decimal_year, [roll, pitch, yaw], false, f64::NAN, &env)?;
    }
    Ok(b.finish())
}

fn check_rate(rate_hz: f64) -> Result<(), SimError> {
    if !(0.1..=1000.0).contains(&rate_hz) {
        return Err(SimError::Parameter(format!("rate {rate_hz} Hz is outside 0.1 … 1000 Hz (the sensor's range)")));
    }
    Ok(())
}

/// An out-and-back run with the dolphin profile.
pub fn run(sensor: &SensorModel, site: &Site, params: &RunParams, seed: u64, rate_hz: f64, scenario: &str) -> Result<Simulation, SimError> {
    run_with(sensor, site, params, seed, rate_hz, scenario, &Effects::none())
}

/// An out-and-back run with real-vehicle effects.
///
/// Without the current effect the kinematics are the original ones: the
/// autopilot crabs into `params`' current and the GPS course is the
/// heading plus the crab angle. With it, `params`' current is replaced by
/// the [`WaterModel`](crate::effects::WaterModel)'s: the vehicle moves through the water at its speed
/// (horizontal part `v cos θ`) along its heading, the water moves it, the
/// true position is the integral of the sum, the GPS course over ground is
/// the direction of the (delayed, noisy) ground velocity, the logged
/// position is a noisy GPS fix at the surface and dead reckoning (speed
/// log and heading, no current) from the last fix below it.
#[allow(clippy::too_many_arguments)]
pub fn run_with(sensor: &SensorModel, site: &Site, params: &RunParams, seed: u64, rate_hz: f64, scenario: &str, effects: &Effects) -> Result<Simulation, SimError> {
    check_rate(rate_hz)?;
    let speed_back = params.speed_back_mps.unwrap_or(params.speed_mps);
    if !(params.leg_m > 0.0 && params.speed_mps > 0.0 && speed_back > 0.0 && params.submerged_s > 0.0 && params.surface_s > 0.0) {
        return Err(SimError::Parameter("leg length, speeds and dolphin times must be positive".into()));
    }
    let (current_mps, current_to_deg) = effects.current.as_ref().map_or((params.current_mps, params.current_to_deg), |w| (w.current_mps, w.current_to_deg));
    if !(current_mps >= 0.0 && current_mps < params.speed_mps.min(speed_back) && params.gps_delay_s >= 0.0 && params.gps_delay_s < 60.0) {
        return Err(SimError::Parameter("the current must be slower than the vehicle and the GPS delay within 0…60 s".into()));
    }
    let mut b = Builder::new(truth_for(scenario, seed, sensor, site, Some(*params))?, sensor, seed, effects);
    let dt = 1.0 / rate_hz;
    let leg_s = params.leg_m / params.speed_mps;
    let leg_back_s = params.leg_m / speed_back;
    let turn_s = 90.0;
    let total = if params.speed_back_mps.is_none() { 2.0 * leg_s + turn_s } else { leg_s + turn_s + leg_back_s };
    let cycle = params.submerged_s + params.surface_s;
    let (mut lat, mut lon) = (site.lat_deg, site.lon_deg);
    // Course over the turn: from out to back, through the shorter side.
    let sweep = calib_core::heading::wrap_pi((params.course_back_deg - params.course_out_deg).to_radians()).to_degrees();
    let n = (total / dt) as usize;
    let mut course_history: Vec<f64> = Vec::with_capacity(n);
    // Current effect: ground velocity history (for the GPS delay), the
    // logged position (fix or dead reckoning), depth.
    let mut ground_history: Vec<[f64; 2]> = Vec::new();
    let (mut nav_lat, mut nav_lon) = (lat, lon);
    let mut depth_m: f64 = 0.0;
    let mut last_heading: Option<f64> = None;
    if let (Some(thermal), Some(thrusters)) = (&effects.temperature, &effects.thrusters) {
        let bus: f64 = thrusters.currents_a(params.speed_mps, 0.0).iter().sum();
        b.sensor_temp_c = Some(thermal.equilibrium_c(0.0, bus));
    }
    for k in 0..n {
        let t = k as f64 * dt;
        let (course, surfaced, turning) = if t < leg_s {
            (params.course_out_deg, (t % cycle) < params.surface_s, false)
        } else if t < leg_s + turn_s {
            (params.course_out_deg + sweep * (t - leg_s) / turn_s, true, true)
        } else {
            let tb = t - leg_s - turn_s;
            (params.course_back_deg, (tb % cycle) < params.surface_s, false)
        };
        let speed = if t < leg_s + turn_s / 2.0 { params.speed_mps } else { speed_back };
        // Pitch: dive after each surfacing, climb before the next.
        let phase = if t < leg_s { t % cycle } else if turning { 0.0 } else { (t - leg_s - turn_s) % cycle };
        let pitch = if surfaced {
            2.0 * (std::f64::consts::TAU * t / 7.0).sin()
        } else if phase < params.surface_s + 40.0 {
            -12.0
        } else if phase > cycle - 40.0 {
            12.0
        } else {
            0.5 * (std::f64::consts::TAU * t / 60.0).sin()
        };
        let roll = if surfaced { 4.0 * (std::f64::consts::TAU * t / 6.0).sin() } else { 1.0 * (std::f64::consts::TAU * t / 45.0).sin() };
        // The autopilot holds the course over ground: it heads into the
        // cross-current by the crab angle asin(c⊥/V), which changes sign on
        // the reciprocal leg.
        let cross = current_mps * (current_to_deg - course).to_radians().sin();
        let crab = (cross / speed).clamp(-0.5, 0.5).asin().to_degrees();
        let heading = course - crab + if turning { 0.0 } else { 1.5 * (std::f64::consts::TAU * t / 90.0).sin() };
        let yaw_rate_deg_s = last_heading.map_or(0.0, |h: f64| calib_core::heading::wrap_pi((heading - h).to_radians()).to_degrees() / dt);
        last_heading = Some(heading);
        let mut env = RowEnv { depth_m, speed_mps: speed, ..RowEnv::default() };
        if let Some(thrusters) = &effects.thrusters {
            env.currents_a = thrusters.currents_a(speed, yaw_rate_deg_s);
        }
        let reference;
        let ground_ne;
        if let Some(water) = &effects.current {
            // Velocity through the water along the heading plus the current.
            let c = water.current_ne_mps();
            let v_h = speed * pitch.to_radians().cos();
            let h = heading.to_radians();
            ground_ne = [v_h * h.cos() + c[0], v_h * h.sin() + c[1]];
            env.course_deg = wrap_two_pi(ground_ne[1].atan2(ground_ne[0])).to_degrees();
            ground_history.push(ground_ne);
            let delayed = k.checked_sub((params.gps_delay_s / dt).round() as usize).map(|i| ground_history[i]);
            // Keeps the sensor's generator in step with the effect-free run.
            let _ = if surfaced && delayed.is_some() { b.rng.gauss() } else { 0.0 };
            reference = match (surfaced, delayed) {
                (true, Some(v)) => {
                    let vn = v[0] + water.gps_velocity_noise_mps * b.erng.gauss();
                    let ve = v[1] + water.gps_velocity_noise_mps * b.erng.gauss();
                    wrap_two_pi(ve.atan2(vn)).to_degrees()
                }
                _ => f64::NAN,
            };
            if surfaced {
                nav_lat = lat + water.gps_position_noise_m * b.erng.gauss() / M_PER_DEG_LAT;
                nav_lon = lon + water.gps_position_noise_m * b.erng.gauss() / (M_PER_DEG_LAT * lat.to_radians().cos());
            }
            env.logged_lat_lon = Some((nav_lat, nav_lon));
        } else {
            let true_course = heading + crab;
            course_history.push(true_course);
            // GPS course at the surface, `gps_delay_s` late.
            let delayed = k.checked_sub((params.gps_delay_s / dt).round() as usize).map(|i| course_history[i]);
            reference = match (surfaced, delayed) {
                (true, Some(c)) => wrap_two_pi((c + params.gps_noise_deg * b.rng.gauss()).to_radians()).to_degrees(),
                _ => f64::NAN,
            };
            ground_ne = [f64::NAN; 2];
            env.course_deg = true_course;
        }
        b.push(t, lat, lon, site.decimal_year, [roll, pitch, heading], true, reference, &env)?;
        if effects.current.is_none() {
            // Move along the course over ground (the original kinematics).
            let step = speed * dt;
            let c = env.course_deg.to_radians();
            lat += step * c.cos() / M_PER_DEG_LAT;
            lon += step * c.sin() / (M_PER_DEG_LAT * lat.to_radians().cos());
        } else {
            // Move over the ground with the velocity through water plus the current.
            lat += ground_ne[0] * dt / M_PER_DEG_LAT;
            lon += ground_ne[1] * dt / (M_PER_DEG_LAT * lat.to_radians().cos());
            // Dead reckoning: the speed log along the heading, no current.
            let h = heading.to_radians();
            let v_h = speed * pitch.to_radians().cos();
            nav_lat += v_h * h.cos() * dt / M_PER_DEG_LAT;
            nav_lon += v_h * h.sin() * dt / (M_PER_DEG_LAT * nav_lat.to_radians().cos());
        }
        depth_m = if surfaced { 0.0 } else { (depth_m - speed * pitch.to_radians().sin() * dt).max(0.0) };
    }
    b.sim.truth.turnaround_s = Some(leg_s + turn_s / 2.0);
    Ok(b.finish())
}

/// A MEMS gyro mounted with the magnetometer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GyroModel {
    /// Constant bias, rad/s.
    pub bias_rad_s: [f64; 3],
    /// White noise per axis and sample, rad/s (1σ).
    pub noise_rad_s: f64,
    /// Small rotation of the gyro triad against the magnetometer's axes,
    /// rad (about x, y, z).
    pub misalignment_rad: [f64; 3],
}

impl GyroModel {
    /// A consumer MEMS gyro after its factory calibration: 0.2–0.3 °/s of
    /// bias, 0.1 °/s of noise, axes within 0.2° of the magnetometer's.
    pub fn mems() -> Self {
        Self { bias_rad_s: [0.004, -0.003, 0.005], noise_rad_s: 0.002, misalignment_rad: [0.003, -0.002, 0.004] }
    }
}

impl Simulation {
    /// Adds `gx, gy, gz`: the body rates of the true attitude history
    /// (Euler-angle rates by central differences over the sample interval,
    /// turned into body rates by the Z-Y-X kinematics
    /// `p = φ̇ − ψ̇ sin θ`, `q = θ̇ cos φ + ψ̇ sin φ cos θ`,
    /// `r = −θ̇ sin φ + ψ̇ cos φ cos θ`), through the misaligned triad, plus
    /// bias and noise (a generator of its own, so the magnetometer's noise
    /// is the same with and without the gyro).
    pub fn with_gyro(mut self, gyro: &GyroModel, seed: u64) -> Self {
        let mut rng = SplitMix64::new(seed ^ 0x6779_726F);
        let t = self.recording.t_s.clone().unwrap_or_default();
        let n = t.len().min(self.true_heading_deg.len());
        let [mx, my, mz] = gyro.misalignment_rad;
        let misalign = [[1.0, -mz, my], [mz, 1.0, -mx], [-my, mx, 1.0]];
        let (mut gx, mut gy, mut gz) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for i in 0..n {
            let (a, b) = (i.saturating_sub(1), (i + 1).min(n - 1));
            let span = t[b] - t[a];
            let rate = |v: &[f64], wrap: bool| {
                let mut d = v[b] - v[a];
                if wrap {
                    d = (d + 540.0).rem_euclid(360.0) - 180.0;
                }
                if span > 0.0 { d.to_radians() / span } else { 0.0 }
            };
            let (roll_dot, pitch_dot, yaw_dot) = (rate(&self.true_roll_deg, false), rate(&self.true_pitch_deg, false), rate(&self.true_heading_deg, true));
            let (roll, pitch) = (self.true_roll_deg[i].to_radians(), self.true_pitch_deg[i].to_radians());
            let body = [
                roll_dot - yaw_dot * pitch.sin(),
                pitch_dot * roll.cos() + yaw_dot * roll.sin() * pitch.cos(),
                -pitch_dot * roll.sin() + yaw_dot * roll.cos() * pitch.cos(),
            ];
            let seen = mul_mat_vec(&misalign, body);
            gx.push(seen[0] + gyro.bias_rad_s[0] + gyro.noise_rad_s * rng.gauss());
            gy.push(seen[1] + gyro.bias_rad_s[1] + gyro.noise_rad_s * rng.gauss());
            gz.push(seen[2] + gyro.bias_rad_s[2] + gyro.noise_rad_s * rng.gauss());
        }
        self.recording.gx_rad_s = Some(gx);
        self.recording.gy_rad_s = Some(gy);
        self.recording.gz_rad_s = Some(gz);
        self
    }

    /// Writes `path` (the recording plus truth columns) and `<path>.truth.json`.
    pub fn write(&self, path: &Path) -> Result<(), SimError> {
        let running: Vec<f64> = self.running.iter().map(|&r| if r { 1.0 } else { 0.0 }).collect();
        let mut extra: Vec<(&str, &Vec<f64>)> =
            vec![("true_heading_deg", &self.true_heading_deg), ("true_roll_deg", &self.true_roll_deg), ("true_pitch_deg", &self.true_pitch_deg), ("running", &running)];
        extra.extend(self.effect_columns.iter().map(|(n, c)| (n.as_str(), c)));
        self.recording.write_with_extra(path, &extra)?;
        let truth_path = truth_path(path);
        let text = serde_json::to_string_pretty(&self.truth).map_err(|e| SimError::Parameter(e.to_string()))?;
        std::fs::write(&truth_path, text).map_err(|source| SimError::Io { path: truth_path.display().to_string(), source })?;
        Ok(())
    }
}

/// `run.csv` → `run.truth.json`.
pub fn truth_path(path: &Path) -> std::path::PathBuf {
    path.with_extension("truth.json")
}
