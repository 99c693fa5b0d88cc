//! The ROS 2 node without DDS: message types mirroring the ROS interfaces in CDR field
//! order ([`msg`]), a parser for `.msg` definitions used to check them ([`msgdef`]), and
//! the node's logic ([`self::core`]): joint-state and condition validation, the control tick
//! `π(q, s)` → safety filter → command, stale-state handling and the status snapshot.
//!
//! The DDS transport (ros2-client), the mock hardware process and the peer tests wrap
//! [`NodeCore`]; everything here is testable without a network.

pub mod core;
pub mod dds;
pub mod idle_poll;
pub mod log;
pub mod msg;
pub mod msgdef;
pub mod node;
pub mod realtime;

pub use self::core::{
    Command, InputGate, Inputs, NodeConfig, NodeCore, NodeError, NodeSetupError, OutputMode,
    Rejection, StatusCode, StatusSnapshot, TickReport, TopicNames, Trigger,
};
pub use msgdef::{ArrayKind, ConstantDef, FieldDef, FieldType, MsgDef, MsgDefError};
