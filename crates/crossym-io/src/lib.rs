//! # crossym-io — recorded formats of crossym
//!
//! The formats robots' data arrive in, without any network:
//! - [`msg`]: the ROS 2 message types crossym reads and writes, mirrored in CDR field order;
//! - [`msgdef`]: a parser for `.msg` definitions, used to check those mirrors;
//! - [`bag`]: rosbag2 bags, written as MCAP and read as MCAP or SQLite3.
//!
//! Beside the maths on the lowest floor: learning reads demonstrations from bags, the node
//! records and replays them.

#![warn(missing_docs)]

pub mod bag;
pub mod lerobot;
pub mod msg;
pub mod msgdef;

pub use msgdef::{
    ArrayKind, ConstantDef, FieldDef, FieldType, FieldTypeError, MsgDef, MsgDefError,
};
