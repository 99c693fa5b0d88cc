//! The composed lifted action of one condition, its inverse and its push-forward (eq. 23):
//!
//!   Φ_g(q) = ρ(σ) · Φ_R(θ, Φ_S(ln λ, q)),   g = g(s), s = (θ, λ, σ),
//!   Φ_g⁻¹(q) = Φ_S(−ln λ, Φ_R(−θ, ρ(σ)⁻¹ q)),
//!   dΦ_g|_q v = ρ(σ) · dΦ_R(θ)|_{Φ_S(q)} · dΦ_S(ln λ)|_q v,
//!
//! with `Φ_R`, `Φ_S` the flows of the horizontally lifted rotation and scaling generators
//! (eqs. 17–18) and `ρ(σ)` the morphological reflection acting linearly on `Q`. The inverse
//! flows each field backwards in the reverse order, so it inverts *this fixed composite
//! map* exactly (up to the integrator's error) whether or not the lifted action is a
//! group action (with `M = I` it is not: the vertical bracket and the 2π drift). The
//! push-forward transports the tangent `v` along the forward flows (variational equation
//! `δ̇ = dX_Q|_γ δ` with the lifted field's closed-form derivative), no `n × n` matrix;
//! its task component is then made exact, `J(Φ_g q) dΦ_g v = Dg J(q) v` (eq. 15 through
//! the composition), by the horizontal lift of the defect, so the integrator's error is
//! left in the vertical component only.
//! `θ` outside `[−π, π]` is wrapped into `(−π, π]` first ([`flow_angle`]), so `θ` and
//! `θ + 2πk` give the same map (`±π` stay apart, as in the augmentation grid).
//!
//! Canonicalisation (issue 18) uses exactly these maps: a policy `π₀` for the identity
//! condition becomes `π(q, s) = dΦ_g|_{q₀} π₀(q₀)` with `q₀ = Φ_g⁻¹(q)`, whose closed loop
//! under `s` is conjugate to `π₀`'s, `q_s(t) = Φ_g(q_e(t))`.
//!
//! The composition is stored as a serialisable [`ComposedSpec`] (the reflection on `Q`,
//! the affine task-space generators of `R` and `S` and the integrator; a canonicalised
//! policy's sidecar carries it), so a [`ComposedLift`] owns everything it needs: it is
//! built once at setup, and [`ComposedLift::inverse`] / [`ComposedLift::act_with_differential`]
//! allocate nothing (a caller-owned [`ComposedWorkspace`]; failures are fixed-size
//! [`ComposedError`]s), which puts them on the control tick.

mod error;

use serde::{Deserialize, Serialize};

pub use self::error::{
    ComposedError, ComposedSpecError, CompositionMismatch, ConditionProblem, Factor,
    IntegratorError,
};

use crate::kinematics::{Kinematics, KinematicsWorkspace, PinvStatus};
use crate::symmetry::affine::{
    max_diff, CanonicalMap, OneParamAction, OneParamKind, StoredPermutation,
};
use crate::symmetry::built::BuiltSymmetry;
use crate::symmetry::compose::Condition;
use crate::symmetry::field::VectorField;
use crate::symmetry::finite::SignedPermutation;
use crate::symmetry::transfer::flow::{
    integrate, integrate_rk4, FlowSettings, FlowStatus, FlowWorkspace,
};
use crate::symmetry::transfer::lift::{jacobian_times, wrap_angle, LiftFieldScratch, LiftedField};

/// Relative tolerance when comparing two specs' generators.
const SPEC_TOL: f64 = 1e-9;

/// Default [`ComposedSpec::residual_tolerance`] (task units).
pub const DEFAULT_RESIDUAL: f64 = 1e-3;

/// How the lifted flows are integrated.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LiftIntegrator {
    /// Dormand–Prince 5(4) with error control (cost follows the tolerance).
    Adaptive {
        /// Tolerances, step limit and warm start.
        settings: FlowSettings,
    },
    /// Classical RK4 with `⌈|t| / max_step⌉` equal steps (fixed cost per call, global
    /// error `O(max_step⁴)`, no error control).
    Rk4 {
        /// Largest step in flow time (rad for the rotation, ln λ for the scaling).
        max_step: f64,
    },
}

impl LiftIntegrator {
    /// Checks the settings; says what is wrong.
    pub fn validate(&self) -> Result<(), IntegratorError> {
        match self {
            Self::Adaptive { settings } => Ok(settings.validate()?),
            Self::Rk4 { max_step } if !(max_step.is_finite() && *max_step > 0.0) => {
                Err(IntegratorError::Rk4Step {
                    max_step: *max_step,
                })
            }
            Self::Rk4 { .. } => Ok(()),
        }
    }
}

/// The composition `ρ(σ) ∘ Φ_R(θ) ∘ Φ_S(ln λ)` as stored (a canonicalised policy's sidecar).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ComposedSpec {
    /// The configuration's composition order, outer → inner (`[M, R, S]` or `[M, R]`).
    pub order: Vec<String>,
    /// `ρ_Q(−1)`, the morphological reflection on joint space.
    pub reflection: StoredPermutation,
    /// The same group acting on task space: `ρ_X(−1)` and the affine generators of the
    /// rotation `R` and the scaling `S` (lifted to `Q` by eq. 17). Also gives the check
    /// `f(Φ_g⁻¹ q) = g⁻¹ f(q)` of every inverse ([`ComposedError::Residual`]).
    pub task: CanonicalMap,
    /// Largest task-space residual `|f(Φ_g⁻¹ q) − g⁻¹ f(q)|∞` accepted, relative to
    /// `max(1, |g⁻¹ f(q)|∞)` (task units): the integrator's error is far below it; above
    /// it a flow crossed a singularity unnoticed.
    pub residual_tolerance: f64,
    /// How the lifted flows are integrated.
    pub integrator: LiftIntegrator,
}

impl ComposedSpec {
    /// The composition `order` (`[M, R, S]` or `[M, R]`) of `built`: `M` morphological,
    /// `R` an affine SO(2), `S` an affine scaling on `X`.
    pub fn from_symmetries(
        kin: &Kinematics,
        built: &[BuiltSymmetry],
        order: &[String],
        integrator: LiftIntegrator,
    ) -> Result<Self, ComposedSpecError> {
        let rho = crate::symmetry::parts::composition_parts(built, order)?.reflection;
        let spec = Self {
            order: order.to_vec(),
            reflection: StoredPermutation {
                perm: rho.perm.clone(),
                signs: rho.signs.clone(),
            },
            task: CanonicalMap::from_symmetries(kin, built, order)?,
            residual_tolerance: DEFAULT_RESIDUAL,
            integrator,
        };
        spec.validate(kin)?;
        Ok(spec)
    }

    /// Checks the spec against the robot: the reflection acts on `Q`, the generators on
    /// `X` and are of their kinds (rotation, scaling), the integrator's settings.
    pub fn validate(&self, kin: &Kinematics) -> Result<(), ComposedSpecError> {
        let (n, m) = (kin.dof(), kin.task_dim());
        SignedPermutation::new(self.reflection.perm.clone(), self.reflection.signs.clone())
            .map_err(|source| ComposedSpecError::Reflection { source })?;
        if self.reflection.perm.len() != n {
            return Err(ComposedSpecError::ReflectionDim {
                acts_on: self.reflection.perm.len(),
                n,
            });
        }
        self.task.validate()?;
        if self.task.dim != m {
            return Err(ComposedSpecError::TaskDim {
                acts_on: self.task.dim,
                m,
            });
        }
        if self.task.reflection.is_none() {
            return Err(ComposedSpecError::NoTaskReflection);
        }
        for (a, want) in [
            (self.task.rotation.as_ref(), OneParamKind::Rotation),
            (self.task.scaling.as_ref(), OneParamKind::Scaling),
        ] {
            match a {
                Some(a) if a.kind != want => {
                    return Err(ComposedSpecError::WrongKind {
                        name: a.name.clone(),
                        want,
                        got: a.kind,
                    })
                }
                None if want == OneParamKind::Rotation => {
                    return Err(ComposedSpecError::NoRotation)
                }
                _ => {}
            }
        }
        if !(self.residual_tolerance.is_finite() && self.residual_tolerance > 0.0) {
            return Err(ComposedSpecError::ResidualTolerance {
                tolerance: self.residual_tolerance,
            });
        }
        Ok(self.integrator.validate()?)
    }

    /// Whether `other` describes the same composition (order, reflection, generators to
    /// 1e-9 relative; the integrator may differ); says what differs.
    pub fn same_composition(&self, other: &Self) -> Result<(), CompositionMismatch> {
        if self.order != other.order {
            return Err(CompositionMismatch::Order {
                ours: self.order.clone(),
                theirs: other.order.clone(),
            });
        }
        if self.reflection != other.reflection {
            return Err(CompositionMismatch::Reflection {
                ours: self.reflection.clone(),
                theirs: other.reflection.clone(),
            });
        }
        if self.task.reflection != other.task.reflection {
            return Err(CompositionMismatch::TaskReflection);
        }
        let close = |a: &OneParamAction, b: &OneParamAction| {
            a.linear.len() == b.linear.len()
                && a.offset.len() == b.offset.len()
                && max_diff(&a.linear, &b.linear).max(max_diff(&a.offset, &b.offset))
                    <= SPEC_TOL * (1.0 + a.offset.iter().fold(1.0f64, |m, v| m.max(v.abs())))
        };
        match (&self.task.rotation, &other.task.rotation) {
            (Some(a), Some(b)) if !close(a, b) => {
                return Err(CompositionMismatch::Rotation {
                    name: a.name.clone(),
                    linear: a.linear.clone(),
                    offset: a.offset.clone(),
                    other_linear: b.linear.clone(),
                    other_offset: b.offset.clone(),
                })
            }
            (Some(_), Some(_)) => {}
            _ => return Err(CompositionMismatch::MissingRotation),
        }
        match (&self.task.scaling, &other.task.scaling) {
            (None, None) => Ok(()),
            (Some(a), Some(b)) if close(a, b) => Ok(()),
            (Some(a), Some(_)) => Err(CompositionMismatch::Scaling {
                name: a.name.clone(),
            }),
            _ => Err(CompositionMismatch::ScalingPresence),
        }
    }
}

/// The flow time of the rotation for `θ` (rad): `θ` itself on `[−π, π]`, else wrapped into
/// `(−π, π]`. The lifted rotation is not 2π-periodic in `Q` (the drift of
/// [`super::lift::periodicity_drift`]), so `±π` are kept apart as the augmentation grid
/// (±180°) keeps them; any other `θ + 2πk` gives the map of its representative.
pub fn flow_angle(theta: f64) -> f64 {
    if theta.abs() <= std::f64::consts::PI {
        theta
    } else {
        wrap_angle(theta)
    }
}

/// The variational field `(y, δ) ↦ (X(y), dX|_y δ)` of a field with a closed-form
/// derivative (no scratch, so built per call at no cost).
struct Tangent<'f, F: VectorField>(&'f F);

impl<F: VectorField> VectorField for Tangent<'_, F> {
    fn dim(&self) -> usize {
        2 * self.0.dim()
    }
    fn eval(&self, p: &[f64], out: &mut [f64]) -> bool {
        let d = self.0.dim();
        let (y, delta) = p.split_at(d);
        let (oy, od) = out.split_at_mut(d);
        self.0.eval_derivative(y, delta, oy, od).unwrap_or(false)
    }
}

/// `Φ_g`, `Φ_g⁻¹` and `dΦ_g` of eq. 23 for the letter-style composition `(M, R[, S])`;
/// owns its robot and spec (`Send`, `Clone`).
#[derive(Debug, Clone)]
pub struct ComposedLift {
    kin: Kinematics,
    spec: ComposedSpec,
    reflection: SignedPermutation,
    reflection_inv: SignedPermutation,
}

/// Scratch for [`ComposedLift`] (allocates once, in [`ComposedLift::workspace`]).
#[derive(Debug, Clone)]
pub struct ComposedWorkspace {
    flows: FlowScratch,
    a: Vec<f64>,
    b: Vec<f64>,
    va: Vec<f64>,
    vb: Vec<f64>,
    kws: KinematicsWorkspace,
    x: Vec<f64>,
    xg: Vec<f64>,
    h: Vec<f64>,
    h2: Vec<f64>,
    residual: f64,
}

/// What one lifted flow needs: the field's scratch, the integrators' workspaces (per
/// factor, so each warm-starts from its own last step size) and the step count.
#[derive(Debug, Clone)]
struct FlowScratch {
    field: LiftFieldScratch,
    pos: [FlowWorkspace; 2],
    var: [FlowWorkspace; 2],
    y0: Vec<f64>,
    y1: Vec<f64>,
    steps: usize,
}

impl ComposedWorkspace {
    /// Integrator steps (accepted and rejected) of the last [`ComposedLift::inverse`] plus
    /// [`ComposedLift::act_with_differential`] pair: the cost of one canonicalised
    /// velocity is about 6 (DOPRI5) or 4 (RK4) lifted-field evaluations per step.
    pub fn steps(&self) -> usize {
        self.flows.steps
    }

    /// `|f(Φ_g⁻¹ q) − g⁻¹ f(q)|∞` of the last successful [`ComposedLift::inverse`] (task
    /// units): the integrator's error in task space.
    pub fn residual(&self) -> f64 {
        self.residual
    }
}

impl ComposedLift {
    /// The lift of `spec` through `kin` (cloned: the lift owns its robot).
    pub fn new(kin: &Kinematics, spec: ComposedSpec) -> Result<Self, ComposedSpecError> {
        spec.validate(kin)?;
        let reflection =
            SignedPermutation::new(spec.reflection.perm.clone(), spec.reflection.signs.clone())?;
        Ok(Self {
            kin: kin.clone(),
            reflection_inv: reflection.inverse(),
            reflection,
            spec,
        })
    }

    /// The composition `order` (outer → inner: `[M, R, S]` or `[M, R]`) of the built
    /// symmetries, the lifted flows integrated by `integrator`.
    pub fn from_symmetries(
        kin: &Kinematics,
        built: &[BuiltSymmetry],
        order: &[String],
        integrator: LiftIntegrator,
    ) -> Result<Self, ComposedSpecError> {
        Self::new(
            kin,
            ComposedSpec::from_symmetries(kin, built, order, integrator)?,
        )
    }

    /// The robot.
    pub fn kinematics(&self) -> &Kinematics {
        &self.kin
    }

    /// The composition as stored.
    pub fn spec(&self) -> &ComposedSpec {
        &self.spec
    }

    /// Scratch sized for this robot.
    pub fn workspace(&self) -> ComposedWorkspace {
        let (n, m) = (self.kin.dof(), self.kin.task_dim());
        ComposedWorkspace {
            flows: FlowScratch {
                field: LiftFieldScratch::new(&self.kin),
                pos: [FlowWorkspace::new(n), FlowWorkspace::new(n)],
                var: [FlowWorkspace::new(2 * n), FlowWorkspace::new(2 * n)],
                y0: vec![0.0; 2 * n],
                y1: vec![0.0; 2 * n],
                steps: 0,
            },
            a: vec![0.0; n],
            b: vec![0.0; n],
            va: vec![0.0; n],
            vb: vec![0.0; n],
            kws: self.kin.workspace(),
            x: vec![0.0; m],
            xg: vec![0.0; m],
            h: vec![0.0; m],
            h2: vec![0.0; m],
            residual: 0.0,
        }
    }

    /// Validates `s` (allocation-free); `θ` is used wrapped to `(−π, π]`.
    fn check(&self, s: &Condition) -> Result<(), ComposedError> {
        if let Some(problem) = ConditionProblem::of(s) {
            return Err(ComposedError::Condition { problem });
        }
        if s.scale != 1.0 && self.spec.task.scaling.is_none() {
            return Err(ComposedError::NoScaling { scale: s.scale });
        }
        Ok(())
    }

    fn generator(&self, factor: Factor) -> &OneParamAction {
        // `validate` requires the rotation; `check` refuses λ ≠ 1 without a scaling.
        let rotation = self.spec.task.rotation.as_ref().expect("validated");
        match factor {
            Factor::Rotation => rotation,
            Factor::Scaling => self.spec.task.scaling.as_ref().unwrap_or(rotation),
        }
    }

    fn outcome(
        factor: Factor,
        status: FlowStatus,
        total: f64,
        steps: &mut usize,
    ) -> Result<(), ComposedError> {
        match status {
            FlowStatus::Done { steps: s, rejected } => {
                *steps += s + rejected;
                Ok(())
            }
            FlowStatus::FieldUndefined { t: 0.0 } => Err(ComposedError::BadStart { factor }),
            FlowStatus::FieldUndefined { t } => Err(ComposedError::Singular { factor, t, total }),
            status => Err(ComposedError::Integration { factor, status }),
        }
    }

    fn rk4_steps(max_step: f64, t: f64) -> usize {
        ((t.abs() / max_step).ceil() as usize).max(1)
    }

    /// Integrates `field` for time `t` with the spec's integrator (`error_dims`: the
    /// components under step control), counting the steps.
    #[allow(clippy::too_many_arguments)]
    fn integrate(
        &self,
        factor: Factor,
        field: &dyn VectorField,
        t: f64,
        y0: &[f64],
        out: &mut [f64],
        error_dims: usize,
        fws: &mut FlowWorkspace,
        steps: &mut usize,
    ) -> Result<(), ComposedError> {
        let status = match &self.spec.integrator {
            LiftIntegrator::Adaptive { settings } => {
                let settings = FlowSettings {
                    error_dims: Some(error_dims),
                    ..*settings
                };
                integrate(field, t, y0, out, &settings, fws)
            }
            LiftIntegrator::Rk4 { max_step } => {
                integrate_rk4(field, t, Self::rk4_steps(*max_step, t), y0, out, fws)
            }
        };
        Self::outcome(factor, status, t, steps)
    }

    /// `out = Φ_factor(t, q)`: the lifted field's flow for time `t`.
    fn flow(
        &self,
        factor: Factor,
        t: f64,
        q: &[f64],
        out: &mut [f64],
        fs: &mut FlowScratch,
    ) -> Result<(), ComposedError> {
        let field = LiftedField::with_scratch(&self.kin, self.generator(factor), &fs.field);
        let fws = &mut fs.pos[factor as usize];
        self.integrate(factor, &field, t, q, out, q.len(), fws, &mut fs.steps)
    }

    /// `(q_out, v_out) = (Φ_factor(t, q), dΦ_factor(t)|_q v)`: positions and tangent
    /// together (variational equation), step control on the positions.
    fn flow_with_tangent(
        &self,
        factor: Factor,
        t: f64,
        (q, v): (&[f64], &[f64]),
        (q_out, v_out): (&mut [f64], &mut [f64]),
        fs: &mut FlowScratch,
    ) -> Result<(), ComposedError> {
        let n = q.len();
        let field = LiftedField::with_scratch(&self.kin, self.generator(factor), &fs.field);
        fs.y0[..n].copy_from_slice(q);
        fs.y0[n..].copy_from_slice(v);
        let fws = &mut fs.var[factor as usize];
        self.integrate(
            factor,
            &Tangent(&field),
            t,
            &fs.y0,
            &mut fs.y1,
            n,
            fws,
            &mut fs.steps,
        )?;
        q_out.copy_from_slice(&fs.y1[..n]);
        v_out.copy_from_slice(&fs.y1[n..]);
        Ok(())
    }

    /// `q_out = Φ_g⁻¹(q) = Φ_S(−ln λ, Φ_R(−θ, ρ(σ)⁻¹ q))` (rad or m); allocation-free.
    ///
    /// Checked in task space: `f(q_out)` must equal `g⁻¹ f(q)` (the closed-form task
    /// action) to [`ComposedSpec::residual_tolerance`], else [`ComposedError::Residual`].
    pub fn inverse(
        &self,
        s: &Condition,
        q: &[f64],
        q_out: &mut [f64],
        ws: &mut ComposedWorkspace,
    ) -> Result<(), ComposedError> {
        self.check(s)?;
        let ComposedWorkspace { flows, a, b, .. } = ws;
        flows.steps = 0;
        if s.reflection == -1 {
            self.reflection_inv.apply(q, a);
        } else {
            a.copy_from_slice(q);
        }
        let theta = flow_angle(s.theta);
        if theta != 0.0 {
            self.flow(Factor::Rotation, -theta, a, b, flows)?;
        } else {
            b.copy_from_slice(a);
        }
        if s.scale != 1.0 {
            self.flow(Factor::Scaling, -s.scale.ln(), b, q_out, flows)?;
        } else {
            q_out.copy_from_slice(b);
        }
        // f(q_out) against g⁻¹ f(q).
        self.kin.forward(q, &mut ws.kws);
        ws.x.copy_from_slice(ws.kws.x.as_slice());
        self.spec
            .task
            .apply_inverse(s, &ws.x, &mut ws.xg, &mut ws.h, &mut ws.h2);
        self.kin.forward(q_out, &mut ws.kws);
        let residual = max_diff(ws.kws.x.as_slice(), &ws.xg);
        let scale = ws.xg.iter().fold(1.0f64, |m, v| m.max(v.abs()));
        let tolerance = self.spec.residual_tolerance * scale;
        if residual.is_nan() || residual > tolerance {
            return Err(ComposedError::Residual {
                residual,
                tolerance,
            });
        }
        ws.residual = residual;
        Ok(())
    }

    /// `q_out = Φ_g(q)` and `v_out = dΦ_g|_q v` (rad or m, and per second); allocation-free.
    ///
    /// The lifted flows are `f`-related to the task action (eq. 15), so `f ∘ Φ_g = g ∘ f`
    /// and, differentiating, `J(Φ_g q) dΦ_g|_q v = Dg J(q) v`: the task component of the
    /// push-forward is known in closed form (`g` is affine). The tangent carried along the
    /// flows (variational equation) is therefore corrected by the horizontal lift of its
    /// task-space defect, `v_out += J⁺(q_out) (Dg J(q) v − J(q_out) v_out)`, which leaves
    /// `J(q_out) v_out = Dg J(q) v` to rounding and the integrator's error in the vertical
    /// component only (where the flows are exact the defect is 0).
    pub fn act_with_differential(
        &self,
        s: &Condition,
        q: &[f64],
        v: &[f64],
        q_out: &mut [f64],
        v_out: &mut [f64],
        ws: &mut ComposedWorkspace,
    ) -> Result<(), ComposedError> {
        self.check(s)?;
        // The task velocity to reach, Dg J(q) v (into `xg`).
        self.kin.jacobian(q, &mut ws.kws);
        jacobian_times(&ws.kws.jac, v, &mut ws.x);
        self.spec
            .task
            .apply_linear(s, &ws.x, &mut ws.xg, &mut ws.h, &mut ws.h2);
        let ComposedWorkspace {
            flows,
            a,
            b,
            va,
            vb,
            ..
        } = ws;
        if s.scale != 1.0 {
            self.flow_with_tangent(Factor::Scaling, s.scale.ln(), (q, v), (a, va), flows)?;
        } else {
            a.copy_from_slice(q);
            va.copy_from_slice(v);
        }
        let theta = flow_angle(s.theta);
        if theta != 0.0 {
            self.flow_with_tangent(Factor::Rotation, theta, (a, va), (b, vb), flows)?;
        } else {
            b.copy_from_slice(a);
            vb.copy_from_slice(va);
        }
        if s.reflection == -1 {
            self.reflection.apply(b, q_out);
            self.reflection.apply(vb, v_out);
        } else {
            q_out.copy_from_slice(b);
            v_out.copy_from_slice(vb);
        }
        // Task-space defect at the end point and its horizontal lift. The flow's last
        // field evaluation was regular at `b` (hence at `q_out = ρ b`); a non-regular factor
        // here (not expected) leaves the uncorrected tangent.
        self.kin.jacobian(q_out, &mut ws.kws);
        jacobian_times(&ws.kws.jac, v_out, &mut ws.x);
        for (d, t) in ws.x.iter_mut().zip(&ws.xg) {
            *d = t - *d;
        }
        if self.kin.factor(&mut ws.kws).status == PinvStatus::Regular {
            self.kin.solve(&mut ws.kws, &ws.x, &mut ws.va);
            for (o, d) in v_out.iter_mut().zip(&ws.va) {
                *o += d;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::flow_angle;
    use std::f64::consts::PI;

    #[test]
    fn flow_angle_keeps_the_grid_and_wraps_the_rest() {
        assert_eq!(flow_angle(-PI), -PI);
        assert_eq!(flow_angle(PI), PI);
        assert_eq!(flow_angle(0.3), 0.3);
        for (theta, want) in [
            (1.5 * PI, -0.5 * PI),
            (-1.5 * PI, 0.5 * PI),
            (2.0 * PI + 0.3, 0.3),
            (-4.0 * PI - 0.3, -0.3),
        ] {
            assert!((flow_angle(theta) - want).abs() < 1e-12, "{theta}");
        }
    }
}
