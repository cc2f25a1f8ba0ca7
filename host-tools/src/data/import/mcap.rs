//! ROS 2 bag in MCAP storage (`.mcap`, rosbag2's default storage since
//! Iron), read with the `mcap` crate (the format's own Rust reader; chunks
//! compressed with zstd or lz4, as rosbag2 writes them, are read). Each
//! channel is a topic: its schema's name is the message type and its
//! `ros2msg` schema the definition checked; the messages go to the shared
//! ROS 2 part ([`super::ros2`]), which says what is read and how.
//!
//! A file cut short or damaged part-way is read up to the damage: the
//! messages before it are imported, the rest counted as one skip of kind
//! `mcap_damaged_after_message_N` with the reader's error in a note. A file
//! whose first message cannot be reached is refused.

use std::collections::HashMap;

use ::mcap as mcap_crate;

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
    let stream = mcap_crate::MessageStream::new(bytes).map_err(|e| McapError::Unreadable(e.to_string()))?;
    let mut bag = Bag::new(Format::Mcap);
    let mut topics: HashMap<u16, usize> = HashMap::new();
    let mut read = 0usize;
    for message in stream {
        let m = match message {
            Ok(m) => m,
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
