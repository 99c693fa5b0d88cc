//! # crossym-io — recorded formats of crossym
//!
//! The formats robots' data arrive in, without any network:
//! - [`msg`]: the ROS 2 message types crossym reads and writes, mirrored in CDR field order;
//! - [`msgdef`]: a parser for `.msg` definitions, used to check those mirrors;
//! - [`bag`]: rosbag2 bags, written as MCAP and read as MCAP or SQLite3.
//!
//! Beside the maths on the lowest floor: learning reads demonstrations from bags, the node
//! records and replays them.
//!
//! ## Example: a message, its definition and its bytes
//!
//! ```
//! use crossym_io::bag::cdr;
//! use crossym_io::msg::{JointState, RosMessage};
//! use crossym_io::msgdef::MsgDef;
//!
//! // A joint state as a driver publishes it, as CDR (what DDS and rosbag2 carry) and back.
//! let js = JointState {
//!     name: vec!["j1".into(), "j2".into()],
//!     position: vec![0.4, 1.2], // rad
//!     ..Default::default()
//! };
//! let bytes = cdr::encode(&js)?;
//! assert_eq!(cdr::decode::<JointState>(&bytes)?, js);
//! assert_eq!(JointState::ROS_TYPE, "sensor_msgs/msg/JointState");
//!
//! // A `.msg` definition, fields in CDR order.
//! let def = MsgDef::parse("# Rotation angle (rad).\nfloat64 theta\nint8 reflection\n")?;
//! let fields: Vec<(String, String)> =
//!     def.fields.iter().map(|f| (f.name.clone(), f.ty.to_string())).collect();
//! assert_eq!(fields, [("theta".into(), "float64".into()), ("reflection".into(), "int8".into())]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

pub mod bag;
#[cfg(feature = "lerobot")]
pub mod lerobot;
pub mod msg;
pub mod msgdef;

pub use msgdef::{
    ArrayKind, ConstantDef, FieldDef, FieldType, FieldTypeError, MsgDef, MsgDefError,
};
