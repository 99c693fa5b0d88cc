//! A policy as loaded from a file: a plain `π(q, s)`, or a network `π₀` canonicalised by
//! the composed lifted action, `π(q, s) = dΦ_g|_{q₀} π₀(q₀)`, `q₀ = Φ_g⁻¹(q)` (issue 18,
//! [`super::EquivariantPolicy`]). The sidecar says which ([`super::PolicyMeta::canonicalised`]);
//! every consumer (evaluation, rollout, the node, replay) goes through [`AnyPolicy`].

use super::equivariant::{EquivariantPolicy, EquivariantWorkspace};
use super::mlp::{Policy, PolicyWorkspace};
use crate::kinematics::Kinematics;
use crate::symmetry::compose::Condition;
use crate::symmetry::transfer::composed::{ComposedError, ComposedLift, ComposedSpec};

/// Either kind of policy.
#[derive(Debug, Clone)]
pub enum AnyPolicy {
    /// A plain `π(q, s)`.
    Plain(Box<Policy>),
    /// A base policy canonicalised by the composed lifted action.
    Canonicalised(Box<EquivariantPolicy>),
}

/// Scratch of an [`AnyPolicy`].
#[derive(Debug, Clone)]
pub enum AnyWorkspace {
    /// Of a plain policy.
    Plain(Box<PolicyWorkspace>),
    /// Of a canonicalised one.
    Canonicalised(Box<EquivariantWorkspace>),
}

impl From<Policy> for AnyPolicy {
    /// A plain policy (a sidecar's composition is only applied by [`AnyPolicy::new`]).
    fn from(p: Policy) -> Self {
        Self::Plain(Box::new(p))
    }
}

impl From<EquivariantPolicy> for AnyPolicy {
    fn from(p: EquivariantPolicy) -> Self {
        Self::Canonicalised(Box::new(p))
    }
}

impl AnyPolicy {
    /// The policy a file holds: canonicalised through `kin` when its sidecar records a
    /// composition ([`super::PolicyMeta::canonicalised`]), plain otherwise.
    pub fn new(policy: Policy, kin: &Kinematics) -> Result<Self, String> {
        match policy.meta.canonicalised.clone() {
            None => Ok(Self::Plain(Box::new(policy))),
            Some(spec) => {
                let lift = ComposedLift::new(kin, spec)
                    .map_err(|e| format!("the sidecar's composition (`canonicalised`): {e}"))?;
                Ok(Self::Canonicalised(Box::new(EquivariantPolicy::new(
                    policy, lift,
                )?)))
            }
        }
    }

    /// The network: `π` itself, or the canonicalised policy's `π₀`.
    pub fn network(&self) -> &Policy {
        match self {
            Self::Plain(p) => p,
            Self::Canonicalised(p) => p.base(),
        }
    }

    /// The composition a canonicalised policy is evaluated through (`None`: plain).
    pub fn composition(&self) -> Option<&ComposedSpec> {
        match self {
            Self::Plain(_) => None,
            Self::Canonicalised(p) => Some(p.lift().spec()),
        }
    }

    /// Refuses a canonicalised policy whose composition is not `config`'s (a policy
    /// canonicalised for another robot, another centre of rotation, another order);
    /// a plain policy passes.
    pub fn check_composition(&self, config: &ComposedSpec) -> Result<(), String> {
        match self.composition() {
            None => Ok(()),
            Some(own) => own.same_composition(config).map_err(|e| {
                format!("the policy is canonicalised by another composition than the config's: {e}")
            }),
        }
    }

    /// Number of joints.
    pub fn dim(&self) -> usize {
        self.network().dim()
    }

    /// Scratch sized for the policy (allocates; setup only).
    pub fn workspace(&self) -> AnyWorkspace {
        match self {
            Self::Plain(p) => AnyWorkspace::Plain(Box::new(p.workspace())),
            Self::Canonicalised(p) => AnyWorkspace::Canonicalised(Box::new(p.workspace())),
        }
    }

    /// `out = π(q, s)` (rad/s or m/s); allocation-free. A canonicalised policy fails where
    /// a flow of its composition does (a singularity, an invalid condition), leaving `out`
    /// untouched; a plain one never fails.
    ///
    /// # Panics
    /// If `ws` was made by [`Self::workspace`] of the other kind of policy (a programming
    /// error, never an input).
    pub fn velocity(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut AnyWorkspace,
    ) -> Result<(), ComposedError> {
        self.velocity_impl(q, None, s, out, ws)
    }

    /// [`Self::velocity`] with the task point `x = f(q)` (m) supplied by the caller (see
    /// [`Policy::velocity_at`]); a canonicalised policy evaluates `π₀` at `q₀ ≠ q` and
    /// ignores `x`.
    pub fn velocity_at(
        &self,
        q: &[f64],
        x: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut AnyWorkspace,
    ) -> Result<(), ComposedError> {
        self.velocity_impl(q, Some(x), s, out, ws)
    }

    fn velocity_impl(
        &self,
        q: &[f64],
        x: Option<&[f64]>,
        s: &Condition,
        out: &mut [f64],
        ws: &mut AnyWorkspace,
    ) -> Result<(), ComposedError> {
        match (self, ws) {
            (Self::Plain(p), AnyWorkspace::Plain(w)) => {
                match x {
                    Some(x) => p.velocity_at(q, x, s, out, w),
                    None => p.velocity(q, s, out, w),
                }
                Ok(())
            }
            (Self::Canonicalised(p), AnyWorkspace::Canonicalised(w)) => p.velocity(q, s, out, w),
            _ => panic!("AnyPolicy: workspace of another policy kind"),
        }
    }
}
