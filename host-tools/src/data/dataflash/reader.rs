//! The DataFlash format read: `FMT` messages describing the others, each
//! message decoded by its format characters, and what the reader skipped
//! to stay on the messages (counted).

use std::collections::HashMap;

use serde::{Deserialize, Serialize};

use super::DataFlashError;

/// The message type of `FMT`.
pub const FMT_TYPE: u8 = 128;
const HEAD: [u8; 2] = [0xA3, 0x95];
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
    pub(super) fn need(&self, label: &'static str) -> Result<f64, DataFlashError> {
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
pub(super) fn field_size(c: char) -> Option<usize> {
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
