//! The interface both sides compile (the ICD): every message of the host
//! link and of the QEMU board's sensor feed, and the constants that give
//! them meaning. Nothing here knows how messages travel; see
//! [`crate::frame`].

use serde::{Deserialize, Serialize};

use crate::error::DeviceError;
use crate::crc::CRC32;
#[cfg(doc)]
use crate::endpoint::RequestBody;

/// Capacity of the short text fields (names, version strings).
pub const NAME_LEN: usize = 24;

/// A short, bounded text field.
pub type Name = heapless::String<NAME_LEN>;

/// The largest motor current a [`RequestBody::AttitudeEnv`] may carry, A.
pub const MAX_MOTOR_CURRENT_A: f32 = 1000.0;

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
    /// NMEA 0183 sentences instead of framed samples: per output sample
    /// `$HCHDG`, `$HCHDT` and `$PMAGI` (heading σ and integrity),
    /// `docs/INTERFACES.md` "NMEA 0183 output". The link still takes framed
    /// requests (and answers them framed) in this mode: `SetStream` with
    /// another mode goes back. (Last: earlier variants keep their wire tags.)
    Nmea,
}

/// The integrity of a sample's heading: calib-core's
/// [`calib_core::integrity::IntegrityState`] itself, so the wire carries
/// every state there is. Its wire tag is the state's code
/// ([`IntegrityState::code`](calib_core::integrity::IntegrityState::code):
/// postcard writes a unit variant as its index, in
/// [`IntegrityState::ALL`](calib_core::integrity::IntegrityState::ALL)'s
/// order); its word in CSV, JSON and the `$PMAGI` sentence is
/// [`IntegrityState::name`](calib_core::integrity::IntegrityState::name).
pub use calib_core::integrity::IntegrityState as Integrity;

pub use calib_core::cal::ModelKind;

/// The models the board fits on its own, as the wire carries them: its own
/// type, so a model added on the host (triangular, attitude, …) never
/// changes the encoding. The discriminant is the byte on the wire — the
/// position each had in calib-core's [`ModelKind`], which the wire carried
/// before, so the bytes did not change (a gap at 3, once `triangular`,
/// which the board never fitted: fit `full` and factor it on the host).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub enum OnboardModel {
    /// Bias and one scale.
    Sphere = 0,
    /// Bias and three axis scales.
    Axis = 1,
    /// Bias and a symmetric matrix.
    Full = 2,
    /// The gyro-aided fit (needs [`RequestBody::Motion`]).
    Gyro = 4,
}

impl OnboardModel {
    /// Every on-board model.
    pub const ALL: [OnboardModel; 4] = [OnboardModel::Sphere, OnboardModel::Axis, OnboardModel::Full, OnboardModel::Gyro];

    /// From its wire byte (`None`: no model the board fits).
    pub fn from_wire(byte: u8) -> Option<Self> {
        Self::ALL.into_iter().find(|m| *m as u8 == byte)
    }

    /// The fit model it is.
    pub fn kind(self) -> ModelKind {
        match self {
            OnboardModel::Sphere => ModelKind::Sphere,
            OnboardModel::Axis => ModelKind::Axis,
            OnboardModel::Full => ModelKind::Full,
            OnboardModel::Gyro => ModelKind::Gyro,
        }
    }

    /// The on-board model of a fit model (`None`: the board does not fit it).
    pub fn of_kind(kind: ModelKind) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.kind() == kind)
    }
}

impl Serialize for OnboardModel {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        // One byte, as postcard wrote the variant index (a varint, one byte below 128).
        s.serialize_u8(*self as u8)
    }
}

impl<'de> Deserialize<'de> for OnboardModel {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let byte = u8::deserialize(d)?;
        Self::from_wire(byte).ok_or_else(|| <D::Error as serde::de::Error>::custom("not a model the board fits"))
    }
}

/// The coefficients the board applies: `h = matrix·(raw ⊘ (1 + gain_per_c ⊙
/// (temp_c − ref_c)) − bias − bias_per_a · motor_current_a)` (the
/// calibration document's formula, `docs/INTERFACES.md`), heading swing
/// correction `[A, B, C, D, E]` (radians), declination. Zero current and
/// temperature terms change nothing.
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
    /// Field the thrusters add per ampere of motor current, ADC counts per A
    /// (the document's `current.bias_per_a`).
    pub current_bias_per_a: [f32; 3],
    /// Temperature at which the field terms hold, °C (`temperature.ref_c`).
    pub temp_ref_c: f32,
    /// Relative gain change per °C, per axis (`temperature.gain_per_c`).
    pub temp_gain_per_c: [f32; 3],
    /// The inclination the integrity monitor judges the field's dip against,
    /// radians, positive down (the document's reference: the world model at
    /// the site or the calibration's own verified dip);
    /// [`Coefficients::NO_INCLINATION`]: none, the board learns it from the
    /// samples it judges (protocol 5).
    pub inclination_rad: f32,
}

impl Coefficients {
    /// The current and temperature terms as calib-core applies them.
    pub fn env_terms(&self) -> calib_core::cal::EnvTerms<f32> {
        calib_core::cal::EnvTerms { bias_per_a: self.current_bias_per_a, ref_c: self.temp_ref_c, gain_per_c: self.temp_gain_per_c }
    }

    /// "No reference inclination": beyond ±π/2, so no dip, and an exact
    /// value, so sets compare equal (a NaN would not) and read back alike.
    pub const NO_INCLINATION: f32 = 4.0;

    /// The reference inclination, radians (`None` for [`Self::NO_INCLINATION`]: learned).
    pub fn inclination(&self) -> Option<f32> {
        (self.inclination_rad != Self::NO_INCLINATION).then_some(self.inclination_rad)
    }

    /// Bytes of the postcard encoding of any set. postcard writes an `f32`
    /// as its 4 little-endian bytes and a fixed-size array as its elements,
    /// with no length (postcard wire format, "f32" and "array"), and every
    /// field here is an `f32` or an array of them: the encoding is the
    /// struct's size (27 × 4 = 108 bytes, no padding between `f32`s).
    /// The firmware's commit buffer and the store's record capacity are this
    /// constant; a test pins it against the encoding of the extreme sets.
    pub const MAX_ENCODED_LEN: usize = core::mem::size_of::<Self>();

    /// CRC-32 of the postcard encoding: what `Commit` must quote.
    pub fn crc(&self) -> u32 {
        let mut buf = [0u8; Self::MAX_ENCODED_LEN];
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
    /// Temperature at the magnetometer measured on the board, °C (`None`
    /// when the thermistor reads out of range: open or shorted; the sample
    /// was then corrected at the reference temperature).
    pub temp_c: Option<f32>,
    /// The heading's 1σ, degrees, as the calibration and the integrity
    /// checks see it (`None` when the board had no heading: no fresh
    /// attitude). Sent in every stream mode with [`Sample::integrity`], so a
    /// raw log records the board's judgement too.
    pub heading_sigma_deg: Option<f32>,
    /// The heading's integrity (in every stream mode): a heading that is
    /// not [`Integrity::Ok`] is still sent (for plots) but must not be used
    /// as a good heading.
    pub integrity: Integrity,
}

/// The counters the board's tasks keep (acquisition, link, UARTs, sensor
/// feed, coefficient store), declared once: the firmware counts into this
/// very type and [`Health`] carries it. All counts are since boot.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BoardCounters {
    /// Set/reset pairs acquired.
    pub pairs: u32,
    /// Pairs with a saturated channel.
    pub saturated: u32,
    /// Failed acquisitions (ADC errors).
    pub acq_errors: u32,
    /// Acquisition deadlines missed.
    pub overruns: u32,
    /// Received bytes dropped (queue full or UART error).
    pub rx_dropped: u32,
    /// Outgoing reply or sample frames dropped (transmit queue full).
    pub tx_dropped: u32,
    /// Damaged frames received.
    pub bad_frames: u32,
    /// Requests served.
    pub requests: u32,
    /// Sensor-feed updates received (QEMU board).
    pub feed_updates: u32,
    /// Longest gap between two acquired pairs since boot, ms (a flash erase
    /// stalls the CPU and shows here).
    pub max_acq_gap_ms: u32,
    /// Coefficient saves done.
    pub store_saves: u32,
    /// The longest save (its CPU stall), ms.
    pub max_store_ms: u32,
}

/// The counters the correction pipeline keeps, declared once: the firmware's
/// device counts into this type and [`Health`] carries it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DeviceCounters {
    /// Output samples produced.
    pub samples: u32,
    /// Samples whose heading was withheld because the motor current was
    /// stale or never sent (older than [`ATTITUDE_TIMEOUT_MS`]) while the
    /// stored current term is non-zero.
    pub current_stale: u32,
    /// Samples with no valid temperature (thermistor open or shorted):
    /// corrected at the reference temperature.
    pub temp_missing: u32,
}

/// Counters and state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Health {
    /// Milliseconds since boot.
    pub uptime_ms: u32,
    /// The board's tasks' counters.
    pub board: BoardCounters,
    /// The correction pipeline's counters.
    pub device: DeviceCounters,
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
    pub last_error: Option<DeviceError>,
    /// Output rate, Hz.
    pub output_rate_hz: u8,
    /// What is streamed.
    pub stream: StreamMode,
    /// The last valid temperature measured, °C.
    pub temp_c: Option<f32>,
    /// The last sample was corrected with a stale/missing current or a
    /// missing temperature.
    pub env_degraded: bool,
    /// Output samples judged in each [`Integrity`] state since boot (or
    /// since the coefficients in use were set), indexed by the state's wire
    /// tag ([`Integrity::index`], in [`Integrity::ALL`]'s order).
    pub integrity_samples: [u32; Integrity::COUNT],
    /// Longest run of samples not `ok` (disturbed or calibration invalid), ms.
    pub longest_disturbance_ms: u32,
    /// The on-line hard-iron estimate, nT in the body frame (`None` before
    /// it has one).
    pub hard_iron_nt: Option<[f32; 3]>,
    /// The estimate is applied to the samples now (under the guard: the
    /// stored calibration judged invalid and the estimate checked).
    pub hard_iron_applied: bool,
    /// Times the estimate was applied.
    pub hard_iron_applications: u32,
}

/// The on-board fit's state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FitReport {
    /// Absorbing samples now.
    pub running: bool,
    /// Model (None before the first start).
    pub model: Option<OnboardModel>,
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
    Error(DeviceError),
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
    /// The wire format the firmware speaks ([`crate::PROTOCOL_VERSION`] of its build).
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
    /// Temperature of the thermistor next to the sensor, °C: the model makes
    /// the thermistor divider's voltage on ADC channel 3 from it (`None`:
    /// unchanged; before any, 25 °C). NaN models an open thermistor.
    pub temp_c: Option<f32>,
}

