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
//! [`ResponseBody::Error`] and a [`LinkError`].
#![no_std]
#![forbid(unsafe_code)]
#![deny(missing_docs)]
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use serde::{Deserialize, Serialize};

/// Version of this wire format. A frame carrying another version is refused
/// with [`LinkError::UnsupportedVersion`].
pub const PROTOCOL_VERSION: u8 = 2;

/// Longest decoded frame (version byte, postcard payload and CRC).
pub const MAX_DECODED_LEN: usize = 250;

/// Longest frame on the wire: COBS adds one byte per 254 plus one, and the
/// trailing zero delimiter.
pub const MAX_FRAME_LEN: usize = MAX_DECODED_LEN + MAX_DECODED_LEN / 254 + 2;

/// Bytes of CRC at the end of a decoded frame.
const CRC_LEN: usize = 4;

/// Longest postcard payload that fits in one frame.
pub const MAX_PAYLOAD_LEN: usize = MAX_DECODED_LEN - 1 - CRC_LEN;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Capacity of the short text fields (names, version strings).
pub const NAME_LEN: usize = 24;

/// A short, bounded text field.
pub type Name = heapless::String<NAME_LEN>;

/// A request from the host. `seq` is echoed in the response so the host can
/// match replies to requests and drop stale ones.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Request {
    /// Host-chosen sequence number, echoed in the [`Response`].
    pub seq: u16,
    /// What is asked.
    pub body: RequestBody,
}

/// What the host can ask. Every request gets exactly one [`Response`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RequestBody {
    /// Liveness check; the board echoes `nonce` in [`ResponseBody::Pong`].
    Ping {
        /// Arbitrary value echoed back.
        nonce: u32,
    },
    /// Ask for the firmware's [`Identity`].
    Identify,
    /// Ask for [`Health`].
    Status,
    /// Choose what is streamed (as unsolicited [`ResponseBody::Sample`] frames).
    SetStream(StreamMode),
    /// Output rate, 1–100 Hz.
    SetOutputRate {
        /// Samples per second.
        hz: u8,
    },
    /// Attitude from the vehicle's AHRS, for the heading. Stale after
    /// [`ATTITUDE_TIMEOUT_MS`].
    Attitude {
        /// Roll, radians.
        roll_rad: f32,
        /// Pitch, radians.
        pitch_rad: f32,
    },
    /// Start the on-board recursive fit (restarts one in progress).
    FitStart {
        /// Which model.
        model: FitModel,
        /// Reference field intensity, nT.
        field_nt: f32,
    },
    /// Stop the on-board fit (its last state stays readable).
    FitStop,
    /// Ask for the fit's [`FitReport`].
    FitQuery,
    /// Ask for the coefficients in use.
    ReadCoefficients,
    /// Unlock coefficient writes: `key` must be the [`Health::unlock_challenge`]
    /// of this boot XOR [`UNLOCK_XOR`]. Refused in mission mode. Expires after
    /// [`UNLOCK_TIMEOUT_MS`].
    Unlock {
        /// The response to the challenge.
        key: u32,
    },
    /// Stage coefficients (validated, not yet used or stored). Needs unlock.
    WriteCoefficients(Coefficients),
    /// Store the staged coefficients in flash and use them. `crc` must be
    /// [`Coefficients::crc`] of what was staged. Needs unlock.
    Commit {
        /// CRC-32 of the staged coefficients.
        crc: u32,
    },
    /// Enter or leave mission mode (locks coefficient writes).
    SetMissionMode {
        /// Mission mode on.
        enabled: bool,
    },
}

/// An attitude older than this is not used for the heading, ms.
pub const ATTITUDE_TIMEOUT_MS: u32 = 500;
/// An unlock lasts this long, ms.
pub const UNLOCK_TIMEOUT_MS: u32 = 60_000;
/// XORed with the challenge to unlock (a deliberate act, not a secret).
pub const UNLOCK_XOR: u32 = 0x4D41_4743; // "MAGC"

/// What the board streams.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StreamMode {
    /// Nothing.
    Off,
    /// Raw counts only.
    Raw,
    /// Calibrated field and heading only.
    Calibrated,
    /// Both.
    Both,
}

/// On-board fit models.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FitModel {
    /// Bias and one scale.
    Sphere,
    /// Bias and three axis scales (paper 000).
    Axis,
    /// Bias and a symmetric matrix.
    Full,
}

/// The coefficients the board applies: `h = matrix·(raw − bias)`, heading
/// swing correction `[A, B, C, D, E]` (radians), declination.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Coefficients {
    /// Hard-iron bias, ADC counts.
    pub bias: [f32; 3],
    /// Counts → nT.
    pub matrix: [[f32; 3]; 3],
    /// Swing terms A…E, radians.
    pub swing: [f32; 5],
    /// Declination, radians, east positive.
    pub declination_rad: f32,
    /// Reference intensity of the calibration, nT.
    pub field_nt: f32,
}

impl Coefficients {
    /// CRC-32 of the postcard encoding: what `Commit` must quote.
    pub fn crc(&self) -> u32 {
        let mut buf = [0u8; 128];
        match postcard::to_slice(self, &mut buf) {
            Ok(b) => CRC32.checksum(b),
            Err(_) => 0,
        }
    }
}

/// Where the coefficients in use came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CoefficientSource {
    /// Loaded from flash (valid CRC and bounds).
    Stored,
    /// Nothing valid stored: the nominal chain gain, no bias.
    Default,
}

/// One output sample (streamed).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Sample {
    /// Milliseconds since boot.
    pub t_ms: u32,
    /// Raw field, counts (when streaming raw).
    pub raw: Option<[f32; 3]>,
    /// Calibrated field, nT (when streaming calibrated).
    pub field_nt: Option<[f32; 3]>,
    /// True heading, radians in [0, 2π), when a fresh attitude is known.
    pub heading_rad: Option<f32>,
    /// A channel was saturated during this sample.
    pub saturated: bool,
    /// QEMU board: the sensor-feed frame every pair of this sample saw
    /// (`None` on the board, or when the feed changed within the sample).
    pub feed_seq: Option<u32>,
}

/// Counters and state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Milliseconds since boot.
    pub uptime_ms: u32,
    /// Set/reset pairs acquired.
    pub pairs: u32,
    /// Output samples produced.
    pub samples: u32,
    /// Pairs with a saturated channel.
    pub saturated: u32,
    /// Failed acquisitions.
    pub acq_errors: u32,
    /// Acquisition deadlines missed.
    pub overruns: u32,
    /// Received bytes dropped (queue full or UART error).
    pub rx_dropped: u32,
    /// Outgoing frames dropped (queue full).
    pub tx_dropped: u32,
    /// Damaged frames received.
    pub bad_frames: u32,
    /// Requests served.
    pub requests: u32,
    /// Mission mode on.
    pub mission_mode: bool,
    /// Coefficient writes unlocked.
    pub unlocked: bool,
    /// This boot's unlock challenge.
    pub unlock_challenge: u32,
    /// Where the coefficients came from.
    pub coefficient_source: CoefficientSource,
    /// Sequence number of the stored record in use (0 for defaults).
    pub coefficient_seq: u32,
    /// The last refusal or failure.
    pub last_error: Option<LinkError>,
    /// Output rate, Hz.
    pub output_rate_hz: u8,
    /// What is streamed.
    pub stream: StreamMode,
    /// Sensor-feed updates received (QEMU board).
    pub feed_updates: u32,
}

/// The on-board fit's state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FitReport {
    /// Absorbing samples now.
    pub running: bool,
    /// Model (None before the first start).
    pub model: Option<FitModel>,
    /// Samples absorbed.
    pub samples: u32,
    /// Percent of field-direction bins visited.
    pub coverage_pct: u8,
    /// RMS of |h| − F with the current estimate over recent samples, nT.
    pub residual_rms_nt: f32,
    /// The current estimate, when it exists and passes the physical checks.
    pub estimate: Option<Coefficients>,
}

/// A reply from the board.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Response {
    /// The request's `seq`, or `None` when the request could not be decoded
    /// far enough to know it.
    pub seq: Option<u16>,
    /// The answer.
    pub body: ResponseBody,
}

/// What the board answers.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ResponseBody {
    /// Answer to [`RequestBody::Ping`].
    Pong {
        /// The request's nonce.
        nonce: u32,
    },
    /// Answer to [`RequestBody::Identify`].
    Identity(Identity),
    /// The request was refused or could not be read.
    Error(LinkError),
    /// Done.
    Ack,
    /// Answer to [`RequestBody::Status`].
    Status(Health),
    /// Answer to the fit requests.
    Fit(FitReport),
    /// Answer to [`RequestBody::ReadCoefficients`].
    Coefficients {
        /// In use.
        coefficients: Coefficients,
        /// Where they came from.
        source: CoefficientSource,
        /// Stored record's sequence (0 for defaults).
        seq: u32,
    },
    /// Answer to [`RequestBody::Commit`]: stored and in use.
    Committed {
        /// The new record's sequence number.
        seq: u32,
    },
    /// A streamed sample (sent with `seq: None`).
    Sample(Sample),
}

/// Who is on the other end of the link.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity {
    /// Firmware name.
    pub name: Name,
    /// Firmware version (semver of the `firmware` crate).
    pub firmware_version: Name,
    /// The wire format the firmware speaks ([`PROTOCOL_VERSION`] of its build).
    pub protocol_version: u8,
    /// Where it runs.
    pub platform: Platform,
    /// Milliseconds since boot.
    pub uptime_ms: u32,
}

/// The hardware the firmware found itself on at boot.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Platform {
    /// The STM32F405 board (RCC reports the internal oscillator running).
    Silicon,
    /// QEMU's `netduinoplus2` machine (RCC is not modelled).
    Qemu,
}

/// Why a request was not served. Sent back in [`ResponseBody::Error`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkError {
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
    /// More than [`MAX_FRAME_LEN`] bytes arrived before a delimiter; they were
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

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            LinkError::Frame(e) => write!(f, "bad frame: {e}"),
            LinkError::Unsupported => f.write_str("request not supported by this firmware"),
            LinkError::BadArgument => f.write_str("argument out of range"),
            LinkError::Locked => f.write_str("coefficient writes are locked (unlock first)"),
            LinkError::MissionMode => f.write_str("refused in mission mode"),
            LinkError::BadKey => f.write_str("wrong unlock key"),
            LinkError::InvalidCoefficients => f.write_str("coefficients fail the physical checks"),
            LinkError::NothingStaged => f.write_str("no coefficients staged"),
            LinkError::CommitMismatch => f.write_str("commit CRC does not match the staged coefficients"),
            LinkError::Storage => f.write_str("flash write failed; previous coefficients kept"),
            LinkError::NoEstimate => f.write_str("the fit has no estimate yet"),
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

/// Messages on the QEMU board's sensor feed (USART2): the host plays the
/// magnetometer bridges.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SensorFeed {
    /// Feed sequence number.
    pub seq: u32,
    /// The field at each bridge, nT (the hull's distortion included); the
    /// board converts it with its own chain gain.
    pub field_nt: [f32; 3],
    /// Bridge offsets, counts (`None`: unchanged — keeps the frame short).
    pub offset_counts: Option<[f32; 3]>,
}

#[cfg(test)]
mod tests;
