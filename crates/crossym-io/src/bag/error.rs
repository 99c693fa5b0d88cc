//! Errors of the bag module.

use std::path::PathBuf;

/// Errors reading or writing bags; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    /// File-system error.
    #[error("{path}: {source}")]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The MCAP container is malformed (truncated, corrupt chunk, bad magic …).
    #[error("{path}: not a readable MCAP file: {message}")]
    Mcap {
        /// The file.
        path: PathBuf,
        /// The mcap crate's description.
        message: String,
    },
    /// The SQLite3 database cannot be read (not a database, truncated, locked …).
    #[error("{path}: not a readable rosbag2 SQLite3 file: {message}")]
    Sqlite {
        /// The file.
        path: PathBuf,
        /// SQLite's description.
        message: String,
    },
    /// A storage this build cannot read (its reader is behind a cargo feature, off here).
    #[error(
        "{path}: {what} are read only by a build with crossym-io's `{feature}` feature \
         (the crossym binary: `cargo build --release --features teach`)"
    )]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What cannot be read, e.g. "SQLite3 bags".
        what: &'static str,
        /// The cargo feature of crossym-io that reads it.
        feature: &'static str,
    },
    /// The MCAP profile is not `ros2` or a channel is not CDR.
    #[error("{path}: {message}")]
    NotRos2 {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A message could not be decoded as its type.
    #[error("{path}: message {index} on {topic} ({ros_type}): {message}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// Topic.
        topic: String,
        /// ROS type.
        ros_type: String,
        /// Index of the message in the file's log order.
        index: usize,
        /// Why.
        message: String,
    },
}
