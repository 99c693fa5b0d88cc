//! [`NodeCore`]: the control tick, a pipeline of parts — the input gate, the policy, the
//! operator's scale and the singularity band, the safety filter, the robot-follows
//! supervisor, the command — and the status; allocation-free after construction.
//!
//! The core owns the order and nothing else: what each stage decides is its part's
//! ([`InputGate`], [`OperatorState`], [`SingularityBand`], [`SafetyFilter`],
//! [`Supervisor`], [`ControllerLink`], [`Counters`], [`StatusPeriod`], [`TickTiming`]). A
//! tick first asks whether the policy may run at all (inactive, the controller lost, no
//! fresh joint state, paused: brake), then the supervisor (the not-following latch, a held
//! robot's dwell, and in position modes whether the commands go on, restart from the
//! measured state or brake), then runs the policy, scales it, filters it and composes the
//! command; the supervisor keeps the command as the next anchor. The tick's code is the
//! most important of what happened ([`tick_code`]).

use crossym_io::msg;
use crossym_math::kinematics::{JointLimits, Kinematics, KinematicsWorkspace};
use crossym_math::symmetry::compose::Condition;
use crossym_policy::{AnyPolicy, AnyWorkspace};

use super::barrier::EeBarrier;
use super::code::StatusCode;
use super::command::{clamp_to, Command};
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
use super::operator::{
    OperatorEffect, OperatorRefusal, OperatorRequest, OperatorState, RuntimeBounds, RuntimeSettings,
};
use super::period::{EventTotals, StatusPeriod};
use super::rejection::Rejection;
use super::singularity::{SingularityBand, SingularityReport, SingularityStatus};
use super::stage::{OutputStage, PolicyOutput};
use super::status::StatusSnapshot;
use super::status::TickReport;
use super::supervisor::{FollowSettings, Supervisor, Verdict};
use super::timing::TickTiming;
use crate::safety::{
    Anchor, BoundRules, ExactBounds, SafetyFilter, SafetyReport, SafetySettings, SafetyStatus,
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
    gate: InputGate,
    output: O,
    filter: SafetyFilter<R>,
    // End-effector distance barrier (two chains, same task dimension), if configured.
    barrier: EeBarrier,
    // The policy's velocity (scaled, banded), and the filter's.
    v_policy: Vec<f64>,
    v_safe: Vec<f64>,
    // Position modes: the hold, restarts, the not-following latch, held and locked.
    sup: Supervisor,
    // Pause, lifecycle, velocity scale, what requests may ask for.
    operator: OperatorState,
    // The command topic's subscribers (the controller switched off and back).
    link: ControllerLink,
    band: SingularityBand,
    // Status: the totals, the last tick's outcome, the tick's timing, the status period.
    counters: Counters,
    last: LastTick,
    timing: TickTiming,
    period: StatusPeriod,
}

/// What the status reports of the last tick.
#[derive(Debug, Clone, Copy, PartialEq)]
struct LastTick {
    code: StatusCode,
    /// Joints on a bound.
    active: u32,
    /// The joint state's age (s; −1 before any).
    age_s: f64,
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
        let filter = SafetyFilter::with_rules(
            kin.limits(),
            SafetySettings {
                dt: cfg.period_s,
                max_state_age_s: cfg.stale_timeout_s,
                ..safety
            },
            rules,
        )?;
        validate_tracking(&safety)?;
        let sup = supervisor(&cfg, filter.settings(), n);
        let gate = input_gate(&cfg, &kin, &policy)?;
        let bounds = RuntimeBounds {
            max_stale_timeout_s: cfg.stale_timeout_s,
            max_margin: kin
                .limits()
                .iter()
                .map(|l| 0.5 * (l.upper - l.lower))
                .filter(|h| h.is_finite())
                .fold(f64::INFINITY, f64::min),
        };
        Ok(Self {
            kws: kin.workspace(),
            pws: policy.workspace(),
            policy,
            gate,
            output,
            filter,
            barrier: EeBarrier::new(safety.min_ee_distance, n),
            v_policy: vec![0.0; n],
            v_safe: vec![0.0; n],
            sup,
            operator: OperatorState::new(cfg.velocity_scale, bounds),
            link: ControllerLink::default(),
            band: SingularityBand::new(cfg.singularity, &kin),
            counters: Counters::default(),
            last: LastTick {
                code: StatusCode::StaleJointStates,
                active: 0,
                age_s: -1.0,
            },
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
        self.kin.limits()
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
            velocities: vec![0.0; self.n()],
            positions: vec![0.0; self.n()],
            start_positions: vec![0.0; self.n()],
            start_velocities: vec![0.0; self.n()],
        }
    }

    /// A separate input gate with this node's checks (offline replay feeding
    /// [`NodeCore::load_inputs`], the node's log explaining rejections).
    pub fn input_gate(&self) -> InputGate {
        InputGate::new(self.kin.joint_names(), &self.cfg)
            .with_domain(self.gate.domain)
            .with_feasibility(feasibility(&self.policy, self.kin.limits()))
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

    fn n(&self) -> usize {
        self.kin.dof()
    }

    fn is_position(&self) -> bool {
        self.cfg.output != OutputMode::Velocity
    }

    /// One control tick at time `now_s` (s) into `out`; allocation-free. See the module docs.
    pub fn tick(&mut self, now_s: f64, out: &mut Command) -> TickReport {
        let report = self.tick_inner(now_s, out);
        if self.is_position() {
            self.sup.after_tick(now_s);
        }
        self.period.observe(report.code);
        report
    }

    /// The pipeline: gate → supervisor → policy → scale and band → filter → command.
    fn tick_inner(&mut self, now_s: f64, out: &mut Command) -> TickReport {
        bump(&mut self.counters.ticks);
        // Whether the policy may run at all: an inactive node, the controller lost, no
        // fresh joint state, a pause brake.
        if let Some(code) = self.stop(now_s) {
            // An inactive node publishes the braking commands up to the first zero one,
            // then nothing (the robot's controller holds the last command).
            let moving = self.sup.v_last().iter().any(|v| *v != 0.0);
            let mut report = self.braking(now_s, out, code);
            report.publish &= code != StatusCode::Inactive || moving;
            return report;
        }
        // The supervisor: the not-following latch, a held robot's dwell; in position
        // modes whether the commands go on, restart from the measured state, or brake.
        let (restart, lagging) = match self.supervise(now_s) {
            Ok(flags) => flags,
            Err(code) => return self.braking(now_s, out, code),
        };
        let held = self.sup.probing();
        // The policy, then the operator's scale and the singularity band (on the scaled
        // command: its look-ahead follows the motion actually asked for).
        let infeasible = self.run_policy();
        self.shape(infeasible);
        // The safety filter, then the command.
        let report = self.run_filter(now_s);
        if !self.compose(out) {
            // Defence in depth: the filter guarantees finiteness; never emit NaN anyway.
            let publish = self.brake(now_s, out);
            self.last.code = StatusCode::SafetyFallback;
            bump(&mut self.counters.fallback_ticks);
            self.last.active = 0;
            return TickReport {
                code: self.last.code,
                publish,
                safety: Some(report.status),
                active_constraints: 0,
            };
        }
        self.sup.commanded(now_s, self.is_position(), out);
        self.count_filtered(&report, infeasible);
        let rejected = self.gate.inputs.joint_state_rejected || self.gate.inputs.condition_rejected;
        let singular = self.band.last().status;
        self.last.code = tick_code(
            rejected, &report, infeasible, restart, held, lagging, singular,
        );
        TickReport {
            code: self.last.code,
            publish: true,
            safety: Some(report.status),
            active_constraints: report.active,
        }
    }

    /// Whether the joint state is fresh at `now_s` (its receipt and its measurement within
    /// the stale timeout: a republished old state is not fresh); sets its age.
    fn fresh(&mut self, now_s: f64) -> bool {
        let i = &self.gate.inputs;
        match i.state_time_s {
            Some(t) => {
                self.last.age_s = now_s - t;
                let data_age = now_s - i.measured_time_s;
                self.last.age_s <= self.cfg.stale_timeout_s && data_age <= self.cfg.stale_timeout_s
            }
            None => {
                self.last.age_s = -1.0;
                false
            }
        }
    }

    /// The gate's refusals to run the policy, by priority: an inactive node, the
    /// controller switched off (the command topic lost its subscribers; reported as stale
    /// when the joint states are stale too: without a measured state that is the graver
    /// fault), no fresh joint state, a pause. `None`: run it.
    fn stop(&mut self, now_s: f64) -> Option<StatusCode> {
        let fresh = self.fresh(now_s);
        if !fresh {
            bump(&mut self.counters.stale_ticks);
        }
        if self.operator.inactive {
            return Some(StatusCode::Inactive);
        }
        if self.link.lost() {
            return Some(if fresh {
                StatusCode::NoCommandSubscriber
            } else {
                StatusCode::StaleJointStates
            });
        }
        if !fresh {
            return Some(StatusCode::StaleJointStates);
        }
        if self.operator.paused {
            bump(&mut self.counters.paused_ticks);
            return Some(StatusCode::Paused);
        }
        None
    }

    /// The supervisor before the policy: `Ok((restart, lagging))` — the code of a restart
    /// from the measured state, if any, and the tracking warning — or `Err(code)`: brake.
    /// A restart at rest also restarts the filter's command history at rest.
    fn supervise(&mut self, now_s: f64) -> Result<(Option<StatusCode>, bool), StatusCode> {
        let condition_seq = self.gate.inputs.condition_seq;
        if let Some(code) = self.sup.admit(now_s, condition_seq, &mut self.counters) {
            return Err(code);
        }
        let resume = self.link.take_resume();
        if !self.is_position() {
            return Ok((None, false));
        }
        let (verdict, at_rest) = self.sup.follow(
            now_s,
            &self.gate.inputs,
            self.kin.limits(),
            resume,
            &mut self.counters,
        );
        if at_rest {
            self.filter.reset(self.sup.zeros());
        }
        match verdict {
            Verdict::Go { restart, lagging } => Ok((restart, lagging)),
            Verdict::Brake(code) => Err(code),
        }
    }

    /// FK and Jacobian once (the safety filter reads the Jacobian, the policy's task
    /// features the point `f(q)`: the same FK as the policy's stored chains, checked at
    /// setup), then `π(q, s)`; true when the accepted condition's flows fail from here (no
    /// policy velocity: NaN, which the filter replaces by 0 and brakes within the limits).
    fn run_policy(&mut self) -> bool {
        let inputs = &self.gate.inputs;
        let q = inputs.q.as_slice();
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
            self.v_policy.fill(f64::NAN);
            bump(&mut self.counters.infeasible_ticks);
        }
        infeasible
    }

    /// The output stage, the operator's scale, the singularity band.
    fn shape(&mut self, infeasible: bool) {
        let q = self.gate.inputs.q.as_slice();
        self.output
            .apply(self.counters.ticks, q, &mut self.v_policy);
        self.operator.scale(&mut self.v_policy);
        let dt = self.cfg.period_s;
        self.band
            .tick(&self.kin, &self.kws, q, &mut self.v_policy, dt, infeasible);
    }

    /// The safety filter on the shaped velocity, anchored at the last commanded position
    /// (position modes) or the measured state, with the Jacobian and the barrier when the
    /// Jacobian is finite.
    fn run_filter(&mut self, now_s: f64) -> SafetyReport {
        let position = self.is_position();
        let inputs = &self.gate.inputs;
        let jac_ok = self.kws.jac.iter().all(|x| x.is_finite());
        let barrier = self.barrier.at(&self.kin, &self.kws, jac_ok);
        let jac = if jac_ok { Some(&self.kws.jac) } else { None };
        let anchor = if position {
            Anchor::Commanded {
                q: self.sup.q_hold(),
            }
        } else {
            Anchor::Measured {
                q: inputs.q.as_slice(),
                time_s: inputs.measured_time_s,
            }
        };
        self.filter.filter(
            now_s,
            anchor,
            &self.v_policy,
            jac,
            barrier,
            &mut self.v_safe,
        )
    }

    /// The counts of a filtered command: joints on a bound, a fallback, a non-finite policy
    /// output (the NaN of an infeasible condition is reported as such, not as a fault).
    fn count_filtered(&mut self, report: &SafetyReport, infeasible: bool) {
        self.last.active = report.active;
        if report.status == SafetyStatus::Fallback {
            bump(&mut self.counters.fallback_ticks);
        }
        if report.policy_nonfinite && !infeasible {
            bump(&mut self.counters.nonfinite_ticks);
        }
    }

    /// Brakes toward zero velocity at the acceleration limits (no usable state) into `out`;
    /// in position modes the braking velocities move the last commanded position. False when
    /// there is nothing to command (position modes before any joint state).
    fn brake(&mut self, now_s: f64, out: &mut Command) -> bool {
        out.mode = self.cfg.output;
        let position = self.is_position();
        if position && !self.sup.has_hold() {
            out.velocities.fill(0.0);
            out.positions.copy_from_slice(self.sup.q_hold());
            return false;
        }
        out.start_positions.copy_from_slice(self.sup.q_hold());
        out.start_velocities.copy_from_slice(self.sup.v_last());
        self.filter.brake(now_s, &mut out.velocities);
        let dt = self.cfg.period_s;
        let i = &self.gate.inputs;
        let limits = self.kin.limits();
        for j in 0..self.kin.dof() {
            let from = if position || i.state_time_s.is_none() {
                self.sup.q_hold()[j]
            } else {
                i.q[j]
            };
            out.positions[j] = clamp_to(&limits[j], from + out.velocities[j] * dt);
        }
        self.sup.commanded(now_s, position, out);
        true
    }

    /// The command of the filtered velocity `v`: `v`, and `q + v·Δt` clamped into the
    /// position limits from the last commanded (position modes) or the measured `q`; false
    /// when a value is not finite.
    fn compose(&self, out: &mut Command) -> bool {
        let position = self.is_position();
        out.mode = self.cfg.output;
        out.start_positions.copy_from_slice(self.sup.q_hold());
        out.start_velocities.copy_from_slice(self.sup.v_last());
        let dt = self.cfg.period_s;
        let q = &self.gate.inputs.q;
        let (hold, limits) = (self.sup.q_hold(), self.kin.limits());
        let mut finite = true;
        for j in 0..self.kin.dof() {
            let v = self.v_safe[j];
            let from = if position { hold[j] } else { q[j] };
            let p = clamp_to(&limits[j], from + v * dt);
            finite &= v.is_finite() && p.is_finite();
            out.velocities[j] = v;
            out.positions[j] = p;
        }
        finite
    }

    /// A braking tick ([`Self::brake`]) reported as `code`.
    fn braking(&mut self, now_s: f64, out: &mut Command, code: StatusCode) -> TickReport {
        let publish = self.brake(now_s, out);
        self.last.code = code;
        self.last.active = 0;
        TickReport {
            code,
            publish,
            safety: Some(SafetyStatus::Braking),
            active_constraints: 0,
        }
    }

    /// The final command on shutdown (zero velocity / hold position) into `out`; false
    /// when there is nothing to hold (position mode before any joint state).
    pub fn shutdown_command(&mut self, out: &mut Command) -> bool {
        self.last.code = StatusCode::Shutdown;
        out.mode = self.cfg.output;
        out.velocities.fill(0.0);
        let i = &self.gate.inputs;
        if !self.is_position() {
            if i.state_time_s.is_some() {
                for (j, l) in self.kin.limits().iter().enumerate() {
                    out.positions[j] = clamp_to(l, i.q[j]);
                }
            }
            return true;
        }
        out.positions.copy_from_slice(self.sup.q_hold());
        self.sup.has_hold()
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
        self.band.last()
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
            OperatorEffect::Restart => self.sup.drop_hold(),
            OperatorEffect::Elsewhere => self.apply_setting(r)?,
        }
        Ok(())
    }

    /// The requests that are not the operator state's: reset, the gate's and the filter's
    /// settings, the default condition.
    fn apply_setting(&mut self, r: OperatorRequest) -> Result<(), OperatorRefusal> {
        match r {
            OperatorRequest::Reset => self.sup.reset(),
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
            self.period.report(self.last.code, &self.event_totals());
        let (c, i, t) = (&self.counters, &self.gate.inputs, &self.timing);
        let singular = self.band.last();
        StatusSnapshot {
            code: self.last.code,
            message: self.last.code.message(),
            last_error: i.last_error,
            active_constraints: self.last.active,
            rejected_joint_states: i.rejected_joint_states,
            rejected_conditions: i.rejected_conditions,
            ticks: c.ticks,
            stale_ticks: c.stale_ticks,
            fallback_ticks: c.fallback_ticks,
            nonfinite_ticks: c.nonfinite_ticks,
            infeasible_ticks: c.infeasible_ticks,
            joint_state_age_s: self.last.age_s,
            restarts: c.restarts,
            not_following_ticks: c.not_following_ticks,
            tracking_warning_ticks: c.tracking_warning_ticks,
            tracking_error: self.sup.tracking_error(),
            tick_time_us: t.last_us,
            tick_time_max_us: t.max_us,
            late_ticks: t.late,
            missed_ticks: t.missed,
            tick_late_max_us: t.late_max_us,
            condition: i.condition,
            paused: self.operator.paused,
            velocity_scale: self.operator.velocity_scale,
            singularity_condition: singular.condition,
            singularity_factor: singular.factor,
            period_code,
            period_ticks,
            period,
            held_events: c.held_events,
            locked_events: c.locked_events,
            locked_joint: self.sup.locked_joint(),
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

/// The robot-follows supervisor for `cfg`, with the filter's delays `fs`: its history
/// spans the stale timeout, the state delay, the latency twice and the tracking window.
fn supervisor(cfg: &NodeConfig, fs: &SafetySettings, n: usize) -> Supervisor {
    let safety = &cfg.safety;
    let capacity =
        ((cfg.stale_timeout_s + fs.state_delay_s + 2.0 * fs.latency() + safety.tracking_window_s)
            / cfg.period_s)
            .ceil()
            .min(1e5) as usize
            + 4;
    let s = FollowSettings {
        tolerance: safety.tracking_tolerance,
        window_s: safety.tracking_window_s,
        warning: safety.tracking_warning,
        max_restarts: safety.max_restarts,
        restart_window_s: safety.restart_window_s,
        held_dwell_s: cfg.motion.held_dwell_s,
        period_s: cfg.period_s,
        state_delay_s: fs.state_delay_s,
        latency_s: fs.latency(),
    };
    Supervisor::new(n, s, cfg.motion, capacity)
}

/// The node's input gate: the configured condition domain, the trained box (for
/// `accept_untrained_conditions` switched off at runtime), the feasibility of a
/// canonicalised policy.
fn input_gate(
    cfg: &NodeConfig,
    kin: &Kinematics,
    policy: &AnyPolicy,
) -> Result<InputGate, NodeError> {
    let domain = checked_domain(cfg, policy)?;
    let trained = NodeConfig {
        accept_untrained_conditions: false,
        ..cfg.clone()
    }
    .condition_domain(policy)
    .ok()
    .flatten();
    Ok(InputGate::new(kin.joint_names(), cfg)
        .with_domain(domain)
        .with_trained_domain(trained)
        .with_feasibility(feasibility(policy, kin.limits())))
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
