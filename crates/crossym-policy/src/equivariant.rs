//! Exactly equivariant policies by canonicalisation through the lifted flows (issue 18;
//! the paper's future work, Sec. VII):
//!
//!   π(q, s) = dΦ_g|_{q₀} · π₀(q₀),   q₀ = Φ_g⁻¹(q),   g = g(s),
//!
//! with `Φ_g` the composed lifted action of eq. 23 ([`ComposedLift`]) and `π₀` a policy
//! evaluated at the identity condition. If `q_e(t)` is a closed-loop trajectory of `π₀`,
//! then `q_s(t) = Φ_g(q_e(t))` satisfies `q̇_s = dΦ_g|_{q_e} π₀(q_e) = π(q_s, s)`: the closed
//! loop under `s` is conjugate to the one under the identity, and in task space
//! `f(q_s(t)) = g · f(q_e(t))` (the lifted flows are `f`-related), for every condition
//! whose flows are feasible from the current state — not only a training grid.

use super::error::PolicyFitError;
use super::mlp::{Policy, PolicyWorkspace};
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::composed::{ComposedError, ComposedLift, ComposedWorkspace};

/// A base policy `π₀` canonicalised by the composed lifted action.
#[derive(Debug, Clone)]
pub struct EquivariantPolicy {
    base: Policy,
    lift: ComposedLift,
}

/// Scratch for [`EquivariantPolicy::velocity`].
#[derive(Debug, Clone)]
pub struct EquivariantWorkspace {
    policy: PolicyWorkspace,
    lift: ComposedWorkspace,
    q0: Vec<f64>,
    v0: Vec<f64>,
    q1: Vec<f64>,
}

impl EquivariantWorkspace {
    /// The composed lift's scratch: its last residual and integrator steps.
    pub fn lift(&self) -> &ComposedWorkspace {
        &self.lift
    }
}

impl EquivariantPolicy {
    /// `π₀` (evaluated at the identity condition) and the composed action it is
    /// canonicalised by; the policy must drive the lift's robot.
    pub fn new(base: Policy, lift: ComposedLift) -> Result<Self, PolicyFitError> {
        Self::new_inner(base, lift).map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::new`], failing with a message.
    fn new_inner(base: Policy, lift: ComposedLift) -> Result<Self, String> {
        if base.dim() != lift.kinematics().dof() {
            return Err(format!(
                "the policy drives {} joints, the robot has {}",
                base.dim(),
                lift.kinematics().dof()
            ));
        }
        Ok(Self { base, lift })
    }

    /// The base policy `π₀`.
    pub fn base(&self) -> &Policy {
        &self.base
    }

    /// The composed action.
    pub fn lift(&self) -> &ComposedLift {
        &self.lift
    }

    /// Scratch sized for the policy and the robot.
    pub fn workspace(&self) -> EquivariantWorkspace {
        let n = self.base.dim();
        EquivariantWorkspace {
            policy: self.base.workspace(),
            lift: self.lift.workspace(),
            q0: vec![0.0; n],
            v0: vec![0.0; n],
            q1: vec![0.0; n],
        }
    }

    /// `out = dΦ_g|_{q₀} π₀(q₀)` with `q₀ = Φ_g⁻¹(q)` (rad/s or m/s); on an error (a flow
    /// reached a singularity, or the condition is invalid) `out` is untouched.
    pub fn velocity(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut EquivariantWorkspace,
    ) -> Result<(), ComposedError> {
        self.lift.inverse(s, q, &mut ws.q0, &mut ws.lift)?;
        self.base
            .velocity(&ws.q0, &Condition::IDENTITY, &mut ws.v0, &mut ws.policy);
        self.lift
            .act_with_differential(s, &ws.q0, &ws.v0, &mut ws.q1, out, &mut ws.lift)?;
        Ok(())
    }

    /// The canonical configuration `q₀ = Φ_g⁻¹(q)` of the last [`Self::velocity`] call and
    /// `Φ_g(q₀)` recomputed from it (rad or m): their distance to `q` is the inverse's
    /// round-trip error.
    pub fn last_canonical<'w>(&self, ws: &'w EquivariantWorkspace) -> (&'w [f64], &'w [f64]) {
        (&ws.q0, &ws.q1)
    }
}
