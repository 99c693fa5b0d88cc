//! # crossym-control — the control floor of crossym
//!
//! Everything between a joint state and a command, without a network:
//! - [`safety`]: the QP joint-limit safety filter (active set, Clarabel as fallback);
//! - [`node`]: the node's logic: joint-state and condition validation ([`InputGate`]), the
//!   control tick `π(q, s)` → safety filter → command ([`NodeCore`]), stale-state handling
//!   and the status snapshot;
//! - [`realtime`]: the control thread's real-time settings (SCHED_FIFO, mlockall);
//! - `faults` (feature `fault-injection`): deliberate filter defects and policy overrides
//!   for tests and fault campaigns; a node's `NodeCore` never runs them.
//!
//! The DDS node, bag replay and the mock robots (crate `crossym-ros`) wrap [`NodeCore`];
//! everything here is testable without a network, and bag replay drives it bit for bit.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "fault-injection")]
pub mod faults;
pub mod node;
pub mod realtime;
pub mod safety;
pub mod severity;

pub use node::{
    Command, InputGate, Inputs, NodeConfig, NodeCore, NodeError, OperatorRefusal, OperatorRequest,
    OutputMode, Rejection, RuntimeBounds, SingularitySettings, StatusCode, StatusSnapshot,
    TickReport, TopicNames, Trigger,
};
pub use severity::Severity;
