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

use std::collections::BTreeMap;
use std::io::Read;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::table::{col, write_table, TableError};

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

/// A calendar date (UTC).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Date {
    /// Year, e.g. 2021.
    pub year: i32,
    /// Month, 1–12.
    pub month: u32,
    /// Day of the month, 1–31.
    pub day: u32,
}

impl Date {
    /// A valid date, else `None`.
    pub fn new(year: i32, month: u32, day: u32) -> Option<Self> {
        ((1..=12).contains(&month) && day >= 1 && day <= days_in_month(year, month)).then_some(Self { year, month, day })
    }

    /// Days since 1970-01-01.
    pub fn days_since_epoch(self) -> i64 {
        // H. Hinnant's days_from_civil.
        let y = self.year as i64 - i64::from(self.month <= 2);
        let era = y.div_euclid(400);
        let yoe = y - era * 400;
        let m = self.month as i64;
        let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + self.day as i64 - 1;
        let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
        era * 146_097 + doe - 719_468
    }

    /// The date `days` after 1970-01-01.
    pub fn from_days_since_epoch(days: i64) -> Self {
        // H. Hinnant's civil_from_days.
        let z = days + 719_468;
        let era = z.div_euclid(146_097);
        let doe = z - era * 146_097;
        let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
        let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
        let mp = (5 * doy + 2) / 153;
        let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
        let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
        let year = (yoe + era * 400 + i64::from(month <= 2)) as i32;
        Self { year, month, day }
    }
}

fn days_in_month(year: i32, month: u32) -> u32 {
    match month {
        4 | 6 | 9 | 11 => 30,
        2 if (year % 4 == 0 && year % 100 != 0) || year % 400 == 0 => 29,
        2 => 28,
        _ => 31,
    }
}

/// What one sentence of a known type holds (degrees, m/s, seconds of the
/// UTC day; `None` where the field is empty). Void fixes are parsed too:
/// `valid` says whether the import may use them.
#[derive(Debug, Clone, PartialEq)]
pub enum Sentence {
    /// `HDG`: heading, deviation & variation.
    Hdg {
        /// The magnetic sensor heading (before the compass's deviation).
        heading_deg: Option<f64>,
        /// The deviation, east positive.
        deviation_deg: Option<f64>,
        /// The variation, east positive.
        variation_deg: Option<f64>,
    },
    /// `HDM`: heading, magnetic.
    Hdm {
        /// The magnetic heading.
        heading_deg: Option<f64>,
    },
    /// `HDT`: heading, true.
    Hdt {
        /// The true heading.
        heading_deg: Option<f64>,
    },
    /// `RMC`: recommended minimum data.
    Rmc {
        /// UTC time of day, s.
        time_s: Option<f64>,
        /// Status `A` and a mode indicator (if any) that is not void.
        valid: bool,
        /// UTC date (`ddmmyy`; `yy` < 80 is 20yy, else 19yy).
        date: Option<Date>,
        /// Latitude, north positive.
        lat_deg: Option<f64>,
        /// Longitude, east positive.
        lon_deg: Option<f64>,
        /// Speed over ground, m/s.
        speed_mps: Option<f64>,
        /// Course over ground, true.
        course_deg: Option<f64>,
        /// Magnetic variation, east positive.
        variation_deg: Option<f64>,
    },
    /// `VTG`: course and speed over ground.
    Vtg {
        /// Course over ground, true.
        course_deg: Option<f64>,
        /// Speed over ground, m/s (from knots, else km/h).
        speed_mps: Option<f64>,
        /// The mode indicator (if any) is not void.
        valid: bool,
    },
    /// `VHW`: speed through water (its headings are not read: the compass
    /// gives its own sentence).
    Vhw {
        /// Speed through water, m/s (from knots, else km/h).
        speed_mps: Option<f64>,
    },
    /// `GGA`: fix data.
    Gga {
        /// UTC time of day, s.
        time_s: Option<f64>,
        /// Latitude, north positive.
        lat_deg: Option<f64>,
        /// Longitude, east positive.
        lon_deg: Option<f64>,
        /// The fix quality (0 none; 6 estimated, 7 manual, 8 simulated: void).
        quality: Option<u8>,
    },
    /// `GLL`: position.
    Gll {
        /// Latitude, north positive.
        lat_deg: Option<f64>,
        /// Longitude, east positive.
        lon_deg: Option<f64>,
        /// UTC time of day, s.
        time_s: Option<f64>,
        /// Status `A` and a mode indicator (if any) that is not void.
        valid: bool,
    },
    /// `ZDA`: time and date.
    Zda {
        /// UTC time of day, s.
        time_s: Option<f64>,
        /// The date, when day, month and a four-digit year are given.
        date: Option<Date>,
        /// The year had two digits (not used as a date).
        two_digit_year: bool,
    },
}

impl Sentence {
    /// The type's three letters.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Hdg { .. } => "HDG",
            Self::Hdm { .. } => "HDM",
            Self::Hdt { .. } => "HDT",
            Self::Rmc { .. } => "RMC",
            Self::Vtg { .. } => "VTG",
            Self::Vhw { .. } => "VHW",
            Self::Gga { .. } => "GGA",
            Self::Gll { .. } => "GLL",
            Self::Zda { .. } => "ZDA",
        }
    }

    /// A heading sentence's heading.
    fn heading_deg(&self) -> Option<f64> {
        match self {
            Self::Hdg { heading_deg, .. } | Self::Hdm { heading_deg } | Self::Hdt { heading_deg } => *heading_deg,
            _ => None,
        }
    }

    /// A void fix (the import uses nothing of it).
    fn is_void(&self) -> bool {
        match self {
            Self::Rmc { valid, .. } | Self::Vtg { valid, .. } | Self::Gll { valid, .. } => !valid,
            Self::Gga { quality, .. } => !matches!(quality, Some(1..=5)),
            _ => false,
        }
    }

    /// A sentence that holds nothing the import keeps (an empty heading, a
    /// VTG without course and speed).
    fn is_empty(&self) -> bool {
        match self {
            Self::Hdg { .. } | Self::Hdm { .. } | Self::Hdt { .. } => self.heading_deg().is_none(),
            Self::Vtg { course_deg, speed_mps, .. } => course_deg.is_none() && speed_mps.is_none(),
            Self::Vhw { speed_mps } => speed_mps.is_none(),
            _ => false,
        }
    }

    /// Its time of day and date, if it carries a time.
    fn stamp(&self) -> Option<(f64, Option<Date>)> {
        match self {
            Self::Rmc { time_s, date, .. } | Self::Zda { time_s, date, .. } => time_s.map(|t| (t, *date)),
            Self::Gga { time_s, .. } | Self::Gll { time_s, .. } => time_s.map(|t| (t, None)),
            _ => None,
        }
    }
}

/// Why a sentence was not read (the report's `partial_reasons`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Partial {
    /// The line is longer than [`MAX_LINE_BYTES`].
    TooLong,
    /// A byte that is not printable ASCII inside the sentence.
    NotAscii,
    /// The address is not two talker characters and a type (or `P…`).
    BadAddress,
    /// A `*` not followed by exactly two hex digits at the end.
    BadChecksumField,
    /// Fewer fields than the type needs (a truncated line).
    TooFewFields,
    /// A number that does not parse.
    BadNumber,
    /// A missing or wrong letter (`E/W`, `N/S`, `M`, `T`, `A/V`).
    BadLetter,
    /// A value out of its range (a heading above 360°, a latitude above 90°).
    OutOfRange,
    /// A time that is not `hhmmss[.s]`.
    BadTime,
    /// A date that is not a date.
    BadDate,
}

impl Partial {
    /// Its name in the report.
    pub fn name(self) -> &'static str {
        match self {
            Self::TooLong => "too_long",
            Self::NotAscii => "not_ascii",
            Self::BadAddress => "bad_address",
            Self::BadChecksumField => "bad_checksum_field",
            Self::TooFewFields => "too_few_fields",
            Self::BadNumber => "bad_number",
            Self::BadLetter => "bad_letter",
            Self::OutOfRange => "out_of_range",
            Self::BadTime => "bad_time",
            Self::BadDate => "bad_date",
        }
    }

    /// Whether the sentence was well framed (address and checksum read)
    /// before this was found.
    fn framed(self) -> bool {
        !matches!(self, Self::TooLong | Self::NotAscii | Self::BadAddress | Self::BadChecksumField)
    }
}

/// What became of one sentence.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// Read: its talker (`GP`, `HC`, …) and values.
    Read {
        /// The two talker characters.
        talker: String,
        /// The values.
        sentence: Sentence,
    },
    /// The checksum does not match.
    BadChecksum {
        /// The `hh` given.
        given: u8,
        /// The XOR computed.
        computed: u8,
    },
    /// Truncated or malformed.
    Partial(Partial),
    /// A type not read here: `MWV`, a proprietary `PMAGI`, `!AIVDM`.
    Unknown(String),
}

/// What one line of a log holds.
#[derive(Debug, Clone, PartialEq)]
pub enum Line {
    /// Empty or white space.
    Blank,
    /// Neither `$` nor `!` on the line.
    NotNmea,
    /// A sentence.
    Sentence {
        /// `$` or `!`.
        start: char,
        /// Text before the `$`/`!` was skipped.
        prefixed: bool,
        /// No `*hh`: read unverified.
        no_checksum: bool,
        /// What became of it.
        outcome: Outcome,
    },
}

/// Reads one line (without its CR/LF). Never panics, whatever the bytes.
pub fn parse_line(line: &[u8]) -> Line {
    let Some(start) = line.iter().position(|&b| b == b'$' || b == b'!') else {
        return if line.iter().all(|b| b.is_ascii_whitespace()) { Line::Blank } else { Line::NotNmea };
    };
    let prefixed = start > 0;
    let end = line.iter().rposition(|b| !matches!(b, b' ' | b'\t')).map_or(start + 1, |e| e + 1);
    let text = &line[start..end.max(start + 1)];
    let (no_checksum, outcome) = read_sentence(text);
    Line::Sentence { start: text[0] as char, prefixed, no_checksum, outcome }
}

/// A sentence from its `$`/`!`: (no checksum given, outcome).
fn read_sentence(text: &[u8]) -> (bool, Outcome) {
    if !text.iter().all(|b| (0x20..=0x7E).contains(b)) {
        return (false, Outcome::Partial(Partial::NotAscii));
    }
    // Printable ASCII: valid UTF-8.
    let Ok(text) = std::str::from_utf8(text) else { return (false, Outcome::Partial(Partial::NotAscii)) };
    let (body, no_checksum) = match text.find('*') {
        Some(star) => {
            let hh = &text[star + 1..];
            let Some(given) = (hh.len() == 2).then(|| u8::from_str_radix(hh, 16).ok()).flatten() else {
                return (false, Outcome::Partial(Partial::BadChecksumField));
            };
            if hh.starts_with(['+', '-']) {
                return (false, Outcome::Partial(Partial::BadChecksumField));
            }
            let body = &text[1..star];
            let computed = body.bytes().fold(0u8, |c, b| c ^ b);
            if computed != given {
                return (false, Outcome::BadChecksum { given, computed });
            }
            (body, false)
        }
        None => (&text[1..], true),
    };
    let (address, fields) = match body.split_once(',') {
        Some((a, rest)) => (a, Some(rest)),
        None => (body, None),
    };
    let alnum = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit());
    if !alnum(address) || address.len() > 16 {
        return (no_checksum, Outcome::Partial(Partial::BadAddress));
    }
    if text.starts_with('!') {
        return (no_checksum, Outcome::Unknown(format!("!{address}")));
    }
    if address.starts_with('P') {
        return (no_checksum, Outcome::Unknown(address.to_string()));
    }
    if address.len() != 5 {
        return (no_checksum, Outcome::Partial(Partial::BadAddress));
    }
    let (talker, kind) = address.split_at(2);
    let known = KNOWN;
    if !known.contains(&kind) {
        return (no_checksum, Outcome::Unknown(kind.to_string()));
    }
    let Some(fields) = fields else { return (no_checksum, Outcome::Partial(Partial::TooFewFields)) };
    let f: Vec<&str> = fields.split(',').collect();
    let outcome = match fields_of(kind, &f) {
        Ok(sentence) => Outcome::Read { talker: talker.to_string(), sentence },
        Err(p) => Outcome::Partial(p),
    };
    (no_checksum, outcome)
}

/// The fields `f` of a sentence of type `kind`.
fn fields_of(kind: &str, f: &[&str]) -> Result<Sentence, Partial> {
    let need = |n: usize| if f.len() < n { Err(Partial::TooFewFields) } else { Ok(()) };
    Ok(match kind {
        "HDG" => {
            need(5)?;
            Sentence::Hdg { heading_deg: angle(f[0], 360.0)?, deviation_deg: east_west(f[1], f[2])?, variation_deg: east_west(f[3], f[4])? }
        }
        "HDM" | "HDT" => {
            need(2)?;
            let heading_deg = angle(f[0], 360.0)?;
            let unit = if kind == "HDM" { "M" } else { "T" };
            if heading_deg.is_some() && f[1] != unit {
                return Err(Partial::BadLetter);
            }
            if kind == "HDM" {
                Sentence::Hdm { heading_deg }
            } else {
                Sentence::Hdt { heading_deg }
            }
        }
        "RMC" => {
            need(9)?;
            let status_ok = status(f[1])?;
            let mode_ok = f.get(11).map_or(Ok(true), |m| mode(m))?;
            let variation_deg = east_west(f.get(9).copied().unwrap_or(""), f.get(10).copied().unwrap_or(""))?;
            Sentence::Rmc {
                time_s: time_of_day(f[0])?,
                valid: status_ok && mode_ok,
                date: ddmmyy(f[8])?,
                lat_deg: coordinate(f[2], f[3], 90.0, 'N', 'S')?,
                lon_deg: coordinate(f[4], f[5], 180.0, 'E', 'W')?,
                speed_mps: non_negative(f[6])?.map(|kn| kn * KNOT_MPS),
                course_deg: angle(f[7], 360.0)?,
                variation_deg,
            }
        }
        "VTG" => {
            need(8)?;
            let course_deg = angle(f[0], 360.0)?;
            letter_if(course_deg, f[1], "T")?;
            let knots = non_negative(f[4])?;
            letter_if(knots, f[5], "N")?;
            let kmh = non_negative(f[6])?;
            letter_if(kmh, f[7], "K")?;
            let speed_mps = knots.map(|kn| kn * KNOT_MPS).or(kmh.map(|k| k / 3.6));
            Sentence::Vtg { course_deg, speed_mps, valid: f.get(8).map_or(Ok(true), |m| mode(m))? }
        }
        "VHW" => {
            need(8)?;
            let knots = non_negative(f[4])?;
            letter_if(knots, f[5], "N")?;
            let kmh = non_negative(f[6])?;
            letter_if(kmh, f[7], "K")?;
            Sentence::Vhw { speed_mps: knots.map(|kn| kn * KNOT_MPS).or(kmh.map(|k| k / 3.6)) }
        }
        "GGA" => {
            need(6)?;
            let quality = match f[5] {
                "" => None,
                q if q.len() <= 2 && q.bytes().all(|b| b.is_ascii_digit()) => q.parse::<u8>().ok(),
                _ => return Err(Partial::BadNumber),
            };
            Sentence::Gga {
                time_s: time_of_day(f[0])?,
                lat_deg: coordinate(f[1], f[2], 90.0, 'N', 'S')?,
                lon_deg: coordinate(f[3], f[4], 180.0, 'E', 'W')?,
                quality,
            }
        }
        "GLL" => {
            need(6)?;
            let status_ok = status(f[5])?;
            let mode_ok = f.get(6).map_or(Ok(true), |m| mode(m))?;
            Sentence::Gll {
                lat_deg: coordinate(f[0], f[1], 90.0, 'N', 'S')?,
                lon_deg: coordinate(f[2], f[3], 180.0, 'E', 'W')?,
                time_s: time_of_day(f[4])?,
                valid: status_ok && mode_ok,
            }
        }
        _ => {
            // ZDA
            need(4)?;
            let (date, two_digit_year) = zda_date(f[1], f[2], f[3])?;
            Sentence::Zda { time_s: time_of_day(f[0])?, date, two_digit_year }
        }
    })
}

/// `[+-]digits[.digits]`, `[+-].digits` (a `.` with no digit after it is
/// a number cut short).
fn is_number(s: &str) -> bool {
    let s = s.strip_prefix(['+', '-']).unwrap_or(s);
    let digits = |p: &str| p.bytes().all(|b| b.is_ascii_digit());
    match s.split_once('.') {
        Some((int, frac)) => digits(int) && digits(frac) && !frac.is_empty(),
        None => digits(s) && !s.is_empty(),
    }
}

/// A number field: `None` when empty.
fn number(s: &str) -> Result<Option<f64>, Partial> {
    if s.is_empty() {
        return Ok(None);
    }
    if !is_number(s) {
        return Err(Partial::BadNumber);
    }
    s.parse::<f64>().map(Some).map_err(|_| Partial::BadNumber)
}

/// A number ≥ 0.
fn non_negative(s: &str) -> Result<Option<f64>, Partial> {
    match number(s)? {
        Some(v) if v < 0.0 => Err(Partial::OutOfRange),
        v => Ok(v),
    }
}

/// An angle in [0, `max`].
fn angle(s: &str, max: f64) -> Result<Option<f64>, Partial> {
    match non_negative(s)? {
        Some(v) if v > max => Err(Partial::OutOfRange),
        v => Ok(v),
    }
}

/// A value with its `E`/`W` letter, east positive (at most 180°); `None`
/// when the value is empty.
fn east_west(value: &str, letter: &str) -> Result<Option<f64>, Partial> {
    let Some(v) = angle(value, 180.0)? else { return Ok(None) };
    match letter {
        "E" => Ok(Some(v)),
        "W" => Ok(Some(-v)),
        _ => Err(Partial::BadLetter),
    }
}

/// When a value is given, its letter must be `want`.
fn letter_if(value: Option<f64>, letter: &str, want: &str) -> Result<(), Partial> {
    if value.is_some() && letter != want {
        return Err(Partial::BadLetter);
    }
    Ok(())
}

/// `A` (valid) or `V` (void).
fn status(s: &str) -> Result<bool, Partial> {
    match s {
        "A" => Ok(true),
        "V" => Ok(false),
        _ => Err(Partial::BadLetter),
    }
}

/// The NMEA 2.3 mode indicator: `N` (not valid), `E` (estimated), `M`
/// (manual), `S` (simulator) are void; empty, `A`, `D`, `P`, `R`, `F` valid.
fn mode(s: &str) -> Result<bool, Partial> {
    match s {
        "" | "A" | "D" | "P" | "R" | "F" => Ok(true),
        "N" | "E" | "M" | "S" => Ok(false),
        _ => Err(Partial::BadLetter),
    }
}

/// `hhmmss[.s…]` as seconds of the day; `None` when empty.
fn time_of_day(s: &str) -> Result<Option<f64>, Partial> {
    if s.is_empty() {
        return Ok(None);
    }
    let b = s.as_bytes();
    if b.len() < 6 || !b[..6].iter().all(u8::is_ascii_digit) {
        return Err(Partial::BadTime);
    }
    let frac = &s[6..];
    if !(frac.is_empty() || (frac.len() > 1 && frac.starts_with('.') && frac[1..].bytes().all(|c| c.is_ascii_digit()))) {
        return Err(Partial::BadTime);
    }
    let two = |i: usize| f64::from((b[i] - b'0') * 10 + (b[i + 1] - b'0'));
    let (h, m) = (two(0), two(2));
    let sec: f64 = s[4..].parse().map_err(|_| Partial::BadTime)?;
    if h >= 24.0 || m >= 60.0 || sec >= 61.0 {
        return Err(Partial::BadTime);
    }
    Ok(Some(h * 3600.0 + m * 60.0 + sec))
}

/// `ddmmyy` (`yy` < 80 is 20yy, else 19yy); `None` when empty.
fn ddmmyy(s: &str) -> Result<Option<Date>, Partial> {
    if s.is_empty() {
        return Ok(None);
    }
    let b = s.as_bytes();
    if b.len() != 6 || !b.iter().all(u8::is_ascii_digit) {
        return Err(Partial::BadDate);
    }
    let two = |i: usize| u32::from((b[i] - b'0') * 10 + (b[i + 1] - b'0'));
    let yy = two(4) as i32;
    Date::new(if yy < 80 { 2000 + yy } else { 1900 + yy }, two(2), two(0)).map(Some).ok_or(Partial::BadDate)
}

/// ZDA's day, month, year: (the date with a four-digit year, a two-digit
/// year was given).
fn zda_date(day: &str, month: &str, year: &str) -> Result<(Option<Date>, bool), Partial> {
    if day.is_empty() && month.is_empty() && year.is_empty() {
        return Ok((None, false));
    }
    let digits = |s: &str, n: std::ops::RangeInclusive<usize>| n.contains(&s.len()) && s.bytes().all(|b| b.is_ascii_digit());
    if !(digits(day, 1..=2) && digits(month, 1..=2) && (digits(year, 4..=4) || digits(year, 2..=2))) {
        return Err(Partial::BadDate);
    }
    let (d, m) = (day.parse::<u32>().map_err(|_| Partial::BadDate)?, month.parse::<u32>().map_err(|_| Partial::BadDate)?);
    if year.len() == 2 {
        // Check what can be checked; the year is not guessed.
        return Date::new(2000, m, d).map(|_| (None, true)).ok_or(Partial::BadDate);
    }
    let y = year.parse::<i32>().map_err(|_| Partial::BadDate)?;
    Date::new(y, m, d).map(|date| (Some(date), false)).ok_or(Partial::BadDate)
}

/// `ddmm.mmm` / `dddmm.mmm` with its hemisphere letter, signed degrees (at
/// most `max_deg`); `None` when both are empty.
fn coordinate(value: &str, hemisphere: &str, max_deg: f64, positive: char, negative: char) -> Result<Option<f64>, Partial> {
    if value.is_empty() {
        return Ok(None);
    }
    let (int, frac) = value.split_once('.').unwrap_or((value, "0"));
    if int.len() < 3 || !int.bytes().all(|b| b.is_ascii_digit()) || frac.is_empty() || !frac.bytes().all(|b| b.is_ascii_digit()) {
        return Err(Partial::BadNumber);
    }
    let (deg, min) = value.split_at(int.len() - 2);
    let deg: f64 = deg.parse().map_err(|_| Partial::BadNumber)?;
    let min: f64 = min.parse().map_err(|_| Partial::BadNumber)?;
    let v = deg + min / 60.0;
    if min >= 60.0 || v > max_deg {
        return Err(Partial::OutOfRange);
    }
    match hemisphere.chars().next().filter(|_| hemisphere.len() == 1) {
        Some(c) if c == positive => Ok(Some(v)),
        Some(c) if c == negative => Ok(Some(-v)),
        _ => Err(Partial::BadLetter),
    }
}

/// Calls `each` with every line of `reader` (CR, LF or CRLF ends a line), at
/// most [`MAX_LINE_BYTES`] held: a longer line comes as `None`. Returns the
/// byte counts (all, not text).
fn for_each_line<R: Read>(mut reader: R, mut each: impl FnMut(Option<&[u8]>)) -> std::io::Result<(u64, u64)> {
    let mut buf = vec![0u8; 64 * 1024];
    let mut line: Vec<u8> = Vec::with_capacity(MAX_LINE_BYTES);
    let (mut too_long, mut total, mut binary) = (false, 0u64, 0u64);
    let push = |line: &mut Vec<u8>, too_long: &mut bool, s: &[u8]| {
        if *too_long || line.len() + s.len() > MAX_LINE_BYTES {
            *too_long = true;
            line.clear();
        } else {
            line.extend_from_slice(s);
        }
    };
    loop {
        let n = match reader.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        let chunk = &buf[..n];
        total += n as u64;
        binary += chunk.iter().filter(|&&b| !(matches!(b, 0x20..=0x7E | b'\t' | b'\r' | b'\n'))).count() as u64;
        let mut rest = chunk;
        while let Some(p) = rest.iter().position(|&b| b == b'\n' || b == b'\r') {
            push(&mut line, &mut too_long, &rest[..p]);
            each((!too_long).then_some(line.as_slice()));
            line.clear();
            too_long = false;
            rest = &rest[p + 1..];
        }
        push(&mut line, &mut too_long, rest);
    }
    if too_long || !line.is_empty() {
        each((!too_long).then_some(line.as_slice()));
    }
    Ok((total, binary))
}

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

/// A sentence kept for the time pass.
struct Kept {
    talker: String,
    sentence: Sentence,
}

/// What the line pass gathered besides the report.
#[derive(Default)]
struct Gathered {
    kept: Vec<Kept>,
    /// Well-framed `$` sentences (read, bad checksum, unknown, partial in
    /// their fields).
    dollar_framed: usize,
    bang: usize,
    too_long_lines: usize,
    first_line: Option<String>,
    hdg_deviation: (usize, f64),
    zda_two_digit_year: usize,
}

fn gather<R: Read>(reader: R, path: &Path, report: &mut NmeaReport) -> Result<(Gathered, u64, u64), NmeaError> {
    let mut g = Gathered::default();
    let (total, binary) = for_each_line(reader, |line| {
        let Some(line) = line else {
            report.lines += 1;
            report.partial += 1;
            bump(&mut report.partial_reasons, Partial::TooLong.name());
            g.too_long_lines += 1;
            return;
        };
        let parsed = parse_line(line);
        if parsed == Line::Blank {
            return;
        }
        report.lines += 1;
        if g.first_line.is_none() {
            g.first_line = Some(String::from_utf8_lossy(&line[..line.len().min(60)]).into_owned());
        }
        let Line::Sentence { start, prefixed, no_checksum, outcome } = parsed else {
            report.non_nmea_lines += 1;
            return;
        };
        report.sentences += 1;
        report.prefixed_lines += usize::from(prefixed);
        report.missing_checksum += usize::from(no_checksum);
        if start == '!' {
            g.bang += 1;
        }
        let framed = match &outcome {
            Outcome::Partial(p) => p.framed(),
            _ => true,
        };
        if start == '$' && framed {
            g.dollar_framed += 1;
        }
        match outcome {
            Outcome::BadChecksum { .. } => report.bad_checksum += 1,
            Outcome::Partial(p) => {
                report.partial += 1;
                bump(&mut report.partial_reasons, p.name());
            }
            Outcome::Unknown(name) => {
                report.unknown += 1;
                bump(&mut report.unknown_types, &name);
            }
            Outcome::Read { talker, sentence } => {
                if sentence.is_void() {
                    report.void_fixes += 1;
                } else if sentence.is_empty() {
                    report.empty_values += 1;
                } else {
                    if let Sentence::Hdg { deviation_deg: Some(d), .. } = sentence {
                        if d != 0.0 {
                            g.hdg_deviation.0 += 1;
                            g.hdg_deviation.1 = g.hdg_deviation.1.max(d.abs());
                        }
                    }
                    if let Sentence::Zda { two_digit_year: true, .. } = sentence {
                        g.zda_two_digit_year += 1;
                    }
                    g.kept.push(Kept { talker, sentence });
                }
            }
        }
    })
    .map_err(|source| NmeaError::Io { path: path.into(), source })?;
    Ok((g, total, binary))
}

/// What the input looked like, for [`NmeaError::NotNmea`].
fn looked_like(g: &Gathered, report: &NmeaReport, total: u64, binary: u64) -> String {
    if total == 0 {
        return "the file is empty (0 bytes)".into();
    }
    if binary * 10 > total {
        return format!("{total} bytes, {:.0} % of them not text: a binary file, not an NMEA 0183 text log", 100.0 * binary as f64 / total as f64);
    }
    if g.bang > 0 {
        return format!("{} `!` sentences (AIS, e.g. `!AIVDM`) and no `$` sentence: nothing here is a compass or a GPS", g.bang);
    }
    if report.lines == g.too_long_lines && g.too_long_lines > 0 {
        return format!("{} line(s) longer than {MAX_LINE_BYTES} bytes and nothing else (an NMEA sentence is at most 82 characters)", g.too_long_lines);
    }
    if report.lines == 0 {
        return "only blank lines".into();
    }
    let first = g.first_line.as_deref().unwrap_or("");
    if report.sentences > 0 {
        return format!("{} lines, {} with a `$` but none a well-formed sentence (first line: {first:?})", report.lines, report.sentences);
    }
    format!("{} lines, no line holds a `$` sentence (first line: {first:?})", report.lines)
}

/// A one-line account of the sentences refused, for errors.
fn refused(report: &NmeaReport) -> String {
    let types: Vec<String> = report.unknown_types.iter().take(8).map(|(k, n)| format!("{k} {n}")).collect();
    format!(
        "{} sentences: {} bad checksum, {} partial, {} unknown ({}), {} void fixes, {} empty",
        report.sentences,
        report.bad_checksum,
        report.partial,
        report.unknown,
        types.join(", "),
        report.void_fixes,
        report.empty_values
    )
}

/// Keeps the heading sentences of one source (talker and type) among
/// `kinds`: the one with the most; the others' count and names.
fn one_source(kept: &mut Vec<Kept>, kinds: &[&str]) -> (Option<String>, usize, Vec<String>) {
    let mut counts: Vec<(String, usize)> = Vec::new();
    for k in kept.iter().filter(|k| kinds.contains(&k.sentence.kind())) {
        let key = format!("{}{}", k.talker, k.sentence.kind());
        match counts.iter_mut().find(|(n, _)| *n == key) {
            Some((_, c)) => *c += 1,
            None => counts.push((key, 1)),
        }
    }
    // The most sentences; the first seen on a tie.
    let Some(best) = counts.iter().enumerate().max_by_key(|(i, (_, c))| (*c, usize::MAX - i)).map(|(_, (n, _))| n.clone()) else {
        return (None, 0, Vec::new());
    };
    let before = kept.len();
    kept.retain(|k| !kinds.contains(&k.sentence.kind()) || format!("{}{}", k.talker, k.sentence.kind()) == best);
    let others = counts.into_iter().filter(|(n, _)| *n != best).map(|(n, c)| format!("{n} ({c})")).collect();
    (Some(best), before - kept.len(), others)
}

/// Keeps only the `HDT` that may be a reference: of a talker in
/// [`REFERENCE_TALKERS`] or the one named. The compass's own (its talker's,
/// or `HC`'s) and the others are counted and removed; the notes say which.
fn independent_hdt_only(kept: &mut Vec<Kept>, compass_talker: &str, named: Option<&str>, report: &mut NmeaReport) -> Vec<String> {
    let mut own: BTreeMap<String, usize> = BTreeMap::new();
    let mut unplaced: BTreeMap<String, usize> = BTreeMap::new();
    kept.retain(|k| {
        if k.sentence.kind() != "HDT" {
            return true;
        }
        let t = k.talker.as_str();
        let source = format!("{t}HDT");
        if t == compass_talker || t == MAGNETIC_COMPASS_TALKER {
            bump(&mut own, &source);
            false
        } else if REFERENCE_TALKERS.contains(&t) || named == Some(t) {
            true
        } else {
            bump(&mut unplaced, &source);
            false
        }
    });
    let list = |m: &BTreeMap<String, usize>| m.iter().map(|(s, n)| format!("{s} ({n})")).collect::<Vec<_>>().join(", ");
    let mut notes = Vec::new();
    report.compass_true_headings = own.values().sum();
    if !own.is_empty() {
        notes.push(format!(
            "{} is the compass's own true heading (its heading plus the variation, already in compass_heading_deg and variation_deg): not a reference, not used",
            list(&own)
        ));
    }
    report.unplaced_true_headings = unplaced.values().sum();
    report.unplaced_true_heading_sources = unplaced.keys().cloned().collect();
    if !unplaced.is_empty() {
        notes.push(format!(
            "{}: a true heading from a talker that is neither a GNSS receiver's nor a gyrocompass's (it may relay the compass's own heading): not used as the reference; if it is an independent instrument, name its talker as the reference talker",
            list(&unplaced)
        ));
    }
    notes
}

/// `hh:mm:ss[.sss]`.
fn clock_text(tod_s: f64) -> String {
    let ms = (tod_s * 1000.0).round() as i64;
    let (h, m, s, frac) = (ms / 3_600_000, ms / 60_000 % 60, ms / 1000 % 60, ms % 1000);
    if frac == 0 {
        format!("{h:02}:{m:02}:{s:02}")
    } else {
        format!("{h:02}:{m:02}:{s:02}.{frac:03}")
    }
}

/// The dated sentences (`RMC`, `ZDA` with a date) that jump: more than
/// [`MAX_DATE_JUMP_S`] from the dated sentences before and after them,
/// which agree with each other (at the log's ends: from the one neighbour,
/// which agrees with its own next). One bad date is refused alone; a
/// genuine pause (the neighbours apart too) is kept.
fn date_jumps(kept: &[Kept]) -> Vec<bool> {
    let dated: Vec<(usize, f64)> = kept
        .iter()
        .enumerate()
        .filter_map(|(i, k)| match k.sentence.stamp() {
            Some((tod, Some(d))) => Some((i, d.days_since_epoch() as f64 * 86_400.0 + tod)),
            _ => None,
        })
        .collect();
    let far = |a: f64, b: f64| (a - b).abs() > MAX_DATE_JUMP_S;
    let mut out = vec![false; kept.len()];
    for (j, &(i, t)) in dated.iter().enumerate() {
        let at = |k: usize| dated.get(k).map(|d| d.1);
        let prev = j.checked_sub(1).and_then(at);
        let next = at(j + 1);
        out[i] = match (prev, next) {
            (Some(p), Some(n)) => far(t, p) && far(t, n) && !far(p, n),
            (None, Some(n)) => far(t, n) && at(j + 2).is_some_and(|m| !far(n, m)),
            (Some(p), None) => far(t, p) && j.checked_sub(2).and_then(at).is_some_and(|m| !far(p, m)),
            (None, None) => false,
        };
    }
    out
}

/// Each kept sentence's time, seconds since the epoch (or since day 0 of a
/// log without a date); `None` where it cannot be timed. Counts what is not
/// used.
fn times(kept: &[Kept], report: &mut NmeaReport) -> (Vec<Option<f64>>, bool) {
    let jumps = date_jumps(kept);
    report.date_jumps = jumps.iter().filter(|&&j| j).count();
    let first_dated = kept.iter().zip(&jumps).filter(|(_, &j)| !j).find_map(|(k, _)| k.sentence.stamp().and_then(|(tod, d)| d.map(|d| (d.days_since_epoch(), tod))));
    let half_day = 43_200.0;
    // Anchors: the timed sentences, on one time line.
    let mut anchor: Vec<Option<f64>> = vec![None; kept.len()];
    let mut dropped = vec![false; kept.len()];
    let (mut current, mut last): (Option<(i64, f64)>, Option<f64>) = (None, None);
    for (i, k) in kept.iter().enumerate() {
        let Some((tod, date)) = k.sentence.stamp() else { continue };
        if jumps[i] {
            dropped[i] = true;
            continue;
        }
        let day = match (date, current, first_dated) {
            (Some(d), _, _) => d.days_since_epoch(),
            (None, Some((day, prev_tod)), _) | (None, None, Some((day, prev_tod))) => {
                if tod < prev_tod - half_day {
                    day + 1
                } else if tod > prev_tod + half_day {
                    day - 1
                } else {
                    day
                }
            }
            (None, None, None) => 0,
        };
        let t = day as f64 * 86_400.0 + tod;
        if last.is_some_and(|l| t < l) {
            report.time_backwards += 1;
            dropped[i] = true;
            continue;
        }
        current = Some((day, tod));
        last = Some(t);
        anchor[i] = Some(t);
    }
    // The sentences without a time, spread between the anchors around them.
    let mut out = anchor.clone();
    let mut prev: Option<f64> = None;
    let mut pending: Vec<usize> = Vec::new();
    for i in 0..kept.len() {
        if dropped[i] {
            continue;
        }
        let Some(t1) = anchor[i] else {
            pending.push(i);
            continue;
        };
        match prev {
            None => report.untimed_before_first_time += pending.len(),
            Some(t0) if t1 - t0 > MAX_SPREAD_GAP_S => report.untimed_in_gaps += pending.len(),
            Some(t0) => {
                let n = pending.len() as f64;
                for (k, &j) in pending.iter().enumerate() {
                    out[j] = Some(if t1 == t0 { t0 } else { t0 + (t1 - t0) * (k as f64 + 1.0) / (n + 1.0) });
                }
            }
        }
        pending.clear();
        prev = Some(t1);
    }
    report.untimed_after_last_time += pending.len();
    (out, first_dated.is_some())
}

/// Imports a log from any reader (`path` names it in errors).
pub fn import_reader<R: Read>(reader: R, path: &Path, opts: &ImportOptions) -> Result<Imported, NmeaError> {
    if let Some(t) = &opts.reference_talker {
        if !(t.len() == 2 && t.bytes().all(|b| b.is_ascii_uppercase() || b.is_ascii_digit())) {
            return Err(NmeaError::BadTalker(t.clone()));
        }
    }
    let mut report = NmeaReport { time_rule: TIME_RULE.to_string(), ..NmeaReport::default() };
    let (mut g, total, binary) = gather(reader, path, &mut report)?;
    if g.dollar_framed == 0 {
        return Err(NmeaError::NotNmea { looked_like: looked_like(&g, &report, total, binary) });
    }
    let heading = |k: &Kept| matches!(k.sentence, Sentence::Hdg { .. } | Sentence::Hdm { .. } | Sentence::Hdt { .. });
    let course = |k: &Kept| matches!(k.sentence, Sentence::Rmc { course_deg: Some(_), .. } | Sentence::Vtg { course_deg: Some(_), .. });
    if !g.kept.iter().any(|k| heading(k) || course(k)) {
        return Err(NmeaError::NothingToCalibrate { detail: format!("no heading sentence (HDG, HDM, HDT) and no GPS course (RMC, VTG) among {}", refused(&report)) });
    }
    if !g.kept.iter().any(|k| k.sentence.stamp().is_some()) {
        return Err(NmeaError::NoTime { detail: refused(&report) });
    }
    let mut notes = Vec::new();
    let (compass, others, names) = one_source(&mut g.kept, &["HDG", "HDM"]);
    report.other_source += others;
    if !names.is_empty() {
        notes.push(format!("compass_heading_deg is from {} only; the headings of {} are another compass (or another sentence of it) and were not used", compass.as_deref().unwrap_or(""), names.join(", ")));
    }
    let compass_talker = compass.as_deref().map_or(MAGNETIC_COMPASS_TALKER, |c| &c[..2]);
    if let Some(t) = opts.reference_talker.as_deref().filter(|t| *t == compass_talker || *t == MAGNETIC_COMPASS_TALKER) {
        return Err(NmeaError::ReferenceIsTheCompass { talker: t.to_string(), compass: compass.clone().unwrap_or_else(|| format!("{t}: a magnetic compass")) });
    }
    notes.extend(independent_hdt_only(&mut g.kept, compass_talker, opts.reference_talker.as_deref(), &mut report));
    let (true_source, others, names) = one_source(&mut g.kept, &["HDT"]);
    report.other_source += others;
    if !names.is_empty() {
        notes.push(format!("ref_heading_deg is from {} only; the HDT of {} were not used", true_source.as_deref().unwrap_or(""), names.join(", ")));
    }
    let (t, dated) = times(&g.kept, &mut report);
    let Some(start) = t.iter().flatten().copied().reduce(f64::min) else {
        return Err(NmeaError::NoTime { detail: refused(&report) });
    };
    let has_hdt = g.kept.iter().zip(&t).any(|(k, t)| t.is_some() && matches!(k.sentence, Sentence::Hdt { .. }));
    report.reference = if has_hdt { Reference::Hdt } else { Reference::None };
    // The rows.
    const NAMES: [&str; 9] =
        [col::T, col::COMPASS_HEADING_DEG, col::VARIATION_DEG, col::REF_HEADING_DEG, col::COURSE_DEG, col::GPS_SPEED_MPS, col::LAT_DEG, col::LON_DEG, col::SPEED_MPS];
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); NAMES.len()];
    let mut gps_talkers: Vec<&str> = Vec::new();
    let mut sources: Vec<Vec<String>> = vec![Vec::new(); NAMES.len()];
    for (k, t) in g.kept.iter().zip(&t) {
        let Some(t) = *t else { continue };
        let mut row = [f64::NAN; 9];
        match k.sentence {
            Sentence::Hdg { heading_deg, variation_deg, .. } => {
                row[1] = heading_deg.unwrap_or(f64::NAN);
                row[2] = variation_deg.unwrap_or(f64::NAN);
            }
            Sentence::Hdm { heading_deg } => row[1] = heading_deg.unwrap_or(f64::NAN),
            Sentence::Hdt { heading_deg } => row[3] = heading_deg.unwrap_or(f64::NAN),
            Sentence::Rmc { lat_deg, lon_deg, speed_mps, course_deg, variation_deg, .. } => {
                row[2] = variation_deg.unwrap_or(f64::NAN);
                row[4] = course_deg.unwrap_or(f64::NAN);
                row[5] = speed_mps.unwrap_or(f64::NAN);
                row[6] = lat_deg.unwrap_or(f64::NAN);
                row[7] = lon_deg.unwrap_or(f64::NAN);
                if !has_hdt {
                    row[3] = super::import::rules::course_at_speed_deg(row[4], row[5], opts.min_course_speed_mps);
                }
            }
            Sentence::Vtg { course_deg, speed_mps, .. } => {
                row[4] = course_deg.unwrap_or(f64::NAN);
                row[5] = speed_mps.unwrap_or(f64::NAN);
                if !has_hdt {
                    row[3] = super::import::rules::course_at_speed_deg(row[4], row[5], opts.min_course_speed_mps);
                }
            }
            Sentence::Gga { lat_deg, lon_deg, .. } | Sentence::Gll { lat_deg, lon_deg, .. } => {
                row[6] = lat_deg.unwrap_or(f64::NAN);
                row[7] = lon_deg.unwrap_or(f64::NAN);
            }
            Sentence::Vhw { speed_mps } => row[8] = speed_mps.unwrap_or(f64::NAN),
            Sentence::Zda { .. } => {}
        }
        let gives_row = row[1..].iter().any(|v| v.is_finite());
        if gives_row || k.sentence.stamp().is_some() {
            *report.used.entry(k.sentence.kind().to_string()).or_default() += 1;
        }
        if matches!(k.sentence, Sentence::Rmc { .. } | Sentence::Vtg { .. } | Sentence::Gga { .. } | Sentence::Gll { .. }) && !gps_talkers.contains(&k.talker.as_str()) {
            gps_talkers.push(&k.talker);
        }
        if !gives_row {
            continue;
        }
        row[0] = t - start;
        for (c, v) in columns.iter_mut().zip(row) {
            c.push(v);
        }
        for (c, v) in row.iter().enumerate().skip(1) {
            let source = format!("{}{}", k.talker, k.sentence.kind());
            if v.is_finite() && !sources[c].contains(&source) && sources[c].len() < MAX_KEYS {
                sources[c].push(source);
            }
        }
    }
    report.rows = columns[0].len();
    let with = |c: usize| columns[c].iter().filter(|v| v.is_finite()).count();
    if with(1) + with(3) + with(4) == 0 {
        return Err(NmeaError::NothingToCalibrate {
            detail: format!(
                "no heading or course could be timed ({} before the first timed sentence, {} after the last, {} in gaps over {MAX_SPREAD_GAP_S} s)",
                report.untimed_before_first_time, report.untimed_after_last_time, report.untimed_in_gaps
            ),
        });
    }
    if !has_hdt && with(3) > 0 {
        report.reference = Reference::Course;
    }
    // The report's words.
    let start_day = (start / 86_400.0).floor();
    let start_tod = start - start_day * 86_400.0;
    report.start_time_of_day_utc = clock_text(start_tod);
    if dated {
        let d = Date::from_days_since_epoch(start_day as i64);
        report.start_utc = Some(format!("{:04}-{:02}-{:02}T{}Z", d.year, d.month, d.day, clock_text(start_tod)));
    } else {
        notes.push("the log has no date (no RMC date, no ZDA with a four-digit year): t counts from the first time of day; start_utc is unknown".into());
    }
    report.duration_s = columns[0].last().copied().unwrap_or(0.0);
    report.compass_source = compass.clone();
    if let Some(source) = compass.as_deref().filter(|s| s.ends_with("HDM")) {
        notes.push(format!("compass_heading_deg is {source}'s magnetic heading, taken as the compass's own reading: if the compass applies its own deviation table, the swing fits only what remains"));
    }
    if g.hdg_deviation.0 > 0 {
        notes.push(format!(
            "{} HDG sentences gave the compass's own deviation (up to {}°): present and NOT applied; compass_heading_deg is the sensor heading",
            g.hdg_deviation.0, g.hdg_deviation.1
        ));
    }
    if report.date_jumps > 0 {
        notes.push(format!(
            "{} RMC/ZDA dated more than {MAX_DATE_JUMP_S} s from the dated sentences before and after them (which agree with each other): a bad date, not used; the rest of the log is timed without them",
            report.date_jumps
        ));
    }
    if g.zda_two_digit_year > 0 {
        notes.push(format!("{} ZDA sentences gave a two-digit year: their date was not used (their time of day was)", g.zda_two_digit_year));
    }
    if report.missing_checksum > 0 {
        notes.push(format!("{} sentences had no *hh checksum: read without verification", report.missing_checksum));
    }
    if report.prefixed_lines > 0 {
        notes.push(format!("{} lines had text before the `$` (a logger's prefix?): skipped, the sentence read from its `$`", report.prefixed_lines));
    }
    if gps_talkers.len() > 1 {
        notes.push(format!("GPS sentences from {} talkers ({}): one receiver assumed", gps_talkers.len(), gps_talkers.join(", ")));
    }
    notes.push(match report.reference {
        Reference::Hdt => format!("ref_heading_deg is {}'s true heading", true_source.as_deref().unwrap_or("HDT")),
        Reference::Course => format!(
            "ref_heading_deg is the GPS course over ground where its sentence gives a ground speed of {} m/s or more ({} rows): course is not heading (in a current they differ by the crab angle)",
            opts.min_course_speed_mps,
            with(3)
        ),
        Reference::None => format!("no ref_heading_deg: no HDT, and no GPS course at a ground speed of {} m/s or more given in the same sentence", opts.min_course_speed_mps),
    });
    report.notes = notes;
    let keep: Vec<usize> = (0..NAMES.len()).filter(|&c| c == 0 || with(c) > 0).collect();
    report.columns = keep.iter().map(|&c| NAMES[c].to_string()).collect();
    for &c in keep.iter().filter(|&&c| c > 0) {
        let mut text = sources[c].join(", ");
        if c == 3 && report.reference == Reference::Course {
            text += &format!(" (course over ground at {} m/s or more)", opts.min_course_speed_mps);
        }
        report.column_sources.insert(NAMES[c].to_string(), text);
    }
    let mut columns: Vec<Option<Vec<f64>>> = columns.into_iter().map(Some).collect();
    let columns = keep.iter().filter_map(|&c| columns[c].take().map(|v| (NAMES[c], v))).collect();
    Ok(Imported { columns, report })
}

/// Imports a log from memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, NmeaError> {
    import_reader(bytes, Path::new("(memory)"), opts)
}

/// Reads a log file and imports it.
pub fn import_file(path: &Path, opts: &ImportOptions) -> Result<Imported, NmeaError> {
    let file = std::fs::File::open(path).map_err(|source| NmeaError::Io { path: path.into(), source })?;
    import_reader(std::io::BufReader::new(file), path, opts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::Value;

    const MIXED: &[u8] = include_bytes!("../../../tests/data/nmea/mixed.nmea");
    const GOFREE: &[u8] = include_bytes!("../../../tests/data/nmea/gofree-merrimac-head.nmea");
    const N2KD: &[u8] = include_bytes!("../../../tests/data/nmea/n2kd-183-merrimac-head.nmea");
    const REFERENCE: &str = include_str!("../../../tests/data/nmea/reference.json");

    /// The non-blank lines, split as the reader and reference.py split them.
    fn lines(log: &[u8]) -> Vec<&[u8]> {
        log.split(|&b| b == b'\n' || b == b'\r').filter(|l| !l.iter().all(u8::is_ascii_whitespace)).collect()
    }

    fn read(line: &str) -> Outcome {
        match parse_line(line.as_bytes()) {
            Line::Sentence { outcome, .. } => outcome,
            other => panic!("{line}: {other:?}"),
        }
    }

    fn sentence(line: &str) -> Sentence {
        match read(line) {
            Outcome::Read { sentence, .. } => sentence,
            other => panic!("{line}: {other:?}"),
        }
    }

    /// Ours against pynmea2's (`null` = empty field), to `tol`.
    fn same(ours: Option<f64>, theirs: &Value, tol: f64) -> bool {
        match (ours, theirs.as_f64()) {
            (None, None) => theirs.is_null(),
            (Some(a), Some(b)) => (a - b).abs() <= tol,
            _ => false,
        }
    }

    /// Where pynmea2 reads a sentence that this reader refuses, and why:
    /// pynmea2 does not check field counts, ranges or characters (it
    /// returns the field's text when it cannot convert it).
    const DISAGREE: [(&str, usize, Partial); 6] = [
        // Truncated `$GPRMC,000003.00,A,4807.0`: pynmea2 gives latitude 0.0
        // (no hemisphere letter), this reader counts it partial.
        ("mixed.nmea", 15, Partial::TooFewFields),
        // `$HCHDG,98.3,0.0,E`: three of HDG's five fields.
        ("mixed.nmea", 16, Partial::TooFewFields),
        // `$HCHDM,abc,M`: pynmea2 returns the text `abc` as the heading.
        ("mixed.nmea", 17, Partial::BadNumber),
        // A NUL byte in the heading: pynmea2 returns the text.
        ("mixed.nmea", 26, Partial::NotAscii),
        // Heading 370°: pynmea2 does not check ranges.
        ("mixed.nmea", 28, Partial::OutOfRange),
        // 32 March: pynmea2 returns the text of the date.
        ("mixed.nmea", 35, Partial::BadDate),
    ];

    /// Every line of the three test logs read as pynmea2 reads it
    /// (tests/data/nmea/reference.py wrote the expected values): types,
    /// talkers, times, positions, speeds, courses, headings and the signs of
    /// variation and deviation to 1e-9 (time to 1 µs, pynmea2's
    /// resolution); where pynmea2 refuses a checksum, a bad checksum here.
    #[test]
    fn agrees_with_pynmea2() {
        let reference: Value = serde_json::from_str(REFERENCE).unwrap();
        let mut compared = 0;
        for (name, log) in [("mixed.nmea", MIXED), ("gofree-merrimac-head.nmea", GOFREE), ("n2kd-183-merrimac-head.nmea", N2KD)] {
            let entries = reference["logs"][name].as_array().unwrap();
            let lines = lines(log);
            assert_eq!(entries.len(), lines.len(), "{name}");
            for (e, raw) in entries.iter().zip(&lines) {
                let n = e["n"].as_u64().unwrap() as usize;
                let at = format!("{name}:{n} {:?}", String::from_utf8_lossy(raw));
                let status = e["status"].as_str().unwrap();
                let parsed = parse_line(raw);
                if status == "no_sentence" {
                    assert_eq!(parsed, Line::NotNmea, "{at}");
                    continue;
                }
                let Line::Sentence { no_checksum, outcome, .. } = parsed else { panic!("{at}: {parsed:?}") };
                assert_eq!(no_checksum, status == "ok_no_checksum", "{at}");
                let kind = e["type"].as_str().unwrap_or("");
                match (status, &outcome) {
                    ("bad_checksum", Outcome::BadChecksum { .. }) => {}
                    // pynmea2 reads no `!` sentence; junk after `*hh`.
                    ("parse_error", Outcome::Unknown(u)) if u == "!AIVDM" => {}
                    ("parse_error", Outcome::Partial(Partial::BadChecksumField)) if (name, n) == ("mixed.nmea", 33) => {}
                    ("ok", Outcome::Unknown(u)) if u.starts_with(kind) && !KNOWN.contains(&kind) => {}
                    ("ok" | "ok_no_checksum", Outcome::Partial(p)) => {
                        assert!(DISAGREE.contains(&(name, n, *p)), "{at}: pynmea2 reads it, this reader says {p:?}");
                    }
                    ("ok" | "ok_no_checksum", Outcome::Read { talker, sentence }) => {
                        assert_eq!((talker.as_str(), sentence.kind()), (e["talker"].as_str().unwrap(), kind), "{at}");
                        assert!(e.get("unparsable").is_none(), "{at}: pynmea2 could not convert {}", e["unparsable"]);
                        check_values(sentence, e, &at);
                        compared += 1;
                    }
                    _ => panic!("{at}: pynmea2 {status} {kind}, this reader {outcome:?}"),
                }
            }
        }
        // mixed: 38 lines − 1 without a sentence − 1 bad checksum − 4 that
        // pynmea2 cannot read or of other types − 6 refused here (DISAGREE);
        // gofree: 168 HDG + 18 × (RMC, VTG, VHW, GGA, GLL, ZDA); n2kd: 7 HDG + 13 HDM.
        assert_eq!(compared, 26 + 276 + 20);
    }

    fn check_values(s: &Sentence, e: &Value, at: &str) {
        const DEG: f64 = 1e-9;
        let time_ok = |t: Option<f64>| same(t, &e["time"], 1e-6);
        let ok = match s {
            Sentence::Hdg { heading_deg, deviation_deg, variation_deg } => {
                same(*heading_deg, &e["heading"], DEG) && same(*deviation_deg, &e["deviation"], DEG) && same(*variation_deg, &e["variation"], DEG)
            }
            Sentence::Hdm { heading_deg } | Sentence::Hdt { heading_deg } => same(*heading_deg, &e["heading"], DEG),
            Sentence::Rmc { time_s, valid, date, lat_deg, lon_deg, speed_mps, course_deg, variation_deg } => {
                let date_ok = match (date, e["date"].as_array()) {
                    (Some(d), Some(r)) => [d.year as u64, d.month as u64, d.day as u64] == [r[0].as_u64().unwrap(), r[1].as_u64().unwrap(), r[2].as_u64().unwrap()],
                    (None, None) => true,
                    _ => false,
                };
                time_ok(*time_s)
                    && *valid == (e["fix_status"] == "A" && !["N", "E", "M", "S"].contains(&e["mode"].as_str().unwrap_or("")))
                    && date_ok
                    && same(*lat_deg, &e["lat"], DEG)
                    && same(*lon_deg, &e["lon"], DEG)
                    && same(speed_mps.map(|v| v / KNOT_MPS), &e["speed_kn"], 1e-9)
                    && same(*course_deg, &e["course"], DEG)
                    && same(*variation_deg, &e["variation"], DEG)
            }
            Sentence::Vtg { course_deg, speed_mps, valid } => {
                let speed = match e["speed_kn"].as_f64() {
                    Some(kn) => Some(kn * KNOT_MPS),
                    None => e["speed_kmh"].as_f64().map(|k| k / 3.6),
                };
                same(*course_deg, &e["course"], DEG) && *speed_mps == speed && *valid == (e["mode"] != "N")
            }
            Sentence::Vhw { speed_mps } => {
                let speed = match e["speed_kn"].as_f64() {
                    Some(kn) => Some(kn * KNOT_MPS),
                    None => e["speed_kmh"].as_f64().map(|k| k / 3.6),
                };
                *speed_mps == speed
            }
            Sentence::Gga { time_s, lat_deg, lon_deg, quality } => {
                time_ok(*time_s) && same(*lat_deg, &e["lat"], DEG) && same(*lon_deg, &e["lon"], DEG) && quality.map(u64::from) == e["quality"].as_u64()
            }
            Sentence::Gll { lat_deg, lon_deg, time_s, valid } => {
                time_ok(*time_s) && same(*lat_deg, &e["lat"], DEG) && same(*lon_deg, &e["lon"], DEG) && *valid == (e["fix_status"] == "A" && e["mode"] != "N")
            }
            Sentence::Zda { time_s, date, two_digit_year } => {
                let (y, m, d) = (e["year"].as_i64().unwrap(), e["month"].as_u64().unwrap() as u32, e["day"].as_u64().unwrap() as u32);
                // A two-digit year (pynmea2 gives it as is, e.g. 14) is not a date here.
                let date_ok = if y < 100 { *two_digit_year && date.is_none() } else { *date == Date::new(y as i32, m, d) };
                time_ok(*time_s) && date_ok
            }
        };
        assert!(ok, "{at}: ours {s:?}, pynmea2 {e}");
    }

    /// Field by field, with values worked out by hand from the sentences.
    #[test]
    fn the_fields_and_their_signs() {
        // 4807.038 N = 48 + 7.038/60 = 48.1173°; 01131.000 W = −11.516 666…°;
        // 022.4 kn = 22.4 × 1852/3600 = 11.523 555… m/s; 003.1,W = −3.1°.
        let s = sentence("$GPRMC,123519,A,4807.038,N,01131.000,W,022.4,084.4,230394,003.1,W*78");
        let Sentence::Rmc { time_s, valid, date, lat_deg, lon_deg, speed_mps, course_deg, variation_deg } = s else { panic!() };
        assert_eq!((time_s, valid, date), (Some(12.0 * 3600.0 + 35.0 * 60.0 + 19.0), true, Date::new(1994, 3, 23)));
        assert!((lat_deg.unwrap() - 48.1173).abs() < 1e-12 && (lon_deg.unwrap() + 11.516_666_666_666_667).abs() < 1e-12);
        assert!((speed_mps.unwrap() - 11.523_555_555_555_556).abs() < 1e-12);
        assert_eq!((course_deg, variation_deg), (Some(84.4), Some(-3.1)));
        // HDG: deviation 1.5 W, variation 4.2 E.
        assert_eq!(sentence("$IIHDG,045.3,1.5,W,4.2,E"), Sentence::Hdg { heading_deg: Some(45.3), deviation_deg: Some(-1.5), variation_deg: Some(4.2) });
        // Talker agnostic, lower-case checksum accepted, trailing blanks ignored.
        let Line::Sentence { outcome: Outcome::Read { talker, .. }, no_checksum: false, .. } = parse_line(b"$GNRMC,000000,A,0000.000,S,00000.000,E,0,0,010100,,*1e  ") else { panic!() };
        assert_eq!(talker, "GN");
        assert!(matches!(read("$GNRMC,000000,A,0000.000,S,00000.000,E,0,0,010100,,*1F"), Outcome::BadChecksum { given: 0x1F, computed: 0x1E }));
        // VTG: km/h only: 36 km/h = 10 m/s.
        assert_eq!(sentence("$GPVTG,,T,,M,,N,036.0,K"), Sentence::Vtg { course_deg: None, speed_mps: Some(10.0), valid: true });
        // VHW: speed through water, knots first (its headings not read).
        assert_eq!(sentence("$IIVHW,,T,,M,5.0,N,9.26,K"), Sentence::Vhw { speed_mps: Some(5.0 * 1852.0 / 3600.0) });
        assert_eq!(sentence("$IIVHW,,T,,M,,N,36.0,K"), Sentence::Vhw { speed_mps: Some(10.0) });
        // A prefix before the $ is skipped; NUL bytes before it too.
        assert!(matches!(parse_line(b"\0\0[12:00:01] $HCHDM,010.0,M"), Line::Sentence { prefixed: true, no_checksum: true, outcome: Outcome::Read { .. }, .. }));
        // Void and invalid letters.
        assert!(sentence("$GPGLL,4916.45,N,12311.12,W,225444,V").is_void());
        assert!(sentence("$GPGGA,123519,4807.038,N,01131.000,E,6,08,0.9,545.4,M,46.9,M,,").is_void());
        assert_eq!(read("$GPGLL,4916.45,X,12311.12,W,225444,A"), Outcome::Partial(Partial::BadLetter));
        assert_eq!(read("$HCHDT,100.0,M"), Outcome::Partial(Partial::BadLetter));
        assert_eq!(read("$HCHDG,100.0,1.0,,2.0,E"), Outcome::Partial(Partial::BadLetter));
        assert_eq!(read("$GPGGA,256000,4807.038,N,01131.000,E,1,08"), Outcome::Partial(Partial::BadTime));
        assert_eq!(read("$GPRMC,123519,A,4860.000,N,01131.000,E,0,0,230394,,"), Outcome::Partial(Partial::OutOfRange));
        assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,1e3,0,230394,,"), Outcome::Partial(Partial::BadNumber));
        assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,inf,0,230394,,"), Outcome::Partial(Partial::BadNumber));
        assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,-1,0,230394,,"), Outcome::Partial(Partial::OutOfRange));
        assert_eq!(read("$GPRMC,123519,A,4807.038,N,01131.000,E,1,0,290223,,"), Outcome::Partial(Partial::BadDate));
        assert_eq!(read("$gprmc,123519,A"), Outcome::Partial(Partial::BadAddress));
        assert_eq!(read("$GPRMC"), Outcome::Partial(Partial::TooFewFields));
        assert_eq!(read("$GPRMC,1*5"), Outcome::Partial(Partial::BadChecksumField));
        assert_eq!(read("$GPRMC,1*+5"), Outcome::Partial(Partial::BadChecksumField));
        assert_eq!(read("$PGRME,15.0,M,45.0,M,25.0,M*1C"), Outcome::Unknown("PGRME".into()));
        assert_eq!(read("$GPGSV,1,1,00*79"), Outcome::Unknown("GSV".into()));
        // 2024-02-29 exists (a leap year), 1900-02-29 does not; the epoch's day count.
        assert!(Date::new(2024, 2, 29).is_some() && Date::new(1900, 2, 29).is_none() && Date::new(2000, 2, 29).is_some());
        assert_eq!(Date::new(2021, 3, 1).unwrap().days_since_epoch(), 18_687);
        for days in [-800_000, -1, 0, 1, 18_687, 2_932_896] {
            let d = Date::from_days_since_epoch(days);
            assert_eq!(Date::new(d.year, d.month, d.day).unwrap().days_since_epoch(), days);
        }
    }

    /// Every prefix of a well-formed sentence (a line cut short) is either
    /// refused or read with the values the whole sentence gives (none
    /// invented, none changed).
    #[test]
    fn a_truncated_sentence_never_gives_a_wrong_value() {
        let mut read_prefixes = 0;
        for whole in lines(MIXED).into_iter().chain(lines(GOFREE)) {
            let Line::Sentence { outcome: Outcome::Read { sentence: full, .. }, .. } = parse_line(whole) else { continue };
            let values = |s: &Sentence| -> Vec<Option<f64>> {
                match s {
                    Sentence::Hdg { heading_deg, deviation_deg, variation_deg } => vec![*heading_deg, *deviation_deg, *variation_deg],
                    Sentence::Hdm { heading_deg } | Sentence::Hdt { heading_deg } => vec![*heading_deg],
                    Sentence::Rmc { time_s, lat_deg, lon_deg, speed_mps, course_deg, variation_deg, .. } => vec![*time_s, *lat_deg, *lon_deg, *speed_mps, *course_deg, *variation_deg],
                    Sentence::Vtg { course_deg, speed_mps, .. } => vec![*course_deg, *speed_mps],
                    Sentence::Vhw { speed_mps } => vec![*speed_mps],
                    Sentence::Gga { time_s, lat_deg, lon_deg, .. } => vec![*time_s, *lat_deg, *lon_deg],
                    Sentence::Gll { time_s, lat_deg, lon_deg, .. } => vec![*time_s, *lat_deg, *lon_deg],
                    Sentence::Zda { time_s, .. } => vec![*time_s],
                }
            };
            let want = values(&full);
            let start = whole.iter().position(|&b| b == b'$').unwrap();
            for cut in start + 1..whole.len() {
                if let Line::Sentence { outcome: Outcome::Read { sentence, .. }, no_checksum, .. } = parse_line(&whole[..cut]) {
                    assert!(no_checksum, "{:?}", String::from_utf8_lossy(&whole[..cut]));
                    assert_eq!(sentence.kind(), full.kind());
                    for (got, want) in values(&sentence).iter().zip(&want) {
                        assert!(got.is_none() || got == want, "{:?}: {got:?} (the whole sentence: {want:?})", String::from_utf8_lossy(&whole[..cut]));
                    }
                    read_prefixes += 1;
                }
            }
        }
        // Cut just before `*`, or after a complete last field: measured.
        // Measured: the cuts that leave every field the type needs (e.g.
        // just before `*hh`, or inside GGA's unused altitude).
        assert_eq!(read_prefixes, 1037);
    }

    proptest::proptest! {
        /// No byte string makes the reader or the import panic.
        #[test]
        fn any_bytes_are_safe(bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..400)) {
            let _ = parse_line(&bytes);
            let _ = import(&bytes, &ImportOptions::default());
        }

        /// Sentences damaged anywhere (a byte changed, or the log cut at any
        /// point) never panic and are refused or counted.
        #[test]
        fn damaged_logs_are_safe(at in 0usize..2000, byte in proptest::prelude::any::<u8>(), cut in 0usize..2000) {
            let mut log = MIXED.to_vec();
            let i = at % log.len();
            log[i] = byte;
            log.truncate(cut.max(i + 1));
            if let Ok(im) = import(&log, &ImportOptions::default()) {
                proptest::prop_assert!(im.report.rows > 0);
            }
        }
    }

    fn t_of(im: &Imported) -> Vec<f64> {
        im.column(col::T).unwrap().to_vec()
    }

    /// The time rule, on numbers worked out by hand.
    #[test]
    fn untimed_sentences_are_spread_between_timed_ones() {
        let log = "$GPRMC,100000,A,,,,,,,010121,,\n\
                   $HCHDM,001.0,M\n$HCHDM,002.0,M\n$HCHDM,003.0,M\n\
                   $GPGGA,100002,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
                   $HCHDM,004.0,M\n\
                   $GPGLL,4807.038,N,01131.000,E,100002,A\n\
                   $HCHDM,005.0,M\n\
                   $GPZDA,100003,01,01,2021,00,00\n";
        let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
        // 3 HDM between 10:00:00 and 10:00:02: 0.5, 1.0, 1.5 s; the HDM
        // between two sentences of 10:00:02 gets 2 s; the last, between
        // 10:00:02 and 10:00:03, 2.5 s. The RMC gives no row (no value).
        assert_eq!(t_of(&im), [0.5, 1.0, 1.5, 2.0, 2.0, 2.0, 2.5]);
        assert_eq!(im.column(col::COMPASS_HEADING_DEG).unwrap()[..3], [1.0, 2.0, 3.0]);
        assert_eq!(im.report.start_utc.as_deref(), Some("2021-01-01T10:00:00Z"));
        assert_eq!(im.report.used.get("RMC"), Some(&1));
        // Before the first and after the last timed sentence, and over a gap
        // longer than MAX_SPREAD_GAP_S: counted, not used.
        let log = "$HCHDM,001.0,M\n$GPZDA,100000,01,01,2021,00,00\n$HCHDM,002.0,M\n$GPZDA,100001,01,01,2021,00,00\n\
                   $HCHDM,003.0,M\n$GPZDA,100020,01,01,2021,00,00\n$HCHDM,004.0,M\n";
        let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
        assert_eq!(t_of(&im), [0.5]);
        let r = &im.report;
        assert_eq!((r.untimed_before_first_time, r.untimed_in_gaps, r.untimed_after_last_time), (1, 1, 1));
        assert_eq!(r.duration_s, 0.5);
    }

    /// GGA and GLL carry the time of day: dated by RMC/ZDA, the day advancing
    /// at midnight; a time going back is dropped.
    #[test]
    fn midnight_and_time_going_back() {
        let log = "$GPGGA,235959.5,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
                   $GPRMC,000000.5,A,4807.038,N,01131.000,E,5.0,090.0,010321,,\n\
                   $HCHDM,010.0,M\n\
                   $GPGGA,000001.5,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
                   $GPGGA,000000.0,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n\
                   $GPGLL,4807.038,N,01131.000,E,000002.5,A\n";
        let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
        // The first GGA, before the first date (1 March) and 12 h after its
        // time of day, is 28 February 23:59:59.5: t = 0, 1, 1.5, 2, (back: dropped), 3.
        assert_eq!(t_of(&im), [0.0, 1.0, 1.5, 2.0, 3.0]);
        assert_eq!(im.report.start_utc.as_deref(), Some("2021-02-28T23:59:59.500Z"));
        assert_eq!(im.report.time_backwards, 1);
        // 5 kn ≥ 0.5 m/s: the course is the reference (no HDT).
        assert_eq!(im.report.reference, Reference::Course);
        assert_eq!(im.column(col::REF_HEADING_DEG).unwrap()[1], 90.0);
        // Without any date: t from the first time of day, no start_utc, said.
        let im = import(b"$GPGGA,120000,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n$HCHDM,010.0,M\n$GPGGA,120001,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n", &ImportOptions::default()).unwrap();
        assert_eq!(t_of(&im), [0.0, 0.5, 1.0]);
        assert_eq!((im.report.start_utc.as_deref(), im.report.start_time_of_day_utc.as_str()), (None, "12:00:00"));
        assert!(im.report.notes.iter().any(|n| n.contains("no date")), "{:?}", im.report.notes);
    }

    /// The hand-made log (tests/data/nmea/make_mixed.py): every count
    /// follows from its 38 lines (see the comments there).
    #[test]
    fn the_mixed_log_is_counted_by_kind() {
        let im = import(MIXED, &ImportOptions::default()).unwrap();
        let r = &im.report;
        assert_eq!((r.lines, r.sentences, r.non_nmea_lines, r.prefixed_lines), (38, 37, 1, 1));
        // Line 14; lines 15, 16, 17, 26, 28, 33, 35; lines 20, 21, 22.
        assert_eq!((r.bad_checksum, r.partial, r.unknown), (1, 7, 3));
        // Lines 10 and 15 have no checksum; 18, 19, 32 are void; 23 is empty.
        assert_eq!((r.missing_checksum, r.void_fixes, r.empty_values), (2, 3, 1));
        // HCHDG (4) is the compass; HCHDM (3) and 24HDG (1) are not used.
        assert_eq!((r.compass_source.as_deref(), r.other_source), (Some("HCHDG"), 4));
        assert_eq!(r.reference, Reference::Hdt);
        assert_eq!(r.start_utc.as_deref(), Some("2021-02-28T23:59:58.500Z"));
        assert_eq!(r.rows, 16);
        // HDG lines 2, 3 and HDT 4 between 23:59:58.5 (line 1) and 23:59:59
        // (line 5): t = 0.125, 0.25, 0.375; line 8 between 00:00:00 and
        // 00:00:01: 2.0; lines 10-12 between 00:00:01 and 00:00:02: 2.75, 3.0, 3.25.
        let t = t_of(&im);
        assert_eq!(t, [0.0, 0.125, 0.25, 0.375, 0.5, 1.5, 2.0, 2.5, 2.75, 3.0, 3.25, 8.5, 9.5, 10.5, 14.0, 14.5]);
        let heading = im.column(col::COMPASS_HEADING_DEG).unwrap();
        assert_eq!([heading[1], heading[2], heading[6], heading[8]], [98.3, 101.5, 99.0, 99.5]);
        assert!(r.notes.iter().any(|n| n.contains("NOT applied") && n.contains("2.5")), "{:?}", r.notes);
        assert!(r.notes.iter().any(|n| n.contains("two-digit year")), "{:?}", r.notes);
        assert_eq!(im.column(col::REF_HEADING_DEG).unwrap()[3], 100.1);
        assert_eq!(r.columns, [col::T, col::COMPASS_HEADING_DEG, col::VARIATION_DEG, col::REF_HEADING_DEG, col::COURSE_DEG, col::GPS_SPEED_MPS, col::LAT_DEG, col::LON_DEG]);
    }

    /// Each HDT by its talker: the compass's own (its HDG's talker, or HC)
    /// left out and counted; a GNSS compass's the reference; another
    /// talker's only when named; the compass's talker never.
    #[test]
    fn an_hdt_is_the_reference_only_from_an_independent_talker() {
        let log = |hdt: &str| format!("$GPRMC,100000,A,4807.038,N,01131.000,E,5.0,090.0,010121,,\n$24HDG,010.0,,,,\n${hdt}HDT,012.0,T\n$GPRMC,100001,A,4807.038,N,01131.000,E,5.0,091.0,010121,,\n");
        let run = |hdt: &str, named: Option<&str>| import(log(hdt).as_bytes(), &ImportOptions { reference_talker: named.map(str::to_string), ..ImportOptions::default() });
        let im = run("24", None).unwrap();
        assert_eq!((im.report.reference, im.report.compass_true_headings), (Reference::Course, 1));
        assert_eq!(im.report.column_sources.get(col::REF_HEADING_DEG).map(String::as_str), Some("GPRMC (course over ground at 0.5 m/s or more)"));
        assert_eq!(run("HC", None).unwrap().report.compass_true_headings, 1);
        let im = run("GN", None).unwrap();
        assert_eq!((im.report.reference, im.report.column_sources.get(col::REF_HEADING_DEG).map(String::as_str)), (Reference::Hdt, Some("GNHDT")));
        let im = run("II", None).unwrap();
        assert_eq!((im.report.reference, im.report.unplaced_true_headings, im.report.unplaced_true_heading_sources.clone()), (Reference::Course, 1, vec!["IIHDT".to_string()]));
        assert_eq!(run("II", Some("II")).unwrap().report.reference, Reference::Hdt);
        let e = run("24", Some("24")).unwrap_err().to_string();
        assert!(e.starts_with("24 is the compass's own talker (24HDG)"), "{e}");
        assert!(run("II", Some("ii")).unwrap_err().to_string().contains("not \"ii\""));
    }

    /// A dated sentence far from both neighbours is refused alone, at the
    /// log's start, middle and end; a pause (neighbours apart too) is kept.
    #[test]
    fn a_date_jump_is_refused_alone() {
        let rmc = |s: u32, date: &str| format!("$GPRMC,1000{s:02},A,4807.038,N,01131.000,E,5.0,090.0,{date},,\n");
        for bad in [0, 5, 9] {
            let log: String = (0..10).map(|s| rmc(s, if s == bad { "010122" } else { "010121" })).collect();
            let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
            assert_eq!((im.report.date_jumps, im.report.rows, im.report.time_backwards), (1, 9, 0), "{bad}");
            assert_eq!(im.report.start_utc.as_deref(), Some(if bad == 0 { "2021-01-01T10:00:01Z" } else { "2021-01-01T10:00:00Z" }));
        }
        // Two days apart, five fixes each: a pause, nothing refused.
        let log: String = (0..10).map(|s| rmc(s, if s < 5 { "010121" } else { "030121" })).collect();
        let im = import(log.as_bytes(), &ImportOptions::default()).unwrap();
        assert_eq!((im.report.date_jumps, im.report.rows), (0, 10));
    }

    /// The refusals, each with what the input looked like.
    #[test]
    fn refusals_say_what_the_input_was() {
        let err = |b: &[u8]| import(b, &ImportOptions::default()).unwrap_err().to_string();
        assert_eq!(err(b""), "no NMEA 0183 sentence: the file is empty (0 bytes)");
        assert!(err(&[0xA3, 0x95, 0x80, 0, 1, 2, b'$', 200]).contains("not text: a binary file"));
        assert!(err(b"!AIVDM,1,1,,A,14eG;o@034o8sd<L9i:a;WF>062D,0*7D\r\n").contains("1 `!` sentences (AIS"));
        assert!(err(b"t,mx,my,mz\n0,1,2,3\n").contains("no line holds a `$` sentence (first line: \"t,mx,my,mz\")"));
        assert!(err(&[b'$'; 3000]).contains("longer than 1024 bytes"));
        let e = err(b"$IIMWV,271.0,R,000.2,N,A*3B\n$GPGGA,120000,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,\n");
        assert!(e.starts_with("nothing to calibrate with: no heading sentence"), "{e}");
        let e = err(N2KD);
        assert!(e.starts_with("no sentence gives a time"), "{e}");
        // Headings only outside the timed part.
        let e = err(b"$HCHDM,001.0,M\n$GPZDA,100000,01,01,2021,00,00\n");
        assert!(e.contains("no heading or course could be timed (1 before the first timed sentence"), "{e}");
    }
}
