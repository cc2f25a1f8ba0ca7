//! What the simulator knows and the recording does not: the truth JSON's
//! structs, and the effects' truth filled in from the rows.

use calib_core::linalg::{mul_mat_vec, Mat3};
use serde::{Deserialize, Serialize};

use host_tools::geomag::{self, Site};

use super::{RunParams, SensorModel, SimError, Simulation};
use crate::effects::{Effect, Effects, Thruster};

pub use crate::field_test_kind::FieldTest;

/// What the simulator knows and the recording does not.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Truth {
    /// Which field test.
    pub scenario: FieldTest,
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
    /// IGRF-14's horizontal intensity at the start, nT.
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

impl Truth {
    /// The truth of a field test before its rows: IGRF-14 at the site and
    /// the matrix that undoes the sensor.
    pub(super) fn new(scenario: FieldTest, seed: u64, sensor: &SensorModel, site: &Site, run: Option<RunParams>) -> Result<Self, SimError> {
        let f = geomag::igrf14(site.lat_deg, site.lon_deg, 0.0, site.decimal_year)?;
        let ideal = calib_core::linalg::inverse3(&sensor.gain_raw_per_nt).ok_or(SimError::SingularSensor)?;
        Ok(Self {
            scenario,
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
    /// The steel structure passed (absent when off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub structure: Option<StructureTruth>,
    /// The payload switched on (absent when off).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload: Option<PayloadTruth>,
}

/// The steel structure as the vehicle met it (the `structure_distance_m`
/// and `truth_disturbance_nt` columns give it row by row).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct StructureTruth {
    /// Closest approach to a segment's centre, m.
    pub closest_m: f64,
    /// When, s.
    pub closest_t_s: f64,
    /// The largest disturbance at the sensor (structure and payload), nT.
    pub peak_disturbance_nt: f64,
}

/// The payload's new hard iron.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PayloadTruth {
    /// Switched on at, s (`None`: not in this field test).
    pub on_at_s: Option<f64>,
    /// Its field at the sensor, body frame, nT.
    pub field_nt: [f64; 3],
    /// The change of the hard iron, raw units (`D·field` at the reference
    /// temperature): what an on-line hard-iron estimate should find.
    pub bias_change_raw: [f64; 3],
}

/// The thrusters' interference, raw units per ampere at the reference
/// temperature (multiply by the bridge gain at other temperatures).
///
/// Where the linear model `raw_per_a · motor_current_a` is not exact: the
/// field is linear in each thruster's current, but the logged bus current
/// explains it with `raw_per_a` only while the thrusters share it equally;
/// in turns the differential thrust adds `raw_per_a_differential·(I₀ − I₁)`;
/// the bridge gain multiplies it at temperatures away from `ref_c`; the
/// logged current has noise.
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

/// The smallest and largest value of a column (NaN without the column).
fn range(column: Option<&[f64]>) -> [f64; 2] {
    column.map(|c| c.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], &v| [lo.min(v), hi.max(v)])).unwrap_or([f64::NAN; 2])
}

impl EffectsTruth {
    /// The effects' truth from a simulation's rows and the effects' models.
    pub(super) fn from_rows(sim: &Simulation, effects: &Effects, sensor: &SensorModel) -> Self {
        Self {
            on: effects.list(),
            models: effects.clone(),
            thrusters: effects.thrusters.as_ref().map(|m| ThrusterTruth::new(&m.thrusters, sensor, sim)),
            temperature: effects.temperature.as_ref().map(|m| TemperatureTruth {
                ref_c: m.ref_c,
                gain_per_c: m.gain_per_c,
                tau_s: m.tau_s,
                sensor_c_range: range(sim.effect_column("sensor_temp_c")),
                thermistor_offset_c: m.thermistor_offset_c,
                ref_c_thermistor: m.ref_c + m.thermistor_offset_c,
            }),
            anomaly: if effects.anomaly.is_some() { AnomalyTruth::from_rows(sim) } else { None },
            ahrs_misalignment_deg: effects.ahrs.map(|m| [m.roll_deg, m.pitch_deg]),
            current: effects.water_current.as_ref().map(|w| CurrentTruth::new(w.current_ne_mps(), sim)),
            structure: effects.structure.as_ref().and_then(|_| StructureTruth::from_rows(sim)),
            payload: effects.payload.as_ref().map(|p| PayloadTruth {
                on_at_s: (p.field_test == sim.truth.scenario).then_some(p.on_at_s),
                field_nt: p.field_nt(),
                bias_change_raw: mul_mat_vec(&sensor.gain_raw_per_nt, p.field_nt()),
            }),
        }
    }
}

impl StructureTruth {
    fn from_rows(sim: &Simulation) -> Option<Self> {
        let (distance, disturbance, t) = (sim.effect_column("structure_distance_m")?, sim.effect_column("truth_disturbance_nt")?, sim.recording.t_s.as_ref()?);
        let (i, closest_m) = distance.iter().copied().enumerate().fold((0, f64::INFINITY), |(bi, b), (i, d)| if d < b { (i, d) } else { (bi, b) });
        Some(Self { closest_m, closest_t_s: *t.get(i)?, peak_disturbance_nt: disturbance.iter().copied().fold(0.0, f64::max) })
    }
}

impl ThrusterTruth {
    fn new(thrusters: &[Thruster], sensor: &SensorModel, sim: &Simulation) -> Self {
        let d = &sensor.gain_raw_per_nt;
        let field: Vec<[f64; 3]> = thrusters.iter().map(Thruster::field_nt_per_a).collect();
        let raw: Vec<[f64; 3]> = field.iter().map(|f| mul_mat_vec(d, *f)).collect();
        let n = raw.len().max(1) as f64;
        let mean = [0, 1, 2].map(|k| raw.iter().map(|r| r[k]).sum::<f64>() / n);
        let differential = (raw.len() == 2).then(|| [0, 1, 2].map(|k| (raw[0][k] - raw[1][k]) / 2.0));
        Self { field_nt_per_a: field, raw_per_a_each: raw, raw_per_a: mean, raw_per_a_differential: differential, bus_current_a_range: range(sim.effect_column("bus_current_a")) }
    }
}

impl CurrentTruth {
    fn new([north_mps, east_mps]: [f64; 2], sim: &Simulation) -> Self {
        let crab = sim.effect_column("true_course_deg").map(|c| {
            c.iter().zip(&sim.true_heading_deg).map(|(c, h)| calib_core::heading::wrap_pi((c - h).to_radians()).to_degrees()).collect::<Vec<_>>()
        });
        let crab_deg_range = crab.filter(|c| c.iter().all(|v| v.is_finite())).map(|c| range(Some(&c)));
        Self { north_mps, east_mps, crab_deg_range }
    }
}

impl AnomalyTruth {
    /// The true field every 60 s from the simulator's true-field columns.
    fn from_rows(s: &Simulation) -> Option<Self> {
        let t = s.recording.t_s.as_ref()?;
        let (n, e, d) = (s.effect_column("true_field_n_nt")?, s.effect_column("true_field_e_nt")?, s.effect_column("true_field_d_nt")?);
        let lat = s.effect_column("true_lat_deg").map(<[f64]>::to_vec).or_else(|| s.recording.lat_deg.clone())?;
        let lon = s.effect_column("true_lon_deg").map(<[f64]>::to_vec).or_else(|| s.recording.lon_deg.clone())?;
        let depth = s.effect_column("depth_m")?;
        let year = s.truth.site.decimal_year;
        let sample = |i: usize| {
            let igrf = geomag::igrf14(lat[i], lon[i], 0.0, year).map(|f| f.total_nt()).unwrap_or(f64::NAN);
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
        Some(Self { at_start: sample(0), profile, intensity_anomaly_nt_range: lo_hi })
    }
}
