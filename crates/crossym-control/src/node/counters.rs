//! The node's running totals: ticks, the ticks that could not run the policy as asked
//! (stale input, the filter's fallback, a non-finite policy output, an infeasible
//! condition, paused), and the supervisor's events (restarts, not-following ticks,
//! tracking warnings, a held robot found, a locked joint found).
//!
//! One [`Counters`] is written by the tick and its parts and read by two things only:
//! [`StatusSnapshot`](super::StatusSnapshot) (the totals since start) and
//! [`EventTotals`] (the transient events a status period counts, with the input gate's
//! rejections and the tick timing's late and missed ticks). Every count saturates at
//! `u64::MAX` instead of wrapping: a total never goes back. Allocation-free.

use super::gate::Inputs;
use super::period::EventTotals;
use super::timing::TickTiming;

/// The node's running totals since start (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Counters {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks without a fresh joint state.
    pub stale_ticks: u64,
    /// Ticks on the filter's fallback (or a non-finite command replaced by braking).
    pub fallback_ticks: u64,
    /// Ticks whose policy output was not finite (not counting infeasible conditions).
    pub nonfinite_ticks: u64,
    /// Ticks whose accepted condition's flow failed from the measured state.
    pub infeasible_ticks: u64,
    /// Ticks paused by an operator.
    pub paused_ticks: u64,
    /// Restarts from the measured state (position modes: the envelope left, a joint locked,
    /// a held robot tried again and held again, a controller back).
    pub restarts: u64,
    /// Ticks held because the robot does not follow.
    pub not_following_ticks: u64,
    /// Ticks with the tracking warning on.
    pub tracking_warning_ticks: u64,
    /// Held robots found.
    pub held_events: u64,
    /// Locked joints found.
    pub locked_events: u64,
}

/// Adds one to `count`, saturating.
pub(crate) fn bump(count: &mut u64) {
    *count = count.saturating_add(1);
}

impl Counters {
    /// The running totals of the transient events a status period counts: these counters,
    /// the gate's rejections (`inputs`) and the late and missed ticks (`timing`).
    pub fn event_totals(&self, inputs: &Inputs, timing: &TickTiming) -> EventTotals {
        EventTotals {
            restarts: self.restarts,
            held: self.held_events,
            locked: self.locked_events,
            rejected: u64::from(inputs.rejected_joint_states)
                + u64::from(inputs.rejected_conditions),
            stale_ticks: self.stale_ticks,
            fallback_ticks: self.fallback_ticks,
            late_ticks: timing.late,
            missed_ticks: timing.missed,
        }
    }
}

#[cfg(test)]
mod tests {
    use crossym_math::symmetry::compose::Condition;

    use super::*;

    fn inputs(rejected_joint_states: u32, rejected_conditions: u32) -> Inputs {
        let mut i = Inputs::new(2, Condition::IDENTITY);
        i.rejected_joint_states = rejected_joint_states;
        i.rejected_conditions = rejected_conditions;
        i
    }

    #[test]
    fn a_count_saturates_instead_of_wrapping() {
        let mut c = u64::MAX - 1;
        bump(&mut c);
        assert_eq!(c, u64::MAX);
        bump(&mut c);
        assert_eq!(c, u64::MAX);
        let mut zero = 0;
        bump(&mut zero);
        assert_eq!(zero, 1);
    }

    #[test]
    fn event_totals_sum_the_counters_the_gates_rejections_and_the_timing() {
        let c = Counters {
            ticks: 100,
            stale_ticks: 3,
            fallback_ticks: 5,
            nonfinite_ticks: 7,
            infeasible_ticks: 11,
            paused_ticks: 13,
            restarts: 17,
            not_following_ticks: 19,
            tracking_warning_ticks: 23,
            held_events: 29,
            locked_events: 31,
        };
        let mut timing = TickTiming::new(0.01);
        // Late by 2.5 periods: one late tick, two missed.
        timing.record_start(0.025, 2);
        // The rejection counts are u32 each; their sum must not wrap.
        let t = c.event_totals(&inputs(u32::MAX, u32::MAX), &timing);
        assert_eq!(
            t,
            EventTotals {
                restarts: 17,
                held: 29,
                locked: 31,
                rejected: 2 * u64::from(u32::MAX),
                stale_ticks: 3,
                fallback_ticks: 5,
                late_ticks: timing.late,
                missed_ticks: timing.missed,
            }
        );
        assert_eq!(timing.late, 1);
    }
}
