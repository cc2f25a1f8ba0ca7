//! The heading-only compass's calibration document: the swing (paper
//! 000's A–E) and the declination, for a compass that gives a heading and
//! no raw field (`docs/INTERFACES.md`, "Heading-only compasses"); and
//! [`Document`], a calibration document of either form.

use std::path::{Path, PathBuf};

use calib_core::cal::Swing;
use serde::{Deserialize, Serialize};

use super::caldoc::{read_doc_text, is_compass_doc, CalDoc, CalDocError, DocForm};
use super::results::Quality;

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
    /// heading rising with the compass's by at least [`super::caldoc::MIN_CORRECTION_SLOPE`].
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
        CompassDoc { format_version: crate::doc::caldoc::FORMAT_VERSION, form: DocForm::HeadingOnly, swing: s, declination_deg: Some(3.0), quality: Quality::default() }
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
}
