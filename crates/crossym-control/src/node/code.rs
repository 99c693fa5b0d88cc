//! The node's status codes, following `moveit_msgs` ServoStatus: their values equal
//! `crossym_msgs/Status`'s constants, and their severity ranks the worst code of a status
//! period.

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
    /// Position modes: every joint commanded to move stopped (a collision hold): the
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

    /// Whether a tick with this code is news an operator hears at once (`~/status` published
    /// early, [`super::StatusPeriod::escalated`]): not the filter's shaping (`NO_WARNING`,
    /// `JOINT_BOUND`, `DECELERATE_FOR_*`) nor the node's own recovery
    /// (`RESTARTED_FROM_MEASURED`), which wait for the period's end.
    pub fn is_news(self) -> bool {
        !matches!(
            self,
            StatusCode::NoWarning
                | StatusCode::JointBound
                | StatusCode::DecelerateForSingularity
                | StatusCode::DecelerateForCollision
                | StatusCode::RestartedFromMeasured
        )
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
