//! ArduPilot / ArduSub DataFlash binary logs (`.bin`) to a recording
//! (`magcal import --dataflash`).
//!
//! The format describes itself: every message is `0xA3 0x95 TYPE` and a
//! payload whose layout a `FMT` message (type 128) gave before — name, total
//! length, one format character per field (`b B h H i I f d q Q n N Z c C e
//! E L M a g`, little-endian; `c C e E` are hundredths and `L` 1e-7 degrees,
//! as pymavlink's `DFReader` reads them) and the field labels. No maintained
//! Rust crate for the format was available here, so the reader is this
//! module; the tests check it against pymavlink.
//!
//! The magnetometer: ArduPilot logs in `MAG` the field *after* its own
//! correction — `Compass::Write_Compass_instance`
//! (libraries/AP_Compass/AP_Compass_Logging.cpp) writes `get_field()`, the
//! output of `AP_Compass_Backend::correct_field`
//! (AP_Compass_Backend.cpp): `field = s·Mat·(raw + Ofs) + MO` with `s`
//! `COMPASS_SCALE` (applied within 1/1.5…1.5), `Mat` the symmetric matrix of
//! `COMPASS_DIA_*`/`COMPASS_ODI_*` and `MO` the motor offsets (`MOX/MOY/MOZ`
//! in the same message). The raw field is therefore
//! `raw = (s·Mat)⁻¹·(Mag − MO) − Ofs`, with `Ofs` and `MO` from each `MAG`
//! message and `s`, `Mat` from the log's `PARM` messages (the values in force
//! at that message); with the default `DIA` = 1, `ODI` = 0 this is
//! `raw = Mag − MO − Ofs`. Units: milligauss, body frame (after the board
//! orientation), and the logged field is truncated to whole mGauss.
//!
//! The gyro: `IMU` of the first IMU (`I` = 0; older logs: `IMU`, with
//! `IMU2`/`IMU3` for the others), `GyrX/Y/Z` in rad/s, body frame — the
//! rates the autopilot uses — interpolated linearly to each `MAG` time; the
//! high-rate `GYR` samples of the first IMU only when the log has no `IMU`.
//! The IMU and compass instances are not paired: the first IMU serves
//! every compass. Attitude, GPS, battery and gyro are carried to the
//! compass's times by the importers' shared [`super::import::rules::Series`].
//!
//! One room per job: the log's self-describing format read message by
//! message ([`reader`]); ArduPilot's compass correction and its inverse
//! ([`correction`], shared with the MAVLink telemetry log's import); the
//! messages collected by kind and carried to each compass sample
//! ([`collect`]); the import's options, report and entry points, here.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::recording::Recording;

mod collect;
mod correction;
mod reader;

use collect::{collect, rows};
pub(crate) use correction::{compass_matrix, solve3};
pub use reader::{read_messages, Message, SkipCounts, FMT_TYPE};

/// Why a log could not be read or imported.
#[derive(Debug, thiserror::Error)]
pub enum DataFlashError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// No FMT message: not a DataFlash log.
    #[error("no FMT message (0xA3 0x95 0x80) in {bytes} bytes: not an ArduPilot DataFlash .bin log (a .log text log or a tlog is not read here)")]
    NotDataFlash {
        /// Size of the input.
        bytes: usize,
    },
    /// A FMT message that contradicts itself.
    #[error("FMT at byte {offset}: message `{name}` (type {type_id}): {reason}")]
    BadFormat {
        /// Byte offset of the FMT message.
        offset: usize,
        /// The message name.
        name: String,
        /// Its type.
        type_id: u8,
        /// What is wrong.
        reason: String,
    },
    /// The log has no magnetometer messages of the instance asked for.
    #[error("no MAG messages for compass instance {instance} (instances in the log: {found:?})")]
    NoMag {
        /// The instance asked for.
        instance: u8,
        /// Instances present.
        found: Vec<u8>,
    },
    /// A message lacks a field the import needs.
    #[error("message `{message}` has no field `{field}` (its fields: {fields})")]
    MissingField {
        /// The message.
        message: String,
        /// The field.
        field: &'static str,
        /// Its fields.
        fields: String,
    },
    /// Time goes backwards.
    #[error("MAG time goes backwards at {t_s} s after {previous_s} s (a reboot inside the log?): split the log first")]
    TimeBackwards {
        /// The time.
        t_s: f64,
        /// The one before.
        previous_s: f64,
    },
    /// The compass's correction matrix cannot be inverted.
    #[error("COMPASS scale/DIA/ODI of instance {instance} make a singular matrix at {t_s} s: the raw field cannot be recovered")]
    Singular {
        /// Compass instance.
        instance: u8,
        /// Time of the message.
        t_s: f64,
    },
}

/// What to import.
#[derive(Debug, Clone, Copy)]
pub struct ImportOptions {
    /// Compass instance (0 = the first).
    pub mag_instance: u8,
    /// GPS course is used as the reference heading only at this ground speed or more, m/s.
    pub min_course_speed_mps: f64,
    /// Attitude, GPS and battery values older than this at a MAG sample are not used, s.
    pub max_age_s: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { mag_instance: 0, min_course_speed_mps: 0.5, max_age_s: 1.0 }
    }
}

/// The imported recording, its extra columns and what happened.
#[derive(Debug, Clone)]
pub struct Imported {
    /// `t, mx, my, mz` (raw, mGauss), `roll_deg, pitch_deg`, `ref_heading_deg`
    /// (GPS course at speed), `lat_deg, lon_deg`, `motor_current_a` (BAT
    /// `Curr` of the first battery monitor, A), `gx, gy, gz` (the first
    /// IMU's gyro, rad/s, body frame).
    pub recording: Recording,
    /// ATT `Yaw`, degrees (the autopilot's own heading, from this compass).
    pub ahrs_yaw_deg: Vec<f64>,
    /// GPS `Spd`, m/s over ground.
    pub gps_speed_mps: Vec<f64>,
    /// The report.
    pub report: ImportReport,
}

/// Counts and notes of an import (`magcal import --json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ImportReport {
    /// Rows written (MAG messages of the instance).
    pub rows: usize,
    /// Messages read by name.
    pub messages: std::collections::BTreeMap<String, usize>,
    /// What the reader skipped.
    pub skipped: SkipCounts,
    /// Rows with roll and pitch.
    pub rows_with_attitude: usize,
    /// Rows with a GPS course as reference.
    pub rows_with_course: usize,
    /// Rows with a battery current.
    pub rows_with_current: usize,
    /// Rows with the first IMU's gyro.
    #[serde(default)]
    pub rows_with_gyro: usize,
    /// Each column written, with the message, field and instance it comes
    /// from; `ref_heading_deg` is the GPS course, independent of the
    /// compass; `ahrs_yaw_deg`, the autopilot's heading from its own
    /// compasses, is never the reference.
    #[serde(default)]
    pub column_sources: std::collections::BTreeMap<String, String>,
    /// Notes (assumptions made).
    pub notes: Vec<String>,
}

/// Imports a log: one row per `MAG` message of the instance.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, DataFlashError> {
    let mut report = ImportReport::default();
    let mut c = collect(bytes, opts, &mut report)?;
    if c.mag.is_empty() {
        c.instances.sort_unstable();
        return Err(DataFlashError::NoMag { instance: opts.mag_instance, found: c.instances });
    }
    Ok(rows(&c, opts, &mut report))
}

/// Reads a log file and imports it.
pub fn import_file(path: &Path, opts: &ImportOptions) -> Result<Imported, DataFlashError> {
    let bytes = std::fs::read(path).map_err(|source| DataFlashError::Io { path: path.into(), source })?;
    import(&bytes, opts)
}

#[cfg(test)]
mod tests;
