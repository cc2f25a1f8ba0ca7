//! NMEA 0183 logs to a recording (`magcal import --nmea`): a heading-only
//! compass (`HDG`, `HDM`), a true heading (`HDT`), the GPS (`RMC`, `VTG`,
//! `GGA`, `GLL`, `ZDA`) and the log's speed through water (`VHW`) as one
//! CSV of `docs/INTERFACES.md`.
//!
//! **Hand-written.** The `nmea` crate (0.8) was checked: it has no `HDG` or
//! `HDM` parser (only their names), refuses a sentence without a checksum
//! and tells a proprietary `$P…` sentence, a truncated line and an unknown
//! type apart only by error text; the import must count each of those by
//! kind and read the compass sentences with all their fields. The grammar
//! needed is small (comma-separated fields, an XOR checksum); the tests
//! check this reader against pynmea2 (`tests/data/nmea/reference.py`).
//!
//! **Lines.** A line ends at LF or CR (CRLF, LF and CR files read alike;
//! blank lines are skipped). A line longer than [`MAX_LINE_BYTES`] is
//! counted partial and skipped without being held in memory. The sentence
//! starts at the line's first `$` or `!`: text before it (a logger's time
//! prefix, NUL bytes) is skipped and the line counted in `prefixed_lines`; a
//! line without either is counted in `non_nmea_lines`. `!` sentences
//! (`!AIVDM`, AIS) and proprietary `$P…` sentences are counted unknown.
//!
//! **Checks, in order** (each refusal counted by kind, never used): every
//! byte of the sentence printable ASCII; `*hh` exactly two hex digits
//! (either case) at the end when a `*` is present; the XOR of the bytes
//! between `$` and `*` equal to `hh` (else *bad checksum*); an address of two
//! talker characters (any upper-case letter or digit: `GP`, `GN`, `HC`, `II`,
//! `24`) and a known sentence type (else *unknown*); the fields the type needs
//! present and well formed — numbers `[+-]digits[.digits]`, `hhmmss[.s]`
//! times, `ddmmyy` dates, `ddmm.m`/`dddmm.m` positions with `N/S`/`E/W`,
//! angles within range, every value's letter (`E/W`, `M`, `T`, `A/V`) given
//! (else *partial*). A sentence without a checksum is read unverified and
//! counted (`missing_checksum`).
//!
//! **What each sentence gives.** `HDG`: the sensor heading (the compass's
//! reading before its own deviation: `compass_heading_deg`), the deviation
//! (reported, never applied) and the variation (`variation_deg`, east
//! positive). `HDM`: the magnetic heading, taken as the compass's own reading.
//! `HDT`: a true heading (`ref_heading_deg` when its talker is independent
//! of the compass: see *A reference is independent*). `RMC`: time, date, status,
//! position, speed over ground (knots), course over ground (true), variation.
//! `VTG`: course (true), speed (knots, else km/h). `VHW`: speed through
//! water (knots, else km/h; `speed_mps`). `GGA`: time of day,
//! position, fix quality. `GLL`: position, time of day, status. `ZDA`: time,
//! day, month, four-digit year (a two-digit year is not used as a date). A
//! void fix — `RMC`/`GLL` status `V`, a mode indicator `N`, `E`, `M` or `S`,
//! `GGA` quality 0, 6, 7 or 8 or empty — gives nothing, not even its time (a
//! receiver without a fix may send an unset clock); counted `void_fixes`. A
//! heading sentence with an empty heading (the board sends that for a
//! heading it does not trust) gives nothing; counted `empty_values`.
//!
//! **One compass.** `compass_heading_deg` comes from one source: of the
//! talker-and-type pairs (`HCHDG`, `04HDM`, …) giving a heading, the one with
//! the most sentences; the others are counted (`other_source`) and named in
//! a note. The same for `HDT`.
//!
//! **A reference is independent.** An `HDT` of the compass's own talker
//! (the talker of the `HDG`/`HDM` used, or `HC`, the magnetic compass's) is
//! the compass's heading plus the variation: it can judge nothing, and the
//! recording already holds it (`compass_heading_deg`, `variation_deg`), so it
//! is left out and counted (`compass_true_headings`), never
//! `ref_heading_deg` — not written as a second column either, which a later
//! command could take for a reference. An `HDT` of a GNSS compass or a
//! gyrocompass ([`REFERENCE_TALKERS`]) or of the talker named in
//! [`ImportOptions::reference_talker`] is the reference; any other talker's
//! (`II`, which may relay the compass) is counted
//! (`unplaced_true_headings`) and not used. The report names each column's
//! sources (`column_sources`).
//!
//! **Date jumps.** A dated sentence more than [`MAX_DATE_JUMP_S`] from the
//! dated sentences before and after it, which agree with each other, is a
//! bad date (a receiver's clock a year ahead): refused alone and counted
//! (`date_jumps`), so that the rest of the log is not "earlier than the one
//! before".
//!
//! **Time** ([`TIME_RULE`]). `RMC` and `ZDA` give date and time; `GGA`,
//! `GLL` (and a `ZDA` without a four-digit year) the time of day, on the day
//! that puts it nearest (within 12 h) the timed sentence before it (before
//! the first dated sentence: nearest the first dated sentence) — so the day
//! advances when the time of day goes back by more than 12 h (midnight).
//! A timed sentence earlier than the one before it is counted
//! (`time_backwards`) and not used. The sentences without a time (`HDG`,
//! `HDM`, `HDT`, `VTG`) between two consecutive timed sentences at `T0` and
//! `T1`: when `T1 = T0` they all get `T0`; when `0 < T1 − T0 ≤`
//! [`MAX_SPREAD_GAP_S`] the k-th of n gets `T0 + (T1 − T0)·k/(n + 1)`; over a
//! longer gap, and before the first or after the last timed sentence, they
//! cannot be timed and are counted, not used. `t` = seconds since the first
//! timed sentence; the report gives that start in ISO-8601 UTC.
//!
//! **The recording.** One row per used sentence that carries a kept value,
//! in time order: `t, compass_heading_deg, variation_deg, ref_heading_deg,
//! course_deg, gps_speed_mps, lat_deg, lon_deg`, an empty cell where that
//! sentence has no such value; a column the log never fills is not written.
//! `ref_heading_deg` is an independent `HDT`'s heading when the log has one, else the GPS
//! course (`RMC`/`VTG`) where the same sentence gives a ground speed of at
//! least [`ImportOptions::min_course_speed_mps`]. No `mx, my, mz`: a heading
//! compass has no raw field.

mod date;
mod election;
mod importer;
mod sentence;
#[cfg(test)]
mod tests;
mod timing;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::table::{write_table, TableError};

pub use date::Date;
pub use importer::{import, import_file, import_reader};

/// The longest line read, bytes: NMEA 0183 allows 82 characters; this leaves
/// room for a logger's prefix and long proprietary sentences. Longer lines
/// are counted partial and skipped.
pub const MAX_LINE_BYTES: usize = 1024;

/// The longest gap between two timed sentences across which the sentences
/// without a time are spread, s; over a longer gap they are counted untimed.
pub const MAX_SPREAD_GAP_S: f64 = 10.0;

/// One knot in m/s (1852 m per hour).
pub const KNOT_MPS: f64 = 1852.0 / 3600.0;

/// The sentence types read (every other is counted as unknown).
pub const KNOWN: [&str; 9] = ["HDG", "HDM", "HDT", "RMC", "VTG", "VHW", "GGA", "GLL", "ZDA"];

/// The time rule, as the report states it.
pub const TIME_RULE: &str = "RMC and ZDA give date and time; GGA, GLL (and a ZDA without a 4-digit year) the time of day, on the day that puts it nearest (within 12 h) the timed sentence before it (before the first dated sentence: nearest that one), so the day advances at midnight; a timed sentence earlier than the one before is not used. Sentences without time (HDG, HDM, HDT, VTG, VHW) between consecutive timed sentences at T0 and T1 get T0 when T1 = T0, else the k-th of n gets T0 + (T1 - T0)*k/(n+1) when T1 - T0 <= 10 s; over a longer gap, before the first or after the last timed sentence they are not used. t = seconds since the first timed sentence (UTC).";

/// The most distinct names kept in the report's maps of unknown types and
/// partial reasons (random input could make many); more go under `(other)`.
const MAX_KEYS: usize = 64;

/// What to import.
#[derive(Debug, Clone)]
pub struct ImportOptions {
    /// GPS course is the reference heading (without `HDT`) only where its
    /// sentence gives this ground speed or more, m/s.
    pub min_course_speed_mps: f64,
    /// A talker (two characters, e.g. `II`) whose `HDT` is an independent
    /// true heading besides [`REFERENCE_TALKERS`]; never the compass's own.
    pub reference_talker: Option<String>,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self { min_course_speed_mps: 0.5, reference_talker: None }
    }
}

/// The talkers whose `HDT` is a true heading independent of the magnetic
/// compass: a GNSS compass (`GP` GPS, `GN` combined, `GA` Galileo, `GB`
/// and `BD` BeiDou, `GL` GLONASS, `GQ` QZSS, `GI` NavIC) or a north-seeking
/// gyrocompass (`HE`). Any other talker's `HDT` may be the magnetic
/// compass's own heading plus the variation, relayed (an instrument bus,
/// `II`): not a reference unless named ([`ImportOptions::reference_talker`]).
pub const REFERENCE_TALKERS: [&str; 9] = ["GP", "GN", "GA", "GB", "BD", "GL", "GQ", "GI", "HE"];

/// The talker of a magnetic compass (NMEA 0183: "heading, magnetic
/// compass"): its `HDT` is never a reference, whatever else the log holds.
pub const MAGNETIC_COMPASS_TALKER: &str = "HC";

/// A dated sentence (`RMC`, `ZDA`) more than this from the dated sentences
/// before and after it, which agree with each other within it, is a date
/// jump (a receiver's bad date, a year ahead): refused alone, s.
pub const MAX_DATE_JUMP_S: f64 = 3600.0;

/// Where `ref_heading_deg` comes from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Reference {
    /// `HDT`, a true heading.
    Hdt,
    /// GPS course over ground at speed (not heading: the crab angle).
    Course,
    /// Neither: no `ref_heading_deg` column.
    #[default]
    None,
}

/// Counts and notes of an import (`magcal import --nmea --json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct NmeaReport {
    /// Rows written.
    pub rows: usize,
    /// The columns written, in order.
    pub columns: Vec<String>,
    /// Lines read (not blank).
    pub lines: usize,
    /// Lines holding a sentence (`$` or `!`).
    pub sentences: usize,
    /// Sentences used (a row or a time), by type.
    pub used: BTreeMap<String, usize>,
    /// Sentences whose checksum does not match.
    pub bad_checksum: usize,
    /// Truncated or malformed sentences (and lines over [`MAX_LINE_BYTES`]).
    pub partial: usize,
    /// `partial` by reason (`too_few_fields`, `bad_number`, …).
    pub partial_reasons: BTreeMap<String, usize>,
    /// Sentences of types not read here (`!AIVDM`, proprietary `$P…`, `MWV`).
    pub unknown: usize,
    /// `unknown` by type.
    pub unknown_types: BTreeMap<String, usize>,
    /// Sentences without a `*hh` checksum (read unverified when well formed).
    pub missing_checksum: usize,
    /// Lines with text before the `$`/`!` (skipped).
    pub prefixed_lines: usize,
    /// Lines without `$` or `!`.
    pub non_nmea_lines: usize,
    /// Void fixes (`RMC`/`GLL` status `V`, void mode, `GGA` quality 0): not used.
    pub void_fixes: usize,
    /// Heading sentences with an empty heading, `VTG` without course or speed.
    pub empty_values: usize,
    /// Heading sentences of a second compass (another talker or type): not used.
    pub other_source: usize,
    /// Timed sentences earlier than the one before: not used.
    pub time_backwards: usize,
    /// Dated sentences (`RMC`, `ZDA`) whose date and time are more than
    /// [`MAX_DATE_JUMP_S`] from the dated sentences around them (which agree
    /// with each other): not used, and the rest of the log kept.
    #[serde(default)]
    pub date_jumps: usize,
    /// `HDT` of the compass's own talker (the talker of its `HDG`/`HDM`, or
    /// `HC`): its heading plus the variation, which `compass_heading_deg`
    /// and `variation_deg` already hold; never the reference: not used.
    #[serde(default)]
    pub compass_true_headings: usize,
    /// `HDT` of talkers neither the compass's nor known independent
    /// ([`REFERENCE_TALKERS`], [`ImportOptions::reference_talker`]): not used.
    #[serde(default)]
    pub unplaced_true_headings: usize,
    /// The sources (talker and type, e.g. `IIHDT`) of `unplaced_true_headings`.
    #[serde(default)]
    pub unplaced_true_heading_sources: Vec<String>,
    /// Sentences without a time before the first timed sentence: not used.
    pub untimed_before_first_time: usize,
    /// Sentences without a time after the last timed sentence: not used.
    pub untimed_after_last_time: usize,
    /// Sentences without a time in a gap longer than [`MAX_SPREAD_GAP_S`]: not used.
    pub untimed_in_gaps: usize,
    /// The first timed sentence (`t` = 0), ISO-8601 UTC; `None` when the log
    /// has no date (no `RMC` date, no `ZDA` with a four-digit year).
    pub start_utc: Option<String>,
    /// The first timed sentence's UTC time of day, `hh:mm:ss[.sss]`.
    pub start_time_of_day_utc: String,
    /// The last row's `t`, s.
    pub duration_s: f64,
    /// How the rows were timed ([`TIME_RULE`]).
    pub time_rule: String,
    /// Where `ref_heading_deg` comes from.
    pub reference: Reference,
    /// The compass (`compass_heading_deg`): talker and type, e.g. `HCHDM`.
    pub compass_source: Option<String>,
    /// Each heading, course and variation column written, with the
    /// sentences it comes from (talker and type: `compass_heading_deg` →
    /// `HCHDG`, `ref_heading_deg` → `GPHDT`, or the course's `GPRMC, GPVTG`
    /// and the speed it needs).
    #[serde(default)]
    pub column_sources: BTreeMap<String, String>,
    /// Notes (assumptions made, values present and not applied).
    pub notes: Vec<String>,
}

impl NmeaReport {
    /// Every sentence or line skipped, in one number.
    pub fn skipped(&self) -> usize {
        self.bad_checksum
            + self.partial
            + self.unknown
            + self.void_fixes
            + self.empty_values
            + self.other_source
            + self.time_backwards
            + self.date_jumps
            + self.compass_true_headings
            + self.unplaced_true_headings
            + self.untimed_before_first_time
            + self.untimed_after_last_time
            + self.untimed_in_gaps
    }
}

fn bump(map: &mut BTreeMap<String, usize>, key: &str) {
    let key = if map.contains_key(key) || map.len() < MAX_KEYS { key } else { "(other)" };
    *map.entry(key.to_string()).or_default() += 1;
}

/// Why a log could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum NmeaError {
    /// The log could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        #[source]
        source: std::io::Error,
    },
    /// Not an NMEA 0183 log.
    #[error("no NMEA 0183 sentence: {looked_like}")]
    NotNmea {
        /// What the input looked like.
        looked_like: String,
    },
    /// No heading and no course.
    #[error("nothing to calibrate with: {detail}")]
    NothingToCalibrate {
        /// What the log held.
        detail: String,
    },
    /// The reference talker named is the compass's own.
    #[error("{talker} is the compass's own talker ({compass}): its HDT is the compass's heading plus the variation, which cannot judge the compass; a reference must be another instrument (a GNSS compass, a gyrocompass) or the GPS course")]
    ReferenceIsTheCompass {
        /// The talker named.
        talker: String,
        /// The compass's source, e.g. `HCHDG`.
        compass: String,
    },
    /// The reference talker named is not two upper-case letters or digits.
    #[error("a talker is two upper-case letters or digits (GP, II, 24), not {0:?}")]
    BadTalker(String),
    /// No sentence gives a time.
    #[error("no sentence gives a time (RMC, GGA, GLL or ZDA with a time and a valid fix), so no row can be timed: {detail}")]
    NoTime {
        /// What the log held.
        detail: String,
    },
    /// The recording could not be written.
    #[error(transparent)]
    Output(#[from] TableError),
}

/// An imported log: the recording's columns and the report.
#[derive(Debug, Clone)]
pub struct Imported {
    /// `(name, values)`, `t` first; NaN where a row has no value.
    pub columns: Vec<(&'static str, Vec<f64>)>,
    /// The report.
    pub report: NmeaReport,
}

impl Imported {
    /// A column by name.
    pub fn column(&self, name: &str) -> Option<&[f64]> {
        self.columns.iter().find(|(n, _)| *n == name).map(|(_, v)| v.as_slice())
    }

    /// Writes the recording (CSV through [`crate::files`]: all or nothing).
    pub fn write(&self, path: &Path) -> Result<(), NmeaError> {
        let header: Vec<&str> = self.columns.iter().map(|(n, _)| *n).collect();
        let rows = (0..self.report.rows).map(|i| self.columns.iter().map(|(_, v)| v[i]).collect());
        write_table(path, &header, rows)?;
        Ok(())
    }
}

