//! What a bag holds once read, whatever its storage: topics, messages in log-time order,
//! decoding on demand. The MCAP reader ([`super::reader`]) and the SQLite3 reader
//! ([`super::sqlite`]) produce a [`Bag`].

use std::path::PathBuf;

use serde::de::DeserializeOwned;

use super::{cdr, BagError};

/// One message as stored.
#[derive(Debug, Clone, PartialEq)]
pub struct RawMessage {
    /// Index into [`Bag::topics`].
    pub topic: usize,
    /// Log time (ns since the Unix epoch).
    pub log_ns: u64,
    /// Publish time (ns since the Unix epoch).
    pub publish_ns: u64,
    /// MCAP sequence number.
    pub sequence: u32,
    /// CDR payload with encapsulation header.
    pub data: Vec<u8>,
}

/// A topic of a bag.
#[derive(Debug, Clone, PartialEq)]
pub struct TopicInfo {
    /// Topic name.
    pub name: String,
    /// ROS type (`pkg/msg/Type`).
    pub ros_type: String,
    /// Messages (count).
    pub count: usize,
    /// `offered_qos_profiles` metadata, if any.
    pub qos: Option<String>,
}

/// The storage format of a bag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Storage {
    /// MCAP (`.mcap`, rosbag2's default since Iron).
    Mcap,
    /// SQLite3 (`.db3`, rosbag2's default up to Humble).
    Sqlite3,
}

impl Storage {
    /// rosbag2's storage identifier (`mcap`, `sqlite3`).
    pub fn id(self) -> &'static str {
        match self {
            Self::Mcap => "mcap",
            Self::Sqlite3 => "sqlite3",
        }
    }
}

/// Summary like `ros2 bag info`.
#[derive(Debug, Clone, PartialEq)]
pub struct BagInfo {
    /// Storage format.
    pub storage: Storage,
    /// Topics.
    pub topics: Vec<TopicInfo>,
    /// Messages (count).
    pub message_count: usize,
    /// First log time (ns since epoch).
    pub start_ns: u64,
    /// Last log time (ns since epoch).
    pub end_ns: u64,
}

impl std::fmt::Display for BagInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "Storage id:    {}", self.storage.id())?;
        writeln!(
            f,
            "Duration:      {:.3} s",
            (self.end_ns - self.start_ns) as f64 * 1e-9
        )?;
        writeln!(f, "Start:         {} ns", self.start_ns)?;
        writeln!(f, "End:           {} ns", self.end_ns)?;
        writeln!(f, "Messages:      {}", self.message_count)?;
        writeln!(f, "Topic information:")?;
        for t in &self.topics {
            writeln!(
                f,
                "  Topic: {} | Type: {} | Count: {} | Serialization Format: cdr",
                t.name, t.ros_type, t.count
            )?;
        }
        Ok(())
    }
}

/// A bag loaded in memory.
#[derive(Debug, Clone)]
pub struct Bag {
    /// The `.mcap` or `.db3` file read (a split bag: its directory).
    pub path: PathBuf,
    /// Its storage format.
    pub storage: Storage,
    /// Topics in channel order.
    pub topics: Vec<TopicInfo>,
    /// All messages, sorted by log time (stable).
    pub messages: Vec<RawMessage>,
}

impl Bag {
    /// Index of `topic`, if present.
    pub fn topic(&self, name: &str) -> Option<usize> {
        self.topics.iter().position(|t| t.name == name)
    }

    /// Decodes message `index` as `M`, checking the topic's type is `M`'s.
    pub fn decode<M: DeserializeOwned + crate::msg::RosMessage>(
        &self,
        index: usize,
    ) -> Result<M, BagError> {
        let m = &self.messages[index];
        let t = &self.topics[m.topic];
        let err = |message: String| BagError::Decode {
            path: self.path.clone(),
            topic: t.name.clone(),
            ros_type: t.ros_type.clone(),
            index,
            message,
        };
        if t.ros_type != M::ROS_TYPE {
            return Err(err(format!("is not a {}", M::ROS_TYPE)));
        }
        cdr::decode(&m.data).map_err(|e| err(e.to_string()))
    }

    /// Topics, counts and time range.
    pub fn info(&self) -> BagInfo {
        BagInfo {
            storage: self.storage,
            topics: self.topics.clone(),
            message_count: self.messages.len(),
            start_ns: self.messages.first().map_or(0, |m| m.log_ns),
            end_ns: self.messages.last().map_or(0, |m| m.log_ns),
        }
    }
}
