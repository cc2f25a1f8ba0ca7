//! Heading-only compasses (a commercial AHRS, a boat's fluxgate): the
//! recording they leave — a heading, no raw field — and the calibration
//! document that holds only the swing (paper 000's A–E) for them.
//!
//! A compass log (`docs/INTERFACES.md`, "Heading-only compasses") has `t`
//! and `compass_heading_deg` (the compass's magnetic heading before any
//! correction) and any of `ref_heading_deg` (true heading, or GPS course),
//! `lat_deg`, `lon_deg`, `speed_mps` (through water), `variation_deg`,
//! `course_deg`, `gps_speed_mps`. The rows need not pair up: `magcal import
//! --nmea` writes one row per sentence, the compass's rows with a heading
//! and the GPS's with a course; the heading at a reference's time is
//! interpolated.

use std::path::{Path, PathBuf};

use calib_core::cal::Swing;
use serde::{Deserialize, Serialize};

use super::caldoc::{CalDoc, CalDocError};
use super::results::Quality;
use super::table::{col, read_table_mapped, write_table, ColumnMap, TableError};

/// A heading-only compass's log, column by column (NaN where not available).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CompassLog {
    /// `t`, seconds (non-decreasing).
    pub t_s: Vec<f64>,
    /// `compass_heading_deg`: the compass's magnetic heading, degrees.
    pub compass_heading_deg: Vec<f64>,
    /// `ref_heading_deg`: the reference, degrees true.
    pub ref_heading_deg: Option<Vec<f64>>,
    /// `lat_deg`.
    pub lat_deg: Option<Vec<f64>>,
    /// `lon_deg`.
    pub lon_deg: Option<Vec<f64>>,
    /// `speed_mps`: speed through water, m/s.
    pub speed_mps: Option<Vec<f64>>,
    /// `variation_deg`: the variation the log states, degrees east.
    pub variation_deg: Option<Vec<f64>>,
}

/// The columns a compass log may have besides `t` and `compass_heading_deg`.
const OPTIONAL: [&str; 5] = [col::REF_HEADING_DEG, col::LAT_DEG, col::LON_DEG, col::SPEED_MPS, col::VARIATION_DEG];

impl CompassLog {
    /// Rows.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Reads a compass log (`t` and `compass_heading_deg` required).
    pub fn read(path: &Path) -> Result<Self, TableError> {
        Self::read_mapped(path, &ColumnMap::default())
    }

    /// [`CompassLog::read`] with the file's own names and units.
    pub fn read_mapped(path: &Path, map: &ColumnMap) -> Result<Self, TableError> {
        let file = std::fs::File::open(path).map_err(|source| TableError::Io { path: path.into(), source })?;
        Self::from_reader_mapped(file, path, map)
    }

    /// From any reader (`path` names it in errors).
    pub fn from_reader_mapped<R: std::io::Read>(reader: R, path: &Path, map: &ColumnMap) -> Result<Self, TableError> {
        let mut t = read_table_mapped(reader, path, &[col::T, col::COMPASS_HEADING_DEG], &OPTIONAL, map)?;
        Ok(Self {
            t_s: t.take(col::T).unwrap_or_default(),
            compass_heading_deg: t.take(col::COMPASS_HEADING_DEG).unwrap_or_default(),
            ref_heading_deg: t.take(col::REF_HEADING_DEG),
            lat_deg: t.take(col::LAT_DEG),
            lon_deg: t.take(col::LON_DEG),
            speed_mps: t.take(col::SPEED_MPS),
            variation_deg: t.take(col::VARIATION_DEG),
        })
    }

    /// Writes the log with the columns it has.
    pub fn write(&self, path: &Path) -> Result<(), TableError> {
        let optional = [
            (col::REF_HEADING_DEG, &self.ref_heading_deg),
            (col::LAT_DEG, &self.lat_deg),
            (col::LON_DEG, &self.lon_deg),
            (col::SPEED_MPS, &self.speed_mps),
            (col::VARIATION_DEG, &self.variation_deg),
        ];
        let present: Vec<(&str, &Vec<f64>)> = optional.iter().filter_map(|(n, c)| c.as_ref().map(|c| (*n, c))).collect();
        let mut header = vec![col::T, col::COMPASS_HEADING_DEG];
        header.extend(present.iter().map(|(n, _)| *n));
        let at = |c: &Vec<f64>, i: usize| c.get(i).copied().unwrap_or(f64::NAN);
        let rows = (0..self.len()).map(|i| [at(&self.t_s, i), at(&self.compass_heading_deg, i)].into_iter().chain(present.iter().map(|(_, c)| at(c, i))).collect());
        write_table(path, &header, rows)
    }

    /// The median of the log's stated variation, degrees east (`None`
    /// without one).
    pub fn stated_variation_deg(&self) -> Option<f64> {
        let mut v: Vec<f64> = self.variation_deg.as_ref()?.iter().copied().filter(|v| v.is_finite()).collect();
        calib_core::series::median(&mut v)
    }
}

/// The form of a heading-only calibration document.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DocForm {
    /// Only the swing, for a compass that gives a heading.
    HeadingOnly,
}

/// The smallest slope of the corrected heading against the compass's that a
/// swing may have (the field calibration's too: one check,
/// [`super::caldoc::swing_problem`]).
pub use super::caldoc::MIN_CORRECTION_SLOPE;

/// A heading-only compass's calibration: the swing and the declination.
/// What `magcal swing` writes for a compass log; `apply` and `card` use it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompassDoc {
    /// The document's format ([`super::caldoc::FORMAT_VERSION`]; absent:
    /// format 1).
    #[serde(default = "super::caldoc::format_one")]
    pub format_version: u32,
    /// `heading_only`.
    pub form: DocForm,
    /// The swing correction: `ψ_magnetic = ψ_compass + δψ(ψ_compass)`.
    pub swing: Swing<f64>,
    /// Declination, degrees east: `ψ_true = ψ_magnetic + declination`.
    /// Absent: A holds the declination too, the corrected heading is true.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub declination_deg: Option<f64>,
    /// The swing fit's quality (`quality.swing`).
    #[serde(default)]
    pub quality: Quality,
}

impl CompassDoc {
    /// The compass's heading corrected, degrees true (magnetic when the
    /// document has no declination and A does not hold it), in `[0, 360)`.
    pub fn corrected_deg(&self, compass_heading_deg: f64) -> f64 {
        let h = compass_heading_deg.to_radians();
        (h + self.swing.correction_rad(h) + self.declination_deg.unwrap_or(0.0).to_radians()).to_degrees().rem_euclid(360.0)
    }

    /// Checks the coefficients: finite, each below 1 rad, and the corrected
    /// heading rising with the compass's by at least [`MIN_CORRECTION_SLOPE`].
    pub fn validate(&self, path: &Path) -> Result<(), CalDocError> {
        let invalid = |reason: String| CalDocError::Invalid { path: path.into(), reason };
        if let Some(why) = super::caldoc::swing_problem(&self.swing) {
            return Err(invalid(why));
        }
        if let Some(why) = self.quality.range_problem() {
            return Err(invalid(format!("quality: {why}")));
        }
        if let Some(d) = self.declination_deg {
            if !(d.is_finite() && d.abs() <= 180.0) {
                return Err(invalid("declination_deg must be within ±180".into()));
            }
        }
        Ok(())
    }

    /// Validates and writes the document (pretty JSON), atomically.
    pub fn save(&self, path: &Path) -> Result<(), CalDocError> {
        self.validate(path)?;
        let text = serde_json::to_string_pretty(self).map_err(|source| CalDocError::Parse { path: path.into(), source })?;
        crate::files::write_text_atomic(path, &(text + "\n"))?;
        Ok(())
    }
}

/// A calibration document of either form.
#[derive(Debug, Clone, PartialEq)]
pub enum Document {
    /// A field calibration (magnetometer axes), with or without a swing.
    Field(Box<CalDoc>),
    /// A heading-only compass's swing.
    Compass(CompassDoc),
}

/// Just the `form` key, to tell the documents apart before reading either.
#[derive(Deserialize)]
struct FormProbe {
    #[serde(default)]
    form: Option<DocForm>,
}

/// Just the `format_version` key, read before the document's own types
/// (which refuse keys they do not know: a newer document must be refused
/// for its format, not for its first new key).
#[derive(Deserialize)]
struct VersionProbe {
    #[serde(default)]
    format_version: Option<u64>,
}

/// The document's text without a UTF-8 byte-order mark, refused when its
/// `format_version` is newer than [`super::caldoc::FORMAT_VERSION`] or 0
/// (text that is not JSON is left to the document's reader to name).
pub(crate) fn read_doc_text(path: &Path) -> Result<String, CalDocError> {
    let text = std::fs::read_to_string(path).map_err(|source| CalDocError::Io { path: path.into(), source })?;
    let text = text.strip_prefix('\u{feff}').map(str::to_string).unwrap_or(text);
    if let Ok(VersionProbe { format_version: Some(version) }) = serde_json::from_str::<VersionProbe>(&text) {
        if version == 0 {
            return Err(CalDocError::BadFormat { path: path.into(), version });
        }
        if version > u64::from(super::caldoc::FORMAT_VERSION) {
            return Err(CalDocError::NewerFormat { path: path.into(), version });
        }
    }
    Ok(text)
}

/// Whether a document's text is the heading-only form (`false` when it
/// does not say, or is not JSON: the field reader then says why).
pub(crate) fn is_compass_doc(text: &str) -> bool {
    serde_json::from_str::<FormProbe>(text).is_ok_and(|p| p.form == Some(DocForm::HeadingOnly))
}

impl Document {
    /// Reads and checks a calibration document of either form, weak
    /// documents refused ([`Document::load_with`]).
    pub fn load(path: &Path) -> Result<Self, CalDocError> {
        Self::load_with(path, false).map(|(doc, _)| doc)
    }

    /// Reads a calibration document of either form and runs its one check
    /// ([`CalDoc::check`], [`CompassDoc::validate`]) with `allow_weak`: the
    /// document and what must be said about it.
    pub fn load_with(path: &Path, allow_weak: bool) -> Result<(Self, Vec<String>), CalDocError> {
        let text = read_doc_text(path)?;
        if is_compass_doc(&text) {
            let doc: CompassDoc = serde_json::from_str(&text).map_err(|source| CalDocError::Parse { path: PathBuf::from(path), source })?;
            doc.validate(path)?;
            Ok((Self::Compass(doc), Vec::new()))
        } else {
            let (doc, said) = CalDoc::load_with(path, allow_weak)?;
            Ok((Self::Field(Box::new(doc)), said))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(s: Swing<f64>) -> CompassDoc {
        CompassDoc { format_version: crate::data::caldoc::FORMAT_VERSION, form: DocForm::HeadingOnly, swing: s, declination_deg: Some(3.0), quality: Quality::default() }
    }

    #[test]
    fn a_compass_document_round_trips_and_is_told_from_a_field_one() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("compass.json");
        let d = doc(Swing { a: 0.05, b: -0.13, c: 0.32, d: 0.01, e: 0.013 });
        d.save(&p).unwrap();
        // The contract of docs/INTERFACES.md, written out here apart from CompassDoc.
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        assert_eq!(v["form"], "heading_only");
        assert_eq!(v["swing"]["c"], 0.32);
        assert_eq!(v["declination_deg"], 3.0);
        assert_eq!(Document::load(&p).unwrap(), Document::Compass(d));
        // A field calibration's reader refuses it by name, not as "unknown field".
        let e = CalDoc::load(&p).unwrap_err();
        assert!(e.to_string().contains("heading-only"), "{e}");
    }

    #[test]
    fn a_swing_that_folds_headings_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("c.json");
        // 1 + B cos ψ has its minimum 1 − 0.9 = 0.1 at ψ = 180°: folds.
        let e = doc(Swing { a: 0.0, b: 0.9, c: 0.0, d: 0.0, e: 0.0 }).save(&p).unwrap_err();
        assert!(e.to_string().contains("folds headings"), "{e}");
        assert!(!p.exists());
        // 0.7: slope 0.3 at worst, kept (Cirrus' compass has B, C ≈ −0.13, 0.32).
        doc(Swing { a: 0.0, b: 0.7, c: 0.0, d: 0.0, e: 0.0 }).save(&p).unwrap();
        let e = doc(Swing { a: f64::NAN, b: 0.0, c: 0.0, d: 0.0, e: 0.0 }).save(&p).unwrap_err();
        assert!(e.to_string().contains("finite"), "{e}");
    }

    #[test]
    fn the_correction_is_paper_000s_sign() {
        // δψ = A + …: a compass reading 10° with A = 2° is 12° magnetic, 15° true at +3°.
        let d = doc(Swing { a: 2f64.to_radians(), b: 0.0, c: 0.0, d: 0.0, e: 0.0 });
        assert!((d.corrected_deg(10.0) - 15.0).abs() < 1e-9);
        assert!((d.corrected_deg(359.0) - 4.0).abs() < 1e-9);
    }

    #[test]
    fn a_compass_log_reads_with_rows_that_do_not_pair_up() {
        let text = "t,compass_heading_deg,ref_heading_deg,variation_deg\n0.0,10.5,,\n0.5,11.0,,3.1\n1.0,,14.2,\n";
        let log = CompassLog::from_reader_mapped(text.as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap();
        assert_eq!(log.len(), 3);
        assert!(log.compass_heading_deg[2].is_nan());
        assert_eq!(log.ref_heading_deg.as_ref().unwrap()[2], 14.2);
        assert_eq!(log.stated_variation_deg(), Some(3.1));
        let e = CompassLog::from_reader_mapped("t,ref_heading_deg\n0,1\n".as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap_err();
        assert!(e.to_string().contains("compass_heading_deg"), "{e}");
        let e = CompassLog::from_reader_mapped("t,compass_heading_deg\n0,400\n".as_bytes(), Path::new("c.csv"), &ColumnMap::default()).unwrap_err();
        assert!(matches!(e, TableError::OutOfRange { .. }), "{e}");
    }
}
