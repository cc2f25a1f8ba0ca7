//! MAVLink telemetry log: not read yet (this module is being written).

use super::{ImportOptions, Imported};

/// Why a MAVLink telemetry log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum TlogError {
    /// This format is not read yet.
    #[error("the MAVLink telemetry log is not read yet")]
    NotRead,
}

/// Whether a log's first bytes look like a MAVLink telemetry log.
pub fn looks_like(_head: &[u8]) -> bool {
    false
}

/// Imports a MAVLink telemetry log held in memory.
pub fn import(_bytes: &[u8], _opts: &ImportOptions) -> Result<Imported, super::ImportError> {
    Err(TlogError::NotRead.into())
}
