//! Errors: damage found on the link ([`FrameError`]) and why the device
//! refused a request ([`DeviceError`], sent back in
//! [`crate::ResponseBody::Error`]). A leaf: both are wire types the ICD
//! carries, and neither needs the framing code (`FrameError`'s message,
//! which quotes the frame limits, is written in [`crate::frame`]).

use serde::{Deserialize, Serialize};

/// Why a request was not served. Sent back in [`crate::ResponseBody::Error`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DeviceError {
    /// The frame was damaged on the link (see [`FrameError`]).
    Frame(FrameError),
    /// The request is well formed but this firmware does not serve it.
    Unsupported,
    /// An argument is out of range (rate, field intensity, attitude).
    BadArgument,
    /// Coefficient writes need an unlock first.
    Locked,
    /// Refused in mission mode.
    MissionMode,
    /// The unlock key is wrong.
    BadKey,
    /// The coefficients fail the physical checks.
    InvalidCoefficients,
    /// Commit without staged coefficients.
    NothingStaged,
    /// The commit's CRC does not match what was staged.
    CommitMismatch,
    /// Writing flash failed; the previous coefficients are still in use.
    Storage,
    /// The fit has no estimate yet (too few samples, or not determined).
    NoEstimate,
}

/// Damage found while reading a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// More than [`crate::MAX_FRAME_LEN`] bytes arrived before a delimiter; they were
    /// discarded up to the next delimiter.
    TooLong,
    /// The bytes between two delimiters are not valid COBS.
    Cobs,
    /// Too short to hold a version byte and a CRC.
    TooShort,
    /// The CRC does not match: the frame was corrupted.
    Crc,
    /// The frame is intact but speaks another protocol version.
    UnsupportedVersion {
        /// The version byte found in the frame.
        got: u8,
    },
    /// The CRC matched but the payload is not a valid message of this version.
    Payload,
    /// The message does not fit in one frame (encoder side).
    Overflow,
}

impl core::fmt::Display for DeviceError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            DeviceError::Frame(e) => write!(f, "bad frame: {e}"),
            DeviceError::Unsupported => f.write_str("request not supported by this firmware"),
            DeviceError::BadArgument => f.write_str("argument out of range"),
            DeviceError::Locked => f.write_str("coefficient writes are locked (unlock first)"),
            DeviceError::MissionMode => f.write_str("refused in mission mode"),
            DeviceError::BadKey => f.write_str("wrong unlock key"),
            DeviceError::InvalidCoefficients => f.write_str("coefficients fail the physical checks"),
            DeviceError::NothingStaged => f.write_str("no coefficients staged"),
            DeviceError::CommitMismatch => f.write_str("commit CRC does not match the staged coefficients"),
            DeviceError::Storage => f.write_str("flash write failed; previous coefficients kept"),
            DeviceError::NoEstimate => f.write_str("the fit has no estimate yet"),
        }
    }
}

