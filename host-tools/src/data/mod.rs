//! Data on disk: recordings (CSV), the calibration document (JSON) and the
//! typed results inside documents and session summaries.

pub mod blocks;
pub mod caldoc;
pub mod dataflash;
pub mod recording;
pub mod results;

pub use caldoc::{CalDoc, CalDocError};
pub use recording::{Recording, RecordingError};
