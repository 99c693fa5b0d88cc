//! Safety: every command the node publishes passes through a joint-limit QP filter.
//!
//! - [`bounds`]: per-joint velocity, acceleration and position bounds that hold over the
//!   time a command can act (state age, actuation latency, one period, braking).
//! - [`history`]: the commands published so far, and which ones the robot may still run.
//! - [`settings`]: the filter's settings, validated once, and its setup errors.
//! - [`filter`]: the QP `min (x − v)ᵀW(x − v)` under those bounds and an optional
//!   end-effector distance barrier, solved by [`active_set`] (a dense primal active-set
//!   method, checked) or, where it declines, by Clarabel set up once.

pub mod active_set;
pub mod bounds;
pub mod filter;
pub mod history;
mod qp;
pub mod rules;
pub mod settings;

pub use filter::{
    Anchor, Barrier, SafetyError, SafetyFilter, SafetyReport, SafetySettings, SafetyStatus,
};
pub use rules::{BoundRules, ExactBounds};
