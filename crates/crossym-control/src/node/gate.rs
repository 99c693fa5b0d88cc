//! The input gate: joint states and conditions validated on arrival into the latest-value
//! [`Inputs`] the tick reads, and the sequence numbers bag replay matches.

use crossym_io::msg;
use crossym_math::symmetry::compose::Condition;
use crossym_policy::ConditionDomain;

use super::config::NodeConfig;
use super::feasibility::ConditionFeasibility;
use super::rejection::Rejection;

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
/// Runs on the I/O side of the node (or inside [`NodeCore`](super::NodeCore) single-threaded); allocation-free.
#[derive(Debug, Clone)]
pub struct InputGate {
    names: Vec<String>,
    map: Vec<usize>,
    stale_timeout_s: f64,
    check_stamps: bool,
    pub(super) domain: Option<ConditionDomain>,
    /// The policy's trained box, enforced unless untrained conditions are accepted.
    trained: Option<ConditionDomain>,
    feasibility: Option<Box<ConditionFeasibility>>,
    pub(super) inputs: Inputs,
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
            trained: None,
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
    /// condition is accepted; the tick then reports [`StatusCode::ConditionInfeasible`](super::StatusCode::ConditionInfeasible) if
    /// its flows fail.
    pub fn with_feasibility(mut self, check: Option<ConditionFeasibility>) -> Self {
        self.feasibility = check.map(Box::new);
        self
    }

    /// Whether the gate checks conditions for feasibility (a canonicalised policy).
    pub fn checks_feasibility(&self) -> bool {
        self.feasibility.is_some()
    }

    /// The policy's trained box (enforced after `set_accept_untrained(false)`).
    pub fn with_trained_domain(mut self, trained: Option<ConditionDomain>) -> Self {
        self.trained = trained;
        self
    }

    /// Accepts conditions outside the trained box (`true`) or enforces it again (runtime
    /// parameter `accept_untrained_conditions`); allocation-free.
    pub fn set_accept_untrained(&mut self, accept: bool) {
        self.domain = if accept { None } else { self.trained };
    }

    /// Sets the stale timeout used by the stamp checks (runtime parameter).
    pub fn set_stale_timeout(&mut self, s: f64) {
        self.stale_timeout_s = s;
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
