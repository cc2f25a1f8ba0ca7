//! The CDR decoding of the few message types a bag is read for: a bounded
//! reader of plain CDR (either byte order), and each type's fixed layout
//! decoded into a [`Sample`].

use super::{IMU, MAGNETIC_FIELD, NAV_SAT_FIX, QUATERNION_STAMPED};

/// Why one CDR message could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    /// Shorter than the 4-byte encapsulation header.
    #[error("shorter than the encapsulation header")]
    NoHeader,
    /// An encapsulation other than plain CDR.
    #[error("encapsulation {0:#06x} is not plain CDR")]
    Encapsulation(u16),
    /// The message ends inside a field.
    #[error("ends inside {field} (needs {need} bytes at {at} of {len})")]
    Short {
        /// The field.
        field: &'static str,
        /// Bytes needed.
        need: usize,
        /// Where, after the encapsulation header.
        at: usize,
        /// The bytes after the header.
        len: usize,
    },
    /// A string without its terminating NUL or of length 0.
    #[error("{0}: not a CDR string")]
    BadString(&'static str),
}

impl CdrError {
    /// The kind of skip it is counted as.
    pub fn kind(&self) -> &'static str {
        match self {
            CdrError::NoHeader | CdrError::Short { .. } => "short_cdr_message",
            CdrError::Encapsulation(_) => "not_plain_cdr",
            CdrError::BadString(_) => "corrupt_cdr_string",
        }
    }
}

/// A bounded reader of one plain-CDR message.
#[derive(Debug)]
pub struct Cdr<'a> {
    buf: &'a [u8],
    pos: usize,
    little: bool,
}

impl<'a> Cdr<'a> {
    /// A reader of `msg`, whose first 4 bytes are the encapsulation header
    /// (`00 00` big-endian, `00 01` little-endian CDR, then 2 option bytes).
    pub fn new(msg: &'a [u8]) -> Result<Self, CdrError> {
        let (head, buf) = msg.split_at_checked(4).ok_or(CdrError::NoHeader)?;
        let kind = u16::from_be_bytes([head[0], head[1]]);
        let little = match kind {
            0 => false,
            1 => true,
            k => return Err(CdrError::Encapsulation(k)),
        };
        Ok(Self { buf, pos: 0, little })
    }

    fn take<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], CdrError> {
        let at = self.pos.next_multiple_of(N);
        let short = CdrError::Short { field, need: N, at, len: self.buf.len() };
        let mut bytes: [u8; N] = self.buf.get(at..at + N).and_then(|b| b.try_into().ok()).ok_or(short)?;
        self.pos = at + N;
        if !self.little {
            bytes.reverse();
        }
        Ok(bytes)
    }

    /// A `float64`.
    pub fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        self.take::<8>(field).map(f64::from_le_bytes)
    }

    /// `N` `float64`s (a fixed array).
    pub fn f64s<const N: usize>(&mut self, field: &'static str) -> Result<[f64; N], CdrError> {
        let mut out = [0.0; N];
        for v in &mut out {
            *v = self.f64(field)?;
        }
        Ok(out)
    }

    /// A `uint32`.
    pub fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        self.take::<4>(field).map(u32::from_le_bytes)
    }

    /// An `int32`.
    pub fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        self.take::<4>(field).map(i32::from_le_bytes)
    }

    /// A `uint16`.
    pub fn u16(&mut self, field: &'static str) -> Result<u16, CdrError> {
        self.take::<2>(field).map(u16::from_le_bytes)
    }

    /// An `int8` or `uint8`.
    pub fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        self.take::<1>(field).map(|[b]| b)
    }

    /// A `string` (a `uint32` length with its NUL, the bytes, the NUL),
    /// bounded by the message: its bytes without the NUL.
    pub fn string(&mut self, field: &'static str) -> Result<&'a [u8], CdrError> {
        let n = self.u32(field)? as usize;
        let at = self.pos;
        let bytes = self.buf.get(at..at.saturating_add(n)).ok_or(CdrError::Short { field, need: n, at, len: self.buf.len() })?;
        let Some((0, text)) = bytes.split_last() else { return Err(CdrError::BadString(field)) };
        self.pos = at + n;
        Ok(text)
    }

    /// A `std_msgs/msg/Header`: its stamp in ns since the epoch, and whether
    /// its `frame_id` names an NED or FRD frame (ends in `_ned` or `_frd`).
    pub fn header(&mut self) -> Result<(i64, bool), CdrError> {
        let sec = self.i32("header.stamp.sec")?;
        let nanosec = self.u32("header.stamp.nanosec")?;
        let frame = self.string("header.frame_id")?.to_ascii_lowercase();
        let ned = frame.ends_with(b"_ned") || frame.ends_with(b"_frd");
        Ok((i64::from(sec) * 1_000_000_000 + i64::from(nanosec), ned))
    }
}

/// A decoded sample: its stamp, the bag's receive time, and up to 7 values
/// (by type: MagneticField x, y, z in T (FLU); Imu's quaternion x, y, z, w
/// then the rate x, y, z in rad/s (FLU), NaN where not given; NavSatFix
/// latitude, longitude; QuaternionStamped x, y, z, w).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// `header.stamp`, ns since the epoch.
    pub stamp_ns: i64,
    /// The bag's receive (log) time, ns since the epoch.
    pub receive_ns: i64,
    /// The values.
    pub v: [f64; 7],
    /// Whether `header.frame_id` names an NED or FRD frame.
    pub ned_frame_id: bool,
}

/// The types read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MsgType {
    /// `sensor_msgs/msg/MagneticField`.
    MagneticField,
    /// `sensor_msgs/msg/Imu`.
    Imu,
    /// `sensor_msgs/msg/NavSatFix`.
    NavSatFix,
    /// `geometry_msgs/msg/QuaternionStamped`.
    QuaternionStamped,
}

impl MsgType {
    /// The type of a name as bags store it (`pkg/msg/Type`, or the older
    /// `pkg/Type`).
    pub fn from_name(name: &str) -> Option<Self> {
        let canonical = name.replace("/msg/", "/");
        [MsgType::MagneticField, MsgType::Imu, MsgType::NavSatFix, MsgType::QuaternionStamped].into_iter().find(|t| t.name().replace("/msg/", "/") == canonical)
    }

    /// Its full name.
    pub fn name(self) -> &'static str {
        match self {
            MsgType::MagneticField => MAGNETIC_FIELD,
            MsgType::Imu => IMU,
            MsgType::NavSatFix => NAV_SAT_FIX,
            MsgType::QuaternionStamped => QUATERNION_STAMPED,
        }
    }

    /// Decodes one message (`Ok(None)`: a valid message without a usable
    /// value, e.g. a NavSatFix without a fix).
    pub fn decode(self, msg: &[u8], receive_ns: i64) -> Result<Option<Sample>, CdrError> {
        let mut c = Cdr::new(msg)?;
        let (stamp_ns, ned_frame_id) = c.header()?;
        let mut v = [f64::NAN; 7];
        match self {
            MsgType::MagneticField => {
                let f = c.f64s::<3>("magnetic_field")?;
                c.f64s::<9>("magnetic_field_covariance")?;
                v[..3].copy_from_slice(&f);
            }
            MsgType::Imu => {
                let q = c.f64s::<4>("orientation")?;
                let q_cov = c.f64s::<9>("orientation_covariance")?;
                let w = c.f64s::<3>("angular_velocity")?;
                let w_cov = c.f64s::<9>("angular_velocity_covariance")?;
                c.f64s::<3>("linear_acceleration")?;
                c.f64s::<9>("linear_acceleration_covariance")?;
                if q_cov[0] != -1.0 {
                    v[..4].copy_from_slice(&q);
                }
                if w_cov[0] != -1.0 {
                    v[4..].copy_from_slice(&w);
                }
            }
            MsgType::NavSatFix => {
                let status = c.u8("status.status")? as i8;
                c.u16("status.service")?;
                let [lat, lon, _alt] = c.f64s::<3>("latitude, longitude, altitude")?;
                c.f64s::<9>("position_covariance")?;
                c.u8("position_covariance_type")?;
                if status < 0 {
                    return Ok(None);
                }
                v[0] = lat;
                v[1] = lon;
            }
            MsgType::QuaternionStamped => {
                let q = c.f64s::<4>("quaternion")?;
                v[..4].copy_from_slice(&q);
            }
        }
        Ok(Some(Sample { stamp_ns, receive_ns, v, ned_frame_id }))
    }
}
