//! Whether a condition is feasible for a canonicalised policy from the current joint state:
//! the lifted flows and the canonical configuration's limits (fixed size, no allocation).

use crossym_math::kinematics::JointLimits;
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::composed::ComposedError;
use crossym_policy::{AnyPolicy, EquivariantPolicy, EquivariantWorkspace};

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

/// The feasibility check of a canonicalised policy (`None` for a plain one).
pub(super) fn feasibility(
    policy: &AnyPolicy,
    limits: &[JointLimits],
) -> Option<ConditionFeasibility> {
    match policy {
        AnyPolicy::Canonicalised(p) => {
            Some(ConditionFeasibility::new((**p).clone(), limits.to_vec()))
        }
        AnyPolicy::Plain(_) | AnyPolicy::TaskHead(_) => None,
    }
}
