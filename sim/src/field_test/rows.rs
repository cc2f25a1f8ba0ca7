//! One row of a recording from the true state of the vehicle and the
//! effects that are on: the true field, the body-fixed sources, the bridge
//! gain, the sensor's counts, the logged attitude and position, and the
//! effects' truth columns.

use calib_core::heading::wrap_two_pi;
use calib_core::linalg::mul_mat_vec;

use host_tools::geomag::{self, Site};

use super::noise::Noise;
use super::{EffectsTruth, SensorModel, SimError, Simulation, Truth};
use crate::effects::{euler_dcm, Effects, M_PER_DEG_LAT};

/// The true state of the vehicle at one row.
#[derive(Debug, Clone, Copy)]
pub(super) struct Row {
    /// Time, s.
    pub t_s: f64,
    /// True latitude, degrees.
    pub lat_deg: f64,
    /// True longitude, degrees.
    pub lon_deg: f64,
    /// True roll, pitch, yaw (heading), degrees.
    pub attitude_deg: [f64; 3],
    /// Thrusters and electronics on.
    pub running: bool,
    /// The GPS course logged with the row (NaN: none), degrees.
    pub reference_deg: f64,
}

/// What a row's effects need from its manoeuvre.
#[derive(Debug, Clone, Default)]
pub(super) struct RowEnv {
    /// Each thruster's current, A (thrusters effect).
    pub currents_a: Vec<f64>,
    /// Depth, m.
    pub depth_m: f64,
    /// Speed through water, m/s.
    pub speed_mps: f64,
    /// The position the vehicle logs (GPS fix or dead reckoning) when it is
    /// not the true one (current effect).
    pub logged_lat_lon: Option<(f64, f64)>,
    /// True course over ground, degrees (current effect).
    pub course_deg: f64,
}

/// Builds a simulation row by row.
pub(super) struct Rows<'a> {
    sim: Simulation,
    sensor: &'a SensorModel,
    effects: &'a Effects,
    /// The generators ([`super::noise`] gives their draw order).
    pub noise: Noise,
    origin: Site,
    /// The sensor's true temperature at the last row (temperature effect),
    /// °C; set before the first row to where the manoeuvre starts it.
    pub sensor_temp_c: Option<f64>,
    last_t: Option<f64>,
}

impl<'a> Rows<'a> {
    /// No rows yet.
    pub fn new(truth: Truth, sensor: &'a SensorModel, seed: u64, effects: &'a Effects) -> Self {
        let origin = truth.site;
        Self { sim: Simulation::empty(truth), sensor, effects, noise: Noise::new(seed), origin, sensor_temp_c: None, last_t: None }
    }

    /// The simulation's truth, to fill in what the manoeuvre knows.
    pub fn truth_mut(&mut self) -> &mut Truth {
        &mut self.sim.truth
    }

    /// North and east of the site, m (the simulator's flat earth).
    fn local_m(&self, lat_deg: f64, lon_deg: f64) -> (f64, f64) {
        ((lat_deg - self.origin.lat_deg) * M_PER_DEG_LAT, (lon_deg - self.origin.lon_deg) * M_PER_DEG_LAT * lat_deg.to_radians().cos())
    }

    /// The true field outside the hull, NED nT: IGRF-14 plus the crustal
    /// anomaly (whose sum goes into the `true_field_*` columns) plus a steel
    /// structure nearby; and the structure's field alone.
    fn outside_field_ned(&mut self, row: &Row, env: &RowEnv) -> Result<([f64; 3], [f64; 3]), SimError> {
        let f = geomag::igrf14(row.lat_deg, row.lon_deg, 0.0, self.origin.decimal_year)?;
        let mut field_ned = [f.north_nt, f.east_nt, f.down_nt];
        if let Some(anomaly) = &self.effects.anomaly {
            let (north_m, east_m) = self.local_m(row.lat_deg, row.lon_deg);
            let a = anomaly.field_nt(north_m, east_m, env.depth_m);
            for k in 0..3 {
                field_ned[k] += a[k];
            }
            self.sim.push_column("true_field_n_nt", field_ned[0]);
            self.sim.push_column("true_field_e_nt", field_ned[1]);
            self.sim.push_column("true_field_d_nt", field_ned[2]);
        }
        let mut structure_ned = [0.0; 3];
        if let Some(structure) = &self.effects.structure {
            let (north_m, east_m) = self.local_m(row.lat_deg, row.lon_deg);
            structure_ned = structure.field_nt([north_m, east_m, env.depth_m], [f.north_nt, f.east_nt, f.down_nt]);
            for k in 0..3 {
                field_ned[k] += structure_ned[k];
            }
            self.sim.push_column("structure_distance_m", structure.distance_m([north_m, east_m, env.depth_m]));
        }
        Ok((field_ned, structure_ned))
    }

    /// The thrusters' field at the sensor (body, nT) and the true bus
    /// current (A); logs the bus current with its sensor's noise.
    fn thrusters(&mut self, env: &RowEnv) -> ([f64; 3], f64) {
        let Some(thrusters) = &self.effects.thrusters else { return ([0.0; 3], 0.0) };
        let field = thrusters.field_nt(&env.currents_a);
        let bus_a: f64 = env.currents_a.iter().sum();
        let logged = bus_a + thrusters.current_noise_a * self.noise.effects.gauss();
        push(&mut self.sim.recording.motor_current_a, logged);
        self.sim.push_column("bus_current_a", bus_a);
        for (k, i) in env.currents_a.iter().enumerate() {
            self.sim.push_column(&format!("thruster_{k}_a"), *i);
        }
        (field, bus_a)
    }

    /// The bridge gain of each axis at the sensor's temperature, which lags
    /// the water's (temperature effect); logs the thermistor.
    fn bridge_gain(&mut self, t_s: f64, depth_m: f64, bus_a: f64) -> [f64; 3] {
        let Some(thermal) = &self.effects.temperature else { return [1.0; 3] };
        let target = thermal.equilibrium_c(depth_m, bus_a);
        // Starts where the manoeuvre put it (or at equilibrium), then lags.
        let temp = match (self.sensor_temp_c, self.last_t) {
            (Some(temp), Some(t0)) => thermal.step(temp, target, t_s - t0),
            (Some(temp), None) => temp,
            (None, _) => target,
        };
        self.sensor_temp_c = Some(temp);
        let logged = temp + thermal.thermistor_offset_c + thermal.thermistor_noise_c * self.noise.effects.gauss();
        push(&mut self.sim.recording.temp_c, logged);
        self.sim.push_column("sensor_temp_c", temp);
        thermal.gain(temp)
    }

    /// Adds one row.
    pub fn push(&mut self, row: &Row, env: &RowEnv) -> Result<(), SimError> {
        let [roll, pitch, yaw] = row.attitude_deg;
        let (field_ned, structure_ned) = self.outside_field_ned(row, env)?;
        // The body frame by the simulator's own direction-cosine matrices, not
        // calib-core's rotation: a convention error there would show here.
        let dcm = euler_dcm(roll, pitch, yaw);
        let h = mul_mat_vec(&dcm, field_ned);
        let (thruster_nt, bus_a) = self.thrusters(env);
        // The thrusters' dipoles replace the constant running bias.
        let running_bias = row.running && self.effects.thrusters.is_none();
        let bridge_gain = self.bridge_gain(row.t_s, env.depth_m, bus_a);
        let e = self.effects;
        if e.temperature.is_some() || e.anomaly.is_some() || e.water_current.is_some() || e.structure.is_some() {
            self.sim.push_column("depth_m", env.depth_m);
        }
        self.last_t = Some(row.t_s);
        let payload_nt = self.payload(row.t_s);
        let body_fixed_nt = [thruster_nt[0] + payload_nt[0], thruster_nt[1] + payload_nt[1], thruster_nt[2] + payload_nt[2]];
        if e.structure.is_some() || e.payload.is_some() {
            let s = mul_mat_vec(&dcm, structure_ned);
            let d = [s[0] + payload_nt[0], s[1] + payload_nt[1], s[2] + payload_nt[2]];
            self.sim.push_column("truth_disturbance_nt", (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
        }
        let raw = self.sensor.measure_env(h, body_fixed_nt, bridge_gain, running_bias, &mut self.noise.sensor);
        self.log_water(row, env);
        self.record(row, raw, env);
        Ok(())
    }

    /// A payload's hard iron at the sensor (body, nT; zero before it is
    /// switched on) and its truth column.
    fn payload(&mut self, t_s: f64) -> [f64; 3] {
        let Some(payload) = &self.effects.payload else { return [0.0; 3] };
        let on = payload.is_on(self.sim.truth.scenario, t_s);
        self.sim.push_column("payload_on", if on { 1.0 } else { 0.0 });
        if on { payload.field_nt() } else { [0.0; 3] }
    }

    /// The speed log and the true track (current effect).
    fn log_water(&mut self, row: &Row, env: &RowEnv) {
        let Some(water) = &self.effects.water_current else { return };
        let logged = env.speed_mps * water.speed_log_scale + water.speed_log_noise_mps * self.noise.effects.gauss();
        push(&mut self.sim.recording.speed_mps, logged);
        self.sim.push_column("water_speed_mps", env.speed_mps);
        self.sim.push_column("true_lat_deg", row.lat_deg);
        self.sim.push_column("true_lon_deg", row.lon_deg);
        self.sim.push_column("true_course_deg", env.course_deg);
    }

    /// The recording's columns and the true attitude.
    fn record(&mut self, row: &Row, raw: [f64; 3], env: &RowEnv) {
        let [roll, pitch, yaw] = row.attitude_deg;
        let (ahrs_roll, ahrs_pitch) = match &self.effects.ahrs {
            Some(m) => {
                let [r, p, _] = m.reported_deg(roll, pitch, yaw);
                (r, p)
            }
            None => (roll, pitch),
        };
        let (logged_lat, logged_lon) = env.logged_lat_lon.unwrap_or((row.lat_deg, row.lon_deg));
        let n = self.sensor.ahrs_noise_deg;
        let bias = self.sensor.ahrs_bias_deg;
        let rng = &mut self.noise.sensor;
        let r = &mut self.sim.recording;
        r.mag.push(raw);
        push(&mut r.t_s, row.t_s);
        push(&mut r.roll_deg, ahrs_roll + bias[0] + n * rng.gauss());
        push(&mut r.pitch_deg, ahrs_pitch + bias[1] + n * rng.gauss());
        push(&mut r.ref_heading_deg, row.reference_deg);
        push(&mut r.lat_deg, logged_lat);
        push(&mut r.lon_deg, logged_lon);
        self.sim.true_heading_deg.push(wrap_two_pi(yaw.to_radians()).to_degrees());
        self.sim.true_roll_deg.push(roll);
        self.sim.true_pitch_deg.push(pitch);
        self.sim.running.push(row.running);
    }

    /// The simulation, with the effects' truth filled in from the rows.
    pub fn finish(mut self) -> Simulation {
        if !self.effects.is_none() {
            self.sim.truth.effects = Some(EffectsTruth::from_rows(&self.sim, self.effects, self.sensor));
        }
        self.sim
    }
}

fn push(col: &mut Option<Vec<f64>>, v: f64) {
    col.get_or_insert_with(Vec::new).push(v);
}
