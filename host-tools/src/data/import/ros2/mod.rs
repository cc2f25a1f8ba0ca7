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
//! ([`super::rules::quaternion_to_euler_deg`]): the heading is 90° − the ENU yaw,
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
//!
//! One room per job: the CDR reader and the message types decoded
//! ([`cdr`]); the check of a stored definition against the layout read
//! ([`definition`]); REP 103's frames to this project's ([`frames`]); the
//! bag being read, the choice of topics, the clock and the rows ([`bag`]).

use std::collections::BTreeMap;

mod bag;
mod cdr;
mod definition;
mod frames;

pub use bag::Bag;
pub use cdr::{MsgType, Sample};
pub use definition::{check_definition, Definition};
pub use frames::{enu_flu_to_ned_frd_euler_deg, flu_to_frd};

/// `sensor_msgs/msg/MagneticField`.
pub const MAGNETIC_FIELD: &str = "sensor_msgs/msg/MagneticField";
/// `sensor_msgs/msg/Imu`.
pub const IMU: &str = "sensor_msgs/msg/Imu";
/// `sensor_msgs/msg/NavSatFix`.
pub const NAV_SAT_FIX: &str = "sensor_msgs/msg/NavSatFix";

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

#[cfg(test)]
mod tests;
