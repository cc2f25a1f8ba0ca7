//! The verified upload: unlock, stage, commit, read back — resumed across
//! reconnects, never written twice, never leaving unverified coefficients.

use std::io::{Read, Write};

use magcal_protocol::Coefficients;

use super::error::SessionError;
use crate::board::{BoardClient, ClientError};

/// Uploads and verifies, reconnecting and resuming when the link fails.
/// After a failure the board's coefficients are read back first: if the set
/// already landed (the reply was lost), it is verified, not written twice.
pub fn upload_verified<P: Read + Write>(
    mut connect: impl FnMut() -> Result<BoardClient<P>, ClientError>,
    c: &Coefficients,
    attempts: u32,
) -> Result<u32, SessionError> {
    for attempt in 1..=attempts {
        let mut link = match connect() {
            Ok(l) => l,
            Err(e) => {
                eprintln!("  upload attempt {attempt}: cannot connect ({e}); retrying");
                continue;
            }
        };
        if let Ok((back, magcal_protocol::CoefficientSource::Stored, seq)) = link.read_coefficients() {
            if back == *c {
                return Ok(seq);
            }
        }
        match link.upload_coefficients(c) {
            Ok(seq) => return Ok(seq),
            Err(ClientError::Remote(e)) => return Err(ClientError::Remote(e).into()),
            Err(e) => eprintln!("  upload attempt {attempt} failed ({e}); reconnecting"),
        }
    }
    Err(SessionError::NotVerified(attempts))
}

