//! ROS 2 bag in MCAP storage: not read yet (this module is being written).

use super::{ImportOptions, Imported};

/// Why a ROS 2 bag in MCAP storage could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    /// This format is not read yet.
    #[error("the ROS 2 bag in MCAP storage is not read yet")]
    NotRead,
}

/// Whether a log's first bytes look like a ROS 2 bag in MCAP storage.
pub fn looks_like(_head: &[u8]) -> bool {
    false
}

/// Imports a ROS 2 bag in MCAP storage held in memory.
pub fn import(_bytes: &[u8], _opts: &ImportOptions) -> Result<Imported, super::ImportError> {
    Err(McapError::NotRead.into())
}
