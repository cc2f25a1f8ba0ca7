//! The ULog file format, read from memory: the header, the definitions
//! (flag bits, formats, information, parameters), then the data section and
//! each appended data section (subscriptions, data, parameters changed,
//! logged strings, dropouts, synchronisation), as the PX4 documentation's
//! "ULog File Format" describes it.
//!
//! Every length is checked against the bytes before use; nested formats are
//! resolved to a bounded depth and size; a message that cannot be read is
//! skipped and counted by kind, never ending the read (a message whose type
//! byte is impossible, zero or of an absurd length starts a search for the
//! next synchronisation message).

use std::collections::{BTreeMap, HashMap};

/// The first seven bytes of every ULog.
pub const MAGIC: [u8; 7] = *b"ULog\x01\x12\x35";
/// The synchronisation message's payload.
const SYNC: [u8; 8] = [0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12];
/// Nested formats deeper than this are refused (a definition naming itself
/// would otherwise never end).
const MAX_DEPTH: usize = 8;
/// A message's payload is at most this long (its size is a `u16`).
const MAX_PAYLOAD: usize = u16::MAX as usize;
/// An unknown message type this long or longer, or of type 0 or length 0,
/// is taken as corruption (pyulog's rule), not as a newer message type.
const CORRUPT_SIZE: usize = 10_000;

/// Why the bytes are not a readable ULog.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ReadError {
    /// The first bytes are not the ULog magic.
    NotUlog,
    /// The file ends inside the 16-byte header.
    TruncatedHeader(usize),
    /// The flag bits set an incompatible flag this reader does not know.
    Incompatible {
        /// Byte of the incompatible flags.
        index: usize,
        /// Its value.
        value: u8,
    },
    /// The file ends before its data section starts.
    NoDataSection,
}

/// A primitive field type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Prim {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
    Bool,
    Char,
}

impl Prim {
    fn parse(s: &str) -> Option<Prim> {
        Some(match s {
            "int8_t" => Prim::I8,
            "uint8_t" => Prim::U8,
            "int16_t" => Prim::I16,
            "uint16_t" => Prim::U16,
            "int32_t" => Prim::I32,
            "uint32_t" => Prim::U32,
            "int64_t" => Prim::I64,
            "uint64_t" => Prim::U64,
            "float" => Prim::F32,
            "double" => Prim::F64,
            "bool" => Prim::Bool,
            "char" => Prim::Char,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Prim::I8 | Prim::U8 | Prim::Bool | Prim::Char => 1,
            Prim::I16 | Prim::U16 => 2,
            Prim::I32 | Prim::U32 | Prim::F32 => 4,
            Prim::I64 | Prim::U64 | Prim::F64 => 8,
        }
    }

    /// The value at the start of `b` (checked), as f64.
    fn get(self, b: &[u8]) -> Option<f64> {
        let n = self.size();
        let b = b.get(..n)?;
        let mut a = [0u8; 8];
        a.get_mut(..n)?.copy_from_slice(b);
        Some(match self {
            Prim::I8 => f64::from(a[0] as i8),
            Prim::U8 | Prim::Char => f64::from(a[0]),
            Prim::Bool => f64::from(u8::from(a[0] != 0)),
            Prim::I16 => f64::from(i16::from_le_bytes([a[0], a[1]])),
            Prim::U16 => f64::from(u16::from_le_bytes([a[0], a[1]])),
            Prim::I32 => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Prim::U32 => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Prim::F32 => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            Prim::I64 => i64::from_le_bytes(a) as f64,
            Prim::U64 => u64::from_le_bytes(a) as f64,
            Prim::F64 => f64::from_le_bytes(a),
        })
    }
}

/// One field of a format definition: its type (primitive or another
/// format's name), array length (0: not an array) and name.
#[derive(Debug, Clone)]
struct FieldDef {
    type_name: String,
    array: usize,
    name: String,
}

/// A format definition's fields flattened to primitives: `name`,
/// `name[i]`, `nested.name`, each at its byte offset.
#[derive(Debug, Clone, Default)]
struct Layout {
    fields: Vec<(String, usize, Prim)>,
    /// Size without the trailing `_padding` fields (what PX4 writes).
    size_min: usize,
    /// Size with them.
    size_full: usize,
}

/// A subscription: a topic's instance logged under a message id, with the
/// wanted fields' places.
#[derive(Debug, Clone)]
struct Subscription {
    key: (String, u8),
    size_min: usize,
    size_full: usize,
    /// The wanted fields (in the order asked; `None` when the topic lacks
    /// one), `timestamp` first.
    wanted: Option<Vec<Option<(usize, Prim)>>>,
}

/// What was read.
#[derive(Debug, Default)]
pub struct Log {
    /// The header's format version byte.
    pub version: u8,
    /// Information messages: numbers.
    pub info_num: BTreeMap<String, f64>,
    /// Information messages: text.
    pub info_text: BTreeMap<String, String>,
    /// Parameters as the log starts.
    pub params: BTreeMap<String, f64>,
    /// Parameters changed during the log, in order (name, value).
    pub param_changes: Vec<(String, f64)>,
    /// Data messages read, by topic and instance (multi_id).
    pub counts: BTreeMap<(String, u8), usize>,
    /// The wanted topics' messages: per topic and instance, one row per
    /// message with `timestamp` (µs) then the wanted fields (NaN when the
    /// topic lacks the field).
    pub rows: BTreeMap<(String, u8), Vec<Vec<f64>>>,
    /// Other message kinds read (parameters, logged strings, sync, …).
    pub other: BTreeMap<&'static str, usize>,
    /// Messages or bytes skipped, by kind.
    pub skipped: BTreeMap<&'static str, usize>,
    /// Dropout messages: how many and their total duration, ms.
    pub dropouts: (usize, u64),
    /// Appended data sections read.
    pub appended_sections: usize,
}

impl Log {
    fn skip(&mut self, kind: &'static str, n: usize) {
        if n > 0 {
            *self.skipped.entry(kind).or_default() += n;
        }
    }

    fn other(&mut self, kind: &'static str) {
        *self.other.entry(kind).or_default() += 1;
    }
}

/// The reader's state between messages.
struct Reader<'a> {
    bytes: &'a [u8],
    /// Wanted fields per topic (`timestamp` is always read first).
    want: &'a HashMap<&'a str, Vec<&'a str>>,
    formats: HashMap<String, Vec<FieldDef>>,
    layouts: HashMap<String, Option<Layout>>,
    subs: HashMap<u16, Subscription>,
    log: Log,
}

/// Reads a ULog: the topics in `want` (topic → field names) into
/// [`Log::rows`], every topic's count, the parameters and information.
pub fn read(bytes: &[u8], want: &HashMap<&str, Vec<&str>>) -> Result<Log, ReadError> {
    if !bytes.starts_with(&MAGIC) && !MAGIC.starts_with(bytes) {
        return Err(ReadError::NotUlog);
    }
    if bytes.len() < 16 {
        return Err(ReadError::TruncatedHeader(bytes.len()));
    }
    let mut r = Reader { bytes, want, formats: HashMap::new(), layouts: HashMap::new(), subs: HashMap::new(), log: Log::default() };
    r.log.version = bytes.get(7).copied().unwrap_or(0);
    let (data_start, appended) = r.definitions()?;
    // Sections: the main one up to the first appended offset, then each
    // appended one up to the next (or the end).
    let mut bounds: Vec<usize> = Vec::new();
    for off in appended {
        match usize::try_from(off) {
            Ok(o) if o >= data_start && o <= bytes.len() && bounds.last().is_none_or(|&l| o > l) => bounds.push(o),
            _ => r.log.skip("appended_offsets_out_of_the_file", 1),
        }
    }
    let mut start = data_start;
    for (i, &end) in bounds.iter().enumerate() {
        r.section(start, end);
        start = end;
        r.log.appended_sections = i + 1;
    }
    r.section(start, bytes.len());
    Ok(r.log)
}

/// A message's header at `pos`: (type, payload start, payload end).
fn header(bytes: &[u8], pos: usize) -> Option<(u8, usize, usize)> {
    let h = bytes.get(pos..pos.checked_add(3)?)?;
    let size = usize::from(u16::from_le_bytes([h[0], h[1]]));
    Some((h[2], pos + 3, pos + 3 + size))
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).trim_end_matches('\0').to_string()
}

impl Reader<'_> {
    /// The definitions section: returns where the data section starts and
    /// the appended data offsets.
    fn definitions(&mut self) -> Result<(usize, Vec<u64>), ReadError> {
        let bytes = self.bytes;
        let mut pos = 16;
        let mut appended = Vec::new();
        loop {
            let Some((kind, start, end)) = header(bytes, pos) else { return Err(ReadError::NoDataSection) };
            let Some(payload) = bytes.get(start..end) else { return Err(ReadError::NoDataSection) };
            match kind {
                b'A' | b'L' | b'C' => return Ok((pos, appended)),
                b'B' => {
                    if payload.len() < 40 {
                        self.log.skip("malformed_flag_bits", 1);
                    } else {
                        for (index, &value) in payload.get(8..16).unwrap_or_default().iter().enumerate() {
                            // Bit 0 of the first byte: data appended (read here).
                            let known = if index == 0 { 1 } else { 0 };
                            if value & !known != 0 {
                                return Err(ReadError::Incompatible { index, value });
                            }
                        }
                        appended = payload
                            .get(16..40)
                            .unwrap_or_default()
                            .chunks_exact(8)
                            .map(|c| u64::from_le_bytes(c.try_into().unwrap_or([0; 8])))
                            .filter(|&o| o != 0)
                            .collect();
                    }
                }
                b'F' => self.format(payload),
                b'I' => self.info(payload),
                b'M' => self.log.other("info_multiple"),
                b'P' => self.parameter(payload, false),
                b'Q' => self.log.other("parameter_defaults"),
                _ if kind == 0 || payload.is_empty() || payload.len() > CORRUPT_SIZE => {
                    self.log.skip("corrupt_bytes", 1);
                    pos += 1;
                    continue;
                }
                _ => self.log.skip("messages_of_unknown_type", 1),
            }
            pos = end;
        }
    }

    /// `name:type field;type field;…`.
    fn format(&mut self, payload: &[u8]) {
        let s = text(payload);
        let Some((name, fields)) = s.split_once(':') else { return self.log.skip("malformed_formats", 1) };
        let mut defs = Vec::new();
        for f in fields.split(';').filter(|f| !f.is_empty()) {
            let Some((ty, field)) = f.split_once(' ') else { return self.log.skip("malformed_formats", 1) };
            let (type_name, array) = match ty.split_once('[') {
                Some((t, n)) => match n.strip_suffix(']').and_then(|n| n.parse::<usize>().ok()) {
                    Some(n) if n <= MAX_PAYLOAD => (t, n),
                    _ => return self.log.skip("malformed_formats", 1),
                },
                None => (ty, 0),
            };
            defs.push(FieldDef { type_name: type_name.to_string(), array, name: field.to_string() });
        }
        self.log.other("formats");
        self.formats.insert(name.to_string(), defs);
    }

    /// `key_len, "type name", value`.
    fn info(&mut self, payload: &[u8]) {
        let Some((&key_len, rest)) = payload.split_first() else { return self.log.skip("malformed_info", 1) };
        let (Some(key), Some(value)) = (rest.get(..usize::from(key_len)), rest.get(usize::from(key_len)..)) else { return self.log.skip("malformed_info", 1) };
        let key = text(key);
        let Some((ty, name)) = key.split_once(' ') else { return self.log.skip("malformed_info", 1) };
        self.log.other("info");
        if ty.starts_with("char[") {
            self.log.info_text.insert(name.to_string(), text(value));
        } else if let Some(v) = Prim::parse(ty).and_then(|p| p.get(value)) {
            self.log.info_num.insert(name.to_string(), v);
        }
    }

    /// `key_len, "float NAME" | "int32_t NAME", 4 bytes`.
    fn parameter(&mut self, payload: &[u8], changed: bool) {
        let Some((&key_len, rest)) = payload.split_first() else { return self.log.skip("malformed_parameters", 1) };
        let (Some(key), Some(value)) = (rest.get(..usize::from(key_len)), rest.get(usize::from(key_len)..)) else { return self.log.skip("malformed_parameters", 1) };
        let key = text(key);
        let v = match key.split_once(' ') {
            Some(("float", _)) => Prim::F32.get(value),
            Some(("int32_t", _)) => Prim::I32.get(value),
            _ => None,
        };
        let (Some(v), Some((_, name))) = (v, key.split_once(' ')) else { return self.log.skip("malformed_parameters", 1) };
        self.log.other("parameters");
        if changed {
            self.log.param_changes.push((name.to_string(), v));
        } else {
            self.log.params.insert(name.to_string(), v);
        }
    }

    /// The flattened layout of format `name` (cached; `None` when it cannot
    /// be resolved: undefined, too deep, too large).
    fn layout(&mut self, name: &str) -> Option<Layout> {
        if let Some(l) = self.layouts.get(name) {
            return l.clone();
        }
        let mut l = Layout::default();
        let ok = self.flatten(name, "", 0, &mut l);
        let l = ok.then(|| {
            l.size_full = l.fields.last().map_or(0, |(_, o, p)| o + p.size());
            let kept = l.fields.iter().rposition(|(n, _, _)| !n.starts_with("_padding")).map_or(0, |i| i + 1);
            l.fields.truncate(kept);
            l.size_min = l.fields.last().map_or(0, |(_, o, p)| o + p.size());
            l
        });
        self.layouts.insert(name.to_string(), l.clone());
        l
    }

    fn flatten(&self, name: &str, prefix: &str, depth: usize, l: &mut Layout) -> bool {
        if depth > MAX_DEPTH {
            return false;
        }
        let Some(defs) = self.formats.get(name) else { return false };
        for d in defs {
            let count = d.array.max(1);
            for i in 0..count {
                let field = if d.array > 0 { format!("{prefix}{}[{i}]", d.name) } else { format!("{prefix}{}", d.name) };
                match Prim::parse(&d.type_name) {
                    Some(p) => {
                        let offset = l.fields.last().map_or(0, |(_, o, p)| o + p.size());
                        if offset + p.size() > MAX_PAYLOAD {
                            return false;
                        }
                        l.fields.push((field, offset, p));
                    }
                    None => {
                        if !self.flatten(&d.type_name, &format!("{field}."), depth + 1, l) {
                            return false;
                        }
                    }
                }
            }
        }
        true
    }

    /// A data section from `pos` to `end`.
    fn section(&mut self, mut pos: usize, end: usize) {
        let bytes = self.bytes;
        let Some(section) = bytes.get(..end) else { return };
        let mut searching = true;
        while pos < end {
            let Some((kind, start, stop)) = header(section, pos).filter(|h| h.2 <= end) else {
                let kind = if end == bytes.len() { "truncated_tail_bytes" } else { "bytes_before_an_appended_section" };
                self.log.skip(kind, end - pos);
                return;
            };
            let payload = section.get(start..stop).unwrap_or_default();
            match kind {
                b'A' => self.subscribe(payload),
                b'D' => self.data(payload),
                b'P' => self.parameter(payload, true),
                b'O' => match payload.get(..2) {
                    Some(d) => {
                        self.log.dropouts.0 += 1;
                        self.log.dropouts.1 += u64::from(u16::from_le_bytes([d[0], d[1]]));
                    }
                    None => self.log.skip("malformed_dropouts", 1),
                },
                b'L' | b'C' => self.log.other("logged_strings"),
                b'S' => self.log.other("sync"),
                b'R' => self.log.other("unsubscriptions"),
                b'I' => self.info(payload),
                b'M' => self.log.other("info_multiple"),
                b'Q' => self.log.other("parameter_defaults"),
                b'F' => self.format(payload),
                b'B' => self.log.skip("flag_bits_in_data", 1),
                _ if kind == 0 || payload.is_empty() || payload.len() > CORRUPT_SIZE => {
                    // Corruption: to the next synchronisation message, else
                    // one byte on.
                    let from = pos + 1;
                    let found = if searching { section.get(from..).and_then(|s| s.windows(SYNC.len()).position(|w| w == SYNC)) } else { None };
                    match found {
                        Some(i) => {
                            self.log.skip("corrupt_bytes", 1 + i + SYNC.len());
                            pos = from + i + SYNC.len();
                        }
                        None => {
                            searching = false;
                            self.log.skip("corrupt_bytes", 1);
                            pos = from;
                        }
                    }
                    continue;
                }
                _ => self.log.skip("messages_of_unknown_type", 1),
            }
            pos = stop;
        }
    }

    /// `multi_id, msg_id, name`.
    fn subscribe(&mut self, payload: &[u8]) {
        let (Some(&multi_id), Some(id), Some(name)) = (payload.first(), payload.get(1..3), payload.get(3..)) else { return self.log.skip("malformed_subscriptions", 1) };
        let msg_id = u16::from_le_bytes([id[0], id[1]]);
        let name = text(name);
        let Some(layout) = self.layout(&name) else { return self.log.skip("subscriptions_of_undefined_formats", 1) };
        let wanted = self.want.get(name.as_str()).map(|fields| {
            std::iter::once("timestamp")
                .chain(fields.iter().copied())
                .map(|f| layout.fields.iter().find(|(n, _, _)| n == f).map(|&(_, o, p)| (o, p)))
                .collect::<Vec<_>>()
        });
        self.log.other("subscriptions");
        self.subs.insert(msg_id, Subscription { key: (name, multi_id), size_min: layout.size_min, size_full: layout.size_full, wanted });
    }

    /// `msg_id, fields`.
    fn data(&mut self, payload: &[u8]) {
        let Some(id) = payload.get(..2) else { return self.log.skip("malformed_data", 1) };
        let Some(sub) = self.subs.get(&u16::from_le_bytes([id[0], id[1]])) else { return self.log.skip("data_of_unsubscribed_ids", 1) };
        let body = payload.get(2..).unwrap_or_default();
        if body.len() < sub.size_min || body.len() > sub.size_full {
            return self.log.skip("data_of_the_wrong_size", 1);
        }
        *self.log.counts.entry(sub.key.clone()).or_default() += 1;
        if let Some(wanted) = &sub.wanted {
            if wanted.first().is_some_and(|t| t.is_none()) {
                return self.log.skip("data_without_timestamp", 1);
            }
            let row = wanted.iter().map(|w| w.and_then(|(o, p)| p.get(body.get(o..)?)).unwrap_or(f64::NAN)).collect();
            self.log.rows.entry(sub.key.clone()).or_default().push(row);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A message: size, type, payload.
    pub(crate) fn msg(kind: u8, payload: &[u8]) -> Vec<u8> {
        let mut v = (payload.len() as u16).to_le_bytes().to_vec();
        v.push(kind);
        v.extend_from_slice(payload);
        v
    }

    fn want() -> HashMap<&'static str, Vec<&'static str>> {
        HashMap::from([("t", vec!["v[1]", "n.x", "missing"])])
    }

    fn log_bytes() -> Vec<u8> {
        let mut b = MAGIC.to_vec();
        b.push(1);
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend(msg(b'F', b"inner:float x;uint8_t[2] _padding0;"));
        b.extend(msg(b'F', b"t:uint64_t timestamp;int16_t[2] v;inner n;uint8_t[3] _padding0;"));
        let mut p = vec![19u8];
        p.extend_from_slice(b"float CAL_MAG0_XOFF");
        p.extend_from_slice(&0.5f32.to_le_bytes());
        b.extend(msg(b'P', &p));
        b.extend(msg(b'A', &[2, 7, 0, b't']));
        for k in 0..3u64 {
            let mut d = vec![7, 0];
            d.extend_from_slice(&(1000 * k).to_le_bytes());
            d.extend_from_slice(&[1, 0, 0xFE, 0xFF]);
            d.extend_from_slice(&1.5f32.to_le_bytes());
            d.extend_from_slice(&[0, 0]);
            b.extend(msg(b'D', &d));
        }
        b
    }

    #[test]
    fn reads_nested_arrays_and_padding() {
        let log = read(&log_bytes(), &want()).unwrap();
        assert_eq!(log.counts[&("t".to_string(), 2)], 3);
        let rows = &log.rows[&("t".to_string(), 2)];
        assert_eq!(rows[2][..3], [2000.0, -2.0, 1.5]);
        assert!(rows[2][3].is_nan());
        assert_eq!(log.params["CAL_MAG0_XOFF"], 0.5);
    }

    #[test]
    fn hostile_bytes_never_panic_and_are_counted() {
        let good = log_bytes();
        // Every truncation.
        for n in 0..good.len() {
            let _ = read(&good[..n], &want());
        }
        // Every single-byte corruption.
        for i in 16..good.len() {
            let mut b = good.clone();
            b[i] ^= 0xA5;
            let _ = read(&b, &want());
        }
        // A self-referencing format: refused to a depth, its data skipped.
        let mut b = MAGIC.to_vec();
        b.push(1);
        b.extend_from_slice(&0u64.to_le_bytes());
        b.extend(msg(b'F', b"loop:uint64_t timestamp;loop next;"));
        b.extend(msg(b'A', &[0, 1, 0, b'l', b'o', b'o', b'p']));
        b.extend(msg(b'D', &[1, 0, 0, 0, 0, 0, 0, 0, 0, 0]));
        b.extend(msg(0, &[]));
        b.extend(msg(b'S', &SYNC));
        let log = read(&b, &want()).unwrap();
        assert_eq!(log.skipped["subscriptions_of_undefined_formats"], 1);
        assert_eq!(log.skipped["data_of_unsubscribed_ids"], 1);
        assert_eq!(log.skipped["corrupt_bytes"], 3 + 3 + 8);
        assert!(log.counts.is_empty());
        assert_eq!(read(b"ULog\x01\x12\x35\x01", &want()).unwrap_err(), ReadError::TruncatedHeader(8));
        assert_eq!(read(b"ULog\x01\x12\x36\x01\0\0\0\0\0\0\0\0", &want()).unwrap_err(), ReadError::NotUlog);
        assert_eq!(read(b"PK", &want()).unwrap_err(), ReadError::NotUlog);
        assert_eq!(read(&good[..16], &want()).unwrap_err(), ReadError::NoDataSection);
    }
}
