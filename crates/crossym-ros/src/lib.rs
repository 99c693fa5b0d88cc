//! # crossym-ros — the ROS 2 floor of crossym
//!
//! The node on the network and the robots it is tested against:
//! - [`dds`]: ROS 2 over pure-Rust DDS (ros2-client): topics, QoS, the clock;
//! - [`event_loop`]: code on the DDS participant's event-loop thread (the node's control
//!   thread, `crossym ping`);
//! - [`node`]: the ROS 2 node around [`crossym_control::NodeCore`]: control thread, I/O
//!   thread, recording, statistics;
//! - [`log`]: the node's console and `/rosout` log;
//! - [`idle_poll`]: `[node] realtime.idle_poll`'s pollers, which keep idle CPUs from halting;
//! - [`realtime`]: `[node] realtime` applied to a process (the node, `crossym ping`);
//! - [`replay`]: offline replay of a recorded bag through the node core;
//! - [`tools`]: the DDS clients of the command line: `ping`, `record`, `status`, `param`
//!   and live replay (`play`);
//! - `security` (cargo feature `security`): SROS2 keystores — the CA, enclaves, governance
//!   and permissions from sros2 policy files, signed as sros2 signs them;
//! - [`sros2`]: SROS2's `ROS_SECURITY_*` variables read as rcl reads them (secured from
//!   which enclave, Enforce or permissive), applied by [`dds`] to every participant;
//! - [`sim`]: mock hardware, the physics robot (MuJoCo, out of process), scenarios and
//!   the stress campaign.
//!
//! ## Example
//!
//! Topic names expand as ROS 2 expands them (`~/` private to the node, relative names in
//! its namespace, absolute names as they are) — what the node subscribes to and what
//! `crossym ping` and the bag tools look for:
//!
//! ```
//! use crossym_ros::dds::expand_topic;
//! assert_eq!(expand_topic("~/status", "/", "crossym"), "/crossym/status");
//! assert_eq!(expand_topic("/joint_states", "/robot", "crossym"), "/joint_states");
//! assert_eq!(expand_topic("commands", "/robot", "crossym"), "/robot/commands");
//! ```

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod dds;
pub mod event_loop;
pub mod idle_poll;
pub mod lifecycle_client;
pub mod log;
pub mod node;
pub mod realtime;
pub mod replay;
pub mod ros_args;
#[cfg(feature = "security")]
pub mod security;
pub mod sim;
pub mod sros2;
pub mod tools;
