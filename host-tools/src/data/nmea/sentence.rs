//! The sentence grammar: a line's `$`/`!` sentence, its checksum, its
//! address and the fields of each known type; and the log's lines.

use std::io::Read;

use super::{Date, KNOT_MPS, KNOWN, MAX_LINE_BYTES};

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
    pub(super) fn heading_deg(&self) -> Option<f64> {
        match self {
            Self::Hdg { heading_deg, .. } | Self::Hdm { heading_deg } | Self::Hdt { heading_deg } => *heading_deg,
            _ => None,
        }
    }

    /// A void fix (the import uses nothing of it).
    pub(super) fn is_void(&self) -> bool {
        match self {
            Self::Rmc { valid, .. } | Self::Vtg { valid, .. } | Self::Gll { valid, .. } => !valid,
            Self::Gga { quality, .. } => !matches!(quality, Some(1..=5)),
            _ => false,
        }
    }

    /// A sentence that holds nothing the import keeps (an empty heading, a
    /// VTG without course and speed).
    pub(super) fn is_empty(&self) -> bool {
        match self {
            Self::Hdg { .. } | Self::Hdm { .. } | Self::Hdt { .. } => self.heading_deg().is_none(),
            Self::Vtg { course_deg, speed_mps, .. } => course_deg.is_none() && speed_mps.is_none(),
            Self::Vhw { speed_mps } => speed_mps.is_none(),
            _ => false,
        }
    }

    /// Its time of day and date, if it carries a time.
    pub(super) fn stamp(&self) -> Option<(f64, Option<Date>)> {
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
    pub(super) fn framed(self) -> bool {
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
pub(super) fn for_each_line<R: Read>(mut reader: R, mut each: impl FnMut(Option<&[u8]>)) -> std::io::Result<(u64, u64)> {
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
