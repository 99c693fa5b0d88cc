//! A policy as loaded from a file: a plain `π(q, s)`, or a network `π₀` canonicalised by
//! the composed lifted action, `π(q, s) = dΦ_g|_{q₀} π₀(q₀)`, `q₀ = Φ_g⁻¹(q)` (issue 18,
//! [`super::EquivariantPolicy`]). The sidecar says which ([`super::PolicyMeta::canonicalised`]);
//! or a task-space head lifted to `Q`, `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))` (issue 17,
//! [`super::TaskHeadPolicy`], [`super::PolicyMeta::task_head`]); every consumer
//! (evaluation, rollout, the node, replay) goes through [`AnyPolicy`].

use super::equivariant::{EquivariantPolicy, EquivariantWorkspace};
use super::error::PolicyFitError;
use super::mlp::{Policy, PolicyWorkspace};
use super::task_head::{TaskHeadPolicy, TaskHeadWorkspace};
use crossym_math::kinematics::Kinematics;
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::composed::{ComposedError, ComposedLift, ComposedSpec};

/// Either kind of policy.
#[derive(Debug, Clone)]
pub enum AnyPolicy {
    /// A plain `π(q, s)`.
    Plain(Box<Policy>),
    /// A base policy canonicalised by the composed lifted action.
    Canonicalised(Box<EquivariantPolicy>),
    /// A task-space head canonicalised in `X` and lifted to `Q`.
    TaskHead(Box<TaskHeadPolicy>),
}

/// Scratch of an [`AnyPolicy`].
#[derive(Debug, Clone)]
pub enum AnyWorkspace {
    /// Of a plain policy.
    Plain(Box<PolicyWorkspace>),
    /// Of a canonicalised one.
    Canonicalised(Box<EquivariantWorkspace>),
    /// Of a task head.
    TaskHead(Box<TaskHeadWorkspace>),
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

impl From<TaskHeadPolicy> for AnyPolicy {
    fn from(p: TaskHeadPolicy) -> Self {
        Self::TaskHead(Box::new(p))
    }
}

impl AnyPolicy {
    /// The policy a file holds: a task head lifted through `kin` when its sidecar records
    /// a task-space map ([`super::PolicyMeta::task_head`]), canonicalised through `kin`
    /// when it records a composition ([`super::PolicyMeta::canonicalised`]), plain
    /// otherwise.
    pub fn new(policy: Policy, kin: &Kinematics) -> Result<Self, PolicyFitError> {
        Self::new_inner(policy, kin).map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::new`], failing with a message.
    fn new_inner(policy: Policy, kin: &Kinematics) -> Result<Self, String> {
        if let Some(map) = policy.meta.task_head.clone() {
            if policy.meta.canonicalised.is_some() {
                return Err("a policy file cannot be both a task head and canonicalised".into());
            }
            return Ok(Self::TaskHead(Box::new(TaskHeadPolicy::new(
                policy, map, kin,
            )?)));
        }
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

    /// The network: `π` itself, the canonicalised policy's `π₀`, or the task head's `h`
    /// (over the task coordinates, not the joints).
    pub fn network(&self) -> &Policy {
        match self {
            Self::Plain(p) => p,
            Self::Canonicalised(p) => p.base(),
            Self::TaskHead(p) => p.head(),
        }
    }

    /// The task head, when the policy is one.
    pub fn task_head(&self) -> Option<&TaskHeadPolicy> {
        match self {
            Self::TaskHead(p) => Some(p),
            _ => None,
        }
    }

    /// A task head with the null-space term `term` added to its lift
    /// ([`TaskHeadPolicy::with_null_space`]); other policies are returned unchanged with
    /// `false` (their joint velocity is not a lift of a task velocity).
    pub fn with_null_space(
        self,
        term: crossym_math::kinematics::NullSpaceTerm,
    ) -> Result<(Self, bool), PolicyFitError> {
        match self {
            Self::TaskHead(p) => Ok((Self::TaskHead(Box::new(p.with_null_space(term)?)), true)),
            other => Ok((other, false)),
        }
    }

    /// A task head with the plain lift (its null-space term removed); `false` when there was
    /// none to remove.
    pub fn with_plain_lift(self) -> (Self, bool) {
        match self {
            Self::TaskHead(p) if p.null_space().is_some() => {
                (Self::TaskHead(Box::new(p.without_null_space())), true)
            }
            other => (other, false),
        }
    }

    /// The composition a canonicalised policy is evaluated through (`None`: plain).
    pub fn composition(&self) -> Option<&ComposedSpec> {
        match self {
            Self::Plain(_) | Self::TaskHead(_) => None,
            Self::Canonicalised(p) => Some(p.lift().spec()),
        }
    }

    /// Refuses a canonicalised policy whose composition is not `config`'s (a policy
    /// canonicalised for another robot, another centre of rotation, another order);
    /// a plain policy passes.
    pub fn check_composition(&self, config: &ComposedSpec) -> Result<(), PolicyFitError> {
        self.check_composition_inner(config)
            .map_err(PolicyFitError::composition)
    }

    // The checks of [`Self::check_composition`], failing with a message.
    fn check_composition_inner(&self, config: &ComposedSpec) -> Result<(), String> {
        match self.composition() {
            None => Ok(()),
            Some(own) => own.same_composition(config).map_err(|e| {
                format!("the policy is canonicalised by another composition than the config's: {e}")
            }),
        }
    }

    /// Number of joints.
    pub fn dim(&self) -> usize {
        match self {
            Self::TaskHead(p) => p.dim(),
            _ => self.network().dim(),
        }
    }

    /// Scratch sized for the policy (allocates; setup only).
    pub fn workspace(&self) -> AnyWorkspace {
        match self {
            Self::Plain(p) => AnyWorkspace::Plain(Box::new(p.workspace())),
            Self::Canonicalised(p) => AnyWorkspace::Canonicalised(Box::new(p.workspace())),
            Self::TaskHead(p) => AnyWorkspace::TaskHead(Box::new(p.workspace())),
        }
    }

    /// `out = π(q, s)` (rad/s or m/s); allocation-free. A canonicalised policy fails where
    /// a flow of its composition does (a singularity, an invalid condition), a task head
    /// where the horizontal lift is undefined or on an invalid condition, leaving `out`
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
    /// [`Policy::velocity_at`]); a canonicalised policy evaluates `π₀` at `q₀ ≠ q` and a
    /// task head computes `f(q)` with its Jacobian: both ignore `x`.
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
            (Self::TaskHead(p), AnyWorkspace::TaskHead(w)) => p.velocity(q, s, out, w),
            _ => panic!("AnyPolicy: workspace of another policy kind"),
        }
    }
}
