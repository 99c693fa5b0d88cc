//! The node's status: the per-tick report and the `Copy` snapshot the I/O side logs and
//! publishes (the codes are in [`code`](super::code)).

use crossym_io::msg;
use crossym_math::symmetry::compose::Condition;

use super::code::StatusCode;
use super::period::PeriodCounts;
use super::rejection::Rejection;
use crate::safety::SafetyStatus;

/// What one tick did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickReport {
    /// Status code of this tick.
    pub code: StatusCode,
    /// False when there is nothing safe to publish (position mode before any joint state).
    pub publish: bool,
    /// Safety filter status; `None` when the policy was not evaluated (stale).
    pub safety: Option<SafetyStatus>,
    /// Joints on a bound (count).
    pub active_constraints: u32,
}

/// Snapshot of the node for the Status message (no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusSnapshot {
    /// Code of the last tick.
    pub code: StatusCode,
    /// Text of the code.
    pub message: &'static str,
    /// Last rejected input, if any since start.
    pub last_error: Option<Rejection>,
    /// Joints on a bound in the last tick (count).
    pub active_constraints: u32,
    /// Rejected joint_states messages (count).
    pub rejected_joint_states: u32,
    /// Rejected symmetry_condition messages (count).
    pub rejected_conditions: u32,
    /// Ticks since start (count).
    pub ticks: u64,
    /// Stale ticks since start (count).
    pub stale_ticks: u64,
    /// Ticks on which the safety QP fell back to the clamp (count).
    pub fallback_ticks: u64,
    /// Ticks on which the policy returned non-finite velocities (count).
    pub nonfinite_ticks: u64,
    /// Ticks on which a canonicalised policy's flows failed for the accepted condition
    /// (zero velocity commanded; count).
    pub infeasible_ticks: u64,
    /// Age of the joint state at the last tick (s); negative when none.
    pub joint_state_age_s: f64,
    /// Position modes: restarts from the measured state since start (count).
    pub restarts: u64,
    /// Position modes: ticks held because the robot does not follow (count).
    pub not_following_ticks: u64,
    /// Position modes: ticks with a tracking error above `safety.tracking_warning` for
    /// longer than `safety.tracking_window_s` (count).
    pub tracking_warning_ticks: u64,
    /// Position modes: the largest distance (rad or m) over the joints between the measured
    /// position and the command in effect when it was measured, at the last tick; 0 in
    /// velocity mode.
    pub tracking_error: f64,
    /// Duration of the last tick (µs), as recorded by the caller.
    pub tick_time_us: f64,
    /// Maximum recorded tick duration (µs).
    pub tick_time_max_us: f64,
    /// Condition of the last tick.
    pub condition: Condition,
    /// Paused by an operator.
    pub paused: bool,
    /// `velocity_scale` in force.
    pub velocity_scale: f64,
    /// Worst condition number of the chains' task Jacobians at the last tick.
    pub singularity_condition: f64,
    /// Factor the singularity band applied at the last tick.
    pub singularity_factor: f64,
    /// Worst code of the ticks since the previous status ([`StatusCode::severity`]).
    pub period_code: StatusCode,
    /// Ticks since the previous status (count).
    pub period_ticks: u32,
    /// Transient events since the previous status (counts).
    pub period: PeriodCounts,
    /// Position modes: robot-held detections since start (count).
    pub held_events: u64,
    /// Position modes: locked-joint detections since start (count).
    pub locked_events: u64,
    /// The joint last found locked (index into the controlled joints).
    pub locked_joint: Option<usize>,
    /// Subscribers matched on the command topic (`None`: not known).
    pub command_subscribers: Option<u32>,
    /// Ticks started more than half a period late since start (count).
    pub late_ticks: u64,
    /// Ticks never run since start (count).
    pub missed_ticks: u64,
    /// Largest lateness of a tick's start since start (µs).
    pub tick_late_max_us: f64,
}

impl StatusSnapshot {
    /// As a Status message stamped `stamp` (allocates; off the tick).
    pub fn to_msg(&self, stamp: msg::Time, joint_names: &[String]) -> msg::Status {
        let header = msg::Header {
            stamp,
            frame_id: String::new(),
        };
        msg::Status {
            header: header.clone(),
            code: self.code as i8,
            message: format!("{}: {}", self.code.constant_name(), self.message),
            last_error: self
                .last_error
                .map(|r| r.explain(joint_names))
                .unwrap_or_default(),
            active_constraints: self.active_constraints,
            rejected_joint_states: self.rejected_joint_states,
            rejected_conditions: self.rejected_conditions,
            ticks: self.ticks,
            stale_ticks: self.stale_ticks,
            joint_state_age_s: self.joint_state_age_s,
            tick_time_us: self.tick_time_us,
            tick_time_max_us: self.tick_time_max_us,
            condition: msg::SymmetryCondition {
                header,
                theta: self.condition.theta,
                scale: self.condition.scale,
                reflection: self.condition.reflection,
            },
            restarts: self.restarts,
            not_following_ticks: self.not_following_ticks,
            tracking_warning_ticks: self.tracking_warning_ticks,
            tracking_error: self.tracking_error,
            paused: self.paused,
            velocity_scale: self.velocity_scale,
            singularity_condition: self.singularity_condition,
            singularity_factor: self.singularity_factor,
            period_code: self.period_code as i8,
            period_ticks: self.period_ticks,
            period_restarts: self.period.restarts,
            period_held: self.period.held,
            period_locked: self.period.locked,
            period_rejected: self.period.rejected,
            period_stale_ticks: self.period.stale_ticks,
            period_fallback_ticks: self.period.fallback_ticks,
            held_events: self.held_events,
            locked_events: self.locked_events,
            locked_joint: self
                .locked_joint
                .and_then(|j| joint_names.get(j).cloned())
                .unwrap_or_default(),
            command_subscribers: self
                .command_subscribers
                .map_or(-1, |n| n.min(i32::MAX as u32) as i32),
            late_ticks: self.late_ticks,
            missed_ticks: self.missed_ticks,
            period_late_ticks: self.period.late_ticks,
            period_missed_ticks: self.period.missed_ticks,
            tick_late_max_us: self.tick_late_max_us,
        }
    }
}
