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
//! The gyro ([`GyroModel`], [`Simulation::with_gyro`]): the body rates of the
//! true attitude history (Z-Y-X Euler-angle kinematics), seen through a
//! slightly misaligned triad, plus a constant bias and white noise.

use std::path::Path;

use calib_core::conformance::SplitMix64;
use calib_core::heading::{ned_to_body, wrap_two_pi};
use calib_core::linalg::{mul_mat, mul_mat_vec, Mat3};
use calib_core::ortho::{gamma, OrthoAngles};
use serde::{Deserialize, Serialize};

use host_tools::data::recording::{Recording, RecordingError};
use host_tools::geomag::{self, GeomagError, Site};

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

    /// Raw counts for a body-frame field, with noise, quantised.
    fn measure(&self, h_body: [f64; 3], running: bool, rng: &mut SplitMix64) -> [f64; 3] {
        let r = mul_mat_vec(&self.gain_raw_per_nt, h_body);
        let mut out = [0.0; 3];
        for k in 0..3 {
            let gain = self.gain_raw_per_nt[k][k].abs();
            let b = self.bias_raw[k] + if running { self.running_bias_raw[k] } else { 0.0 };
            out[k] = (r[k] + b + self.noise_nt * gain * rng.gauss()).round();
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
    /// The truth.
    pub truth: Truth,
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
    })
}

struct Builder<'a> {
    sim: Simulation,
    sensor: &'a SensorModel,
    rng: SplitMix64,
}

impl Builder<'_> {
    #[allow(clippy::too_many_arguments)]
    fn push(&mut self, t: f64, lat: f64, lon: f64, year: f64, attitude_deg: [f64; 3], running: bool, reference_deg: f64) -> Result<(), SimError> {
        let [roll, pitch, yaw] = attitude_deg;
        let f = geomag::igrf14(lat, lon, 0.0, year)?;
        let h = ned_to_body([f.north_nt, f.east_nt, f.down_nt], roll.to_radians(), pitch.to_radians(), yaw.to_radians());
        let raw = self.sensor.measure(h, running, &mut self.rng);
        let n = self.sensor.ahrs_noise_deg;
        let r = &mut self.sim.recording;
        r.mag.push(raw);
        push(&mut r.t_s, t);
        push(&mut r.roll_deg, roll + self.sensor.ahrs_bias_deg[0] + n * self.rng.gauss());
        push(&mut r.pitch_deg, pitch + self.sensor.ahrs_bias_deg[1] + n * self.rng.gauss());
        push(&mut r.ref_heading_deg, reference_deg);
        push(&mut r.lat_deg, lat);
        push(&mut r.lon_deg, lon);
        self.sim.true_heading_deg.push(wrap_two_pi(yaw.to_radians()).to_degrees());
        self.sim.true_roll_deg.push(roll);
        self.sim.true_pitch_deg.push(pitch);
        self.sim.running.push(running);
        Ok(())
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
        truth,
    }
}

/// Segment boundaries of the swing test, seconds from its start (paper
/// Table 2: roll only, roll + pitch, roll + pitch + yaw).
pub const SWING_SEGMENTS_S: [(f64, f64, &str); 3] = [(0.0, 300.0, "roll"), (300.0, 730.0, "roll+pitch"), (730.0, 1330.0, "roll+pitch+yaw")];

/// The swing test: the vehicle turned by a diver, thrusters off (roll ±55°,
/// pitch ±10°, as in paper 000).
pub fn swing(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64) -> Result<Simulation, SimError> {
    swing_limited(sensor, site, seed, rate_hz, 55.0, 10.0)
}

/// The swing test with other roll and pitch amplitudes, degrees (a vehicle
/// that cannot be rolled far: ±15° / ±5°).
pub fn swing_limited(sensor: &SensorModel, site: &Site, seed: u64, rate_hz: f64, roll_amp_deg: f64, pitch_amp_deg: f64) -> Result<Simulation, SimError> {
    check_rate(rate_hz)?;
    if !((0.0..=90.0).contains(&roll_amp_deg) && (0.0..=60.0).contains(&pitch_amp_deg)) {
        return Err(SimError::Parameter(format!("swing amplitudes roll {roll_amp_deg}°, pitch {pitch_amp_deg}° are outside 0…90° / 0…60°")));
    }
    let mut b = Builder { sim: empty(truth_for("swing", seed, sensor, site, None)?), sensor, rng: SplitMix64::new(seed) };
    let dt = 1.0 / rate_hz;
    let end = SWING_SEGMENTS_S[2].1;
    let yaw0 = 360.0 * b.rng.uniform();
    let n = (end / dt) as usize;
    for k in 0..n {
        let t = k as f64 * dt;
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
        b.push(t, site.lat_deg, site.lon_deg, site.decimal_year, [roll, pitch, yaw], false, f64::NAN)?;
    }
    Ok(b.sim)
}

fn check_rate(rate_hz: f64) -> Result<(), SimError> {
    if !(0.1..=1000.0).contains(&rate_hz) {
        return Err(SimError::Parameter(format!("rate {rate_hz} Hz is outside 0.1 … 1000 Hz (the sensor's range)")));
    }
    Ok(())
}

/// An out-and-back run with the dolphin profile.
pub fn run(sensor: &SensorModel, site: &Site, params: &RunParams, seed: u64, rate_hz: f64, scenario: &str) -> Result<Simulation, SimError> {
    check_rate(rate_hz)?;
    if !(params.leg_m > 0.0 && params.speed_mps > 0.0 && params.submerged_s > 0.0 && params.surface_s > 0.0) {
        return Err(SimError::Parameter("leg length, speed and dolphin times must be positive".into()));
    }
    if !(params.current_mps >= 0.0 && params.current_mps < params.speed_mps && params.gps_delay_s >= 0.0 && params.gps_delay_s < 60.0) {
        return Err(SimError::Parameter("the current must be slower than the vehicle and the GPS delay within 0…60 s".into()));
    }
    let mut b = Builder { sim: empty(truth_for(scenario, seed, sensor, site, Some(*params))?), sensor, rng: SplitMix64::new(seed) };
    let dt = 1.0 / rate_hz;
    let leg_s = params.leg_m / params.speed_mps;
    let turn_s = 90.0;
    let total = 2.0 * leg_s + turn_s;
    let cycle = params.submerged_s + params.surface_s;
    let (mut lat, mut lon) = (site.lat_deg, site.lon_deg);
    // Course over the turn: from out to back, through the shorter side.
    let sweep = calib_core::heading::wrap_pi((params.course_back_deg - params.course_out_deg).to_radians()).to_degrees();
    let n = (total / dt) as usize;
    let mut course_history: Vec<f64> = Vec::with_capacity(n);
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
        let cross = params.current_mps * (params.current_to_deg - course).to_radians().sin();
        let crab = (cross / params.speed_mps).clamp(-0.5, 0.5).asin().to_degrees();
        let heading = course - crab + if turning { 0.0 } else { 1.5 * (std::f64::consts::TAU * t / 90.0).sin() };
        let true_course = heading + crab;
        course_history.push(true_course);
        // GPS course at the surface, `gps_delay_s` late.
        let delayed = k.checked_sub((params.gps_delay_s / dt).round() as usize).map(|i| course_history[i]);
        let reference = match (surfaced, delayed) {
            (true, Some(c)) => wrap_two_pi((c + params.gps_noise_deg * b.rng.gauss()).to_radians()).to_degrees(),
            _ => f64::NAN,
        };
        b.push(t, lat, lon, site.decimal_year, [roll, pitch, heading], true, reference)?;
        // Move along the course over ground.
        let step = params.speed_mps * dt;
        let c = true_course.to_radians();
        lat += step * c.cos() / 111_320.0;
        lon += step * c.sin() / (111_320.0 * lat.to_radians().cos());
    }
    b.sim.truth.turnaround_s = Some(leg_s + turn_s / 2.0);
    Ok(b.sim)
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
        self.recording.write_with_extra(
            path,
            &[
                ("true_heading_deg", &self.true_heading_deg),
                ("true_roll_deg", &self.true_roll_deg),
                ("true_pitch_deg", &self.true_pitch_deg),
                ("running", &self.running.iter().map(|&r| if r { 1.0 } else { 0.0 }).collect::<Vec<_>>()),
            ],
        )?;
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
