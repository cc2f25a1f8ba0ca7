//! The text formats' lines: canboat's (`timestamp,prio,pgn,src,dst,len,hex…`,
//! FAST or PLAIN) and Actisense's N2K ASCII (`Ahhmmss.ddd SSDDP PPPPP hex`),
//! their timestamps, and the fast-packet reassembly of a PLAIN log.

use std::collections::BTreeMap;

use super::pgn::is_fast_packet;
use crate::data::nmea::Date;

/// The longest line read, bytes (a canboat line of an ISO transport message
/// of 1785 bytes is about 5.4 kB); longer lines are counted and skipped.
pub const MAX_LINE_BYTES: usize = 8192;

/// The longest payload a line may declare, bytes (ISO 11783 transport).
pub const MAX_PAYLOAD_BYTES: usize = 1785;

/// The longest fast-packet payload, bytes (6 in the first frame, 7 in each
/// of 31 more).
pub const MAX_FAST_PACKET_BYTES: usize = 223;

/// A log's text format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextFormat {
    /// canboat FAST: one line per whole PGN (fast packets assembled).
    Fast,
    /// canboat PLAIN: one line per CAN frame (fast packets in frames).
    Plain,
    /// Actisense N2K ASCII (`A173321.107 23FF7 1F513 012F…`): whole PGNs.
    Actisense,
}

/// What a line's timestamp is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TimeForm {
    /// A date and time (`2026-07-02T06:01:32.996Z`, `2011-11-24-22:42:04.388`);
    /// `utc` when it ends in `Z`.
    DateTime {
        /// Ends in `Z`.
        utc: bool,
    },
    /// A number of seconds (`12.345`).
    Seconds,
    /// A time of day without a date (Actisense's `hhmmss.ddd`).
    TimeOfDay,
}

/// One NMEA 2000 message (a whole PGN).
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    /// Its time, s after [`Log::base_s`].
    pub t_s: f64,
    /// Priority (0–7).
    pub prio: u8,
    /// Parameter group number.
    pub pgn: u32,
    /// Source address.
    pub src: u8,
    /// Destination address.
    pub dst: u8,
    /// The payload.
    pub data: Vec<u8>,
}

/// A log read into messages.
#[derive(Debug, Clone)]
pub struct Log {
    /// Its text format.
    pub format: TextFormat,
    /// Its timestamps' form.
    pub time: TimeForm,
    /// What the messages' times count from: for a date and time, the
    /// first message's day's midnight, s since 1970-01-01 (UTC when the
    /// timestamps end in `Z`); 0 otherwise (the seconds as written, or the
    /// first day's midnight for a time of day). Times are kept from it so
    /// that a millisecond stays exact in an `f64`.
    pub base_s: f64,
    /// The whole messages, in the log's order (a PLAIN log's fast packets
    /// at their last frame).
    pub messages: Vec<Message>,
    /// CAN frames read (a PLAIN log's lines); 0 for the other formats.
    pub frames: usize,
    /// Lines and frames refused, by kind.
    pub skipped: BTreeMap<&'static str, usize>,
}

/// Why a line was refused (the report's kind).
type Refusal = &'static str;

/// A line before assembly.
struct Raw {
    /// Days since 1970-01-01 (a date and time), else 0.
    day: i64,
    /// s since that day's midnight, or the seconds, or the time of day.
    t_s: f64,
    form: TimeForm,
    prio: u8,
    pgn: u32,
    src: u8,
    dst: u8,
    data: Vec<u8>,
    actisense: bool,
}

/// Reads a log's lines; when no line is a message of either format, the
/// refusals by kind (what was found).
pub fn read(bytes: &[u8]) -> Result<Log, BTreeMap<&'static str, usize>> {
    let mut skipped: BTreeMap<&'static str, usize> = BTreeMap::new();
    let mut declared: Option<TextFormat> = None;
    let mut raws: Vec<Raw> = Vec::new();
    for line in bytes.split(|&b| b == b'\n' || b == b'\r') {
        if line.len() > MAX_LINE_BYTES {
            *skipped.entry("line_too_long").or_default() += 1;
            continue;
        }
        let Ok(text) = std::str::from_utf8(line) else {
            *skipped.entry("not_text").or_default() += 1;
            continue;
        };
        let text = text.trim();
        if text.is_empty() {
            continue;
        }
        if let Some(comment) = text.strip_prefix('#') {
            match comment.trim().strip_prefix("format=").map(str::trim) {
                Some(f) if f.eq_ignore_ascii_case("FAST") => declared = Some(TextFormat::Fast),
                Some(f) if f.eq_ignore_ascii_case("PLAIN") => declared = Some(TextFormat::Plain),
                _ => {}
            }
            continue;
        }
        match parse_line(text) {
            Ok(raw) => raws.push(raw),
            Err(kind) => *skipped.entry(kind).or_default() += 1,
        }
    }
    let Some(first) = raws.first() else { return Err(skipped) };
    let (actisense, form) = (first.actisense, first.form);
    let format = if actisense {
        TextFormat::Actisense
    } else {
        declared.unwrap_or(if raws.iter().any(|r| !r.actisense && r.data.len() > 8) { TextFormat::Fast } else { TextFormat::Plain })
    };
    let base_day = first.day;
    let base_s = base_day as f64 * 86_400.0;
    let mut log = Log { format, time: form, base_s, messages: Vec::new(), frames: 0, skipped: BTreeMap::new() };
    let mut day = Day::default();
    let mut fast = Reassembly::default();
    for mut raw in raws {
        if raw.actisense != actisense {
            *skipped.entry("line_of_the_other_text_format").or_default() += 1;
            continue;
        }
        if std::mem::discriminant(&raw.form) != std::mem::discriminant(&form) {
            *skipped.entry("timestamp_of_another_form").or_default() += 1;
            continue;
        }
        if form == TimeForm::TimeOfDay {
            raw.t_s = day.place(raw.t_s);
        } else {
            raw.t_s += (raw.day - base_day) as f64 * 86_400.0;
        }
        let m = Message { t_s: raw.t_s, prio: raw.prio, pgn: raw.pgn, src: raw.src, dst: raw.dst, data: raw.data };
        if format == TextFormat::Plain {
            log.frames += 1;
            if m.data.len() <= 8 && is_fast_packet(m.pgn) {
                if let Some(whole) = fast.frame(m, &mut skipped) {
                    log.messages.push(whole);
                }
                continue;
            }
        }
        log.messages.push(m);
    }
    fast.finish(&mut skipped);
    log.skipped = skipped;
    Ok(log)
}

/// Whether the first lines look like one of the formats: among the first
/// 20 complete lines that are not comments, at least one message and no
/// more lines that are not.
pub fn looks_like(head: &[u8]) -> bool {
    // The last line may be cut by the head's end: only complete lines.
    let complete = match head.iter().rposition(|&b| b == b'\n' || b == b'\r') {
        Some(end) => &head[..end],
        None => return false,
    };
    let (mut good, mut bad) = (0usize, 0usize);
    for line in complete.split(|&b| b == b'\n' || b == b'\r').filter(|l| !l.is_empty()).take(40) {
        let Ok(text) = std::str::from_utf8(line) else { return false };
        let text = text.trim();
        if text.is_empty() || text.starts_with('#') {
            continue;
        }
        match parse_line(text) {
            Ok(_) => good += 1,
            Err(_) => bad += 1,
        }
        if good + bad >= 20 {
            break;
        }
    }
    good > 0 && good >= bad
}

/// One line of either format.
fn parse_line(text: &str) -> Result<Raw, Refusal> {
    if text.starts_with('A') && text.as_bytes().get(1).is_some_and(u8::is_ascii_digit) {
        return parse_actisense(text);
    }
    let mut fields = text.split(',');
    let stamp = fields.next().unwrap_or("");
    let mut header = [0u32; 5];
    for h in header.iter_mut() {
        let f = fields.next().ok_or("too_few_fields")?.trim();
        *h = decimal(f).ok_or("bad_header_number")?;
    }
    let [prio, pgn, src, dst, len] = header;
    let (prio, src, dst) = (u8::try_from(prio).ok().filter(|p| *p <= 7).ok_or("bad_header_number")?, byte(src)?, byte(dst)?);
    let len = usize::try_from(len).ok().filter(|l| *l <= MAX_PAYLOAD_BYTES).ok_or("bad_header_number")?;
    let mut data = Vec::with_capacity(len);
    for f in fields {
        if data.len() == len {
            return Err("wrong_length");
        }
        data.push(hex_byte(f.trim()).ok_or("bad_hex")?);
    }
    if data.len() != len {
        return Err("wrong_length");
    }
    let (day, t_s, form) = timestamp(stamp.trim()).ok_or("bad_timestamp")?;
    Ok(Raw { day, t_s, form, prio, pgn, src, dst, data, actisense: false })
}

/// `Ahhmmss.ddd SSDDP PPPPP hexdata`: source, destination (two hex digits
/// each) and priority (one), the PGN in hex, the payload as hex pairs.
fn parse_actisense(text: &str) -> Result<Raw, Refusal> {
    let mut parts = text.split_ascii_whitespace();
    let (Some(time), Some(addr), Some(pgn), Some(hex), None) = (parts.next(), parts.next(), parts.next(), parts.next(), parts.next()) else {
        return Err("too_few_fields");
    };
    let tod = time.get(1..).and_then(time_of_day_compact).ok_or("bad_timestamp")?;
    if addr.len() != 5 || pgn.is_empty() || pgn.len() > 5 {
        return Err("bad_header_number");
    }
    let number = |s: &str| u32::from_str_radix(s, 16).ok().filter(|_| s.bytes().all(|b| b.is_ascii_hexdigit()));
    let (src, dst, prio) = (
        addr.get(..2).and_then(number).ok_or("bad_header_number")?,
        addr.get(2..4).and_then(number).ok_or("bad_header_number")?,
        addr.get(4..).and_then(number).ok_or("bad_header_number")?,
    );
    let pgn = number(pgn).ok_or("bad_header_number")?;
    if hex.len() % 2 != 0 || hex.len() / 2 > MAX_PAYLOAD_BYTES {
        return Err("wrong_length");
    }
    let data = hex.as_bytes().chunks(2).map(|c| std::str::from_utf8(c).ok().and_then(hex_byte)).collect::<Option<Vec<u8>>>().ok_or("bad_hex")?;
    Ok(Raw { day: 0, t_s: tod, form: TimeForm::TimeOfDay, prio: u8::try_from(prio).ok().filter(|p| *p <= 7).ok_or("bad_header_number")?, pgn, src: byte(src)?, dst: byte(dst)?, data, actisense: true })
}

fn byte(v: u32) -> Result<u8, Refusal> {
    u8::try_from(v).map_err(|_| "bad_header_number")
}

/// Decimal digits only (at most 9: no overflow).
fn decimal(s: &str) -> Option<u32> {
    (!s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit())).then(|| s.parse().ok()).flatten()
}

/// One or two hex digits.
fn hex_byte(s: &str) -> Option<u8> {
    (!s.is_empty() && s.len() <= 2 && s.bytes().all(|b| b.is_ascii_hexdigit())).then(|| u8::from_str_radix(s, 16).ok()).flatten()
}

/// A canboat timestamp: `YYYY-MM-DD`, a separator (`T`, `-` or a space),
/// `HH:MM:SS`, an optional fraction (`.` or `,` and digits) and an optional
/// `Z`; or a number of seconds (`digits[.digits]`). The day (days since
/// 1970-01-01; 0 for seconds) and the seconds into it.
fn timestamp(s: &str) -> Option<(i64, f64, TimeForm)> {
    if !s.is_empty() && s.len() <= 20 && s.bytes().all(|b| b.is_ascii_digit() || b == b'.') && s.bytes().filter(|&b| b == b'.').count() <= 1 && !s.starts_with('.') {
        return s.parse::<f64>().ok().filter(|v| v.is_finite()).map(|v| (0, v, TimeForm::Seconds));
    }
    let b = s.as_bytes();
    let digits = |from: usize, n: usize| -> Option<u32> { s.get(from..from + n).and_then(decimal) };
    if b.len() < 19 || b.get(4) != Some(&b'-') || b.get(7) != Some(&b'-') || !matches!(b.get(10), Some(b'T' | b'-' | b' ')) || b.get(13) != Some(&b':') || b.get(16) != Some(&b':') {
        return None;
    }
    let date = Date::new(i32::try_from(digits(0, 4)?).ok()?, digits(5, 2)?, digits(8, 2)?)?;
    let (h, m, sec) = (digits(11, 2)?, digits(14, 2)?, digits(17, 2)?);
    if h > 23 || m > 59 || sec > 60 {
        return None;
    }
    let rest = s.get(19..)?;
    let (rest, utc) = match rest.strip_suffix('Z') {
        Some(r) => (r, true),
        None => (rest, false),
    };
    let frac = fraction(rest)?;
    Some((date.days_since_epoch(), f64::from(h * 3600 + m * 60 + sec) + frac, TimeForm::DateTime { utc }))
}

/// `""`, or `.ddd` / `,ddd` (1–9 digits): the fraction of a second.
fn fraction(rest: &str) -> Option<f64> {
    if rest.is_empty() {
        return Some(0.0);
    }
    let digits = rest.strip_prefix('.').or_else(|| rest.strip_prefix(','))?;
    let v = decimal(digits)?;
    Some(f64::from(v) / 10f64.powi(i32::try_from(digits.len()).ok()?))
}

/// `hhmmss[.ddd]` → s since midnight.
fn time_of_day_compact(s: &str) -> Option<f64> {
    let (h, m, sec) = (s.get(0..2).and_then(decimal)?, s.get(2..4).and_then(decimal)?, s.get(4..6).and_then(decimal)?);
    if h > 23 || m > 59 || sec > 60 {
        return None;
    }
    Some(f64::from(h * 3600 + m * 60 + sec) + fraction(s.get(6..)?)?)
}

/// Times of day placed on consecutive days: the day advances when the time
/// of day goes back by more than 12 h (midnight passed).
#[derive(Default)]
struct Day {
    offset_s: f64,
    last_s: Option<f64>,
}

impl Day {
    fn place(&mut self, tod_s: f64) -> f64 {
        if let Some(last) = self.last_s {
            if tod_s + 43_200.0 < last {
                self.offset_s += 86_400.0;
            }
        }
        self.last_s = Some(tod_s);
        tod_s + self.offset_s
    }
}

/// A fast packet being assembled.
struct Pending {
    seq: u8,
    next_index: u8,
    total: usize,
    data: Vec<u8>,
}

/// The fast packets of a PLAIN log being assembled, by source and PGN.
#[derive(Default)]
struct Reassembly {
    pending: BTreeMap<(u8, u32), Pending>,
}

impl Reassembly {
    /// Takes one frame (byte 0: sequence counter in bits 5–7, frame index in
    /// bits 0–4; the first frame's byte 1 the payload's length, then 6
    /// bytes; later frames 7 bytes each); the whole message when complete.
    fn frame(&mut self, m: Message, skipped: &mut BTreeMap<&'static str, usize>) -> Option<Message> {
        let mut skip = |kind| *skipped.entry(kind).or_default() += 1;
        let key = (m.src, m.pgn);
        let Some(&b0) = m.data.first() else {
            skip("fast_packet_empty_frame");
            return None;
        };
        let (seq, index) = (b0 >> 5, b0 & 0x1F);
        let p = if index == 0 {
            if self.pending.remove(&key).is_some() {
                skip("fast_packet_incomplete");
            }
            let Some(&total) = m.data.get(1) else {
                skip("fast_packet_empty_frame");
                return None;
            };
            let total = usize::from(total);
            if total > MAX_FAST_PACKET_BYTES {
                skip("fast_packet_bad_length");
                return None;
            }
            self.pending.entry(key).or_insert(Pending { seq, next_index: 1, total, data: m.data.get(2..).unwrap_or_default().to_vec() })
        } else {
            match self.pending.get_mut(&key) {
                Some(p) if p.seq == seq && p.next_index == index => {
                    p.data.extend_from_slice(m.data.get(1..).unwrap_or_default());
                    p.next_index += 1;
                    p
                }
                Some(_) => {
                    self.pending.remove(&key);
                    skip("fast_packet_incomplete");
                    skip("fast_packet_frame_without_start");
                    return None;
                }
                None => {
                    skip("fast_packet_frame_without_start");
                    return None;
                }
            }
        };
        if p.data.len() < p.total {
            return None;
        }
        let mut done = self.pending.remove(&key)?;
        done.data.truncate(done.total);
        Some(Message { data: done.data, ..m })
    }

    /// Packets still incomplete at the log's end.
    fn finish(self, skipped: &mut BTreeMap<&'static str, usize>) {
        if !self.pending.is_empty() {
            *skipped.entry("fast_packet_incomplete").or_default() += self.pending.len();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timestamps_of_every_form() {
        let (day, t, f) = timestamp("2026-07-02T06:01:32.996Z").unwrap();
        assert_eq!(f, TimeForm::DateTime { utc: true });
        // 2026-07-02 is day 20636 since 1970-01-01.
        assert_eq!(day, 20_636);
        assert!((t - (6.0 * 3600.0 + 60.0 + 32.996)).abs() < 1e-9, "{t}");
        assert_eq!(timestamp("2011-11-24-22:42:04.388").unwrap().2, TimeForm::DateTime { utc: false });
        assert_eq!(timestamp("2011-11-24 22:42:04,5").unwrap().1 % 1.0, 0.5);
        assert_eq!(timestamp("12.25").unwrap(), (0, 12.25, TimeForm::Seconds));
        for bad in ["", "2026-13-02T06:01:32Z", "2026-07-02T25:01:32Z", "2026-07-02T06:01:32.x", "1.2.3", "yesterday"] {
            assert!(timestamp(bad).is_none(), "{bad}");
        }
        assert_eq!(time_of_day_compact("000159.990"), Some(119.99));
    }

    #[test]
    fn lines_of_both_formats_and_their_refusals() {
        let r = parse_line("2026-07-02T06:01:33.010Z,2,65350,27,255,8,f9,fd,01,f6,cd,23,02,ff").unwrap();
        assert_eq!((r.prio, r.pgn, r.src, r.dst, r.data.len()), (2, 65350, 27, 255, 8));
        let a = parse_line("A000200.004 96FF2 1F802 FFFCCA300100FFFF").unwrap();
        assert_eq!((a.prio, a.pgn, a.src, a.dst, a.data.len(), a.t_s), (2, 129026, 150, 255, 8, 120.004));
        for (line, kind) in [
            ("2026-07-02T06:01:33.010Z,2,65350,27,255", "too_few_fields"),
            ("2026-07-02T06:01:33.010Z,2,65350,27,255,8,f9,fd,01,f6,cd,23,02", "wrong_length"),
            ("2026-07-02T06:01:33.010Z,2,65350,27,255,2,f9,fd,01", "wrong_length"),
            ("2026-07-02T06:01:33.010Z,2,65350,27,255,2,f9,zz", "bad_hex"),
            ("2026-07-02T06:01:33.010Z,9,65350,27,255,2,f9,00", "bad_header_number"),
            ("2026-07-02T06:01:33.010Z,2,65350,300,255,2,f9,00", "bad_header_number"),
            ("2026-07-02X06:01:33.010Z,2,65350,27,255,2,f9,00", "bad_timestamp"),
            ("A000200.004 96FF2 1F802 FFFCCA300100FFF", "wrong_length"),
        ] {
            assert_eq!(parse_line(line).err(), Some(kind), "{line}");
        }
    }

    #[test]
    fn plain_fast_packets_are_assembled_and_a_missing_frame_counted() {
        // PGN 129029 (fast): 10 bytes in two frames, sequence 2.
        let frames = |seq: u8| {
            [
                format!("1.0,3,129029,41,255,8,{:02x},0a,00,01,02,03,04,05", seq << 5),
                format!("1.1,3,129029,41,255,8,{:02x},06,07,08,09,ff,ff,ff", (seq << 5) | 1),
            ]
        };
        let [a, b] = frames(2);
        let text = format!("{a}\n{b}\n");
        let log = read(text.as_bytes()).unwrap();
        assert_eq!(log.format, TextFormat::Plain);
        assert_eq!(log.messages.len(), 1);
        assert_eq!(log.messages[0].data, (0u8..10).collect::<Vec<_>>());
        assert_eq!(log.messages[0].t_s, 1.1);
        assert!(log.skipped.is_empty(), "{:?}", log.skipped);
        // The second frame lost: the packet is incomplete; a later start
        // begins afresh; a lone second frame has no start.
        let [a2, b2] = frames(3);
        let text = format!("{a}\n{a2}\n{b2}\n{b}\n");
        let log = read(text.as_bytes()).unwrap();
        assert_eq!(log.messages.len(), 1);
        assert_eq!(log.skipped.get("fast_packet_incomplete"), Some(&1));
        assert_eq!(log.skipped.get("fast_packet_frame_without_start"), Some(&1));
        // Only a first frame: incomplete at the end.
        let log = read(format!("{a}\n").as_bytes()).unwrap();
        assert_eq!(log.skipped.get("fast_packet_incomplete"), Some(&1));
    }

    #[test]
    fn detection_needs_messages() {
        assert!(looks_like(b"# format=FAST\n2026-07-02T06:01:33.010Z,2,65350,27,255,8,f9,fd,01,f6,cd,23,02,ff\n"));
        assert!(looks_like(b"A000159.990 CCFF7 0FF63 3B9F0000000002FF\n"));
        assert!(!looks_like(b"t,mx,my,mz\n0,1,2,3\n"));
        assert!(!looks_like(b"$HCHDG,101.1,,,7.1,W*3C\r\n"));
        assert!(!looks_like(b"2026-07-02T06:01:33.010Z,2,65350,27,255,8,f9"));
    }
}
