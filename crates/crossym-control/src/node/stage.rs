//! What the node does with the policy's velocity before the safety filter
//! ([`OutputStage`]): nothing ([`PolicyOutput`], the only stage a node runs). Fault
//! campaigns and tests put adversarial policies here (`crossym_ros::sim::stress`, and with
//! the `fault-injection` feature `crate::faults::OverrideOutput`); whatever they output,
//! the safety filter still bounds every command.

/// A stage between the policy and the safety filter.
pub trait OutputStage {
    /// Called once per tick that evaluates the policy, with the tick count, the measured `q`
    /// and the policy's velocity `v` (rad/s or m/s), which it may overwrite.
    #[inline]
    fn apply(&mut self, tick: u64, q: &[f64], v: &mut [f64]) {
        let _ = (tick, q, v);
    }
}

/// The policy's velocity as it is.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PolicyOutput;

impl OutputStage for PolicyOutput {}
