//! ROS 2 bag in MCAP storage (`.mcap`, rosbag2's default storage since
//! Iron), read with the `mcap` crate (the format's own Rust reader; chunks
//! compressed with zstd or lz4, as rosbag2 writes them, are read). Each
//! channel is a topic: its schema's name is the message type and its
//! `ros2msg` schema the definition checked; the messages go to the shared
//! ROS 2 part ([`super::ros2`]), which says what is read and how.
//!
//! The records are read by the crate's sans-I/O `MessageReader` with a limit
//! on a record's length ([`record_length_limit`]).
//!
//! A file cut short or damaged part-way is read up to the damage: the
//! messages before it are imported, the rest counted as one skip of kind
//! `mcap_damaged_after_message_N` with the reader's error in a note. A file
//! whose first message cannot be reached is refused.

use std::collections::HashMap;

use ::mcap as mcap_crate;
use mcap_crate::sans_io::{LinearReaderOptions, MessageReadEvent, MessageReader};

use super::ros2::{Bag, Definition, Ros2Error};
use super::{Format, ImportError, ImportOptions, Imported};

/// Why a ROS 2 bag in MCAP storage could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    /// The bytes do not start with MCAP's magic.
    #[error("not an MCAP file: it does not start with MCAP's magic (89 4D 43 41 50 30 0D 0A)")]
    NotMcap,
    /// No message could be read.
    #[error("MCAP file unreadable before its first message: {0}")]
    Unreadable(String),
    /// What both storages refuse (no magnetometer topic, …).
    #[error(transparent)]
    Bag(#[from] Ros2Error),
}

/// The longest record read, bytes: a record in a chunk may be longer than
/// the file (compressed), so 64 times the file, at least 16 MiB and at most
/// 1 GiB. The crate's `MessageStream` sets no limit inside chunks, where a
/// damaged length asks for an allocation of any size (a capacity-overflow
/// panic): hence the crate's sans-I/O reader with this limit.
fn record_length_limit(file_len: usize) -> usize {
    file_len.saturating_mul(64).clamp(16 << 20, 1 << 30)
}

/// Whether a log's first bytes look like a ROS 2 bag in MCAP storage: the
/// MCAP magic.
pub fn looks_like(head: &[u8]) -> bool {
    head.starts_with(mcap_crate::MAGIC)
}

/// Imports a ROS 2 bag in MCAP storage held in memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    if !looks_like(bytes) {
        return Err(McapError::NotMcap.into());
    }
    let limit = record_length_limit(bytes.len());
    let mut reader = MessageReader::new_with_options(LinearReaderOptions::default().with_record_length_limit(limit));
    let mut rest = bytes;
    let mut bag = Bag::new(Format::Mcap);
    let mut topics: HashMap<u16, usize> = HashMap::new();
    let mut read = 0usize;
    while let Some(event) = reader.next_event() {
        let m = match event {
            Ok(MessageReadEvent::ReadRequest(need)) => {
                let n = need.min(rest.len());
                let (now, later) = rest.split_at(n);
                reader.insert(n).copy_from_slice(now);
                reader.notify_read(n);
                rest = later;
                continue;
            }
            Ok(MessageReadEvent::Message(m)) => m,
            Err(e) if read == 0 => return Err(McapError::Unreadable(e.to_string()).into()),
            Err(e) => {
                bag.skip(&format!("mcap_damaged_after_message_{read}"), 1);
                bag.note(format!("the MCAP file is damaged or cut short after its message {read}: {e}; the messages before are imported"));
                break;
            }
        };
        read += 1;
        let channel = &m.channel;
        let topic = *topics.entry(channel.id).or_insert_with(|| {
            let (type_name, definition) = match &channel.schema {
                Some(s) => (s.name.clone(), Some(Definition { encoding: s.encoding.clone(), text: String::from_utf8_lossy(&s.data).into_owned() })),
                None => (String::new(), None),
            };
            bag.topic(&channel.topic, &type_name, &channel.message_encoding, definition.as_ref())
        });
        bag.message(topic, i64::try_from(m.log_time).unwrap_or(i64::MAX), &m.data);
    }
    bag.finish(opts, |e| McapError::Bag(e).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAG: &[u8] = include_bytes!("../../../../tests/data/ros2/swing.mcap");

    #[test]
    fn the_fixture_imports_and_is_detected() {
        let im = import(BAG, &ImportOptions::default()).unwrap();
        assert_eq!(im.report.rows, 266);
        assert_eq!(im.report.messages["/imu/mag"], 268);
        assert_eq!(Format::detect(BAG), Some(Format::Mcap));
        assert!(matches!(import(b"\x89MCAX", &ImportOptions::default()), Err(ImportError::Mcap(McapError::NotMcap))));
    }

    #[test]
    fn cut_or_changed_anywhere_never_panics() {
        for cut in (0..BAG.len()).step_by(97) {
            match import(&BAG[..cut], &ImportOptions::default()) {
                Ok(im) => assert!(im.report.rows <= 266 && (im.report.skipped.keys().any(|k| k.starts_with("mcap_damaged")) || cut > BAG.len() - 200)),
                Err(e) => assert!(!e.to_string().is_empty()),
            }
        }
        for at in (8..BAG.len()).step_by(89) {
            let mut b = BAG.to_vec();
            b[at] ^= 0xA5;
            let _ = import(&b, &ImportOptions::default());
        }
    }
}
