//! The calibration document (`docs/INTERFACES.md`): what `magcal fit`,
//! `swing` and `backstep` print with `--json` and write with `--out`; its
//! `quality` and `trace` are the typed structs of [`super::results`].

use std::path::{Path, PathBuf};

use calib_core::cal::{CalError, Calibration, EnvTerms, FieldCal, ModelKind, Swing};
use serde::{Deserialize, Serialize};

use super::auto::MAX_HELD_OUT_DEG;
use super::results::{Quality, TraceEntry};
use super::reference::Reference;

/// Largest |bias| accepted in a document, raw units (far beyond any sensor
/// range in counts, nT or µT; catches corrupted files).
pub const MAX_BIAS_ABS: f64 = 1e7;

/// Why a calibration document was refused.
#[derive(Debug, thiserror::Error)]
pub enum CalDocError {
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// Not valid JSON of the expected shape.
    #[error("{path}: not a calibration document: {source}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The parser's message.
        #[source]
        source: serde_json::Error,
    },
    /// A document of a format newer than this build reads.
    #[error("{path}: a calibration document of format {version}, newer than this magcal reads (up to format {newest}): read it with the magcal that wrote it, or a newer one", newest = FORMAT_VERSION)]
    NewerFormat {
        /// The file.
        path: PathBuf,
        /// Its `format_version`.
        version: u64,
    },
    /// A `format_version` that is no format.
    #[error("{path}: format_version {version} is not a calibration document format (formats count from 1)")]
    BadFormat {
        /// The file.
        path: PathBuf,
        /// Its `format_version`.
        version: u64,
    },
    /// A heading-only compass's document where a field calibration is needed.
    #[error("{0}: a heading-only calibration (`\"form\": \"heading_only\"`: a compass's swing, no field calibration); this needs a magnetometer's field calibration")]
    HeadingOnly(PathBuf),
    /// The coefficients are unusable.
    #[error("{path}: coefficients refused: {reason}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
    /// The document's own reference check failed (`reference.check.agrees`
    /// false: kept by a fit that allowed weak results) and weak documents
    /// were not allowed by the command using it.
    #[error("{path}: the calibration disagrees with its own reference field ({disagreement}); it was kept only because weak results were allowed when it was fitted")]
    WeakReference {
        /// The file.
        path: PathBuf,
        /// The document's `reference.check.disagreement`.
        disagreement: String,
    },
    /// `fit` (auto) kept a model none of whose candidates qualified
    /// (`quality.auto.kept_weak`: its held-out or its own expected error at
    /// or above [`MAX_HELD_OUT_DEG`]), only because weak results were
    /// allowed when it was fitted, and the command using it did not allow
    /// them.
    #[error("{path}: `fit` kept this calibration only because weak results were allowed when it was fitted: {numbers}")]
    KeptWeak {
        /// The file.
        path: PathBuf,
        /// The kept model's held-out and own expected errors against the limit, in words.
        numbers: String,
    },
    /// The document failed a check when it, or a document it was made
    /// from, was written, and was kept only because weak results were
    /// allowed (`quality.allowed_weak`); the command using it did not
    /// allow them.
    #[error("{path}: this calibration was kept only because weak results were allowed when it was written: {what}")]
    AllowedWeak {
        /// The file.
        path: PathBuf,
        /// The document's `quality.allowed_weak`, joined.
        what: String,
    },
}

/// The range of the geomagnetic field's intensity at the Earth's surface
/// (IGRF: about 22 000 nT off Brazil to 67 000 nT near the south magnetic
/// pole), widened for local anomalies: 10 000 … 100 000 nT. A document's
/// `field_nt` and every intensity a user gives are held to it.
pub const FIELD_NT_RANGE: std::ops::RangeInclusive<f64> = 10_000.0..=100_000.0;

/// Why `field_nt` is not a geomagnetic field intensity at the Earth's
/// surface in nT, saying which unit it looks like (`None`: it is one).
pub fn field_nt_problem(field_nt: f64) -> Option<String> {
    if FIELD_NT_RANGE.contains(&field_nt) {
        return None;
    }
    // The Earth's field is 22–67 µT: which unit makes the number one?
    let guess = [("µT", 1e3), ("mGauss", 100.0), ("Gauss", 1e5), ("pT", 1e-3)]
        .iter()
        .find(|(_, nt_per_unit)| FIELD_NT_RANGE.contains(&(field_nt * nt_per_unit)))
        .map(|(unit, k)| format!(" (it looks like {unit}: {field_nt} {unit} is {:.0} nT)", field_nt * k))
        .unwrap_or_default();
    Some(format!(
        "{field_nt} nT is not a geomagnetic field intensity at the Earth's surface ({:.0} … {:.0} nT){guess}",
        FIELD_NT_RANGE.start(),
        FIELD_NT_RANGE.end()
    ))
}

/// The smallest slope of the corrected heading against the measured one
/// that a swing may have, degrees per degree: below it the correction
/// (nearly) folds neighbouring headings onto one another (at 0, two
/// measured headings give one corrected heading; below 0 the corrected
/// heading turns back). Held for both forms of document.
pub const MIN_CORRECTION_SLOPE: f64 = 0.2;

/// The smallest slope `d(ψ + δψ(ψ))/dψ = 1 + B cos ψ − C sin ψ + 2D cos 2ψ
/// − 2E sin 2ψ` over all headings, on a 0.25° grid (the slope's second
/// harmonic moves by under 0.03 % of 2·|D, E| between grid points).
pub fn min_correction_slope(s: &Swing<f64>) -> f64 {
    (0..1440)
        .map(|k| {
            let h = (k as f64 * 0.25).to_radians();
            1.0 + s.b * h.cos() - s.c * h.sin() + 2.0 * s.d * (2.0 * h).cos() - 2.0 * s.e * (2.0 * h).sin()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Why a swing cannot be applied (`None`: it can): a coefficient not finite
/// or beyond 1 rad, or a correction that folds the heading (slope below
/// [`MIN_CORRECTION_SLOPE`] somewhere). The one check of the swing of both
/// the field calibration and the heading-only compass's document.
pub fn swing_problem(s: &Swing<f64>) -> Option<String> {
    if ![s.a, s.b, s.c, s.d, s.e].iter().all(|v| v.is_finite() && v.abs() < 1.0) {
        return Some("swing coefficients must be finite and below 1 rad".into());
    }
    let slope = min_correction_slope(s);
    (slope < MIN_CORRECTION_SLOPE).then(|| {
        format!("the swing folds headings: the corrected heading rises only {slope:.2}° per degree of the measured heading somewhere (at least {MIN_CORRECTION_SLOPE} needed)")
    })
}

/// Why the matrix is not of the document's model (`None`: it is): a
/// `sphere` is one scale (`g·I`), an `axis` model three scales (diagonal),
/// a `triangular` one upper triangular (paper 001); `full`, `gyro` and
/// `attitude` may hold any matrix. Entries that must be zero may differ
/// from it by 1e-6 of the largest entry (a hand-rounded file), the sphere's
/// scales from each other by as much.
pub fn model_problem(model: ModelKind, m: &[[f64; 3]; 3]) -> Option<String> {
    let tol = 1e-6 * m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    let small = |v: f64| v.abs() <= tol;
    let off_diagonal_zero = (0..3).all(|i| (0..3).all(|j| i == j || small(m[i][j])));
    match model {
        ModelKind::Sphere if !(off_diagonal_zero && small(m[0][0] - m[1][1]) && small(m[0][0] - m[2][2])) => {
            Some("model `sphere` is one scale on every axis (the matrix a multiple of the identity), but the matrix has other terms: the model does not match the coefficients".into())
        }
        ModelKind::Axis if !off_diagonal_zero => Some("model `axis` has three axis scales (a diagonal matrix), but the matrix has off-diagonal terms: the model does not match the coefficients".into()),
        ModelKind::Triangular if !(small(m[1][0]) && small(m[2][0]) && small(m[2][1])) => {
            Some("model `triangular` is upper triangular, but the matrix has terms below the diagonal: the model does not match the coefficients".into())
        }
        _ => None,
    }
}

/// Largest thruster term accepted, raw units per ampere (a 100 A thruster
/// bus at this would add 10⁶ units: far beyond any installation).
pub const MAX_BIAS_PER_A: f64 = 1e4;

/// The thruster-current block: `h = matrix · (raw − bias − bias_per_a · motor_current_a)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CurrentBlock {
    /// Field the thrusters add per ampere of `motor_current_a`, raw input units per A.
    pub bias_per_a: [f64; 3],
}

/// The temperature block: the sensor's gain changes by `gain_per_c` (relative,
/// per °C) away from `ref_c`: `raw ⊘ (1 + gain_per_c ⊙ (temp_c − ref_c))`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TemperatureBlock {
    /// Reference temperature, °C.
    pub ref_c: f64,
    /// Relative gain change per °C, per axis.
    pub gain_per_c: [f64; 3],
}

/// The format of the calibration documents this build writes and the newest
/// it reads (`format_version`, both forms: the field calibration and the
/// heading-only compass's). A document without the key is of format 1 (the
/// format before it was numbered). Raise it when a block changes meaning; a
/// new optional block that older readers refuse by name needs no new number.
pub const FORMAT_VERSION: u32 = 1;

/// What a document without `format_version` is.
pub(crate) fn format_one() -> u32 {
    1
}

/// The form of a heading-only calibration document.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DocForm {
    /// Only the swing, for a compass that gives a heading.
    HeadingOnly,
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
/// `format_version` is newer than [`FORMAT_VERSION`] or 0
/// (text that is not JSON is left to the document's reader to name).
pub(crate) fn read_doc_text(path: &Path) -> Result<String, CalDocError> {
    let text = std::fs::read_to_string(path).map_err(|source| CalDocError::Io { path: path.into(), source })?;
    let text = text.strip_prefix('\u{feff}').map(str::to_string).unwrap_or(text);
    if let Ok(VersionProbe { format_version: Some(version) }) = serde_json::from_str::<VersionProbe>(&text) {
        if version == 0 {
            return Err(CalDocError::BadFormat { path: path.into(), version });
        }
        if version > u64::from(FORMAT_VERSION) {
            return Err(CalDocError::NewerFormat { path: path.into(), version });
        }
    }
    Ok(text)
}

/// What `auto`'s held-out errors were measured against, in a few words.
fn basis_words(basis: super::auto::HeldOutBasis) -> &'static str {
    use super::auto::HeldOutBasis::*;
    match basis {
        ReferenceHeading => "held out against ref_heading_deg",
        GyroYaw => "held out against the integrated gyro yaw",
        FieldAndDip => "held out against the field's dip and horizontal intensity",
        Intensity => "held out against the field's intensity",
    }
}

/// Whether a document's text is the heading-only form (`false` when it
/// does not say, or is not JSON: the field reader then says why).
pub(crate) fn is_compass_doc(text: &str) -> bool {
    serde_json::from_str::<FormProbe>(text).is_ok_and(|p| p.form == Some(DocForm::HeadingOnly))
}

/// The calibration document. A key it does not know is refused with the
/// key's name (the contract: a reader that does not know a block must
/// refuse the document rather than ignore it).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalDoc {
    /// The document's format ([`FORMAT_VERSION`] when written; a document
    /// without it was written before formats were numbered and is read as
    /// format 1; a newer one is refused when read).
    #[serde(default = "format_one")]
    pub format_version: u32,
    /// `sphere`, `axis`, `full` or `triangular`.
    #[serde(with = "model_name")]
    pub model: ModelKind,
    /// Hard-iron bias, input units.
    pub bias: [f64; 3],
    /// `h_nT = matrix · (raw − bias)`.
    pub matrix: [[f64; 3]; 3],
    /// Reference intensity the fit used, nT.
    pub field_nt: f64,
    /// Declination, degrees east.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub declination_deg: Option<f64>,
    /// Swing (heading) correction.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub swing: Option<Swing<f64>>,
    /// Thruster-current compensation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current: Option<CurrentBlock>,
    /// Temperature compensation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub temperature: Option<TemperatureBlock>,
    /// The field the calibration is judged against (the world model at the
    /// site, the user's, or the fit's own estimate), with what the
    /// calibrated recording showed beside it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reference: Option<Reference>,
    /// Residuals, coverage, warnings of each step.
    #[serde(default)]
    pub quality: Quality,
    /// Per-iteration back-stepping trace (`backstep --json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trace: Option<Vec<TraceEntry>>,
}

/// The model as its document name, with a specific message for an unknown one.
mod model_name {
    use calib_core::cal::ModelKind;
    use serde::{de::Error, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(m: &ModelKind, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(m.name())
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ModelKind, D::Error> {
        let name = String::deserialize(d)?;
        ModelKind::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = ModelKind::ALL.iter().map(|m| m.name()).collect();
            D::Error::custom(format!("unknown model `{name}` (expected one of {})", names.join(", ")))
        })
    }
}

/// The document name of a model ([`ModelKind::from_name`]).
pub fn model_kind(name: &str) -> Option<ModelKind> {
    ModelKind::from_name(name)
}

/// Why a calibration's coefficients are unusable, in words.
pub(crate) fn cal_error_text(e: CalError) -> &'static str {
    match e {
        CalError::NonFinite => "a coefficient is NaN or infinite",
        CalError::NotOrientationPreserving => "the matrix is singular or mirrors the field (determinant ≤ 0)",
        CalError::Implausible => "the matrix stretches one axis more than 4× another",
        CalError::BiasOutOfRange => "the bias is beyond any sensor's range",
    }
}

impl CalDoc {
    /// A document for a field calibration.
    pub fn new(kind: ModelKind, cal: &FieldCal<f64>, field_nt: f64, quality: Quality) -> Self {
        Self {
            format_version: FORMAT_VERSION,
            model: kind,
            bias: cal.bias,
            matrix: cal.matrix,
            field_nt,
            declination_deg: None,
            swing: None,
            current: None,
            temperature: None,
            reference: None,
            quality,
            trace: None,
        }
    }

    /// The field calibration.
    pub fn field_cal(&self) -> FieldCal<f64> {
        FieldCal { bias: self.bias, matrix: self.matrix }
    }

    /// Everything the board applies.
    pub fn calibration(&self) -> Calibration<f64> {
        Calibration {
            field: self.field_cal(),
            swing: self.swing.unwrap_or_else(Swing::zero),
            declination_rad: self.declination_deg.unwrap_or(0.0).to_radians(),
            env: self.env_terms(),
        }
    }

    /// The current and temperature terms ([`EnvTerms::none`] for absent blocks).
    pub fn env_terms(&self) -> EnvTerms<f64> {
        let none = EnvTerms::none();
        EnvTerms {
            bias_per_a: self.current.map_or(none.bias_per_a, |c| c.bias_per_a),
            ref_c: self.temperature.map_or(none.ref_c, |t| t.ref_c),
            gain_per_c: self.temperature.map_or(none.gain_per_c, |t| t.gain_per_c),
        }
    }

    /// The recording columns the document needs beyond the field and attitude:
    /// `motor_current_a` with a current block, `temp_c` with a temperature block.
    pub fn needed_columns(&self) -> Vec<&'static str> {
        let mut cols = vec![];
        if self.current.is_some() {
            cols.push("motor_current_a");
        }
        if self.temperature.is_some() {
            cols.push("temp_c");
        }
        cols
    }

    /// Checks the coefficients: finite, the matrix keeping the field's
    /// handedness and of the document's model, `field_nt` an intensity at
    /// the Earth's surface ([`FIELD_NT_RANGE`]), a swing that does not fold
    /// the heading ([`swing_problem`]), the reference and the quality
    /// numbers in their ranges. What a document must be to be written at
    /// all; [`CalDoc::check`] adds what a command using it must know.
    pub fn validate(&self, path: &Path) -> Result<(), CalDocError> {
        let invalid = |reason: &str| CalDocError::Invalid { path: path.into(), reason: reason.to_string() };
        self.field_cal().validate(MAX_BIAS_ABS).map_err(|e| invalid(cal_error_text(e)))?;
        if let Some(why) = model_problem(self.model, &self.matrix) {
            return Err(invalid(&why));
        }
        if let Some(why) = field_nt_problem(self.field_nt) {
            return Err(invalid(&format!("field_nt {why}")));
        }
        if let Some(why) = self.swing.as_ref().and_then(swing_problem) {
            return Err(invalid(&why));
        }
        if let Some(why) = self.quality.range_problem() {
            return Err(invalid(&format!("quality: {why}")));
        }
        if let Some(r) = &self.reference {
            let pos = |v: f64| v.is_finite() && v > 0.0;
            if !(pos(r.field_nt) && pos(r.field_sigma_nt) && r.field_sigma_nt < r.field_nt) {
                return Err(invalid("reference.field_nt and field_sigma_nt must be positive numbers of nT, the σ below the intensity"));
            }
            if !r.inclination_deg.is_none_or(|i| i.is_finite() && i.abs() < 90.0) || !r.inclination_sigma_deg.is_none_or(|s| s.is_finite() && s > 0.0 && s < 90.0) {
                return Err(invalid("reference.inclination_deg must be within ±90 and its σ a positive number of degrees"));
            }
        }
        if let Some(d) = self.declination_deg {
            if !(d.is_finite() && d.abs() <= 180.0) {
                return Err(invalid("declination_deg must be within ±180"));
            }
        }
        match self.env_terms().validate(MAX_BIAS_PER_A) {
            Ok(()) => {}
            Err(CalError::NonFinite) => return Err(invalid("current.bias_per_a and temperature.ref_c/gain_per_c must be finite numbers")),
            Err(CalError::Implausible) => return Err(invalid("temperature: each gain_per_c must be below 0.03 per °C in size and ref_c within ±100 °C")),
            Err(_) => return Err(invalid("current.bias_per_a is beyond 10 000 raw units per ampere")),
        }
        Ok(())
    }

    /// The document's own reference check's disagreement, when it failed
    /// (`reference.check.agrees` false: a fit that allowed weak results).
    pub fn reference_disagreement(&self) -> Option<&str> {
        let check = self.reference.as_ref()?.check.as_ref()?;
        (!check.agrees).then_some(if check.disagreement.is_empty() { "no reason recorded" } else { check.disagreement.as_str() })
    }

    /// Why `fit` (auto) kept this document only as weak results were
    /// allowed (`quality.auto.kept_weak`), with the kept model's numbers
    /// from its candidate row against [`MAX_HELD_OUT_DEG`] (the recorded
    /// words when the row is missing); `None` for any other document.
    pub fn kept_weak(&self) -> Option<String> {
        let auto = self.quality.auto.as_ref()?;
        let recorded = auto.kept_weak.as_ref()?;
        let row = auto.candidates.iter().find(|r| r.model == auto.chosen);
        let deg = |v: Option<f64>| v.map_or_else(|| "not recorded".to_string(), |v| format!("{v:.2}°"));
        Some(match row {
            Some(r) if r.held_out_deg.is_some() => format!(
                "the model kept, `{}`, has a held-out error of {} and its own expected error is {} ({}), where both must be below {MAX_HELD_OUT_DEG}°",
                auto.chosen,
                deg(r.held_out_deg),
                deg(r.expected_deg.or(r.held_out_deg)),
                basis_words(auto.basis),
            ),
            _ => format!("`{}`: {recorded}", auto.chosen),
        })
    }

    /// The one check of a document a command is about to use:
    /// [`CalDoc::validate`], then refused unless `allow_weak`: a check
    /// failed when it was written ([`CalDocError::AllowedWeak`]), a failed
    /// reference check ([`CalDocError::WeakReference`]) and a model `fit`
    /// (auto) kept though it did not qualify ([`CalDocError::KeptWeak`]).
    /// Returns what the command must say about the document (on stderr and
    /// in its summary or output document): empty for a sound one.
    pub fn check(&self, path: &Path, allow_weak: bool) -> Result<Vec<String>, CalDocError> {
        self.validate(path)?;
        let mut said = Vec::new();
        if !self.quality.allowed_weak.is_empty() {
            let what = self.quality.allowed_weak.join("; ");
            if !allow_weak {
                return Err(CalDocError::AllowedWeak { path: path.into(), what });
            }
            said.push(format!("{}: a weak calibration ({what}); used because weak results were allowed", path.display()));
        }
        if let Some(numbers) = self.kept_weak() {
            if !allow_weak {
                return Err(CalDocError::KeptWeak { path: path.into(), numbers });
            }
            said.push(format!("{}: a weak calibration (`fit` kept it only because weak results were allowed: {numbers}); used because weak results were allowed", path.display()));
        }
        if let Some(d) = self.reference_disagreement() {
            // A reference the fit estimated from its own calibration
            // recording is no independent judge: its disagreement is said,
            // not refused (the session's chain writes such documents when
            // no site is known; the world model's or a user's is refused).
            let independent = self.reference.as_ref().is_some_and(|r| r.source != super::reference::ReferenceSource::CalibrationData);
            if !independent {
                said.push(format!("{}: the calibration disagrees with the field estimated from its own calibration recording ({d}): no independent reference judged it", path.display()));
                return Ok(said);
            }
            if !allow_weak {
                return Err(CalDocError::WeakReference { path: path.into(), disagreement: d.to_string() });
            }
            said.push(format!("{}: the calibration disagrees with its own reference field ({d}); used because weak results were allowed", path.display()));
        }
        Ok(said)
    }

    /// Reads a document and runs [`CalDoc::check`] on it: weak documents
    /// (a failed reference check, a model `fit` kept only as weak) refused. [`CalDoc::load_with`] to allow them.
    pub fn load(path: &Path) -> Result<Self, CalDocError> {
        Self::load_with(path, false).map(|(doc, _)| doc)
    }

    /// Reads a document and runs [`CalDoc::check`] on it with `allow_weak`:
    /// the document and what must be said about it.
    pub fn load_with(path: &Path, allow_weak: bool) -> Result<(Self, Vec<String>), CalDocError> {
        // A UTF-8 byte-order mark (Windows editors) is not part of the JSON.
        let text = read_doc_text(path)?;
        if is_compass_doc(&text) {
            return Err(CalDocError::HeadingOnly(path.into()));
        }
        let doc: CalDoc = serde_json::from_str(&text).map_err(|source| CalDocError::Parse { path: path.into(), source })?;
        let said = doc.check(path, allow_weak)?;
        Ok((doc, said))
    }

    /// Validates and writes the document (pretty JSON), through
    /// [`crate::files::write_atomic`]: an interrupted write never leaves a
    /// half-written calibration behind.
    pub fn save(&self, path: &Path) -> Result<(), CalDocError> {
        self.validate(path)?;
        let text = serde_json::to_string_pretty(self).map_err(|source| CalDocError::Parse { path: path.into(), source })?;
        crate::files::write_text_atomic(path, &(text + "\n"))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc() -> CalDoc {
        let cal = FieldCal { bias: [1.0, 2.0, 3.0], matrix: [[5.0, 0.0, 0.0], [0.0, 5.5, 0.0], [0.0, 0.0, 4.8]] };
        CalDoc::new(ModelKind::Axis, &cal, 48_730.0, Quality::default())
    }

    /// `format_version`: written as 1; a document without it (every one
    /// written before it was numbered) loads as format 1; 2 is refused for
    /// its format, before its unknown keys; 0 is no format. Both forms.
    #[test]
    fn documents_carry_their_format_and_a_newer_one_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cal.json");
        doc().save(&p).unwrap();
        let written: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
        assert_eq!(written["format_version"], 1);
        let with = |key_value: Option<&str>, extra: &str| {
            let mut v = written.clone();
            let obj = v.as_object_mut().unwrap();
            obj.remove("format_version");
            let mut text = serde_json::to_string(&v).unwrap();
            text.pop();
            if let Some(kv) = key_value {
                text += &format!(",{kv}");
            }
            text += extra;
            text += "}";
            std::fs::write(&p, text).unwrap();
            CalDoc::load(&p)
        };
        assert_eq!(with(None, "").unwrap().format_version, 1, "an older document loads");
        let e = with(Some("\"format_version\": 2"), ",\"gradient\": {}").unwrap_err().to_string();
        assert!(e.contains("format 2, newer than this magcal reads (up to format 1)"), "{e}");
        let e = with(Some("\"format_version\": 0"), "").unwrap_err().to_string();
        assert!(e.contains("format_version 0 is not"), "{e}");
        // The heading-only form through the same reader.
        let c = dir.path().join("compass.json");
        std::fs::write(&c, r#"{"format_version": 3, "form": "heading_only", "swing": {"a": 0, "b": 0, "c": 0, "d": 0, "e": 0}}"#).unwrap();
        let e = crate::doc::compass::Document::load(&c).unwrap_err().to_string();
        assert!(e.contains("format 3, newer"), "{e}");
        std::fs::write(&c, r#"{"form": "heading_only", "swing": {"a": 0, "b": 0, "c": 0, "d": 0, "e": 0}}"#).unwrap();
        assert!(crate::doc::compass::Document::load(&c).is_ok());
    }

    #[test]
    fn documents_round_trip_and_match_the_interface() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cal.json");
        let mut d = doc();
        d.swing = Some(Swing { a: 0.14199, b: -0.01101, c: 0.01071, d: 0.0061, e: 0.05528 });
        d.save(&p).unwrap();
        // The contract of docs/INTERFACES.md, written out here apart from CalDoc.
        #[derive(serde::Deserialize)]
        struct Swing5 {
            e: f64,
        }
        #[derive(serde::Deserialize)]
        struct Interface {
            model: String,
            bias: [f64; 3],
            matrix: [[f64; 3]; 3],
            field_nt: f64,
            declination_deg: Option<f64>,
            swing: Swing5,
        }
        let text = std::fs::read_to_string(&p).unwrap();
        let v: Interface = serde_json::from_str(&text).unwrap();
        assert_eq!(v.model, "axis");
        assert_eq!(v.bias[2], 3.0);
        assert_eq!(v.matrix[1][1], 5.5);
        assert_eq!(v.field_nt, 48_730.0);
        assert_eq!(v.swing.e, 0.05528);
        assert!(v.declination_deg.is_none() && !text.contains("declination_deg"));
        assert_eq!(CalDoc::load(&p).unwrap(), d);
    }

    /// Coefficients read back bit for bit: the firmware's conformance and
    /// the board's upload rest on it. The numbers are serde_json's own
    /// reported misreads without its `float_roundtrip` feature (serde-rs/json
    /// issues 937 and 1336: one unit in the last place off, e.g.
    /// 0x3ff9_3e93_e93e_863b read as …863a); Rust's `str::parse` is the
    /// reference.
    #[test]
    fn coefficients_are_read_back_bit_for_bit() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cal.json");
        let texts = ["0.09144338512092887", "0.9146155235219107", "1.5777777777770001"];
        let v: Vec<f64> = texts.iter().map(|t| t.parse().unwrap()).collect();
        let cal = FieldCal { bias: [v[0], v[1], v[2]], matrix: [[v[2], v[0], 0.0], [v[0], v[1], 0.0], [0.0, 0.0, v[2]]] };
        let d = CalDoc::new(ModelKind::Full, &cal, 48_730.0, Quality::default());
        d.save(&p).unwrap();
        let back = CalDoc::load(&p).unwrap();
        assert_eq!(back.bias.map(f64::to_bits), cal.bias.map(f64::to_bits));
        assert_eq!(back.matrix.map(|r| r.map(f64::to_bits)), cal.matrix.map(|r| r.map(f64::to_bits)));
    }

    #[test]
    fn bad_documents_are_refused_with_a_reason() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.json");
        std::fs::write(&p, "{\"model\": \"axis\"}").unwrap();
        assert!(matches!(CalDoc::load(&p), Err(CalDocError::Parse { .. })));
        let out = dir.path().join("out.json");
        let ellipse = serde_json::to_string(&doc()).unwrap().replace("\"axis\"", "\"ellipse\"");
        std::fs::write(&p, ellipse).unwrap();
        let e = CalDoc::load(&p).unwrap_err();
        assert!(matches!(e, CalDocError::Parse { .. }) && e.to_string().contains("unknown model `ellipse`"), "{e}");
        let mut d = doc();
        d.matrix[0][0] = -5.0;
        let e = d.save(&out).unwrap_err();
        assert!(e.to_string().contains("determinant"), "{e}");
        assert!(!out.exists(), "nothing written for a refused document");
    }

    #[test]
    fn current_and_temperature_blocks_are_read_and_unknown_blocks_refused() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cal.json");
        let base = r#""model": "full", "bias": [1, 2, 3], "matrix": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "field_nt": 50000"#;
        let load = |text: String| {
            std::fs::write(&p, text).unwrap();
            CalDoc::load(&p)
        };
        let none = load(format!("{{{base}}}")).unwrap();
        assert!(none.current.is_none() && none.temperature.is_none() && none.needed_columns().is_empty());
        let both = load(format!(
            r#"{{{base}, "current": {{"bias_per_a": [0.5, -1.5, 2]}}, "temperature": {{"ref_c": 20, "gain_per_c": [0.001, 0, -0.002]}}}}"#
        ))
        .unwrap();
        assert_eq!(both.current.unwrap().bias_per_a, [0.5, -1.5, 2.0]);
        assert_eq!(both.calibration().env.gain_per_c[2], -0.002);
        assert_eq!(both.needed_columns(), ["motor_current_a", "temp_c"]);
        let e = load(format!(r#"{{{base}, "hysteresis": {{"k": 1}}}}"#)).unwrap_err();
        assert!(matches!(e, CalDocError::Parse { .. }) && e.to_string().contains("unknown field `hysteresis`"), "{e}");
        let e = load(format!(r#"{{{base}, "current": {{"bias_per_amp": [1, 2, 3]}}}}"#)).unwrap_err();
        assert!(e.to_string().contains("bias_per_amp"), "{e}");
        let e = load(format!(r#"{{{base}, "temperature": {{"ref_c": 20, "gain_per_c": [0.5, 0, 0]}}}}"#)).unwrap_err();
        assert!(matches!(e, CalDocError::Invalid { .. }) && e.to_string().contains("0.03 per °C"), "{e}");
        // Written and read back, the blocks survive.
        let out = dir.path().join("out.json");
        both.save(&out).unwrap();
        assert_eq!(CalDoc::load(&out).unwrap(), both);
    }

    #[test]
    fn the_one_check_refuses_what_cannot_be_a_calibration_and_a_weak_one_unless_allowed() {
        let p = Path::new("cal.json");
        let reason = |d: &CalDoc| d.validate(p).unwrap_err().to_string();
        // A fold: 1 + B cos ψ is 0.1 at 180° with B = 0.9 (the compass form's rule).
        let mut d = doc();
        d.swing = Some(Swing { a: 0.0, b: 0.9, c: 0.0, d: 0.0, e: 0.0 });
        assert!(reason(&d).contains("folds headings") && reason(&d).contains("0.10°"), "{}", reason(&d));
        assert!((min_correction_slope(&d.swing.unwrap()) - 0.1).abs() < 1e-12);
        // A model its matrix is not.
        let mut d = doc();
        d.matrix[0][1] = 0.3;
        assert!(reason(&d).contains("model `axis`"), "{}", reason(&d));
        d.model = ModelKind::Full;
        d.validate(p).unwrap();
        d.model = ModelKind::Sphere;
        d.matrix = [[5.0, 0.0, 0.0], [0.0, 5.0, 0.0], [0.0, 0.0, 5.0]];
        d.validate(p).unwrap();
        d.matrix[2][2] = 5.5;
        assert!(reason(&d).contains("model `sphere`"), "{}", reason(&d));
        // Field in µT, a heading error of 10⁹ degrees.
        let mut d = doc();
        d.field_nt = 48.73;
        assert!(reason(&d).contains("looks like µT"), "{}", reason(&d));
        let mut d = doc();
        d.quality.predicted_heading_rms_deg = Some(1e9);
        assert!(reason(&d).contains("predicted_heading_rms_deg"), "{}", reason(&d));
        // A failed reference check: refused, or kept with allow_weak and said.
        let mut d = doc();
        let mut r = crate::doc::reference::Reference::user_intensity(48_730.0);
        r.check = Some(crate::doc::reference::ReferenceCheck { inclination_deg: None, inclination_allowance_deg: None, field_nt: 30_000.0, agrees: false, disagreement: "the calibrated intensity is 30000 nT".into() });
        d.reference = Some(r);
        d.validate(p).unwrap();
        assert!(matches!(d.check(p, false), Err(CalDocError::WeakReference { .. })));
        let said = d.check(p, true).unwrap();
        assert!(said.len() == 1 && said[0].contains("30000 nT"), "{said:?}");
        assert!(doc().check(p, false).unwrap().is_empty());
        // A model `fit` (auto) kept only as weak: refused with its numbers
        // against the limit, or used with allow_weak and said.
        let mut w = doc();
        let row = |model: &str, held_out: f64, expected: f64| crate::doc::auto::CandidateRow { model: model.into(), held_out_deg: Some(held_out), predicted_deg: None, expected_deg: Some(expected), refused: None, note: None };
        w.quality.auto = Some(crate::doc::auto::AutoChoice {
            chosen: "axis".into(),
            basis: crate::doc::auto::HeldOutBasis::GyroYaw,
            candidates: vec![row("attitude", 9.1, 2.0), row("axis", 7.88, 3.4)],
            kept_weak: Some("kept because weak results were allowed".into()),
        });
        let e = w.check(p, false).unwrap_err();
        let text = e.to_string();
        assert!(matches!(e, CalDocError::KeptWeak { .. }) && text.contains("`axis`") && text.contains("7.88°") && text.contains("3.40°") && text.contains("below 5°") && text.contains("gyro yaw"), "{text}");
        let said = w.check(p, true).unwrap();
        assert!(said.len() == 1 && said[0].contains("7.88°") && said[0].contains("weak results were allowed"), "{said:?}");
        w.quality.auto.as_mut().unwrap().kept_weak = None;
        assert!(w.check(p, false).unwrap().is_empty(), "a choice that qualified is not weak");
        // Against the fit's own estimate (no independent judge): said, not refused.
        d.reference.as_mut().unwrap().source = crate::doc::reference::ReferenceSource::CalibrationData;
        let said = d.check(p, false).unwrap();
        assert!(said.len() == 1 && said[0].contains("no independent reference"), "{said:?}");
    }
}
