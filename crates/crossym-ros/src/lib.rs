//! # crossym-ros — the ROS 2 floor of crossym
//!
//! The node on the network and the robots it is tested against:
//! - [`dds`]: ROS 2 over pure-Rust DDS (ros2-client): topics, QoS, the clock;
//! - [`event_loop`]: code on the DDS participant's event-loop thread (the node's control
//!   thread, `crossym ping`);
//! - [`node`]: the ROS 2 node around [`crossym_control::NodeCore`]: control thread, I/O
//!   thread, recording, statistics;
//! - [`log`]: the node's console and `/rosout` log;
//! - [`idle_poll`]: the I/O thread's wait on several DDS readers;
//! - [`replay`]: offline replay of a recorded bag through the node core;
//! - [`sim`]: mock hardware, the physics robot (MuJoCo, out of process), scenarios and
//!   the stress campaign.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod dds;
pub mod event_loop;
pub mod idle_poll;
pub mod log;
pub mod node;
pub mod replay;
pub mod sim;
