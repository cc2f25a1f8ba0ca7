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

use rusqlite::types::ValueRef;
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
    /// Shorter than the pages its header counts.
    #[error("SQLite database cut short: {bytes} bytes where its header counts {pages} pages of {page_size} bytes")]
    CutShort {
        /// The bytes given.
        bytes: usize,
        /// The pages the header counts.
        pages: u64,
        /// Bytes a page.
        page_size: u64,
    },
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

/// The pages and page size the header counts, when its page count is valid
/// (the change counter at 24 equals the version-valid-for number at 92, as
/// SQLite requires).
fn header_pages(bytes: &[u8]) -> Option<(u64, u64)> {
    let be32 = |at: usize| bytes.get(at..at + 4).and_then(|b| b.try_into().ok()).map(u32::from_be_bytes);
    let page_size = match bytes.get(16..18)? {
        [0, 1] => 65_536,
        [a, b] => u64::from(u16::from_be_bytes([*a, *b])),
        _ => return None,
    };
    (be32(24)? == be32(92)? && page_size >= 512).then_some((u64::from(be32(28)?), page_size))
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
    if let Some((pages, page_size)) = header_pages(bytes) {
        if (bytes.len() as u64) < pages.saturating_mul(page_size) {
            return Err(Sqlite3Error::CutShort { bytes: bytes.len(), pages, page_size });
        }
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
    // Only the data of the topics decoded is read (a camera's images are
    // counted, not loaded). In time order; equal times in the table's order
    // (rosbag2's timestamp index holds the rowid).
    let decoded: Vec<String> = topics.iter().filter(|(_, &i)| bag.decodes(i)).map(|(id, _)| id.to_string()).collect();
    let sql = format!("SELECT topic_id, timestamp, CASE WHEN topic_id IN ({}) THEN data END FROM messages ORDER BY timestamp", decoded.join(", "));
    let mut q = conn.prepare(&sql)?;
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
        let data = match row.get_ref(2) {
            Ok(ValueRef::Blob(b)) => Some(b),
            Ok(ValueRef::Null) => Some(&[][..]),
            _ => None,
        };
        match (row.get::<_, i64>(0), row.get::<_, i64>(1), data) {
            (Ok(topic_id), Ok(receive_ns), Some(data)) => match topics.get(&topic_id) {
                Some(&topic) => bag.message(topic, receive_ns, data),
                None => bag.skip("message_of_undeclared_topic", 1),
            },
            _ => bag.skip("message_row_of_wrong_types", 1),
        }
    }
    Ok(bag)
}

#[cfg(test)]
mod tests {
    use super::*;

    const BAG: &[u8] = include_bytes!("../../../../tests/data/ros2/swing_db3/swing_db3.db3");

    /// The fixture changed by `sql` (and `edit` on each message's data),
    /// as bytes.
    fn edited(sql: &str, edit: impl Fn(&str, &mut Vec<u8>)) -> Vec<u8> {
        let mut conn = Connection::open_in_memory().unwrap();
        conn.deserialize_read_exact("main", BAG, BAG.len(), false).unwrap();
        conn.execute_batch(sql).unwrap();
        let sql = "SELECT messages.id, topics.name, data FROM messages JOIN topics ON topics.id = topic_id";
        let rows: Vec<(i64, String, Vec<u8>)> = conn.prepare(sql).unwrap().query_map([], |r| Ok((r.get(0)?, r.get(1)?, r.get(2)?))).unwrap().map(Result::unwrap).collect();
        for (id, topic, mut data) in rows {
            edit(&topic, &mut data);
            conn.execute("UPDATE messages SET data = ?1 WHERE id = ?2", rusqlite::params![data, id]).unwrap();
        }
        conn.serialize("main").unwrap().to_vec()
    }

    fn import_ok(bytes: &[u8], opts: &ImportOptions) -> Imported {
        import(bytes, opts).unwrap()
    }

    #[test]
    fn the_fixture_imports() {
        let im = import_ok(BAG, &ImportOptions::default());
        assert_eq!(im.report.rows, 266);
        assert_eq!(im.report.messages["/imu/mag"], 268);
        assert!(Format::detect(BAG) == Some(Format::Sqlite3));
    }

    #[test]
    fn an_older_bag_without_definitions_is_read_by_type_names() {
        let old = edited("DROP TABLE message_definitions;", |_, _| {});
        let im = import_ok(&old, &ImportOptions::default());
        assert_eq!(im.report.rows, 266);
        assert!(im.report.notes.iter().any(|n| n.contains("/imu/mag: no definition stored")), "{:?}", im.report.notes);
    }

    #[test]
    fn a_definition_of_another_layout_is_refused() {
        let sql = "UPDATE message_definitions SET encoded_message_definition = replace(encoded_message_definition, 'float64 y', 'float32 y') WHERE topic_type = 'sensor_msgs/msg/MagneticField';";
        let e = import(&edited(sql, |_, _| {}), &ImportOptions::default()).unwrap_err().to_string();
        assert!(e.contains("/imu/mag (sensor_msgs/msg/MagneticField) cannot be read: the bag's definition is not the layout read: Vector3: fields") && e.contains("float32 y"), "{e}");
        // Another topic's: that topic is not read, the import goes on.
        let sql = "UPDATE message_definitions SET encoded_message_definition = 'float64 x' WHERE topic_type = 'sensor_msgs/msg/NavSatFix';";
        let im = import_ok(&edited(sql, |_, _| {}), &ImportOptions::default());
        assert!(im.column("lat_deg").is_none());
        assert_eq!(im.report.skipped["definition_differs: /gnss/fix"], 266);
    }

    #[test]
    fn unstamped_messages_fall_back_to_the_receive_time() {
        let unstamped = edited("", |_, d| {
            if d.len() > 12 {
                d[4..12].fill(0);
            }
        });
        let im = import_ok(&unstamped, &ImportOptions::default());
        assert!(im.report.clock.contains("receive time"), "{}", im.report.clock);
        // The receive times are the stamps plus 5 ms: the same t.
        assert_eq!(im.column("t").unwrap()[1], 5.0);
        assert!(im.column("roll_deg").is_some());
        // Receive times at both ends of i64: no overflow.
        let sql = "UPDATE messages SET timestamp = -9223372036854775808 WHERE id = 1; UPDATE messages SET timestamp = 9223372036854775807 WHERE id = 5;";
        let extreme = edited(sql, |_, d| {
            if d.len() > 12 {
                d[4..12].fill(0);
            }
        });
        assert!(import_ok(&extreme, &ImportOptions::default()).report.duration_s > 1e9);
        // Only the IMU unstamped: its receive time (5 ms late), said.
        let imu_unstamped = edited("", |topic, d| {
            if topic == "/imu/data" {
                d[4..12].fill(0);
            }
        });
        // (The fixture's rows are 5 s apart: samples carried up to 10 s.)
        let im = import_ok(&imu_unstamped, &ImportOptions { max_age_s: 10.0, ..ImportOptions::default() });
        assert!(im.report.clock.contains("header.stamp"), "{}", im.report.clock);
        assert!(im.report.notes.iter().any(|n| n.starts_with("/imu/data: every header.stamp is zero: its receive time used")), "{:?}", im.report.notes);
        // The first row is before the first IMU sample (5 ms later); the others have one.
        let roll = im.column("roll_deg").unwrap();
        assert!(roll[0].is_nan() && roll[1..].iter().all(|r| r.is_finite()));
    }

    #[test]
    fn not_a_bag_wal_and_damage() {
        let mut conn = Connection::open_in_memory().unwrap();
        conn.execute_batch("CREATE TABLE boats (name TEXT);").unwrap();
        let other = conn.serialize("main").unwrap().to_vec();
        assert!(matches!(read(&other), Err(Sqlite3Error::NotABag { tables }) if tables == ["boats"]));
        // A bag left in WAL mode (bytes 18, 19 = 2) reads the same.
        let mut wal = BAG.to_vec();
        wal[18..20].copy_from_slice(&[2, 2]);
        assert_eq!(import_ok(&wal, &ImportOptions::default()).report.rows, 266);
        // Cut anywhere or bytes changed: an error or an import, never a panic.
        for cut in (0..BAG.len()).step_by(1531) {
            let _ = import(&BAG[..cut], &ImportOptions::default());
        }
        for at in (0..BAG.len()).step_by(1009) {
            let mut b = BAG.to_vec();
            b[at] ^= 0x5A;
            let _ = import(&b, &ImportOptions::default());
        }
    }
}
