//! Writing a rosbag2 MCAP bag directory (see the module docs of [`crate::bag`]).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{cdr, schema, BagError};
use crate::msg::RosMessage;

/// The offered QoS recorded for a topic (rosbag2 Humble numeric form).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Qos {
    /// Reliable (true) or best effort.
    pub reliable: bool,
    /// Keep-last depth.
    pub depth: u32,
}

impl Qos {
    /// Reliable, keep last `depth`.
    pub const fn reliable(depth: u32) -> Self {
        Self {
            reliable: true,
            depth,
        }
    }

    /// Best effort, keep last `depth`.
    pub const fn best_effort(depth: u32) -> Self {
        Self {
            reliable: false,
            depth,
        }
    }

    /// The `offered_qos_profiles` YAML (a list of one profile).
    pub fn yaml(&self) -> String {
        let inf = "\n    sec: 2147483647\n    nsec: 4294967295";
        format!(
            "- history: 1\n  depth: {}\n  reliability: {}\n  durability: 2\n  deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  avoid_ros_namespace_conventions: false",
            self.depth,
            if self.reliable { 1 } else { 2 }
        )
    }
}

struct TopicEntry {
    name: String,
    ros_type: String,
    qos: Qos,
    channel: u16,
    count: u64,
}

/// An open bag being written; [`BagWriter::finish`] completes the MCAP file and writes
/// `metadata.yaml`. Dropping it unfinished leaves a truncated MCAP (readers say so).
pub struct BagWriter {
    dir: PathBuf,
    file_name: String,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    topics: Vec<TopicEntry>,
    first_ns: Option<u64>,
    last_ns: u64,
    count: u64,
}

/// Handle of a topic in a [`BagWriter`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TopicId(usize);

impl BagWriter {
    /// Creates the bag directory `dir` (it must not exist, as with `ros2 bag record -o`).
    pub fn create(dir: &Path) -> Result<Self, BagError> {
        let io = |source| BagError::Io {
            path: dir.to_path_buf(),
            source,
        };
        if dir.exists() {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::AlreadyExists,
                "bag directory exists",
            )));
        }
        std::fs::create_dir_all(dir).map_err(io)?;
        let base = dir
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "bag".into());
        let file_name = format!("{base}_0.mcap");
        let path = dir.join(&file_name);
        let f = File::create(&path).map_err(|source| BagError::Io {
            path: path.clone(),
            source,
        })?;
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(concat!("crossym ", env!("CARGO_PKG_VERSION")))
            .compression(Some(mcap::Compression::Zstd))
            .chunk_size(Some(1 << 20))
            .create(BufWriter::new(f))
            .map_err(|e| BagError::Mcap {
                path: path.clone(),
                message: e.to_string(),
            })?;
        Ok(Self {
            dir: dir.to_path_buf(),
            file_name,
            writer: Some(writer),
            topics: Vec::new(),
            first_ns: None,
            last_ns: 0,
            count: 0,
        })
    }

    fn mcap_err(&self, e: mcap::McapError) -> BagError {
        BagError::Mcap {
            path: self.dir.join(&self.file_name),
            message: e.to_string(),
        }
    }

    /// Adds a topic of message type `M`.
    pub fn add_topic<M: RosMessage>(&mut self, topic: &str, qos: Qos) -> Result<TopicId, BagError> {
        let text = schema::schema_of::<M>();
        let w = self.writer.as_mut().expect("open until finish");
        let r = w
            .add_schema(M::ROS_TYPE, "ros2msg", text.as_bytes())
            .and_then(|sid| {
                let mut meta = BTreeMap::new();
                meta.insert("offered_qos_profiles".to_string(), qos.yaml());
                w.add_channel(sid, topic, "cdr", &meta)
            });
        let channel = r.map_err(|e| self.mcap_err(e))?;
        self.topics.push(TopicEntry {
            name: topic.to_string(),
            ros_type: M::ROS_TYPE.to_string(),
            qos,
            channel,
            count: 0,
        });
        Ok(TopicId(self.topics.len() - 1))
    }

    /// Writes a message already encoded as CDR (with header) at `log_ns` (ns since epoch).
    pub fn write_raw(
        &mut self,
        topic: TopicId,
        data: &[u8],
        log_ns: u64,
        publish_ns: u64,
        sequence: u32,
    ) -> Result<(), BagError> {
        let t = &mut self.topics[topic.0];
        let header = mcap::records::MessageHeader {
            channel_id: t.channel,
            sequence,
            log_time: log_ns,
            publish_time: publish_ns,
        };
        t.count += 1;
        self.count += 1;
        self.first_ns = Some(self.first_ns.map_or(log_ns, |f| f.min(log_ns)));
        self.last_ns = self.last_ns.max(log_ns);
        let w = self.writer.as_mut().expect("open until finish");
        w.write_to_known_channel(&header, data)
            .map_err(|e| BagError::Mcap {
                path: self.dir.join(&self.file_name),
                message: e.to_string(),
            })
    }

    /// Encodes `m` as CDR and writes it.
    pub fn write<M: Serialize>(
        &mut self,
        topic: TopicId,
        m: &M,
        log_ns: u64,
        sequence: u32,
    ) -> Result<(), BagError> {
        let data = cdr::encode(m).map_err(|e| BagError::Decode {
            path: self.dir.join(&self.file_name),
            topic: self.topics[topic.0].name.clone(),
            ros_type: self.topics[topic.0].ros_type.clone(),
            index: self.count as usize,
            message: e.to_string(),
        })?;
        self.write_raw(topic, &data, log_ns, log_ns, sequence)
    }

    /// Messages written so far (count).
    pub fn message_count(&self) -> u64 {
        self.count
    }

    /// Completes the MCAP file (summary, statistics) and writes `metadata.yaml`.
    pub fn finish(mut self) -> Result<PathBuf, BagError> {
        let mut w = self.writer.take().expect("open until finish");
        w.finish().map_err(|e| self.mcap_err(e))?;
        drop(w);
        let start = self.first_ns.unwrap_or(0);
        let duration = self.last_ns.saturating_sub(start);
        let mut y = String::from(
            "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: mcap\n",
        );
        y.push_str(&format!(
            "  duration:\n    nanoseconds: {duration}\n  starting_time:\n    nanoseconds_since_epoch: {start}\n  message_count: {}\n  topics_with_message_count:\n",
            self.count
        ));
        for t in &self.topics {
            y.push_str(&format!(
                "    - topic_metadata:\n        name: {}\n        type: {}\n        serialization_format: cdr\n        offered_qos_profiles: {:?}\n      message_count: {}\n",
                t.name,
                t.ros_type,
                t.qos.yaml(),
                t.count
            ));
        }
        y.push_str(&format!(
            "  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - {f}\n  files:\n    - path: {f}\n      starting_time:\n        nanoseconds_since_epoch: {start}\n      duration:\n        nanoseconds: {duration}\n      message_count: {}\n",
            self.count,
            f = self.file_name
        ));
        let meta = self.dir.join("metadata.yaml");
        std::fs::write(&meta, y).map_err(|source| BagError::Io {
            path: meta.clone(),
            source,
        })?;
        Ok(self.dir.clone())
    }
}
