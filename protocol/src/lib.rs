//! Wire types and framing shared by the magcal firmware and the host tools.
//!
//! Both sides compile this one crate, so a message cannot mean one thing on
//! the board and another on the host.
//!
//! # Frame format (protocol version [`PROTOCOL_VERSION`])
//!
//! ```text
//! COBS( version:u8 ‖ postcard(message) ‖ crc32(version ‖ postcard(message)):u32 LE ) ‖ 0x00
//! ```
//!
//! * postcard gives a compact, self-delimiting, `no_std` encoding of the serde
//!   types below;
//! * the CRC-32 (ISO-HDLC, the Ethernet/zip polynomial) covers the version byte
//!   and the payload, so a flipped bit on the link is detected before the
//!   payload is interpreted;
//! * COBS removes every zero byte, so `0x00` marks the end of a frame and a
//!   receiver resynchronises at the next zero after any garbage.
//!
//! Every frame fits in [`MAX_FRAME_LEN`] bytes on the wire. The receiver
//! ([`FrameDecoder`]) never allocates, never panics, and turns every kind of
//! damage into a typed [`FrameError`]; the firmware answers such a frame with
//! [`ResponseBody::Error`] and a [`DeviceError`].
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

//!
//! # Layout
//!
//! As postcard-rpc keeps its ICD apart from its wire code:
//! * [`endpoint`]: the requests, each paired with the one kind of answer
//!   it gets, in one table both sides dispatch through (postcard-rpc's
//!   `endpoints!` is the model);
//! * [`icd`]: the messages both sides compile (responses, samples,
//!   health, coefficients, the sensor feed) — what is said;
//! * [`frame`]: how it travels — versioned, CRC-checked, COBS-delimited
//!   frames, encoder and incremental decoder;
//! * [`error`]: damage on the link and the device's refusals (wire types;
//!   the ICD carries them);
//! * [`crc`]: the CRC-32 of the frames and of the coefficient commit.
//!
//! Imports go one way: `endpoint` → `icd`, `error`; `icd` → `error`, `crc`; `frame` → `error`, `crc`;
//! the ICD knows nothing of framing.
//!
//! Everything is re-exported here, so `magcal_protocol::Request` etc. work.

pub mod crc;
pub mod endpoint;
pub mod error;
pub mod frame;
pub mod icd;

pub use endpoint::{Call, Endpoint, EndpointInfo, Reply, Request, RequestBody, ENDPOINTS};
pub use error::{DeviceError, FrameError};
pub use frame::{decode, decode_body, encode, FrameDecoder, MAX_DECODED_LEN, MAX_FRAME_LEN, MAX_PAYLOAD_LEN, PROTOCOL_VERSION};
pub use icd::*;

#[cfg(test)]
mod tests;
