//! Reading rosbag2 bags (a bag directory, split or not, a single `.mcap` file or a single
//! `.db3` file):
//! MCAP here (checks the profile and encodings), SQLite3 in [`super::sqlite`]; every message
//! loaded in log-time order, CDR decoded on demand ([`Bag::decode`]).

use std::path::{Path, PathBuf};

use super::content::{Bag, RawMessage, Storage, TopicInfo};
use super::BagError;

impl Bag {
    /// Opens a bag directory (its `.mcap` or `.db3` files: several are a split bag, merged
    /// in log-time order, see the private `split` module), an `.mcap` file or a `.db3` file.
    pub fn open(path: &Path) -> Result<Self, BagError> {
        if !path.is_dir() {
            return Self::open_file(path);
        }
        let rd = std::fs::read_dir(path).map_err(|source| BagError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut files: Vec<PathBuf> = rd
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mcap" || e == "db3"))
            .collect();
        super::split::sort_parts(&mut files);
        match files.len() {
            0 => Err(BagError::NotRos2 {
                path: path.to_path_buf(),
                message: "not a rosbag2 bag: the directory holds no .mcap or .db3 file".into(),
            }),
            1 => Self::open_file(&files[0]),
            _ => {
                let parts = files
                    .iter()
                    .map(|f| Self::open_file(f))
                    .collect::<Result<Vec<_>, _>>()?;
                super::split::merge(path, parts)
            }
        }
    }

    /// Opens one storage file (`.db3`: SQLite3, else MCAP).
    fn open_file(file: &Path) -> Result<Self, BagError> {
        if file.extension().is_some_and(|e| e == "db3") {
            #[cfg(feature = "sqlite")]
            return super::sqlite::open(file);
            #[cfg(not(feature = "sqlite"))]
            return Err(BagError::Unsupported {
                path: file.to_path_buf(),
                what: "SQLite3 bags",
                feature: "sqlite",
            });
        }
        let buf = std::fs::read(file).map_err(|source| BagError::Io {
            path: file.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&buf, file)
    }

    /// Parses MCAP bytes; `path` labels errors.
    pub fn from_bytes(buf: &[u8], path: &Path) -> Result<Self, BagError> {
        let not_ros2 = |message: String| BagError::NotRos2 {
            path: path.to_path_buf(),
            message,
        };
        precheck(buf).map_err(|message| BagError::Mcap {
            path: path.to_path_buf(),
            message,
        })?;
        // The header record (right after the magic) carries the profile; parsed here with
        // bounds checks (the mcap crate allocates declared string lengths first).
        let profile = header_profile(buf).map_err(|message| BagError::Mcap {
            path: path.to_path_buf(),
            message,
        })?;
        if profile != "ros2" {
            return Err(not_ros2(format!(
                "MCAP profile is `{profile}`, expected `ros2`"
            )));
        }
        let mut records = Records::default();
        // The sans-io reader with a record-length limit: `MessageStream` has none inside
        // chunks, so a corrupt record length there would make it reserve without bound
        // (found by the `bag_reader` fuzz target).
        let limit = buf
            .len()
            .saturating_mul(64)
            .saturating_add(1 << 20)
            .min(1 << 30);
        let mut reader = mcap::sans_io::LinearReader::new_with_options(
            mcap::sans_io::LinearReaderOptions::default()
                .with_record_length_limit(limit)
                .with_validate_chunk_crcs(true),
        );
        let mut fed = 0usize;
        while let Some(event) = reader.next_event() {
            match event.map_err(|e| mcap_err(path, e))? {
                mcap::sans_io::LinearReadEvent::ReadRequest(n) => {
                    let take = n.min(buf.len() - fed);
                    reader.insert(take).copy_from_slice(&buf[fed..fed + take]);
                    reader.notify_read(take);
                    fed += take;
                }
                mcap::sans_io::LinearReadEvent::Record { data, opcode } => {
                    records.record(opcode, data, path)?;
                }
            }
        }
        records.summary_channels(buf);
        let Records {
            topics,
            mut messages,
            ..
        } = records;
        messages.sort_by_key(|m| m.log_ns);
        Ok(Self {
            path: path.to_path_buf(),
            storage: Storage::Mcap,
            topics,
            messages,
        })
    }
}

/// An MCAP reader error on the file `path`.
fn mcap_err(path: &Path, e: mcap::McapError) -> BagError {
    BagError::Mcap {
        path: path.to_path_buf(),
        message: e.to_string(),
    }
}

/// What the records read so far hold: the topics (in the order of their first message),
/// the index of each channel's topic, the schemas and channels by id, and the messages.
#[derive(Default)]
struct Records {
    topics: Vec<TopicInfo>,
    channel_index: std::collections::HashMap<u16, usize>,
    schemas: std::collections::HashMap<u16, (String, String)>,
    channels: std::collections::HashMap<u16, mcap::records::Channel>,
    messages: Vec<RawMessage>,
}

impl Records {
    /// Takes in one record of the data section (`opcode`, `data`); `path` labels errors.
    fn record(&mut self, opcode: u8, data: &[u8], path: &Path) -> Result<(), BagError> {
        // Only schemas, channels and messages are needed; their length prefixes
        // are checked first (the mcap crate allocates what a prefix declares).
        if !matches!(opcode, 0x03..=0x05) {
            return Ok(());
        }
        check_lengths(opcode, data).map_err(|m| BagError::Mcap {
            path: path.to_path_buf(),
            message: m,
        })?;
        match mcap::parse_record(opcode, data).map_err(|e| mcap_err(path, e))? {
            mcap::records::Record::Schema { header, .. } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding));
            }
            mcap::records::Record::Channel(ch) => {
                self.channels.entry(ch.id).or_insert(ch);
            }
            mcap::records::Record::Message { header, data } => {
                let idx =
                    self.topic_of(header.channel_id)
                        .map_err(|message| BagError::NotRos2 {
                            path: path.to_path_buf(),
                            message,
                        })?;
                self.topics[idx].count += 1;
                self.messages.push(RawMessage {
                    topic: idx,
                    log_ns: header.log_time,
                    publish_ns: header.publish_time,
                    sequence: header.sequence,
                    data: data.into_owned(),
                });
            }
            _ => {}
        }
        Ok(())
    }

    /// The topic of channel `channel_id`, added on its first message after checking its
    /// message and schema encodings; what is wrong otherwise.
    fn topic_of(&mut self, channel_id: u16) -> Result<usize, String> {
        if let Some(&i) = self.channel_index.get(&channel_id) {
            return Ok(i);
        }
        let ch = self
            .channels
            .get(&channel_id)
            .ok_or_else(|| format!("message on unknown channel {channel_id}"))?;
        if ch.message_encoding != "cdr" {
            return Err(format!(
                "topic {} has message encoding `{}`, expected `cdr`",
                ch.topic, ch.message_encoding
            ));
        }
        let (name, enc) = self
            .schemas
            .get(&ch.schema_id)
            .ok_or_else(|| format!("topic {} has no schema", ch.topic))?;
        if enc != "ros2msg" && enc != "ros2idl" {
            return Err(format!(
                "topic {} has schema encoding `{enc}`, expected `ros2msg`",
                ch.topic
            ));
        }
        self.topics.push(TopicInfo {
            name: ch.topic.clone(),
            ros_type: name.clone(),
            count: 0,
            qos: ch.metadata.get("offered_qos_profiles").cloned(),
        });
        self.channel_index.insert(ch.id, self.topics.len() - 1);
        Ok(self.topics.len() - 1)
    }

    /// Adds the channels without messages (from the summary, when there is one).
    fn summary_channels(&mut self, buf: &[u8]) {
        if let Ok(Some(summary)) = mcap::Summary::read(buf) {
            let mut ids: Vec<_> = summary.channels.keys().copied().collect();
            ids.sort();
            for id in ids {
                let ch = &summary.channels[&id];
                if self.channel_index.contains_key(&id) || ch.message_encoding != "cdr" {
                    continue;
                }
                if let Some(schema) = &ch.schema {
                    self.topics.push(TopicInfo {
                        name: ch.topic.clone(),
                        ros_type: schema.name.clone(),
                        count: 0,
                        qos: ch.metadata.get("offered_qos_profiles").cloned(),
                    });
                    self.channel_index.insert(id, self.topics.len() - 1);
                }
            }
        }
    }
}

/// Walks the data section's records and refuses chunks whose declared uncompressed size is
/// implausible (the mcap crate reserves that size before decompressing: a corrupt chunk
/// header would otherwise abort the process). Found by the `bag_reader` fuzz target.
fn precheck(buf: &[u8]) -> Result<(), String> {
    const MAGIC: &[u8] = b"\x89MCAP0\r\n";
    const MAX_UNCOMPRESSED: u64 = 1 << 30;
    const MAX_RATIO: u64 = 1024;
    if buf.len() < MAGIC.len() || &buf[..MAGIC.len()] != MAGIC {
        return Err("bad magic: not an MCAP file".into());
    }
    let u64_at = |o: usize| -> Option<u64> {
        buf.get(o..o + 8)
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
    };
    let mut off = MAGIC.len();
    while off < buf.len() {
        let op = buf[off];
        let len =
            u64_at(off + 1).ok_or_else(|| format!("truncated record header at byte {off}"))?;
        let body = off + 9;
        let end = (body as u64)
            .checked_add(len)
            .filter(|&e| e <= buf.len() as u64)
            .ok_or_else(|| {
                format!("record at byte {off} runs past the end of the file (truncated?)")
            })? as usize;
        match op {
            0x06 => {
                // Chunk: start u64, end u64, uncompressed_size u64, crc u32, compression
                // string, records length u64, records.
                let size = u64_at(body + 16).ok_or("truncated chunk header")?;
                let compressed = len.saturating_sub(8 * 4 + 4 + 4);
                if size > MAX_UNCOMPRESSED || size > MAX_RATIO.saturating_mul(compressed.max(1)) {
                    return Err(format!(
                        "chunk at byte {off} declares {size} uncompressed bytes for {compressed} stored (corrupt)"
                    ));
                }
            }
            0x0F | 0x02 => return Ok(()), // DataEnd, Footer: the data section is over.
            _ => {}
        }
        off = end;
    }
    Ok(())
}

/// Checks that every length prefix of a Schema (0x03) or Channel (0x04) record body fits in
/// the record (found by the `bag_reader` fuzz target: the mcap crate allocates the declared
/// string length before reading it).
fn check_lengths(opcode: u8, d: &[u8]) -> Result<(), String> {
    let bad = || format!("record {opcode:#04x} has a length prefix beyond its end (corrupt)");
    let u32_at = |o: usize| -> Result<usize, String> {
        d.get(o..o + 4)
            .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
            .ok_or_else(bad)
    };
    // Skips a u32-prefixed byte string at `o`, returning the offset after it.
    let skip = |o: usize| -> Result<usize, String> {
        let n = u32_at(o)?;
        let end = (o + 4)
            .checked_add(n)
            .filter(|&e| e <= d.len())
            .ok_or_else(bad)?;
        Ok(end)
    };
    match opcode {
        0x03 => {
            let o = skip(2)?; // name
            let o = skip(o)?; // encoding
            skip(o)?; // data
        }
        0x04 => {
            let o = skip(4)?; // topic
            let o = skip(o)?; // message encoding
            let map_end = skip(o)?; // metadata map (byte length)
            let mut k = o + 4;
            while k < map_end {
                k = skip(k)?;
                k = skip(k)?;
                if k > map_end {
                    return Err(bad());
                }
            }
        }
        _ => {}
    }
    Ok(())
}

/// The profile string of the Header record that follows the magic.
fn header_profile(buf: &[u8]) -> Result<String, String> {
    let o = 8; // after the magic (checked by `precheck`)
    if buf.get(o) != Some(&0x01) {
        return Err("MCAP file does not start with a header record".into());
    }
    let len = buf
        .get(o + 1..o + 9)
        .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
        .ok_or("truncated header record")?;
    let body = buf
        .get(o + 9..)
        .and_then(|b| b.get(..usize::try_from(len).ok()?))
        .ok_or("truncated header record")?;
    let n = body
        .get(..4)
        .map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
        .ok_or("truncated header record")?;
    let p = body
        .get(4..4usize.saturating_add(n))
        .ok_or("corrupt header record")?;
    String::from_utf8(p.to_vec()).map_err(|_| "header profile is not UTF-8".into())
}
