//! rosbag2 bags: recording (MCAP) and reading (MCAP and SQLite3); the node records its
//! traffic in them and `crossym_ros::replay` replays it.
//!
//! Layout (as `ros2 bag record -s mcap` writes it): a bag is a directory holding
//! `<name>_0.mcap` and `metadata.yaml` (`rosbag2_bagfile_information`, storage `mcap`).
//! The MCAP file has profile `ros2`; one schema per message type (encoding `ros2msg`, the
//! `.msg` text with its dependencies, see [`schema`]); one channel per topic (message
//! encoding `cdr`, metadata `offered_qos_profiles`); messages are CDR with the 4-byte
//! encapsulation header (`00 01 00 00`, little endian), log and publish times in ns since
//! the Unix epoch; zstd chunks, message indexes, a summary and statistics.
//!
//! crossym also stores, in the MCAP `sequence` field, which inputs produced each
//! message, so that a run can be replayed exactly (`crossym_ros::replay`): a joint state carries the
//! count of accepted joint states after it, a condition the count of accepted conditions,
//! and a command `(js_seq mod 2¹⁹) · 2¹² + (cond_seq mod 2¹²)` of the inputs its tick used,
//! with bit 31 set on the final shutdown command.

pub mod cdr;
pub mod content;
mod error;
pub mod reader;
pub mod schema;
mod split;
#[cfg(feature = "sqlite")]
pub mod sqlite;
pub mod writer;

pub use content::{Bag, BagInfo, RawMessage, Storage, TopicInfo};
pub use writer::{BagWriter, Qos};

pub use error::BagError;
