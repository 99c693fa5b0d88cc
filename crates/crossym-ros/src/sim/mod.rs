//! Mock hardware: a simulated robot that integrates joint commands and publishes
//! `/joint_states`, with configurable latency, jitter, noise, drops and faults.
//!
//! Model (per step of `Δt_sim = 1/rate_hz`): velocity mode `q ← q + Δt_sim·v_cmd`;
//! position / trajectory mode `q ← q_cmd` (ideal position servo), its velocity counted
//! as the step over the time since the previous command (at most 0.1 s: a step after a
//! longer pause is a jump). A command takes effect `latency_s + U(−jitter_s, jitter_s)` after
//! it arrives and is lost with probability `drop_probability`. The last command is held
//! forever (as ros2_control's ForwardCommandController does). Published positions carry
//! Gaussian noise `N(0, noise_std²)`. Limits are **not** enforced: every position or
//! velocity outside the URDF limits is counted and logged, so a bad controller shows.
//! Faults, from `fault_after_s` (or, with `fault_near_limit`, from the first step after it
//! at which a joint moves toward a position limit close to it) for `fault_duration_s` (or
//! to the end): `frozen` (the state stops changing but messages keep coming), `silent` (no
//! more joint states), `nan_position` (one controlled joint's published position is NaN)
//! or `missing_joint` (one controlled joint is left out of the message). During the last
//! two the robot keeps integrating commands: its sensors fail, not its motors.
//!
//! [`MockHardware`] is the simulation without DDS; [`process`] runs it as a DDS node.

pub mod endurance;
mod error;
mod fault;
pub mod physics;
pub mod process;
pub mod scenario;
pub mod stress;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

pub use self::error::MockHwError;
pub use self::fault::FaultKind;
use crossym_control::OutputMode;
use crossym_math::kinematics::{JointLimits, RobotModel};

/// `[mock_hw]`: the simulated robot's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MockHwConfig {
    /// Node name.
    pub name: String,
    /// Integration and publishing rate (Hz).
    pub rate_hz: f64,
    /// How commands are interpreted; `None` follows `[node] output`.
    pub command: Option<OutputMode>,
    /// Command topic; `None` follows `[node] topics.command`.
    pub command_topic: Option<String>,
    /// Joint-state topic.
    pub joint_states_topic: String,
    /// Reset topic (Float64MultiArray of the controlled joints' positions, rad or m).
    pub reset_topic: String,
    /// Initial positions of the controlled joints (rad or m), in the robot's order;
    /// `None` → `[check] reference_q` if present, else zeros.
    pub initial_q: Option<Vec<f64>>,
    /// Command latency (s).
    pub latency_s: f64,
    /// Uniform jitter added to the latency (± s).
    pub jitter_s: f64,
    /// Standard deviation of the position noise on published joint states (rad or m).
    pub noise_std: f64,
    /// Probability of losing a command (0–1).
    pub drop_probability: f64,
    /// Fault kind, if any.
    pub fault: Option<FaultKind>,
    /// Time after start when the fault begins (s); with `fault_near_limit`, the earliest.
    pub fault_after_s: f64,
    /// Length of the fault window (s); `None`: to the end of the run.
    pub fault_duration_s: Option<f64>,
    /// Controlled joint that `nan_position` / `missing_joint` corrupt; `None`: the first
    /// controlled joint.
    pub fault_joint: Option<String>,
    /// Distance (rad or m): the fault begins at the first step after `fault_after_s` at
    /// which a controlled joint within this distance of a position limit moves toward it
    /// at ≥ 25 % of its velocity limit; `None`: at `fault_after_s`.
    pub fault_near_limit: Option<f64>,
    /// Random seed for jitter, noise and drops.
    pub seed: u64,
    /// Tolerance for counting a limit violation (rad, rad/s).
    pub violation_tolerance: f64,
    /// After a reset, commands arriving within this time (s) are discarded: they were
    /// computed from the pre-reset state (a teleport is a simulation-only event).
    pub reset_settle_s: f64,
    /// Which robot `crossym mock-hw` simulates (`--plant` overrides it).
    pub plant: physics::Plant,
    /// The physics robot's settings (`plant = "mujoco"`).
    pub mujoco: physics::MujocoConfig,
}

impl Default for MockHwConfig {
    fn default() -> Self {
        Self {
            name: "mock_hw".into(),
            rate_hz: 200.0,
            command: None,
            command_topic: None,
            joint_states_topic: "/joint_states".into(),
            reset_topic: "/mock_hw/reset".into(),
            initial_q: None,
            latency_s: 0.0,
            jitter_s: 0.0,
            noise_std: 0.0,
            drop_probability: 0.0,
            fault: None,
            fault_after_s: 0.0,
            fault_duration_s: None,
            fault_joint: None,
            fault_near_limit: None,
            seed: 0,
            violation_tolerance: 1e-6,
            reset_settle_s: 0.05,
            plant: physics::Plant::Kinematic,
            mujoco: physics::MujocoConfig::default(),
        }
    }
}

impl MockHwConfig {
    /// Checks rates and probabilities; says what is wrong.
    pub fn validate(&self) -> Result<(), MockHwError> {
        let pos = |v: f64| v.is_finite() && v > 0.0;
        let nonneg = |v: f64| v.is_finite() && v >= 0.0;
        if !pos(self.rate_hz) {
            return Err(MockHwError::setting(format!(
                "rate_hz = {} must be positive",
                self.rate_hz
            )));
        }
        for (k, v) in [
            ("latency_s", self.latency_s),
            ("jitter_s", self.jitter_s),
            ("noise_std", self.noise_std),
            ("fault_after_s", self.fault_after_s),
            ("violation_tolerance", self.violation_tolerance),
            ("reset_settle_s", self.reset_settle_s),
        ] {
            if !nonneg(v) {
                return Err(MockHwError::setting(format!(
                    "{k} = {v} must be finite and >= 0"
                )));
            }
        }
        if let Some(v) = self.fault_duration_s {
            if !pos(v) {
                return Err(MockHwError::setting(format!(
                    "fault_duration_s = {v} must be finite and > 0"
                )));
            }
        }
        if let Some(v) = self.fault_near_limit {
            if !nonneg(v) {
                return Err(MockHwError::setting(format!(
                    "fault_near_limit = {v} must be finite and >= 0"
                )));
            }
        }
        if !(0.0..=1.0).contains(&self.drop_probability) {
            return Err(MockHwError::setting(format!(
                "drop_probability = {} must be in [0, 1]",
                self.drop_probability
            )));
        }
        if self.plant == physics::Plant::Mujoco && self.fault_near_limit.is_some() {
            return Err(MockHwError::setting(
                "fault_near_limit: the physics robot starts its faults by time only".into(),
            ));
        }
        self.mujoco
            .validate()
            .map_err(|e| MockHwError::setting(format!("mujoco: {e}")))
    }
}

/// One limit violation seen by the mock hardware.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Violation {
    /// Simulation time (s).
    pub time_s: f64,
    /// Joint name.
    pub joint: String,
    /// `position` or `velocity`.
    pub kind: String,
    /// The offending value (rad or rad/s).
    pub value: f64,
    /// The bound it crossed (rad or rad/s).
    pub bound: f64,
}

/// Counters of a mock-hardware run.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MockHwSummary {
    /// Simulation steps (count).
    pub steps: u64,
    /// Commands received (count).
    pub commands_received: u64,
    /// Commands dropped on purpose (count).
    pub commands_dropped: u64,
    /// Commands discarded inside a reset's settle window (count).
    pub commands_discarded: u64,
    /// Commands rejected (wrong length or non-finite) (count).
    pub commands_invalid: u64,
    /// Joint states published (count).
    pub joint_states_published: u64,
    /// Resets applied (count).
    pub resets: u64,
    /// Limit violations (count); the first 100 are listed.
    pub violation_count: u64,
    /// The first violations.
    pub violations: Vec<Violation>,
    /// Largest |velocity| seen per controlled joint (rad/s).
    pub max_abs_velocity: Vec<f64>,
    /// The last valid command received (velocities or positions of the controlled joints).
    pub last_command: Vec<f64>,
    /// Simulation time when the fault began (s); `None`: no fault (yet).
    #[serde(default)]
    pub fault_started_s: Option<f64>,
    /// With `fault_near_limit`: the joint whose approach to a limit started the fault.
    #[serde(default)]
    pub fault_trigger_joint: Option<String>,
    /// Joint states published while the fault was active (count).
    #[serde(default)]
    pub joint_states_faulted: u64,
    /// `crossym mock-hw`: timer periods it missed between its first and last step (a
    /// loaded machine; each is a step not taken, so its simulated clock lags the wall
    /// clock that stamps its joint states by that many periods) (count).
    #[serde(default)]
    pub missed_steps: u64,
    /// Physics robot only (`--plant mujoco`): its own tracking error per joint, the
    /// controller's reference − measured (rad); empty for the kinematic mock.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub tracking_error: BTreeMap<String, TrackingPercentiles>,
    /// Physics robot only: time each actuator spent at its force limit (s).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub torque_limit_time_s: BTreeMap<String, f64>,
    /// Physics robot only: smallest distance of each joint to a URDF position limit (rad).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub min_limit_margin: BTreeMap<String, f64>,
}

/// Median, 99th percentile and maximum of a joint's tracking error (rad).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TrackingPercentiles {
    /// Median (rad).
    pub p50: f64,
    /// 99th percentile (rad).
    pub p99: f64,
    /// Maximum (rad).
    pub max: f64,
}

impl MockHwSummary {
    /// One line on the physics robot's tracking, torque-limit time and limit margins (worst
    /// joint of each); `None` for the kinematic mock.
    pub fn plant_line(&self) -> Option<String> {
        if self.tracking_error.is_empty() {
            return None;
        }
        let worst = |f: fn(&TrackingPercentiles) -> f64| {
            self.tracking_error
                .iter()
                .map(|(j, p)| (f(p), j.as_str()))
                .fold((0.0, ""), |a, b| if b.0 > a.0 { b } else { a })
        };
        let (p50, j50) = worst(|p| p.p50);
        let (p99, j99) = worst(|p| p.p99);
        let (max, jmax) = worst(|p| p.max);
        let (torque, jt) = self
            .torque_limit_time_s
            .iter()
            .map(|(j, t)| (*t, j.as_str()))
            .fold((0.0, "-"), |a, b| if b.0 > a.0 { b } else { a });
        let (margin, jm) = self
            .min_limit_margin
            .iter()
            .map(|(j, m)| (*m, j.as_str()))
            .fold((f64::INFINITY, "-"), |a, b| if b.0 < a.0 { b } else { a });
        Some(format!(
            "Physics robot: tracking error (reference − measured, worst joint) p50 {:.1} mrad ({j50}), \
             p99 {:.1} mrad ({j99}), max {:.1} mrad ({jmax}); longest time at a torque limit {torque:.2} s \
             ({jt}); smallest distance to a URDF limit {margin:.3} rad ({jm}).",
            p50 * 1e3,
            p99 * 1e3,
            max * 1e3
        ))
    }
}

/// The simulated robot (no DDS). Positions of all movable URDF joints; the controlled ones
/// follow commands.
pub struct MockHardware {
    cfg: MockHwConfig,
    mode: OutputMode,
    /// All movable joint names (URDF order).
    pub names: Vec<String>,
    /// Index into `names` of each controlled joint.
    controlled: Vec<usize>,
    limits: Vec<JointLimits>,
    /// Index into `names` of the joint `nan_position` / `missing_joint` corrupt.
    fault_joint: usize,
    /// When the fault window began (s), once it has.
    fault_start_s: Option<f64>,
    /// Velocity of each controlled joint over the last step (rad/s or m/s).
    vel: Vec<f64>,
    q: Vec<f64>,
    cmd: Vec<f64>,
    has_cmd: bool,
    // When the command in force was applied (s): a position command's step is spread over
    // the time since the one before it when its velocity is measured.
    applied_s: f64,
    pending: Vec<(f64, Vec<f64>)>,
    rng: StdRng,
    time_s: f64,
    reset_at_s: Option<f64>,
    summary: MockHwSummary,
}

impl MockHardware {
    /// A robot with all movable joints of `model`; `controlled` are the commanded joints (in
    /// command order) starting at `initial_q`; other joints start at `held` values or 0.
    pub fn new(
        model: &RobotModel,
        controlled: &[String],
        limits: &[JointLimits],
        held: &std::collections::BTreeMap<String, f64>,
        initial_q: &[f64],
        mode: OutputMode,
        cfg: MockHwConfig,
    ) -> Result<Self, MockHwError> {
        cfg.validate()?;
        if initial_q.len() != controlled.len() || limits.len() != controlled.len() {
            return Err(MockHwError::robot(format!(
                "initial_q has {} values, limits {}, controlled joints {}",
                initial_q.len(),
                limits.len(),
                controlled.len()
            )));
        }
        let names: Vec<String> = model
            .joints
            .iter()
            .filter(|j| j.kind != crossym_math::kinematics::JointKind::Fixed)
            .map(|j| j.name.clone())
            .collect();
        let mut q: Vec<f64> = names
            .iter()
            .map(|n| held.get(n).copied().unwrap_or(0.0))
            .collect();
        let mut idx = Vec::with_capacity(controlled.len());
        for (c, &q0) in controlled.iter().zip(initial_q) {
            let i = names.iter().position(|n| n == c).ok_or_else(|| {
                MockHwError::robot(format!(
                    "controlled joint `{c}` is not a movable URDF joint"
                ))
            })?;
            if !q0.is_finite() {
                return Err(MockHwError::robot(format!(
                    "initial_q for `{c}` is not finite"
                )));
            }
            q[i] = q0;
            idx.push(i);
        }
        let fault_joint = match &cfg.fault_joint {
            Some(f) => controlled
                .iter()
                .position(|c| c == f)
                .map(|k| idx[k])
                .ok_or_else(|| {
                    MockHwError::setting(format!("fault_joint `{f}` is not a controlled joint"))
                })?,
            None => idx.first().copied().unwrap_or(0),
        };
        let n = controlled.len();
        let rng = StdRng::seed_from_u64(cfg.seed);
        Ok(Self {
            mode,
            names,
            controlled: idx,
            limits: limits.to_vec(),
            fault_joint,
            fault_start_s: None,
            vel: vec![0.0; n],
            q,
            cmd: vec![0.0; n],
            has_cmd: false,
            applied_s: f64::NEG_INFINITY,
            pending: Vec::new(),
            rng,
            time_s: 0.0,
            reset_at_s: None,
            summary: MockHwSummary {
                max_abs_velocity: vec![0.0; n],
                ..Default::default()
            },
            cfg,
        })
    }

    /// Simulation time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The run's counters so far.
    pub fn summary(&self) -> &MockHwSummary {
        &self.summary
    }

    /// True positions of all joints (rad or m), no noise.
    pub fn positions(&self) -> &[f64] {
        &self.q
    }

    /// Receives a command (velocities or positions of the controlled joints). Returns false
    /// when it is invalid (length, non-finite) and therefore ignored.
    pub fn command(&mut self, data: &[f64]) -> bool {
        self.summary.commands_received += 1;
        if data.len() != self.controlled.len() || data.iter().any(|x| !x.is_finite()) {
            self.summary.commands_invalid += 1;
            return false;
        }
        self.summary.last_command.clear();
        self.summary.last_command.extend_from_slice(data);
        if self
            .reset_at_s
            .is_some_and(|t| self.time_s - t < self.cfg.reset_settle_s)
        {
            self.summary.commands_discarded += 1;
            return true;
        }
        if self.cfg.drop_probability > 0.0 && self.rng.random::<f64>() < self.cfg.drop_probability {
            self.summary.commands_dropped += 1;
            return true;
        }
        let jitter = if self.cfg.jitter_s > 0.0 {
            self.rng
                .random_range(-self.cfg.jitter_s..=self.cfg.jitter_s)
        } else {
            0.0
        };
        let at = self.time_s + (self.cfg.latency_s + jitter).max(0.0);
        self.pending.push((at, data.to_vec()));
        true
    }

    /// Teleports the controlled joints to `q` and clears commands (simulation only).
    pub fn reset(&mut self, q: &[f64]) -> bool {
        if q.len() != self.controlled.len() || q.iter().any(|x| !x.is_finite()) {
            return false;
        }
        for (k, &i) in self.controlled.iter().enumerate() {
            self.q[i] = q[k];
        }
        self.cmd.fill(0.0);
        self.has_cmd = false;
        self.applied_s = f64::NEG_INFINITY;
        self.pending.clear();
        self.reset_at_s = Some(self.time_s);
        self.summary.resets += 1;
        true
    }

    /// When the fault window begins (s): `fault_after_s`, or with `fault_near_limit` the
    /// time it was triggered; `None` without a fault or before the trigger.
    fn fault_window_start(&self) -> Option<f64> {
        self.cfg.fault?;
        match self.cfg.fault_near_limit {
            Some(_) => self.fault_start_s,
            None => Some(self.cfg.fault_after_s),
        }
    }

    /// The fault active at the current time, if any.
    pub fn faulted(&self) -> Option<FaultKind> {
        let kind = self.cfg.fault?;
        let start = self.fault_window_start()?;
        let end = start + self.cfg.fault_duration_s.unwrap_or(f64::INFINITY);
        (self.time_s >= start && self.time_s < end).then_some(kind)
    }

    /// Starts a `fault_near_limit` fault at `now` (s) when a controlled joint moves toward a
    /// position limit within that distance of it.
    fn arm_fault(&mut self, now: f64) {
        let Some(near) = self.cfg.fault_near_limit else {
            return;
        };
        if self.cfg.fault.is_none() || self.fault_start_s.is_some() || now < self.cfg.fault_after_s
        {
            return;
        }
        for k in 0..self.controlled.len() {
            let (l, q, v) = (self.limits[k], self.q[self.controlled[k]], self.vel[k]);
            let min_speed = if l.velocity.is_finite() && l.velocity > 0.0 {
                0.25 * l.velocity
            } else {
                f64::MIN_POSITIVE
            };
            let side = if v >= min_speed && l.upper - q <= near {
                "upper"
            } else if -v >= min_speed && q - l.lower <= near {
                "lower"
            } else {
                continue;
            };
            let joint = self.names[self.controlled[k]].clone();
            eprintln!(
                "mock_hw: fault {:?} on {} from t = {now:.3} s: {joint} at {q:.6} moves toward its {side} limit at {v:.3}",
                self.cfg.fault.unwrap_or(FaultKind::Frozen),
                self.names[self.fault_joint],
            );
            self.fault_start_s = Some(now);
            self.summary.fault_trigger_joint = Some(joint);
            return;
        }
    }

    /// Advances the simulation by `dt` (s).
    pub fn step(&mut self, dt: f64) {
        self.summary.steps += 1;
        let now = self.time_s + dt;
        // Apply due commands in arrival order (the latest due one wins).
        let mut k = 0;
        // The time a position command's step spans: since the previous command was applied
        // (commands at 100 Hz stepped at 200 Hz move in one step what took a period).
        let mut span = dt;
        while k < self.pending.len() {
            if self.pending[k].0 <= now {
                let (_, c) = self.pending.remove(k);
                self.cmd = c;
                self.has_cmd = true;
                span = (now - self.applied_s).clamp(dt, 0.1);
                self.applied_s = now;
            } else {
                k += 1;
            }
        }
        self.vel.fill(0.0);
        if self.faulted() != Some(FaultKind::Frozen) && self.has_cmd {
            for k in 0..self.controlled.len() {
                let i = self.controlled[k];
                let before = self.q[i];
                let v = match self.mode {
                    OutputMode::Velocity => {
                        self.q[i] += dt * self.cmd[k];
                        self.cmd[k]
                    }
                    OutputMode::Position | OutputMode::Trajectory => {
                        self.q[i] = self.cmd[k];
                        (self.q[i] - before) / span
                    }
                };
                self.vel[k] = v;
                let m = &mut self.summary.max_abs_velocity[k];
                *m = m.max(v.abs());
                self.check(k, v);
            }
        }
        self.arm_fault(now);
        self.time_s = now;
        if self.summary.fault_started_s.is_none() && self.faulted().is_some() {
            self.summary.fault_started_s = self.fault_window_start();
        }
    }

    fn check(&mut self, k: usize, v: f64) {
        let l = self.limits[k];
        let q = self.q[self.controlled[k]];
        let tol = self.cfg.violation_tolerance;
        let mut found = Vec::new();
        if q > l.upper + tol {
            found.push(("position", q, l.upper));
        } else if q < l.lower - tol {
            found.push(("position", q, l.lower));
        }
        if v.abs() > l.velocity + tol {
            found.push(("velocity", v, l.velocity.copysign(v)));
        }
        for (kind, value, bound) in found {
            let joint = self.names[self.controlled[k]].clone();
            eprintln!(
                "mock_hw: LIMIT VIOLATION at t = {:.3} s: {joint} {kind} {value:.6} beyond {bound:.6}",
                self.time_s
            );
            self.summary.violation_count += 1;
            if self.summary.violations.len() < 100 {
                self.summary.violations.push(Violation {
                    time_s: self.time_s,
                    joint,
                    kind: kind.to_string(),
                    value,
                    bound,
                });
            }
        }
    }

    /// Positions to publish (with noise and a `nan_position` fault) into `out` (all joints,
    /// rad or m; a `missing_joint` fault is applied by [`Self::joint_state`]); false when
    /// silent.
    pub fn measured(&mut self, out: &mut Vec<f64>) -> bool {
        let fault = self.faulted();
        if fault == Some(FaultKind::Silent) {
            return false;
        }
        out.clear();
        out.extend_from_slice(&self.q);
        if self.cfg.noise_std > 0.0 {
            for x in out.iter_mut() {
                // Box–Muller.
                let u1: f64 = self.rng.random::<f64>().max(1e-300);
                let u2: f64 = self.rng.random();
                *x += self.cfg.noise_std
                    * (-2.0 * u1.ln()).sqrt()
                    * (2.0 * std::f64::consts::PI * u2).cos();
            }
        }
        if fault == Some(FaultKind::NanPosition) {
            out[self.fault_joint] = f64::NAN;
        }
        self.summary.joint_states_published += 1;
        if fault.is_some() {
            self.summary.joint_states_faulted += 1;
        }
        true
    }

    /// The joint state to publish: joint names and positions (rad or m, with noise and the
    /// active fault: a NaN, or the `fault_joint` left out); false when silent.
    pub fn joint_state(&mut self, names: &mut Vec<String>, positions: &mut Vec<f64>) -> bool {
        if !self.measured(positions) {
            return false;
        }
        names.clear();
        names.extend(self.names.iter().cloned());
        if self.faulted() == Some(FaultKind::MissingJoint) {
            names.remove(self.fault_joint);
            positions.remove(self.fault_joint);
        }
        true
    }
}
