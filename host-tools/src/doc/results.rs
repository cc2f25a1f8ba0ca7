//! Typed results: what the fits, the back-stepping and a session report.
//! These are the `quality`, `trace` and summary parts of the JSON documents
//! of `docs/INTERFACES.md`; every program that reads them (the CLI, the
//! session, the report, `cargo xtask`) reads these structs, so a renamed
//! field is a compile error rather than a NaN.

use calib_core::backstep::RunStats;
use calib_core::linalg::Mat3;
use calib_core::swing::SwingTerms;
use serde::{Deserialize, Serialize};

/// A calibration document's `quality` block: what each step found.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Quality {
    /// The field fit's residuals and coverage (absent on coefficients read
    /// from a board).
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub fit: Option<FitQuality>,
    /// The back-stepping on the out-and-back run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub backstep: Option<BackstepQuality>,
    /// The swing (heading) fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub swing: Option<SwingQuality>,
    /// The gyro-aided fit's diagnostics.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub gyro: Option<GyroQuality>,
    /// The 1σ heading error over all headings that the fit's own uncertainty
    /// predicts, degrees (`docs/INTERFACES.md`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_heading_rms_deg: Option<f64>,
    /// The heading RMS a recording should show with this calibration against
    /// a true heading, degrees: the calibration's own predicted error
    /// (`predicted_heading_rms_deg`) and each sample's noise across the
    /// horizontal field (the latest step's residual over `F cos I`) in
    /// quadrature (`compute::apply::expected_heading_rms_deg`); for `fit
    /// --model auto` at least the held-out error. What a validation run's
    /// heading RMS is compared with.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_heading_rms_deg: Option<f64>,
    /// `fit --model auto`: the candidates, their held-out errors and the choice.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub auto: Option<super::auto::AutoChoice>,
    /// Every check this document, or a document it was made from, failed
    /// and was kept only because weak results were allowed (`--allow-weak`):
    /// one line each, in words (a fit's failed quality gate; a weak
    /// calibration a later step was run from). A reader refuses the
    /// document unless weak results are allowed again ([`super::CalDoc::check`]),
    /// and a step run from it carries these lines into its own output.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub allowed_weak: Vec<String>,
}

/// What the gyro-aided fit determined, and how well.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GyroQuality {
    /// Windows of integrated gyro rotation used.
    pub kinematic_windows: u32,
    /// Levelled-vertical equations used (rows with roll and pitch).
    pub attitude_rows: u32,
    /// Integration window, s.
    pub window_s: f64,
    /// The magnetometer's lag behind the gyro that was applied, s.
    pub gyro_lag_s: f64,
    /// The gyro's bias, estimated, rad/s.
    pub gyro_bias_rad_s: [f64; 3],
    /// The levelled vertical field, nT.
    pub vertical_nt: f64,
    /// RMS residual of the kinematic and attitude equations, nT.
    pub residual_rms_nt: f64,
    /// 1σ of the hard iron, raw units.
    pub bias_sigma_raw: [f64; 3],
    /// 1σ of the matrix entries relative to the x gain
    /// (`xy xz yx yy yz zx zy zz`).
    pub matrix_sigma_rel: [f64; 8],
    /// The 1σ heading error the covariance predicts, degrees.
    pub predicted_heading_rms_deg: f64,
    /// The parameters the data determine weakly, one sentence each.
    #[serde(default)]
    pub weakly_determined: Vec<String>,
}

impl GyroQuality {
    /// The dip the fit found, degrees: its levelled vertical over `field_nt`.
    pub fn inclination_deg(&self, field_nt: f64) -> f64 {
        (self.vertical_nt / field_nt).clamp(-1.0, 1.0).asin().to_degrees()
    }
}

/// The largest heading error a quality number may state, degrees: a
/// heading is never further than half a turn from another.
pub const MAX_HEADING_ERROR_DEG: f64 = 180.0;

/// Largest delay of a reference behind a heading a document may state, s
/// (the command line's bound on `--delay-s`).
pub const MAX_DELAY_S: f64 = 3600.0;

impl Quality {
    /// Every warning of every step, in order (fit, back-stepping, swing).
    pub fn warnings(&self) -> impl Iterator<Item = &str> {
        let fit = self.fit.iter().flat_map(|f| f.warnings.iter());
        let swing = self.swing.iter().flat_map(|s| s.warnings.iter());
        fit.chain(swing).map(String::as_str)
    }

    /// Why a number of the block is out of its stated range (`None`: all
    /// are in range): heading errors within 0 … [`MAX_HEADING_ERROR_DEG`],
    /// residuals finite and not negative, coverage 0 … 100 %, the axis
    /// spread 0 … 1, a swing's delay within ±[`MAX_DELAY_S`].
    pub fn range_problem(&self) -> Option<String> {
        let mut headings: Vec<(&str, f64)> = vec![];
        let mut residuals: Vec<(&str, f64)> = vec![];
        if let Some(v) = self.predicted_heading_rms_deg {
            headings.push(("predicted_heading_rms_deg", v));
        }
        if let Some(v) = self.expected_heading_rms_deg {
            headings.push(("expected_heading_rms_deg", v));
        }
        if let Some(f) = &self.fit {
            residuals.extend([("residual_rms_nt", f.residual_rms_nt), ("residual_rms_pct", f.residual_rms_pct), ("residual_max_nt", f.residual_max_nt)]);
            if f.coverage_pct > 100 {
                return Some(format!("coverage_pct {} is beyond 100 %", f.coverage_pct));
            }
            if !f.axis_spread.iter().all(|v| (0.0..=1.0).contains(v)) {
                return Some(format!("axis_spread {:?} must be within 0 … 1", f.axis_spread));
            }
        }
        if let Some(g) = &self.gyro {
            headings.push(("gyro.predicted_heading_rms_deg", g.predicted_heading_rms_deg));
            residuals.push(("gyro.residual_rms_nt", g.residual_rms_nt));
        }
        if let Some(e) = self.backstep.as_ref().and_then(|b| b.estimates.as_ref()) {
            headings.push(("backstep.estimates.predicted_heading_rms_deg", e.predicted_heading_rms_deg));
            residuals.push(("backstep.estimates.residual_rms_nt", e.residual_rms_nt));
        }
        if let Some(s) = &self.swing {
            headings.extend([("swing.before_rms_deg", s.before_rms_deg), ("swing.after_rms_deg", s.after_rms_deg)]);
            if !(s.delay_s.is_finite() && s.delay_s.abs() <= MAX_DELAY_S) {
                return Some(format!("swing.delay_s {} must be within ±{MAX_DELAY_S} s", s.delay_s));
            }
        }
        if let Some((name, v)) = headings.into_iter().find(|(_, v)| !(0.0..=MAX_HEADING_ERROR_DEG).contains(v)) {
            return Some(format!("{name} {v} must be within 0 … {MAX_HEADING_ERROR_DEG}°"));
        }
        if let Some((name, v)) = residuals.into_iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
            return Some(format!("{name} {v} must be a finite number, not negative"));
        }
        None
    }
}

/// A field fit's quality on the samples it was fitted to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitQuality {
    /// Which units the raw data look like against the reference (a hint).
    pub input_units_guess: String,
    /// Samples fitted.
    pub samples: u32,
    /// Rows skipped for an incomplete `mx, my, mz`.
    pub skipped_rows: usize,
    /// RMS of `|h| − F`, nT.
    pub residual_rms_nt: f64,
    /// RMS of `|h| − F`, % of `F`.
    pub residual_rms_pct: f64,
    /// Mean of `|h| − F`, nT.
    pub residual_mean_nt: f64,
    /// Largest `||h| − F|`, nT.
    pub residual_max_nt: f64,
    /// Field directions visited, % of the sphere's equal-area bins.
    pub coverage_pct: u8,
    /// Standard deviation of each component of the unit field direction
    /// (≈ 0.577 for a full tumble, ≈ 0 for an axis that never turned).
    pub axis_spread: [f64; 3],
    /// What the operator should know.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// Which back-stepping solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum BackstepMethod {
    /// Paper 000's corrections (axis model only).
    Paper,
    /// Our joint least-squares refinement (the default).
    Joint,
}

impl BackstepMethod {
    /// The name used in documents and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BackstepMethod::Paper => "paper",
            BackstepMethod::Joint => "joint",
        }
    }
}

/// The run's levelled statistics with one calibration (`RunStats` of
/// calib-core, in the document's units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RunStatsDoc {
    /// Mean |H| after the turnaround minus before, nT.
    pub step_nt: f64,
    /// Mean levelled horizontal intensity, nT.
    pub hh_nt: f64,
    /// Mean levelled vertical component, nT.
    pub hz_nt: f64,
    /// Mean |H|, nT.
    pub f_nt: f64,
    /// RMS of |H| − the reference F, nT.
    pub f_error_rms_nt: f64,
}

impl From<&RunStats<f64>> for RunStatsDoc {
    fn from(s: &RunStats<f64>) -> Self {
        Self { step_nt: s.step_nt, hh_nt: s.hh_nt, hz_nt: s.hz_nt, f_nt: s.f_nt, f_error_rms_nt: s.f_error_rms_nt }
    }
}

/// What our joint refinement separated.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct JointDetails {
    /// The thrusters' running-only bias, raw units.
    pub running_bias_raw: [f64; 3],
    /// The bias with thrusters off, raw units.
    pub resting_bias_raw: [f64; 3],
    /// Swing-test samples used for the magnitudes.
    pub swing_samples: usize,
}

/// The back-stepping's report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BackstepQuality {
    /// Which solver.
    pub method: BackstepMethod,
    /// The turnaround used, s from the start of the recording.
    pub turnaround_s: f64,
    /// Run samples used.
    pub samples: usize,
    /// The run with the input calibration.
    pub before: RunStatsDoc,
    /// The run with the result.
    pub after: RunStatsDoc,
    /// The joint solver's separated biases.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub details: Option<JointDetails>,
    /// The joint solver's environment estimates with their 1σ.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimates: Option<JointEstimates>,
}

/// An estimate and its 1σ.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Estimate3 {
    /// The value per axis.
    pub value: [f64; 3],
    /// Its 1σ per axis.
    pub sigma: [f64; 3],
}

/// What the joint refinement estimated besides the field calibration, each
/// with its 1σ from the fit's covariance, and what it could not estimate.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct JointEstimates {
    /// The thrusters' field per ampere, raw units per A (when estimated).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bias_per_a_raw: Option<Estimate3>,
    /// The gains' change per °C (when estimated).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gain_per_c: Option<Estimate3>,
    /// Reference temperature of the gains, °C.
    pub ref_c: f64,
    /// The resting bias, raw units.
    pub bias_raw: Estimate3,
    /// The running-only bias, raw units (zero when the current term is used).
    pub running_bias_raw: Estimate3,
    /// 1σ of the matrix entries, row major.
    pub matrix_sigma: [f64; 9],
    /// The local inclination minus the reference's, degrees.
    pub local_inclination_offset_deg: f64,
    /// Its 1σ, degrees.
    pub local_inclination_sigma_deg: f64,
    /// The local horizontal and down components this gives, nT (the
    /// intensity is the reference's: not observable).
    pub local_hz_nt: [f64; 2],
    /// 1σ of the intensity (IGRF-14's, along F), nT.
    pub intensity_sigma_nt: f64,
    /// The AHRS misalignment added to roll and pitch, degrees (when
    /// observable), with its 1σ.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub misalignment_deg: Option<[f64; 2]>,
    /// 1σ of the misalignment, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub misalignment_sigma_deg: Option<[f64; 2]>,
    /// RMS of the run and swing residuals, nT.
    pub residual_rms_nt: f64,
    /// The 1σ heading error at level headings 0°, 15°, … 345°, degrees.
    pub heading_sigma_deg: Vec<f64>,
    /// Their RMS, degrees.
    pub predicted_heading_rms_deg: f64,
    /// Predicted RMS with 1, 2, 3 … more level surface circles, degrees.
    pub predicted_with_circles_deg: Vec<f64>,
    /// What more coverage would buy, one sentence.
    pub guidance: String,
    /// What the data could not separate, one sentence each.
    pub notes: Vec<String>,
}

/// The swing (Fourier heading) fit's report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwingQuality {
    /// Terms fitted: 1 (A), 3 (A, B, C) or 5.
    #[serde(with = "swing_terms_count")]
    pub terms: SwingTerms,
    /// Heading pairs fitted.
    pub samples: u32,
    /// Delay of the reference behind the magnetometer, s.
    pub delay_s: f64,
    /// Whether the delay was estimated (or given).
    pub delay_estimated: bool,
    /// The delay search: its window and whether it stopped at an edge
    /// (absent when the delay was given).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub delay_search: Option<Box<DelaySearch>>,
    /// The constant-only fit's A, rad (a sanity check of the full fit).
    pub a_only_rad: f64,
    /// Heading error against the reference before the swing correction, ° RMS.
    pub before_rms_deg: f64,
    /// And after, ° RMS.
    pub after_rms_deg: f64,
    /// The water current removed from the GPS course before the fit (absent
    /// when course was used as heading).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current: Option<SwingCurrent>,
    /// The fit judged on data it did not see: each half of the reference
    /// (by time) corrected by the swing fitted on the other half (absent
    /// when a half cannot be fitted, or the current was removed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOutSwing>,
    /// What the operator should know.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// Where the delay of a swing's reference was searched, and whether the
/// search stopped at the window's edge.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct DelaySearch {
    /// The window searched, s.
    pub window_s: [f64; 2],
    /// The window's bound the search stopped at, s, when the delay found is
    /// within one search step of it: the residual may fall further outside
    /// the window, and the delay (and the A it shifts) is then the window's,
    /// not the data's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub at_edge_s: Option<f64>,
}

/// A swing judged on held-out data: each half of the reference pairs (split
/// at the median time) against the heading corrected by the swing fitted
/// on the other half.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HeldOutSwing {
    /// Pairs judged (both halves).
    pub pairs: u32,
    /// Reference − heading before any correction, ° RMS.
    pub before_rms_deg: f64,
    /// Reference − heading corrected by the other half's swing, ° RMS.
    pub after_rms_deg: f64,
}

/// The water current the swing fit estimated from the surface GPS fixes and
/// the speed through water, and removed from the course (the crab angle).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SwingCurrent {
    /// The current towards north and east, m/s.
    pub current_ne_mps: [f64; 2],
    /// Its 1σ from the scatter of the fixes, m/s.
    pub sigma_ne_mps: [f64; 2],
    /// GPS fixes used.
    pub fixes: u32,
    /// Runs of consecutive fixes.
    pub segments: u32,
    /// `|Σ s·u(ψ)| / Σ s` of the water velocity at the fixes (0 for whole
    /// circles, 1 for a straight leg).
    pub heading_resultant: f64,
    /// Rounds of the current/swing alternation.
    pub rounds: u32,
    /// The swing fit's residual against raw course (crab angle left in), ° RMS.
    pub course_after_rms_deg: f64,
}

/// `SwingTerms` as the number of coefficients (1, 3 or 5) in JSON.
mod swing_terms_count {
    use calib_core::swing::SwingTerms;
    use serde::{de::Error, Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(t: &SwingTerms, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_u8(t.count() as u8)
    }
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<SwingTerms, D::Error> {
        match u8::deserialize(d)? {
            1 => Ok(SwingTerms::ConstantOnly),
            3 => Ok(SwingTerms::FirstHarmonic),
            5 => Ok(SwingTerms::Full),
            n => Err(D::Error::custom(format!("swing terms must be 1, 3 or 5, not {n}"))),
        }
    }
}

/// Which correction a back-stepping trace entry made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Correction {
    /// The input coefficients.
    #[serde(rename = "start")]
    Start,
    /// The paper's first correction: horizontal scales from the Hh ratio.
    #[serde(rename = "horizontal scale (Hh ratio)")]
    HorizontalScale,
    /// The paper's second: `sz` for no step at the turnaround.
    #[serde(rename = "sz for no step")]
    VerticalScale,
    /// The paper's third: `bz` from the magnitude.
    #[serde(rename = "bz from magnitude")]
    VerticalBias,
    /// Our joint least squares.
    #[serde(rename = "joint least squares")]
    JointLeastSquares,
}

impl Correction {
    /// calib-core's trace code (0 start, 1 horizontal scale, 2 sz, 3 bz).
    pub fn from_paper_code(code: u8) -> Self {
        match code {
            0 => Correction::Start,
            1 => Correction::HorizontalScale,
            2 => Correction::VerticalScale,
            _ => Correction::VerticalBias,
        }
    }

    /// How the trace prints it.
    pub fn label(self) -> &'static str {
        match self {
            Correction::Start => "start",
            Correction::HorizontalScale => "horizontal scale (Hh ratio)",
            Correction::VerticalScale => "sz for no step",
            Correction::VerticalBias => "bz from magnitude",
            Correction::JointLeastSquares => "joint least squares",
        }
    }
}

/// One entry of the back-stepping trace (`backstep --json`'s `trace`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TraceEntry {
    /// Iteration (0 = the input coefficients).
    pub iteration: u8,
    /// Which correction.
    pub correction: Correction,
    /// The bias after it, raw units (when the step changes coefficients).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bias: Option<[f64; 3]>,
    /// The paper's axis scales after it, nT per raw unit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub scale: Option<[f64; 3]>,
    /// Our full matrix after it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub matrix: Option<Mat3<f64>>,
    /// What the run shows with these coefficients.
    #[serde(flatten)]
    pub stats: RunStatsDoc,
}

/// The on-board fit's report at the end of the swing test.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OnboardFitSummary {
    /// Samples the board absorbed.
    pub samples: u32,
    /// Field directions visited, %.
    pub coverage_pct: u8,
    /// The board's residual, nT RMS.
    pub residual_rms_nt: f32,
}

/// Heading and field errors on a validation run with a known heading.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ValidationMetrics {
    /// True-heading RMS error with the board's coefficients before the
    /// session, °.
    pub heading_rms_deg_before: f64,
    /// With the uploaded coefficients, from the board's own output, °.
    pub heading_rms_deg_after: f64,
    /// RMS of the board's |F| minus the reference field with the uploaded
    /// coefficients, nT: the true local field where the vehicle knows it
    /// (`field_reference` `true`: a simulated vehicle, crustal anomaly
    /// included), otherwise IGRF-14 at the logged position.
    pub field_error_nt_after: f64,
    /// `field_error_nt_after` is against the true local field (`false`:
    /// against IGRF).
    #[serde(default)]
    pub field_against_truth: bool,
    /// Samples with a heading from the board.
    pub validation_samples: usize,
}

/// `magcal session`'s summary (`summary.json`, `session --json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionSummary {
    /// The validation run's errors (a vehicle with a known heading only).
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub validation: Option<ValidationMetrics>,
    /// The coefficients were uploaded, committed and read back equal.
    pub coefficients_verified: bool,
    /// The board's sequence number of the stored set.
    pub coefficient_seq: u32,
    /// The on-board fit during the swing test.
    pub onboard_fit: OnboardFitSummary,
    /// The back-stepping's report.
    pub backstep: BackstepQuality,
    /// The swing fit's report.
    pub swing: SwingQuality,
    /// The true-heading error the calibration predicts for itself, ° RMS:
    /// the back-stepping's estimate from its parameters' covariance
    /// (`quality.predicted_heading_rms_deg`) and the run's white heading
    /// noise in quadrature, to set beside the validation's observed
    /// `heading_rms_deg_after`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted_heading_rms_deg: Option<f64>,
    /// Observed over predicted: `heading_rms_deg_after /
    /// predicted_heading_rms_deg` (near 1: the prediction is honest; well
    /// above 1: errors the model does not know about).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub heading_rms_observed_over_predicted: Option<f64>,
    /// "Recalibrate": the validation run's integrity (the final calibration
    /// applied by the board's own code) says the calibration does not fit
    /// this vehicle, with the evidence; absent when it fits or without a
    /// validation run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub recalibrate: Option<RecalibrateEvidence>,
    /// Where the session's files are.
    pub session_dir: std::path::PathBuf,
}

/// Why a session or `magcal log` says "recalibrate": what the run's
/// per-sample integrity found with the calibration (the session's validation
/// run with the final calibration; the board's streamed states for `magcal
/// log`). The rule is [`crate::doc::integrity::recalibrate_evidence`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RecalibrateEvidence {
    /// Rows of the validation run.
    pub rows: usize,
    /// Rows judged `cal_invalid` (a sustained misfit).
    pub cal_invalid_rows: usize,
    /// Their share of the rows, 0…1.
    pub cal_invalid_fraction: f64,
    /// The on-line hard-iron estimate was applied at some point (the stored
    /// hard iron no longer fits).
    pub hard_iron_applied: bool,
    /// The on-line hard-iron estimate at the end, nT (when there is one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hard_iron_nt: Option<[f64; 3]>,
    /// Longest run of rows not `ok`, s.
    pub longest_disturbance_s: f64,
    /// Longest run of rows `cal_invalid`, s (`magcal log`, which has the
    /// board's clock per sample; absent from a session's summary).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub longest_cal_invalid_s: Option<f64>,
}

/// What a session saves as `settings.json`: enough to reproduce it offline.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionSettings {
    /// Latitude, degrees.
    pub lat_deg: f64,
    /// Longitude, degrees.
    pub lon_deg: f64,
    /// Decimal year of the reference field.
    pub decimal_year: f64,
    /// The vehicle: what played the manoeuvres.
    pub vehicle: String,
    /// The board's firmware version.
    pub firmware: String,
    /// The commands that reproduce the computation offline.
    pub reproduce: Vec<String>,
}
