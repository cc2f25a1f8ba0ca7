//! Why a report could not be written.

use std::path::{Path, PathBuf};

use super::plot::PlotError;
use crate::compute::card::CardError;

/// Why a report could not be written.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// The validation truth has another number of rows than its recording.
    #[error("the validation truth has {truth_rows} rows, the recording {recording_rows}")]
    TruthLength {
        /// Rows of the truth.
        truth_rows: usize,
        /// Rows of the recording.
        recording_rows: usize,
    },
    /// The deviation card could not be put in JSON.
    #[error("deviation card: {0}")]
    Json(#[from] serde_json::Error),
    /// A figure could not be drawn.
    #[error("{0}")]
    Plot(#[from] PlotError),
    /// The deviation card could not be written.
    #[error("deviation card: {0}")]
    Card(#[from] CardError),
}

/// The [`ReportError::Io`] of writing `path`.
pub(crate) fn io(path: &Path) -> impl FnOnce(std::io::Error) -> ReportError + '_ {
    move |source| ReportError::Io { path: path.into(), source }
}
