//! Deliberate faults, for the tests and fault campaigns that must see the node's guarantees
//! hold (or a broken filter caught): compiled only with the `fault-injection` feature. A
//! node runs `NodeCore<PolicyOutput, ExactBounds>`, whose tick has no path through
//! anything here.
//!
//! - [`FilterDefect`]: broken bound rules for [`crate::safety::SafetyFilter::with_rules`]
//!   and [`crate::NodeCore::with_stages`];
//! - [`OverrideOutput`]: a replaceable override of the policy's velocity (adversarial
//!   policies written as closures).

use crate::node::OutputStage;
use crate::safety::{BoundRules, ExactBounds};

/// A deliberate defect of the safety filter's bounds, for the fault campaigns and tests that
/// must see a broken filter caught: `SafetyFilter::with_rules(limits, settings, defect)`.
/// [`FilterDefect::None`] computes the bounds as [`ExactBounds`] does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FilterDefect {
    /// The real filter.
    #[default]
    None,
    /// The position bound ignores the state's age, the latency and the commands in flight
    /// (the filter before issue 16: one period, as if measured now).
    NoHorizon,
    /// No position bound at all.
    NoPositionBound,
    /// No acceleration bound (the velocity box only).
    NoAccelerationBound,
}

impl BoundRules for FilterDefect {
    #[inline]
    fn since(&self, exact: f64, dt: f64) -> f64 {
        match self {
            FilterDefect::NoAccelerationBound => 1e9 * dt,
            _ => ExactBounds.since(exact, dt),
        }
    }

    #[inline]
    fn horizon_applies(&self) -> bool {
        *self != FilterDefect::NoHorizon
    }

    #[inline]
    fn position_bound(&self) -> bool {
        *self != FilterDefect::NoPositionBound
    }
}

/// A policy override, replaceable between ticks: called with the tick count, the measured
/// `q` and the policy's velocity, which it may overwrite; `None` leaves the policy's output.
pub type PolicyOverride = Box<dyn FnMut(u64, &[f64], &mut [f64]) + Send>;

/// The output stage of a node under test: the policy's velocity, or what the current
/// override makes of it (`core.output_stage_mut().0 = Some(Box::new(...))`).
#[derive(Default)]
pub struct OverrideOutput(pub Option<PolicyOverride>);

impl OutputStage for OverrideOutput {
    #[inline]
    fn apply(&mut self, tick: u64, q: &[f64], v: &mut [f64]) {
        if let Some(f) = self.0.as_mut() {
            f(tick, q, v);
        }
    }
}
