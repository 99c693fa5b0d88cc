//! The DDS clients of the command line, as library calls: each opens a participant of its
//! own beside a running node (or driver) and does one job. The `crossym` commands of the
//! same names parse their options into these modules' settings, call them and print what
//! they return.
//!
//! - [`ping`]: the joint state → command round trip of a running node (`crossym ping`);
//! - [`record`]: topics into a rosbag2 MCAP bag (`crossym record`);
//! - [`status`]: a running node's `~/status`, one line per message (`crossym status`);
//! - [`param`]: a running node's parameters, get and set (`crossym param`);
//! - [`play`]: a recorded bag's inputs published at the recorded rate (`crossym replay
//!   --live`);
//! - [`stop`]: a flag set by SIGINT or SIGTERM, for the clients that run until stopped.

pub mod param;
pub mod ping;
pub mod play;
pub mod record;
pub mod status;
pub mod stop;
