//! Safety: every command the node publishes passes through a joint-limit QP filter.
//!
//! - [`bounds`]: per-joint velocity, acceleration and braking-aware position bounds.
//! - [`filter`]: the QP `min (x − v)ᵀW(x − v)` under those bounds and an optional
//!   end-effector distance barrier, solved with Clarabel set up once.

pub mod bounds;
pub mod filter;

pub use filter::{Barrier, SafetyError, SafetyFilter, SafetyReport, SafetySettings, SafetyStatus};
