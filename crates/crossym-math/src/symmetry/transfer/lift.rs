//! Lifting task-space symmetries to configuration space (paper Sec. IV-B, eqs. 11–18).
//!
//! For a redundant robot the forward kinematics `f: Q → X` is a smooth submersion
//! away from singularities (A1–A3), so every task velocity has a unique horizontal lift
//! `q̇_H = J⁺(q) ẋ`, `J⁺ = M⁻¹Jᵀ(J M⁻¹Jᵀ)⁻¹` (eqs. 12–13). Lifting a task-space
//! generator `X_X^ξ` gives the horizontal field (eq. 17)
//!
//! `X_Q^ξ(q) = J⁺(q) X_X^ξ(f(q))`,
//!
//! `f`-related to `X_X^ξ` (eq. 15: `J X_Q^ξ = X_X^ξ ∘ f`). Its flow (eq. 18) defines the
//! lifted action `Φ_Q(exp(tξ), q) = γ^Q_ξ(t, q)`, and by naturality of flows
//! `f(Φ_Q(g, q)) = Φ_X(g, f(q))` (eq. 19 of the flows) — which [`LiftedAction`] checks.
//!
//! Conditions reported numerically rather than assumed:
//! - the Lie-bracket condition (eq. 16): `[X_Q^ξ, X_Q^ζ] = X_Q^{[ξ,ζ]}`; since both sides
//!   are `f`-related to `[X_X^ξ, X_X^ζ]`, the difference is vertical, and its size
//!   (the vertical component of `[X_Q^ξ, X_Q^ζ]`) is what [`bracket_condition`] reports;
//! - periodicity: for a periodic task action (SO(2), period 2π) the lifted flow returns to
//!   `q` only if it generates no vertical drift; [`periodicity_drift`] reports the drift;
//! - singularities along the flow: the lifted field is undefined where the pseudo-inverse is
//!   near-singular, and the flow stops there with [`LiftError::Singular`].

use std::cell::RefCell;

use crate::kinematics::{Kinematics, KinematicsWorkspace, PinvStatus};
use crate::symmetry::field::{lie_bracket, VectorField, DEFAULT_FD_STEP};
use crate::symmetry::lie::TaskGroupAction;
use crate::symmetry::transfer::flow::{
    integrate, integrate_through, FlowSettings, FlowSettingsError, FlowStatus, FlowWorkspace,
    VariationalField,
};

/// Errors of the lifted action: the flow could not be carried to the requested element.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum LiftError {
    /// The flow reached a (near-)singular configuration, where `J⁺` is undefined (A3 fails).
    #[error(
        "lifting `{symmetry}`: kinematic singularity reached at flow time {t:.6} of {total:.6}"
    )]
    Singular {
        /// Symmetry name.
        symmetry: String,
        /// Flow time reached.
        t: f64,
        /// Requested flow time.
        total: f64,
    },
    /// The integrator gave up or produced non-finite values.
    #[error("lifting `{symmetry}`: integration failed ({status:?})")]
    Integration {
        /// Symmetry name.
        symmetry: String,
        /// Integrator status.
        status: FlowStatus,
    },
    /// The starting configuration is already singular or non-finite.
    #[error("lifting `{symmetry}`: start configuration is singular or not finite")]
    BadStart {
        /// Symmetry name.
        symmetry: String,
    },
}

/// The horizontally lifted field `X_Q(q) = J⁺(q) X_X(f(q))` (eq. 17) of a task field.
///
/// Undefined (returns `false`) where the pseudo-inverse is not [`PinvStatus::Regular`].
/// Uses interior scratch (a `RefCell`, no lock): one instance per thread.
pub struct LiftedField<'a, F: VectorField> {
    kin: &'a Kinematics,
    task: F,
    scratch: ScratchCell<'a>,
}

/// The scratch of a [`LiftedField`] held by the field, or borrowed from a caller-owned
/// [`LiftFieldScratch`] (a field built per call without allocating).
enum ScratchCell<'a> {
    Owned(Box<RefCell<LiftScratch>>),
    Borrowed(&'a RefCell<LiftScratch>),
}

impl ScratchCell<'_> {
    fn cell(&self) -> &RefCell<LiftScratch> {
        match self {
            Self::Owned(c) => c,
            Self::Borrowed(c) => c,
        }
    }
}

/// Caller-owned scratch for [`LiftedField::with_scratch`]: allocate once (setup), then
/// build a lifted field per call at no allocation (the control tick).
#[derive(Debug, Clone)]
pub struct LiftFieldScratch(RefCell<LiftScratch>);

impl LiftFieldScratch {
    /// Scratch sized for `kin`.
    pub fn new(kin: &Kinematics) -> Self {
        Self(RefCell::new(LiftScratch::new(kin)))
    }
}

/// Interior scratch of a [`LiftedField`] (allocated once in [`LiftedField::new`]).
#[derive(Debug, Clone)]
struct LiftScratch {
    ws: KinematicsWorkspace,
    /// Task velocity `v(f(q))`, then the residual `r` of the derivative (m).
    xdot: Vec<f64>,
    /// `J δ` and the task field's derivative along it (m).
    xp: Vec<f64>,
    vp: Vec<f64>,
    /// Multiplier `u = S⁻¹ v` (m).
    u: Vec<f64>,
    /// `J'ᵀ u`, then `g = M⁻¹ J'ᵀ u` (n).
    jtu: Vec<f64>,
    g: Vec<f64>,
    /// Probe point of the task field's central difference (m).
    probe: Vec<f64>,
}

impl LiftScratch {
    fn new(kin: &Kinematics) -> Self {
        let (m, n) = (kin.task_dim(), kin.dof());
        Self {
            ws: kin.workspace(),
            xdot: vec![0.0; m],
            xp: vec![0.0; m],
            vp: vec![0.0; m],
            u: vec![0.0; m],
            jtu: vec![0.0; n],
            g: vec![0.0; n],
            probe: vec![0.0; m],
        }
    }
}

impl<'a, F: VectorField> LiftedField<'a, F> {
    /// Lifts `task` (a field on `X`, `task.dim() == kin.task_dim()`) through `kin`.
    pub fn new(kin: &'a Kinematics, task: F) -> Self {
        let scratch = ScratchCell::Owned(Box::new(RefCell::new(LiftScratch::new(kin))));
        Self::build(kin, task, scratch)
    }

    /// Lifts `task` through `kin` using the caller's `scratch` (sized for `kin`): builds
    /// the field without allocating.
    pub fn with_scratch(kin: &'a Kinematics, task: F, scratch: &'a LiftFieldScratch) -> Self {
        Self::build(kin, task, ScratchCell::Borrowed(&scratch.0))
    }

    fn build(kin: &'a Kinematics, task: F, scratch: ScratchCell<'a>) -> Self {
        assert_eq!(
            task.dim(),
            kin.task_dim(),
            "task field dimension differs from dim X"
        );
        Self { kin, task, scratch }
    }

    /// The task-space field being lifted.
    pub fn task_field(&self) -> &F {
        &self.task
    }
}

impl<F: VectorField> VectorField for LiftedField<'_, F> {
    fn dim(&self) -> usize {
        self.kin.dof()
    }
    fn eval(&self, q: &[f64], out: &mut [f64]) -> bool {
        if q.iter().any(|v| !v.is_finite()) {
            return false;
        }
        let mut s = self.scratch.cell().borrow_mut();
        let LiftScratch { ws, xdot, .. } = &mut *s;
        self.kin.jacobian(q, ws);
        if !self.task.eval(ws.x.as_slice(), xdot) {
            return false;
        }
        let report = self.kin.factor(ws);
        if report.status != PinvStatus::Regular {
            return false;
        }
        self.kin.solve(ws, xdot, out);
        true
    }

    /// Closed form of `dX_Q|_q δ` for `X_Q = W Jᵀ u`, `u = S⁻¹ v(f(q))`,
    /// `S = J W Jᵀ + λ²I`, `W = M⁻¹`: with `J' = dJ[δ]`, `g = W J'ᵀ u`,
    ///
    /// `dX_Q δ = g + W Jᵀ S⁻¹ (dv[J δ] − J' X_Q − J g)`
    ///
    /// (the derivative of `S⁻¹` is `−S⁻¹ S' S⁻¹` with `S' = J' W Jᵀ + J W J'ᵀ`). One FK,
    /// Jacobian and factorisation serve both `X_Q` and its derivative. The task field's
    /// derivative is its own closed form, or a central difference along `J δ`.
    fn eval_derivative(
        &self,
        q: &[f64],
        delta: &[f64],
        out: &mut [f64],
        out_d: &mut [f64],
    ) -> Option<bool> {
        if q.iter().chain(delta).any(|v| !v.is_finite()) {
            return Some(false);
        }
        let mut s = self.scratch.cell().borrow_mut();
        let LiftScratch {
            ws,
            xdot,
            xp,
            vp,
            u,
            jtu,
            g,
            probe,
        } = &mut *s;
        let kin = self.kin;
        kin.jacobian(q, ws);
        let (m, n) = (xp.len(), out.len());
        jacobian_times(&ws.jac, delta, xp);
        // v(f(q)) and dv[J δ]: closed form, or a central difference along J δ.
        let x = ws.x.as_slice();
        if self.task.eval_derivative(x, xp, xdot, vp).is_none() {
            if !self.task.eval(x, xdot) {
                return Some(false);
            }
            if !central_difference(&self.task, x, xp, probe, vp, u) {
                return Some(false);
            }
        }
        if kin.factor(ws).status != PinvStatus::Regular {
            return Some(false);
        }
        kin.solve(ws, xdot, out);
        u.copy_from_slice(kin.pinv().multiplier(&ws.pinv));
        kin.jacobian_derivative(delta, ws);
        // Column-major slices of J and J' (entry (r, c) at r + c·m).
        let (jac, jdot) = (ws.jac.as_slice(), ws.jac_dot.as_slice());
        // g = W J'ᵀ u; r = dv[Jδ] − J' X − J g (into xdot); out_d = g + W Jᵀ S⁻¹ r.
        for (t, col) in jtu.iter_mut().zip(jdot.chunks_exact(m)) {
            *t = col.iter().zip(u.iter()).map(|(a, b)| a * b).sum();
        }
        kin.pinv().apply_metric_inverse(jtu, g);
        xdot.copy_from_slice(vp);
        for c in 0..n {
            let (jc, jdc) = (&jac[c * m..(c + 1) * m], &jdot[c * m..(c + 1) * m]);
            let (xc, gc) = (out[c], g[c]);
            for r in 0..m {
                xdot[r] -= jdc[r] * xc + jc[r] * gc;
            }
        }
        kin.solve(ws, xdot, out_d);
        for (o, gi) in out_d.iter_mut().zip(g.iter()) {
            *o += gi;
        }
        Some(true)
    }
}

/// `vp = dv[xp]` at `x` by a central difference along `xp` (`u` takes the second probe's
/// value); false where the task field is undefined at a probe.
fn central_difference<F: VectorField>(
    task: &F,
    x: &[f64],
    xp: &[f64],
    probe: &mut [f64],
    vp: &mut [f64],
    u: &mut [f64],
) -> bool {
    let m = xp.len();
    let norm = xp.iter().map(|a| a * a).sum::<f64>().sqrt();
    if norm == 0.0 {
        vp.fill(0.0);
    } else {
        let xn = x.iter().map(|a| a * a).sum::<f64>().sqrt();
        let h = 1e-5 * xn.max(1.0) / norm;
        // `u` takes the second probe's value (it is computed below).
        for i in 0..m {
            probe[i] = x[i] + h * xp[i];
        }
        if !task.eval(probe, vp) {
            return false;
        }
        for i in 0..m {
            probe[i] = x[i] - h * xp[i];
        }
        if !task.eval(probe, u) {
            return false;
        }
        for i in 0..m {
            vp[i] = (vp[i] - u[i]) / (2.0 * h);
        }
    }
    true
}

/// `out = J v` for the column-major `m × n` task Jacobian (allocation-free; column by
/// column, the order every caller relies on for identical rounding).
pub(crate) fn jacobian_times(j: &nalgebra::DMatrix<f64>, v: &[f64], out: &mut [f64]) {
    let m = j.nrows();
    out.fill(0.0);
    for (col, &vc) in j.as_slice().chunks_exact(m).zip(v) {
        for (o, x) in out.iter_mut().zip(col) {
            *o += x * vc;
        }
    }
}

/// Called with `(i, q_i, q̇_i)` at each checkpoint `t_i` of an orbit (rad, rad/s).
pub type OrbitVisitor<'v> = dyn FnMut(usize, &[f64], &[f64]) + 'v;

/// Scratch for [`LiftedAction`] (allocates once).
#[derive(Debug, Clone)]
pub struct LiftWorkspace {
    flow: FlowWorkspace,
    var: FlowWorkspace,
    y0: Vec<f64>,
}

/// Why a task-space action cannot be lifted ([`LiftedAction::new`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LiftSetupError {
    /// The flow settings are invalid.
    #[error(transparent)]
    Flow {
        /// What is wrong with them.
        #[from]
        source: FlowSettingsError,
    },
    /// The action's space is not the robot's task space.
    #[error(
        "symmetry `{symmetry}` acts on R^{acts_on} but the robot's task space is R^{task_dim}"
    )]
    Dimension {
        /// Symmetry name.
        symmetry: String,
        /// Dimension of the space it acts on.
        acts_on: usize,
        /// The robot's task-space dimension.
        task_dim: usize,
    },
}

/// Lifted action `Φ_Q(exp(ξ), q)` of a task-space Lie group action (eq. 18).
pub struct LiftedAction<'a> {
    kin: &'a Kinematics,
    action: &'a dyn TaskGroupAction,
    settings: FlowSettings,
}

impl<'a> LiftedAction<'a> {
    /// Lifts `action` (acting on `X = R^{kin.task_dim()}`) through `kin`.
    pub fn new(
        kin: &'a Kinematics,
        action: &'a dyn TaskGroupAction,
        settings: FlowSettings,
    ) -> Result<Self, LiftSetupError> {
        settings.validate()?;
        if action.dim() != kin.task_dim() {
            return Err(LiftSetupError::Dimension {
                symmetry: action.name().into(),
                acts_on: action.dim(),
                task_dim: kin.task_dim(),
            });
        }
        Ok(Self {
            kin,
            action,
            settings,
        })
    }

    /// The task-space action being lifted.
    pub fn task_action(&self) -> &dyn TaskGroupAction {
        self.action
    }

    /// The robot.
    pub fn kinematics(&self) -> &Kinematics {
        self.kin
    }

    /// Scratch sized for this robot.
    pub fn workspace(&self) -> LiftWorkspace {
        let n = self.kin.dof();
        LiftWorkspace {
            flow: FlowWorkspace::new(n),
            var: FlowWorkspace::new(2 * n),
            y0: vec![0.0; 2 * n],
        }
    }

    fn outcome(&self, status: FlowStatus, total: f64) -> Result<FlowStatus, LiftError> {
        match status {
            FlowStatus::Done { .. } => Ok(status),
            FlowStatus::FieldUndefined { t: 0.0 } => Err(LiftError::BadStart {
                symmetry: self.action.name().to_string(),
            }),
            FlowStatus::FieldUndefined { t } => Err(LiftError::Singular {
                symmetry: self.action.name().to_string(),
                t,
                total,
            }),
            other => Err(LiftError::Integration {
                symmetry: self.action.name().to_string(),
                status: other,
            }),
        }
    }

    /// `q_out = Φ_Q(exp(ξ), q)`: the flow of `X_Q^ξ` for unit time.
    pub fn act(
        &self,
        xi: &[f64],
        q: &[f64],
        q_out: &mut [f64],
        ws: &mut LiftWorkspace,
    ) -> Result<FlowStatus, LiftError> {
        let field = LiftedField::new(self.kin, self.action.generator_field(xi));
        let st = integrate(&field, 1.0, q, q_out, &self.settings, &mut ws.flow);
        self.outcome(st, 1.0)
    }

    /// `q_out = Φ_Q(exp(ξ), q)` and `qdot_out = dΦ_Q|_q q̇` (variational equation).
    pub fn act_with_differential(
        &self,
        xi: &[f64],
        q: &[f64],
        qdot: &[f64],
        q_out: &mut [f64],
        qdot_out: &mut [f64],
        ws: &mut LiftWorkspace,
    ) -> Result<FlowStatus, LiftError> {
        self.act_with_differential_through(xi, &[1.0], q, qdot, ws, &mut |_, qa, va| {
            q_out.copy_from_slice(qa);
            qdot_out.copy_from_slice(va);
        })
    }

    /// `Φ_Q(exp(t_i ξ), q)` and `dΦ_Q|_q q̇` for every `t_i` of `ts`, from one integration
    /// of the flow of `X_Q^ξ` through the checkpoints `t_i` (one side of 0, `|t_i|`
    /// non-decreasing; see [`integrate_through`]): calls `visit(i, q_i, q̇_i)` for each
    /// one reached, so an orbit `θ = 30°, 60°, …` costs one flow to its last angle.
    /// On an error every checkpoint before the failure has been visited.
    pub fn act_with_differential_through(
        &self,
        xi: &[f64],
        ts: &[f64],
        q: &[f64],
        qdot: &[f64],
        ws: &mut LiftWorkspace,
        visit: &mut OrbitVisitor<'_>,
    ) -> Result<FlowStatus, LiftError> {
        let n = self.kin.dof();
        let field = LiftedField::new(self.kin, self.action.generator_field(xi));
        // The lifted field has a closed-form derivative (`eval_derivative`), so the
        // difference step is never used; step control on the positions (the tangent
        // follows their steps).
        let var = VariationalField::new(&field, DEFAULT_FD_STEP);
        ws.y0[..n].copy_from_slice(q);
        ws.y0[n..].copy_from_slice(qdot);
        let settings = FlowSettings {
            error_dims: Some(n),
            ..self.settings
        };
        let st = integrate_through(&var, ts, &ws.y0, &settings, &mut ws.var, &mut |i, y| {
            visit(i, &y[..n], &y[n..])
        });
        self.outcome(st, ts.last().copied().unwrap_or(0.0))
    }

    /// Equivariance residual `‖f(Φ_Q(g, q)) − Φ_X(g, f(q))‖` (eq. 19) for `g = exp(ξ)`.
    pub fn equivariance_residual(
        &self,
        xi: &[f64],
        q: &[f64],
        ws: &mut LiftWorkspace,
    ) -> Result<f64, LiftError> {
        let n = self.kin.dof();
        let m = self.kin.task_dim();
        let mut q_out = vec![0.0; n];
        self.act(xi, q, &mut q_out, ws)?;
        let mut kws = self.kin.workspace();
        let x0 = self.kin.forward(q, &mut kws).clone();
        let x1 = self.kin.forward(&q_out, &mut kws).clone();
        let mut gx = vec![0.0; m];
        if !self.action.act_on(xi, x0.as_slice(), &mut gx) {
            return Ok(f64::INFINITY);
        }
        Ok(x1
            .iter()
            .zip(&gx)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt())
    }
}

/// Outcome of the Lie-bracket condition (eq. 16) at sampled configurations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BracketReport {
    /// Max norm of the vertical component `N [X_Q^ξ, X_Q^ζ]` (`N = I − J⁺J`), in rad per unit time².
    pub vertical: f64,
    /// The same relative to `max ‖X_Q^ξ‖ · max ‖X_Q^ζ‖` (a bracket scales like the product
    /// of the fields per radian), so that it does not depend on the fields' magnitudes.
    pub vertical_relative: f64,
    /// Max `‖[X_Q^ξ, X_Q^ζ] − X_Q^{[ξ,ζ]}‖` with the task bracket lifted (eq. 16 residual).
    pub residual: f64,
    /// Max `‖J [X_Q^ξ, X_Q^ζ] − [X_X^ξ, X_X^ζ]‖` (f-relatedness of brackets; should be ~0).
    pub horizontal_mismatch: f64,
    /// Configurations evaluated (singular ones skipped).
    pub samples: usize,
}

/// Evaluates eq. 16 for two task fields at the given configurations (analysis; allocates).
pub fn bracket_condition(
    kin: &Kinematics,
    a: &dyn VectorField,
    b: &dyn VectorField,
    configs: &[Vec<f64>],
    h: f64,
) -> BracketReport {
    let n = kin.dof();
    let m = kin.task_dim();
    let la = LiftedField::new(kin, a);
    let lb = LiftedField::new(kin, b);
    let mut ws = kin.workspace();
    let (mut bq, mut bx, mut lifted, mut jb) =
        (vec![0.0; n], vec![0.0; m], vec![0.0; n], vec![0.0; m]);
    let mut out = BracketReport {
        vertical: 0.0,
        vertical_relative: 0.0,
        residual: 0.0,
        horizontal_mismatch: 0.0,
        samples: 0,
    };
    let (mut max_a, mut max_b): (f64, f64) = (0.0, 0.0);
    let (mut va, mut vb) = (vec![0.0; n], vec![0.0; n]);
    for q in configs {
        if la.eval(q, &mut va) && lb.eval(q, &mut vb) {
            max_a = max_a.max(va.iter().map(|v| v * v).sum::<f64>().sqrt());
            max_b = max_b.max(vb.iter().map(|v| v * v).sum::<f64>().sqrt());
        }
        if !lie_bracket(&la, &lb, q, h, &mut bq) {
            continue;
        }
        kin.jacobian(q, &mut ws);
        let x = ws.x.clone();
        if !lie_bracket(a, b, x.as_slice(), h, &mut bx) {
            continue;
        }
        if kin.factor(&mut ws).status != PinvStatus::Regular {
            continue;
        }
        kin.solve(&mut ws, &bx, &mut lifted);
        // J [X_Q^a, X_Q^b] and the horizontal part J⁺ J [..].
        for (r, o) in jb.iter_mut().enumerate() {
            *o = (0..n).map(|c| ws.jac[(r, c)] * bq[c]).sum();
        }
        let mut horiz = vec![0.0; n];
        kin.solve(&mut ws, &jb, &mut horiz);
        let vert = bq
            .iter()
            .zip(&horiz)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt();
        let resid = bq
            .iter()
            .zip(&lifted)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt();
        let hm = jb
            .iter()
            .zip(&bx)
            .map(|(x, y)| (x - y) * (x - y))
            .sum::<f64>()
            .sqrt();
        out.vertical = out.vertical.max(vert);
        out.residual = out.residual.max(resid);
        out.horizontal_mismatch = out.horizontal_mismatch.max(hm);
        out.samples += 1;
    }
    let scale = max_a * max_b;
    out.vertical_relative = if scale > 0.0 {
        out.vertical / scale
    } else {
        out.vertical
    };
    out
}

/// Drift `‖Φ_Q(exp(T ξ), q) − q‖` after one task-space period `T` (e.g. 2π for SO(2)),
/// with revolute/continuous joint differences wrapped to (−π, π].
pub fn periodicity_drift(
    lifted: &LiftedAction<'_>,
    xi_period: &[f64],
    q: &[f64],
    ws: &mut LiftWorkspace,
) -> Result<f64, LiftError> {
    let mut out = vec![0.0; q.len()];
    lifted.act(xi_period, q, &mut out, ws)?;
    let limits = lifted.kinematics().limits();
    Ok(out
        .iter()
        .zip(q)
        .zip(limits)
        .map(|((a, b), l)| {
            let d = a - b;
            // Joints with a span of at least 2π are angles on a circle: wrap.
            let d = if l.upper - l.lower >= std::f64::consts::TAU - 1e-9 {
                wrap_angle(d)
            } else {
                d
            };
            d * d
        })
        .sum::<f64>()
        .sqrt())
}

/// Wraps an angle difference to (−π, π].
pub fn wrap_angle(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let r = a.rem_euclid(t);
    if r > std::f64::consts::PI {
        r - t
    } else {
        r
    }
}
