//! How the vehicle moves over the ground on a run, and what GPS and the
//! navigation log make of it: two models.
//!
//! * [`AlongCourse`] (the original kinematics, every effect but the current):
//!   the autopilot holds the course over ground, the vehicle moves along it
//!   at its speed through water, the GPS course is the true course `gps_delay_s`
//!   late plus white noise, the logged position the true one.
//! * [`WithWater`] (the current effect): the vehicle moves through the water
//!   at its speed (horizontal part `v cos θ`) along its heading, the water
//!   moves it, the true position is the integral of the sum, the GPS course
//!   over ground is the direction of the (delayed, noisy) ground velocity,
//!   the logged position is a noisy GPS fix at the surface and dead
//!   reckoning (speed log and heading, no current) from the last fix below it.

use calib_core::conformance::SplitMix64;
use calib_core::heading::wrap_two_pi;

use crate::effects::{WaterModel, M_PER_DEG_LAT};

/// The vehicle's motion at one row, as the autopilot sets it.
#[derive(Debug, Clone, Copy)]
pub(super) struct Motion {
    /// At the surface (GPS available).
    pub surfaced: bool,
    /// Speed through the water, m/s.
    pub speed_mps: f64,
    /// Pitch, degrees.
    pub pitch_deg: f64,
    /// Heading, degrees.
    pub heading_deg: f64,
    /// Crab angle the autopilot holds into the cross-current, degrees.
    pub crab_deg: f64,
}

/// What the navigation sees at one row.
#[derive(Debug, Clone, Copy)]
pub(super) struct Observed {
    /// The GPS course logged (NaN below the surface or before the first
    /// delayed course), degrees.
    pub reference_deg: f64,
    /// The true course over ground, degrees.
    pub course_deg: f64,
    /// The logged position when it is not the true one.
    pub logged_lat_lon: Option<(f64, f64)>,
}

/// A position on the simulator's flat earth, degrees.
#[derive(Debug, Clone, Copy)]
struct LatLon {
    lat_deg: f64,
    lon_deg: f64,
}

impl LatLon {
    /// Moves by `north_m`, `east_m` (the longitude step at the new latitude).
    fn step(&mut self, north_m: f64, east_m: f64) {
        self.lat_deg += north_m / M_PER_DEG_LAT;
        self.lon_deg += east_m / (M_PER_DEG_LAT * self.lat_deg.to_radians().cos());
    }
}

/// The original kinematics: along the course over ground.
pub(super) struct AlongCourse {
    at: LatLon,
    delay_rows: usize,
    gps_noise_deg: f64,
    course_history: Vec<f64>,
}

/// The current effect's kinematics: through the water plus the current.
pub(super) struct WithWater<'a> {
    at: LatLon,
    nav: LatLon,
    water: &'a WaterModel,
    delay_rows: usize,
    ground_history: Vec<[f64; 2]>,
}

/// One of the two models.
pub(super) enum Kinematics<'a> {
    /// [`AlongCourse`].
    AlongCourse(AlongCourse),
    /// [`WithWater`].
    WithWater(WithWater<'a>),
}

impl<'a> Kinematics<'a> {
    /// Starting at `lat_deg, lon_deg`; the GPS course `delay_rows` rows late.
    pub fn new(lat_deg: f64, lon_deg: f64, water: Option<&'a WaterModel>, delay_rows: usize, gps_noise_deg: f64, rows: usize) -> Self {
        let at = LatLon { lat_deg, lon_deg };
        match water {
            None => Self::AlongCourse(AlongCourse { at, delay_rows, gps_noise_deg, course_history: Vec::with_capacity(rows) }),
            Some(water) => Self::WithWater(WithWater { at, nav: at, water, delay_rows, ground_history: Vec::new() }),
        }
    }

    /// The true position, degrees.
    pub fn position_deg(&self) -> (f64, f64) {
        let at = match self {
            Self::AlongCourse(m) => m.at,
            Self::WithWater(m) => m.at,
        };
        (at.lat_deg, at.lon_deg)
    }

    /// What the navigation sees at row `k`. `gps_draw` is the sensor
    /// generator's normal deviate for the GPS course, drawn when the
    /// vehicle is at the surface and a delayed course exists (both models
    /// draw it, see [`super::noise`]; only [`AlongCourse`] uses it).
    pub fn observe(&mut self, k: usize, m: &Motion, gps_draw: Option<f64>, effects_rng: &mut SplitMix64) -> Observed {
        match self {
            Self::AlongCourse(a) => a.observe(k, m, gps_draw),
            Self::WithWater(w) => w.observe(k, m, effects_rng),
        }
    }

    /// Moves the vehicle over one sample interval after row `k`.
    pub fn advance(&mut self, m: &Motion, observed: &Observed, dt_s: f64) {
        match self {
            Self::AlongCourse(a) => a.advance(m, observed, dt_s),
            Self::WithWater(w) => w.advance(m, dt_s),
        }
    }
}

impl AlongCourse {
    fn observe(&mut self, k: usize, m: &Motion, gps_draw: Option<f64>) -> Observed {
        let true_course = m.heading_deg + m.crab_deg;
        self.course_history.push(true_course);
        // GPS course at the surface, `gps_delay_s` late.
        let delayed = k.checked_sub(self.delay_rows).map(|i| self.course_history[i]);
        let reference_deg = match (m.surfaced, delayed, gps_draw) {
            (true, Some(c), Some(g)) => wrap_two_pi((c + self.gps_noise_deg * g).to_radians()).to_degrees(),
            _ => f64::NAN,
        };
        Observed { reference_deg, course_deg: true_course, logged_lat_lon: None }
    }

    fn advance(&mut self, m: &Motion, observed: &Observed, dt_s: f64) {
        let step = m.speed_mps * dt_s;
        let c = observed.course_deg.to_radians();
        self.at.step(step * c.cos(), step * c.sin());
    }
}

impl WithWater<'_> {
    /// Velocity over the ground: through the water along the heading plus
    /// the current, north and east, m/s.
    fn ground_ne_mps(&self, m: &Motion) -> [f64; 2] {
        let c = self.water.current_ne_mps();
        let [n, e] = self.through_water_ne_mps(m);
        [n + c[0], e + c[1]]
    }

    /// Velocity through the water (the speed log's, horizontal), m/s.
    fn through_water_ne_mps(&self, m: &Motion) -> [f64; 2] {
        let v_h = m.speed_mps * m.pitch_deg.to_radians().cos();
        let h = m.heading_deg.to_radians();
        [v_h * h.cos(), v_h * h.sin()]
    }

    fn observe(&mut self, k: usize, m: &Motion, rng: &mut SplitMix64) -> Observed {
        let ground_ne = self.ground_ne_mps(m);
        let course_deg = wrap_two_pi(ground_ne[1].atan2(ground_ne[0])).to_degrees();
        self.ground_history.push(ground_ne);
        let delayed = k.checked_sub(self.delay_rows).map(|i| self.ground_history[i]);
        let reference_deg = match (m.surfaced, delayed) {
            (true, Some(v)) => {
                let vn = v[0] + self.water.gps_velocity_noise_mps * rng.gauss();
                let ve = v[1] + self.water.gps_velocity_noise_mps * rng.gauss();
                wrap_two_pi(ve.atan2(vn)).to_degrees()
            }
            _ => f64::NAN,
        };
        if m.surfaced {
            let noise = self.water.gps_position_noise_m;
            self.nav.lat_deg = self.at.lat_deg + noise * rng.gauss() / M_PER_DEG_LAT;
            self.nav.lon_deg = self.at.lon_deg + noise * rng.gauss() / (M_PER_DEG_LAT * self.at.lat_deg.to_radians().cos());
        }
        Observed { reference_deg, course_deg, logged_lat_lon: Some((self.nav.lat_deg, self.nav.lon_deg)) }
    }

    fn advance(&mut self, m: &Motion, dt_s: f64) {
        let ground_ne = self.ground_ne_mps(m);
        self.at.step(ground_ne[0] * dt_s, ground_ne[1] * dt_s);
        // Dead reckoning: the speed log along the heading, no current.
        let [n, e] = self.through_water_ne_mps(m);
        self.nav.step(n * dt_s, e * dt_s);
    }
}
