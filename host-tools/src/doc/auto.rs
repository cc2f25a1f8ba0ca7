//! `fit --model auto`'s choice as a document holds it (`quality.auto`):
//! every candidate's row, what the held-out errors are measured against,
//! the model kept, and the held-out error above which no model is kept.

use serde::{Deserialize, Serialize};

/// No candidate with a held-out error or an expected error of its own at
/// or above this is kept (unless weak results are allowed), degrees.
pub const MAX_HELD_OUT_DEG: f64 = 5.0;

/// One candidate's row of the table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CandidateRow {
    /// The model's document name.
    pub model: String,
    /// Held-out RMS, degrees (heading, or the field's consistency), when the full fit was accepted.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub held_out_deg: Option<f64>,
    /// The covariance's own prediction, degrees.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub predicted_deg: Option<f64>,
    /// The candidate's own expected heading error (the prediction with the
    /// heading noise, before the held-out error), degrees.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub expected_deg: Option<f64>,
    /// Why the model was not fitted or not judged.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
    /// What was waived for it (the in-sample magnitude gate of the gyro-
    /// and attitude-aided fits).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub note: Option<String>,
}

/// What the held-out judgement compares with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum HeldOutBasis {
    /// The recording's `ref_heading_deg`.
    ReferenceHeading,
    /// The heading's changes along each held-out block against the
    /// integrated gyro yaw (one constant per unbroken stretch removed).
    GyroYaw,
    /// The dip and horizontal intensity against the reference field.
    FieldAndDip,
    /// The intensity alone (no roll and pitch).
    Intensity,
}

/// The choice and its table (the document's `quality.auto`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AutoChoice {
    /// The model kept.
    pub chosen: String,
    /// What the held-out errors are measured against.
    pub basis: HeldOutBasis,
    /// Every candidate.
    pub candidates: Vec<CandidateRow>,
    /// Set when the model kept did not qualify (its held-out or its own
    /// expected error at or above [`MAX_HELD_OUT_DEG`]) and was kept only
    /// because weak results were allowed: why, in words.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kept_weak: Option<String>,
}
