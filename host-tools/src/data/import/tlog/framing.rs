//! The tlog's wire grammar: records of an 8-byte big-endian time and one
//! MAVLink frame (v1 or v2), each frame's checksum, and the
//! resynchronisation past what does not read (counted by kind).

use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavlinkVersion, Message};

/// A time in µs since 1970 within 2000–2100: a tlog record's time.
pub(super) const UNIX_US: std::ops::RangeInclusive<u64> = 946_684_800_000_000..=4_102_444_800_000_000;
pub(super) const STX_V1: u8 = 0xFE;
pub(super) const STX_V2: u8 = 0xFD;
/// The time in front of each frame, bytes.
pub(super) const TIME_LEN: usize = 8;

/// One MAVLink frame of a tlog, its checksum checked.
#[derive(Debug, Clone, Copy)]
pub(super) struct Frame<'a> {
    /// The record's time, µs since 1970 (the topside's clock).
    pub(super) t_unix_us: u64,
    pub(super) version: MavlinkVersion,
    pub(super) sysid: u8,
    pub(super) compid: u8,
    pub(super) msgid: u32,
    pub(super) payload: &'a [u8],
}

/// What the bytes at one place of a tlog are.
pub(super) enum Record<'a> {
    /// A frame whose checksum holds; the record's length (time included).
    Good(Frame<'a>, usize),
    /// A frame whose checksum fails; the record's length by its header.
    BadCrc(usize),
    /// A frame of a message the dialect does not know (its checksum cannot
    /// be checked); the record's length by its header.
    UnknownMessage(usize),
    /// A plausible time and start byte, and the file ends inside the frame.
    Truncated,
    /// Not the start of a record.
    No,
}

/// The record's time when the 8 bytes at the start of `b` are one.
fn record_time(b: &[u8]) -> Option<u64> {
    let t = u64::from_be_bytes(b.get(..TIME_LEN)?.try_into().ok()?);
    UNIX_US.contains(&t).then_some(t)
}

/// Reads the record at `o`.
pub(super) fn record(bytes: &[u8], o: usize) -> Record<'_> {
    let Some(rest) = bytes.get(o..) else { return Record::No };
    let Some(t_unix_us) = record_time(rest) else { return Record::No };
    let f = rest.get(TIME_LEN..).unwrap_or_default();
    let (version, header_len) = match f.first() {
        Some(&STX_V1) => (MavlinkVersion::V1, 6),
        Some(&STX_V2) => (MavlinkVersion::V2, 10),
        Some(_) => return Record::No,
        None => return Record::Truncated,
    };
    let Some(&payload_len) = f.get(1) else { return Record::Truncated };
    let payload_len = payload_len as usize;
    let signature = match (version, f.get(2)) {
        (MavlinkVersion::V2, None) => return Record::Truncated,
        (MavlinkVersion::V2, Some(incompat)) if incompat & 1 != 0 => 13,
        _ => 0,
    };
    let frame_len = header_len + payload_len + 2 + signature;
    let Some(frame) = f.get(..frame_len) else { return Record::Truncated };
    let len = TIME_LEN + frame_len;
    let (sysid, compid, msgid) = match version {
        MavlinkVersion::V1 => (frame[3], frame[4], frame[5] as u32),
        MavlinkVersion::V2 => (frame[5], frame[6], u32::from_le_bytes([frame[7], frame[8], frame[9], 0])),
    };
    if MavMessage::default_message_from_id(msgid).is_none() {
        return Record::UnknownMessage(len);
    }
    let crc_at = header_len + payload_len;
    let crc = u16::from_le_bytes([frame[crc_at], frame[crc_at + 1]]);
    if mavlink::calculate_crc(&frame[1..crc_at], MavMessage::extra_crc(msgid)) != crc {
        return Record::BadCrc(len);
    }
    let payload = &frame[header_len..crc_at];
    Record::Good(Frame { t_unix_us, version, sysid, compid, msgid, payload }, len)
}

/// Whether a record could start at `o` (time and start byte; the checksum
/// is not checked).
fn could_start(bytes: &[u8], o: usize) -> bool {
    bytes.get(o..).and_then(record_time).is_some() && matches!(bytes.get(o + TIME_LEN), Some(&STX_V1 | &STX_V2))
}

/// What the framing skipped, by kind.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(super) struct FrameSkips {
    pub(super) bad_crc: usize,
    pub(super) unknown_message: usize,
    pub(super) garbage_bytes: usize,
    pub(super) truncated_tail_bytes: usize,
}

/// Reads every record of a tlog, calling `each` on every frame whose
/// checksum holds, in file order.
pub(super) fn read_frames<'a>(bytes: &'a [u8], mut each: impl FnMut(Frame<'a>)) -> FrameSkips {
    let mut s = FrameSkips::default();
    let mut o = 0;
    while o < bytes.len() {
        let here = record(bytes, o);
        let frame_len = match here {
            Record::Good(frame, len) => {
                each(frame);
                o += len;
                continue;
            }
            Record::BadCrc(len) | Record::UnknownMessage(len) => Some(len),
            _ => None,
        };
        let mut count_frame = || match here {
            Record::BadCrc(_) => s.bad_crc += 1,
            _ => s.unknown_message += 1,
        };
        // A frame's length is trusted when a record (or the end) follows it.
        if let Some(len) = frame_len.filter(|&len| o + len == bytes.len() || could_start(bytes, o + len)) {
            count_frame();
            o += len;
            continue;
        }
        match next_good(bytes, o + 1) {
            Some(p) => {
                // A bad frame ending before the next good one is counted as a frame, the rest as bytes.
                match frame_len.filter(|&len| o + len <= p) {
                    Some(len) => {
                        count_frame();
                        s.garbage_bytes += p - o - len;
                    }
                    None => s.garbage_bytes += p - o,
                }
                o = p;
            }
            None => {
                // Nothing readable after: a record cut by the end of the file, or junk.
                if matches!(here, Record::Truncated) {
                    s.truncated_tail_bytes += bytes.len() - o;
                } else {
                    s.garbage_bytes += bytes.len() - o;
                }
                break;
            }
        }
    }
    s
}

/// The next place from `from` where a record with a good checksum starts.
fn next_good(bytes: &[u8], from: usize) -> Option<usize> {
    (from..bytes.len()).find(|&p| could_start(bytes, p) && matches!(record(bytes, p), Record::Good(..)))
}

/// Whether a log's first bytes look like a MAVLink telemetry log: from the
/// start, records one after another (a plausible time, a start byte, the
/// frame's length), the first of them whose checksum holds at least two (or
/// all of them, in a shorter head) — a corrupt or unknown frame among them
/// does not hide the format.
pub fn looks_like(head: &[u8]) -> bool {
    let (mut o, mut good, mut seen) = (0, 0, 0);
    while seen < 8 && o < head.len() {
        let len = match record(head, o) {
            Record::Good(_, len) => {
                good += 1;
                len
            }
            Record::BadCrc(len) | Record::UnknownMessage(len) => len,
            Record::Truncated => break,
            Record::No => return false,
        };
        seen += 1;
        o += len;
    }
    good >= 2 || (good == 1 && seen == 1)
}
