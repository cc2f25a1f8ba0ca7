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
//! compass's times by the importers' shared [`rules::Series`].

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::import::rules::{self, Kind, Series};
use super::recording::Recording;
use super::table::col;

/// The message type of `FMT`.
pub const FMT_TYPE: u8 = 128;
const HEAD: [u8; 2] = [0xA3, 0x95];

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

/// One message format from a `FMT` message.
#[derive(Debug, Clone, PartialEq)]
pub struct Format {
    /// Message type.
    pub type_id: u8,
    /// Name (`MAG`, `ATT`, …).
    pub name: String,
    /// Total length including the 3-byte header.
    pub length: usize,
    /// One character per field.
    pub format: String,
    /// Field labels.
    pub labels: Vec<String>,
}

/// A field's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// Numbers (integers, floats, the scaled `c C e E L`).
    Num(f64),
    /// `n N Z` text, NULs removed.
    Text(String),
    /// `a`: `int16[32]`.
    Array(Vec<i16>),
}

/// One decoded message.
#[derive(Debug, Clone, PartialEq)]
pub struct Message<'f> {
    /// Its format.
    pub format: &'f Format,
    /// Byte offset in the log.
    pub offset: usize,
    /// Values, in the order of `format.labels`.
    pub values: Vec<Value>,
}

impl Message<'_> {
    /// A numeric field by label.
    pub fn num(&self, label: &str) -> Option<f64> {
        let i = self.format.labels.iter().position(|l| l == label)?;
        match &self.values[i] {
            Value::Num(v) => Some(*v),
            _ => None,
        }
    }

    /// A numeric field the import needs.
    fn need(&self, label: &'static str) -> Result<f64, DataFlashError> {
        self.num(label).ok_or_else(|| DataFlashError::MissingField {
            message: self.format.name.clone(),
            field: label,
            fields: self.format.labels.join(","),
        })
    }

    /// A text field by label.
    pub fn text(&self, label: &str) -> Option<&str> {
        let i = self.format.labels.iter().position(|l| l == label)?;
        match &self.values[i] {
            Value::Text(s) => Some(s),
            _ => None,
        }
    }
}

/// Size in bytes of one format character.
fn field_size(c: char) -> Option<usize> {
    Some(match c {
        'b' | 'B' | 'M' => 1,
        'h' | 'H' | 'c' | 'C' | 'g' => 2,
        'i' | 'I' | 'e' | 'E' | 'L' | 'f' | 'n' => 4,
        'd' | 'q' | 'Q' => 8,
        'N' => 16,
        'Z' | 'a' => 64,
        _ => return None,
    })
}

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).into_owned()
}

/// IEEE half float.
fn half(bits: u16) -> f64 {
    let (sign, exp, frac) = (if bits >> 15 == 1 { -1.0 } else { 1.0 }, (bits >> 10) & 0x1F, (bits & 0x3FF) as f64);
    sign * match exp {
        0 => frac * 2f64.powi(-24),
        31 => {
            if frac == 0.0 {
                f64::INFINITY
            } else {
                f64::NAN
            }
        }
        e => (1.0 + frac / 1024.0) * 2f64.powi(e as i32 - 15),
    }
}

fn decode(format: &str, body: &[u8]) -> Vec<Value> {
    let mut out = Vec::with_capacity(format.len());
    let mut o = 0;
    for c in format.chars() {
        let n = field_size(c).unwrap_or(0);
        let b = &body[o..o + n];
        let le2 = || [b[0], b[1]];
        let le4 = || [b[0], b[1], b[2], b[3]];
        let le8 = || [b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]];
        out.push(match c {
            'b' => Value::Num(b[0] as i8 as f64),
            'B' | 'M' => Value::Num(b[0] as f64),
            'h' => Value::Num(i16::from_le_bytes(le2()) as f64),
            'H' => Value::Num(u16::from_le_bytes(le2()) as f64),
            'c' => Value::Num(i16::from_le_bytes(le2()) as f64 * 0.01),
            'C' => Value::Num(u16::from_le_bytes(le2()) as f64 * 0.01),
            'g' => Value::Num(half(u16::from_le_bytes(le2()))),
            'i' => Value::Num(i32::from_le_bytes(le4()) as f64),
            'I' => Value::Num(u32::from_le_bytes(le4()) as f64),
            'e' => Value::Num(i32::from_le_bytes(le4()) as f64 * 0.01),
            'E' => Value::Num(u32::from_le_bytes(le4()) as f64 * 0.01),
            'L' => Value::Num(i32::from_le_bytes(le4()) as f64 * 1e-7),
            'f' => Value::Num(f32::from_le_bytes(le4()) as f64),
            'd' => Value::Num(f64::from_le_bytes(le8())),
            'q' => Value::Num(i64::from_le_bytes(le8()) as f64),
            'Q' => Value::Num(u64::from_le_bytes(le8()) as f64),
            'n' | 'N' | 'Z' => Value::Text(text(b)),
            _ => Value::Array(b.chunks_exact(2).map(|p| i16::from_le_bytes([p[0], p[1]])).collect()),
        });
        o += n;
    }
    out
}

/// What the reader skipped (reported, never silent).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SkipCounts {
    /// Bytes skipped to find the next message header (corruption).
    pub garbage_bytes: usize,
    /// Messages of a type no FMT described.
    pub unknown_type_messages: usize,
    /// A truncated message at the end of the file.
    pub truncated_tail_bytes: usize,
    /// ATT, GPS, BAT/CURR and IMU samples dropped because their time went
    /// back (a reboot inside the log?).
    #[serde(default)]
    pub out_of_order_samples: usize,
}

/// Reads every message of a log (`FMT` included), calling `each` in file
/// order.
pub fn read_messages(bytes: &[u8], mut each: impl FnMut(&Message)) -> Result<SkipCounts, DataFlashError> {
    let mut formats: HashMap<u8, Format> = HashMap::new();
    let fmt_fmt = Format {
        type_id: FMT_TYPE,
        name: "FMT".into(),
        length: 89,
        format: "BBnNZ".into(),
        labels: ["Type", "Length", "Name", "Format", "Columns"].map(String::from).to_vec(),
    };
    formats.insert(FMT_TYPE, fmt_fmt);
    let mut skips = SkipCounts::default();
    let mut seen_fmt = false;
    let mut o = 0;
    while o + 3 <= bytes.len() {
        if bytes[o..o + 2] != HEAD {
            skips.garbage_bytes += 1;
            o += 1;
            continue;
        }
        let t = bytes[o + 2];
        let Some(f) = formats.get(&t) else {
            // An undescribed type: its length is unknown; resynchronise on the next header.
            skips.unknown_type_messages += 1;
            o += 3;
            continue;
        };
        if o + f.length > bytes.len() {
            skips.truncated_tail_bytes = bytes.len() - o;
            break;
        }
        let values = decode(&f.format, &bytes[o + 3..o + f.length]);
        if t == FMT_TYPE {
            seen_fmt = true;
            let num = |i: usize| if let Value::Num(v) = values[i] { v } else { 0.0 };
            let txt = |i: usize| if let Value::Text(s) = &values[i] { s.clone() } else { String::new() };
            let (type_id, length, name, format) = (num(0) as u8, num(1) as usize, txt(2), txt(3));
            let labels: Vec<String> = txt(4).split(',').filter(|l| !l.is_empty()).map(String::from).collect();
            let bad = |reason: String| DataFlashError::BadFormat { offset: o, name: name.clone(), type_id, reason };
            if let Some(c) = format.chars().find(|c| field_size(*c).is_none()) {
                return Err(bad(format!("unknown format character `{c}` in `{format}`")));
            }
            let size: usize = 3 + format.chars().filter_map(field_size).sum::<usize>();
            if size != length {
                return Err(bad(format!("format `{format}` makes {size} bytes, the FMT says {length}")));
            }
            if labels.len() != format.len() {
                return Err(bad(format!("{} labels for {} fields", labels.len(), format.len())));
            }
            if type_id != FMT_TYPE {
                formats.insert(type_id, Format { type_id, name, length, format, labels });
            }
            if let Some(fmt) = formats.get(&FMT_TYPE) {
                each(&Message { format: fmt, offset: o, values });
            }
        } else {
            each(&Message { format: f, offset: o, values });
        }
        let len = formats.get(&t).map_or(3, |f| f.length);
        o += len;
    }
    if !seen_fmt {
        return Err(DataFlashError::NotDataFlash { bytes: bytes.len() });
    }
    Ok(skips)
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

/// The correction matrix `s·Mat` of one compass instance from its
/// parameters (names per `AP_Compass`: the first compass `COMPASS_DIA_X`,
/// the second `COMPASS_DIA2_X`, …), as `AP_Compass_Backend::correct_field`
/// applies it: zero diagonals taken as 1, `COMPASS_SCALE` only within
/// 1/1.5…1.5. Also the parameters missing (ArduPilot's defaults taken: DIA
/// 1, ODI 0, SCALE 1). Shared with the MAVLink telemetry log's import.
pub(crate) fn compass_matrix(params: &HashMap<String, f64>, instance: u8) -> ([[f64; 3]; 3], Vec<String>) {
    let suffix = if instance == 0 { String::new() } else { (instance + 1).to_string() };
    let mut missing = Vec::new();
    let mut get = |base: &str, axis: &str, default: f64| {
        let name = format!("COMPASS_{base}{suffix}{axis}");
        params.get(&name).copied().unwrap_or_else(|| {
            missing.push(name);
            default
        })
    };
    let mut dia = [get("DIA", "_X", 1.0), get("DIA", "_Y", 1.0), get("DIA", "_Z", 1.0)];
    let odi = [get("ODI", "_X", 0.0), get("ODI", "_Y", 0.0), get("ODI", "_Z", 0.0)];
    let scale = get("SCALE", "", 1.0);
    if dia == [0.0; 3] {
        dia = [1.0; 3]; // correct_field sets zero diagonals to 1
    }
    // have_scale_factor: applied only within COMPASS_MIN/MAX_SCALE_FACTOR.
    let s = if (1.0 / 1.5..=1.5).contains(&scale) { scale } else { 1.0 };
    ([[dia[0], odi[0], odi[1]], [odi[0], dia[1], odi[2]], [odi[1], odi[2], dia[2]]].map(|r| r.map(|v| v * s)), missing)
}

/// The DataFlash import's matrix: [`compass_matrix`], the parameters
/// missing said once.
fn compass_matrix_noted(params: &HashMap<String, f64>, instance: u8, notes: &mut Vec<String>) -> [[f64; 3]; 3] {
    let (m, missing) = compass_matrix(params, instance);
    if !missing.is_empty() {
        let note = format!("no PARM {} in the log before the first MAG: taken as ArduPilot's defaults (DIA 1, ODI 0, SCALE 1)", missing.join(", "));
        if !notes.contains(&note) {
            notes.push(note);
        }
    }
    m
}

/// `m⁻¹·v`, `None` when `m` is singular.
pub(crate) fn solve3(m: &[[f64; 3]; 3], v: [f64; 3]) -> Option<[f64; 3]> {
    let inv = calib_core::linalg::inverse3(m)?;
    Some([0, 1, 2].map(|i| inv[i][0] * v[0] + inv[i][1] * v[1] + inv[i][2] * v[2]))
}

/// What the messages of a log hold, in time order per kind.
struct Collected {
    params: HashMap<String, f64>,
    /// ATT Roll, Pitch, Yaw.
    att: Series<3>,
    /// GPS instance 0: Status, Lat, Lng, Spd, GCrs.
    gps: Series<5>,
    /// BAT/CURR instance 0: Curr.
    bat: Series<1>,
    /// The first IMU's gyro (IMU with I = 0, or IMU of older logs), rad/s.
    imu: Series<3>,
    /// GYR of the first IMU (high-rate samples), rad/s: used without IMU.
    gyr: Series<3>,
    /// The chosen compass's raw field: (time, raw).
    mag: Vec<(f64, [f64; 3])>,
    /// Every compass instance seen.
    instances: Vec<u8>,
}

impl Default for Collected {
    fn default() -> Self {
        Self {
            params: HashMap::new(),
            att: Series::new([Kind::Linear, Kind::Linear, Kind::Heading360]),
            gps: Series::new([Kind::Latest; 5]),
            bat: Series::new([Kind::Latest]),
            imu: Series::new([Kind::Linear; 3]),
            gyr: Series::new([Kind::Linear; 3]),
            mag: Vec::new(),
            instances: Vec::new(),
        }
    }
}

impl Collected {
    /// A compass message (`MAG`, `MAG2`, `MAG3`): the raw field of the
    /// chosen instance, the autopilot's corrections undone.
    fn mag(&mut self, m: &Message, name: &str, opts: &ImportOptions, report: &mut ImportReport) -> Result<(), DataFlashError> {
        let inst = match (name, m.num("I")) {
            ("MAG", Some(i)) => i as u8,
            ("MAG", None) => 0,
            ("MAG2", _) => 1,
            _ => 2,
        };
        if !self.instances.contains(&inst) {
            self.instances.push(inst);
        }
        if inst != opts.mag_instance {
            return Ok(());
        }
        let t = m.need("TimeUS")? * 1e-6;
        let field = [m.need("MagX")?, m.need("MagY")?, m.need("MagZ")?];
        let ofs = [m.need("OfsX")?, m.need("OfsY")?, m.need("OfsZ")?];
        let mo = [m.num("MOX").unwrap_or(0.0), m.num("MOY").unwrap_or(0.0), m.num("MOZ").unwrap_or(0.0)];
        let mat = compass_matrix_noted(&self.params, inst, &mut report.notes);
        let corrected = solve3(&mat, [0, 1, 2].map(|k| field[k] - mo[k])).ok_or(DataFlashError::Singular { instance: inst, t_s: t })?;
        let raw = [0, 1, 2].map(|k| corrected[k] - ofs[k]);
        if let Some((prev, _)) = self.mag.last() {
            if t < *prev {
                return Err(DataFlashError::TimeBackwards { t_s: t, previous_s: *prev });
            }
        }
        self.mag.push((t, raw));
        Ok(())
    }

    /// One message of any kind.
    fn message(&mut self, m: &Message, opts: &ImportOptions, report: &mut ImportReport) -> Result<(), DataFlashError> {
        match m.format.name.as_str() {
            "PARM" => {
                if let (Some(n), Some(v)) = (m.text("Name"), m.num("Value")) {
                    self.params.insert(n.to_string(), v);
                }
            }
            name @ ("MAG" | "MAG2" | "MAG3") => self.mag(m, name, opts, report)?,
            "ATT" => self.att.push(m.need("TimeUS")? * 1e-6, [m.need("Roll")?, m.need("Pitch")?, m.need("Yaw")?]),
            "GPS" if m.num("I").unwrap_or(0.0) == 0.0 => {
                self.gps.push(m.need("TimeUS")? * 1e-6, [m.need("Status")?, m.need("Lat")?, m.need("Lng")?, m.need("Spd")?, m.need("GCrs")?])
            }
            "BAT" | "CURR" if m.num("Inst").or(m.num("I")).unwrap_or(0.0) == 0.0 => self.bat.push(m.need("TimeUS")? * 1e-6, [m.need("Curr")?]),
            // The first IMU: `IMU` with I = 0 (older logs: `IMU`, with `IMU2`, `IMU3` for the others).
            "IMU" if m.num("I").unwrap_or(0.0) == 0.0 => self.imu.push(m.need("TimeUS")? * 1e-6, [m.need("GyrX")?, m.need("GyrY")?, m.need("GyrZ")?]),
            "GYR" if m.num("I").unwrap_or(0.0) == 0.0 => self.gyr.push(m.num("SampleUS").map_or_else(|| m.need("TimeUS"), Ok)? * 1e-6, [m.need("GyrX")?, m.need("GyrY")?, m.need("GyrZ")?]),
            _ => {}
        }
        Ok(())
    }
}

/// Reads every message of the log (the first bad one stops it).
fn collect(bytes: &[u8], opts: &ImportOptions, report: &mut ImportReport) -> Result<Collected, DataFlashError> {
    let mut c = Collected::default();
    let mut first_error: Option<DataFlashError> = None;
    let skipped = read_messages(bytes, |m| {
        if first_error.is_some() {
            return;
        }
        *report.messages.entry(m.format.name.clone()).or_default() += 1;
        if let Err(e) = c.message(m, opts, report) {
            first_error = Some(e);
        }
    })?;
    if let Some(e) = first_error {
        return Err(e);
    }
    report.skipped = skipped;
    Ok(c)
}

/// The recording: one row per compass sample, the attitude and the first
/// IMU's gyro interpolated to it, the latest GPS fix and battery current
/// ([`rules::Series`]).
fn rows(c: &Collected, opts: &ImportOptions, report: &mut ImportReport) -> Imported {
    let (att, gps, bat, mag) = (&c.att, &c.gps, &c.bat, &c.mag);
    // The gyro: IMU (the rates the autopilot uses); GYR (high-rate samples) only without IMU.
    let (gyro, gyro_from) = if !c.imu.is_empty() { (&c.imu, "IMU instance 0 (IMU with I = 0, or IMU of older logs) GyrX/Y/Z, rad/s") } else { (&c.gyr, "GYR instance 0 GyrX/Y/Z (high-rate samples; the log has no IMU), rad/s") };
    let n = mag.len();
    let (mut roll, mut pitch, mut course, mut lat, mut lon) = (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
    let (mut yaw, mut speed, mut current) = (vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]);
    let mut g = [vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]];
    for (i, &(t, _)) in mag.iter().enumerate() {
        // Attitude: linear between the ATT samples around t (yaw across ±180°).
        if let Some(v) = att.at(t, opts.max_age_s) {
            (roll[i], pitch[i], yaw[i]) = (v[0], v[1], v[2]);
            report.rows_with_attitude += 1;
        }
        // GPS: the latest fix (Status ≥ 3: 3D); the course only at speed.
        if let Some(v) = gps.at(t, opts.max_age_s) {
            if v[0] >= 3.0 {
                (lat[i], lon[i], speed[i]) = (v[1], v[2], v[3]);
                course[i] = rules::course_at_speed_deg(v[4], v[3], opts.min_course_speed_mps);
                if course[i].is_finite() {
                    report.rows_with_course += 1;
                }
            }
        }
        if let Some(v) = bat.at(t, opts.max_age_s) {
            current[i] = v[0];
            report.rows_with_current += 1;
        }
        if let Some(v) = gyro.at(t, opts.max_age_s) {
            for k in 0..3 {
                g[k][i] = v[k];
            }
            report.rows_with_gyro += 1;
        }
    }
    report.skipped.out_of_order_samples = att.out_of_order + gps.out_of_order + bat.out_of_order + gyro.out_of_order;
    report.rows = n;
    let k = opts.mag_instance;
    for (column, source) in [
        ("mx, my, mz", format!("MAG instance {k} (MAG with I = {k}, or MAG{} of older logs), MagX/Y/Z with ArduPilot's correction undone: the raw field", if k == 0 { String::new() } else { (k + 1).to_string() })),
        (col::ROLL_DEG, "ATT Roll".to_string()),
        (col::PITCH_DEG, "ATT Pitch".to_string()),
        (col::REF_HEADING_DEG, format!("GPS instance 0 GCrs (course over ground) with a 3D fix at a ground speed of {} m/s or more", opts.min_course_speed_mps)),
        ("ahrs_yaw_deg", "ATT Yaw: the autopilot's own heading, from its compasses (not a reference)".to_string()),
        (col::GPS_SPEED_MPS, "GPS instance 0 Spd".to_string()),
        (col::LAT_DEG, "GPS instance 0 Lat".to_string()),
        (col::LON_DEG, "GPS instance 0 Lng".to_string()),
        (col::MOTOR_CURRENT_A, "BAT/CURR instance 0 Curr".to_string()),
        ("gx, gy, gz", format!("{gyro_from}, linear between the samples around each MAG time")),
    ] {
        report.column_sources.insert(column.to_string(), source);
    }
    let [gx, gy, gz] = g;
    let recording = Recording {
        t_s: Some(mag.iter().map(|m| m.0).collect()),
        mag: mag.iter().map(|m| m.1).collect(),
        roll_deg: Some(roll),
        pitch_deg: Some(pitch),
        ref_heading_deg: Some(course),
        lat_deg: Some(lat),
        lon_deg: Some(lon),
        motor_current_a: Some(current),
        gx_rad_s: Some(gx),
        gy_rad_s: Some(gy),
        gz_rad_s: Some(gz),
        ..Recording::default()
    };
    Imported { recording, ahrs_yaw_deg: yaw, gps_speed_mps: speed, report: std::mem::take(report) }
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
mod tests {
    use super::*;

    fn fmt(type_id: u8, name: &str, format: &str, labels: &str) -> Vec<u8> {
        let len: usize = 3 + format.chars().map(|c| field_size(c).unwrap()).sum::<usize>();
        let mut b = vec![0xA3, 0x95, FMT_TYPE, type_id, len as u8];
        let mut pad = |s: &str, n: usize| {
            let mut v = s.as_bytes().to_vec();
            v.resize(n, 0);
            b.extend(v);
        };
        pad(name, 4);
        pad(format, 16);
        pad(labels, 64);
        b
    }

    #[test]
    fn refusals_and_resynchronisation() {
        assert!(matches!(import(b"hello", &ImportOptions::default()), Err(DataFlashError::NotDataFlash { .. })));
        // A FMT whose length disagrees with its format.
        let mut bad = fmt(200, "XYZ", "Qh", "TimeUS,A");
        bad[4] = 20;
        let e = import(&bad, &ImportOptions::default()).unwrap_err();
        assert!(e.to_string().contains("makes 13 bytes, the FMT says 20"), "{e}");
        // A log with a MAG format, junk bytes, then one MAG of instance 1 only.
        let mut log = fmt(201, "MAG", "QBhhhhhh", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ");
        log.extend([1, 2, 3]);
        log.extend([0xA3, 0x95, 201]);
        log.extend(5_000_000u64.to_le_bytes());
        log.push(1);
        for v in [100i16, 200, 300, 10, 20, 30] {
            log.extend(v.to_le_bytes());
        }
        let e = import(&log, &ImportOptions::default()).unwrap_err();
        assert!(matches!(&e, DataFlashError::NoMag { instance: 0, found } if found == &vec![1]), "{e}");
        let ok = import(&log, &ImportOptions { mag_instance: 1, ..Default::default() }).unwrap();
        assert_eq!(ok.recording.mag[0], [90.0, 180.0, 270.0]);
        assert_eq!(ok.report.skipped.garbage_bytes, 3);
        assert_eq!(ok.report.notes.len(), 1, "defaults assumed and said");
        // Every column says where it came from; the reference is the course.
        assert!(ok.report.column_sources["mx, my, mz"].starts_with("MAG instance 1"));
        assert!(ok.report.column_sources[col::REF_HEADING_DEG].starts_with("GPS instance 0 GCrs"));
    }

    #[test]
    fn the_first_imus_gyro_at_each_mag_time() {
        let msg = |t: u8, body: Vec<u8>| [vec![0xA3, 0x95, t], body].concat();
        let mag = |t_us: u64| {
            let mut b = t_us.to_le_bytes().to_vec();
            b.push(0);
            for v in [1i16, 2, 3, 0, 0, 0] {
                b.extend(v.to_le_bytes());
            }
            msg(201, b)
        };
        let gyro = |t: u8, t_us: u64, i: u8, sample_us: Option<u64>, g: [f32; 3]| {
            let mut b = t_us.to_le_bytes().to_vec();
            b.push(i);
            if let Some(s) = sample_us {
                b.extend(s.to_le_bytes());
            }
            for v in g {
                b.extend(v.to_le_bytes());
            }
            msg(t, b)
        };
        let mut log = fmt(201, "MAG", "QBhhhhhh", "TimeUS,I,MagX,MagY,MagZ,OfsX,OfsY,OfsZ");
        log.extend(fmt(202, "IMU", "QBfff", "TimeUS,I,GyrX,GyrY,GyrZ"));
        log.extend(fmt(203, "GYR", "QBQfff", "TimeUS,I,SampleUS,GyrX,GyrY,GyrZ"));
        let mut with_imu = log.clone();
        with_imu.extend(gyro(202, 900_000, 0, None, [0.1, 0.0, -1.0]));
        with_imu.extend(gyro(202, 1_000_000, 1, None, [9.0, 9.0, 9.0])); // the second IMU: not used
        with_imu.extend(gyro(203, 1_000_000, 0, Some(1_000_000), [5.0, 5.0, 5.0])); // GYR: only without IMU
        with_imu.extend(gyro(202, 1_100_000, 0, None, [0.3, 0.5, -1.0]));
        with_imu.extend(mag(1_000_000));
        let im = import(&with_imu, &ImportOptions::default()).unwrap();
        let g = [&im.recording.gx_rad_s, &im.recording.gy_rad_s, &im.recording.gz_rad_s].map(|c| c.as_ref().unwrap()[0]);
        for (got, want) in g.iter().zip([0.2, 0.25, -1.0]) {
            assert!((got - want).abs() < 1e-6, "{g:?}");
        }
        assert!(im.report.column_sources["gx, gy, gz"].starts_with("IMU instance 0"));
        assert_eq!(im.report.rows_with_gyro, 1);
        // GYR alone: its sample times.
        log.extend(gyro(203, 2_000_000, 0, Some(950_000), [0.4, 0.0, 0.0]));
        log.extend(gyro(203, 2_000_000, 0, Some(1_050_000), [0.6, 0.0, 0.0]));
        log.extend(mag(1_000_000));
        let im = import(&log, &ImportOptions::default()).unwrap();
        assert!((im.recording.gx_rad_s.as_ref().unwrap()[0] - 0.5).abs() < 1e-6);
        assert!(im.report.column_sources["gx, gy, gz"].starts_with("GYR instance 0"));
    }

}
