//! [`NodeCore`]: the control tick `π(q, s)` → safety filter → command, stale-input stop,
//! tracking of position commands, status; allocation-free after construction.

use crossym_io::msg;
use crossym_math::kinematics::{JointLimits, Kinematics, KinematicsWorkspace};
use crossym_math::symmetry::compose::Condition;
use crossym_policy::{AnyPolicy, AnyWorkspace};

use super::code::StatusCode;
use super::command::Command;
use super::config::validate_tracking;
use super::config::NodeConfig;
use super::config::OutputMode;
use super::counters::{bump, Counters};
use super::error::NodeError;
use super::feasibility::feasibility;
use super::fit::{checked_domain, checked_policy};
use super::gate::InputGate;
use super::gate::Inputs;
use super::link::ControllerLink;
use super::motion::{Motion, MotionSupervisor};
use super::operator::{
    OperatorEffect, OperatorRefusal, OperatorRequest, OperatorState, RuntimeBounds, RuntimeSettings,
};
use super::period::{EventTotals, StatusPeriod};
use super::rejection::Rejection;
use super::singularity::{SingularityBand, SingularityReport, SingularityStatus};
use super::stage::{OutputStage, PolicyOutput};
use super::status::StatusSnapshot;
use super::status::TickReport;
use super::timing::TickTiming;
use crate::safety::history::{CommandHistory, CommandWindow};
use crate::safety::{
    Anchor, Barrier, BoundRules, ExactBounds, SafetyFilter, SafetyReport, SafetySettings,
    SafetyStatus,
};

/// The node's logic: latest inputs, the control tick, the status. See the module docs.
///
/// A node runs `NodeCore` = `NodeCore<PolicyOutput, ExactBounds>`: the policy's velocity
/// through the exact safety filter. Fault campaigns and tests build it with other stages
/// ([`NodeCore::with_stages`]): an adversarial policy output `O`, deliberately broken bound
/// rules `R` (feature `fault-injection`).
pub struct NodeCore<O: OutputStage = PolicyOutput, R: BoundRules = ExactBounds> {
    cfg: NodeConfig,
    kin: Kinematics,
    kws: KinematicsWorkspace,
    policy: AnyPolicy,
    pws: AnyWorkspace,
    filter: SafetyFilter<R>,
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
    output: O,
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
    tracking_error: f64,
    // Position modes: held-robot and locked-joint detection, and the node's reaction.
    motion: MotionSupervisor,
    held: Held,
    locked_joint: Option<usize>,
    // Subscribers matched on the command topic (`None`: not known), whether one ever
    // matched, and whether the next fresh tick restarts from the measured state (a
    // controller switched back on).
    link: ControllerLink,
    motion_seq: u64,
    // Operator controls: the singularity band, pause, the velocity scale, what may change.
    band: SingularityBand,
    singular: SingularityReport,
    operator: OperatorState,
    // Status: the running totals, the last tick's code.
    counters: Counters,
    code: StatusCode,
    active: u32,
    age_s: f64,
    timing: TickTiming,
    period: StatusPeriod,
}

/// A held robot's handling (position modes).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Held {
    /// Not held.
    Clear,
    /// Found held: holding at the measured state until the time (s).
    Dwell(f64),
    /// Trying the policy again; reported held until a joint moves.
    Probe,
}

impl NodeCore {
    /// Builds the node for `kin`'s controlled joints; the safety filter's `dt` is set to
    /// `cfg.period_s`. The policy must have `kin.dof()` joints (and, if it names them,
    /// the same names in the same order). With `safety.min_ee_distance`, the robot must
    /// have exactly two chains of the same task dimension (the two end-effectors).
    ///
    /// A policy whose sidecar records a composition is canonicalised through `kin`
    /// ([`AnyPolicy::new`]): the node then accepts any condition that is feasible from the
    /// current joint state ([`ConditionFeasibility`](super::ConditionFeasibility)) instead of a trained box. `safety`
    /// replaces `cfg.safety`.
    pub fn new(
        kin: Kinematics,
        policy: impl Into<AnyPolicy>,
        safety: SafetySettings,
        cfg: NodeConfig,
    ) -> Result<Self, NodeError> {
        Self::with_stages(kin, policy, safety, cfg, PolicyOutput, ExactBounds)
    }
}

impl<O: OutputStage, R: BoundRules> NodeCore<O, R> {
    /// [`NodeCore::new`] with the output stage `output` between the policy and the filter,
    /// and the filter's bound rules `rules` (fault campaigns, tests).
    pub fn with_stages(
        kin: Kinematics,
        policy: impl Into<AnyPolicy>,
        safety: SafetySettings,
        mut cfg: NodeConfig,
        output: O,
        rules: R,
    ) -> Result<Self, NodeError> {
        // One source of the safety settings: the tick reads the tracking settings from
        // `cfg`, the filter is built from `safety`.
        cfg.safety = safety;
        cfg.validate()?;
        let policy = checked_policy(policy.into(), &kin, &safety)?;
        let n = kin.dof();
        let limits = kin.limits().to_vec();
        let filter = SafetyFilter::with_rules(
            &limits,
            SafetySettings {
                dt: cfg.period_s,
                max_state_age_s: cfg.stale_timeout_s,
                ..safety
            },
            rules,
        )?;
        let fs = filter.settings();
        let motion_delay = fs.latency() + fs.state_delay_s;
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
        let domain = checked_domain(&cfg, &policy)?;
        // The trained box, for `accept_untrained_conditions` switched off at runtime.
        let trained = NodeConfig {
            accept_untrained_conditions: false,
            ..cfg.clone()
        }
        .condition_domain(&policy)
        .ok()
        .flatten();
        let gate = InputGate::new(kin.joint_names(), &cfg)
            .with_domain(domain)
            .with_trained_domain(trained)
            .with_feasibility(feasibility(&policy, &limits));
        let bounds = RuntimeBounds {
            max_stale_timeout_s: cfg.stale_timeout_s,
            max_margin: limits
                .iter()
                .map(|l| 0.5 * (l.upper - l.lower))
                .filter(|h| h.is_finite())
                .fold(f64::INFINITY, f64::min),
        };
        let band = SingularityBand::new(cfg.singularity, &kin);
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
            output,
            restart_times: vec![f64::NEG_INFINITY; safety.max_restarts as usize + 1],
            restart_head: 0,
            prev_meas_q: vec![0.0; n],
            prev_meas_time_s: f64::NEG_INFINITY,
            prev_meas_seq: 0,
            cmd_speed: vec![0.0; n],
            halted: false,
            halted_condition_seq: 0,
            tracking_high_since: None,
            tracking_error: 0.0,
            motion: MotionSupervisor::new(n, cfg.motion, motion_delay),
            held: Held::Clear,
            locked_joint: None,
            link: ControllerLink::default(),
            motion_seq: 0,
            band,
            singular: SingularityReport {
                status: SingularityStatus::Clear,
                factor: 1.0,
                condition: f64::NAN,
            },
            operator: OperatorState::new(cfg.velocity_scale, bounds),
            counters: Counters::default(),
            code: StatusCode::StaleJointStates,
            active: 0,
            age_s: -1.0,
            timing: TickTiming::new(cfg.period_s),
            period: StatusPeriod::new(),
            cfg,
            kin,
        })
    }

    /// The output stage between the policy and the safety filter (tests replace an
    /// override through it).
    pub fn output_stage_mut(&mut self) -> &mut O {
        &mut self.output
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

    /// Position modes, before the policy runs: a held robot or a locked joint
    /// ([`MotionSupervisor`]), whether the robot follows the commands (the hull test, and
    /// with a lag window no jump), else a restart from the measured state at rest, counted;
    /// `Err` with the braking tick once the restarts say the robot does not follow, or when
    /// the robot was found held. `Ok((restart, lagging))`: the restart's code, if any, and
    /// whether the tracking warning holds.
    fn follow(
        &mut self,
        now_s: f64,
        out: &mut Command,
    ) -> Result<(Option<StatusCode>, bool), TickReport> {
        let motion = self.watch_motion();
        if let Motion::Held { .. } = motion {
            // Hold where the robot is (no command away from it while it cannot move), then
            // try again: a release finds the commands on the measured state.
            bump(&mut self.counters.held_events);
            self.restart_at_rest(now_s);
            self.held = Held::Dwell(now_s + self.cfg.motion.held_dwell_s);
            return Err(self.braking(now_s, out, StatusCode::RobotHeld));
        }
        let locked = if let Motion::Locked { joint } = motion {
            bump(&mut self.counters.locked_events);
            self.locked_joint = Some(joint);
            true
        } else {
            false
        };
        // With a lag window, a measured jump (a reset, a robot moved by something else)
        // restarts even when it lands inside the envelope of the window's commands.
        // Without one the envelope is the commands since the measurement: a jump
        // leaves it anyway.
        let jumped = self.cfg.safety.tracking_window_s > 0.0 && self.measured_jump();
        let tracks = !self.has_hold || (!locked && !jumped && self.tracks_commands());
        if !tracks && self.count_restart(now_s) {
            // Repeated restarts: the robot does not follow. Hold where the commands are.
            self.halted = true;
            self.halted_condition_seq = self.gate.inputs.condition_seq;
            bump(&mut self.counters.not_following_ticks);
            self.tracking_high_since = None;
            return Err(self.braking(now_s, out, StatusCode::RobotNotFollowing));
        }
        let mut restart = None;
        if !self.has_hold || !tracks {
            if self.has_hold {
                restart = Some(if locked {
                    StatusCode::JointLocked
                } else {
                    StatusCode::RestartedFromMeasured
                });
            }
            self.restart_at_rest(now_s);
        }
        let lagging = self.watch_tracking(now_s);
        Ok((restart, lagging))
    }

    /// The motion supervisor on a new joint state (position modes, while commands are
    /// continued): held, locked or nothing.
    fn watch_motion(&mut self) -> Motion {
        let i = &self.gate.inputs;
        if !self.has_hold || i.joint_state_seq == self.motion_seq {
            return Motion::Normal;
        }
        self.motion_seq = i.joint_state_seq;
        let t = i.state_time_s.unwrap_or(i.measured_time_s);
        let m = self.motion.measure(t, &i.q);
        if self.held == Held::Probe {
            if self.motion.moved() {
                self.held = Held::Clear;
            } else if let Some(joint) = (0..self.n)
                .find(|&j| (self.q_hold[j] - i.q[j]).abs() > self.cfg.safety.tracking_tolerance)
            {
                // Tried again and still held: no farther than the tracking tolerance from
                // the robot (a release then finds the command close to its state).
                return Motion::Held { joint };
            }
        }
        m
    }

    /// The commands restart from the measured state at rest (position modes).
    fn restart_at_rest(&mut self, now_s: f64) {
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
        self.motion.reset();
    }

    /// The command of the filtered velocity `v`: `v`, and `q + v·Δt` clamped into the
    /// position limits from the last commanded (position modes) or the measured `q`; false
    /// when a value is not finite.
    fn compose(&self, position: bool, out: &mut Command) -> bool {
        out.mode = self.cfg.output;
        out.start_positions.copy_from_slice(&self.q_hold);
        out.start_velocities.copy_from_slice(&self.v_last);
        let dt = self.cfg.period_s;
        let q = &self.gate.inputs.q;
        let mut finite = true;
        for j in 0..self.n {
            let v = self.v_safe[j];
            let from = if position { self.q_hold[j] } else { q[j] };
            let p = clamp_to(&self.limits[j], from + v * dt);
            finite &= v.is_finite() && p.is_finite();
            out.velocities[j] = v;
            out.positions[j] = p;
        }
        finite
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
        // After a gap longer than the history (a silent robot) the commands' speed is not
        // known: no evidence of a jump; the hull test still applies.
        let known = self.pos_history.max_speed(since, &mut self.cmd_speed);
        // A robot that takes each position command at once moves a whole period's step
        // between two measurements however close they are, and commands held up by the
        // latency envelope arrive together: one period and the latency more.
        let reach = dt + self.cfg.period_s + self.filter.settings().latency();
        let jumped = self.prev_meas_seq != 0
            && known
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
        bump(&mut self.counters.restarts);
        let k = self.restart_times.len();
        self.restart_head = (self.restart_head + 1) % k;
        self.restart_times[self.restart_head] = now_s;
        // The oldest of the last `max_restarts + 1` restarts.
        let oldest = self.restart_times[(self.restart_head + 1) % k];
        now_s - oldest <= self.cfg.safety.restart_window_s
    }

    /// One control tick at time `now_s` (s) into `out`; allocation-free. See the module docs.
    pub fn tick(&mut self, now_s: f64, out: &mut Command) -> TickReport {
        let report = self.tick_inner(now_s, out);
        if self.is_position() {
            self.motion.command(now_s, &self.v_last);
        }
        self.period.observe(report.code);
        report
    }

    fn tick_inner(&mut self, now_s: f64, out: &mut Command) -> TickReport {
        bump(&mut self.counters.ticks);
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
            bump(&mut self.counters.stale_ticks);
        }
        if self.operator.inactive {
            // Publishes the braking commands up to the first zero one (a deactivation),
            // then nothing: an inactive node commands nothing (the robot's controller
            // holds the last command).
            let moving = self.v_last.iter().any(|v| *v != 0.0);
            let mut report = self.braking(now_s, out, StatusCode::Inactive);
            report.publish &= moving;
            return report;
        }
        // The controller switched off (the command topic lost its subscribers): hold, and
        // start again from the measured state when one matches again. A driver that went
        // away altogether (its joint states stale too) is reported as stale: without a
        // measured state that is the graver fault.
        if self.link.lost() {
            let code = if fresh {
                StatusCode::NoCommandSubscriber
            } else {
                StatusCode::StaleJointStates
            };
            return self.braking(now_s, out, code);
        }
        if !fresh {
            return self.braking(now_s, out, StatusCode::StaleJointStates);
        }
        // Joint states back after a silence (a driver restarting): the hull test below
        // restarts from the measured state when the robot is not where the braking
        // commands left it (moved by hand); else the commands go on from there.
        if self.operator.paused {
            bump(&mut self.counters.paused_ticks);
            return self.braking(now_s, out, StatusCode::Paused);
        }
        // Position modes: a robot found not following stays held (braking, then holding the
        // last command) until a new condition is accepted.
        if self.halted {
            if self.gate.inputs.condition_seq == self.halted_condition_seq {
                bump(&mut self.counters.not_following_ticks);
                return self.braking(now_s, out, StatusCode::RobotNotFollowing);
            }
            // A new condition: start again from the measured state, with a clean count.
            self.halted = false;
            self.has_hold = false;
            self.restart_times.fill(f64::NEG_INFINITY);
        }
        // A held robot is held at its measured state for a while, then tried again.
        if let Held::Dwell(until) = self.held {
            if now_s < until {
                return self.braking(now_s, out, StatusCode::RobotHeld);
            }
            self.held = Held::Probe;
            self.has_hold = false;
        }
        let mut resumed = false;
        if self.link.take_resume() && self.is_position() && self.has_hold {
            self.has_hold = false;
            bump(&mut self.counters.restarts);
            resumed = true;
        }
        // Position modes: the next command continues the last commanded position, unless
        // there is none yet or the robot is not where the commands put it.
        let (mut restart, lagging) = if self.is_position() {
            match self.follow(now_s, out) {
                Ok(flags) => flags,
                Err(report) => return report,
            }
        } else {
            (None, false)
        };
        if resumed {
            restart = Some(StatusCode::RestartedFromMeasured);
        }
        let held = self.held == Held::Probe;
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
            bump(&mut self.counters.infeasible_ticks);
        }
        self.output
            .apply(self.counters.ticks, q, &mut self.v_policy);
        // The operator's scale, then the singularity band (on the scaled command: its
        // look-ahead follows the motion actually asked for).
        self.operator.scale(&mut self.v_policy);
        self.singular = if infeasible {
            SingularityReport {
                status: SingularityStatus::Clear,
                factor: 1.0,
                condition: f64::INFINITY,
            }
        } else {
            self.band.apply(
                &self.kin,
                &self.kws,
                q,
                &mut self.v_policy,
                self.cfg.period_s,
            )
        };
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
        if !self.compose(position, out) {
            // Defence in depth: the filter guarantees finiteness; never emit NaN anyway.
            let publish = self.brake(now_s, out);
            self.code = StatusCode::SafetyFallback;
            bump(&mut self.counters.fallback_ticks);
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
            bump(&mut self.counters.fallback_ticks);
        }
        // The NaN of an infeasible condition is reported as such, not as a policy fault.
        if report.policy_nonfinite && !infeasible {
            bump(&mut self.counters.nonfinite_ticks);
        }
        let rejected = inputs.joint_state_rejected || inputs.condition_rejected;
        self.code = tick_code(
            rejected,
            &report,
            infeasible,
            restart,
            held,
            lagging,
            self.singular.status,
        );
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
            bump(&mut self.counters.tracking_warning_ticks);
        }
        lagging
    }

    /// What runtime requests may ask for (fixed at start; for the callers' checks).
    pub fn runtime_bounds(&self) -> RuntimeBounds {
        self.operator.bounds
    }

    /// The runtime settings in force.
    pub fn runtime(&self) -> RuntimeSettings {
        RuntimeSettings {
            paused: self.operator.paused,
            velocity_scale: self.operator.velocity_scale,
            stale_timeout_s: self.cfg.stale_timeout_s,
            accept_untrained: self.gate.domain.is_none(),
            margin: self.filter.settings().margin,
        }
    }

    /// The singularity band's outcome at the last tick.
    pub fn singularity(&self) -> SingularityReport {
        self.singular
    }

    /// Applies an operator's request between two ticks (checked against
    /// [`Self::runtime_bounds`] again; refused: nothing changes). Allocation-free.
    ///
    /// Resume and reset start position modes again from the measured state (the commands'
    /// anchor is re-read, not continued); reset also clears the `ROBOT_NOT_FOLLOWING` latch
    /// and its restart count. `default_condition` goes through the input gate like a
    /// condition message and is in force from the next tick.
    pub fn apply(&mut self, r: OperatorRequest) -> Result<(), OperatorRefusal> {
        self.operator.bounds.check(&r)?;
        match self.operator.apply(&r) {
            OperatorEffect::Done => {}
            OperatorEffect::Restart => self.has_hold = false,
            OperatorEffect::Elsewhere => self.apply_setting(r)?,
        }
        Ok(())
    }

    /// The requests that are not the operator state's: reset, the gate's and the filter's
    /// settings, the default condition.
    fn apply_setting(&mut self, r: OperatorRequest) -> Result<(), OperatorRefusal> {
        match r {
            OperatorRequest::Reset => {
                self.held = Held::Clear;
                self.halted = false;
                self.has_hold = false;
                self.restart_times.fill(f64::NEG_INFINITY);
                self.tracking_high_since = None;
            }
            OperatorRequest::StaleTimeout(t) => {
                self.cfg.stale_timeout_s = t;
                self.gate.set_stale_timeout(t);
                self.filter
                    .set_max_state_age(t, self.operator.bounds.max_stale_timeout_s);
            }
            OperatorRequest::AcceptUntrained(a) => {
                self.cfg.accept_untrained_conditions = a;
                self.gate.set_accept_untrained(a);
            }
            OperatorRequest::Margin(m) => {
                self.cfg.safety.margin = m;
                self.filter.set_margin(m);
            }
            OperatorRequest::DefaultCondition(c) => {
                let m = msg::SymmetryCondition {
                    header: msg::Header::default(),
                    theta: c.theta,
                    scale: c.scale,
                    reflection: c.reflection,
                };
                self.gate
                    .on_condition(&m)
                    .map_err(|rejection| OperatorRefusal::Gate { rejection })?;
                self.cfg.default_condition = c;
            }
            OperatorRequest::Pause(_)
            | OperatorRequest::Activate(_)
            | OperatorRequest::VelocityScale(_) => {}
        }
        Ok(())
    }

    /// Records the caller-measured duration of the last tick (µs).
    pub fn record_tick_time(&mut self, us: f64) {
        self.timing.record_duration(us);
    }

    /// Records, before a tick, how late (s) it starts after its time and how many ticks
    /// never ran before it ([`TickTiming::record_start`]).
    pub fn record_tick_start(&mut self, late_s: f64, missed: u32) {
        self.timing.record_start(late_s, missed);
    }

    /// Snapshot for the Status message.
    pub fn status(&self) -> StatusSnapshot {
        let (period_code, period_ticks, period) =
            self.period.report(self.code, &self.event_totals());
        StatusSnapshot {
            code: self.code,
            message: self.code.message(),
            last_error: self.gate.inputs.last_error,
            active_constraints: self.active,
            rejected_joint_states: self.gate.inputs.rejected_joint_states,
            rejected_conditions: self.gate.inputs.rejected_conditions,
            ticks: self.counters.ticks,
            stale_ticks: self.counters.stale_ticks,
            fallback_ticks: self.counters.fallback_ticks,
            nonfinite_ticks: self.counters.nonfinite_ticks,
            infeasible_ticks: self.counters.infeasible_ticks,
            joint_state_age_s: self.age_s,
            restarts: self.counters.restarts,
            not_following_ticks: self.counters.not_following_ticks,
            tracking_warning_ticks: self.counters.tracking_warning_ticks,
            tracking_error: self.tracking_error,
            tick_time_us: self.timing.last_us,
            tick_time_max_us: self.timing.max_us,
            late_ticks: self.timing.late,
            missed_ticks: self.timing.missed,
            tick_late_max_us: self.timing.late_max_us,
            condition: self.gate.inputs.condition,
            paused: self.operator.paused,
            velocity_scale: self.operator.velocity_scale,
            singularity_condition: self.singular.condition,
            singularity_factor: self.singular.factor,
            period_code,
            period_ticks,
            period,
            held_events: self.counters.held_events,
            locked_events: self.counters.locked_events,
            locked_joint: self.locked_joint,
            command_subscribers: self.link.subscribers(),
        }
    }

    /// The running totals of the transient events the status counts per period.
    fn event_totals(&self) -> EventTotals {
        self.counters.event_totals(&self.gate.inputs, &self.timing)
    }

    /// Ends the status period (after its status was published): the next snapshot's
    /// worst code and counts start from here.
    pub fn end_status_period(&mut self) {
        let totals = self.event_totals();
        self.period.restart(totals, false);
    }

    /// Whether a tick since the last status had a code more severe than that status's
    /// worst: publish the status now and end the period with
    /// [`Self::end_status_period_early`] (see [`StatusPeriod::escalated`]).
    pub fn status_escalated(&self) -> bool {
        self.period.escalated()
    }

    /// Ends the status period early, after a status published at an escalation.
    pub fn end_status_period_early(&mut self) {
        let totals = self.event_totals();
        self.period.restart(totals, true);
    }

    /// The number of subscribers matched on the command topic (from the DDS graph, between
    /// ticks). Once one has matched, none means the controller was switched off: the node
    /// brakes to a hold (`NO_COMMAND_SUBSCRIBER`) and starts again from the measured state
    /// when one matches again.
    pub fn set_command_subscribers(&mut self, n: u32) {
        self.link.set(n);
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

/// The status of a tick that published a filtered command, by priority: rejected input,
/// the filter's fallback, an infeasible condition, a policy fault, a restart (or a locked
/// joint), a held robot being tried again, a tracking warning, the singularity band (halt, then deceleration), a joint on a bound.
#[allow(clippy::too_many_arguments)]
fn tick_code(
    rejected: bool,
    report: &SafetyReport,
    infeasible: bool,
    restart: Option<StatusCode>,
    held: bool,
    lagging: bool,
    singular: SingularityStatus,
) -> StatusCode {
    if rejected {
        StatusCode::InvalidInput
    } else if report.status == SafetyStatus::Fallback {
        StatusCode::SafetyFallback
    } else if infeasible {
        StatusCode::ConditionInfeasible
    } else if report.policy_nonfinite {
        StatusCode::PolicyNonfinite
    } else if let Some(code) = restart {
        code
    } else if held {
        StatusCode::RobotHeld
    } else if lagging {
        StatusCode::TrackingError
    } else if singular == SingularityStatus::Halt {
        StatusCode::HaltForSingularity
    } else if singular == SingularityStatus::Decelerate {
        StatusCode::DecelerateForSingularity
    } else if report.active > 0 {
        StatusCode::JointBound
    } else {
        StatusCode::NoWarning
    }
}

#[cfg(test)]
#[path = "core_tests.rs"]
mod tests;
