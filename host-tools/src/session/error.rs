//! Why a session stopped: one typed error for the session module.

use std::path::PathBuf;

use crate::board::ClientError;
use crate::compute::ComputeError;
use crate::doc::caldoc::CalDocError;
use crate::data::recording::RecordingError;
use crate::report::ReportError;

/// Why a session stopped.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    /// The output could not be written ([`crate::files`]).
    #[error(transparent)]
    Output(#[from] crate::files::OutputError),
    /// The link failed.
    #[error("link: {0}")]
    Link(#[from] ClientError),
    /// A computation refused the data.
    #[error("{0}")]
    Compute(#[from] ComputeError),
    /// The board stopped answering a step.
    #[error("no sample from the board for step {step} within {timeout_ms} ms")]
    NoSample {
        /// Step index.
        step: usize,
        /// Timeout.
        timeout_ms: u64,
    },
    /// The swing test did not cover enough attitudes: what the operator
    /// must still do, one instruction each.
    #[error("swing test incomplete: {}", .0.join("; "))]
    Coverage(Vec<String>),
    /// A file or directory of the session could not be written.
    #[error("{}: {source}", path.display())]
    File {
        /// The file or directory.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// A calibration document could not be saved.
    #[error("{0}")]
    Doc(#[from] CalDocError),
    /// A recording could not be saved.
    #[error("{0}")]
    Recording(#[from] RecordingError),
    /// The report could not be written.
    #[error("{0}")]
    Report(#[from] ReportError),
    /// A JSON file could not be made.
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// The vehicle cannot perform a phase's manoeuvre (its label).
    #[error("the vehicle has no {0} manoeuvre")]
    NoManoeuvre(&'static str),
    /// A step of the chain left no quality report (the step's name).
    #[error("the {0} left no report")]
    NoReport(&'static str),
    /// A navigation stream is malformed or was already used.
    #[error(transparent)]
    NavStream(#[from] NavStreamError),
    /// The coefficients could not be verified on the board.
    #[error("coefficients not verified after {0} attempts")]
    NotVerified(u32),
}

/// Why a navigation stream cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum NavStreamError {
    /// The stream ended before its header.
    #[error("navigation stream: empty (expected a header)")]
    Empty,
    /// Reading the header failed.
    #[error("navigation stream: {0}")]
    Read(#[source] std::io::Error),
    /// The header lacks a required column.
    #[error("navigation stream: {0}")]
    Header(#[from] crate::data::table::StreamHeaderError),
    /// The phase's stream was used by an earlier phase.
    #[error("the {0} navigation stream was already used")]
    AlreadyUsed(&'static str),
}
