//! What a report is made of, and what writing it produced.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::doc::caldoc::CalDoc;
use crate::data::recording::Recording;
use crate::doc::results::{SessionSettings, SessionSummary};
use crate::geomag::Site;

/// A validation run: a recording and the true heading of each row.
pub struct Validation<'a> {
    /// The recording (mx, my, mz, roll_deg, pitch_deg, …).
    pub recording: &'a Recording,
    /// The true heading of each row, degrees from true north (NaN: unknown).
    pub truth_deg: &'a [f64],
    /// The column it came from (`true_heading_deg`; `ref_heading_deg`, a
    /// GPS course, is a reference, not the truth, and the headline says so).
    pub truth_column: &'a str,
}

/// What to put in a report. Every part is optional: a section whose input
/// is missing says so.
pub struct ReportInputs<'a> {
    /// The out-and-back run (field and surface-heading figures).
    pub run: Option<&'a Recording>,
    /// The swing test (coverage maps).
    pub swing: Option<&'a Recording>,
    /// The validation run with its truth (headline, card, heading vs truth).
    pub validation: Option<Validation<'a>>,
    /// Calibrations to compare, with their labels, in the order they were
    /// made: the last is the one reported on (the card, the headline).
    pub cals: Vec<(String, &'a CalDoc)>,
    /// The coefficients the board had before the session (the "before" of
    /// the validation run); without, the card's raw heading.
    pub before: Option<&'a CalDoc>,
    /// Reference intensity for the field figure, nT (else the site's IGRF).
    pub field_nt: Option<f64>,
    /// Where and when (date, IGRF).
    pub site: Option<Site>,
    /// The session's summary (verified upload, the board's own validation numbers).
    pub summary: Option<&'a SessionSummary>,
    /// The session's settings (vehicle, firmware).
    pub settings: Option<&'a SessionSettings>,
}

/// The files of the deviation card.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CardFiles {
    /// `magcal card`'s text table.
    pub text: PathBuf,
    /// `magcal card --csv`.
    pub csv: PathBuf,
    /// `magcal card --json`.
    pub json: PathBuf,
    /// What the card compares with: `truth (validation run)` or `GPS course (run)`.
    pub against: String,
}

/// What [`super::write_report`] wrote.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WrittenReport {
    /// The page.
    pub index: PathBuf,
    /// The deviation card, when the inputs allow one.
    pub card: Option<CardFiles>,
    /// Figures drawn.
    pub figures: usize,
    /// Sections left without their input, with the reason.
    pub missing: Vec<String>,
}
