//! ROS 2 bag in sqlite3 storage (`.db3`, rosbag2's default storage before
//! Iron), read with `rusqlite` (SQLite bundled). The database is opened from
//! the bytes in memory (SQLite's `sqlite3_deserialize`, rusqlite's
//! `serialize` feature; read-only), not through a temporary file. The
//! `topics` table gives each topic's name, type and serialization; the
//! `message_definitions` table (rosbag2 since Iron) the definitions checked;
//! the `messages` table, read in time order, the messages, which go to the
//! shared ROS 2 part ([`super::ros2`]), which says what is read and how.
//!
//! A database damaged part-way is read up to the damage (the messages before
//! it imported, one skip of kind `sqlite3_damaged_after_message_N`, SQLite's
//! error in a note); one whose tables cannot be read is refused. A bag in
//! WAL journal mode is read as its `.db3` holds it (the `-wal` file beside it
//! is not part of the log given).

use std::collections::HashMap;
use std::io::Read;

use rusqlite::{Connection, OpenFlags};

use super::ros2::{Bag, Definition, Ros2Error};
use super::{Format, ImportError, ImportOptions, Imported};

/// SQLite's magic: the first 16 bytes of every database.
const MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// Why a ROS 2 bag in sqlite3 storage could not be imported.
#[derive(Debug, thiserror::Error)]
pub enum Sqlite3Error {
    /// The bytes do not start with SQLite's magic.
    #[error("not an SQLite database: it does not start with \"SQLite format 3\"")]
    NotSqlite,
    /// Shorter than SQLite's 100-byte header.
    #[error("SQLite database cut short: {0} bytes, fewer than its 100-byte header")]
    Truncated(usize),
    /// An SQLite database without rosbag2's tables.
    #[error("an SQLite database, not a ROS 2 bag: no `topics` and `messages` tables (tables: {})", if tables.is_empty() { "none".to_string() } else { tables.join(", ") })]
    NotABag {
        /// The tables found.
        tables: Vec<String>,
    },
    /// SQLite could not read the database.
    #[error("the ROS 2 bag's database cannot be read: {0}")]
    Unreadable(String),
    /// What both storages refuse (no magnetometer topic, …).
    #[error(transparent)]
    Bag(#[from] Ros2Error),
}

impl From<rusqlite::Error> for Sqlite3Error {
    fn from(e: rusqlite::Error) -> Self {
        Sqlite3Error::Unreadable(e.to_string())
    }
}

/// Whether a log's first bytes look like a ROS 2 bag in sqlite3 storage:
/// SQLite's magic (the tables are checked on import).
pub fn looks_like(head: &[u8]) -> bool {
    head.starts_with(MAGIC)
}

/// Opens the database held in `bytes`, read-only, in memory.
fn open(bytes: &[u8]) -> Result<Connection, Sqlite3Error> {
    let mut conn = Connection::open_with_flags(":memory:", OpenFlags::SQLITE_OPEN_READ_WRITE | OpenFlags::SQLITE_OPEN_NO_MUTEX)?;
    // A database in WAL mode (file format bytes 18 and 19 = 2) cannot be
    // deserialized: read it as the legacy journal mode (1, 1), which reads
    // the same pages.
    let wal = bytes.get(18..20) == Some(&[2, 2]);
    let head: &[u8] = if wal { &[1, 1] } else { bytes.get(18..20).unwrap_or(&[]) };
    let reader = bytes.get(..18).unwrap_or(&[]).chain(head).chain(bytes.get(20..).unwrap_or(&[]));
    conn.deserialize_read_exact("main", reader, bytes.len(), true)?;
    conn.execute_batch("PRAGMA cell_size_check = ON; PRAGMA trusted_schema = OFF;")?;
    Ok(conn)
}

/// Imports a ROS 2 bag in sqlite3 storage held in memory.
pub fn import(bytes: &[u8], opts: &ImportOptions) -> Result<Imported, ImportError> {
    read(bytes)?.finish(opts, |e| Sqlite3Error::Bag(e).into())
}

/// Reads the bag's topics and messages.
fn read(bytes: &[u8]) -> Result<Bag, Sqlite3Error> {
    if !looks_like(bytes) {
        return Err(Sqlite3Error::NotSqlite);
    }
    if bytes.len() < 100 {
        return Err(Sqlite3Error::Truncated(bytes.len()));
    }
    let conn = open(bytes)?;
    let tables: Vec<String> = conn.prepare("SELECT name FROM sqlite_master WHERE type = 'table' ORDER BY name")?.query_map([], |r| r.get(0))?.collect::<Result<_, _>>()?;
    if !tables.iter().any(|t| t == "topics") || !tables.iter().any(|t| t == "messages") {
        return Err(Sqlite3Error::NotABag { tables });
    }
    let mut definitions: HashMap<String, Definition> = HashMap::new();
    if tables.iter().any(|t| t == "message_definitions") {
        let mut q = conn.prepare("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions")?;
        let rows = q.query_map([], |r| Ok((r.get::<_, String>(0)?, Definition { encoding: r.get(1)?, text: r.get(2)? })))?;
        for row in rows {
            let (type_name, d) = row?;
            definitions.insert(type_name, d);
        }
    }
    let mut bag = Bag::new(Format::Sqlite3);
    let mut topics: HashMap<i64, usize> = HashMap::new();
    {
        let mut q = conn.prepare("SELECT id, name, type, serialization_format FROM topics ORDER BY id")?;
        let rows = q.query_map([], |r| Ok((r.get::<_, i64>(0)?, r.get::<_, String>(1)?, r.get::<_, String>(2)?, r.get::<_, String>(3)?)))?;
        for row in rows {
            let (id, name, type_name, serialization) = row?;
            let index = bag.topic(&name, &type_name, &serialization, definitions.get(&type_name));
            topics.insert(id, index);
        }
    }
    let mut q = conn.prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id")?;
    let mut rows = q.query([])?;
    let mut read = 0usize;
    loop {
        let row = match rows.next() {
            Ok(Some(row)) => row,
            Ok(None) => break,
            Err(e) if read == 0 => return Err(e.into()),
            Err(e) => {
                bag.skip(&format!("sqlite3_damaged_after_message_{read}"), 1);
                bag.note(format!("the database is damaged after its message {read}: {e}; the messages before are imported"));
                break;
            }
        };
        read += 1;
        let fields = (row.get::<_, i64>(0), row.get::<_, i64>(1), row.get_ref(2).map(|v| v.as_blob().map(<[u8]>::to_vec)));
        match fields {
            (Ok(topic_id), Ok(receive_ns), Ok(Ok(data))) => match topics.get(&topic_id) {
                Some(&topic) => bag.message(topic, receive_ns, &data),
                None => bag.skip("message_of_undeclared_topic", 1),
            },
            _ => bag.skip("message_row_of_wrong_types", 1),
        }
    }
    Ok(bag)
}
