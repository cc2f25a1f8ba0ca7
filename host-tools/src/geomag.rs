//! Geomagnetic reference models: IGRF-14 from the official coefficients,
//! and WMM2025 through the `world_magnetic_model` crate as a cross-check;
//! and [`Site`], the place and date a calibration is referred to.
//!
//! IGRF-14: main field to degree 13, definitive/IGRF models every 5 years
//! from 1900 (interpolated linearly), secular variation from 2025 to 2030.
//! The position is geodetic (WGS-84) and converted to geocentric spherical
//! coordinates for the synthesis; the field is rotated back to the geodetic
//! north/east/down frame.

use world_magnetic_model::time::{Date, Month};
use world_magnetic_model::uom::si::angle::degree;
use world_magnetic_model::uom::si::f32::{Angle, Length};
use world_magnetic_model::uom::si::length::meter;
use world_magnetic_model::uom::si::magnetic_flux_density::nanotesla;
use world_magnetic_model::GeomagneticField;

const COEFFICIENTS: &str = include_str!("../data/igrf14coeffs.txt");
/// Highest degree of the IGRF-14 main field.
pub const MAX_DEGREE: usize = 13;
/// IGRF reference radius, km.
const RADIUS_KM: f64 = 6371.2;
/// WGS-84 semi-major axis, km.
const WGS84_A_KM: f64 = 6378.137;
/// WGS-84 flattening.
const WGS84_F: f64 = 1.0 / 298.257_223_563;

/// Why a reference field could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GeomagError {
    /// The date is outside the model's validity.
    #[error("date {0} is outside {1}")]
    DateOutOfRange(f64, &'static str),
    /// Latitude outside ±90° or longitude outside ±360°.
    #[error("position ({lat_deg}°, {lon_deg}°) is not a valid latitude/longitude")]
    BadPosition {
        /// Latitude given.
        lat_deg: f64,
        /// Longitude given.
        lon_deg: f64,
    },
    /// Height outside [`MIN_HEIGHT_M`] … 1000 km.
    #[error("height {0} m is outside -11 000 m (the deepest ocean) … 1 000 000 m")]
    BadHeight(f64),
    /// The date text is not YYYY-MM-DD or a decimal year.
    #[error("date `{0}` is neither YYYY-MM-DD nor a decimal year")]
    BadDate(String),
    /// The WMM crate refused the query.
    #[error("WMM2025: {0}")]
    Wmm(#[source] world_magnetic_model::Error),
    /// The decimal year is no calendar date.
    #[error("WMM2025: year {0} is no calendar date: {1}")]
    WmmDate(f64, #[source] world_magnetic_model::time::error::ComponentRange),
}

/// The geomagnetic field at a point, geodetic north/east/down.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Field {
    /// Northward component X, nT.
    pub north_nt: f64,
    /// Eastward component Y, nT.
    pub east_nt: f64,
    /// Downward component Z, nT.
    pub down_nt: f64,
}

impl Field {
    /// Horizontal intensity H, nT.
    pub fn horizontal_nt(&self) -> f64 {
        self.north_nt.hypot(self.east_nt)
    }
    /// Total intensity F, nT.
    pub fn total_nt(&self) -> f64 {
        self.horizontal_nt().hypot(self.down_nt)
    }
    /// Inclination (dip), degrees, positive down.
    pub fn inclination_deg(&self) -> f64 {
        self.down_nt.atan2(self.horizontal_nt()).to_degrees()
    }
    /// Declination, degrees, positive east.
    pub fn declination_deg(&self) -> f64 {
        self.east_nt.atan2(self.north_nt).to_degrees()
    }
}

/// Where and when: the place and date of a calibration, for its reference
/// field.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Site {
    /// Geodetic latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Decimal year.
    pub decimal_year: f64,
}

impl Site {
    /// A site from a place and a date (`YYYY-MM-DD` or a decimal year).
    pub fn new(lat_deg: f64, lon_deg: f64, date: &str) -> Result<Self, GeomagError> {
        let site = Self { lat_deg, lon_deg, decimal_year: parse_date(date)? };
        site.field()?;
        Ok(site)
    }

    /// IGRF-14 at the site, at sea level.
    pub fn field(&self) -> Result<Field, GeomagError> {
        igrf14(self.lat_deg, self.lon_deg, 0.0, self.decimal_year)
    }

    /// IGRF-14 at another position, at the site's date.
    pub fn field_at(&self, lat_deg: f64, lon_deg: f64) -> Result<Field, GeomagError> {
        igrf14(lat_deg, lon_deg, 0.0, self.decimal_year)
    }
}

/// Which model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// IGRF-14 (default).
    Igrf14,
    /// WMM2025 (through `world_magnetic_model`).
    Wmm2025,
}

impl Model {
    /// Display name.
    pub fn name(self) -> &'static str {
        match self {
            Model::Igrf14 => "IGRF-14",
            Model::Wmm2025 => "WMM2025",
        }
    }
}

/// Parses `YYYY-MM-DD` (midnight UTC) or a decimal year into a decimal year.
pub fn parse_date(text: &str) -> Result<f64, GeomagError> {
    let bad = || GeomagError::BadDate(text.to_string());
    let t = text.trim();
    if let Ok(y) = t.parse::<f64>() {
        return if y.is_finite() { Ok(y) } else { Err(bad()) };
    }
    let parts: Vec<&str> = t.split('-').collect();
    let [y, m, d] = parts.as_slice() else { return Err(bad()) };
    let (y, m, d): (i32, u32, u32) = (y.parse().map_err(|_| bad())?, m.parse().map_err(|_| bad())?, d.parse().map_err(|_| bad())?);
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let month_days = [31, if leap { 29 } else { 28 }, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31];
    if !(1..=12).contains(&m) || d == 0 || d > month_days[(m - 1) as usize] {
        return Err(bad());
    }
    let day_of_year: u32 = month_days[..(m - 1) as usize].iter().sum::<u32>() + d - 1;
    Ok(f64::from(y) + f64::from(day_of_year) / if leap { 366.0 } else { 365.0 })
}

/// Gauss coefficients g, h [n][m] for one epoch.
type Coeffs = [[(f64, f64); MAX_DEGREE + 1]; MAX_DEGREE + 1];

/// The parsed coefficient table.
struct Table {
    epochs: Vec<f64>,
    /// per epoch, then the secular variation (last)
    sets: Vec<Coeffs>,
}

fn table() -> &'static Table {
    static TABLE: std::sync::OnceLock<Table> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| parse_table(COEFFICIENTS))
}

fn parse_table(text: &str) -> Table {
    let mut epochs = Vec::new();
    let mut sets: Vec<Coeffs> = Vec::new();
    for line in text.lines() {
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.first() == Some(&"g/h") {
            epochs = f[3..f.len() - 1].iter().filter_map(|v| v.parse().ok()).collect();
            sets = vec![[[(0.0, 0.0); MAX_DEGREE + 1]; MAX_DEGREE + 1]; epochs.len() + 1];
            continue;
        }
        let (Some(kind), Some(n), Some(m)) = (f.first(), f.get(1).and_then(|v| v.parse::<usize>().ok()), f.get(2).and_then(|v| v.parse::<usize>().ok())) else {
            continue;
        };
        if n > MAX_DEGREE || m > n {
            continue;
        }
        for (k, v) in f[3..].iter().enumerate().take(sets.len()) {
            let v: f64 = v.parse().unwrap_or(0.0);
            match *kind {
                "g" => sets[k][n][m].0 = v,
                "h" => sets[k][n][m].1 = v,
                _ => {}
            }
        }
    }
    Table { epochs, sets }
}

/// The coefficients at a decimal year (linear between epochs, secular
/// variation after the last one, to 5 years past it).
fn coefficients_at(year: f64) -> Result<Coeffs, GeomagError> {
    let t = table();
    let (first, last) = (t.epochs[0], t.epochs[t.epochs.len() - 1]);
    if !(year >= first && year <= last + 5.0) {
        return Err(GeomagError::DateOutOfRange(year, "IGRF-14's validity (1900.0 to 2030.0)"));
    }
    let mut out = [[(0.0, 0.0); MAX_DEGREE + 1]; MAX_DEGREE + 1];
    if year >= last {
        let (base, sv) = (&t.sets[t.epochs.len() - 1], &t.sets[t.epochs.len()]);
        let dt = year - last;
        for n in 0..=MAX_DEGREE {
            for m in 0..=n {
                out[n][m] = (base[n][m].0 + sv[n][m].0 * dt, base[n][m].1 + sv[n][m].1 * dt);
            }
        }
        return Ok(out);
    }
    let i = t.epochs.iter().rposition(|&e| e <= year).unwrap_or(0);
    let f = (year - t.epochs[i]) / (t.epochs[i + 1] - t.epochs[i]);
    // n and m are the degree and order of the formula, not just positions.
    #[allow(clippy::needless_range_loop)]
    for n in 0..=MAX_DEGREE {
        for m in 0..=n {
            let (a, b) = (t.sets[i][n][m], t.sets[i + 1][n][m]);
            out[n][m] = (a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1));
        }
    }
    Ok(out)
}

/// Lowest height accepted, m: the Challenger Deep is 10 935 m down, and
/// AUVs dive to 6 000 m.
pub const MIN_HEIGHT_M: f64 = -11_000.0;

/// IGRF-14 at a geodetic position (WGS-84), height above the ellipsoid, and
/// decimal year.
pub fn igrf14(lat_deg: f64, lon_deg: f64, height_m: f64, year: f64) -> Result<Field, GeomagError> {
    if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 360.0) {
        return Err(GeomagError::BadPosition { lat_deg, lon_deg });
    }
    if !(MIN_HEIGHT_M..=1_000_000.0).contains(&height_m) {
        return Err(GeomagError::BadHeight(height_m));
    }
    let coeffs = coefficients_at(year)?;
    let h_km = height_m / 1000.0;
    // Geodetic → geocentric.
    let (a2, b) = (WGS84_A_KM * WGS84_A_KM, WGS84_A_KM * (1.0 - WGS84_F));
    let b2 = b * b;
    let lat = lat_deg.to_radians();
    let (slat, clat) = lat.sin_cos();
    let (sa, cb) = (a2 * clat * clat, b2 * slat * slat);
    let rho = (sa + cb).sqrt();
    let r = (h_km * (h_km + 2.0 * rho) + (a2 * sa + b2 * cb) / (sa + cb)).sqrt();
    // Rotation from geocentric to geodetic: cos and sin of (geodetic − geocentric latitude).
    let cd = (h_km + rho) / r;
    let sd = (a2 - b2) / rho * slat * clat / r;
    // Geocentric colatitude.
    let (sin_gc_lat, cos_gc_lat) = (slat * cd - clat * sd, clat * cd + slat * sd);
    let (ct, st) = (sin_gc_lat, cos_gc_lat.max(1e-12));
    let lon = lon_deg.to_radians();

    // Schmidt semi-normalised P_n^m(cos θ) and dP/dθ.
    let mut p = [[0.0f64; MAX_DEGREE + 1]; MAX_DEGREE + 1];
    let mut dp = [[0.0f64; MAX_DEGREE + 1]; MAX_DEGREE + 1];
    p[0][0] = 1.0;
    for n in 1..=MAX_DEGREE {
        let nf = n as f64;
        if n == 1 {
            p[1][1] = st;
            dp[1][1] = ct;
        } else {
            let k = ((2.0 * nf - 1.0) / (2.0 * nf)).sqrt();
            p[n][n] = k * st * p[n - 1][n - 1];
            dp[n][n] = k * (ct * p[n - 1][n - 1] + st * dp[n - 1][n - 1]);
        }
        for m in 0..n {
            let mf = m as f64;
            let (prev2, dprev2) = if n >= 2 { (p[n - 2][m], dp[n - 2][m]) } else { (0.0, 0.0) };
            let k1 = ((nf - 1.0) * (nf - 1.0) - mf * mf).max(0.0).sqrt();
            let k0 = (nf * nf - mf * mf).sqrt();
            p[n][m] = ((2.0 * nf - 1.0) * ct * p[n - 1][m] - k1 * prev2) / k0;
            dp[n][m] = ((2.0 * nf - 1.0) * (ct * dp[n - 1][m] - st * p[n - 1][m]) - k1 * dprev2) / k0;
        }
    }
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    let ratio = RADIUS_KM / r;
    let mut rn = ratio * ratio;
    for n in 1..=MAX_DEGREE {
        rn *= ratio; // (a/r)^(n+2)
        let nf = n as f64;
        for m in 0..=n {
            let (g, h) = coeffs[n][m];
            let (sm, cm) = (m as f64 * lon).sin_cos();
            let gc = g * cm + h * sm;
            x += rn * gc * dp[n][m];
            y += rn * m as f64 * (g * sm - h * cm) * p[n][m] / st;
            z -= rn * (nf + 1.0) * gc * p[n][m];
        }
    }
    // Back to the geodetic frame.
    Ok(Field { north_nt: x * cd + z * sd, east_nt: y, down_nt: z * cd - x * sd })
}

/// WMM2025's validity, decimal years: the crate answers outside it with an
/// older model (WMM2020 for 2021), which must not be labelled WMM2025.
pub const WMM2025_YEARS: (f64, f64) = (2025.0, 2030.0);

/// WMM2025 at a geodetic position, through `world_magnetic_model` (f32);
/// a date outside [`WMM2025_YEARS`] is refused.
pub fn wmm2025(lat_deg: f64, lon_deg: f64, height_m: f64, year: f64) -> Result<Field, GeomagError> {
    if !(year >= WMM2025_YEARS.0 && year <= WMM2025_YEARS.1) {
        return Err(GeomagError::DateOutOfRange(year, "WMM2025's validity (2025.0 to 2030.0; for an earlier date, IGRF-14 covers 1900.0 to 2030.0)"));
    }
    let y = year.floor() as i32;
    let leap = (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
    let days = if leap { 366.0 } else { 365.0 };
    let ordinal = (((year - f64::from(y)) * days).floor() as u16 + 1).min(days as u16);
    let date = Date::from_ordinal_date(y, ordinal).or_else(|_| Date::from_calendar_date(y, Month::January, 1)).map_err(|e| GeomagError::WmmDate(year, e))?;
    if !(lat_deg.abs() <= 90.0 && lon_deg.abs() <= 360.0) {
        return Err(GeomagError::BadPosition { lat_deg, lon_deg });
    }
    // The crate takes longitudes in [−180, 180].
    let lon = (lon_deg + 180.0).rem_euclid(360.0) - 180.0;
    let f = GeomagneticField::new(
        Length::new::<meter>(height_m as f32),
        Angle::new::<degree>(lat_deg as f32),
        Angle::new::<degree>(lon as f32),
        date,
    )
    .map_err(GeomagError::Wmm)?;
    Ok(Field {
        north_nt: f64::from(f.x().get::<nanotesla>()),
        east_nt: f64::from(f.y().get::<nanotesla>()),
        down_nt: f64::from(f.z().get::<nanotesla>()),
    })
}

/// The field of either model.
pub fn field(model: Model, lat_deg: f64, lon_deg: f64, height_m: f64, year: f64) -> Result<Field, GeomagError> {
    match model {
        Model::Igrf14 => igrf14(lat_deg, lon_deg, height_m, year),
        Model::Wmm2025 => wmm2025(lat_deg, lon_deg, height_m, year),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_parse() {
        assert_eq!(parse_date("2025.5").unwrap(), 2025.5);
        assert_eq!(parse_date("2024-01-01").unwrap(), 2024.0);
        assert!((parse_date("2024-12-31").unwrap() - (2024.0 + 365.0 / 366.0)).abs() < 1e-12);
        assert!((parse_date("2023-07-02").unwrap() - (2023.0 + 182.0 / 365.0)).abs() < 1e-12);
        for bad in ["2023-02-29", "2023-13-01", "yesterday", "2023-1", "nan"] {
            assert!(parse_date(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_table_has_every_epoch_and_the_secular_variation() {
        let t = table();
        assert_eq!(t.epochs.first(), Some(&1900.0));
        assert_eq!(t.epochs.last(), Some(&2025.0));
        assert_eq!(t.epochs.len(), 26);
        // g(1,0) of 2025 and its secular variation, from the file's first data row.
        assert_eq!(t.sets[25][1][0].0, -29350.0);
        assert_eq!(t.sets[26][1][0].0, 12.6);
    }

    #[test]
    fn out_of_range_inputs_are_refused() {
        assert!(matches!(igrf14(0.0, 0.0, 0.0, 2031.0), Err(GeomagError::DateOutOfRange(..))));
        assert!(matches!(igrf14(0.0, 0.0, 0.0, 1899.9), Err(GeomagError::DateOutOfRange(..))));
        // WMM2025 from 2025.0 to 2030.0 only (the crate gave WMM2020's field
        // for 2021, then labelled WMM2025).
        for year in [2021.0, 2024.99, 2030.01] {
            assert!(matches!(wmm2025(0.0, 0.0, 0.0, year), Err(GeomagError::DateOutOfRange(..))), "{year}");
        }
        assert!(wmm2025(0.0, 0.0, 0.0, 2025.0).is_ok() && wmm2025(0.0, 0.0, 0.0, 2029.99).is_ok());
        assert!(matches!(igrf14(91.0, 0.0, 0.0, 2026.0), Err(GeomagError::BadPosition { .. })));
        assert!(matches!(igrf14(0.0, 0.0, -12_000.0, 2026.0), Err(GeomagError::BadHeight(_))));
        assert!(matches!(igrf14(0.0, 0.0, 1.1e6, 2026.0), Err(GeomagError::BadHeight(_))));
    }

    #[test]
    fn an_auv_at_6000_m_gets_the_field_there() {
        // Refused below −1 000 m before. The field's main (dipole) part grows
        // as r⁻³: 6 km down, by (6371.2 / 6365.2)³ − 1 = 0.28 %; the higher
        // degrees grow faster, so between 0.2 % and 0.5 %.
        let (top, deep) = (igrf14(45.0, -30.0, 0.0, 2026.0).unwrap(), igrf14(45.0, -30.0, -6000.0, 2026.0).unwrap());
        let growth = deep.total_nt() / top.total_nt() - 1.0;
        assert!((0.002..0.005).contains(&growth), "{growth}");
        assert!(igrf14(11.35, 142.2, -10_935.0, 2026.0).is_ok(), "the Challenger Deep");
        assert!(igrf14(f64::NAN, 0.0, 0.0, 2026.0).is_err());
    }
}
