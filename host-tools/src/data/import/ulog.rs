//! PX4 ULog: not read yet (this module is being written).

use super::{ImportOptions, Imported};

/// Why a PX4 ULog could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum UlogError {
    /// This format is not read yet.
    #[error("the PX4 ULog is not read yet")]
    NotRead,
}

/// Whether a log's first bytes look like a PX4 ULog.
pub fn looks_like(_head: &[u8]) -> bool {
    false
}

/// Imports a PX4 ULog held in memory.
pub fn import(_bytes: &[u8], _opts: &ImportOptions) -> Result<Imported, super::ImportError> {
    Err(UlogError::NotRead.into())
}
