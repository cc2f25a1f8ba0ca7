//! One importer for the logs vehicles already write: ArduPilot DataFlash,
//! NMEA 0183, MAVLink telemetry logs, PX4 ULog, ROS 2 bags (MCAP and
//! sqlite3) and NMEA 2000 in canboat's text formats.
//!
//! Every format is a module that yields the same [`Imported`]: columns by
//! their names in the column registry ([`crate::data::table::col`]) and its
//! units (angles in degrees, rates in rad/s, speeds in m/s; the field in the
//! unit [`ImportReport::field_unit`] says), one row per compass sample on
//! one clock ([`ImportReport::clock`]), a report of the messages read and of
//! every refusal by kind, and each column's [`ColumnSource`]: the message,
//! instance, topic, talker or PGN it comes from and its [`Role`] (the
//! compass itself, an independent reference, the vehicle's own estimate, or
//! another sensor). The rules formats share are in [`rules`], written once.
//!
//! The format is found from the content ([`Format::detect`]: magic bytes,
//! the first line) or named ([`Format::from_name`]).

pub(crate) mod mcap;
pub(crate) mod nmea2000;
pub(crate) mod ros2;
pub(crate) mod rules;
pub(crate) mod sqlite3;
pub(crate) mod tlog;
pub(crate) mod ulog;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::table::{col, write_table, TableError, COLUMNS};
use super::{dataflash, nmea};

/// A log format the importer reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Format {
    /// ArduPilot / ArduSub DataFlash binary log (`.bin`).
    Dataflash,
    /// NMEA 0183 text (`$HCHDG`, `$GPRMC`, …).
    Nmea0183,
    /// MAVLink telemetry log (`.tlog`: BlueOS, QGroundControl, MAVProxy).
    Tlog,
    /// PX4 ULog (`.ulg`).
    Ulog,
    /// ROS 2 bag, MCAP storage (`.mcap`).
    Mcap,
    /// ROS 2 bag, sqlite3 storage (`.db3`).
    Sqlite3,
    /// NMEA 2000 in canboat's text formats (FAST, PLAIN, Actisense).
    Nmea2000,
}

impl Format {
    /// Every format, in the order [`Format::detect`] tries them.
    pub const ALL: [Format; 7] = [Format::Dataflash, Format::Ulog, Format::Mcap, Format::Sqlite3, Format::Tlog, Format::Nmea2000, Format::Nmea0183];

    /// The name `--format` takes.
    pub fn name(self) -> &'static str {
        match self {
            Format::Dataflash => "dataflash",
            Format::Nmea0183 => "nmea0183",
            Format::Tlog => "tlog",
            Format::Ulog => "ulog",
            Format::Mcap => "mcap",
            Format::Sqlite3 => "sqlite3",
            Format::Nmea2000 => "nmea2000",
        }
    }

    /// What it is, for people.
    pub fn title(self) -> &'static str {
        match self {
            Format::Dataflash => "ArduPilot DataFlash",
            Format::Nmea0183 => "NMEA 0183",
            Format::Tlog => "MAVLink telemetry log",
            Format::Ulog => "PX4 ULog",
            Format::Mcap => "ROS 2 bag (MCAP)",
            Format::Sqlite3 => "ROS 2 bag (sqlite3)",
            Format::Nmea2000 => "NMEA 2000 (canboat text)",
        }
    }

    /// The format named `name` (as [`Format::name`] gives it).
    pub fn from_name(name: &str) -> Option<Format> {
        Format::ALL.into_iter().find(|f| f.name().eq_ignore_ascii_case(name))
    }

    /// The names, for messages.
    pub fn names() -> String {
        Format::ALL.map(Format::name).join(", ")
    }

    /// The format of a log from its first bytes (at least the first 4 KiB
    /// when the log has them), or `None`.
    pub fn detect(head: &[u8]) -> Option<Format> {
        Format::ALL.into_iter().find(|f| match f {
            Format::Dataflash => dataflash_looks_like(head),
            Format::Nmea0183 => nmea0183_looks_like(head),
            Format::Tlog => tlog::looks_like(head),
            Format::Ulog => ulog::looks_like(head),
            Format::Mcap => mcap::looks_like(head),
            Format::Sqlite3 => sqlite3::looks_like(head),
            Format::Nmea2000 => nmea2000::looks_like(head),
        })
    }
}

impl std::fmt::Display for Format {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A DataFlash log starts with a message header `A3 95` and the `FMT`
/// message's type (128).
fn dataflash_looks_like(head: &[u8]) -> bool {
    head.starts_with(&[0xA3, 0x95, dataflash::FMT_TYPE])
}

/// NMEA 0183: among the first lines, one starting (after an optional
/// logger's prefix) with `$` or `!`, a talker and a type, and none of
/// canboat's or another text format's shapes first.
fn nmea0183_looks_like(head: &[u8]) -> bool {
    let text = String::from_utf8_lossy(head);
    text.lines().take(20).any(|l| {
        let l = l.trim();
        l.find(['$', '!']).is_some_and(|i| l[i + 1..].chars().take(5).filter(|c| c.is_ascii_alphanumeric()).count() == 5)
    })
}

/// What to import.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// The GNSS course is a reference heading only at this ground speed or
    /// more, m/s ([`rules::course_at_speed_deg`]).
    pub min_course_speed_mps: f64,
    /// The magnetometer instance to import (`None`: the first; the report
    /// says when there were several).
    pub instance: Option<u32>,
    /// The magnetometer topic, when a ROS 2 bag or a PX4 ULog holds several.
    pub topic: Option<String>,
    /// NMEA 0183: a talker whose `HDT` is an independent true heading.
    pub reference_talker: Option<String>,
    /// Samples of another message older than this at a compass sample are
    /// not used for it, s.
    pub max_age_s: f64,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { min_course_speed_mps: 0.5, instance: None, topic: None, reference_talker: None, max_age_s: 1.0 }
    }
}

/// What a column is, for judging a compass with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Role {
    /// The compass being calibrated: its field or its heading.
    Compass,
    /// An independent heading reference (a GNSS compass, a gyrocompass,
    /// the course at speed): may judge the compass.
    Reference,
    /// The vehicle's own estimate from its compass (an autopilot's yaw):
    /// never a reference.
    OwnEstimate,
    /// Another sensor (attitude, gyro, position, speed, current).
    Sensor,
}

/// Where a column comes from.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ColumnSource {
    /// The message and field, with its instance, topic, talker or PGN and
    /// source address, and the unit conversion made.
    pub from: String,
    /// What it is.
    pub role: Role,
}

/// One column of an import.
#[derive(Debug, Clone)]
pub struct Column {
    /// Its name in the registry ([`crate::data::table::COLUMNS`]).
    pub name: &'static str,
    /// One value a row; NaN where a row has none.
    pub values: Vec<f64>,
}

/// Counts and notes of an import (`magcal import --json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ImportReport {
    /// The format read.
    pub format: Format,
    /// Rows written: one a compass sample.
    pub rows: usize,
    /// The last row's time minus the first's, s.
    pub duration_s: f64,
    /// What `t` counts (e.g. "s since the autopilot's boot").
    pub clock: String,
    /// The unit of `mx, my, mz`, when written (e.g. "mGauss", "nT").
    pub field_unit: Option<String>,
    /// The columns written, in order.
    pub columns: Vec<String>,
    /// Messages read, by kind (message name, topic, PGN, sentence type).
    pub messages: BTreeMap<String, usize>,
    /// Messages, frames or bytes skipped or refused, by kind of refusal.
    pub skipped: BTreeMap<String, usize>,
    /// Each column written and where it comes from.
    pub column_sources: BTreeMap<String, ColumnSource>,
    /// Notes: assumptions made, choices among instances, values present and
    /// not applied.
    pub notes: Vec<String>,
    /// What only one format reports.
    pub detail: Detail,
}

/// What only one format reports.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Detail {
    /// Nothing more.
    None,
    /// ArduPilot DataFlash.
    Dataflash(dataflash::ImportReport),
    /// NMEA 0183.
    Nmea0183(Box<nmea::NmeaReport>),
}

impl ImportReport {
    /// Every refusal counted, in one number.
    pub fn skipped_total(&self) -> usize {
        self.skipped.values().sum()
    }
}

/// An imported log: its columns (`t` first) and the report.
#[derive(Debug, Clone)]
pub struct Imported {
    /// `t` first, then the registry's order; every column as long as `t`.
    pub columns: Vec<Column>,
    /// The report.
    pub report: ImportReport,
}

impl Imported {
    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find(|c| c.name == name).map(|c| c.values.as_slice())
    }

    /// Writes the recording (CSV through [`crate::files`]: all or nothing).
    pub fn write(&self, path: &Path) -> Result<(), ImportError> {
        let header: Vec<&str> = self.columns.iter().map(|c| c.name).collect();
        let rows = (0..self.report.rows).map(|i| self.columns.iter().map(|c| c.values.get(i).copied().unwrap_or(f64::NAN)).collect());
        write_table(path, &header, rows)?;
        Ok(())
    }
}

/// Builds an [`Imported`] the same way for every format: the rows sorted by
/// time, columns checked against the registry, empty columns left out,
/// sources and counts in the report.
#[derive(Debug)]
pub struct Builder {
    format: Format,
    t_s: Vec<f64>,
    columns: Vec<(Column, ColumnSource)>,
    /// The report being filled; `rows`, `duration_s`, `columns` and
    /// `column_sources` are set by [`Builder::finish`].
    pub report: ImportReport,
}

impl Builder {
    /// A builder for `format` whose rows are at `t_s` on `clock`.
    pub fn new(format: Format, t_s: Vec<f64>, clock: impl Into<String>) -> Self {
        let report = ImportReport {
            format,
            rows: 0,
            duration_s: 0.0,
            clock: clock.into(),
            field_unit: None,
            columns: Vec::new(),
            messages: BTreeMap::new(),
            skipped: BTreeMap::new(),
            column_sources: BTreeMap::new(),
            notes: Vec::new(),
            detail: Detail::None,
        };
        Self { format, t_s, columns: Vec::new(), report }
    }

    /// Adds a column (a registry name, one value a row). A column with no
    /// finite value is left out; one of another length than `t` or a name
    /// not in the registry is an [`ImportError::Column`] (a fault of the
    /// importer, said rather than written wrong).
    pub fn column(&mut self, name: &'static str, values: Vec<f64>, from: impl Into<String>, role: Role) -> Result<(), ImportError> {
        if !COLUMNS.iter().any(|c| c.name == name) || name == col::T {
            return Err(ImportError::Column { format: self.format, detail: format!("{name} is not a column of the registry") });
        }
        if values.len() != self.t_s.len() {
            return Err(ImportError::Column { format: self.format, detail: format!("{name} has {} values for {} rows", values.len(), self.t_s.len()) });
        }
        if self.columns.iter().any(|(c, _)| c.name == name) {
            return Err(ImportError::Column { format: self.format, detail: format!("{name} given twice") });
        }
        if values.iter().any(|v| v.is_finite()) {
            self.columns.push((Column { name, values }, ColumnSource { from: from.into(), role }));
        }
        Ok(())
    }

    /// Counts `n` refusals of `kind` (nothing when `n` is 0).
    pub fn skip(&mut self, kind: &str, n: usize) {
        if n > 0 {
            *self.report.skipped.entry(kind.to_string()).or_default() += n;
        }
    }

    /// A note, once.
    pub fn note(&mut self, note: impl Into<String>) {
        let note = note.into();
        if !self.report.notes.contains(&note) {
            self.report.notes.push(note);
        }
    }

    /// The import: rows in time order (a stable sort: equal times keep the
    /// log's order), `t` first and the columns in the registry's order.
    pub fn finish(self) -> Result<Imported, ImportError> {
        let Builder { format, t_s, mut columns, mut report } = self;
        if t_s.is_empty() {
            return Err(ImportError::Column { format, detail: "no rows".into() });
        }
        if t_s.iter().any(|t| !t.is_finite()) {
            return Err(ImportError::Column { format, detail: "a row's time is not finite".into() });
        }
        let mut order: Vec<usize> = (0..t_s.len()).collect();
        order.sort_by(|&a, &b| t_s[a].total_cmp(&t_s[b]));
        let sorted = order.windows(2).all(|w| w[0] < w[1]);
        let permute = |v: Vec<f64>| if sorted { v } else { order.iter().map(|&i| v[i]).collect() };
        let rank = |name: &str| COLUMNS.iter().position(|c| c.name == name).unwrap_or(usize::MAX);
        columns.sort_by_key(|(c, _)| rank(c.name));
        report.rows = t_s.len();
        let t_s = permute(t_s);
        report.duration_s = t_s.last().copied().unwrap_or(0.0) - t_s.first().copied().unwrap_or(0.0);
        report.columns = std::iter::once(col::T.to_string()).chain(columns.iter().map(|(c, _)| c.name.to_string())).collect();
        let mut out = vec![Column { name: col::T, values: t_s }];
        for (c, source) in columns {
            report.column_sources.insert(c.name.to_string(), source);
            out.push(Column { name: c.name, values: permute(c.values) });
        }
        Ok(Imported { columns: out, report })
    }
}

/// Why a log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum ImportError {
    /// The log could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The log.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// No format recognised.
    #[error("the log's format is not recognised from its first bytes ({head}): name it with --format ({names})", names = Format::names())]
    UnknownFormat {
        /// The first bytes, escaped.
        head: String,
    },
    /// An instance asked for (or any) is not in the log.
    #[error("{sensor}: {}", match wanted { Some(w) => format!("no instance {w} in the log (instances found: {found:?})"), None => "no instance in the log".to_string() })]
    NoInstance {
        /// The sensor (message or topic).
        sensor: String,
        /// The instance asked for.
        wanted: Option<u32>,
        /// The instances found.
        found: Vec<u32>,
    },
    /// An option that does not apply to the log's format.
    #[error("{option} does not apply to a {} log", format.title())]
    Unsupported {
        /// The format.
        format: Format,
        /// The option (`--topic`, …).
        option: &'static str,
    },
    /// A column could not be built (a fault of the importer).
    #[error("{format}: {detail}")]
    Column {
        /// The format.
        format: Format,
        /// What went wrong.
        detail: String,
    },
    /// ArduPilot DataFlash.
    #[error(transparent)]
    Dataflash(#[from] dataflash::DataFlashError),
    /// NMEA 0183.
    #[error(transparent)]
    Nmea0183(#[from] nmea::NmeaError),
    /// MAVLink telemetry log.
    #[error(transparent)]
    Tlog(#[from] tlog::TlogError),
    /// PX4 ULog.
    #[error(transparent)]
    Ulog(#[from] ulog::UlogError),
    /// ROS 2 MCAP.
    #[error(transparent)]
    Mcap(#[from] mcap::McapError),
    /// ROS 2 sqlite3.
    #[error(transparent)]
    Sqlite3(#[from] sqlite3::Sqlite3Error),
    /// NMEA 2000.
    #[error(transparent)]
    Nmea2000(#[from] nmea2000::Nmea2000Error),
    /// The recording could not be written.
    #[error(transparent)]
    Output(#[from] TableError),
}

/// Imports a log held in memory, in `format` (see [`Format::detect`]).
pub fn import(bytes: &[u8], format: Format, opts: &ImportOptions) -> Result<Imported, ImportError> {
    let unsupported = |option| Err(ImportError::Unsupported { format, option });
    if opts.topic.is_some() && !matches!(format, Format::Mcap | Format::Sqlite3 | Format::Ulog) {
        return unsupported("--topic");
    }
    if opts.reference_talker.is_some() && format != Format::Nmea0183 {
        return unsupported("--reference-talker");
    }
    if opts.instance.is_some() && format == Format::Nmea0183 {
        return unsupported("--instance (an NMEA 0183 log holds headings, not a magnetometer's instances)");
    }
    match format {
        Format::Dataflash => from_dataflash(bytes, opts),
        Format::Nmea0183 => from_nmea0183(bytes, opts),
        Format::Tlog => tlog::import(bytes, opts),
        Format::Ulog => ulog::import(bytes, opts),
        Format::Mcap => mcap::import(bytes, opts),
        Format::Sqlite3 => sqlite3::import(bytes, opts),
        Format::Nmea2000 => nmea2000::import(bytes, opts),
    }
}

/// Reads a log file and imports it: in `format`, or the format its content
/// shows.
pub fn import_file(path: &Path, format: Option<Format>, opts: &ImportOptions) -> Result<Imported, ImportError> {
    let bytes = std::fs::read(path).map_err(|source| ImportError::Io { path: path.into(), source })?;
    let format = match format {
        Some(f) => f,
        None => Format::detect(&bytes[..bytes.len().min(64 * 1024)]).ok_or_else(|| ImportError::UnknownFormat { head: escaped_head(&bytes) })?,
    };
    import(&bytes, format, opts)
}

/// The first 16 bytes, printable as text or hex.
fn escaped_head(bytes: &[u8]) -> String {
    let head = &bytes[..bytes.len().min(16)];
    if bytes.is_empty() {
        "the file is empty".into()
    } else if head.iter().all(|b| b.is_ascii_graphic() || *b == b' ') {
        format!("{:?}", String::from_utf8_lossy(head))
    } else {
        head.iter().map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" ")
    }
}

/// ArduPilot DataFlash through [`dataflash::import`].
fn from_dataflash(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    let instance = match opts.instance {
        Some(i) => u8::try_from(i).map_err(|_| ImportError::NoInstance { sensor: "MAG".into(), wanted: Some(i), found: Vec::new() })?,
        None => 0,
    };
    let df = dataflash::ImportOptions { mag_instance: instance, min_course_speed_mps: opts.min_course_speed_mps, max_age_s: opts.max_age_s };
    let im = dataflash::import(bytes, &df)?;
    let rec = &im.recording;
    let mut b = Builder::new(Format::Dataflash, rec.t_s.clone().unwrap_or_default(), "s since the autopilot's boot (TimeUS)");
    b.report.field_unit = Some("mGauss".into());
    let src = |name: &str| im.report.column_sources.get(name).cloned().unwrap_or_default();
    for (k, name) in col::MAG.into_iter().enumerate() {
        b.column(name, rec.mag.iter().map(|m| m[k]).collect(), src("mx, my, mz"), Role::Compass)?;
    }
    let sensor = [(col::ROLL_DEG, &rec.roll_deg), (col::PITCH_DEG, &rec.pitch_deg), (col::LAT_DEG, &rec.lat_deg), (col::LON_DEG, &rec.lon_deg), (col::MOTOR_CURRENT_A, &rec.motor_current_a)];
    for (name, values) in sensor {
        if let Some(v) = values {
            b.column(name, v.clone(), src(name), Role::Sensor)?;
        }
    }
    if let Some(v) = &rec.ref_heading_deg {
        b.column(col::REF_HEADING_DEG, v.clone(), src(col::REF_HEADING_DEG), Role::Reference)?;
    }
    for (name, values) in col::GYRO.into_iter().zip([&rec.gx_rad_s, &rec.gy_rad_s, &rec.gz_rad_s]) {
        if let Some(v) = values {
            b.column(name, v.clone(), src("gx, gy, gz"), Role::Sensor)?;
        }
    }
    b.column(col::AHRS_YAW_DEG, im.ahrs_yaw_deg.clone(), src(col::AHRS_YAW_DEG), Role::OwnEstimate)?;
    b.column(col::GPS_SPEED_MPS, im.gps_speed_mps.clone(), src(col::GPS_SPEED_MPS), Role::Sensor)?;
    b.report.messages = im.report.messages.clone();
    let s = im.report.skipped;
    b.skip("corrupt_bytes", s.garbage_bytes);
    b.skip("messages_of_undescribed_types", s.unknown_type_messages);
    b.skip("truncated_tail_bytes", s.truncated_tail_bytes);
    b.skip("samples_out_of_time_order", s.out_of_order_samples);
    for n in &im.report.notes {
        b.note(n.clone());
    }
    b.report.detail = Detail::Dataflash(im.report);
    b.finish()
}

/// NMEA 0183 through [`nmea::import`].
fn from_nmea0183(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    let o = nmea::ImportOptions { min_course_speed_mps: opts.min_course_speed_mps, reference_talker: opts.reference_talker.clone() };
    let im = nmea::import(bytes, &o)?;
    let r = im.report;
    let t = im.columns.iter().find(|(n, _)| *n == col::T).map(|(_, v)| v.clone()).unwrap_or_default();
    let clock = match &r.start_utc {
        Some(start) => format!("s since {start}"),
        None => format!("s since {} UTC (no date in the log)", r.start_time_of_day_utc),
    };
    let mut b = Builder::new(Format::Nmea0183, t, clock);
    for (name, values) in im.columns.into_iter().filter(|(n, _)| *n != col::T) {
        let role = match name {
            col::COMPASS_HEADING_DEG => Role::Compass,
            col::REF_HEADING_DEG => Role::Reference,
            _ => Role::Sensor,
        };
        b.column(name, values, r.column_sources.get(name).cloned().unwrap_or_default(), role)?;
    }
    b.report.messages = r.used.clone();
    let untimed = r.untimed_before_first_time + r.untimed_after_last_time + r.untimed_in_gaps;
    for (kind, n) in [
        ("bad_checksum", r.bad_checksum),
        ("partial", r.partial),
        ("unknown_type", r.unknown),
        ("void_fix", r.void_fixes),
        ("empty_value", r.empty_values),
        ("another_compass", r.other_source),
        ("time_backwards", r.time_backwards),
        ("date_jump", r.date_jumps),
        ("compass_own_true_heading", r.compass_true_headings),
        ("true_heading_of_unplaced_talker", r.unplaced_true_headings),
        ("untimed", untimed),
    ] {
        b.skip(kind, n);
    }
    for n in &r.notes {
        b.note(n.clone());
    }
    for source in &r.unplaced_true_heading_sources {
        b.note(format!("if {source} is an independent heading sensor (not the compass relayed), give --reference-talker {}", source.get(..2).unwrap_or(source)));
    }
    b.report.detail = Detail::Nmea0183(Box::new(r));
    b.finish()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn formats_are_found_by_name_and_content() {
        for f in Format::ALL {
            assert_eq!(Format::from_name(f.name()), Some(f));
        }
        assert_eq!(Format::detect(b"$HCHDG,101.1,,,7.1,W*3C\r\n"), Some(Format::Nmea0183));
        assert_eq!(Format::detect(&[0xA3, 0x95, 128, 128, 89]), Some(Format::Dataflash));
        assert_eq!(Format::detect(b"t,mx,my,mz\n0,1,2,3\n"), None);
    }

    #[test]
    fn the_builder_sorts_rows_and_keeps_registry_order() {
        let mut b = Builder::new(Format::Nmea0183, vec![1.0, 0.0, 2.0], "s");
        b.column(col::REF_HEADING_DEG, vec![10.0, 0.0, 20.0], "x", Role::Reference).unwrap();
        b.column(col::MAG[0], vec![1.0, 0.0, 2.0], "x", Role::Compass).unwrap();
        b.column(col::LAT_DEG, vec![f64::NAN; 3], "x", Role::Sensor).unwrap();
        assert!(b.column("ahrs_yaw", vec![0.0; 3], "x", Role::Sensor).is_err());
        assert!(b.column(col::LON_DEG, vec![0.0; 2], "x", Role::Sensor).is_err());
        let im = b.finish().unwrap();
        assert_eq!(im.report.columns, ["t", "mx", "ref_heading_deg"]);
        assert_eq!(im.column("t").unwrap(), [0.0, 1.0, 2.0]);
        assert_eq!(im.column("ref_heading_deg").unwrap(), [0.0, 10.0, 20.0]);
        assert_eq!(im.report.duration_s, 2.0);
    }
}
