//! The node's settings (`[node]`): output mode, topics, trigger, periods, the safety
//! envelope; validated once.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crossym_math::symmetry::compose::Condition;
use crossym_policy::{AnyPolicy, ConditionDomain};

use super::error::NodeError;
use crate::safety::SafetySettings;

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
    /// `[node.task_pose]`: conditions also from an observed object pose (a perception
    /// node's `geometry_msgs/PoseStamped`); absent: from `symmetry_condition` only.
    pub task_pose: Option<super::task_pose::TaskPoseConfig>,
    /// `[node.singularity]`: the slow-down band before singular postures.
    pub singularity: super::singularity::SingularitySettings,
    /// `[node.motion]`: held-robot and locked-joint detection (position modes).
    pub motion: super::motion::MotionSettings,
    /// The policy's velocity is multiplied by this before the safety filter (0 < s ≤ 1;
    /// settable at runtime).
    pub velocity_scale: f64,
    /// The ROS 2 distribution whose graph formats the node speaks (one of
    /// [`SUPPORTED_ROS_DISTROS`]); absent: `ROS_DISTRO`, else Humble.
    pub ros_distro: Option<String>,
    /// Lifecycle: true = the node activates itself at start (the policy drives the robot on
    /// the first joint state); false = it starts *inactive* — subscribed, ticking, publishing
    /// its status but no command — until a lifecycle `activate` (`~/change_state`).
    pub autostart: bool,
}

/// `ROS_DISTRO` values the node speaks (`[node] ros_distro`).
pub const SUPPORTED_ROS_DISTROS: [&str; 3] = ["humble", "jazzy", "kilted"];

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
            task_pose: None,
            singularity: Default::default(),
            motion: Default::default(),
            velocity_scale: 1.0,
            ros_distro: None,
            autostart: true,
        }
    }
}

impl NodeConfig {
    /// The conditions the node accepts for `policy`: its trained [`ConditionDomain`], or
    /// `None` (every valid condition) with `accept_untrained_conditions` or when the policy
    /// records no training; an error names a malformed training record.
    /// A canonicalised policy has no box: it is checked for feasibility instead; nor has a
    /// task head of the whole group (reflection, rotation and scaling, or reflection and
    /// rotation at λ = 1 when the sidecar's composition has no scaling), exactly
    /// equivariant in `X` for every condition whose drawing the arms reach.
    pub fn condition_domain(&self, policy: &AnyPolicy) -> Result<Option<ConditionDomain>, String> {
        if self.accept_untrained_conditions || policy.composition().is_some() {
            return Ok(None);
        }
        if let Some(h) = policy.task_head() {
            let m = h.map();
            if m.reflection.is_some() && m.rotation.is_some() {
                if m.scaling.is_some() {
                    return Ok(None);
                }
                // A composition without a scaling (`[M, R]`, e.g. the pan): the whole group
                // is every θ and σ at λ = 1 — a scale the head cannot apply is refused, not
                // ignored.
                let order = policy.network().meta.symmetry.get("order");
                let has_s = order
                    .and_then(|o| o.as_array())
                    .is_none_or(|o| o.iter().any(|n| n.as_str() == Some("S")));
                if !has_s {
                    let corner = |theta: f64, reflection: i8| Condition {
                        theta,
                        scale: 1.0,
                        reflection,
                    };
                    let pi = std::f64::consts::PI;
                    return Ok(ConditionDomain::spanning(&[corner(pi, -1), corner(-pi, 1)]));
                }
            }
        }
        ConditionDomain::from_meta(&policy.network().meta)
    }

    /// Checks periods, timeout, names and the default condition; says what is wrong.
    pub fn validate(&self) -> Result<(), NodeError> {
        let bad = |field: &'static str, message: String| NodeError::Config { field, message };
        if let Some(d) = &self.ros_distro {
            if !SUPPORTED_ROS_DISTROS.contains(&d.as_str()) {
                return Err(bad(
                    "ros_distro",
                    format!(
                        "`{d}` is not a supported ROS 2 distribution ({})",
                        SUPPORTED_ROS_DISTROS.join(", ")
                    ),
                ));
            }
        }
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
            .map_err(|m| bad("default_condition", m.to_string()))?;
        if let Some(r) = &self.realtime {
            r.validate().map_err(|e| bad("realtime", e.to_string()))?;
        }
        self.singularity
            .validate()
            .map_err(|e| bad("singularity", e))?;
        self.motion.validate().map_err(|e| bad("motion", e))?;
        if !(self.velocity_scale > 0.0 && self.velocity_scale <= 1.0) {
            return Err(bad(
                "velocity_scale",
                format!("{} must be in (0, 1]", self.velocity_scale),
            ));
        }
        if let Some(p) = &self.task_pose {
            super::task_pose::TaskPoseMap::new(p.clone())
                .map_err(|e| bad("task_pose", e.to_string()))?;
        }
        Ok(())
    }
}

/// Checks the position modes' tracking settings of `safety`.
pub(super) fn validate_tracking(safety: &SafetySettings) -> Result<(), NodeError> {
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
