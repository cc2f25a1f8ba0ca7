//! Five effects of a real vehicle that the fit's model (`D·h + b`, a constant
//! running bias, IGRF as the field, perfect attitude) does not have, each
//! written from its physics and each switchable:
//!
//! * [`ThrusterModel`]: every thruster a magnetic dipole at its place in the
//!   hull whose moment scales with its own current; currents from a
//!   propulsion model (thrust ∝ speed², current ∝ thrust^1.5, differential
//!   thrust while turning);
//! * [`ThermalModel`]: water temperature with a thermocline, the sensor's
//!   temperature a first-order lag plus self-heating, and the bridge gain
//!   `1 + k_i (T − T_ref)` on everything the bridge sees;
//! * [`AnomalyModel`]: crustal bodies (buried dipoles) that make the local
//!   field differ from IGRF by 100–300 nT with a gradient along the track;
//! * [`AhrsMisalignment`]: the AHRS mounted at a small fixed angle to the
//!   magnetometer;
//! * [`WaterModel`]: a water current, speed through water, positions
//!   integrated from velocity through water plus current, GPS fixes and
//!   course over ground from the ground velocity.
//!
//! And two disturbances for integrity checks, off in `all`:
//!
//! * [`SteelStructure`]: a steel pier beside the validation run's track,
//!   its piles magnetised by the Earth's field (induced, from their volume,
//!   susceptibility and demagnetising factors) and permanently, as lines
//!   of dipoles;
//! * [`Payload`]: a body-fixed magnetic dipole (a motor, a battery) switched
//!   on part-way through a field test.
//!
//! [`Effects`] carries them; [`Effects::none`] gives today's simulator,
//! number for number.

use calib_core::linalg::{mul_mat, Mat3};
use serde::{Deserialize, Serialize};

use crate::field_test_kind::FieldTest;

/// μ0/4π, T·m/A.
pub const MU0_OVER_4PI: f64 = 1e-7;

/// Metres per degree of latitude (the simulator's flat-earth step).
pub const M_PER_DEG_LAT: f64 = 111_320.0;

/// The field of a magnetic dipole of moment `moment_am2` (A·m²) at the
/// displacement `r_m` (metres, from the dipole to the point), in nT:
/// `B = μ0/(4π r³) (3 (m·r̂) r̂ − m)`. Zero at the dipole itself.
pub fn dipole_field_nt(moment_am2: [f64; 3], r_m: [f64; 3]) -> [f64; 3] {
    let r = (r_m[0] * r_m[0] + r_m[1] * r_m[1] + r_m[2] * r_m[2]).sqrt();
    if r == 0.0 {
        return [0.0; 3];
    }
    let u = [r_m[0] / r, r_m[1] / r, r_m[2] / r];
    let mu = moment_am2[0] * u[0] + moment_am2[1] * u[1] + moment_am2[2] * u[2];
    let k = MU0_OVER_4PI / (r * r * r) * 1e9;
    [k * (3.0 * mu * u[0] - moment_am2[0]), k * (3.0 * mu * u[1] - moment_am2[1]), k * (3.0 * mu * u[2] - moment_am2[2])]
}

/// μ0, T·m/A.
pub const MU0: f64 = 4.0 * std::f64::consts::PI * 1e-7;

/// Demagnetising factor along the long axis of a prolate spheroid of
/// aspect ratio `aspect` = length / diameter ≥ 1 (Osborn 1945, eq. 2.4:
/// `N = (1 − e²)/e³ (atanh e − e)`, `e = √(1 − 1/aspect²)`); 1/3 for a
/// sphere. The two transverse factors are `(1 − N)/2` each.
pub fn prolate_demag_axial(aspect: f64) -> f64 {
    if aspect <= 1.0 + 1e-9 {
        return 1.0 / 3.0;
    }
    let e = (1.0 - 1.0 / (aspect * aspect)).sqrt();
    (1.0 - e * e) / (e * e * e) * (e.atanh() - e)
}

/// Magnetisation induced in a uniformly magnetised body of susceptibility
/// `chi` by an applied field `h_a_per_m` along one of its principal axes
/// with demagnetising factor `demag`: `M = χ/(1 + Nχ) H`, A/m.
pub fn induced_magnetisation_a_per_m(chi: f64, demag: f64, h_a_per_m: f64) -> f64 {
    chi / (1.0 + demag * chi) * h_a_per_m
}

/// One piece of a steel body, magnetised uniformly: a dipole at its centre.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SteelSegment {
    /// Centre, north of the site, m.
    pub north_m: f64,
    /// Centre, east of the site, m.
    pub east_m: f64,
    /// Centre, depth below the surface, m.
    pub depth_m: f64,
    /// Volume of steel, m³.
    pub volume_m3: f64,
    /// The body's long axis, unit vector, NED.
    pub axis_ned: [f64; 3],
    /// Demagnetising factor along the long axis (the transverse ones are
    /// `(1 − N)/2`).
    pub demag_axial: f64,
    /// Permanent magnetisation, NED, A/m.
    pub permanent_a_per_m: [f64; 3],
}

/// A steel structure in the water (a pier's piles, a hull) as lines of
/// dipoles: each segment's moment is its steel volume times its induced
/// magnetisation in the ambient field (`χ/(1 + Nχ) H` along its long axis
/// and across it) plus its permanent magnetisation; its field falls off as
/// 1/r³ ([`dipole_field_nt`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SteelStructure {
    /// Intrinsic (initial) relative susceptibility of the steel.
    pub susceptibility: f64,
    /// The segments.
    pub segments: Vec<SteelSegment>,
}

impl SteelStructure {
    /// A steel pier beside the validation run's outbound track (150° from
    /// the site): two rows of six tubular piles (1.2 m diameter, 20 mm wall,
    /// from the surface to 20 m, each ten 2 m segments), the rows 4 m apart
    /// along the track, the piles 5 m apart across it, the pier head 2.5 m
    /// to port of the track line 1 000 m from the site — so the vehicle, at
    /// whatever depth its dives take it (0–17 m), passes the nearest pile
    /// at a few metres; the calibration run and the swing test stay ≥ 900 m
    /// away (< 0.01 nT). Mild steel, χ = 200 (initial permeability of
    /// structural steel in weak fields: 100–500); each pile's steel with
    /// the demagnetising factors of its envelope (aspect 16.7: N = 0.009
    /// along, 0.496 across — an approximation for a thin tube). Permanent
    /// magnetisation: 800 A/m down the pile (piles are magnetised along
    /// their axis by driving, comparable to the induced ~2 300 A/m) and
    /// 800 A/m across it in a direction of each pile's own (handling and
    /// welding), which is what turns the horizontal field at the sensor.
    /// At the closest approach (2.6 m on the effects' validation run, 3.9 m
    /// on paper 000's) 2.3–3.3 µT at the sensor and up to 5° of heading
    /// error (`examples/disturbances.rs`).
    pub fn pier_beside_validation() -> Self {
        let (along_m, port_m, row_gap_m, pile_gap_m) = (1000.0, 2.5, 4.0, 5.0);
        let (diameter_m, wall_m, length_m, pieces) = (1.2, 0.02, 20.0, 10);
        let course = 150.0_f64.to_radians();
        let (fwd, port) = ([course.cos(), course.sin()], [(course - std::f64::consts::FRAC_PI_2).cos(), (course - std::f64::consts::FRAC_PI_2).sin()]);
        let piece_m = length_m / pieces as f64;
        let volume_m3 = std::f64::consts::PI * diameter_m * wall_m * piece_m;
        let demag_axial = prolate_demag_axial(length_m / diameter_m);
        let mut segments = vec![];
        for (r, row) in [-0.5, 0.5].into_iter().enumerate() {
            for pile in 0..6 {
                let a = along_m + row * row_gap_m;
                let p = port_m + pile as f64 * pile_gap_m;
                // Each pile's own horizontal remanence direction.
                let remanence = (20.0 + 77.0 * pile as f64 + 131.0 * r as f64).to_radians();
                for k in 0..pieces {
                    segments.push(SteelSegment {
                        north_m: a * fwd[0] + p * port[0],
                        east_m: a * fwd[1] + p * port[1],
                        depth_m: (k as f64 + 0.5) * piece_m,
                        volume_m3,
                        axis_ned: [0.0, 0.0, 1.0],
                        demag_axial,
                        permanent_a_per_m: [800.0 * remanence.cos(), 800.0 * remanence.sin(), 800.0],
                    });
                }
            }
        }
        Self { susceptibility: 200.0, segments }
    }

    /// A segment's moment in the ambient field (NED nT), A·m².
    pub fn moment_am2(&self, s: &SteelSegment, ambient_ned_nt: [f64; 3]) -> [f64; 3] {
        let h = ambient_ned_nt.map(|b| b * 1e-9 / MU0);
        let along = h[0] * s.axis_ned[0] + h[1] * s.axis_ned[1] + h[2] * s.axis_ned[2];
        let demag_transverse = (1.0 - s.demag_axial) / 2.0;
        let m_along = induced_magnetisation_a_per_m(self.susceptibility, s.demag_axial, along);
        let k_across = induced_magnetisation_a_per_m(self.susceptibility, demag_transverse, 1.0);
        [0, 1, 2].map(|i| s.volume_m3 * (m_along * s.axis_ned[i] + k_across * (h[i] - along * s.axis_ned[i]) + s.permanent_a_per_m[i]))
    }

    /// The structure's field at a point (north, east, depth; m from the
    /// site) in the ambient field (NED nT), NED nT.
    pub fn field_nt(&self, at_ned_m: [f64; 3], ambient_ned_nt: [f64; 3]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for s in &self.segments {
            let f = dipole_field_nt(self.moment_am2(s, ambient_ned_nt), [at_ned_m[0] - s.north_m, at_ned_m[1] - s.east_m, at_ned_m[2] - s.depth_m]);
            for k in 0..3 {
                out[k] += f[k];
            }
        }
        out
    }

    /// Distance from a point to the nearest segment's centre, m.
    pub fn distance_m(&self, at_ned_m: [f64; 3]) -> f64 {
        self.segments
            .iter()
            .map(|s| ((at_ned_m[0] - s.north_m).powi(2) + (at_ned_m[1] - s.east_m).powi(2) + (at_ned_m[2] - s.depth_m).powi(2)).sqrt())
            .fold(f64::INFINITY, f64::min)
    }
}

/// A payload switched on part-way through one field test: a body-fixed
/// magnetic dipole (a motor's magnets, a battery's current loop) near the
/// sensor, a new hard iron from that moment on.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Payload {
    /// The field test in which it is switched on (off in the others).
    pub field_test: FieldTest,
    /// When, s from the test's start.
    pub on_at_s: f64,
    /// Position in the body frame relative to the magnetometer, m.
    pub position_m: [f64; 3],
    /// Its moment, body frame, A·m².
    pub moment_am2: [f64; 3],
}

impl Payload {
    /// A thruster-sized motor (0.5 A·m², mostly along x) 0.36 m ahead of and
    /// beside the sensor, switched on 1 800 s into the validation run (mid-run
    /// for both the paper's and the effects' validation runs): 2 000 nT at
    /// the sensor.
    pub fn motor_on_validation() -> Self {
        Self { field_test: FieldTest::Validation, on_at_s: 1800.0, position_m: [0.35, 0.08, 0.03], moment_am2: [0.45, 0.15, -0.15] }
    }

    /// Whether it is on at `t_s` of a field test.
    pub fn is_on(&self, field_test: FieldTest, t_s: f64) -> bool {
        field_test == self.field_test && t_s >= self.on_at_s
    }

    /// Its field at the sensor, body frame, nT.
    pub fn field_nt(&self) -> [f64; 3] {
        dipole_field_nt(self.moment_am2, [-self.position_m[0], -self.position_m[1], -self.position_m[2]])
    }
}

/// One thruster: where it sits and the dipole its current makes.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Thruster {
    /// Position in the body frame relative to the magnetometer, metres
    /// (x forward, y starboard, z down).
    pub position_m: [f64; 3],
    /// Dipole moment per ampere of its current (windings, leads), A·m²/A,
    /// body frame.
    pub moment_am2_per_a: [f64; 3],
}

impl Thruster {
    /// The field this thruster makes at the magnetometer per ampere, nT/A.
    pub fn field_nt_per_a(&self) -> [f64; 3] {
        dipole_field_nt(self.moment_am2_per_a, [-self.position_m[0], -self.position_m[1], -self.position_m[2]])
    }
}

/// The thrusters and the propulsion model that sets their currents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ThrusterModel {
    /// The thrusters (surge thrusters; their lateral offset `y` makes the
    /// yaw moment of differential thrust).
    pub thrusters: Vec<Thruster>,
    /// Hull drag: total thrust = `drag_n_per_mps2 · v²`, N per (m/s)².
    pub drag_n_per_mps2: f64,
    /// Thruster law: current = `idle_a + a_per_n1_5 · thrust^1.5` per
    /// thruster (thrust ∝ rpm², shaft power ∝ rpm³ at a fixed bus voltage).
    pub idle_a: f64,
    /// The law's coefficient, A per N^1.5.
    pub a_per_n1_5: f64,
    /// Yaw moment needed per °/s of turn rate (hydrodynamic yaw damping), N·m per °/s.
    pub yaw_moment_nm_per_deg_s: f64,
    /// Current sensor noise of the logged bus current, A (1σ).
    pub current_noise_a: f64,
    /// Thrust-test steps for the swing test (each thruster's current, A,
    /// held 40 s each with the heading held); empty: no thrust test.
    pub thrust_test_steps_a: Vec<f64>,
}

impl ThrusterModel {
    /// A small survey AUV: two stern surge thrusters 1.1 m behind the
    /// magnetometer, ±0.18 m off the centre line; ~0.1 A·m²/A each (their
    /// leads' loops are not symmetric, so neither are the moments). Drag
    /// 20 N at 1 m/s; the law gives ~3 A per thruster at 10 N (a T200-class
    /// thruster at 16 V). About 14–16 nT at the sensor per ampere of each
    /// thruster, mostly along x: at 1.2 m/s (11 A of bus) ~170 nT, at
    /// 0.9 m/s (5 A) ~80 nT.
    pub fn survey_auv() -> Self {
        Self {
            thrusters: vec![
                Thruster { position_m: [-1.1, -0.18, 0.05], moment_am2_per_a: [0.10, 0.04, -0.06] },
                Thruster { position_m: [-1.1, 0.18, 0.05], moment_am2_per_a: [0.09, -0.02, -0.08] },
            ],
            drag_n_per_mps2: 20.0,
            idle_a: 0.3,
            a_per_n1_5: 0.095,
            yaw_moment_nm_per_deg_s: 0.8,
            current_noise_a: 0.05,
            thrust_test_steps_a: vec![],
        }
    }

    /// The same with a thrust test after the swing test (0, 2, 5, 10, 5,
    /// 0 A per thruster).
    pub fn with_thrust_test(mut self) -> Self {
        self.thrust_test_steps_a = vec![0.0, 2.0, 5.0, 10.0, 5.0, 0.0];
        self
    }

    /// Each thruster's current for a speed through water and a turn rate:
    /// thrust `drag·v²` shared equally, plus the differential thrust that
    /// makes the yaw moment `yaw_moment · r` (`T_j += −y_j N / Σy²`, a
    /// thruster to port pushing harder turns the vehicle to starboard),
    /// each thrust at least 0; then the thruster law.
    pub fn currents_a(&self, speed_mps: f64, yaw_rate_deg_s: f64) -> Vec<f64> {
        let n = self.thrusters.len().max(1) as f64;
        let total = self.drag_n_per_mps2 * speed_mps * speed_mps;
        let moment = self.yaw_moment_nm_per_deg_s * yaw_rate_deg_s;
        let sum_y2: f64 = self.thrusters.iter().map(|t| t.position_m[1] * t.position_m[1]).sum();
        self.thrusters
            .iter()
            .map(|t| {
                let diff = if sum_y2 > 0.0 { -t.position_m[1] * moment / sum_y2 } else { 0.0 };
                let thrust = (total / n + diff).max(0.0);
                if thrust > 0.0 {
                    self.idle_a + self.a_per_n1_5 * thrust.powf(1.5)
                } else {
                    0.0
                }
            })
            .collect()
    }

    /// The field of all thrusters at the magnetometer for their currents, nT.
    pub fn field_nt(&self, currents_a: &[f64]) -> [f64; 3] {
        let mut out = [0.0; 3];
        for (t, &i) in self.thrusters.iter().zip(currents_a) {
            let b = t.field_nt_per_a();
            for k in 0..3 {
                out[k] += b[k] * i;
            }
        }
        out
    }
}

/// Water temperature, the sensor's thermal lag and its bridge gain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ThermalModel {
    /// Water temperature at the surface, °C.
    pub surface_c: f64,
    /// Water temperature below the thermocline, °C.
    pub deep_c: f64,
    /// Depth of the thermocline's middle, m.
    pub thermocline_m: f64,
    /// Half-thickness of the thermocline (tanh scale), m.
    pub thermocline_scale_m: f64,
    /// Time constant of the sensor's temperature behind the water's, s.
    pub tau_s: f64,
    /// Self-heating of the electronics: the sensor's steady excess over
    /// the water with the electronics on, °C.
    pub self_heat_c: f64,
    /// Extra self-heating per ampere of thruster bus current (motor
    /// drivers near the sensor), °C/A.
    pub self_heat_c_per_a: f64,
    /// The swing test starts with the sensor this much warmer than its
    /// equilibrium (the vehicle comes from a sunny deck), °C.
    pub swing_start_excess_c: f64,
    /// Relative bridge gain change per °C, per axis (HMC1001/1002 ≈ −0.3 %/°C).
    pub gain_per_c: [f64; 3],
    /// Temperature at which the sensor model (`D`, `b`) holds, °C.
    pub ref_c: f64,
    /// Thermistor offset, °C.
    pub thermistor_offset_c: f64,
    /// Thermistor noise, °C (1σ).
    pub thermistor_noise_c: f64,
}

impl ThermalModel {
    /// A summer sea (Caspian-like): 24 °C at the surface, 12 °C below a
    /// shallow thermocline at 6 m (calm warm weather; the dolphin dives
    /// reach 8–17 m). The sensor sits on a board in an air-filled
    /// pressure housing: the air gap and the housing wall give a time
    /// constant of tens of minutes; 20 min (1200 s) is chosen, so a
    /// 1000 s dive takes the sensor ~56 % of the way to the deep water.
    /// Electronics keep it 3 °C above the water, the motor drivers 0.05 °C
    /// more per ampere. Gains −0.31/−0.28/−0.33 %/°C, reference 20 °C.
    pub fn summer_sea() -> Self {
        Self {
            surface_c: 24.0,
            deep_c: 12.0,
            thermocline_m: 6.0,
            thermocline_scale_m: 2.0,
            tau_s: 1200.0,
            self_heat_c: 3.0,
            self_heat_c_per_a: 0.05,
            swing_start_excess_c: 6.0,
            gain_per_c: [-0.0031, -0.0028, -0.0033],
            ref_c: 20.0,
            thermistor_offset_c: 0.3,
            thermistor_noise_c: 0.05,
        }
    }

    /// Water temperature at a depth, °C (tanh thermocline).
    pub fn water_c(&self, depth_m: f64) -> f64 {
        let s = 0.5 * (1.0 + ((depth_m - self.thermocline_m) / self.thermocline_scale_m).tanh());
        self.surface_c + (self.deep_c - self.surface_c) * s
    }

    /// The temperature the sensor tends to, °C.
    pub fn equilibrium_c(&self, depth_m: f64, bus_current_a: f64) -> f64 {
        self.water_c(depth_m) + self.self_heat_c + self.self_heat_c_per_a * bus_current_a
    }

    /// One step of the first-order lag `τ dT/dt = T_eq − T`, exact for a
    /// target held over the step: `T + (T_eq − T)(1 − e^(−dt/τ))`.
    pub fn step(&self, temp_c: f64, target_c: f64, dt_s: f64) -> f64 {
        temp_c + (target_c - temp_c) * (1.0 - (-dt_s / self.tau_s).exp())
    }

    /// The bridge gain of each axis at a temperature.
    pub fn gain(&self, temp_c: f64) -> [f64; 3] {
        let d = temp_c - self.ref_c;
        [1.0 + self.gain_per_c[0] * d, 1.0 + self.gain_per_c[1] * d, 1.0 + self.gain_per_c[2] * d]
    }
}

/// A magnetised crustal body, modelled as a buried dipole.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CrustalBody {
    /// North of the site, m.
    pub north_m: f64,
    /// East of the site, m.
    pub east_m: f64,
    /// Depth below the sea surface, m.
    pub depth_m: f64,
    /// Moment, NED, A·m².
    pub moment_am2: [f64; 3],
}

/// The local field's departure from IGRF: buried bodies.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AnomalyModel {
    /// The bodies.
    pub bodies: Vec<CrustalBody>,
}

impl AnomalyModel {
    /// Two bodies magnetised along the present field (induced; inclination
    /// ~56°, declination ~5°): a broad one 3 km down, 5 km east and 1 km
    /// south of the site (2.5·10¹¹ A·m²: a 5 km block magnetised at
    /// 2 A/m, basalt-like), and a small shallower one (1.2 km down, 3·10⁹
    /// A·m²) 2 km north-east. Along the runs |F| departs from IGRF by −270
    /// to +235 nT, with gradients of up to ~100 nT/km.
    pub fn two_bodies() -> Self {
        let dir = |m: f64| {
            let (inc, dec) = (56.0_f64.to_radians(), 5.0_f64.to_radians());
            [m * inc.cos() * dec.cos(), m * inc.cos() * dec.sin(), m * inc.sin()]
        };
        Self {
            bodies: vec![
                CrustalBody { north_m: -1000.0, east_m: 5000.0, depth_m: 3000.0, moment_am2: dir(2.5e11) },
                CrustalBody { north_m: 1500.0, east_m: 1500.0, depth_m: 1200.0, moment_am2: dir(3.0e9) },
            ],
        }
    }

    /// The anomaly field, NED nT, at a point north/east of the site (m) and
    /// a depth (m).
    pub fn field_nt(&self, north_m: f64, east_m: f64, depth_m: f64) -> [f64; 3] {
        let mut out = [0.0; 3];
        for b in &self.bodies {
            let f = dipole_field_nt(b.moment_am2, [north_m - b.north_m, east_m - b.east_m, depth_m - b.depth_m]);
            for k in 0..3 {
                out[k] += f[k];
            }
        }
        out
    }
}

/// A fixed rotation of the AHRS against the magnetometer.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct AhrsMisalignment {
    /// About x (roll), degrees.
    pub roll_deg: f64,
    /// About y (pitch), degrees.
    pub pitch_deg: f64,
}

impl AhrsMisalignment {
    /// A few tenths of a degree, as a bracket and two boards give.
    pub fn typical() -> Self {
        Self { roll_deg: 0.4, pitch_deg: -0.3 }
    }

    /// The attitude the AHRS reports, degrees, for the magnetometer's true
    /// roll, pitch and yaw (degrees): the AHRS frame is the magnetometer's
    /// turned by `Rx(δφ) Ry(δθ)`, and its Z-Y-X Euler angles are read off
    /// the product of direction-cosine matrices.
    pub fn reported_deg(&self, roll_deg: f64, pitch_deg: f64, yaw_deg: f64) -> [f64; 3] {
        let c = mul_mat(&mul_mat(&rx(self.roll_deg.to_radians()), &ry(self.pitch_deg.to_radians())), &euler_dcm(roll_deg, pitch_deg, yaw_deg));
        euler_of_dcm(&c)
    }
}

fn rx(a: f64) -> Mat3<f64> {
    let (s, c) = a.sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]]
}

fn ry(a: f64) -> Mat3<f64> {
    let (s, c) = a.sin_cos();
    [[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]]
}

fn rz(a: f64) -> Mat3<f64> {
    let (s, c) = a.sin_cos();
    [[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// NED → body direction-cosine matrix of Z-Y-X Euler angles, degrees.
pub fn euler_dcm(roll_deg: f64, pitch_deg: f64, yaw_deg: f64) -> Mat3<f64> {
    mul_mat(&mul_mat(&rx(roll_deg.to_radians()), &ry(pitch_deg.to_radians())), &rz(yaw_deg.to_radians()))
}

/// Z-Y-X Euler angles (roll, pitch, yaw; degrees) of a NED → body matrix.
pub fn euler_of_dcm(c: &Mat3<f64>) -> [f64; 3] {
    [c[1][2].atan2(c[2][2]).to_degrees(), (-c[0][2]).clamp(-1.0, 1.0).asin().to_degrees(), c[0][1].atan2(c[0][0]).to_degrees()]
}

/// The water current, the speed log and GPS.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WaterModel {
    /// Speed of the current, m/s.
    pub current_mps: f64,
    /// Direction the current flows towards, degrees true.
    pub current_to_deg: f64,
    /// Speed log (propeller model) scale factor.
    pub speed_log_scale: f64,
    /// Speed log noise, m/s (1σ).
    pub speed_log_noise_mps: f64,
    /// GPS position noise per axis, m (1σ).
    pub gps_position_noise_m: f64,
    /// GPS (Doppler) velocity noise per axis, m/s (1σ); course over ground
    /// is the direction of the noisy ground velocity.
    pub gps_velocity_noise_mps: f64,
}

impl WaterModel {
    /// A 0.25 m/s current towards 100°: at 0.9–1.2 m/s it crabs the
    /// vehicle by up to 16°.
    pub fn tidal() -> Self {
        Self { current_mps: 0.25, current_to_deg: 100.0, speed_log_scale: 1.03, speed_log_noise_mps: 0.03, gps_position_noise_m: 2.0, gps_velocity_noise_mps: 0.01 }
    }

    /// The current, north and east, m/s.
    pub fn current_ne_mps(&self) -> [f64; 2] {
        let a = self.current_to_deg.to_radians();
        [self.current_mps * a.cos(), self.current_mps * a.sin()]
    }
}

/// One of the five effects.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Effect {
    /// Thruster interference scaling with motor current.
    Thrusters,
    /// Temperature drift of the bridge gain.
    Temperature,
    /// A crustal anomaly: the local field is not IGRF.
    Anomaly,
    /// AHRS misaligned to the magnetometer.
    Ahrs,
    /// A water current and kinematically consistent GPS.
    Current,
    /// A steel pier passed at a few metres on the validation run.
    Structure,
    /// A payload switched on in the middle of the validation run.
    Payload,
}

impl Effect {
    /// The five calibration effects, in their order (`all`).
    pub const ALL: [Effect; 5] = [Effect::Thrusters, Effect::Temperature, Effect::Anomaly, Effect::Ahrs, Effect::Current];

    /// The disturbances for integrity checks (not in `all`).
    pub const DISTURBANCES: [Effect; 2] = [Effect::Structure, Effect::Payload];

    /// The name used by `--effects`.
    pub fn name(self) -> &'static str {
        match self {
            Effect::Thrusters => "thrusters",
            Effect::Temperature => "temperature",
            Effect::Anomaly => "anomaly",
            Effect::Ahrs => "ahrs",
            Effect::Current => "current",
            Effect::Structure => "structure",
            Effect::Payload => "payload",
        }
    }
}

/// A list of effects that could not be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown effect `{0}`: expected all, none, or a comma-separated list of all, thrusters, temperature, anomaly, ahrs, current, structure, payload")]
pub struct UnknownEffect(pub String);

/// Which effects are on, with their parameters (`None` = off).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Effects {
    /// Thruster dipoles scaling with current.
    pub thrusters: Option<ThrusterModel>,
    /// Thermal lag and bridge gain.
    pub temperature: Option<ThermalModel>,
    /// Crustal anomaly.
    pub anomaly: Option<AnomalyModel>,
    /// AHRS misalignment.
    pub ahrs: Option<AhrsMisalignment>,
    /// Water current, speed log and GPS (`current` in scenario files).
    #[serde(rename = "current")]
    pub water_current: Option<WaterModel>,
    /// A steel structure beside the track.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure: Option<SteelStructure>,
    /// A payload switched on mid-test.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload: Option<Payload>,
}

impl Effects {
    /// None: today's simulator.
    pub fn none() -> Self {
        Self::default()
    }

    /// The five calibration effects with their default parameters (not the disturbances).
    pub fn all() -> Self {
        Self::of(&Effect::ALL)
    }

    /// The listed effects with their default parameters.
    pub fn of(list: &[Effect]) -> Self {
        let mut e = Self::none();
        for &x in list {
            e.set(x);
        }
        e
    }

    /// Switches one effect on with its default parameters.
    pub fn set(&mut self, effect: Effect) {
        match effect {
            Effect::Thrusters => self.thrusters = Some(ThrusterModel::survey_auv()),
            Effect::Temperature => self.temperature = Some(ThermalModel::summer_sea()),
            Effect::Anomaly => self.anomaly = Some(AnomalyModel::two_bodies()),
            Effect::Ahrs => self.ahrs = Some(AhrsMisalignment::typical()),
            Effect::Current => self.water_current = Some(WaterModel::tidal()),
            Effect::Structure => self.structure = Some(SteelStructure::pier_beside_validation()),
            Effect::Payload => self.payload = Some(Payload::motor_on_validation()),
        }
    }

    /// `all`, `none` or a comma-separated list of effect names, where `all`
    /// stands for the five calibration effects (`all,structure,payload`).
    pub fn parse(text: &str) -> Result<Self, UnknownEffect> {
        if matches!(text.trim(), "none" | "") {
            return Ok(Self::none());
        }
        let mut e = Self::none();
        for name in text.split(',').map(str::trim) {
            if name == "all" {
                Effect::ALL.iter().for_each(|&x| e.set(x));
                continue;
            }
            let effect = Effect::ALL.iter().chain(&Effect::DISTURBANCES).copied().find(|x| x.name() == name).ok_or_else(|| UnknownEffect(name.to_string()))?;
            e.set(effect);
        }
        Ok(e)
    }

    /// True when no effect is on.
    pub fn is_none(&self) -> bool {
        self.list().is_empty()
    }

    /// The effects that are on.
    pub fn list(&self) -> Vec<Effect> {
        let on = [self.thrusters.is_some(), self.temperature.is_some(), self.anomaly.is_some(), self.ahrs.is_some(), self.water_current.is_some(), self.structure.is_some(), self.payload.is_some()];
        Effect::ALL.iter().chain(&Effect::DISTURBANCES).zip(on).filter(|(_, o)| *o).map(|(e, _)| *e).collect()
    }
}
