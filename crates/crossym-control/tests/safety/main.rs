//! The safety floor, proved by `cargo test -p crossym-control` alone (no ROS, no candle):
//! the QP joint-limit safety filter's public API, each invariant checked from first
//! principles rather than with the filter's own helpers.
//!
//! - [`envelope`]: a simulated robot (latency, old states, position or velocity commands)
//!   never passes a position limit less the margin, a velocity or an acceleration limit,
//!   nor while braking; one tick's command is the documented braking bound's clamp.
//! - [`qp`]: the active-set solution satisfies the QP's KKT conditions and is Clarabel's;
//!   the filter's weighted QP (either solver) is the one Clarabel solves when called
//!   directly; a solver failure falls back to the clamp; bad settings are refused.
//!
//! The input gate's refusals are unit tests beside it (`src/node/gate.rs`).

// The checks index several arrays with one loop variable, as the kernels they check do.
#![allow(clippy::needless_range_loop)]

mod envelope;
mod qp;
mod support;
