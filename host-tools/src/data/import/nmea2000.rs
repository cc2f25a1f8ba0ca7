//! NMEA 2000 in canboat's text formats: not read yet (this module is being written).

use super::{ImportOptions, Imported};

/// Why a NMEA 2000 in canboat's text formats could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum Nmea2000Error {
    /// This format is not read yet.
    #[error("the NMEA 2000 in canboat's text formats is not read yet")]
    NotRead,
}

/// Whether a log's first bytes look like a NMEA 2000 in canboat's text formats.
pub fn looks_like(_head: &[u8]) -> bool {
    false
}

/// Imports a NMEA 2000 in canboat's text formats held in memory.
pub fn import(_bytes: &[u8], _opts: &ImportOptions) -> Result<Imported, super::ImportError> {
    Err(Nmea2000Error::NotRead.into())
}
