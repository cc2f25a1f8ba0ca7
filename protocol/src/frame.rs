//! Framing: `COBS(version ‖ postcard(message) ‖ CRC-32)` ending in `0x00`.
//! The encoder, the one-shot decoder and the incremental [`FrameDecoder`];
//! none of them allocates or panics.

use serde::{Deserialize, Serialize};

use crate::crc::CRC32;
use crate::error::FrameError;

/// Version of this wire format. A frame carrying another version is refused
/// with [`FrameError::UnsupportedVersion`]. Version 3 appended the current
/// and temperature terms to `Coefficients`, `temp_c` to `Sample` and
/// `SensorFeed`, the environment counters to `Health`, and the
/// `AttitudeEnv` request (postcard has no field tags, so a version-2 peer
/// would misread these). Version 4 appended the heading's σ and integrity
/// to `Sample`, the integrity counters and the on-line hard iron to
/// `Health`, and the `Nmea` stream mode. Version 5 appended the reference
/// inclination to `Coefficients`. Version 6 gathered `Health`'s counters
/// into [`crate::BoardCounters`] and [`crate::DeviceCounters`] (declared once,
/// counted into by the firmware), which reorders `Health`'s fields.
pub const PROTOCOL_VERSION: u8 = 6;

/// Longest decoded frame (version byte, postcard payload and CRC).
pub const MAX_DECODED_LEN: usize = 250;

/// Longest frame on the wire: COBS adds one byte per 254 plus one, and the
/// trailing zero delimiter.
pub const MAX_FRAME_LEN: usize = MAX_DECODED_LEN + MAX_DECODED_LEN / 254 + 2;

/// Bytes of CRC at the end of a decoded frame.
const CRC_LEN: usize = 4;

/// Longest postcard payload that fits in one frame.
pub const MAX_PAYLOAD_LEN: usize = MAX_DECODED_LEN - 1 - CRC_LEN;


// The message of a [`FrameError`] quotes this module's limits, so it is
// written here, next to them (`error` stays a leaf that knows no framing).
impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            FrameError::TooLong => write!(f, "frame longer than {MAX_FRAME_LEN} bytes"),
            FrameError::Cobs => f.write_str("invalid COBS encoding"),
            FrameError::TooShort => f.write_str("frame too short for version and CRC"),
            FrameError::Crc => f.write_str("CRC mismatch"),
            FrameError::UnsupportedVersion { got } => write!(
                f,
                "protocol version {got} is not supported (this side speaks {PROTOCOL_VERSION})"
            ),
            FrameError::Payload => f.write_str("payload is not a valid message"),
            FrameError::Overflow => f.write_str("message does not fit in one frame"),
        }
    }
}

/// Encodes `message` as one complete frame (including the trailing zero) into
/// `out`, returning the number of bytes written.
///
/// # Errors
/// [`FrameError::Overflow`] when the message or its frame does not fit.
pub fn encode<T: Serialize>(message: &T, out: &mut [u8]) -> Result<usize, FrameError> {
    let mut raw = [0u8; MAX_DECODED_LEN];
    let (version, rest) = raw.split_first_mut().ok_or(FrameError::Overflow)?;
    *version = PROTOCOL_VERSION;
    let payload_len = postcard::to_slice(message, rest)
        .map_err(|_| FrameError::Overflow)?
        .len();
    let body_len = 1 + payload_len;
    let total = body_len + CRC_LEN;
    let body = raw.get(..body_len).ok_or(FrameError::Overflow)?;
    let crc = CRC32.checksum(body).to_le_bytes();
    raw.get_mut(body_len..total)
        .ok_or(FrameError::Overflow)?
        .copy_from_slice(&crc);
    let decoded = raw.get(..total).ok_or(FrameError::Overflow)?;
    let n = cobs::try_encode(decoded, out).map_err(|_| FrameError::Overflow)?;
    let delimiter = out.get_mut(n).ok_or(FrameError::Overflow)?;
    *delimiter = 0;
    Ok(n + 1)
}

/// Checks the version and CRC of a COBS-decoded frame and deserialises its
/// payload.
///
/// # Errors
/// [`FrameError::TooShort`], [`FrameError::Crc`],
/// [`FrameError::UnsupportedVersion`] or [`FrameError::Payload`].
pub fn decode_body<'de, T: Deserialize<'de>>(decoded: &'de [u8]) -> Result<T, FrameError> {
    if decoded.len() < 1 + CRC_LEN {
        return Err(FrameError::TooShort);
    }
    let (body, crc) = decoded.split_at(decoded.len() - CRC_LEN);
    let mut crc_bytes = [0u8; CRC_LEN];
    crc_bytes.copy_from_slice(crc);
    if CRC32.checksum(body) != u32::from_le_bytes(crc_bytes) {
        return Err(FrameError::Crc);
    }
    let (&version, payload) = body.split_first().ok_or(FrameError::TooShort)?;
    if version != PROTOCOL_VERSION {
        return Err(FrameError::UnsupportedVersion { got: version });
    }
    let (message, rest) = postcard::take_from_bytes(payload).map_err(|_| FrameError::Payload)?;
    if !rest.is_empty() {
        // Trailing bytes under a valid CRC: a sender bug, not link noise.
        return Err(FrameError::Payload);
    }
    Ok(message)
}

/// Decodes one complete frame (with or without its trailing zero) in one go.
///
/// # Errors
/// Any [`FrameError`].
pub fn decode<T: for<'de> Deserialize<'de>>(frame: &[u8]) -> Result<T, FrameError> {
    let frame = frame.strip_suffix(&[0]).unwrap_or(frame);
    let mut decoder = FrameDecoder::new();
    let mut result = Err(FrameError::TooShort);
    for &b in frame.iter().chain(core::iter::once(&0u8)) {
        if let Some(r) = decoder.push(b) {
            result = r.and_then(decode_body);
        }
    }
    result
}

/// Incremental receiver: feed it bytes as they arrive, one at a time.
///
/// Holds at most [`MAX_FRAME_LEN`] bytes; never allocates or panics.
#[derive(Debug)]
pub struct FrameDecoder {
    buf: [u8; MAX_FRAME_LEN],
    len: usize,
    overflowed: bool,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// An empty receiver.
    pub const fn new() -> Self {
        Self { buf: [0; MAX_FRAME_LEN], len: 0, overflowed: false }
    }

    /// Feeds one byte. Returns `None` while a frame is incomplete, and at a
    /// delimiter either the COBS-decoded frame (to be checked by
    /// [`decode_body`]) or the damage found.
    ///
    /// Consecutive delimiters (an empty frame) are ignored, so a sender may
    /// prefix frames with a zero to resynchronise the receiver.
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], FrameError>> {
        if byte != 0 {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = byte;
                self.len += 1;
            } else {
                self.overflowed = true;
            }
            return None;
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.overflowed) {
            return Some(Err(FrameError::TooLong));
        }
        if len == 0 {
            return None;
        }
        let encoded = self.buf.get_mut(..len)?;
        Some(match cobs::decode_in_place(encoded) {
            Ok(n) => encoded.get(..n).ok_or(FrameError::Cobs),
            Err(_) => Err(FrameError::Cobs),
        })
    }

    /// Number of bytes of the frame in progress.
    pub fn pending(&self) -> usize {
        self.len
    }
}

