//! The one way in: a recording is read and judged once, the same way, for
//! every command that reads one (fit, apply, backstep, swing, card, report,
//! export, session; `merge` for its two logs' time).
//!
//! What [`read_recording`] adds to the table reader's rules (a header
//! naming each column it reads once, cells that are numbers, angles within
//! their range, time non-decreasing):
//! - **the time's unit** ([`time_unit`]): `t` in seconds, milliseconds or
//!   microseconds, found from the median sample interval when the mapping
//!   does not give it; converted with a note, or refused when two units
//!   are plausible;
//! - **roll and pitch in radians** under degree names: refused (the
//!   attitude-aided fit's test, [`check_attitude_units`],
//!   at a nominal intensity: the test compares two residuals, the scale
//!   does not matter), unless the mapping gives their unit;
//! - **placeholder fixes** ([`drop_placeholder_fixes`]): positions at
//!   exactly (0°, 0°), a GPS receiver's value before its first fix, and
//!   rows with one coordinate missing, taken as no position, counted and
//!   said;
//! - **the positions against the site** ([`check_positions`]): the
//!   distance from the site to the farthest position, and the declination
//!   change between them.

use std::path::{Path, PathBuf};

use super::table::{col, ColumnMap, ColumnUnit, TableError};
use super::Recording;
use calib_core::attitude_fit::{fit_attitude_in, scratch_len, AttitudeConfig, AttitudeSample};
use calib_core::heading::Tilt;

use crate::doc::caldoc::MAX_BIAS_ABS;

/// The sample intervals a recording or a log may have, s: 1 kHz to one
/// sample every 10 s (a slow navigation log at 0.1 Hz; the Seagliders'
/// science logs sample every 5 s). A longer step in seconds is far less
/// likely than the same number in milliseconds (a 10 Hz log's 100 ms); a
/// log that really samples that slowly says so in its mapping (`t=NAME:s`).
pub const PLAUSIBLE_INTERVAL_S: std::ops::RangeInclusive<f64> = 1e-3..=10.0;

/// The field intensity the radians test levels with, nT: the test compares
/// the residuals of two readings of the angles, so any intensity of the
/// Earth's serves.
const NOMINAL_FIELD_NT: f64 = 50_000.0;

/// Distance beyond which a recording's positions are warned about as far
/// from the site (the declination can move by tenths of a degree), km.
pub const SITE_WARN_KM: f64 = 20.0;
/// Distance beyond which they are refused (a wrong sign or a typo in the
/// site: the reference field would be another place's), km.
pub const SITE_REFUSE_KM: f64 = 500.0;
/// A declination that changes by more than this between the site and the
/// recording's farthest position is refused unless weak results are
/// allowed, degrees: the heading is corrected by the site's declination,
/// so the change is a heading error of that size at the far end (half of
/// a good calibration's 1°).
pub const DECLINATION_CHANGE_LIMIT_DEG: f64 = 0.5;

/// Why a recording is not taken in.
#[derive(Debug, thiserror::Error)]
pub enum IntakeError {
    /// The table could not be read.
    #[error(transparent)]
    Read(#[from] TableError),
    /// `t`'s unit is not clear from its sample interval.
    #[error("{path}: `t`'s median step is {median_step} with no unit given: {why}")]
    TimeUnit {
        /// The file.
        path: PathBuf,
        /// The median positive step of `t`, in the file's unit.
        median_step: f64,
        /// Which units fit, in words.
        why: String,
    },
    /// Roll and pitch look like radians under degree names.
    #[error("{path}: {source}")]
    AttitudeUnits {
        /// The file.
        path: PathBuf,
        /// The test's finding.
        #[source]
        source: AnglesLookLikeRadians,
    },
    /// A position is too far from the site.
    #[error("{}: the reference field and declination would be another place's; give the site where the recording was made", .0)]
    FarFromSite(SiteDistance),
    /// The declination changes too much between the site and a position.
    #[error("{distance}: the declination there is {change_deg:.2}° from the site's ({DECLINATION_CHANGE_LIMIT_DEG}° allowed): the heading would be that far off at that end; give the site where the recording was made")]
    DeclinationChange {
        /// Where.
        distance: SiteDistance,
        /// The declination's change, degrees.
        change_deg: f64,
    },
}

/// A recording taken in, with what was done to it in words.
#[derive(Debug, Clone)]
pub struct Intake {
    /// The recording, in the project's units.
    pub recording: Recording,
    /// What was converted or dropped, one sentence each (for stderr).
    pub notes: Vec<String>,
}

/// Reads a recording through the one way in (see the module's rules).
pub fn read_recording(path: &Path, map: &ColumnMap) -> Result<Intake, IntakeError> {
    let recording = Recording::read_mapped(path, map)?;
    take_in(recording, path, map)
}

/// The one way in's judgement of a recording already read under `map`
/// (`path` names it).
pub fn take_in(mut recording: Recording, path: &Path, map: &ColumnMap) -> Result<Intake, IntakeError> {
    let mut notes = Vec::new();
    if let Some(t) = recording.t_s.as_mut() {
        if map.unit(col::T).is_none() {
            if let Some(note) = convert_time(t, path)? {
                notes.push(note);
            }
        }
    }
    if map.unit(col::ROLL_DEG).is_none() && map.unit(col::PITCH_DEG).is_none() {
        check_attitude_units(&recording, NOMINAL_FIELD_NT).map_err(|source| IntakeError::AttitudeUnits { path: path.into(), source })?;
    }
    if let (Some(lat), Some(lon)) = (recording.lat_deg.as_mut(), recording.lon_deg.as_mut()) {
        notes.extend(placeholder_note(drop_placeholder_fixes(lat, lon), path));
    }
    Ok(Intake { recording, notes })
}

/// A heading-only compass's log through the one way in: its `t`'s unit
/// and its placeholder fixes judged as a recording's (it has no roll and
/// pitch to judge). Returns the log and the notes.
pub fn read_compass(path: &Path, map: &ColumnMap) -> Result<(super::compass::CompassLog, Vec<String>), IntakeError> {
    let mut log = super::compass::CompassLog::read_mapped(path, map)?;
    let mut notes = Vec::new();
    if map.unit(col::T).is_none() {
        notes.extend(convert_time(&mut log.t_s, path)?);
    }
    if let (Some(lat), Some(lon)) = (log.lat_deg.as_mut(), log.lon_deg.as_mut()) {
        notes.extend(placeholder_note(drop_placeholder_fixes(lat, lon), path));
    }
    Ok((log, notes))
}

/// The unit `t` is in, from its median positive step (`None` when there
/// are fewer than two distinct times, or seconds fit): seconds when the
/// step is a plausible interval in seconds ([`PLAUSIBLE_INTERVAL_S`]);
/// otherwise the one of milliseconds and microseconds that makes it one.
/// Refused when both do (a step of 1 000 … 10 000: 1–10 s in ms,
/// 1–10 ms in µs) or neither.
pub fn time_unit(t: &[f64], path: &Path) -> Result<Option<ColumnUnit>, IntakeError> {
    let Some(step) = super::pairing::median_step_s(t) else { return Ok(None) };
    if step <= *PLAUSIBLE_INTERVAL_S.end() {
        return Ok(None);
    }
    let fits = |k: f64| PLAUSIBLE_INTERVAL_S.contains(&(step * k));
    let hz = |k: f64| 1.0 / (step * k);
    let (lo, hi) = (PLAUSIBLE_INTERVAL_S.start(), PLAUSIBLE_INTERVAL_S.end());
    let err = |why: String| IntakeError::TimeUnit { path: path.into(), median_step: step, why };
    match (fits(1e-3), fits(1e-6)) {
        (true, false) => Ok(Some(ColumnUnit::Milliseconds)),
        (false, true) => Ok(Some(ColumnUnit::Microseconds)),
        (true, true) => Err(err(format!(
            "as seconds no recording samples that slowly ({lo} … {hi} s between samples are plausible); as milliseconds it is {:.3} s ({:.3} Hz), as microseconds {:.3} s ({:.1} Hz): give `t`'s unit in the column mapping (t=NAME:ms or t=NAME:us)",
            step * 1e-3,
            hz(1e-3),
            step * 1e-6,
            hz(1e-6)
        ))),
        (false, false) => Err(err(format!("no unit of s, ms, µs makes it a plausible sample interval ({lo} … {hi} s): is `t` a time?"))),
    }
}

/// Converts `t` to seconds when its step says it is in ms or µs
/// ([`time_unit`]); the note says so.
pub fn convert_time(t: &mut [f64], path: &Path) -> Result<Option<String>, IntakeError> {
    let Some(unit) = time_unit(t, path)? else { return Ok(None) };
    let (k, name) = match unit {
        ColumnUnit::Milliseconds => (1e-3, "milliseconds"),
        _ => (1e-6, "microseconds"),
    };
    let step = super::pairing::median_step_s(t).unwrap_or(f64::NAN);
    t.iter_mut().for_each(|v| *v *= k);
    Ok(Some(format!(
        "{}: `t` read as {name} (its median step {step} is {:.4} s in {name}, and no recording samples every {step} s): converted to seconds",
        path.display(),
        step * k
    )))
}

/// The note for `placeholders` rows at (0, 0) dropped (none for none).
fn placeholder_note(placeholders: usize, path: &Path) -> Option<String> {
    (placeholders > 0).then(|| format!("{}: {placeholders} row(s) at lat/lon (0, 0) (a GPS receiver's placeholder before its first fix) taken as no position", path.display()))
}

/// Sets positions that are no fix to NaN: exactly (0°, 0°) (a receiver's
/// placeholder before its first fix; no vehicle calibrates its compass in
/// the Gulf of Guinea's exact centre) and rows with one coordinate missing.
/// Returns how many rows were at (0, 0).
pub fn drop_placeholder_fixes(lat_deg: &mut [f64], lon_deg: &mut [f64]) -> usize {
    let mut placeholders = 0;
    for (a, o) in lat_deg.iter_mut().zip(lon_deg.iter_mut()) {
        let zero = *a == 0.0 && *o == 0.0;
        placeholders += usize::from(zero);
        if zero || !a.is_finite() || !o.is_finite() {
            (*a, *o) = (f64::NAN, f64::NAN);
        }
    }
    placeholders
}

/// The recording's position farthest from a site.
#[derive(Debug, Clone, PartialEq)]
pub struct SiteDistance {
    /// The recording.
    pub path: PathBuf,
    /// The site, degrees.
    pub site_deg: (f64, f64),
    /// The position, degrees.
    pub position_deg: (f64, f64),
    /// Its 1-based data row.
    pub row: usize,
    /// Its distance from the site, km.
    pub km: f64,
}

impl std::fmt::Display for SiteDistance {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}: the recording's position {:.5}°, {:.5}° (data row {}) is {:.0} km from the site {}°, {}°",
            self.path.display(),
            self.position_deg.0,
            self.position_deg.1,
            self.row,
            self.km,
            self.site_deg.0,
            self.site_deg.1
        )
    }
}

/// Great-circle distance on a sphere of the Earth's mean radius, km.
pub fn distance_km(lat1_deg: f64, lon1_deg: f64, lat2_deg: f64, lon2_deg: f64) -> f64 {
    let (p1, p2) = (lat1_deg.to_radians(), lat2_deg.to_radians());
    let (dp, dl) = (p2 - p1, (lon2_deg - lon1_deg).to_radians());
    let h = (dp / 2.0).sin().powi(2) + p1.cos() * p2.cos() * (dl / 2.0).sin().powi(2);
    2.0 * 6371.0 * h.sqrt().clamp(0.0, 1.0).asin()
}

/// What [`check_positions`] found that is kept, for a warning.
#[derive(Debug, Clone, PartialEq)]
pub enum SiteWarning {
    /// The farthest position is beyond [`SITE_WARN_KM`].
    Far(SiteDistance),
    /// The declination changes beyond [`DECLINATION_CHANGE_LIMIT_DEG`]
    /// (kept because weak results are allowed).
    Declination {
        /// Where.
        distance: SiteDistance,
        /// The change, degrees.
        change_deg: f64,
    },
}

impl std::fmt::Display for SiteWarning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SiteWarning::Far(d) => write!(f, "{d}: the reference field and declination are the site's, not the recording's"),
            SiteWarning::Declination { distance, change_deg } => write!(
                f,
                "{distance}: the declination there is {change_deg:.2}° from the site's ({DECLINATION_CHANGE_LIMIT_DEG}° allowed): kept as weak results are allowed; the heading may be off by as much at that end"
            ),
        }
    }
}

/// The recording's position (`lat_deg`/`lon_deg`, where present and a fix)
/// farthest from the site.
pub fn farthest_position(rec: &Recording, path: &Path, site_lat_deg: f64, site_lon_deg: f64) -> Option<SiteDistance> {
    let (Some(lat), Some(lon)) = (&rec.lat_deg, &rec.lon_deg) else { return None };
    let fix = |a: f64, o: f64| a.is_finite() && o.is_finite() && !(a == 0.0 && o == 0.0);
    lat.iter()
        .zip(lon)
        .enumerate()
        .filter(|(_, (a, o))| fix(**a, **o))
        .map(|(i, (&a, &o))| (distance_km(site_lat_deg, site_lon_deg, a, o), i, a, o))
        .max_by(|x, y| x.0.total_cmp(&y.0))
        .map(|(km, i, a, o)| SiteDistance { path: path.into(), site_deg: (site_lat_deg, site_lon_deg), position_deg: (a, o), row: i + 1, km })
}

/// Checks the recording's positions against the site of the reference
/// field: refused beyond [`SITE_REFUSE_KM`]; with a date (`decimal_year`),
/// the declination at the farthest position against the site's, refused
/// beyond [`DECLINATION_CHANGE_LIMIT_DEG`] unless `allow_weak` (then a
/// warning). Returns the warnings to say. Placeholder fixes at (0, 0) are
/// not positions.
pub fn check_positions(rec: &Recording, path: &Path, site_lat_deg: f64, site_lon_deg: f64, decimal_year: Option<f64>, allow_weak: bool) -> Result<Vec<SiteWarning>, IntakeError> {
    let Some(far) = farthest_position(rec, path, site_lat_deg, site_lon_deg) else { return Ok(vec![]) };
    if far.km > SITE_REFUSE_KM {
        return Err(IntakeError::FarFromSite(far));
    }
    let mut warnings = Vec::new();
    if let Some(year) = decimal_year {
        let declination = |a: f64, o: f64| crate::geomag::igrf14(a, o, 0.0, year).ok().map(|f| f.declination_deg());
        if let (Some(here), Some(there)) = (declination(site_lat_deg, site_lon_deg), declination(far.position_deg.0, far.position_deg.1)) {
            let change_deg = (there - here + 540.0).rem_euclid(360.0) - 180.0;
            if change_deg.abs() > DECLINATION_CHANGE_LIMIT_DEG {
                if !allow_weak {
                    return Err(IntakeError::DeclinationChange { distance: far, change_deg: change_deg.abs() });
                }
                warnings.push(SiteWarning::Declination { distance: far.clone(), change_deg: change_deg.abs() });
            }
        }
    }
    if far.km > SITE_WARN_KM {
        warnings.push(SiteWarning::Far(far));
    }
    Ok(warnings)
}

/// The samples with the attitude columns read as `k` × degrees.
pub(crate) fn levelled_samples(rec: &Recording, roll: &[f64], pitch: &[f64], k: f64) -> Vec<AttitudeSample<f64>> {
    rec.mag.iter().zip(roll).zip(pitch).map(|((&raw, r), p)| AttitudeSample { raw, tilt: Tilt::new((k * r).to_radians(), (k * p).to_radians()) }).collect()
}

/// A recording's roll and pitch that look like radians under degree names:
/// every angle within ±π, and levelled as radians the field is far more
/// consistent (the attitude-aided fit's robust residual under
/// [`RADIANS_RESIDUAL_RATIO`] of the one read as degrees). A vehicle that
/// really stays within ±3° is not refused: read as radians its angles
/// reach ±170° and level nothing.
pub fn check_attitude_units(rec: &Recording, field_nt: f64) -> Result<(), AnglesLookLikeRadians> {
    let (Some(roll), Some(pitch)) = (rec.roll_deg.as_ref(), rec.pitch_deg.as_ref()) else { return Ok(()) };
    let max_abs = roll.iter().chain(pitch).filter(|v| v.is_finite()).fold(0.0f64, |m, v| m.max(v.abs()));
    if !(max_abs <= std::f64::consts::PI && max_abs >= MIN_RADIANS_SPAN) {
        return Ok(());
    }
    let fit = |k: f64| {
        // A fit that fails, or whose matrix no sensor has, is no fit.
        let samples = levelled_samples(rec, roll, pitch, k);
        let mut scratch = vec![0.0; scratch_len(samples.len())];
        fit_attitude_in(&samples, field_nt, &AttitudeConfig::new(), &mut scratch).ok().filter(|e| e.cal.validate(MAX_BIAS_ABS).is_ok()).map(|e| e.residual_sigma_nt)
    };
    let Some(as_radians) = fit(180.0 / std::f64::consts::PI) else { return Ok(()) };
    let as_degrees = fit(1.0);
    if as_degrees.is_none_or(|d| as_radians < RADIANS_RESIDUAL_RATIO * d) {
        return Err(AnglesLookLikeRadians { max_abs, as_degrees_nt: as_degrees.unwrap_or(f64::INFINITY), as_radians_nt: as_radians });
    }
    Ok(())
}

/// Below this largest |angle| (0.57° read as degrees) the columns say
/// nothing about their unit.
const MIN_RADIANS_SPAN: f64 = 0.01;
/// Radians are refused when levelling with them leaves less than this
/// fraction of the residual that degrees leave.
pub const RADIANS_RESIDUAL_RATIO: f64 = 0.5;

/// `roll_deg`, `pitch_deg` hold radians: the numbers of the test
/// ([`check_attitude_units`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error(
    "roll_deg and pitch_deg look like radians: every angle is within ±{max_abs:.2}, and levelled with them read as radians the field is consistent to {as_radians_nt:.0} nT where read as degrees it is {as_degrees_nt:.0} nT (inf: no plausible calibration)"
)]
pub struct AnglesLookLikeRadians {
    /// Largest |angle| in the columns.
    pub max_abs: f64,
    /// The attitude fit's robust residual with the angles as degrees, nT.
    pub as_degrees_nt: f64,
    /// The same as radians, nT.
    pub as_radians_nt: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn take(text: &str, map: &str) -> Result<Intake, IntakeError> {
        let map: ColumnMap = map.parse().unwrap();
        let rec = Recording::from_reader_mapped(text.as_bytes(), Path::new("rec.csv"), &map)?;
        take_in(rec, Path::new("rec.csv"), &map)
    }

    fn rows(t: impl Fn(usize) -> f64) -> String {
        let mut s = String::from("t,mx,my,mz\n");
        for k in 0..20 {
            s += &format!("{},{},2,3\n", t(k), 100 + k);
        }
        s
    }

    /// `t` at 50 Hz in s; at 5 Hz in ms (200: only ms); at 0.1 Hz and
    /// 50 Hz in µs (10⁷ and 20 000: only µs); at 1 Hz or 0.2 Hz in ms
    /// (1 000, 5 000: also 1 kHz or 200 Hz in µs): refused.
    #[test]
    fn the_time_unit_is_found_from_the_step_or_refused() {
        let r = take(&rows(|k| k as f64 * 0.02), "").unwrap();
        assert!(r.notes.is_empty());
        let r = take(&rows(|k| 1000.0 + k as f64 * 200.0), "").unwrap();
        let t = r.recording.t_s.unwrap();
        assert!((t[1] - t[0] - 0.2).abs() < 1e-12 && r.notes[0].contains("milliseconds"), "{:?}", r.notes);
        let r = take(&rows(|k| k as f64 * 1e7), "").unwrap();
        let t = r.recording.t_s.unwrap();
        assert!((t[1] - 10.0).abs() < 1e-9 && r.notes[0].contains("microseconds"), "{:?}", r.notes);
        let r = take(&rows(|k| 123_456_789.0 + k as f64 * 20_000.0), "").unwrap();
        let t = r.recording.t_s.unwrap();
        assert!((t[1] - t[0] - 0.02).abs() < 1e-9 && r.notes[0].contains("microseconds"), "{:?}", r.notes);
        for step in [5_000.0, 1_000.0] {
            let e = take(&rows(|k| 123_456_789.0 + k as f64 * step), "").unwrap_err();
            assert!(matches!(e, IntakeError::TimeUnit { .. }) && e.to_string().contains("t=NAME:us"), "{e}");
        }
        // The unit given: taken as given, no guess.
        let r = take(&rows(|k| k as f64 * 20_000.0), "t=t:us").unwrap();
        assert!(r.notes.is_empty() && (r.recording.t_s.unwrap()[1] - 0.02).abs() < 1e-12);
        let e = take(&rows(|k| k as f64 * 1e12), "").unwrap_err();
        assert!(e.to_string().contains("no unit of s, ms, µs"), "{e}");
    }

    /// A compass log is judged as a recording: `t` in ms at 10 Hz read as
    /// seconds, a (0, 0) fix dropped.
    #[test]
    fn a_compass_log_goes_the_same_way_in() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("c.csv");
        let mut s = String::from("t,compass_heading_deg,lat_deg,lon_deg\n");
        for k in 0..20 {
            s += &if k == 0 { format!("{},10,0,0\n", k * 100) } else { format!("{},{},45,10\n", k * 100, 10 + k) };
        }
        std::fs::write(&path, s).unwrap();
        let (log, notes) = read_compass(&path, &ColumnMap::default()).unwrap();
        assert!((log.t_s[1] - 0.1).abs() < 1e-12 && log.lat_deg.unwrap()[0].is_nan(), "{notes:?}");
        assert!(notes.len() == 2 && notes[0].contains("milliseconds") && notes[1].contains("1 row(s) at lat/lon (0, 0)"), "{notes:?}");
    }

    #[test]
    fn placeholder_fixes_are_no_positions() {
        let mut lat = vec![0.0, 45.0, 45.1, f64::NAN, 0.0];
        let mut lon = vec![0.0, 10.0, f64::NAN, 10.0, 7.0];
        assert_eq!(drop_placeholder_fixes(&mut lat, &mut lon), 1);
        assert!(lat[0].is_nan() && lon[0].is_nan() && lat[1] == 45.0 && lat[2].is_nan() && lon[3].is_nan());
        // (0, 7): on the equator, a position.
        assert_eq!((lat[4], lon[4]), (0.0, 7.0));
    }

    /// One degree of latitude is 111.2 km on the mean sphere (2π·6371/360).
    #[test]
    fn distances_and_declination_changes() {
        assert!((distance_km(45.0, 10.0, 46.0, 10.0) - 111.19).abs() < 0.01);
        let rec = |lat: Vec<f64>, lon: Vec<f64>| Recording { mag: vec![[1.0, 2.0, 3.0]; lat.len()], lat_deg: Some(lat), lon_deg: Some(lon), ..Recording::default() };
        let p = Path::new("r.csv");
        // Placeholders and a nearby fix: nothing to say.
        assert!(check_positions(&rec(vec![0.0, 45.01], vec![0.0, 10.0]), p, 45.0, 10.0, Some(2025.0), false).unwrap().is_empty());
        let e = check_positions(&rec(vec![45.0, 52.0], vec![10.0, 10.0]), p, 45.0, 10.0, None, false).unwrap_err();
        assert!(matches!(e, IntakeError::FarFromSite(ref d) if d.row == 2) && e.to_string().contains("778 km"), "{e}");
        // 300 km north at 70° N: the declination turns by degrees there.
        let far_north = rec(vec![70.0, 72.7], vec![20.0, 20.0]);
        let e = check_positions(&far_north, p, 70.0, 20.0, Some(2025.0), false).unwrap_err();
        assert!(matches!(e, IntakeError::DeclinationChange { change_deg, .. } if change_deg > 0.5), "{e}");
        let w = check_positions(&far_north, p, 70.0, 20.0, Some(2025.0), true).unwrap();
        assert!(matches!(w[0], SiteWarning::Declination { .. }) && matches!(w[1], SiteWarning::Far(_)), "{w:?}");
    }
}
