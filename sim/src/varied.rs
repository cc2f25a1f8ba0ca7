//! The five effects at other sites and with other magnitudes than
//! [`Effects::all`]'s: a site (latitude, longitude, date:
//! another IGRF field, inclination and declination) and every effect's
//! physical parameters drawn by seed from stated ranges
//! ([`MagnitudeRanges`]), so that tests and the bench do not pass on the
//! defaults alone.
//!
//! Written from physics like [`crate::effects`], never from an estimator's
//! equations: thrusters are dipoles at drawn places with drawn moments per
//! ampere; the sea has a drawn thermocline; the sensor a drawn lag,
//! self-heating and per-axis bridge gains; the crustal bodies are buried
//! dipoles magnetised by the *site's* field (induced along its direction,
//! with a remanent part of drawn Koenigsberger ratio in a drawn direction);
//! the AHRS is misaligned by drawn angles; the current has a drawn speed
//! and direction.

use calib_core::conformance::SplitMix64;
use serde::{Deserialize, Serialize};

use host_tools::geomag::{self, Site};

use crate::effects::{AhrsMisalignment, AnomalyModel, CrustalBody, Effects, ThermalModel, Thruster, ThrusterModel, WaterModel, MU0_OVER_4PI};
use crate::field_test::SimError;

/// A named site of the varied scenarios.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct NamedSite {
    /// Short name for tables (`high-latitude`, …).
    pub name: &'static str,
    /// Where and when.
    pub site: Site,
    /// The AHRS's roll and pitch noise there (1σ, °): the levelling's
    /// error, which at a steep inclination becomes heading noise (× tan I).
    pub ahrs_noise_deg: f64,
}

impl NamedSite {
    /// [`SensorModel::paper_like`](crate::SensorModel::paper_like) with this
    /// site's AHRS noise.
    pub fn sensor(&self) -> crate::SensorModel {
        crate::SensorModel { ahrs_noise_deg: self.ahrs_noise_deg, ..crate::SensorModel::paper_like() }
    }
}

/// Four sites unlike paper 000's (inclination 56°, |F| 48.7 µT), each at
/// mid-2024 (IGRF-14 there, for scale):
///
/// * `high-latitude`: Trondheimsfjord, 63.45° N 10.3° E — inclination 74.9°,
///   |F| 52.2 µT, H only 13.6 µT (a heading sees half the horizontal field);
/// * `low-latitude`: the Arabian Sea off Goa, 15.0° N 73.0° E — inclination
///   19.5°, |F| 41.9 µT, H 39.5 µT, Z 14.0 µT (the vertical channel weak);
/// * `southern`: off Suva, Fiji, 18.2° S 178.4° E — inclination −39.9°
///   (the field points up), declination +12.8°, |F| 42.4 µT;
/// * `high-latitude-quiet-ahrs`: Trondheimsfjord again with an AHRS of
///   0.05° roll/pitch noise (a navigation-grade unit) instead of 0.15°, so
///   that the AHRS's noise × tan I no longer hides the calibration's error.
pub fn varied_sites() -> [NamedSite; 4] {
    let trondheim = Site { lat_deg: 63.45, lon_deg: 10.3, decimal_year: 2024.5 };
    [
        NamedSite { name: "high-latitude", site: trondheim, ahrs_noise_deg: 0.15 },
        NamedSite { name: "low-latitude", site: Site { lat_deg: 15.0, lon_deg: 73.0, decimal_year: 2024.5 }, ahrs_noise_deg: 0.15 },
        NamedSite { name: "southern", site: Site { lat_deg: -18.2, lon_deg: 178.4, decimal_year: 2024.5 }, ahrs_noise_deg: 0.15 },
        NamedSite { name: "high-latitude-quiet-ahrs", site: trondheim, ahrs_noise_deg: 0.05 },
    ]
}

/// A closed interval a parameter is drawn from, uniformly.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Range {
    /// Lower end.
    pub lo: f64,
    /// Upper end.
    pub hi: f64,
}

const fn r(lo: f64, hi: f64) -> Range {
    Range { lo, hi }
}

impl Range {
    fn draw(&self, rng: &mut SplitMix64) -> f64 {
        self.lo + (self.hi - self.lo) * rng.uniform()
    }

    fn contains(&self, v: f64) -> bool {
        v >= self.lo.min(self.hi) && v <= self.hi.max(self.lo)
    }
}

/// The ranges every effect's parameters are drawn from. The defaults
/// ([`MagnitudeRanges::default`]) bracket [`Effects::all`]'s values by
/// roughly ×0.5 … ×2 where physics allows, and say why.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MagnitudeRanges {
    /// Thrusters' distance behind the magnetometer, m (x = −this).
    pub thruster_aft_m: Range,
    /// Thrusters' offset either side of the centre line, m.
    pub thruster_side_m: Range,
    /// Thrusters' height below the sensor, m.
    pub thruster_down_m: Range,
    /// Moment per ampere along x (leads and windings), A·m²/A.
    pub moment_x_am2_per_a: Range,
    /// Moment per ampere along y and z, A·m²/A (either sign).
    pub moment_yz_am2_per_a: Range,
    /// Hull drag, N per (m/s)² (sets the currents at cruise).
    pub drag_n_per_mps2: Range,
    /// Sea-surface temperature, °C.
    pub surface_c: Range,
    /// How much colder the water is below the thermocline, °C.
    pub thermocline_drop_c: Range,
    /// Depth of the thermocline's middle, m (the dives reach 8–17 m).
    pub thermocline_m: Range,
    /// Half-thickness of the thermocline, m.
    pub thermocline_scale_m: Range,
    /// The sensor's thermal time constant, s.
    pub tau_s: Range,
    /// Electronics' self-heating, °C.
    pub self_heat_c: Range,
    /// Self-heating per ampere of bus current, °C/A.
    pub self_heat_c_per_a: Range,
    /// The swing test's start above equilibrium, °C.
    pub swing_start_excess_c: Range,
    /// Each axis' bridge gain change, per °C (HMC100x: −0.2 … −0.4 %/°C).
    pub gain_per_c: Range,
    /// The thermistor's offset, °C.
    pub thermistor_offset_c: Range,
    /// The broad crustal body's peak anomaly at the surface right above it
    /// (`2·μ0/4π·m/d³` for its moment `m` at depth `d`), nT: sets its moment.
    pub broad_peak_nt: Range,
    /// Its depth, m.
    pub broad_depth_m: Range,
    /// Its horizontal distance from the site, m (bearing uniform).
    pub broad_distance_m: Range,
    /// The small shallow body's peak anomaly at the surface, nT.
    pub small_peak_nt: Range,
    /// Its depth, m.
    pub small_depth_m: Range,
    /// Its horizontal distance from the site, m (bearing uniform).
    pub small_distance_m: Range,
    /// Koenigsberger ratio (remanent / induced magnetisation) of each body;
    /// the remanence in a direction drawn on the sphere.
    pub koenigsberger: Range,
    /// AHRS roll and pitch misalignment, degrees (either sign).
    pub misalignment_deg: Range,
    /// Water current speed, m/s (slower than the 0.9 m/s leg).
    pub current_mps: Range,
    /// The speed log's scale factor.
    pub speed_log_scale: Range,
}

impl Default for MagnitudeRanges {
    fn default() -> Self {
        Self {
            thruster_aft_m: r(0.9, 1.4),
            thruster_side_m: r(0.12, 0.25),
            thruster_down_m: r(0.0, 0.12),
            moment_x_am2_per_a: r(0.05, 0.18),
            moment_yz_am2_per_a: r(-0.10, 0.10),
            drag_n_per_mps2: r(15.0, 28.0),
            surface_c: r(14.0, 29.0),
            thermocline_drop_c: r(5.0, 14.0),
            thermocline_m: r(4.0, 10.0),
            thermocline_scale_m: r(1.0, 3.5),
            tau_s: r(600.0, 1800.0),
            self_heat_c: r(1.5, 4.5),
            self_heat_c_per_a: r(0.02, 0.08),
            swing_start_excess_c: r(2.0, 8.0),
            gain_per_c: r(-0.0040, -0.0020),
            thermistor_offset_c: r(-0.5, 0.5),
            broad_peak_nt: r(120.0, 400.0),
            broad_depth_m: r(2500.0, 4500.0),
            broad_distance_m: r(2000.0, 7000.0),
            small_peak_nt: r(40.0, 200.0),
            small_depth_m: r(800.0, 1600.0),
            small_distance_m: r(1000.0, 3500.0),
            koenigsberger: r(0.0, 0.5),
            misalignment_deg: r(-0.6, 0.6),
            current_mps: r(0.10, 0.35),
            speed_log_scale: r(0.97, 1.05),
        }
    }
}

/// Salt of the magnitude generator, so that its draws never coincide with
/// the sensor's or the effects' noise of the same seed.
const DRAW_SALT: u64 = 0x7661_7269_6564_3239;

impl MagnitudeRanges {
    /// The five effects with parameters drawn by `seed` from these ranges,
    /// the crustal bodies magnetised by `site`'s IGRF field.
    pub fn draw(&self, site: &Site, seed: u64) -> Result<Effects, SimError> {
        if !(self.current_mps.lo >= 0.0 && self.current_mps.hi < 0.9) {
            return Err(SimError::Parameter { what: "the current's range, m/s", got: format!("{:?}", self.current_mps), allowed: "within 0 … 0.9 m/s (the slowest leg)" });
        }
        let mut rng = SplitMix64::new(seed ^ DRAW_SALT);
        let rng = &mut rng;
        let thrusters = self.thrusters(rng);
        let temperature = self.thermal(rng);
        let anomaly = self.anomaly(site, rng)?;
        let ahrs = AhrsMisalignment { roll_deg: self.misalignment_deg.draw(rng), pitch_deg: self.misalignment_deg.draw(rng) };
        let water = WaterModel {
            current_mps: self.current_mps.draw(rng),
            current_to_deg: 360.0 * rng.uniform(),
            speed_log_scale: self.speed_log_scale.draw(rng),
            ..WaterModel::tidal()
        };
        Ok(Effects {
            thrusters: Some(thrusters),
            temperature: Some(temperature),
            anomaly: Some(anomaly),
            ahrs: Some(ahrs),
            water_current: Some(water),
            structure: None,
            payload: None,
        })
    }

    /// Two stern thrusters, one either side, each with its own place and
    /// moment per ampere; the propulsion law of [`ThrusterModel::survey_auv`]
    /// with a drawn drag.
    fn thrusters(&self, rng: &mut SplitMix64) -> ThrusterModel {
        let mut one = |side: f64| Thruster {
            position_m: [-self.thruster_aft_m.draw(rng), side * self.thruster_side_m.draw(rng), self.thruster_down_m.draw(rng)],
            moment_am2_per_a: [self.moment_x_am2_per_a.draw(rng), self.moment_yz_am2_per_a.draw(rng), self.moment_yz_am2_per_a.draw(rng)],
        };
        let thrusters = vec![one(-1.0), one(1.0)];
        ThrusterModel { thrusters, drag_n_per_mps2: self.drag_n_per_mps2.draw(rng), ..ThrusterModel::survey_auv() }
    }

    /// A sea with a drawn thermocline and a sensor with drawn lag,
    /// self-heating and bridge gains (reference 20 °C as the sensor's
    /// datasheet holds it).
    fn thermal(&self, rng: &mut SplitMix64) -> ThermalModel {
        let surface_c = self.surface_c.draw(rng);
        ThermalModel {
            surface_c,
            deep_c: surface_c - self.thermocline_drop_c.draw(rng),
            thermocline_m: self.thermocline_m.draw(rng),
            thermocline_scale_m: self.thermocline_scale_m.draw(rng),
            tau_s: self.tau_s.draw(rng),
            self_heat_c: self.self_heat_c.draw(rng),
            self_heat_c_per_a: self.self_heat_c_per_a.draw(rng),
            swing_start_excess_c: self.swing_start_excess_c.draw(rng),
            gain_per_c: [self.gain_per_c.draw(rng), self.gain_per_c.draw(rng), self.gain_per_c.draw(rng)],
            thermistor_offset_c: self.thermistor_offset_c.draw(rng),
            ..ThermalModel::summer_sea()
        }
    }

    /// A broad deep body and a small shallow one at drawn bearings,
    /// distances and depths, each magnetised along the site's field
    /// (induced) plus a remanent part in a direction of its own.
    fn anomaly(&self, site: &Site, rng: &mut SplitMix64) -> Result<AnomalyModel, SimError> {
        let f = geomag::igrf14(site.lat_deg, site.lon_deg, 0.0, site.decimal_year)?;
        let total = f.total_nt();
        let along = [f.north_nt / total, f.east_nt / total, f.down_nt / total];
        let mut body = |peak: &Range, depth: &Range, distance: &Range| {
            let peak_nt = peak.draw(rng);
            let (d, bearing) = (distance.draw(rng), 360.0_f64.to_radians() * rng.uniform());
            let depth_m = depth.draw(rng);
            // A dipole's field right above it along its axis: 2·μ0/4π·m/d³.
            let m = peak_nt * 1e-9 * depth_m.powi(3) / (2.0 * MU0_OVER_4PI);
            let q = self.koenigsberger.draw(rng);
            let remanent = rng.direction();
            CrustalBody { north_m: d * bearing.cos(), east_m: d * bearing.sin(), depth_m, moment_am2: [0, 1, 2].map(|k| m * (along[k] + q * remanent[k])) }
        };
        let broad = body(&self.broad_peak_nt, &self.broad_depth_m, &self.broad_distance_m);
        let small = body(&self.small_peak_nt, &self.small_depth_m, &self.small_distance_m);
        Ok(AnomalyModel { bodies: vec![broad, small] })
    }

    /// Whether a set of effects' parameters lies within these ranges (the
    /// tests' check that a draw is what the ranges state).
    pub fn holds(&self, e: &Effects) -> bool {
        let (Some(t), Some(th), Some(a), Some(w)) = (&e.thrusters, &e.temperature, &e.ahrs, &e.water_current) else { return false };
        let thrusters_ok = t.thrusters.iter().all(|x| {
            self.thruster_aft_m.contains(-x.position_m[0])
                && self.thruster_side_m.contains(x.position_m[1].abs())
                && self.thruster_down_m.contains(x.position_m[2])
                && self.moment_x_am2_per_a.contains(x.moment_am2_per_a[0])
                && self.moment_yz_am2_per_a.contains(x.moment_am2_per_a[1])
                && self.moment_yz_am2_per_a.contains(x.moment_am2_per_a[2])
        }) && self.drag_n_per_mps2.contains(t.drag_n_per_mps2);
        let thermal_ok = self.surface_c.contains(th.surface_c)
            && self.thermocline_drop_c.contains(th.surface_c - th.deep_c)
            && self.thermocline_m.contains(th.thermocline_m)
            && self.tau_s.contains(th.tau_s)
            && th.gain_per_c.iter().all(|&g| self.gain_per_c.contains(g));
        let ahrs_ok = self.misalignment_deg.contains(a.roll_deg) && self.misalignment_deg.contains(a.pitch_deg);
        thrusters_ok && thermal_ok && ahrs_ok && self.current_mps.contains(w.current_mps)
    }
}

/// The five effects at `site` with magnitudes drawn by `seed` from
/// [`MagnitudeRanges::default`].
pub fn varied_effects(site: &Site, seed: u64) -> Result<Effects, SimError> {
    MagnitudeRanges::default().draw(site, seed)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sites_are_what_their_names_say() {
        let [high, low, south, _] = varied_sites().map(|s| geomag::igrf14(s.site.lat_deg, s.site.lon_deg, 0.0, s.site.decimal_year).unwrap());
        assert!((70.0..80.0).contains(&high.inclination_deg()), "{}", high.inclination_deg());
        assert!((15.0..25.0).contains(&low.inclination_deg()), "{}", low.inclination_deg());
        assert!(south.inclination_deg() < -30.0 && south.declination_deg() > 10.0, "{} {}", south.inclination_deg(), south.declination_deg());
    }

    #[test]
    fn draws_stay_in_their_ranges_differ_by_seed_and_are_not_the_defaults() {
        let ranges = MagnitudeRanges::default();
        let site = varied_sites()[0].site;
        let a = ranges.draw(&site, 1).unwrap();
        let b = ranges.draw(&site, 2).unwrap();
        assert!(ranges.holds(&a) && ranges.holds(&b));
        assert_ne!(a, b);
        assert_eq!(a, ranges.draw(&site, 1).unwrap(), "deterministic");
        let defaults = Effects::all();
        assert_ne!(a.thrusters, defaults.thrusters);
        assert_ne!(a.temperature, defaults.temperature);
        assert_ne!(a.anomaly, defaults.anomaly);
        // The bodies are magnetised by the site's field: at a high-latitude
        // site mostly downwards, at a southern one mostly upwards.
        let down = |e: &Effects| e.anomaly.as_ref().unwrap().bodies[0].moment_am2[2];
        assert!(down(&a) > 0.0);
        let south = ranges.draw(&varied_sites()[2].site, 1).unwrap();
        assert!(down(&south) < 0.0);
    }
}
