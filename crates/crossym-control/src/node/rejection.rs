//! Why an input message was rejected (fixed size; the node's state is left untouched).

use crossym_policy::DomainViolation;

use super::feasibility::Infeasibility;

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
    /// The condition is valid but outside the policy's trained [`ConditionDomain`](crossym_policy::ConditionDomain).
    UntrainedCondition {
        /// The part that lies outside.
        part: DomainViolation,
    },
    /// The condition is valid, but a canonicalised policy cannot follow it from the current
    /// joint state (see [`ConditionFeasibility`](super::ConditionFeasibility)).
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
