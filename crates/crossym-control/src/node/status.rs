//! The node's status: codes (following `moveit_msgs` ServoStatus), the per-tick report and
//! the `Copy` snapshot the I/O side logs and publishes.

use crossym_io::msg;
use crossym_math::symmetry::compose::Condition;

use super::period::PeriodCounts;
use super::rejection::Rejection;
use crate::safety::SafetyStatus;

/// Status codes of `crossym_msgs/Status` (values equal the message's constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i8)]
#[non_exhaustive]
pub enum StatusCode {
    /// The (filtered) policy output was commanded.
    NoWarning = 0,
    /// Moving toward a singular posture inside the band: the command is scaled down.
    DecelerateForSingularity = 1,
    /// At `singularity.stop`: the command toward the singularity is zero.
    HaltForSingularity = 2,
    /// The end-effector distance barrier shaped the command.
    DecelerateForCollision = 3,
    /// At least one joint's command sits on a bound.
    JointBound = 5,
    /// No joint state yet, or a stale one: zero velocity / hold.
    StaleJointStates = 16,
    /// The latest message on an input topic was rejected.
    InvalidInput = 17,
    /// The safety QP failed; the clamp of the policy output was commanded.
    SafetyFallback = 18,
    /// The policy returned non-finite velocities (replaced by 0).
    PolicyNonfinite = 19,
    /// Shutting down: the final zero / hold command was produced.
    Shutdown = 20,
    /// A canonicalised policy's flows failed from the current state (the robot moved to
    /// where the accepted condition is singular), or a task-space head's lift `J⁺` is
    /// singular there (a stretched or folded arm): zero velocity, filtered.
    ConditionInfeasible = 21,
    /// Position modes: the measured state left the envelope of the commands the robot may
    /// be following (a reset, a robot moved by something else): the commands restarted from
    /// the measured state at rest this tick.
    RestartedFromMeasured = 22,
    /// Position modes: the robot does not follow its commands (more than
    /// `safety.max_restarts` restarts within `safety.restart_window_s`): braking to a hold,
    /// no policy motion until a new condition is accepted.
    RobotNotFollowing = 23,
    /// Position modes: the measured state has been farther than `safety.tracking_warning`
    /// from the command in effect for longer than `safety.tracking_window_s`.
    TrackingError = 24,
    /// Paused by an operator (`~/pause`): braking to zero, then holding.
    Paused = 25,
    /// Lifecycle state not active (inactive, unconfigured or finalized): no command, except
    /// the braking commands after a deactivation until they reach zero.
    Inactive = 26,
    /// Position modes: every joint stopped while commanded to move (a collision hold): the
    /// commands restarted from the measured state and hold there, then the policy is tried
    /// again; reported until a joint moves.
    RobotHeld = 27,
    /// Position modes: one joint did not move while commanded faster than
    /// `[node] motion.speed` and the others moved (`locked_joint` names it): the commands
    /// restarted from the measured state (counted like a restart).
    JointLocked = 28,
    /// The command topic has no matched subscriber (the controller was switched off):
    /// braking to a hold; restarts from the measured state when one matches again.
    NoCommandSubscriber = 29,
}

impl StatusCode {
    /// The `Status.msg` constant name of this code.
    pub fn constant_name(self) -> &'static str {
        match self {
            StatusCode::NoWarning => "NO_WARNING",
            StatusCode::DecelerateForSingularity => "DECELERATE_FOR_APPROACHING_SINGULARITY",
            StatusCode::HaltForSingularity => "HALT_FOR_SINGULARITY",
            StatusCode::DecelerateForCollision => "DECELERATE_FOR_COLLISION",
            StatusCode::JointBound => "JOINT_BOUND",
            StatusCode::StaleJointStates => "STALE_JOINT_STATES",
            StatusCode::InvalidInput => "INVALID_INPUT",
            StatusCode::SafetyFallback => "SAFETY_FALLBACK",
            StatusCode::PolicyNonfinite => "POLICY_NONFINITE",
            StatusCode::Shutdown => "SHUTDOWN",
            StatusCode::ConditionInfeasible => "CONDITION_INFEASIBLE",
            StatusCode::RestartedFromMeasured => "RESTARTED_FROM_MEASURED",
            StatusCode::RobotNotFollowing => "ROBOT_NOT_FOLLOWING",
            StatusCode::TrackingError => "TRACKING_ERROR",
            StatusCode::Paused => "PAUSED",
            StatusCode::Inactive => "INACTIVE",
            StatusCode::RobotHeld => "ROBOT_HELD",
            StatusCode::JointLocked => "JOINT_LOCKED",
            StatusCode::NoCommandSubscriber => "NO_COMMAND_SUBSCRIBER",
        }
    }

    /// Rank of the code for the worst code of a status period (0 = `NO_WARNING`; higher is
    /// worse; every code its own rank): faults of the node, then the robot not doing what it
    /// is told, then inputs, then the operator's states, then shaping by the filter.
    pub fn severity(self) -> u8 {
        match self {
            StatusCode::NoWarning => 0,
            StatusCode::JointBound => 1,
            StatusCode::DecelerateForSingularity => 2,
            StatusCode::DecelerateForCollision => 3,
            StatusCode::HaltForSingularity => 4,
            StatusCode::Inactive => 5,
            StatusCode::Paused => 6,
            StatusCode::TrackingError => 7,
            StatusCode::RestartedFromMeasured => 8,
            StatusCode::ConditionInfeasible => 9,
            StatusCode::InvalidInput => 10,
            StatusCode::StaleJointStates => 11,
            StatusCode::NoCommandSubscriber => 12,
            StatusCode::JointLocked => 13,
            StatusCode::RobotHeld => 14,
            StatusCode::RobotNotFollowing => 15,
            StatusCode::PolicyNonfinite => 16,
            StatusCode::SafetyFallback => 17,
            StatusCode::Shutdown => 18,
        }
    }

    /// The code's value in `Status.code`.
    pub fn value(self) -> i8 {
        self as i8
    }

    /// Every code, for table checks.
    pub const ALL: [StatusCode; 19] = [
        StatusCode::NoWarning,
        StatusCode::DecelerateForSingularity,
        StatusCode::HaltForSingularity,
        StatusCode::DecelerateForCollision,
        StatusCode::JointBound,
        StatusCode::StaleJointStates,
        StatusCode::InvalidInput,
        StatusCode::SafetyFallback,
        StatusCode::PolicyNonfinite,
        StatusCode::Shutdown,
        StatusCode::ConditionInfeasible,
        StatusCode::RestartedFromMeasured,
        StatusCode::RobotNotFollowing,
        StatusCode::TrackingError,
        StatusCode::Paused,
        StatusCode::Inactive,
        StatusCode::RobotHeld,
        StatusCode::JointLocked,
        StatusCode::NoCommandSubscriber,
    ];

    /// Human-readable text of the code.
    pub fn message(self) -> &'static str {
        match self {
            StatusCode::NoWarning => "ok",
            StatusCode::DecelerateForSingularity => {
                "approaching a singular posture: command scaled down"
            }
            StatusCode::HaltForSingularity => {
                "at the singularity stop: no motion toward the singular posture"
            }
            StatusCode::DecelerateForCollision => "end-effector distance barrier active",
            StatusCode::JointBound => "joint command on a velocity/acceleration/position bound",
            StatusCode::StaleJointStates => "no recent joint state: zero velocity / hold",
            StatusCode::InvalidInput => "latest input message rejected (see last_error)",
            StatusCode::SafetyFallback => "safety QP failed: clamped policy output",
            StatusCode::PolicyNonfinite => "policy output not finite: replaced by 0",
            StatusCode::Shutdown => "shutting down: final zero/hold command",
            StatusCode::ConditionInfeasible => {
                "policy undefined at the current state (singular flow or lift): zero velocity"
            }
            StatusCode::RestartedFromMeasured => {
                "robot left the envelope of its commands: restarted from the measured state"
            }
            StatusCode::RobotNotFollowing => {
                "robot does not follow its commands: holding until a new condition is accepted"
            }
            StatusCode::TrackingError => {
                "robot lags its commands by more than safety.tracking_warning"
            }
            StatusCode::Paused => "paused by an operator (~/pause): braking, then holding",
            StatusCode::Inactive => {
                "lifecycle state not active: no command until activated (~/change_state)"
            }
            StatusCode::RobotHeld => {
                "robot held (every joint stopped while commanded to move): holding at the \
                 measured state, then trying again"
            }
            StatusCode::JointLocked => {
                "a joint does not move while commanded to (see locked_joint): restarted from \
                 the measured state"
            }
            StatusCode::NoCommandSubscriber => {
                "no subscriber matched on the command topic (controller off): holding"
            }
        }
    }
}

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
        }
    }
}
