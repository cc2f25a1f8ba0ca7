//! ROS 2 bags, the part both storages share ([`super::mcap`],
//! [`super::sqlite3`]): the CDR decoding of the few message types read, the
//! check of the message definitions a bag stores, the choice of topics, the
//! frames' conventions and the assembly of the rows.
//!
//! **Messages read** (by type, whatever the topic's name):
//! - `sensor_msgs/msg/MagneticField`: the compass. `magnetic_field` in tesla
//!   → nT; one row a message of the chosen topic.
//! - `sensor_msgs/msg/Imu`: `orientation` → `roll_deg`, `pitch_deg` and
//!   `ahrs_yaw_deg` (the vehicle's own estimate, never the reference: an IMU's
//!   yaw comes from its magnetometer or integrates the gyro);
//!   `angular_velocity` → `gx, gy, gz`. An orientation or a rate whose
//!   covariance starts with −1 ("not given", as the message's definition
//!   says) is not used.
//! - `sensor_msgs/msg/NavSatFix`: `latitude`, `longitude` (status ≥ 0, a fix).
//! - A heading reference: a `geometry_msgs/msg/QuaternionStamped` or
//!   `sensor_msgs/msg/Imu` topic whose name holds `heading` (as GNSS-compass
//!   drivers name it, e.g. `/gnss/heading`): its yaw → `ref_heading_deg`
//!   (an independent true heading). No other topic is taken for a reference:
//!   the course from a GNSS velocity is not read.
//!
//! **Topics**: among several of one type, the one with the most messages
//! (ties: the first by name); `--topic` names the magnetometer's; the report's
//! notes say which were found and which was taken.
//!
//! **Time**: every topic on its messages' `header.stamp` (the sensor's time
//! of the sample), `t` in s since the chosen magnetometer's first stamp;
//! when that topic's stamps are all zero (a driver that does not stamp), the
//! bag's receive time for every topic instead; another topic whose stamps are
//! all zero on its receive time; the report says so.
//!
//! **Frames** (REP 103 → this project's): ROS's body frame is FLU
//! (forward, left, up) and its world ENU (east, north, up); the columns are in
//! an FRD body (forward, right, down) and an NED world. Vectors in the body
//! (field, angular rate): (x, y, z)_FLU → (x, −y, −z)_FRD. Orientation: the
//! quaternion q of the FLU body in the ENU world becomes
//! q_NED←ENU ⊗ q ⊗ q_FLU←FRD (both fixed rotations are 180° turns: about
//! (1, 1, 0)/√2 and about x), then the aerospace Z-Y-X angles
//! ([`rules::quaternion_to_euler_deg`]): the heading is 90° − the ENU yaw,
//! pitch changes sign (ROS's positive pitch is nose down), roll keeps it.
//! A `header.frame_id` ending in `_ned` or `_frd` (drivers that publish in
//! those frames say so there) is converted the same way and a note says so.
//!
//! **CDR** is read by hand, a bounded cursor of a few dozen lines for the
//! fixed layouts of these four types: the serde-based CDR crates (`cdr`, no
//! release for years; `cdr-encoding`) would need the same per-type structs,
//! take the byte order as a type parameter where the encapsulation header
//! gives it at run time, and report a short message without saying which
//! field. Little- and big-endian plain CDR (encapsulation `00 00`, `00 01`)
//! are read; XCDR2 and parameter lists are refused per message. Alignment is
//! the primitive's size, counted from the end of the 4-byte encapsulation
//! header.
//!
//! **Definitions**: a bag stores each type's definition (MCAP's `ros2msg`
//! schemas; the sqlite3 storage's `message_definitions` table since ROS 2
//! Iron). Where one is stored as `ros2msg`, its fields (type and name, in
//! order, of the message and of the nested types it includes: `Header`,
//! `Time`, `Vector3`, `Quaternion`, `NavSatStatus`) must be the layout decoded
//! here, or the topic is not read (its messages counted as skipped; the
//! magnetometer's is refused). Without a definition (older sqlite3 bags) or
//! in another encoding (`ros2idl`), the type's name alone decides, and a note
//! says so.

use std::collections::BTreeMap;

use super::rules::{self, Kind, Series};
use super::{Builder, Format, ImportError, ImportOptions, Imported, Role};
use crate::data::table::col;

/// `sensor_msgs/msg/MagneticField`.
pub const MAGNETIC_FIELD: &str = "sensor_msgs/msg/MagneticField";
/// `sensor_msgs/msg/Imu`.
pub const IMU: &str = "sensor_msgs/msg/Imu";
/// `sensor_msgs/msg/NavSatFix`.
pub const NAV_SAT_FIX: &str = "sensor_msgs/msg/NavSatFix";
/// The first bytes of a zstd frame (rosbag2's per-message compression).
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xB5, 0x2F, 0xFD];

/// `geometry_msgs/msg/QuaternionStamped`.
pub const QUATERNION_STAMPED: &str = "geometry_msgs/msg/QuaternionStamped";

/// Why a ROS 2 bag could not be imported (in either storage).
#[derive(Debug, thiserror::Error)]
pub enum Ros2Error {
    /// No `sensor_msgs/msg/MagneticField` topic.
    #[error("no sensor_msgs/msg/MagneticField topic in the bag (topics: {})", list_or_none(topics))]
    NoMagnetometer {
        /// The topics found, with their types.
        topics: Vec<String>,
    },
    /// `--topic` names no magnetometer topic of the bag.
    #[error("--topic {wanted}: not a sensor_msgs/msg/MagneticField topic of the bag (magnetometer topics: {})", list_or_none(found))]
    NoTopic {
        /// The topic asked for.
        wanted: String,
        /// The magnetometer topics found.
        found: Vec<String>,
    },
    /// The magnetometer topic cannot be read: its stored definition is not
    /// the layout read, or it is not serialized as CDR.
    #[error("{topic} ({type_name}) cannot be read: {detail}")]
    Definition {
        /// The topic.
        topic: String,
        /// Its type.
        type_name: String,
        /// What differs.
        detail: String,
    },
    /// The magnetometer topic holds no message that could be decoded.
    #[error("{topic}: none of its {messages} messages could be decoded (skipped: {skipped:?})")]
    NoSamples {
        /// The topic.
        topic: String,
        /// Its messages.
        messages: usize,
        /// Why they were skipped.
        skipped: BTreeMap<String, usize>,
    },
}

fn list_or_none(v: &[String]) -> String {
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

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

/// The layouts read: each type's fields (type, name) in order, types by
/// their last path element.
const LAYOUTS: &[(&str, &[(&str, &str)])] = &[
    ("MagneticField", &[("Header", "header"), ("Vector3", "magnetic_field"), ("float64[9]", "magnetic_field_covariance")]),
    (
        "Imu",
        &[
            ("Header", "header"),
            ("Quaternion", "orientation"),
            ("float64[9]", "orientation_covariance"),
            ("Vector3", "angular_velocity"),
            ("float64[9]", "angular_velocity_covariance"),
            ("Vector3", "linear_acceleration"),
            ("float64[9]", "linear_acceleration_covariance"),
        ],
    ),
    (
        "NavSatFix",
        &[
            ("Header", "header"),
            ("NavSatStatus", "status"),
            ("float64", "latitude"),
            ("float64", "longitude"),
            ("float64", "altitude"),
            ("float64[9]", "position_covariance"),
            ("uint8", "position_covariance_type"),
        ],
    ),
    ("QuaternionStamped", &[("Header", "header"), ("Quaternion", "quaternion")]),
    ("Header", &[("Time", "stamp"), ("string", "frame_id")]),
    ("Time", &[("int32", "sec"), ("uint32", "nanosec")]),
    ("Vector3", &[("float64", "x"), ("float64", "y"), ("float64", "z")]),
    ("Quaternion", &[("float64", "x"), ("float64", "y"), ("float64", "z"), ("float64", "w")]),
    ("NavSatStatus", &[("int8", "status"), ("uint16", "service")]),
];

fn short_type(t: &str) -> &str {
    t.rsplit('/').next().unwrap_or(t)
}

/// The fields (type, name) of one `.msg` section: comments, blank lines and
/// constants (`TYPE NAME=VALUE`) left out, default values ignored.
fn msg_fields(section: &str) -> Vec<(String, String)> {
    section
        .lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty() && !l.contains('='))
        .filter_map(|l| {
            let mut it = l.split_whitespace();
            Some((short_type(it.next()?).to_string(), it.next()?.to_string()))
        })
        .collect()
}

/// Checks a `ros2msg` definition of `type_name` (the message's own text,
/// then each included type after a line of `=` and `MSG: pkg/Type`) against
/// the layout read: `Err` says the first difference.
pub fn check_definition(type_name: &str, text: &str) -> Result<(), String> {
    let mut sections: Vec<(String, &str)> = Vec::new();
    let mut name = short_type(type_name).to_string();
    let mut rest = text;
    loop {
        let (body, next) = match rest.find("\n====") {
            Some(i) => (&rest[..i], Some(&rest[i + 1..])),
            None => (rest, None),
        };
        sections.push((name.clone(), body));
        let Some(next) = next else { break };
        // Past the line of '=' to the "MSG: pkg/Type" line.
        let after_rule = next.split_once('\n').map_or("", |(_, r)| r);
        let (msg_line, body_rest) = after_rule.split_once('\n').unwrap_or((after_rule, ""));
        name = match msg_line.trim().strip_prefix("MSG:") {
            Some(t) => short_type(t.trim()).to_string(),
            None => return Err(format!("an included definition without its MSG: line ({:?})", msg_line.trim())),
        };
        rest = body_rest;
    }
    for (name, body) in sections {
        let Some((_, want)) = LAYOUTS.iter().find(|(n, _)| *n == name) else { continue };
        let got = msg_fields(body);
        let want: Vec<(String, String)> = want.iter().map(|(t, n)| (t.to_string(), n.to_string())).collect();
        if got != want {
            let show = |f: &[(String, String)]| f.iter().map(|(t, n)| format!("{t} {n}")).collect::<Vec<_>>().join("; ");
            return Err(format!("{name}: fields [{}], read as [{}]", show(&got), show(&want)));
        }
    }
    Ok(())
}

/// A type's definition as a bag stores it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Definition {
    /// `ros2msg`, `ros2idl`, or what the bag says.
    pub encoding: String,
    /// The text.
    pub text: String,
}

#[derive(Debug)]
struct TopicState {
    name: String,
    type_name: String,
    msg_type: Option<MsgType>,
    /// Why its messages are not read (a definition that differs, not CDR).
    refused: Option<(&'static str, String)>,
    messages: usize,
    samples: Vec<Sample>,
    skipped: BTreeMap<&'static str, usize>,
}

/// A bag being read: topics declared by the storage, messages fed to it in
/// the bag's order, then [`Bag::finish`].
#[derive(Debug)]
pub struct Bag {
    format: Format,
    topics: Vec<TopicState>,
    skipped: BTreeMap<String, usize>,
    notes: Vec<String>,
}

impl Bag {
    /// An empty bag of `format` ([`Format::Mcap`] or [`Format::Sqlite3`]).
    pub fn new(format: Format) -> Self {
        Self { format, topics: Vec::new(), skipped: BTreeMap::new(), notes: Vec::new() }
    }

    /// Declares a topic: its name, type, serialization (`cdr`) and stored
    /// definition; the index [`Bag::message`] takes.
    pub fn topic(&mut self, name: &str, type_name: &str, serialization: &str, definition: Option<&Definition>) -> usize {
        let msg_type = MsgType::from_name(type_name);
        let mut refused = None;
        if let Some(t) = msg_type {
            if !serialization.eq_ignore_ascii_case("cdr") {
                refused = Some(("not_cdr", format!("serialized as {serialization:?}, not CDR")));
            } else {
                match definition {
                    Some(d) if d.encoding == "ros2msg" => {
                        if let Err(e) = check_definition(t.name(), &d.text) {
                            refused = Some(("definition_differs", format!("the bag's definition is not the layout read: {e}")));
                        }
                    }
                    Some(d) => self.note(format!("{name}: definition in {:?}, not checked: decoded as {}", d.encoding, t.name())),
                    None => self.note(format!("{name}: no definition stored: decoded as {} by its type's name", t.name())),
                }
            }
        }
        self.topics.push(TopicState { name: name.into(), type_name: type_name.into(), msg_type, refused, messages: 0, samples: Vec::new(), skipped: BTreeMap::new() });
        self.topics.len() - 1
    }

    /// Whether the messages of topic `topic` are decoded (of a type read and
    /// not refused): a storage may leave the others' data unread.
    pub fn decodes(&self, topic: usize) -> bool {
        self.topics.get(topic).is_some_and(|t| t.msg_type.is_some() && t.refused.is_none())
    }

    /// One message of topic `topic` (from [`Bag::topic`]), received at
    /// `receive_ns`; decoded when its type is read, counted always.
    pub fn message(&mut self, topic: usize, receive_ns: i64, data: &[u8]) {
        let Some(t) = self.topics.get_mut(topic) else {
            *self.skipped.entry("message_of_unknown_topic".into()).or_default() += 1;
            return;
        };
        t.messages += 1;
        let Some(msg_type) = t.msg_type else { return };
        if let Some((kind, _)) = &t.refused {
            *t.skipped.entry(kind).or_default() += 1;
            return;
        }
        if data.starts_with(&ZSTD_MAGIC) {
            *t.skipped.entry("zstd_compressed_message").or_default() += 1;
            let note = "messages compressed one by one (rosbag2's message compression, zstd) are not read: decompress the bag first (ros2 bag convert)".to_string();
            if !self.notes.contains(&note) {
                self.notes.push(note);
            }
            return;
        }
        match msg_type.decode(data, receive_ns) {
            Ok(Some(s)) => t.samples.push(s),
            Ok(None) => *t.skipped.entry("navsatfix_without_fix").or_default() += 1,
            Err(e) => *t.skipped.entry(e.kind()).or_default() += 1,
        }
    }

    /// Counts `n` refusals of `kind` by the storage (a corrupt chunk, a
    /// truncated tail).
    pub fn skip(&mut self, kind: &str, n: usize) {
        if n > 0 {
            *self.skipped.entry(kind.to_string()).or_default() += n;
        }
    }

    /// A note from the storage.
    pub fn note(&mut self, note: impl Into<String>) {
        let note = note.into();
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    /// Topics of `t`, the busiest first (ties: by name).
    fn of_type(&self, t: MsgType, filter: impl Fn(&TopicState) -> bool) -> Vec<usize> {
        let mut idx: Vec<usize> = (0..self.topics.len()).filter(|&i| self.topics[i].msg_type == Some(t) && filter(&self.topics[i])).collect();
        idx.sort_by(|&a, &b| self.topics[b].messages.cmp(&self.topics[a].messages).then_with(|| self.topics[a].name.cmp(&self.topics[b].name)));
        idx
    }

    /// The busiest usable topic of a kind, with a note when there were
    /// several.
    fn pick(&mut self, what: &str, candidates: Vec<usize>) -> Option<usize> {
        let usable: Vec<usize> = candidates.iter().copied().filter(|&i| self.topics[i].refused.is_none()).collect();
        let chosen = usable.first().copied();
        if let Some(c) = chosen {
            if candidates.len() > 1 {
                let list = candidates.iter().map(|&i| format!("{} ({})", self.topics[i].name, self.topics[i].messages)).collect::<Vec<_>>().join(", ");
                self.note(format!("{what}: {} topics ({list}); {} taken (the most messages)", candidates.len(), self.topics[c].name));
            }
        }
        chosen
    }

    /// The import: the magnetometer topic's samples as rows, the other
    /// topics' carried to their times ([`rules::Series`]), in this project's
    /// frames and units; `wrap` makes the format's error from a
    /// [`Ros2Error`].
    pub fn finish(mut self, opts: &ImportOptions, wrap: impl Fn(Ros2Error) -> ImportError) -> Result<Imported, ImportError> {
        let all_topics: Vec<String> = self.topics.iter().map(|t| format!("{} ({})", t.name, t.type_name)).collect();
        let mags = self.of_type(MsgType::MagneticField, |_| true);
        let mag = match &opts.topic {
            Some(wanted) => {
                let Some(&i) = mags.iter().find(|&&i| self.topics[i].name == *wanted) else {
                    return Err(wrap(Ros2Error::NoTopic { wanted: wanted.clone(), found: mags.iter().map(|&i| self.topics[i].name.clone()).collect() }));
                };
                if mags.len() > 1 {
                    let list = mags.iter().map(|&i| self.topics[i].name.clone()).collect::<Vec<_>>().join(", ");
                    self.note(format!("magnetometer: {} of {list} (--topic)", self.topics[i].name));
                }
                i
            }
            None => {
                let Some(&first) = mags.first() else { return Err(wrap(Ros2Error::NoMagnetometer { topics: all_topics })) };
                self.pick("magnetometer", mags.clone()).unwrap_or(first)
            }
        };
        let m = &self.topics[mag];
        if let Some((_, detail)) = &m.refused {
            return Err(wrap(Ros2Error::Definition { topic: m.name.clone(), type_name: m.type_name.clone(), detail: detail.clone() }));
        }
        if m.samples.is_empty() {
            let skipped = m.skipped.iter().map(|(k, v)| (k.to_string(), *v)).collect();
            return Err(wrap(Ros2Error::NoSamples { topic: m.name.clone(), messages: m.messages, skipped }));
        }
        let heading_named = |t: &TopicState| t.name.to_ascii_lowercase().contains("heading");
        let imu_candidates = self.of_type(MsgType::Imu, |t| !heading_named(t));
        let imu = self.pick("attitude (sensor_msgs/msg/Imu)", imu_candidates);
        let fix_candidates = self.of_type(MsgType::NavSatFix, |_| true);
        let fix = self.pick("position (sensor_msgs/msg/NavSatFix)", fix_candidates);
        let mut heading_candidates = self.of_type(MsgType::QuaternionStamped, heading_named);
        heading_candidates.extend(self.of_type(MsgType::Imu, heading_named));
        let heading = self.pick("heading reference (a topic named *heading*)", heading_candidates);

        // The clock: header stamps, unless the magnetometer's are all zero
        // (then the receive time for every topic); another topic whose
        // stamps are all zero on its receive time.
        let has_stamps = |t: &TopicState| t.samples.iter().any(|s| s.stamp_ns != 0);
        let stamped = has_stamps(&self.topics[mag]);
        let by_stamp: Vec<bool> = self.topics.iter().map(|t| stamped && has_stamps(t)).collect();
        let time = |i: usize, s: &Sample| if by_stamp.get(i) == Some(&true) { s.stamp_ns } else { s.receive_ns };
        let mag_name = self.topics[mag].name.clone();
        let t0_ns = self.topics[mag].samples.iter().map(|s| time(mag, s)).min().unwrap_or(0);
        // i128: a hostile receive time may be anywhere on i64.
        let t_of = |ns: i64| (i128::from(ns) - i128::from(t0_ns)) as f64 / 1e9;
        let clock = if stamped {
            format!("s since the first {mag_name} header.stamp ({}.{:09} s since the UNIX epoch); every topic on its header.stamp", t0_ns.div_euclid(1_000_000_000), t0_ns.rem_euclid(1_000_000_000))
        } else {
            format!("s since the first {mag_name} message received ({}.{:09} s since the UNIX epoch): the bag's receive time for every topic", t0_ns.div_euclid(1_000_000_000), t0_ns.rem_euclid(1_000_000_000))
        };
        if !stamped {
            self.note(format!("{mag_name}: every header.stamp is zero: the bag's receive time is the clock for every topic"));
        }
        for i in [imu, fix, heading].into_iter().flatten() {
            if stamped && !by_stamp[i] && !self.topics[i].samples.is_empty() {
                let name = self.topics[i].name.clone();
                self.note(format!("{name}: every header.stamp is zero: its receive time used (later than the sample by the transport's delay)"));
            }
        }

        let mut non_finite = 0;
        let mut t_s = Vec::new();
        let mut field_nt: [Vec<f64>; 3] = Default::default();
        for s in &self.topics[mag].samples {
            let f = flu_to_frd([s.v[0], s.v[1], s.v[2]]).map(|v| v * rules::NT_PER_TESLA);
            if f.iter().any(|v| !v.is_finite()) {
                non_finite += 1;
                continue;
            }
            t_s.push(t_of(time(mag, s)));
            for k in 0..3 {
                field_nt[k].push(f[k]);
            }
        }
        let mut att = Series::new([Kind::Angle180, Kind::Linear, Kind::Heading360]);
        let mut gyro = Series::new([Kind::Linear; 3]);
        if let Some(i) = imu {
            for s in &self.topics[i].samples {
                if let Some(e) = enu_flu_to_ned_frd_euler_deg([s.v[0], s.v[1], s.v[2], s.v[3]]) {
                    att.push(t_of(time(i, s)), e);
                }
                let g = flu_to_frd([s.v[4], s.v[5], s.v[6]]);
                if g.iter().all(|v| v.is_finite()) {
                    gyro.push(t_of(time(i, s)), g);
                }
            }
        }
        let mut pos = Series::new([Kind::Linear; 2]);
        if let Some(i) = fix {
            for s in &self.topics[i].samples {
                pos.push(t_of(time(i, s)), [s.v[0], s.v[1]]);
            }
        }
        let mut hdg = Series::new([Kind::Heading360]);
        if let Some(i) = heading {
            for s in &self.topics[i].samples {
                if let Some(e) = enu_flu_to_ned_frd_euler_deg([s.v[0], s.v[1], s.v[2], s.v[3]]) {
                    hdg.push(t_of(time(i, s)), [e[2]]);
                }
            }
        }
        let carried = |series_at: &dyn Fn(f64) -> Option<Vec<f64>>, k: usize| -> Vec<f64> { t_s.iter().map(|&t| series_at(t).and_then(|v| v.get(k).copied()).unwrap_or(f64::NAN)).collect() };
        let age = opts.max_age_s;
        let att_at = |t: f64| att.at(t, age).map(|v| v.to_vec());
        let gyro_at = |t: f64| gyro.at(t, age).map(|v| v.to_vec());
        let pos_at = |t: f64| pos.at(t, age).map(|v| v.to_vec());
        let hdg_at = |t: f64| hdg.at(t, age).map(|v| v.to_vec());
        let columns = [
            (col::ROLL_DEG, carried(&att_at, 0)),
            (col::PITCH_DEG, carried(&att_at, 1)),
            (col::AHRS_YAW_DEG, carried(&att_at, 2)),
            (col::GYRO[0], carried(&gyro_at, 0)),
            (col::GYRO[1], carried(&gyro_at, 1)),
            (col::GYRO[2], carried(&gyro_at, 2)),
            (col::LAT_DEG, carried(&pos_at, 0)),
            (col::LON_DEG, carried(&pos_at, 1)),
            (col::REF_HEADING_DEG, carried(&hdg_at, 0)),
        ];
        let out_of_order = att.out_of_order + gyro.out_of_order + pos.out_of_order + hdg.out_of_order;

        let mut b = Builder::new(self.format, t_s, clock);
        b.report.field_unit = Some("nT".into());
        let frd = "FLU → FRD: (x, −y, −z)";
        for (k, name) in col::MAG.into_iter().enumerate() {
            b.column(name, std::mem::take(&mut field_nt[k]), format!("{MAGNETIC_FIELD} {mag_name}: magnetic_field (T × 1e9 → nT), {frd}"), Role::Compass)?;
        }
        let topic_name = |i: Option<usize>| i.map(|i| self.topics[i].name.clone()).unwrap_or_default();
        let (imu_name, fix_name, hdg_name) = (topic_name(imu), topic_name(fix), topic_name(heading));
        let hdg_type = heading.map(|i| self.topics[i].type_name.clone()).unwrap_or_default();
        for (name, values) in columns {
            let (from, role) = match name {
                col::ROLL_DEG | col::PITCH_DEG => (format!("{IMU} {imu_name}: orientation (ENU/FLU → NED/FRD, Z-Y-X)"), Role::Sensor),
                col::AHRS_YAW_DEG => (format!("{IMU} {imu_name}: orientation's heading (90° − the ENU yaw): the vehicle's own estimate"), Role::OwnEstimate),
                col::LAT_DEG | col::LON_DEG => (format!("{NAV_SAT_FIX} {fix_name}: latitude, longitude (status ≥ 0)"), Role::Sensor),
                col::REF_HEADING_DEG => (format!("{hdg_type} {hdg_name}: heading (90° − the ENU yaw), an independent heading reference (the topic's name)"), Role::Reference),
                _ => (format!("{IMU} {imu_name}: angular_velocity (rad/s), {frd}"), Role::Sensor),
            };
            b.column(name, values, from, role)?;
        }
        for t in &self.topics {
            *b.report.messages.entry(t.name.clone()).or_default() += t.messages;
            for (kind, n) in &t.skipped {
                b.skip(&format!("{kind}: {}", t.name), *n);
            }
            if let Some((_, why)) = &t.refused {
                b.note(format!("{}: not read: {why}", t.name));
            }
        }
        for (kind, n) in &self.skipped {
            b.skip(kind, *n);
        }
        b.skip(&format!("non_finite_field: {mag_name}"), non_finite);
        b.skip("sample_older_than_the_last (other topics)", out_of_order);
        for n in std::mem::take(&mut self.notes) {
            b.note(n);
        }
        b.note("frames: ROS's FLU body and ENU world (REP 103) converted to FRD and NED: field and rates (x, −y, −z); roll kept, pitch negated, heading = 90° − the ENU yaw".to_string());
        for i in [Some(mag), imu, heading].into_iter().flatten() {
            if self.topics[i].samples.iter().any(|s| s.ned_frame_id) {
                b.note(format!(
                    "{}: a header.frame_id ends in _ned or _frd: a driver may publish in NED/FRD already; converted from ENU/FLU (REP 103) all the same: check the signs",
                    self.topics[i].name
                ));
            }
        }
        if heading.is_none() {
            b.note("no heading reference: no QuaternionStamped or Imu topic named *heading* (a GNSS compass's); ahrs_yaw_deg is the vehicle's own estimate, not a reference".to_string());
        }
        b.finish()
    }
}

/// A body vector from ROS's FLU to this project's FRD.
pub fn flu_to_frd(v: [f64; 3]) -> [f64; 3] {
    [v[0], -v[1], -v[2]]
}

/// Hamilton product of quaternions `[w, x, y, z]`.
fn qmul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [aw, ax, ay, az] = a;
    let [bw, bx, by, bz] = b;
    [aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw]
}

/// Roll, pitch and heading (degrees; heading on 0–360°) of the FRD body in
/// the NED world, from a ROS orientation: the quaternion `[x, y, z, w]` (ROS's
/// order) of the FLU body in the ENU world. `None` when it is not finite or
/// near zero.
pub fn enu_flu_to_ned_frd_euler_deg(q_xyzw: [f64; 4]) -> Option<[f64; 3]> {
    let [x, y, z, w] = q_xyzw;
    let h = std::f64::consts::FRAC_1_SQRT_2;
    // NED ← ENU: 180° about (1, 1, 0)/√2; FLU ← FRD: 180° about x.
    let ned_from_enu = [0.0, h, h, 0.0];
    let flu_from_frd = [0.0, 1.0, 0.0, 0.0];
    rules::quaternion_to_euler_deg(qmul(qmul(ned_from_enu, [w, x, y, z]), flu_from_frd))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ROS quaternion `[x, y, z, w]` of a rotation by `deg` about `axis`.
    fn q(axis: [f64; 3], deg: f64) -> [f64; 4] {
        let h = (deg / 2.0).to_radians();
        [axis[0] * h.sin(), axis[1] * h.sin(), axis[2] * h.sin(), h.cos()]
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        a.iter().zip(b).all(|(x, y)| rules::wrap180(x - y).abs() < 1e-9)
    }

    #[test]
    fn orientations_by_hand() {
        // Level, facing east: ROS's identity (x forward = east).
        assert!(close(enu_flu_to_ned_frd_euler_deg([0.0, 0.0, 0.0, 1.0]).unwrap(), [0.0, 0.0, 90.0]));
        // Level, facing north: 90° about up in ENU.
        assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 0.0, 1.0], 90.0)).unwrap(), [0.0, 0.0, 0.0]));
        // Facing west: 180° about up.
        assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 0.0, 1.0], 180.0)).unwrap(), [0.0, 0.0, 270.0]));
        // Facing east, nose up 10°: about FLU's left axis by −10° (positive
        // about left turns the nose down).
        assert!(close(enu_flu_to_ned_frd_euler_deg(q([0.0, 1.0, 0.0], -10.0)).unwrap(), [0.0, 10.0, 90.0]));
        // Facing east, right side down 20°: about forward by +20° (the left
        // side rises).
        assert!(close(enu_flu_to_ned_frd_euler_deg(q([1.0, 0.0, 0.0], 20.0)).unwrap(), [20.0, 0.0, 90.0]));
        // Facing north, right side down 20°: yaw, then roll in the body.
        let [x, y, z, w] = q([0.0, 0.0, 1.0], 90.0);
        let [rx, ry, rz, rw] = q([1.0, 0.0, 0.0], 20.0);
        let [w2, x2, y2, z2] = qmul([w, x, y, z], [rw, rx, ry, rz]);
        assert!(close(enu_flu_to_ned_frd_euler_deg([x2, y2, z2, w2]).unwrap(), [20.0, 0.0, 0.0]));
        assert!(enu_flu_to_ned_frd_euler_deg([0.0; 4]).is_none());
    }

    #[test]
    fn the_field_by_hand() {
        // The field north 20 000 nT, down 40 000 nT (ENU: (0, 2e-5, −4e-5) T).
        // Facing north, FLU reads forward = north, left = west, up: (2e-5, 0, −4e-5).
        assert_eq!(flu_to_frd([2e-5, 0.0, -4e-5]), [2e-5, 0.0, 4e-5]);
        // Facing east, left = north: (0, 2e-5, −4e-5) → right (south) negative, down positive.
        assert_eq!(flu_to_frd([0.0, 2e-5, -4e-5]), [0.0, -2e-5, 4e-5]);
    }

    /// A MagneticField in CDR: `little` or big endian, frame_id `frame`.
    fn magnetic_field(little: bool, frame: &str, f: [f64; 3]) -> Vec<u8> {
        let mut b = vec![0, u8::from(little), 0, 0];
        let put = |b: &mut Vec<u8>, bytes: &[u8], align: usize| {
            while !(b.len() - 4).is_multiple_of(align) {
                b.push(0);
            }
            if little {
                b.extend(bytes.iter().rev());
            } else {
                b.extend(bytes);
            }
        };
        put(&mut b, &7i32.to_be_bytes(), 4);
        put(&mut b, &5u32.to_be_bytes(), 4);
        put(&mut b, &(frame.len() as u32 + 1).to_be_bytes(), 4);
        b.extend(frame.as_bytes());
        b.push(0);
        for v in f.into_iter().chain([0.0; 9]) {
            put(&mut b, &v.to_be_bytes(), 8);
        }
        b
    }

    #[test]
    fn cdr_of_both_byte_orders_and_alignments() {
        for little in [true, false] {
            // frame_id lengths that leave every padding before the float64s.
            for frame in ["", "a", "ab", "abc", "abcd", "imu_link"] {
                let msg = magnetic_field(little, frame, [1e-5, -2e-5, 3.5e-5]);
                let s = MsgType::MagneticField.decode(&msg, 9).unwrap().unwrap();
                assert_eq!(s.stamp_ns, 7_000_000_005, "{little} {frame:?}");
                assert_eq!(s.v[..3], [1e-5, -2e-5, 3.5e-5], "{little} {frame:?}");
                assert_eq!(s.receive_ns, 9);
            }
        }
    }

    #[test]
    fn short_and_strange_cdr_is_an_error_naming_the_field() {
        let msg = magnetic_field(true, "imu", [1.0, 2.0, 3.0]);
        for n in 0..msg.len() {
            let e = MsgType::MagneticField.decode(&msg[..n], 0).unwrap_err();
            assert!(matches!(e, CdrError::NoHeader | CdrError::Short { .. } | CdrError::BadString(_)), "{n}: {e}");
        }
        let e = MsgType::MagneticField.decode(&msg[..30], 0).unwrap_err();
        assert_eq!(e.to_string(), "ends inside magnetic_field (needs 8 bytes at 24 of 26)");
        let mut xcdr2 = msg.clone();
        xcdr2[1] = 7;
        assert_eq!(MsgType::MagneticField.decode(&xcdr2, 0).unwrap_err(), CdrError::Encapsulation(7));
        // A frame_id length of 4 GB: bounded, not allocated.
        let mut huge = msg.clone();
        huge[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(MsgType::MagneticField.decode(&huge, 0).unwrap_err(), CdrError::Short { field: "header.frame_id", .. }));
        // A string without its NUL.
        let mut no_nul = msg;
        no_nul[19] = b'x';
        assert_eq!(MsgType::MagneticField.decode(&no_nul, 0).unwrap_err(), CdrError::BadString("header.frame_id"));
    }

    #[test]
    fn definitions_are_checked_field_by_field() {
        let rosbags_style = "std_msgs/Header header\ngeometry_msgs/Vector3 magnetic_field\nfloat64[9] magnetic_field_covariance\n\
            ================================================================================\nMSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n\
            ================================================================================\nMSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n\
            ================================================================================\nMSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";
        assert_eq!(check_definition(MAGNETIC_FIELD, rosbags_style), Ok(()));
        // rosbag2's own: the .msg files with comments and constants.
        let with_comments = "# Measurement of the Magnetic Field vector\n\nstd_msgs/Header header # timestamp\n\ngeometry_msgs/Vector3 magnetic_field # tesla\nfloat64[9] magnetic_field_covariance\n";
        assert_eq!(check_definition(MAGNETIC_FIELD, with_comments), Ok(()));
        let fix = "int8 STATUS_NO_FIX =  -1\nstd_msgs/Header header\nNavSatStatus status\nfloat64 latitude\nfloat64 longitude\nfloat64 altitude\nfloat64[9] position_covariance\nuint8 COVARIANCE_TYPE_UNKNOWN = 0\nuint8 position_covariance_type\n\
            ================================================================================\nMSG: sensor_msgs/NavSatStatus\nint8 STATUS_FIX = 0\nint8 status\nuint16 service\n";
        assert_eq!(check_definition(NAV_SAT_FIX, fix), Ok(()));
        // A float32 field where float64 is read.
        let e = check_definition(MAGNETIC_FIELD, &rosbags_style.replace("float64 y", "float32 y")).unwrap_err();
        assert!(e.contains("Vector3") && e.contains("float32 y"), "{e}");
        let e = check_definition(IMU, "std_msgs/Header header\ngeometry_msgs/Quaternion orientation\n").unwrap_err();
        assert!(e.starts_with("Imu:"), "{e}");
    }

    /// A message of a header (stamp `ns`) and `f64s` in little-endian CDR.
    fn stamped(ns: i64, f64s: &[f64]) -> Vec<u8> {
        stamped_in(ns, "m", f64s)
    }

    /// The same with `frame` for `header.frame_id`.
    fn stamped_in(ns: i64, frame: &str, f64s: &[f64]) -> Vec<u8> {
        let mut b = vec![0, 1, 0, 0];
        b.extend(((ns / 1_000_000_000) as i32).to_le_bytes());
        b.extend(((ns % 1_000_000_000) as u32).to_le_bytes());
        b.extend((frame.len() as u32 + 1).to_le_bytes());
        b.extend(frame.as_bytes());
        b.push(0);
        while (b.len() - 4) % 8 != 0 {
            b.push(0);
        }
        for v in f64s {
            b.extend(v.to_le_bytes());
        }
        b
    }

    /// An Imu: orientation `q` (x, y, z, w), rate `w`, covariances zero.
    fn imu(ns: i64, q: [f64; 4], w: [f64; 3]) -> Vec<u8> {
        let mut v = q.to_vec();
        v.extend([0.0; 9]);
        v.extend(w);
        v.extend([0.0; 9 + 3 + 9]);
        stamped(ns, &v)
    }

    #[test]
    fn a_bag_by_hand_topics_roles_and_frames() {
        let mut bag = Bag::new(Format::Mcap);
        let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
        let att = bag.topic("/imu", IMU, "cdr", None);
        let hdg = bag.topic("/ins/heading", IMU, "cdr", None);
        let other = bag.topic("/camera", "sensor_msgs/msg/Image", "cdr", None);
        // Facing north, level, turning right at 0.1 rad/s; the field 20 000 nT
        // north, 40 000 nT down; a GNSS compass's heading 2° (yaw 88° in ENU).
        let north = q([0.0, 0.0, 1.0], 90.0);
        for k in 0..3 {
            let ns = 1_000_000_000 * (10 + k);
            bag.message(mag, ns + 7, &stamped(ns, &[2e-5, 0.0, -4e-5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]));
            bag.message(att, ns + 7, &imu(ns, north, [0.0, 0.0, -0.1]));
            bag.message(hdg, ns + 7, &imu(ns, q([0.0, 0.0, 1.0], 88.0), [0.0; 3]));
            bag.message(other, ns, &[1, 2, 3]);
        }
        bag.message(mag, 0, &[0, 1, 0, 0, 1]);
        let im = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap();
        assert_eq!(im.column("t").unwrap(), [0.0, 1.0, 2.0]);
        assert_eq!(im.column("mx").unwrap()[0], 20_000.0);
        assert_eq!(im.column("mz").unwrap()[0], 40_000.0);
        assert!(im.column("ahrs_yaw_deg").unwrap()[0].abs() < 1e-9);
        assert!((im.column("ref_heading_deg").unwrap()[0] - 2.0).abs() < 1e-9);
        assert!((im.column("gz").unwrap()[0] - 0.1).abs() < 1e-15);
        assert_eq!(im.report.column_sources["ref_heading_deg"].role, Role::Reference);
        assert!(im.report.column_sources["ref_heading_deg"].from.contains("/ins/heading"));
        assert!(im.report.column_sources["roll_deg"].from.contains("/imu:"));
        assert_eq!(im.report.messages["/camera"], 3);
        assert_eq!(im.report.messages["/mag"], 4);
        assert_eq!(im.report.skipped["short_cdr_message: /mag"], 1);
        assert!(im.report.notes.iter().any(|n| n.contains("/mag: no definition stored")), "{:?}", im.report.notes);
        assert!(!im.report.notes.iter().any(|n| n.contains("_ned")), "{:?}", im.report.notes);
        let mut bag = Bag::new(Format::Mcap);
        let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
        bag.message(mag, 0, &stamped_in(1, "imu_NED", &[1e-5; 12]));
        let im = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap();
        assert!(im.report.notes.iter().any(|n| n.starts_with("/mag: a header.frame_id ends in _ned or _frd")), "{:?}", im.report.notes);
    }

    #[test]
    fn a_bag_by_hand_refusals() {
        let mut bag = Bag::new(Format::Sqlite3);
        bag.topic("/imu", IMU, "cdr", None);
        let e = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
        assert_eq!(e, "no sensor_msgs/msg/MagneticField topic in the bag (topics: /imu (sensor_msgs/msg/Imu))");
        let mut bag = Bag::new(Format::Sqlite3);
        let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
        bag.message(mag, 0, &[0, 1, 0, 0]);
        let e = bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
        assert!(e.starts_with("/mag: none of its 1 messages could be decoded"), "{e}");
        let mut bag = Bag::new(Format::Sqlite3);
        let mag = bag.topic("/mag", MAGNETIC_FIELD, "cdr", None);
        bag.message(mag, 0, &stamped(1, &[0.0; 12]));
        let opts = ImportOptions { topic: Some("/other".into()), ..ImportOptions::default() };
        let e = bag.finish(&opts, |e| ImportError::Mcap(e.into())).unwrap_err().to_string();
        assert_eq!(e, "--topic /other: not a sensor_msgs/msg/MagneticField topic of the bag (magnetometer topics: /mag)");
        let mut bag = Bag::new(Format::Sqlite3);
        let mag = bag.topic("/mag", MAGNETIC_FIELD, "json", None);
        bag.message(mag, 0, b"{}");
        assert!(bag.finish(&ImportOptions::default(), |e| ImportError::Mcap(e.into())).unwrap_err().to_string().contains("not CDR"));
    }

    #[test]
    fn types_by_either_name() {
        assert_eq!(MsgType::from_name("sensor_msgs/MagneticField"), Some(MsgType::MagneticField));
        assert_eq!(MsgType::from_name(IMU), Some(MsgType::Imu));
        assert_eq!(MsgType::from_name("sensor_msgs/msg/Image"), None);
    }
}
