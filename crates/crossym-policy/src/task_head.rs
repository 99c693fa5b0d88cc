//! Task-space heads lifted to joint space (issue 17): a network `h` over the task space `X`,
//! canonicalised by the group's closed-form action on `X` and lifted to `Q` by the horizontal
//! lift (eqs. 13, 23):
//!
//!   π(q, s) = J⁺(q) · Dg(s) · h(g(s)⁻¹ f(q)),   J⁺ = M⁻¹Jᵀ(J M⁻¹Jᵀ)⁻¹,
//!
//! with `f` the stacked forward kinematics, `g(s) = ρ_X(σ) ∘ Φ_R(θ) ∘ Φ_S(ln λ)` the letter
//! group's affine action on `X` ([`CanonicalMap`], eq. 23's order) and `h` trained on the
//! original demonstrations' task paths (identity condition).
//!
//! **Exact equivariance in `X`.** Where `J` has full row rank, `J J⁺ = I`, so the task point
//! of the closed loop obeys `ẋ = Dg h(g⁻¹ x)`. If `x̃(t)` solves `x̃' = h(x̃)`, then
//! `x(t) = g x̃(t)` solves it (`g` affine: `d/dt (g x̃) = Dg h(x̃) = Dg h(g⁻¹ x)`): the closed
//! loop under `s` draws `g(s)` applied to the identity's drawing, for every condition whose
//! drawing the arms can reach — not only a training grid. The joints follow the horizontal
//! lift of that task motion, which is how the demonstrations were tracked (damped least
//! squares, eq. 13 with `M = I`) and how the paper transfers task motions to `Q`.
//!
//! A sub-group's head ([`CanonicalMap`] without some factors, e.g. `π_R`) ignores the
//! factors of `s` it lacks: it behaves as a policy that never saw them.
//!
//! **Redundancy** ([`TaskHeadPolicy::with_null_space`], config `[redundancy]`): on a
//! redundant arm the lift may add a secondary motion in the null space of `J`,
//!
//!   π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q)) + (I − J⁺J) v₀(q),
//!
//! `v₀` pulling toward a rest posture and away from the joint limits
//! ([`crossym_math::kinematics::null_space`]). `J (I − J⁺J) = 0`, so the task velocity and
//! the exact equivariance in `X` above are unchanged; without it (the default) the lift is
//! the plain one, bit for bit.
//!
//! Evaluation costs one FK with Jacobian, one `m × m` Cholesky factor and solve, and the
//! `m`-input network (an ensemble's block-diagonal hidden layers run packed, see
//! [`super::MlpInference`]), and allocates nothing.

use super::error::PolicyFitError;
use super::mlp::{Policy, PolicyWorkspace};
use crate::trajectory::JointTrajectory;
use crossym_math::kinematics::{
    lift_with_secondary, Kinematics, KinematicsWorkspace, NullSpaceTerm, PinvStatus,
    SecondaryWorkspace,
};
use crossym_math::symmetry::affine::CanonicalMap;
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::composed::{ComposedError, ConditionProblem};

/// Names of the task coordinates of `kin`, in the order of `f(q)`: `<chain>.x`, `<chain>.y`
/// (and `<chain>.z` on `xyz` chains). A task head's network uses them as its "joint" names.
pub fn task_coordinate_names(kin: &Kinematics) -> Vec<String> {
    kin.chains()
        .iter()
        .flat_map(|c| {
            ["x", "y", "z"][..c.task.dim()]
                .iter()
                .map(move |a| format!("{}.{a}", c.name))
        })
        .collect()
}

/// The task path of a demonstration as a trajectory of a task head's network: positions
/// `x = f(q)` (task units), velocities the forward difference over `dt` (the last sample's
/// velocity is 0, the demonstration at rest at its goal), as the demonstrations' `q̇` are.
pub fn task_path_trajectory(d: &JointTrajectory) -> JointTrajectory {
    let (len, m) = (d.len(), d.m);
    let mut qdot = vec![0.0; len * m];
    for i in 0..len.saturating_sub(1) {
        for j in 0..m {
            qdot[i * m + j] = (d.x[(i + 1) * m + j] - d.x[i * m + j]) / d.dt;
        }
    }
    JointTrajectory {
        demo: d.demo,
        n: m,
        m: 0,
        dt: d.dt,
        q: d.x.clone(),
        qdot,
        x: Vec::new(),
    }
}

/// A task-space network `h` canonicalised by the group's action on `X` and lifted to `Q`.
#[derive(Debug, Clone)]
pub struct TaskHeadPolicy {
    head: Policy,
    map: CanonicalMap,
    kin: Kinematics,
    null_space: Option<NullSpaceTerm>,
}

/// Scratch for [`TaskHeadPolicy::velocity`].
#[derive(Debug, Clone)]
pub struct TaskHeadWorkspace {
    kin: KinematicsWorkspace,
    head: PolicyWorkspace,
    xt: Vec<f64>,
    u: Vec<f64>,
    v: Vec<f64>,
    h: Vec<f64>,
    h2: Vec<f64>,
    /// `v₀(q)` (n) and the secondary lift's scratch, with a null-space term.
    v0: Vec<f64>,
    secondary: SecondaryWorkspace,
}

impl TaskHeadPolicy {
    /// `h` (a network over `X = R^m`, evaluated at the identity condition, named by
    /// [`task_coordinate_names`]), the group's action on `X`, and the robot it is lifted to.
    pub fn new(head: Policy, map: CanonicalMap, kin: &Kinematics) -> Result<Self, PolicyFitError> {
        Self::new_inner(head, map, kin).map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::new`], failing with a message.
    fn new_inner(head: Policy, map: CanonicalMap, kin: &Kinematics) -> Result<Self, String> {
        map.validate().map_err(|e| format!("task head map: {e}"))?;
        let m = kin.task_dim();
        if map.dim != m || head.dim() != m {
            return Err(format!(
                "the task head acts on R^{} with a network over R^{}, the robot's task space \
                 is R^{m}",
                map.dim,
                head.dim()
            ));
        }
        if head.task_features().is_some() {
            return Err("a task head's network takes no task features".into());
        }
        let names = task_coordinate_names(kin);
        if !head.meta.joint_names.is_empty() && head.meta.joint_names != names {
            return Err(format!(
                "task head coordinates {:?} differ from the robot's {names:?}",
                head.meta.joint_names
            ));
        }
        Ok(Self {
            head,
            map,
            kin: kin.clone(),
            null_space: None,
        })
    }

    /// The same head with the null-space term `(I − J⁺J) v₀(q)` added to its lift (module
    /// docs); fails when the term is not sized for the robot.
    pub fn with_null_space(mut self, term: NullSpaceTerm) -> Result<Self, PolicyFitError> {
        if term.dim() != self.kin.dof() {
            return Err(PolicyFitError::robot(format!(
                "the null-space term has {} joints, the robot {}",
                term.dim(),
                self.kin.dof()
            )));
        }
        self.null_space = Some(term);
        Ok(self)
    }

    /// The same head with the plain lift (no null-space term).
    pub fn without_null_space(mut self) -> Self {
        self.null_space = None;
        self
    }

    /// The null-space term added to the lift, if any.
    pub fn null_space(&self) -> Option<&NullSpaceTerm> {
        self.null_space.as_ref()
    }

    /// The network `h` over `X`.
    pub fn head(&self) -> &Policy {
        &self.head
    }

    /// The group's action on `X` the head is canonicalised by.
    pub fn map(&self) -> &CanonicalMap {
        &self.map
    }

    /// The robot the head is lifted to.
    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    /// Number of joints `n` of the robot.
    pub fn dim(&self) -> usize {
        self.kin.dof()
    }

    /// Scratch sized for the head and the robot (allocates; setup only).
    pub fn workspace(&self) -> TaskHeadWorkspace {
        let m = self.map.dim;
        TaskHeadWorkspace {
            kin: self.kin.workspace(),
            head: self.head.workspace(),
            xt: vec![0.0; m],
            u: vec![0.0; m],
            v: vec![0.0; m],
            h: vec![0.0; m],
            h2: vec![0.0; m],
            v0: vec![0.0; self.kin.dof()],
            secondary: SecondaryWorkspace::new(m),
        }
    }

    /// `out = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))` (rad/s or m/s), plus `(I − J⁺J) v₀(q)` with a
    /// null-space term; allocation-free. Fails, leaving
    /// `out` untouched, on an invalid condition or where the lift is undefined (a
    /// singular or near-singular `J`).
    pub fn velocity(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut TaskHeadWorkspace,
    ) -> Result<(), ComposedError> {
        if let Some(problem) = ConditionProblem::of(s) {
            return Err(ComposedError::Condition { problem });
        }
        self.kin.jacobian(q, &mut ws.kin);
        let report = self.kin.factor(&mut ws.kin);
        if report.status != PinvStatus::Regular {
            return Err(ComposedError::SingularLift {
                manipulability: report.manipulability,
            });
        }
        let TaskHeadWorkspace {
            kin,
            head,
            xt,
            u,
            v,
            h,
            h2,
            v0,
            secondary,
        } = ws;
        self.map.apply_inverse(s, kin.x.as_slice(), xt, h, h2);
        self.head.velocity(xt, &Condition::IDENTITY, u, head);
        self.map.apply_linear(s, u, v, h, h2);
        match &self.null_space {
            None => self.kin.solve(kin, v, out),
            Some(term) => {
                term.secondary(q, v0);
                lift_with_secondary(&self.kin, kin, v, v0, out, secondary);
            }
        }
        Ok(())
    }

    /// The canonical task point `g(s)⁻¹ f(q)` of the last successful [`Self::velocity`]
    /// call (task units).
    pub fn last_canonical<'w>(&self, ws: &'w TaskHeadWorkspace) -> &'w [f64] {
        &ws.xt
    }
}
