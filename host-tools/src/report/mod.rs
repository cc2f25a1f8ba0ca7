//! The calibration report: one self-contained HTML page (SVG figures and CSS
//! inline, no external fetches, a print stylesheet) that an engineer hands
//! to a colleague, and the deviation card beside it (text, CSV, JSON).
//!
//! Sections, each saying so when its input is missing:
//! 1. the headline — true-heading RMS before/after on the validation run,
//!    the predicted heading error, coefficients verified, date, site, IGRF;
//! 2. the deviation card of the validation run (against truth), else of the
//!    run (against its GPS reference);
//! 3. the swing test's coverage: heading × roll and heading × pitch maps
//!    with the gaps marked (paper 000 Fig 6);
//! 4. the field magnitude along the run for each calibration (Figs 7–12);
//! 5. heading against the reference at the surface (Fig 13) and against the
//!    truth in validation; then the integrity along the validation run
//!    (`magcal apply` with the final calibration: the heading error by
//!    state over the predicted ±1σ, rows per state, the σ's honesty);
//! 6. the back-stepping trace;
//! 7. residual distributions (|F| − IGRF, heading errors);
//! 8. the coefficients.
//!
//! Figures are drawn by [`plot`] (plotters' SVG backend).
//!
//! Layout: [`sections`] writes each section, `page` holds the page and its
//! stylesheet, [`inputs`] what goes in and comes out, [`error`] why it
//! failed.

pub(crate) mod error;
pub(crate) mod inputs;
mod page;
pub(crate) mod plot;
pub(crate) mod sections;

use std::path::Path;

pub use error::ReportError;
pub use inputs::{CardFiles, ReportInputs, Validation, WrittenReport};
pub use plot::{line_plot, Series};
pub use sections::{date_of_decimal_year, write_card};

use error::io;
use page::Page;
use sections::Context;

/// The page's file name in the report's folder.
pub const INDEX: &str = "index.html";
/// The deviation card's files in the report's folder: text, CSV, JSON.
pub const CARD_FILES: [&str; 3] = ["deviation_card.txt", "deviation_card.csv", "deviation_card.json"];

/// Checks the report's folder before any work: made when missing, and
/// each file a report may write there ([`INDEX`], [`CARD_FILES`]) checked
/// by [`crate::files::check_output`] against every input (the recordings
/// and documents the report reads): an input under one of these names —
/// the same file on disk, through any link — is refused, never overwritten.
pub fn check_outputs(dir: &Path, inputs: &[&Path]) -> Result<(), ReportError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    for name in std::iter::once(INDEX).chain(CARD_FILES) {
        crate::files::check_output(&dir.join(name), inputs)?;
    }
    Ok(())
}

/// Writes `index.html` (self-contained) into `dir` and, when the inputs
/// allow, the deviation card as `deviation_card.txt`, `.csv` and `.json`
/// (check them against the inputs first: [`check_outputs`]).
pub fn write_report(dir: &Path, inputs: &ReportInputs<'_>) -> Result<WrittenReport, ReportError> {
    std::fs::create_dir_all(dir).map_err(io(dir))?;
    let cx = Context::new(inputs)?;
    let mut page = Page::new();
    sections::headline(&mut page, &cx);
    let card = sections::card(&mut page, &cx, dir)?;
    sections::coverage(&mut page, &cx)?;
    let field_errors = sections::field(&mut page, &cx)?;
    let heading_errors = sections::heading(&mut page, &cx)?;
    sections::integrity(&mut page, &cx)?;
    sections::backstep(&mut page, &cx)?;
    sections::residuals(&mut page, &cx, &field_errors, &heading_errors)?;
    sections::coefficients(&mut page, &cx);
    let title = match &inputs.site {
        Some(s) => format!("Magnetometer calibration report — {}", date_of_decimal_year(s.decimal_year)),
        None => "Magnetometer calibration report".into(),
    };
    let index = dir.join(INDEX);
    crate::files::write_text_atomic(&index, &page.html(&title))?;
    Ok(WrittenReport { index, card, figures: page.figures, missing: page.missing })
}

#[cfg(test)]
mod tests;
