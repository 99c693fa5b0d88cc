//! The node's logic without DDS: latest-value inputs, the control tick and the status.
//!
//! Inputs are validated on arrival: `/joint_states` is mapped by name onto the controlled
//! joints (other joints — torso, head, wheels — are ignored) and rejected when a
//! controlled joint is missing or duplicated, names and positions differ in length, a
//! position is not finite, or the header stamp is stale; `~/symmetry_condition` is
//! rejected unless `θ` is finite, `λ > 0` is finite and `σ = ±1`, and — unless
//! `accept_untrained_conditions` — unless it lies in the box of conditions the policy was
//! trained on ([`ConditionDomain`](crossym_policy::ConditionDomain), from its sidecar). A rejected message
//! leaves the node's state untouched and is recorded (fixed-size [`Rejection`] + counts).
//!
//! Each tick at period `Δt`: with no joint state, or one older than the stale timeout,
//! the command is zero velocity (velocity mode) or a hold of the last commanded position
//! (position / trajectory mode). Otherwise `v = π(q, s)`, then the safety filter with
//! `W = JᵀJ + εI` from the task Jacobian at `q`, then the command: `v`, or `q + v·Δt`
//! clamped inside the position limits. Commands are always finite and inside the limits.
//! The tick allocates, locks and logs nothing (buffers are sized at construction).
//!
//! Position and trajectory modes continue the last commanded position while the robot
//! follows: the measured `q` must lie within `safety.tracking_tolerance` of the hull of the
//! commands issued since `safety.tracking_window_s` before its measurement (a servo whose
//! step response does not overshoot stays inside the hull of its recent commands, so lag
//! and sag pass), and — with a window — must not have moved faster than those commands did
//! (a jump: a reset, another controller). Otherwise the commands restart from the measured
//! state at rest (`RESTARTED_FROM_MEASURED`); more than `safety.max_restarts` restarts within
//! `safety.restart_window_s` mean the robot does not follow: the node brakes to a hold
//! (`ROBOT_NOT_FOLLOWING`) until a new condition is accepted. A distance to the command in
//! effect at the measurement above `safety.tracking_warning` for longer than the window is
//! reported as `TRACKING_ERROR`.
//!
//! Each concern is a part with its own rules and tests, [`NodeCore`] only their order: the
//! input gate (`gate`), the robot-follows supervisor (`supervisor`: the hold, the envelope,
//! restarts, the not-following latch, held and locked reactions; `motion` tells held from
//! locked), the operator state (`operator`), the controller at the command topic (`link`),
//! the singularity band (`singularity`), the end-effector barrier (`barrier`), the running
//! totals (`counters`), the status period (`period`) and the tick's timing (`timing`).

mod barrier;
mod code;
mod command;
mod config;
mod core;
mod counters;
mod error;
mod feasibility;
mod fit;
mod gate;
mod link;
mod motion;
mod operator;
mod period;
mod quat;
mod rejection;
mod singularity;
mod stage;
mod status;
mod supervisor;
mod task_pose;
#[cfg(test)]
mod test_robot;
mod tf;
mod timing;

pub use self::code::StatusCode;
pub use self::command::Command;
pub use self::config::{NodeConfig, OutputMode, TopicNames, Trigger, SUPPORTED_ROS_DISTROS};
pub use self::core::NodeCore;
pub use self::error::NodeError;
pub use self::feasibility::{ConditionFeasibility, Infeasibility};
pub use self::gate::{InputGate, Inputs, SHUTDOWN_SEQUENCE_BIT};
pub use self::motion::{Motion, MotionSettings, MotionSupervisor};
pub use self::operator::{OperatorRefusal, OperatorRequest, RuntimeBounds, RuntimeSettings};
pub use self::period::{EventTotals, PeriodCounts, StatusPeriod};
pub use self::rejection::Rejection;
pub use self::singularity::{
    SingularityBand, SingularityReport, SingularitySettings, SingularityStatus,
};
pub use self::stage::{OutputStage, PolicyOutput};
pub use self::status::{StatusSnapshot, TickReport};
pub use self::task_pose::{
    PoseCondition, PoseRejection, TaskPoseConfig, TaskPoseConfigError, TaskPoseMap,
};
pub use self::tf::{TfBuffer, TfError};
pub use self::timing::TickTiming;
