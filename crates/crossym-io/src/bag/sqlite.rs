//! Reading rosbag2 SQLite3 bags (`.db3`, the default storage of `ros2 bag record` up to
//! Humble): the same [`Bag`] as an MCAP bag, so everything downstream is storage-agnostic.
//!
//! Layout (rosbag2_storage_default_plugins, schema versions 1–4): table
//! `topics(id, name, type, serialization_format, offered_qos_profiles, …)` and table
//! `messages(id, topic_id, timestamp, data)`, `timestamp` the receive time in ns since the
//! Unix epoch, `data` the CDR payload with its encapsulation header. SQLite3 bags store no
//! publish time and no sequence number: both are taken as the receive time and 0.
//!
//! The file is opened read-only (`SQLITE_OPEN_READ_ONLY`), through the SQLite library
//! compiled into crossym (`rusqlite`, `bundled`), so nothing needs to be installed.

use std::collections::HashMap;
use std::path::Path;

use rusqlite::{Connection, OpenFlags};

use super::content::{Bag, RawMessage, Storage, TopicInfo};
use super::BagError;

/// Reads a `.db3` file into memory; messages sorted by receive time (then row id).
pub fn open(path: &Path) -> Result<Bag, BagError> {
    let conn = open_read_only(path)?;
    let (mut topics, index) = read_topics(&conn, path)?;
    let messages = read_messages(&conn, path, &index, &mut topics)?;
    Ok(Bag {
        path: path.to_path_buf(),
        storage: Storage::Sqlite3,
        topics,
        messages,
    })
}

/// The SQLite error `e` met reading the bag at `path`.
fn sqlite_err(path: &Path) -> impl Fn(rusqlite::Error) -> BagError + '_ {
    move |e: rusqlite::Error| BagError::Sqlite {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// Opens the existing file `path` read-only.
fn open_read_only(path: &Path) -> Result<Connection, BagError> {
    // SQLite would create an empty database for a missing file even read-only in some
    // builds; refuse it first with the OS error.
    std::fs::metadata(path).map_err(|source| BagError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    Connection::open_with_flags(
        path,
        OpenFlags::SQLITE_OPEN_READ_ONLY | OpenFlags::SQLITE_OPEN_NO_MUTEX,
    )
    .map_err(sqlite_err(path))
}

/// The bag's topics in id order (all CDR) and the index of each topic id among them.
fn read_topics(
    conn: &Connection,
    path: &Path,
) -> Result<(Vec<TopicInfo>, HashMap<i64, usize>), BagError> {
    let err = sqlite_err(path);
    // Column set of `topics` (offered_qos_profiles appeared in rosbag2 Foxy).
    let columns: Vec<String> = conn
        .prepare("PRAGMA table_info(topics)")
        .and_then(|mut s| {
            s.query_map([], |r| r.get::<_, String>(1))?
                .collect::<Result<Vec<_>, _>>()
        })
        .map_err(&err)?;
    if columns.is_empty() {
        return Err(BagError::NotRos2 {
            path: path.to_path_buf(),
            message: "an SQLite database without rosbag2's `topics` table".into(),
        });
    }
    let qos_col = if columns.iter().any(|c| c == "offered_qos_profiles") {
        "offered_qos_profiles"
    } else {
        "''"
    };
    let mut topics = Vec::new();
    let mut index: HashMap<i64, usize> = HashMap::new();
    let mut stmt = conn
        .prepare(&format!(
            "SELECT id, name, type, serialization_format, {qos_col} FROM topics ORDER BY id"
        ))
        .map_err(&err)?;
    let rows = stmt
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, String>(1)?,
                r.get::<_, String>(2)?,
                r.get::<_, String>(3)?,
                r.get::<_, Option<String>>(4)?,
            ))
        })
        .map_err(&err)?;
    for row in rows {
        let (id, name, ros_type, format, qos) = row.map_err(&err)?;
        if format != "cdr" {
            return Err(BagError::NotRos2 {
                path: path.to_path_buf(),
                message: format!(
                    "topic {name} has serialization format `{format}`, expected `cdr`"
                ),
            });
        }
        index.insert(id, topics.len());
        topics.push(TopicInfo {
            name,
            ros_type,
            count: 0,
            qos: qos.filter(|q| !q.is_empty()),
        });
    }
    Ok((topics, index))
}

/// Every message by receive time (then row id), counted on its topic.
fn read_messages(
    conn: &Connection,
    path: &Path,
    index: &HashMap<i64, usize>,
    topics: &mut [TopicInfo],
) -> Result<Vec<RawMessage>, BagError> {
    let err = sqlite_err(path);
    let mut messages = Vec::new();
    let mut stmt = conn
        .prepare("SELECT topic_id, timestamp, data FROM messages ORDER BY timestamp, id")
        .map_err(&err)?;
    let rows = stmt
        .query_map([], |r| {
            Ok((
                r.get::<_, i64>(0)?,
                r.get::<_, i64>(1)?,
                r.get::<_, Vec<u8>>(2)?,
            ))
        })
        .map_err(&err)?;
    for row in rows {
        let (topic_id, stamp, data) = row.map_err(&err)?;
        let topic = *index.get(&topic_id).ok_or_else(|| BagError::NotRos2 {
            path: path.to_path_buf(),
            message: format!("a message on unknown topic id {topic_id}"),
        })?;
        let ns = u64::try_from(stamp).map_err(|_| BagError::NotRos2 {
            path: path.to_path_buf(),
            message: format!("a message with negative timestamp {stamp} ns"),
        })?;
        topics[topic].count += 1;
        messages.push(RawMessage {
            topic,
            log_ns: ns,
            publish_ns: ns,
            sequence: 0,
            data,
        });
    }
    Ok(messages)
}
