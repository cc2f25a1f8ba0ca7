//! The host link's endpoints: every request paired with the one kind of
//! answer it gets, in one table (as postcard-rpc's `endpoints!` keeps its
//! ICD), which both sides dispatch through.
//!
//! The table below generates, from one row per request:
//! * the wire enum [`RequestBody`] (its variants in the table's order, so a
//!   row's position is its wire tag, [`Endpoint::CODE`]);
//! * one request type per row ([`Ping`], [`Status`], …) implementing
//!   [`Endpoint`], whose [`Endpoint::Response`] is the one [`Reply`] kind
//!   the board answers it with (or [`ResponseBody::Error`]);
//! * [`Call`]: a received [`RequestBody`] as its row's request type. The
//!   board serves a request with an exhaustive `match` on [`Call`], each arm
//!   answering through its request's [`Endpoint::answer`], which takes only
//!   that endpoint's response; the host's `call::<E>()` gets back an
//!   `E::Response`;
//! * [`ENDPOINTS`]: the rows as data (name, code, response kind), for tests
//!   and documentation.
//!
//! Adding a request is one row (appended: earlier rows keep their wire
//! tags); the compiler then asks for its arm on the board.

use serde::{Deserialize, Serialize};

use crate::error::DeviceError;
use crate::icd::{CoefficientSource, Coefficients, FitReport, Health, Identity, OnboardModel, ResponseBody, StreamMode};
#[cfg(doc)]
use crate::icd::{Response, ATTITUDE_TIMEOUT_MS, UNLOCK_TIMEOUT_MS, UNLOCK_XOR};

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

/// One request/response pair of the host link: the request type itself,
/// its wire tag and the one kind of answer it gets.
pub trait Endpoint: Sized {
    /// What the board answers when it serves the request.
    type Response: Reply;
    /// The request's name (its [`RequestBody`] variant).
    const NAME: &'static str;
    /// The request's wire tag: its [`RequestBody`] variant's index, which
    /// postcard writes first.
    const CODE: u8;

    /// The request as it goes on the wire.
    fn into_body(self) -> RequestBody;

    /// The board's answer to this request: its response, or the refusal.
    fn answer(&self, result: Result<Self::Response, DeviceError>) -> ResponseBody {
        match result {
            Ok(r) => r.into_body(),
            Err(e) => ResponseBody::Error(e),
        }
    }
}

/// A kind of answer: a typed view of one [`ResponseBody`] variant.
pub trait Reply: Sized {
    /// The name of its [`ResponseBody`] variant.
    const KIND: &'static str;

    /// The answer as it goes on the wire.
    fn into_body(self) -> ResponseBody;

    /// The answer, when `body` is of this kind (else `body` back).
    ///
    /// # Errors
    /// `body` itself, when it is another kind (handed back whole, not an
    /// error type: hence its size).
    #[allow(clippy::result_large_err)]
    fn from_body(body: ResponseBody) -> Result<Self, ResponseBody>;
}

/// "Done" ([`ResponseBody::Ack`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Ack;

/// The echoed nonce ([`ResponseBody::Pong`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pong {
    /// The request's nonce.
    pub nonce: u32,
}

/// The coefficients in use ([`ResponseBody::Coefficients`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InUse {
    /// In use.
    pub coefficients: Coefficients,
    /// Where they came from.
    pub source: CoefficientSource,
    /// Stored record's sequence (0 for defaults).
    pub seq: u32,
}

/// Stored and in use ([`ResponseBody::Committed`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Committed {
    /// The new record's sequence number.
    pub seq: u32,
}

/// Implements [`Reply`] for the type a `ResponseBody` variant carries.
macro_rules! reply {
    ($ty:ty, $kind:ident, |$v:ident| $pat:pat => $make:expr, $body:expr) => {
        impl Reply for $ty {
            const KIND: &'static str = stringify!($kind);
            fn into_body(self) -> ResponseBody {
                let $v = self;
                $body
            }
            #[allow(clippy::result_large_err)]
            fn from_body(body: ResponseBody) -> Result<Self, ResponseBody> {
                match body {
                    $pat => Ok($make),
                    other => Err(other),
                }
            }
        }
    };
}

reply!(Ack, Ack, |_a| ResponseBody::Ack => Ack, ResponseBody::Ack);
reply!(Pong, Pong, |p| ResponseBody::Pong { nonce } => Pong { nonce }, ResponseBody::Pong { nonce: p.nonce });
reply!(Identity, Identity, |i| ResponseBody::Identity(i) => i, ResponseBody::Identity(i));
reply!(Health, Status, |h| ResponseBody::Status(h) => h, ResponseBody::Status(h));
reply!(FitReport, Fit, |r| ResponseBody::Fit(r) => r, ResponseBody::Fit(r));
reply!(InUse, Coefficients, |c| ResponseBody::Coefficients { coefficients, source, seq } => InUse { coefficients, source, seq },
    ResponseBody::Coefficients { coefficients: c.coefficients, source: c.source, seq: c.seq });
reply!(Committed, Committed, |c| ResponseBody::Committed { seq } => Committed { seq }, ResponseBody::Committed { seq: c.seq });

/// One row of the endpoint table, as data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EndpointInfo {
    /// The request's name.
    pub name: &'static str,
    /// Its wire tag.
    pub code: u8,
    /// The [`ResponseBody`] variant that answers it ([`Reply::KIND`]).
    pub response: &'static str,
}

/// The endpoint table: rows are read one by one (unit, tuple or struct
/// requests), each emitting its request type, then every table-wide item
/// is emitted from the accumulated rows.
macro_rules! endpoints {
    // A unit request: `Name => Response;`.
    (@rows [$($acc:tt)*] $(#[$m:meta])* $name:ident => $resp:ty; $($rest:tt)*) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name;
        endpoints!(@rows [$($acc)* { [$(#[$m])*] $name [] [] $resp }] $($rest)*);
    };
    // A request carrying one value: `Name(Type) => Response;`.
    (@rows [$($acc:tt)*] $(#[$m:meta])* $name:ident ($t:ty) => $resp:ty; $($rest:tt)*) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name(pub $t);
        endpoints!(@rows [$($acc)* { [$(#[$m])*] $name [($t)] [(v)] $resp }] $($rest)*);
    };
    // A request with named fields: `Name { field: Type, … } => Response;`.
    (@rows [$($acc:tt)*] $(#[$m:meta])* $name:ident { $($(#[$fm:meta])* $f:ident : $ft:ty),* $(,)? } => $resp:ty; $($rest:tt)*) => {
        $(#[$m])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name {
            $($(#[$fm])* pub $f: $ft,)*
        }
        endpoints!(@rows [$($acc)* { [$(#[$m])*] $name [{ $($(#[$fm])* $f: $ft),* }] [{ $($f),* }] $resp }] $($rest)*);
    };
    (@rows [$({ [$($m:tt)*] $name:ident [$($decl:tt)*] [$($pat:tt)*] $resp:ty })*]) => {
        /// What the host can ask: one variant per [`Endpoint`], in the
        /// table's order (a variant's index is its wire tag). Every request
        /// gets exactly one [`Response`], of its endpoint's
        /// [`Endpoint::Response`] kind or [`ResponseBody::Error`].
        #[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum RequestBody {
            $($($m)* $name $($decl)*,)*
        }

        /// The wire tags, in the table's order.
        #[repr(u8)]
        #[allow(dead_code)]
        enum Code {
            $($name,)*
        }

        $(
            impl Endpoint for $name {
                type Response = $resp;
                const NAME: &'static str = stringify!($name);
                const CODE: u8 = Code::$name as u8;
                fn into_body(self) -> RequestBody {
                    let $name $($pat)* = self;
                    RequestBody::$name $($pat)*
                }
            }
        )*

        /// A received request as its endpoint's request type: the board
        /// matches on it (exhaustively) and answers each arm through
        /// [`Endpoint::answer`].
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub enum Call {
            $(
                #[doc = concat!("[`", stringify!($name), "`].")]
                $name($name),
            )*
        }

        impl From<RequestBody> for Call {
            fn from(body: RequestBody) -> Self {
                match body {
                    $(RequestBody::$name $($pat)* => Call::$name($name $($pat)*),)*
                }
            }
        }

        impl Call {
            /// The request's wire tag ([`Endpoint::CODE`]).
            pub fn code(&self) -> u8 {
                match self {
                    $(Call::$name(_) => <$name as Endpoint>::CODE,)*
                }
            }
        }

        /// Every endpoint, in wire-tag order.
        pub const ENDPOINTS: &[EndpointInfo] = &[
            $(EndpointInfo { name: <$name as Endpoint>::NAME, code: <$name as Endpoint>::CODE, response: <$resp as Reply>::KIND },)*
        ];
    };
    ($($rows:tt)*) => {
        endpoints!(@rows [] $($rows)*);
    };
}

endpoints! {
    /// Liveness check; the board echoes `nonce` in [`ResponseBody::Pong`].
    Ping {
        /// Arbitrary value echoed back.
        nonce: u32,
    } => Pong;
    /// Ask for the firmware's [`Identity`].
    Identify => Identity;
    /// Ask for [`Health`].
    Status => Health;
    /// Choose what is streamed (as unsolicited [`ResponseBody::Sample`] frames).
    SetStream(StreamMode) => Ack;
    /// Output rate, 1–100 Hz.
    SetOutputRate {
        /// Samples per second.
        hz: u8,
    } => Ack;
    /// Attitude from the vehicle's AHRS, for the heading. Stale after
    /// [`ATTITUDE_TIMEOUT_MS`].
    Attitude {
        /// Roll, radians.
        roll_rad: f32,
        /// Pitch, radians.
        pitch_rad: f32,
    } => Ack;
    /// Start the on-board recursive fit (restarts one in progress).
    FitStart {
        /// Which model.
        model: OnboardModel,
        /// Reference field intensity, nT.
        field_nt: f32,
    } => FitReport;
    /// Stop the on-board fit (its last state stays readable).
    FitStop => FitReport;
    /// Ask for the fit's [`FitReport`].
    FitQuery => FitReport;
    /// Ask for the coefficients in use.
    ReadCoefficients => InUse;
    /// Unlock coefficient writes: `key` must be the [`Health::unlock_challenge`]
    /// of this boot XOR [`UNLOCK_XOR`]. Refused in mission mode. Expires after
    /// [`UNLOCK_TIMEOUT_MS`].
    Unlock {
        /// The response to the challenge.
        key: u32,
    } => Ack;
    /// Stage coefficients (validated, not yet used or stored). Needs unlock.
    WriteCoefficients(Coefficients) => Ack;
    /// Store the staged coefficients in flash and use them. `crc` must be
    /// [`Coefficients::crc`] of what was staged. Needs unlock.
    Commit {
        /// CRC-32 of the staged coefficients.
        crc: u32,
    } => Committed;
    /// Enter or leave mission mode (locks coefficient writes).
    SetMissionMode {
        /// Mission mode on.
        enabled: bool,
    } => Ack;
    /// Attitude and body rates from the vehicle's AHRS: the
    /// [`RequestBody::Attitude`] for the heading plus what the on-board
    /// gyro-aided fit ([`OnboardModel::Gyro`]) needs. Stale after
    /// [`ATTITUDE_TIMEOUT_MS`]. (After the requests above: they keep their
    /// wire tags.)
    Motion {
        /// Roll, radians.
        roll_rad: f32,
        /// Pitch, radians.
        pitch_rad: f32,
        /// Body rates (x forward, y right, z down), rad/s.
        rate_rad_s: [f32; 3],
    } => Ack;
    /// [`RequestBody::Attitude`] plus the thrusters' (motor) current, for
    /// the current term of the [`Coefficients`]. The current is stale after
    /// [`ATTITUDE_TIMEOUT_MS`], like the attitude; while it is stale and the
    /// stored current term is non-zero the board withholds the heading
    /// ([`crate::DeviceCounters::current_stale`] counts those samples).
    /// (After [`RequestBody::Motion`]: earlier requests keep their wire tags.)
    AttitudeEnv {
        /// Roll, radians.
        roll_rad: f32,
        /// Pitch, radians.
        pitch_rad: f32,
        /// Thruster (motor) current, A (the recording's `motor_current_a`).
        motor_current_a: f32,
    } => Ack;
}
