//! The node's logic without DDS: latest-value inputs, the control tick and the status.
//!
//! Inputs are validated on arrival: `/joint_states` is mapped by name onto the controlled
//! joints (other joints — torso, head, wheels — are ignored) and rejected when a
//! controlled joint is missing or duplicated, names and positions differ in length, a
//! position is not finite, or the header stamp is stale; `~/symmetry_condition` is
//! rejected unless `θ` is finite, `λ > 0` is finite and `σ = ±1`, and — unless
//! `accept_untrained_conditions` — unless it lies in the box of conditions the policy was
//! trained on ([`ConditionDomain`], from its sidecar). A rejected message
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

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::safety::history::{CommandHistory, CommandWindow};
use crate::safety::{Anchor, Barrier, SafetyError, SafetyFilter, SafetySettings, SafetyStatus};
use crossym_io::msg;
use crossym_learn::policy::{
    AnyPolicy, AnyWorkspace, ConditionDomain, DomainViolation, EquivariantPolicy,
    EquivariantWorkspace,
};
use crossym_math::kinematics::{JointLimits, Kinematics, KinematicsWorkspace};
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::composed::ComposedError;

/// What the node publishes on its command topic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputMode {
    /// Joint velocities (rad/s) as Float64MultiArray (ForwardCommandController).
    #[default]
    Velocity,
    /// Integrated joint positions `q + v·Δt` (rad) as Float64MultiArray.
    Position,
    /// A one-point JointTrajectory (positions and velocities, reached after `Δt`).
    Trajectory,
}

/// Topic names (ROS syntax; `~/` is the node's private namespace).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TopicNames {
    /// Joint-state input (sensor_msgs/JointState).
    pub joint_states: String,
    /// Condition input (crossym_msgs/SymmetryCondition).
    pub symmetry_condition: String,
    /// Command output (Float64MultiArray or JointTrajectory).
    pub command: String,
    /// Status output (crossym_msgs/Status).
    pub status: String,
}

impl Default for TopicNames {
    fn default() -> Self {
        Self {
            joint_states: "/joint_states".into(),
            symmetry_condition: "~/symmetry_condition".into(),
            command: "/forward_velocity_controller/commands".into(),
            status: "~/status".into(),
        }
    }
}

/// When the control tick runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Trigger {
    /// Every `period_s`, on the latest inputs (fixed-rate controller).
    #[default]
    Timer,
    /// On every accepted joint state (lowest latency); when none arrives for
    /// `stale_timeout_s`, at `period_s` (commanding the stale-input stop).
    JointStates,
}

/// `[node]`: the ROS 2 node's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NodeConfig {
    /// Node name.
    pub name: String,
    /// Node namespace (`/` for the root).
    pub namespace: String,
    /// Control period `Δt` (s); overrides the safety filter's `dt`.
    pub period_s: f64,
    /// Joint states older than this (s) are stale: zero velocity / hold position.
    pub stale_timeout_s: f64,
    /// Reject joint states whose non-zero header stamp is older than the stale timeout.
    pub check_stamps: bool,
    /// Condition applied until a valid `symmetry_condition` arrives.
    pub default_condition: Condition,
    /// What the command topic carries.
    pub output: OutputMode,
    /// Topic names.
    pub topics: TopicNames,
    /// When the tick runs.
    pub trigger: Trigger,
    /// Period of `~/status` (s).
    pub status_period_s: f64,
    /// Policy file (`.safetensors` with its `.json` sidecar), relative to the config file.
    pub policy: Option<PathBuf>,
    /// Safety filter settings (`dt` is replaced by `period_s`).
    pub safety: SafetySettings,
    /// Accept symmetry conditions outside the box the policy was trained on (its
    /// [`ConditionDomain`], read from the policy's sidecar): the policy then extrapolates.
    /// Default false: such conditions are rejected and the previous one is kept.
    pub accept_untrained_conditions: bool,
    /// Console and `/rosout` log level of the node (`debug`, `info`, `warn`, `error`).
    pub log_level: crate::Severity,
    /// Real-time settings of the control thread (`SCHED_FIFO`, locked memory); off when
    /// absent.
    pub realtime: Option<crate::realtime::RealtimeConfig>,
    /// Trajectory mode: each JointTrajectory starts with a point at `time_from_start = 0`
    /// on the previous command, so that a JointTrajectoryController interpolates along the
    /// node's path instead of restarting from the measured state (its default). False: one
    /// point, reached after `period_s`.
    pub trajectory_start_point: bool,
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self {
            name: "crossym".into(),
            namespace: "/".into(),
            period_s: 0.01,
            stale_timeout_s: 0.1,
            check_stamps: true,
            default_condition: Condition::IDENTITY,
            output: OutputMode::Velocity,
            topics: TopicNames::default(),
            trigger: Trigger::Timer,
            status_period_s: 0.1,
            policy: None,
            safety: SafetySettings::default(),
            accept_untrained_conditions: false,
            log_level: crate::Severity::Info,
            realtime: None,
            trajectory_start_point: true,
        }
    }
}

impl NodeConfig {
    /// The conditions the node accepts for `policy`: its trained [`ConditionDomain`], or
    /// `None` (every valid condition) with `accept_untrained_conditions` or when the policy
    /// records no training; an error names a malformed training record.
    /// A canonicalised policy has no box: it is checked for feasibility instead; nor has a
    /// task head of the whole group (reflection, rotation and scaling), exactly
    /// equivariant in `X` for every condition whose drawing the arms reach.
    pub fn condition_domain(&self, policy: &AnyPolicy) -> Result<Option<ConditionDomain>, String> {
        let whole_group = policy.task_head().is_some_and(|h| {
            let m = h.map();
            m.reflection.is_some() && m.rotation.is_some() && m.scaling.is_some()
        });
        if self.accept_untrained_conditions || policy.composition().is_some() || whole_group {
            return Ok(None);
        }
        ConditionDomain::from_meta(&policy.network().meta)
    }

    /// Checks periods, timeout, names and the default condition; says what is wrong.
    pub fn validate(&self) -> Result<(), NodeError> {
        let bad = |field: &'static str, message: String| NodeError::Config { field, message };
        if !(self.period_s.is_finite() && self.period_s > 0.0) {
            return Err(bad(
                "period_s",
                format!("{} must be positive", self.period_s),
            ));
        }
        if !(self.stale_timeout_s.is_finite() && self.stale_timeout_s >= self.period_s) {
            return Err(bad(
                "stale_timeout_s",
                format!(
                    "{} must be finite and at least period_s = {}",
                    self.stale_timeout_s, self.period_s
                ),
            ));
        }
        if !(self.status_period_s.is_finite() && self.status_period_s > 0.0) {
            return Err(bad(
                "status_period_s",
                format!("{} must be positive", self.status_period_s),
            ));
        }
        if self.name.is_empty() {
            return Err(bad("name", "must not be empty".into()));
        }
        if !self.namespace.starts_with('/') {
            return Err(bad(
                "namespace",
                format!("`{}` must start with /", self.namespace),
            ));
        }
        self.default_condition
            .validate()
            .map_err(|m| bad("default_condition", m))?;
        if let Some(r) = &self.realtime {
            r.validate().map_err(|m| bad("realtime", m))?;
        }
        Ok(())
    }
}

/// Setup errors of the node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeError {
    /// A `[node]` setting is out of its domain.
    #[error("invalid node setting `{field}`: {message}")]
    Config {
        /// Configuration key.
        field: &'static str,
        /// Why.
        message: String,
    },
    /// The policy does not fit the robot's controlled joints.
    #[error("policy does not fit the robot: {message}")]
    Policy {
        /// What differs.
        message: String,
    },
    /// The safety filter could not be built.
    #[error(transparent)]
    Safety {
        /// Filter error.
        #[from]
        source: SafetyError,
    },
}

/// Why a condition is infeasible for a canonicalised policy from the current joint state
/// (fixed size, no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Infeasibility {
    /// A lifted flow of `Φ_g⁻¹` or `dΦ_g` fails from the current state (a singularity at
    /// some flow time, an integration failure).
    Flow(ComposedError),
    /// The canonical configuration `q₀ = Φ_g⁻¹(q)` puts joint `joint` outside its limits.
    JointLimit {
        /// Index in the controlled joint order.
        joint: usize,
        /// Its canonical position (rad or m).
        position: f64,
    },
    /// The policy's output at the current state is not finite.
    NonFinite,
}

impl std::fmt::Display for Infeasibility {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Flow(e) => write!(f, "{e}"),
            Self::JointLimit { position, .. } => write!(
                f,
                "the canonical configuration Φ_g⁻¹(q) puts the joint at {position:.4}, outside its limits"
            ),
            Self::NonFinite => f.write_str("the canonicalised policy's output is not finite"),
        }
    }
}

/// The feasibility check of a condition for a canonicalised policy, from the current joint
/// state `q`: `Φ_g⁻¹(q)` and `dΦ_g π₀` must integrate (no singularity on the way), the
/// canonical configuration `q₀ = Φ_g⁻¹(q)` must lie inside the joint limits (slack 1e-9),
/// and the output must be finite. Replaces the trained-box check of plain policies: any
/// condition passing it is followed exactly (conjugate closed loop). Allocation-free after
/// construction.
#[derive(Debug, Clone)]
pub struct ConditionFeasibility {
    policy: EquivariantPolicy,
    ws: EquivariantWorkspace,
    limits: Vec<JointLimits>,
    v: Vec<f64>,
}

impl ConditionFeasibility {
    /// The check for `policy` on a robot with joint `limits`.
    pub fn new(policy: EquivariantPolicy, limits: Vec<JointLimits>) -> Self {
        let ws = policy.workspace();
        let v = vec![0.0; limits.len()];
        Self {
            policy,
            ws,
            limits,
            v,
        }
    }

    /// Whether `s` is feasible from `q`; allocation-free.
    pub fn check(&mut self, q: &[f64], s: &Condition) -> Result<(), Infeasibility> {
        self.policy
            .velocity(q, s, &mut self.v, &mut self.ws)
            .map_err(Infeasibility::Flow)?;
        let (q0, _) = self.policy.last_canonical(&self.ws);
        for (j, (l, &p)) in self.limits.iter().zip(q0).enumerate() {
            if p < l.lower - 1e-9 || p > l.upper + 1e-9 {
                return Err(Infeasibility::JointLimit {
                    joint: j,
                    position: p,
                });
            }
        }
        if self.v.iter().any(|v| !v.is_finite()) {
            return Err(Infeasibility::NonFinite);
        }
        Ok(())
    }
}

/// Why an input message was rejected (fixed size, no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Rejection {
    /// JointState `name` and `position` lengths differ.
    LengthMismatch {
        /// Number of names.
        names: usize,
        /// Number of positions.
        positions: usize,
    },
    /// A controlled joint is not in the JointState.
    MissingJoint {
        /// Index in the controlled joint order.
        joint: usize,
    },
    /// A controlled joint appears twice in the JointState.
    DuplicateJoint {
        /// Index in the controlled joint order.
        joint: usize,
    },
    /// A controlled joint's position is NaN or infinite.
    NonFinitePosition {
        /// Index in the controlled joint order.
        joint: usize,
    },
    /// The JointState's header stamp is older than the stale timeout.
    StaleStamp,
    /// The condition's `θ` is not finite.
    InvalidTheta,
    /// The condition's `λ` is not finite and positive.
    InvalidScale,
    /// The condition's `σ` is not ±1.
    InvalidReflection {
        /// The value received.
        value: i8,
    },
    /// The condition is valid but outside the policy's trained [`ConditionDomain`].
    UntrainedCondition {
        /// The part that lies outside.
        part: DomainViolation,
    },
    /// The condition is valid, but a canonicalised policy cannot follow it from the current
    /// joint state (see [`ConditionFeasibility`]).
    InfeasibleCondition {
        /// Why.
        reason: Infeasibility,
    },
}

impl Rejection {
    /// Short fixed description.
    pub fn describe(&self) -> &'static str {
        match self {
            Rejection::LengthMismatch { .. } => "joint_states: name and position lengths differ",
            Rejection::MissingJoint { .. } => "joint_states: a controlled joint is missing",
            Rejection::DuplicateJoint { .. } => "joint_states: a controlled joint appears twice",
            Rejection::NonFinitePosition { .. } => "joint_states: non-finite position",
            Rejection::StaleStamp => "joint_states: header stamp older than the stale timeout",
            Rejection::InvalidTheta => "symmetry_condition: theta is not finite",
            Rejection::InvalidScale => "symmetry_condition: scale must be finite and > 0",
            Rejection::InvalidReflection { .. } => "symmetry_condition: reflection must be 1 or -1",
            Rejection::InfeasibleCondition { .. } => {
                "symmetry_condition: infeasible from the current joint state"
            }
            Rejection::UntrainedCondition { part } => match part {
                DomainViolation::Theta => {
                    "symmetry_condition: theta outside the policy's trained range"
                }
                DomainViolation::Scale => {
                    "symmetry_condition: scale outside the policy's trained range"
                }
                DomainViolation::Reflection => {
                    "symmetry_condition: reflection -1, but the policy was trained without it"
                }
            },
        }
    }

    /// Full description naming the joint (allocates; for the status, off the tick).
    pub fn explain(&self, joint_names: &[String]) -> String {
        let name = |j: usize| joint_names.get(j).map_or("?", String::as_str);
        match *self {
            Rejection::LengthMismatch { names, positions } => {
                format!("{} ({names} names, {positions} positions)", self.describe())
            }
            Rejection::MissingJoint { joint }
            | Rejection::DuplicateJoint { joint }
            | Rejection::NonFinitePosition { joint } => {
                format!("{} (`{}`)", self.describe(), name(joint))
            }
            Rejection::InvalidReflection { value } => format!("{} (got {value})", self.describe()),
            Rejection::InfeasibleCondition {
                reason: Infeasibility::JointLimit { joint, position },
            } => format!(
                "{}: the canonical configuration Φ_g⁻¹(q) puts `{}` at {position:.4}, outside its limits",
                self.describe(),
                name(joint)
            ),
            Rejection::InfeasibleCondition { reason } => format!("{}: {reason}", self.describe()),
            _ => self.describe().to_string(),
        }
    }
}

/// Status codes of `crossym_msgs/Status` (values equal the message's constants).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i8)]
#[non_exhaustive]
pub enum StatusCode {
    /// The (filtered) policy output was commanded.
    NoWarning = 0,
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
}

impl StatusCode {
    /// The `Status.msg` constant name of this code.
    pub fn constant_name(self) -> &'static str {
        match self {
            StatusCode::NoWarning => "NO_WARNING",
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
        }
    }

    /// The code's value in `Status.code`.
    pub fn value(self) -> i8 {
        self as i8
    }

    /// Every code, for table checks.
    pub const ALL: [StatusCode; 12] = [
        StatusCode::NoWarning,
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
    ];

    /// Human-readable text of the code.
    pub fn message(self) -> &'static str {
        match self {
            StatusCode::NoWarning => "ok",
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
        }
    }
}

/// One command, sized for the controlled joints (reused every tick).
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// What the command carries.
    pub mode: OutputMode,
    /// Joint velocities (rad/s or m/s); zero when stale.
    pub velocities: Vec<f64>,
    /// Joint positions (rad or m): `q + v·Δt` clamped to the limits, or the hold position.
    pub positions: Vec<f64>,
    /// Position modes: where this command starts (rad or m): the previous command, or the
    /// measured state on a (re)start.
    pub start_positions: Vec<f64>,
    /// Position modes: the velocities at the start (rad/s or m/s): the previous command's,
    /// zero on a (re)start.
    pub start_velocities: Vec<f64>,
}

impl Command {
    /// The Float64MultiArray payload: velocities (velocity mode) or positions (rad/s or rad).
    pub fn data(&self) -> &[f64] {
        match self.mode {
            OutputMode::Velocity => &self.velocities,
            OutputMode::Position | OutputMode::Trajectory => &self.positions,
        }
    }

    /// As a Float64MultiArray for ForwardCommandController (allocates).
    pub fn to_float64_multi_array(&self) -> msg::Float64MultiArray {
        msg::Float64MultiArray {
            layout: msg::MultiArrayLayout::default(),
            data: self.data().to_vec(),
        }
    }

    /// As a JointTrajectory whose last point, the command, is reached after `dt` (s)
    /// (allocates). With `start_point`, a first point at `time_from_start = 0` holds where
    /// the command starts (the previous command): a JointTrajectoryController then
    /// interpolates from there, not from the measured state — its default for the start of
    /// every new trajectory (`open_loop_control = false`), which would restart a lagging
    /// robot's reference from where the robot is, 100 times a second.
    pub fn to_joint_trajectory(
        &self,
        joint_names: &[String],
        dt: f64,
        start_point: bool,
    ) -> msg::JointTrajectory {
        let point = |positions: &[f64], velocities: &[f64], t: f64| msg::JointTrajectoryPoint {
            positions: positions.to_vec(),
            velocities: velocities.to_vec(),
            accelerations: Vec::new(),
            effort: Vec::new(),
            time_from_start: msg::Duration::from_secs_f64(t),
        };
        let mut points = Vec::with_capacity(2);
        if start_point {
            points.push(point(&self.start_positions, &self.start_velocities, 0.0));
        }
        points.push(point(&self.positions, &self.velocities, dt));
        msg::JointTrajectory {
            header: msg::Header::default(),
            joint_names: joint_names.to_vec(),
            points,
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
            message: self.message.to_string(),
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
        }
    }
}

/// Bit of a recorded command's MCAP `sequence` marking the final shutdown command.
pub const SHUTDOWN_SEQUENCE_BIT: u32 = 1 << 31;

/// Latest validated inputs, handed from the DDS I/O side to the control tick.
#[derive(Debug, Clone, PartialEq)]
pub struct Inputs {
    /// Latest valid joint positions in the controlled order (rad or m).
    pub q: Vec<f64>,
    /// Receipt time of `q` (s, the clock of `now_s`); `None` before the first.
    pub state_time_s: Option<f64>,
    /// When `q` was measured (s): its header stamp when stamps are checked and it is not
    /// later than the receipt time, else the receipt time.
    pub measured_time_s: f64,
    /// Header stamp of `q` (s) when stamps are checked and it is not zero.
    pub last_stamp_s: Option<f64>,
    /// Latest valid condition (or the configured default).
    pub condition: Condition,
    /// Last rejected input, if any since start.
    pub last_error: Option<Rejection>,
    /// The latest joint_states message was rejected.
    pub joint_state_rejected: bool,
    /// The latest symmetry_condition message was rejected.
    pub condition_rejected: bool,
    /// Rejected joint_states messages since start (count).
    pub rejected_joint_states: u32,
    /// Rejected symmetry_condition messages since start (count).
    pub rejected_conditions: u32,
    /// Accepted joint_states messages since start (count).
    pub joint_state_seq: u64,
    /// Accepted symmetry_condition messages since start (count).
    pub condition_seq: u64,
}

impl Inputs {
    fn new(n: usize, condition: Condition) -> Self {
        Self {
            q: vec![0.0; n],
            state_time_s: None,
            measured_time_s: f64::NEG_INFINITY,
            last_stamp_s: None,
            condition,
            last_error: None,
            joint_state_rejected: false,
            condition_rejected: false,
            rejected_joint_states: 0,
            rejected_conditions: 0,
            joint_state_seq: 0,
            condition_seq: 0,
        }
    }

    /// The MCAP `sequence` recorded with a command computed from these inputs:
    /// `(joint_state_seq mod 2¹⁹) · 2¹² + (condition_seq mod 2¹²)`; bit 31 is left clear
    /// (it marks the shutdown command, [`SHUTDOWN_SEQUENCE_BIT`]). See `crossym_io::bag`.
    pub fn command_sequence(&self) -> u32 {
        (((self.joint_state_seq & 0x7_FFFF) << 12) | (self.condition_seq & 0xFFF)) as u32
    }

    /// Copies `src` into `self` without allocating (same joint count).
    pub fn copy_from(&mut self, src: &Inputs) {
        self.q.copy_from_slice(&src.q);
        self.state_time_s = src.state_time_s;
        self.measured_time_s = src.measured_time_s;
        self.last_stamp_s = src.last_stamp_s;
        self.condition = src.condition;
        self.last_error = src.last_error;
        self.joint_state_rejected = src.joint_state_rejected;
        self.condition_rejected = src.condition_rejected;
        self.rejected_joint_states = src.rejected_joint_states;
        self.rejected_conditions = src.rejected_conditions;
        self.joint_state_seq = src.joint_state_seq;
        self.condition_seq = src.condition_seq;
    }
}

/// Validates input messages into [`Inputs`]: joints mapped by name, conditions checked.
///
/// Runs on the I/O side of the node (or inside [`NodeCore`] single-threaded); allocation-free.
#[derive(Debug, Clone)]
pub struct InputGate {
    names: Vec<String>,
    map: Vec<usize>,
    stale_timeout_s: f64,
    check_stamps: bool,
    domain: Option<ConditionDomain>,
    feasibility: Option<Box<ConditionFeasibility>>,
    inputs: Inputs,
}

impl InputGate {
    /// A gate for the controlled `joint_names` with `cfg`'s stamp checks and default condition.
    pub fn new(joint_names: &[String], cfg: &NodeConfig) -> Self {
        let n = joint_names.len();
        Self {
            names: joint_names.to_vec(),
            map: vec![usize::MAX; n],
            stale_timeout_s: cfg.stale_timeout_s,
            check_stamps: cfg.check_stamps,
            domain: None,
            feasibility: None,
            inputs: Inputs::new(n, cfg.default_condition),
        }
    }

    /// The gate also rejects valid conditions outside `domain` (`None`: accepts them all).
    pub fn with_domain(mut self, domain: Option<ConditionDomain>) -> Self {
        self.domain = domain;
        self
    }

    /// The gate also rejects conditions a canonicalised policy cannot follow from the latest
    /// accepted joint state (`None`: no such check). Before the first joint state a valid
    /// condition is accepted; the tick then reports [`StatusCode::ConditionInfeasible`] if
    /// its flows fail.
    pub fn with_feasibility(mut self, check: Option<ConditionFeasibility>) -> Self {
        self.feasibility = check.map(Box::new);
        self
    }

    /// Whether the gate checks conditions for feasibility (a canonicalised policy).
    pub fn checks_feasibility(&self) -> bool {
        self.feasibility.is_some()
    }

    /// The condition domain this gate enforces, if any.
    pub fn domain(&self) -> Option<&ConditionDomain> {
        self.domain.as_ref()
    }

    /// [`Rejection::explain`] with this gate's joint names, plus the trained domain for an
    /// untrained condition (allocates; off the tick).
    pub fn explain(&self, r: &Rejection) -> String {
        match (r, &self.domain) {
            (Rejection::UntrainedCondition { .. }, Some(d)) => {
                format!("{} (trained on {})", r.explain(&self.names), d.describe())
            }
            _ => r.explain(&self.names),
        }
    }

    /// The validated inputs so far.
    pub fn inputs(&self) -> &Inputs {
        &self.inputs
    }

    fn reject_joint_state(&mut self, r: Rejection) -> Result<(), Rejection> {
        let i = &mut self.inputs;
        i.joint_state_rejected = true;
        i.rejected_joint_states = i.rejected_joint_states.saturating_add(1);
        i.last_error = Some(r);
        Err(r)
    }

    /// Accepts a JointState received at `now_s` (s, ROS time) or says why not; allocation-free.
    pub fn on_joint_state(&mut self, m: &msg::JointState, now_s: f64) -> Result<(), Rejection> {
        if m.name.len() != m.position.len() {
            return self.reject_joint_state(Rejection::LengthMismatch {
                names: m.name.len(),
                positions: m.position.len(),
            });
        }
        if self.check_stamps && !m.header.stamp.is_zero() {
            let age = now_s - m.header.stamp.as_secs_f64();
            if age.is_nan() || age > self.stale_timeout_s {
                return self.reject_joint_state(Rejection::StaleStamp);
            }
        }
        self.map.fill(usize::MAX);
        for (k, name) in m.name.iter().enumerate() {
            if let Some(j) = self.names.iter().position(|c| c == name) {
                if self.map[j] != usize::MAX {
                    return self.reject_joint_state(Rejection::DuplicateJoint { joint: j });
                }
                self.map[j] = k;
            }
        }
        for j in 0..self.names.len() {
            let k = self.map[j];
            if k == usize::MAX {
                return self.reject_joint_state(Rejection::MissingJoint { joint: j });
            }
            if !m.position[k].is_finite() {
                return self.reject_joint_state(Rejection::NonFinitePosition { joint: j });
            }
        }
        let i = &mut self.inputs;
        for j in 0..self.names.len() {
            i.q[j] = m.position[self.map[j]];
        }
        i.state_time_s = Some(now_s);
        let stamp = m.header.stamp.as_secs_f64();
        let stamped = self.check_stamps && !m.header.stamp.is_zero();
        // A republished message (same stamp) is the same measurement: it keeps the time of
        // its first receipt, so a driver repeating its last state cannot make it look fresh.
        let repeat = stamped && i.last_stamp_s == Some(stamp);
        i.measured_time_s = if repeat {
            i.measured_time_s.min(now_s)
        } else if stamped && stamp < now_s {
            stamp
        } else {
            now_s
        };
        i.last_stamp_s = stamped.then_some(stamp);
        i.joint_state_rejected = false;
        i.joint_state_seq = i.joint_state_seq.wrapping_add(1);
        Ok(())
    }

    /// Accepts a SymmetryCondition or says why not (the previous one stays); allocation-free.
    pub fn on_condition(&mut self, m: &msg::SymmetryCondition) -> Result<(), Rejection> {
        let s = Condition {
            theta: m.theta,
            scale: m.scale,
            reflection: m.reflection,
        };
        let r = if !m.theta.is_finite() {
            Some(Rejection::InvalidTheta)
        } else if !(m.scale.is_finite() && m.scale > 0.0) {
            Some(Rejection::InvalidScale)
        } else if !(m.reflection == 1 || m.reflection == -1) {
            Some(Rejection::InvalidReflection {
                value: m.reflection,
            })
        } else {
            let untrained = self
                .domain
                .as_ref()
                .and_then(|d| d.check(&s).err())
                .map(|part| Rejection::UntrainedCondition { part });
            match (untrained, self.feasibility.as_mut()) {
                (Some(r), _) => Some(r),
                (None, Some(f)) if self.inputs.state_time_s.is_some() => f
                    .check(&self.inputs.q, &s)
                    .err()
                    .map(|reason| Rejection::InfeasibleCondition { reason }),
                _ => None,
            }
        };
        let i = &mut self.inputs;
        if let Some(r) = r {
            i.condition_rejected = true;
            i.rejected_conditions = i.rejected_conditions.saturating_add(1);
            i.last_error = Some(r);
            return Err(r);
        }
        i.condition = s;
        i.condition_rejected = false;
        i.condition_seq = i.condition_seq.wrapping_add(1);
        Ok(())
    }
}

/// The feasibility check of a canonicalised policy (`None` for a plain one).
fn feasibility(policy: &AnyPolicy, limits: &[JointLimits]) -> Option<ConditionFeasibility> {
    match policy {
        AnyPolicy::Canonicalised(p) => {
            Some(ConditionFeasibility::new((**p).clone(), limits.to_vec()))
        }
        AnyPolicy::Plain(_) | AnyPolicy::TaskHead(_) => None,
    }
}

/// Replaces the policy's output in [`NodeCore::tick`] (fault campaigns): called with the
/// tick count, the measured `q` and the policy's velocity, which it may overwrite.
pub type PolicyOverride = Box<dyn FnMut(u64, &[f64], &mut [f64]) + Send>;

/// The node's logic: latest inputs, the control tick, the status. See the module docs.
pub struct NodeCore {
    cfg: NodeConfig,
    kin: Kinematics,
    kws: KinematicsWorkspace,
    policy: AnyPolicy,
    pws: AnyWorkspace,
    filter: SafetyFilter,
    limits: Vec<JointLimits>,
    n: usize,
    gate: InputGate,
    // End-effector distance barrier (two chains, same task dimension), if configured.
    min_ee_distance: Option<f64>,
    barrier_grad: Vec<f64>,
    v_policy: Vec<f64>,
    v_safe: Vec<f64>,
    // Last commanded position (position / trajectory modes: the anchor of the next command).
    q_hold: Vec<f64>,
    has_hold: bool,
    // The last command's velocities (the start of the next trajectory segment).
    v_last: Vec<f64>,
    // Commanded positions with their times, and the hull of those the robot may follow.
    pos_history: CommandHistory,
    pos_window: CommandWindow,
    unbounded: Vec<f64>,
    zeros: Vec<f64>,
    policy_override: Option<PolicyOverride>,
    // Position modes: times of the last `max_restarts + 1` restarts (ring), the hold after
    // the robot was found not following, and the tracking error's watch.
    restart_times: Vec<f64>,
    restart_head: usize,
    // The joint state the last tick saw (jump detection).
    prev_meas_q: Vec<f64>,
    prev_meas_time_s: f64,
    prev_meas_seq: u64,
    cmd_speed: Vec<f64>,
    halted: bool,
    halted_condition_seq: u64,
    tracking_high_since: Option<f64>,
    restarts: u64,
    not_following_ticks: u64,
    tracking_warning_ticks: u64,
    tracking_error: f64,
    // Status.
    code: StatusCode,
    ticks: u64,
    stale_ticks: u64,
    fallback_ticks: u64,
    nonfinite_ticks: u64,
    infeasible_ticks: u64,
    active: u32,
    age_s: f64,
    tick_time_us: f64,
    tick_time_max_us: f64,
}

impl NodeCore {
    /// Builds the node for `kin`'s controlled joints; the safety filter's `dt` is set to
    /// `cfg.period_s`. The policy must have `kin.dof()` joints (and, if it names them,
    /// the same names in the same order). With `safety.min_ee_distance`, the robot must
    /// have exactly two chains of the same task dimension (the two end-effectors).
    ///
    /// A policy whose sidecar records a composition is canonicalised through `kin`
    /// ([`AnyPolicy::new`]): the node then accepts any condition that is feasible from the
    /// current joint state ([`ConditionFeasibility`]) instead of a trained box. `safety`
    /// replaces `cfg.safety`.
    pub fn new(
        kin: Kinematics,
        policy: impl Into<AnyPolicy>,
        safety: SafetySettings,
        mut cfg: NodeConfig,
    ) -> Result<Self, NodeError> {
        // One source of the safety settings: the tick reads the tracking settings from
        // `cfg`, the filter is built from `safety`.
        cfg.safety = safety;
        cfg.validate()?;
        let policy = match policy.into() {
            AnyPolicy::Plain(p) if p.meta.canonicalised.is_some() || p.meta.task_head.is_some() => {
                AnyPolicy::new(*p, &kin).map_err(|message| NodeError::Policy { message })?
            }
            other => other,
        };
        let n = kin.dof();
        if policy.dim() != n {
            return Err(NodeError::Policy {
                message: format!("policy has {} joints, robot controls {n}", policy.dim()),
            });
        }
        let names = &policy.network().meta.joint_names;
        // A task head's network is named by task coordinates, checked when it was built.
        if policy.task_head().is_none()
            && !names.is_empty()
            && names.as_slice() != kin.joint_names()
        {
            return Err(NodeError::Policy {
                message: format!(
                    "policy joints {:?} differ from the robot's {:?}",
                    names,
                    kin.joint_names()
                ),
            });
        }
        if let Some(t) = policy.network().task_features() {
            t.check_kinematics(&kin)
                .map_err(|message| NodeError::Policy { message })?;
        }
        if safety.min_ee_distance.is_some() {
            let c = kin.chains();
            if c.len() != 2 || c[0].task.dim() != c[1].task.dim() {
                return Err(NodeError::Config {
                    field: "safety.min_ee_distance",
                    message: format!(
                        "needs exactly two chains of equal task dimension, robot has {}",
                        c.len()
                    ),
                });
            }
        }
        let limits = kin.limits().to_vec();
        let filter = SafetyFilter::new(
            &limits,
            SafetySettings {
                dt: cfg.period_s,
                max_state_age_s: cfg.stale_timeout_s,
                ..safety
            },
        )?;
        let fs = filter.settings();
        validate_tracking(&safety)?;
        let pos_capacity = ((cfg.stale_timeout_s
            + fs.state_delay_s
            + 2.0 * fs.latency()
            + safety.tracking_window_s)
            / cfg.period_s)
            .ceil()
            .min(1e5) as usize
            + 4;
        let kws = kin.workspace();
        let pws = policy.workspace();
        let domain = cfg
            .condition_domain(&policy)
            .map_err(|m| NodeError::Policy {
                message: format!("the sidecar's training record: {m}"),
            })?;
        if let Some(d) = &domain {
            if let Err(part) = d.check(&cfg.default_condition) {
                return Err(NodeError::Config {
                    field: "default_condition",
                    message: format!(
                        "{:?}: {part} lies outside the policy's trained conditions ({}); \
                         set accept_untrained_conditions = true to allow it",
                        cfg.default_condition,
                        d.describe()
                    ),
                });
            }
        }
        let gate = InputGate::new(kin.joint_names(), &cfg)
            .with_domain(domain)
            .with_feasibility(feasibility(&policy, &limits));
        Ok(Self {
            kws,
            pws,
            policy,
            filter,
            limits,
            n,
            gate,
            min_ee_distance: safety.min_ee_distance,
            barrier_grad: vec![0.0; n],
            v_policy: vec![0.0; n],
            v_safe: vec![0.0; n],
            q_hold: vec![0.0; n],
            has_hold: false,
            v_last: vec![0.0; n],
            pos_history: CommandHistory::new(n, pos_capacity),
            pos_window: CommandWindow::new(n),
            unbounded: vec![f64::INFINITY; n],
            zeros: vec![0.0; n],
            policy_override: None,
            restart_times: vec![f64::NEG_INFINITY; safety.max_restarts as usize + 1],
            restart_head: 0,
            prev_meas_q: vec![0.0; n],
            prev_meas_time_s: f64::NEG_INFINITY,
            prev_meas_seq: 0,
            cmd_speed: vec![0.0; n],
            halted: false,
            halted_condition_seq: 0,
            tracking_high_since: None,
            restarts: 0,
            not_following_ticks: 0,
            tracking_warning_ticks: 0,
            tracking_error: 0.0,
            code: StatusCode::StaleJointStates,
            ticks: 0,
            stale_ticks: 0,
            fallback_ticks: 0,
            nonfinite_ticks: 0,
            infeasible_ticks: 0,
            active: 0,
            age_s: -1.0,
            tick_time_us: 0.0,
            tick_time_max_us: 0.0,
            cfg,
            kin,
        })
    }

    /// Replaces (or, with `None`, restores) the policy's output each tick: adversarial
    /// policies of `crossym stress`. The safety filter still bounds every command.
    pub fn set_policy_override(&mut self, f: Option<PolicyOverride>) {
        self.policy_override = f;
    }

    /// Breaks the safety filter on purpose (tests and `crossym stress --break`).
    pub fn inject_filter_defect(&mut self, defect: crate::safety::FilterDefect) {
        self.filter.inject_defect(defect);
    }

    /// The node's settings.
    pub fn config(&self) -> &NodeConfig {
        &self.cfg
    }

    /// The robot's kinematics (controlled joints).
    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    /// Controlled joint names, the order of every command.
    pub fn joint_names(&self) -> &[String] {
        self.kin.joint_names()
    }

    /// Controlled joint limits (rad, rad/s, rad/s²).
    pub fn limits(&self) -> &[JointLimits] {
        &self.limits
    }

    /// The condition currently applied.
    pub fn condition(&self) -> Condition {
        self.gate.inputs.condition
    }

    /// The latest valid joint positions (rad) and their receipt time (s), if any.
    pub fn joint_state(&self) -> Option<(&[f64], f64)> {
        let i = &self.gate.inputs;
        i.state_time_s.map(|t| (i.q.as_slice(), t))
    }

    /// A command buffer sized for this node (allocate once).
    pub fn command(&self) -> Command {
        Command {
            mode: self.cfg.output,
            velocities: vec![0.0; self.n],
            positions: vec![0.0; self.n],
            start_positions: vec![0.0; self.n],
            start_velocities: vec![0.0; self.n],
        }
    }

    /// A separate input gate with this node's checks (offline replay feeding
    /// [`NodeCore::load_inputs`], the node's log explaining rejections).
    pub fn input_gate(&self) -> InputGate {
        InputGate::new(self.kin.joint_names(), &self.cfg)
            .with_domain(self.gate.domain)
            .with_feasibility(feasibility(&self.policy, &self.limits))
    }

    /// The policy (plain or canonicalised).
    pub fn policy(&self) -> &AnyPolicy {
        &self.policy
    }

    /// The validated inputs so far (joint state, condition, their sequence numbers).
    pub fn inputs(&self) -> &Inputs {
        &self.gate.inputs
    }

    /// Replaces the node's inputs by `src` (from another gate); allocation-free.
    pub fn load_inputs(&mut self, src: &Inputs) {
        self.gate.inputs.copy_from(src);
    }

    /// Accepts a JointState received at `now_s` (s) or says why not; allocation-free.
    pub fn on_joint_state(&mut self, m: &msg::JointState, now_s: f64) -> Result<(), Rejection> {
        self.gate.on_joint_state(m, now_s)
    }

    /// Accepts a SymmetryCondition or says why not (the previous one stays); allocation-free.
    pub fn on_condition(&mut self, m: &msg::SymmetryCondition) -> Result<(), Rejection> {
        self.gate.on_condition(m)
    }

    fn is_position(&self) -> bool {
        self.cfg.output != OutputMode::Velocity
    }

    /// Brakes toward zero velocity at the acceleration limits (no usable state) into `out`;
    /// in position modes the braking velocities move the last commanded position. False when
    /// there is nothing to command (position modes before any joint state).
    fn brake(&mut self, now_s: f64, out: &mut Command) -> bool {
        out.mode = self.cfg.output;
        if self.is_position() && !self.has_hold {
            out.velocities.fill(0.0);
            out.positions.copy_from_slice(&self.q_hold);
            return false;
        }
        out.start_positions.copy_from_slice(&self.q_hold);
        out.start_velocities.copy_from_slice(&self.v_last);
        self.filter.brake(now_s, &mut out.velocities);
        let dt = self.cfg.period_s;
        let i = &self.gate.inputs;
        for j in 0..self.n {
            let from = if self.is_position() || i.state_time_s.is_none() {
                self.q_hold[j]
            } else {
                i.q[j]
            };
            out.positions[j] = clamp_to(&self.limits[j], from + out.velocities[j] * dt);
        }
        if self.is_position() {
            self.q_hold.copy_from_slice(&out.positions);
            self.pos_history.push(now_s, &out.positions);
        }
        self.v_last.copy_from_slice(&out.velocities);
        true
    }

    /// True when the measured `q` lies within `tracking_tolerance` of the hull of the
    /// positions the robot may be following (position modes): the commands from
    /// `tracking_window_s` before the measurement until now; false after a teleport or when
    /// the robot does not follow. Also sets the tracking error (the measured state against
    /// the command in effect when it was measured).
    fn tracks_commands(&mut self) -> bool {
        let i = &self.gate.inputs;
        let fs = self.filter.settings();
        let s = i.measured_time_s - fs.state_delay_s;
        let t = i.state_time_s.unwrap_or(s);
        let window = self.cfg.safety.tracking_window_s;
        self.pos_history.window(
            s.min(t) - window,
            t,
            fs.latency(),
            &self.unbounded,
            &mut self.pos_window,
        );
        self.tracking_error = match self.pos_history.at(s) {
            Some(c) => (0..self.n).fold(0.0, |e: f64, j| e.max((i.q[j] - c[j]).abs())),
            None => 0.0,
        };
        let tol = self.cfg.safety.tracking_tolerance;
        (0..self.n).all(|j| {
            i.q[j] >= self.pos_window.past_min[j] - tol
                && i.q[j] <= self.pos_window.past_max[j] + tol
        })
    }

    /// A braking tick ([`Self::brake`]) reported as `code`.
    fn braking(&mut self, now_s: f64, out: &mut Command, code: StatusCode) -> TickReport {
        let publish = self.brake(now_s, out);
        self.code = code;
        self.active = 0;
        TickReport {
            code,
            publish,
            safety: Some(SafetyStatus::Braking),
            active_constraints: 0,
        }
    }

    /// Whether the measured state jumped since the previous joint state this tick saw. A
    /// servo that does not overshoot moves no faster than its commands did over the tracking
    /// window (its velocity is a positive average of theirs), so a joint that moved farther
    /// than 1.5 × that speed × (the time between the two measurements + one period + the
    /// latency `L`), plus
    /// half the tracking tolerance (noise, sag), was moved by something else: a reset,
    /// another controller, a glitch. Remembers the measurement for the next call.
    fn measured_jump(&mut self) -> bool {
        let i = &self.gate.inputs;
        if i.joint_state_seq == self.prev_meas_seq {
            return false;
        }
        let dt = i.measured_time_s - self.prev_meas_time_s;
        let slack = 0.5 * self.cfg.safety.tracking_tolerance;
        let since = i.measured_time_s
            - self.filter.settings().state_delay_s
            - self.filter.settings().latency()
            - self.cfg.safety.tracking_window_s
            - dt.max(0.0);
        self.pos_history.max_speed(since, &mut self.cmd_speed);
        // A robot that takes each position command at once moves a whole period's step
        // between two measurements however close they are, and commands held up by the
        // latency envelope arrive together: one period and the latency more.
        let reach = dt + self.cfg.period_s + self.filter.settings().latency();
        let jumped = self.prev_meas_seq != 0
            && dt >= 0.0
            && (0..self.n).any(|j| {
                (i.q[j] - self.prev_meas_q[j]).abs() > 1.5 * self.cmd_speed[j] * reach + slack
            });
        self.prev_meas_q.copy_from_slice(&i.q);
        self.prev_meas_time_s = i.measured_time_s;
        self.prev_meas_seq = i.joint_state_seq;
        jumped
    }

    /// Records a restart at `now_s`; true when it makes more than `max_restarts` within
    /// `restart_window_s` (the robot does not follow).
    fn count_restart(&mut self, now_s: f64) -> bool {
        self.restarts = self.restarts.saturating_add(1);
        let k = self.restart_times.len();
        self.restart_head = (self.restart_head + 1) % k;
        self.restart_times[self.restart_head] = now_s;
        // The oldest of the last `max_restarts + 1` restarts.
        let oldest = self.restart_times[(self.restart_head + 1) % k];
        now_s - oldest <= self.cfg.safety.restart_window_s
    }

    /// One control tick at time `now_s` (s) into `out`; allocation-free. See the module docs.
    pub fn tick(&mut self, now_s: f64, out: &mut Command) -> TickReport {
        self.ticks = self.ticks.saturating_add(1);
        let fresh = match self.gate.inputs.state_time_s {
            Some(t) => {
                self.age_s = now_s - t;
                // The data's own age counts too (a republished old state is not fresh).
                let data_age = now_s - self.gate.inputs.measured_time_s;
                self.age_s <= self.cfg.stale_timeout_s && data_age <= self.cfg.stale_timeout_s
            }
            None => {
                self.age_s = -1.0;
                false
            }
        };
        if !fresh {
            self.stale_ticks = self.stale_ticks.saturating_add(1);
            return self.braking(now_s, out, StatusCode::StaleJointStates);
        }
        // Position modes: a robot found not following stays held (braking, then holding the
        // last command) until a new condition is accepted.
        if self.halted {
            if self.gate.inputs.condition_seq == self.halted_condition_seq {
                self.not_following_ticks = self.not_following_ticks.saturating_add(1);
                return self.braking(now_s, out, StatusCode::RobotNotFollowing);
            }
            // A new condition: start again from the measured state, with a clean count.
            self.halted = false;
            self.has_hold = false;
            self.restart_times.fill(f64::NEG_INFINITY);
        }
        // Position modes: the next command continues the last commanded position, unless
        // there is none yet or the robot is not where the commands put it (a reset, a robot
        // that does not follow): then it starts from the measured state at rest.
        let mut restarted = false;
        let mut lagging = false;
        if self.is_position() {
            // With a lag window, a measured jump (a reset, a robot moved by something else)
            // restarts even when it lands inside the envelope of the window's commands.
            // Without one the envelope is the commands since the measurement: a jump
            // leaves it anyway.
            let jumped = self.cfg.safety.tracking_window_s > 0.0 && self.measured_jump();
            let tracks = !self.has_hold || (!jumped && self.tracks_commands());
            if !tracks && self.count_restart(now_s) {
                // Repeated restarts: the robot does not follow. Hold where the commands are.
                self.halted = true;
                self.halted_condition_seq = self.gate.inputs.condition_seq;
                self.not_following_ticks = self.not_following_ticks.saturating_add(1);
                self.tracking_high_since = None;
                return self.braking(now_s, out, StatusCode::RobotNotFollowing);
            }
            if !self.has_hold || !tracks {
                restarted = self.has_hold;
                for j in 0..self.n {
                    self.q_hold[j] = clamp_to(&self.limits[j], self.gate.inputs.q[j]);
                }
                self.filter.reset(&self.zeros);
                if self.has_hold {
                    // Commands still in flight may yet move the robot: keep them in the hull.
                    self.pos_history.push(now_s, &self.q_hold);
                } else {
                    self.pos_history.reset_to(&self.q_hold);
                }
                self.has_hold = true;
                self.tracking_high_since = None;
                self.tracking_error = 0.0;
                self.v_last.fill(0.0);
            }
            lagging = self.watch_tracking(now_s);
        }
        let inputs = &self.gate.inputs;
        let q = inputs.q.as_slice();
        // FK and Jacobian once: the safety filter reads the Jacobian, the policy's task
        // features the point `f(q)` (the same FK as the policy's stored chains, checked at
        // setup).
        self.kin.jacobian(q, &mut self.kws);
        let infeasible = self
            .policy
            .velocity_at(
                q,
                self.kws.x.as_slice(),
                &inputs.condition,
                &mut self.v_policy,
                &mut self.pws,
            )
            .is_err();
        if infeasible {
            // The accepted condition's flows fail from here: no policy velocity (the filter
            // replaces the non-finite output by 0 and brakes within the limits).
            self.v_policy.fill(f64::NAN);
            self.infeasible_ticks = self.infeasible_ticks.saturating_add(1);
        }
        if let Some(f) = self.policy_override.as_mut() {
            f(self.ticks, q, &mut self.v_policy);
        }
        let jac_ok = self.kws.jac.iter().all(|x| x.is_finite());
        let barrier = match self.min_ee_distance {
            Some(d_min) if jac_ok => {
                ee_barrier(&self.kin, &self.kws, d_min, &mut self.barrier_grad)
            }
            _ => None,
        };
        let jac = if jac_ok { Some(&self.kws.jac) } else { None };
        let position = self.cfg.output != OutputMode::Velocity;
        let anchor = if position {
            Anchor::Commanded { q: &self.q_hold }
        } else {
            Anchor::Measured {
                q,
                time_s: inputs.measured_time_s,
            }
        };
        let report = self.filter.filter(
            now_s,
            anchor,
            &self.v_policy,
            jac,
            barrier,
            &mut self.v_safe,
        );
        out.mode = self.cfg.output;
        out.start_positions.copy_from_slice(&self.q_hold);
        out.start_velocities.copy_from_slice(&self.v_last);
        let dt = self.cfg.period_s;
        let mut finite = true;
        for j in 0..self.n {
            let v = self.v_safe[j];
            let from = if position { self.q_hold[j] } else { q[j] };
            let p = clamp_to(&self.limits[j], from + v * dt);
            finite &= v.is_finite() && p.is_finite();
            out.velocities[j] = v;
            out.positions[j] = p;
        }
        if !finite {
            // Defence in depth: the filter guarantees finiteness; never emit NaN anyway.
            let publish = self.brake(now_s, out);
            self.code = StatusCode::SafetyFallback;
            self.fallback_ticks = self.fallback_ticks.saturating_add(1);
            self.active = 0;
            return TickReport {
                code: self.code,
                publish,
                safety: Some(report.status),
                active_constraints: 0,
            };
        }
        if position {
            self.q_hold.copy_from_slice(&out.positions);
            self.pos_history.push(now_s, &out.positions);
        }
        self.v_last.copy_from_slice(&out.velocities);
        self.active = report.active;
        if report.status == SafetyStatus::Fallback {
            self.fallback_ticks = self.fallback_ticks.saturating_add(1);
        }
        // The NaN of an infeasible condition is reported as such, not as a policy fault.
        if report.policy_nonfinite && !infeasible {
            self.nonfinite_ticks = self.nonfinite_ticks.saturating_add(1);
        }
        self.code = if inputs.joint_state_rejected || inputs.condition_rejected {
            StatusCode::InvalidInput
        } else if report.status == SafetyStatus::Fallback {
            StatusCode::SafetyFallback
        } else if infeasible {
            StatusCode::ConditionInfeasible
        } else if report.policy_nonfinite {
            StatusCode::PolicyNonfinite
        } else if restarted {
            StatusCode::RestartedFromMeasured
        } else if lagging {
            StatusCode::TrackingError
        } else if report.active > 0 {
            StatusCode::JointBound
        } else {
            StatusCode::NoWarning
        };
        TickReport {
            code: self.code,
            publish: true,
            safety: Some(report.status),
            active_constraints: report.active,
        }
    }

    /// The final command on shutdown (zero velocity / hold position) into `out`; false
    /// when there is nothing to hold (position mode before any joint state).
    pub fn shutdown_command(&mut self, out: &mut Command) -> bool {
        self.code = StatusCode::Shutdown;
        out.mode = self.cfg.output;
        out.velocities.fill(0.0);
        let i = &self.gate.inputs;
        if !self.is_position() {
            if i.state_time_s.is_some() {
                for j in 0..self.n {
                    out.positions[j] = clamp_to(&self.limits[j], i.q[j]);
                }
            }
            return true;
        }
        out.positions.copy_from_slice(&self.q_hold);
        self.has_hold
    }

    /// Whether the tracking error has stayed above `tracking_warning` for longer than
    /// `tracking_window_s` (at least one period) at `now_s`; counts such ticks.
    fn watch_tracking(&mut self, now_s: f64) -> bool {
        let Some(limit) = self.cfg.safety.tracking_warning else {
            return false;
        };
        if self.tracking_error <= limit {
            self.tracking_high_since = None;
            return false;
        }
        let since = *self.tracking_high_since.get_or_insert(now_s);
        let lagging = now_s - since >= self.cfg.safety.tracking_window_s.max(self.cfg.period_s);
        if lagging {
            self.tracking_warning_ticks = self.tracking_warning_ticks.saturating_add(1);
        }
        lagging
    }

    /// Records the caller-measured duration of the last tick (µs).
    pub fn record_tick_time(&mut self, us: f64) {
        if us.is_finite() {
            self.tick_time_us = us;
            self.tick_time_max_us = self.tick_time_max_us.max(us);
        }
    }

    /// Snapshot for the Status message.
    pub fn status(&self) -> StatusSnapshot {
        StatusSnapshot {
            code: self.code,
            message: self.code.message(),
            last_error: self.gate.inputs.last_error,
            active_constraints: self.active,
            rejected_joint_states: self.gate.inputs.rejected_joint_states,
            rejected_conditions: self.gate.inputs.rejected_conditions,
            ticks: self.ticks,
            stale_ticks: self.stale_ticks,
            fallback_ticks: self.fallback_ticks,
            nonfinite_ticks: self.nonfinite_ticks,
            infeasible_ticks: self.infeasible_ticks,
            joint_state_age_s: self.age_s,
            restarts: self.restarts,
            not_following_ticks: self.not_following_ticks,
            tracking_warning_ticks: self.tracking_warning_ticks,
            tracking_error: self.tracking_error,
            tick_time_us: self.tick_time_us,
            tick_time_max_us: self.tick_time_max_us,
            condition: self.gate.inputs.condition,
        }
    }
}

/// The end-effector distance barrier `h(q) = ‖p₁ − p₂‖ − d_min` and its gradient
/// `∂h/∂q = uᵀ[J₁, −J₂]`, `u = (p₁ − p₂)/‖p₁ − p₂‖`, from `ws` after [`Kinematics::jacobian`].
/// `None` when the end-effectors coincide (no direction). Allocation-free.
fn ee_barrier<'g>(
    kin: &Kinematics,
    ws: &KinematicsWorkspace,
    d_min: f64,
    grad: &'g mut [f64],
) -> Option<Barrier<'g>> {
    let d = kin.chains()[0].task.dim();
    let (x1, x2) = (kin.x_offset(0), kin.x_offset(1));
    let mut dist2 = 0.0;
    for r in 0..d {
        let e = ws.x[x1 + r] - ws.x[x2 + r];
        dist2 += e * e;
    }
    let dist = dist2.sqrt();
    if !(dist.is_finite() && dist > 1e-9) {
        return None;
    }
    for (col, g) in grad.iter_mut().enumerate() {
        let mut acc = 0.0;
        for r in 0..d {
            let u = (ws.x[x1 + r] - ws.x[x2 + r]) / dist;
            acc += u * (ws.jac[(x1 + r, col)] - ws.jac[(x2 + r, col)]);
        }
        *g = acc;
    }
    Some(Barrier {
        gradient: grad,
        value: dist - d_min,
    })
}

/// Checks the position modes' tracking settings of `safety`.
fn validate_tracking(safety: &SafetySettings) -> Result<(), NodeError> {
    let bad = |field: &'static str, message: String| NodeError::Config { field, message };
    if !(safety.tracking_tolerance.is_finite() && safety.tracking_tolerance > 0.0) {
        return Err(bad(
            "safety.tracking_tolerance",
            format!("{} must be positive", safety.tracking_tolerance),
        ));
    }
    if !(safety.tracking_window_s.is_finite() && (0.0..=10.0).contains(&safety.tracking_window_s)) {
        return Err(bad(
            "safety.tracking_window_s",
            format!("{} must lie in [0, 10] s", safety.tracking_window_s),
        ));
    }
    if let Some(w) = safety.tracking_warning {
        if !(w.is_finite() && w > 0.0) {
            return Err(bad(
                "safety.tracking_warning",
                format!("{w} must be positive"),
            ));
        }
    }
    if !(1..=64).contains(&safety.max_restarts) {
        return Err(bad(
            "safety.max_restarts",
            format!("{} must lie in 1..=64", safety.max_restarts),
        ));
    }
    if !(safety.restart_window_s.is_finite() && safety.restart_window_s > 0.0) {
        return Err(bad(
            "safety.restart_window_s",
            format!("{} must be positive", safety.restart_window_s),
        ));
    }
    Ok(())
}

/// Clamps `x` into `[lower, upper]` (infinite limits bound nothing; NaN stays NaN).
fn clamp_to(l: &JointLimits, x: f64) -> f64 {
    let mut y = x;
    if y > l.upper {
        y = l.upper;
    }
    if y < l.lower {
        y = l.lower;
    }
    y
}
