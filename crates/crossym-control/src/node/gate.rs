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
    pub(crate) fn new(n: usize, condition: Condition) -> Self {
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

#[cfg(test)]
mod tests {
    //! The gate's refusals, each checked against a message built to break exactly one rule
    //! (the expected verdict is written here from the rules in the module docs of
    //! `crate::node`, not asked of the gate's helpers): a refused message changes nothing
    //! but the rejection record, an accepted one is mapped by name.

    use std::f64::consts::PI;

    use crossym_io::msg::{Header, JointState, SymmetryCondition, Time};
    use crossym_policy::DomainViolation;
    use proptest::prelude::*;
    use proptest::test_runner::{Config as ProptestConfig, RngSeed};

    use super::*;

    /// Fixed seed, fixed case count, no persistence files in the tree.
    fn config(cases: u32) -> ProptestConfig {
        ProptestConfig {
            cases,
            failure_persistence: None,
            rng_seed: RngSeed::Fixed(54),
            ..ProptestConfig::default()
        }
    }

    const TIMEOUT_S: f64 = 0.1;

    fn controlled(n: usize) -> Vec<String> {
        (0..n).map(|j| format!("arm_{j}")).collect()
    }

    fn gate(n: usize) -> InputGate {
        let cfg = NodeConfig {
            stale_timeout_s: TIMEOUT_S,
            check_stamps: true,
            ..NodeConfig::default()
        };
        InputGate::new(&controlled(n), &cfg)
    }

    /// A joint state: `(name, position)` pairs in message order, stamped `stamp_s` (0: none).
    fn joint_state(pairs: &[(String, f64)], stamp_s: f64) -> JointState {
        JointState {
            header: Header {
                stamp: Time::from_secs_f64(stamp_s),
                frame_id: String::new(),
            },
            name: pairs.iter().map(|(n, _)| n.clone()).collect(),
            position: pairs.iter().map(|(_, p)| *p).collect(),
            ..Default::default()
        }
    }

    /// What a refusal may change: the flag, the count and the last error.
    fn after_refusal(before: &Inputs, r: Rejection, joint_state: bool) -> Inputs {
        let mut i = before.clone();
        i.last_error = Some(r);
        if joint_state {
            i.joint_state_rejected = true;
            i.rejected_joint_states += 1;
        } else {
            i.condition_rejected = true;
            i.rejected_conditions += 1;
        }
        i
    }

    /// A valid message for `n` controlled joints: the controlled joints in the order
    /// `order`, other joints (torso, wheels; any value, even NaN) mixed in.
    fn valid_state(n: usize) -> impl Strategy<Value = (Vec<(String, f64)>, Vec<f64>)> {
        (
            prop::collection::vec(-3.0..3.0f64, n),
            Just((0..n).collect::<Vec<usize>>()).prop_shuffle(),
            prop::collection::vec(
                prop_oneof![Just(f64::NAN), Just(f64::INFINITY), -9.0..9.0f64],
                0..4,
            ),
        )
            .prop_map(|(q, order, extras)| {
                let mut pairs: Vec<(String, f64)> =
                    order.iter().map(|&j| (format!("arm_{j}"), q[j])).collect();
                for (k, x) in extras.into_iter().enumerate() {
                    pairs.insert(k * 2 % (pairs.len() + 1), (format!("torso_{k}"), x));
                }
                (pairs, q)
            })
    }

    /// One broken rule of a joint state.
    #[derive(Debug, Clone)]
    enum Break {
        /// The controlled joint at this index is not finite.
        NonFinite(usize, f64),
        /// The controlled joint at this index is not in the message.
        Missing(usize),
        /// The controlled joint at this index appears a second time.
        Duplicate(usize),
        /// One position more or fewer than names.
        Length(bool),
        /// Stamped this long (s) beyond the stale timeout.
        Stale(f64),
    }

    fn breaks(n: usize) -> impl Strategy<Value = Break> {
        prop_oneof![
            (
                0..n,
                prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)]
            )
                .prop_map(|(j, x)| Break::NonFinite(j, x)),
            (0..n).prop_map(Break::Missing),
            (0..n).prop_map(Break::Duplicate),
            any::<bool>().prop_map(Break::Length),
            (1e-3..1e3f64).prop_map(Break::Stale),
        ]
    }

    proptest! {
        #![proptest_config(config(128))]

        /// Controlled joints are taken by name, whatever their order and the other joints
        /// around them; the measurement time is the stamp when older than the receipt.
        #[test]
        fn a_valid_joint_state_is_mapped_by_name(
            (pairs, q) in (1usize..8).prop_flat_map(valid_state),
            now in 10.0..1e4f64,
            age in prop_oneof![Just(None), (0.0..TIMEOUT_S).prop_map(Some)],
        ) {
            let mut g = gate(q.len());
            let m = joint_state(&pairs, age.map_or(0.0, |a| now - a));
            prop_assert_eq!(g.on_joint_state(&m, now), Ok(()));
            let i = g.inputs();
            prop_assert_eq!(&i.q, &q);
            prop_assert_eq!(i.state_time_s, Some(now));
            prop_assert_eq!(i.joint_state_seq, 1);
            prop_assert!(!i.joint_state_rejected && i.last_error.is_none());
            let stamp = m.header.stamp.as_secs_f64();
            let measured = if age.is_some() && stamp < now { stamp } else { now };
            prop_assert_eq!(i.measured_time_s, measured);
        }

        /// A joint state that breaks one rule is refused for that rule and leaves the
        /// inputs as they were (the last valid state stays in force).
        #[test]
        fn a_broken_joint_state_is_refused_and_changes_nothing(
            (n, first, (pairs, _), broken) in (1usize..8).prop_flat_map(|n| {
                (Just(n), valid_state(n), valid_state(n), breaks(n))
            }),
            now in 10.0..1e4f64,
        ) {
            let mut g = gate(n);
            prop_assert_eq!(g.on_joint_state(&joint_state(&first.0, now - 0.01), now), Ok(()));
            let before = g.inputs().clone();
            let name = |j: usize| format!("arm_{j}");
            let mut pairs = pairs;
            let mut stamp = now - 0.5 * TIMEOUT_S;
            match broken {
                Break::NonFinite(j, x) => {
                    pairs.iter_mut().find(|(n, _)| *n == name(j)).unwrap().1 = x;
                }
                Break::Missing(j) => pairs.retain(|(n, _)| *n != name(j)),
                Break::Duplicate(j) => pairs.push((name(j), 0.5)),
                Break::Stale(beyond) => stamp = now - TIMEOUT_S - beyond,
                Break::Length(_) => {}
            }
            let mut m = joint_state(&pairs, stamp);
            let expected = match broken {
                Break::NonFinite(j, _) => Rejection::NonFinitePosition { joint: j },
                Break::Missing(j) => Rejection::MissingJoint { joint: j },
                Break::Duplicate(j) => Rejection::DuplicateJoint { joint: j },
                Break::Stale(_) => Rejection::StaleStamp,
                Break::Length(more) => {
                    if more { m.position.push(0.0) } else { m.position.pop(); }
                    Rejection::LengthMismatch { names: m.name.len(), positions: m.position.len() }
                }
            };
            prop_assert_eq!(g.on_joint_state(&m, now), Err(expected));
            prop_assert_eq!(g.inputs(), &after_refusal(&before, expected, true));
        }

        /// A condition is accepted exactly when `θ` is finite, `λ` finite and positive,
        /// `σ = ±1` and, with a trained domain, inside it; a refused one leaves the
        /// previous condition in force.
        #[test]
        fn conditions_are_refused_for_the_first_rule_they_break(
            theta in prop_oneof![
                3 => -PI..PI,
                1 => prop_oneof![Just(f64::NAN), Just(f64::INFINITY), Just(f64::NEG_INFINITY)],
            ],
            scale in prop_oneof![
                3 => 0.05..3.0f64,
                1 => prop_oneof![
                    Just(0.0), Just(-1.0), Just(f64::NAN), Just(f64::INFINITY), -3.0..0.0f64
                ],
            ],
            reflection in prop_oneof![3 => prop_oneof![Just(1i8), Just(-1)], 1 => any::<i8>()],
            domain in prop_oneof![
                Just(None),
                (0.1..3.0f64, 0.2..1.0f64, 1.0..2.0f64, any::<bool>()).prop_map(
                    |(t, lo, hi, r)| Some(ConditionDomain {
                        max_abs_theta: t,
                        scale_min: lo,
                        scale_max: hi,
                        reflection: r,
                    })
                ),
            ],
        ) {
            let mut g = gate(2).with_domain(domain);
            let m = SymmetryCondition { theta, scale, reflection, ..Default::default() };
            let expected = if !theta.is_finite() {
                Some(Rejection::InvalidTheta)
            } else if !(scale.is_finite() && scale > 0.0) {
                Some(Rejection::InvalidScale)
            } else if reflection != 1 && reflection != -1 {
                Some(Rejection::InvalidReflection { value: reflection })
            } else {
                domain.and_then(|d| {
                    let part = if theta.abs() > d.max_abs_theta {
                        DomainViolation::Theta
                    } else if scale < d.scale_min || scale > d.scale_max {
                        DomainViolation::Scale
                    } else if reflection == -1 && !d.reflection {
                        DomainViolation::Reflection
                    } else {
                        return None;
                    };
                    Some(Rejection::UntrainedCondition { part })
                })
            };
            let before = g.inputs().clone();
            match expected {
                Some(r) => {
                    prop_assert_eq!(g.on_condition(&m), Err(r));
                    prop_assert_eq!(g.inputs(), &after_refusal(&before, r, false));
                }
                None => {
                    prop_assert_eq!(g.on_condition(&m), Ok(()));
                    let c = g.inputs().condition;
                    prop_assert_eq!((c.theta, c.scale, c.reflection), (theta, scale, reflection));
                    prop_assert_eq!(g.inputs().condition_seq, 1);
                }
            }
        }
    }

    #[test]
    fn stamps_are_checked_only_when_asked_and_present() {
        let names = controlled(2);
        let pairs = [(names[0].clone(), 0.1), (names[1].clone(), 0.2)];
        let now = 100.0;
        // Stale by a second: refused with checks on, accepted with checks off.
        let old = joint_state(&pairs, now - 1.0);
        assert_eq!(
            gate(2).on_joint_state(&old, now),
            Err(Rejection::StaleStamp)
        );
        let cfg = NodeConfig {
            check_stamps: false,
            ..NodeConfig::default()
        };
        let mut unchecked = InputGate::new(&names, &cfg);
        assert_eq!(unchecked.on_joint_state(&old, now), Ok(()));
        assert_eq!(unchecked.inputs().measured_time_s, now, "receipt time");
        // No stamp (zero): accepted, measured at receipt.
        let mut g = gate(2);
        assert_eq!(g.on_joint_state(&joint_state(&pairs, 0.0), now), Ok(()));
        assert_eq!(g.inputs().measured_time_s, now);
        // A clock that is not a number makes every stamp's age unknown: refused.
        let fresh = joint_state(&pairs, now);
        assert_eq!(
            g.on_joint_state(&fresh, f64::NAN),
            Err(Rejection::StaleStamp)
        );
        // A stamp from the future is measured at receipt, never later.
        let ahead = joint_state(&pairs, now + 5.0);
        assert_eq!(g.on_joint_state(&ahead, now), Ok(()));
        assert_eq!(g.inputs().measured_time_s, now);
        // A longer stale timeout (runtime parameter) lets the old state through.
        g.set_stale_timeout(2.0);
        assert_eq!(g.on_joint_state(&old, now), Ok(()));
        assert_eq!(g.inputs().measured_time_s, old.header.stamp.as_secs_f64());
    }

    #[test]
    fn a_republished_state_keeps_the_time_of_its_first_receipt() {
        let names = controlled(1);
        let m = joint_state(&[(names[0].clone(), 0.3)], 99.99);
        let mut g = gate(1);
        assert_eq!(g.on_joint_state(&m, 100.0), Ok(()));
        let first = g.inputs().measured_time_s;
        assert_eq!(first, m.header.stamp.as_secs_f64());
        // The same stamp again, 50 ms later: the same measurement, not a fresh one.
        assert_eq!(g.on_joint_state(&m, 100.05), Ok(()));
        assert_eq!(g.inputs().measured_time_s, first);
        assert_eq!(g.inputs().state_time_s, Some(100.05));
        // Past the timeout since its stamp it is stale, however often it is repeated.
        assert_eq!(g.on_joint_state(&m, 100.2), Err(Rejection::StaleStamp));
    }

    #[test]
    fn untrained_conditions_follow_the_runtime_parameter() {
        let trained = ConditionDomain {
            max_abs_theta: 0.5,
            scale_min: 0.8,
            scale_max: 1.2,
            reflection: false,
        };
        let mut g = gate(1)
            .with_trained_domain(Some(trained))
            .with_domain(Some(trained));
        let wide = SymmetryCondition {
            theta: 1.0,
            scale: 1.0,
            reflection: 1,
            ..Default::default()
        };
        let part = DomainViolation::Theta;
        assert_eq!(
            g.on_condition(&wide),
            Err(Rejection::UntrainedCondition { part })
        );
        assert_eq!(g.inputs().condition, Condition::IDENTITY);
        g.set_accept_untrained(true);
        assert_eq!(g.on_condition(&wide), Ok(()));
        g.set_accept_untrained(false);
        let mirrored = SymmetryCondition {
            reflection: -1,
            ..wide
        };
        let part = DomainViolation::Reflection;
        assert_eq!(
            g.on_condition(&SymmetryCondition {
                theta: 0.1,
                ..mirrored
            }),
            Err(Rejection::UntrainedCondition { part })
        );
        // The refused condition left the accepted one in force.
        assert_eq!(g.inputs().condition.theta, 1.0);
        assert_eq!(g.inputs().rejected_conditions, 2);
    }
}
