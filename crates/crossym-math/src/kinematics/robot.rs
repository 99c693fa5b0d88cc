//! Multi-chain robot kinematics: `Q = Q_1 × … × Q_k`, `X = X_1 × … × X_k`.
//!
//! The stacked forward map is `f(q) = (f_1(q_1), …, f_k(q_k))` and its task
//! Jacobian is block-diagonal, `J = diag(J_1, …, J_k)` (paper Sec. VI-A: the planar
//! dual arm with `Q = T⁴ × T⁴`, `X = R² × R²`; Example 1: RB-Y1 with `X = R³ × R³`).
//! The horizontal lift `X_Q(q) = J⁺(q) X_X(f(q))` (eq. 17) uses the configured metric
//! over the whole of `Q`, so a non-block-diagonal `M` couples the arms.

use std::collections::HashMap;
use std::sync::Arc;

use nalgebra::{DMatrix, DVector};

use super::chain::{Chain, ChainSpec, ChainWorkspace};
use super::error::KinematicsError;
use super::model::{JointLimits, RobotModel};
use super::pinv::{DampedPinv, JacobianBlock, Metric, PinvReport, PinvWorkspace};

/// Settings of the lift: damping `λ`, metric `M`, singularity threshold.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KinematicsSettings {
    /// Damping `λ ≥ 0` of eq. 13 (task units). `0` gives the exact horizontal lift.
    #[serde(default)]
    pub damping: f64,
    /// Diagonal of a constant metric `M` (one positive entry per joint); identity when absent.
    #[serde(default)]
    pub metric_diagonal: Option<Vec<f64>>,
    /// Manipulability `√det(J M⁻¹ Jᵀ)` below which a configuration counts as near-singular.
    #[serde(default = "default_singular")]
    pub singular_manipulability: f64,
}

fn default_singular() -> f64 {
    1e-6
}

impl Default for KinematicsSettings {
    fn default() -> Self {
        Self {
            damping: 0.0,
            metric_diagonal: None,
            singular_manipulability: default_singular(),
        }
    }
}

/// A robot as a stack of serial chains with its pseudo-inverse settings.
#[derive(Debug, Clone)]
pub struct Kinematics {
    /// Robot name from the URDF.
    pub robot: String,
    chains: Vec<Chain>,
    q_offsets: Vec<usize>,
    x_offsets: Vec<usize>,
    joint_names: Vec<String>,
    limits: Vec<JointLimits>,
    n: usize,
    m: usize,
    pinv: DampedPinv,
    source: Arc<RobotModel>,
    held: HashMap<String, f64>,
}

/// Caller-owned scratch for [`Kinematics`]; create once with [`Kinematics::workspace`].
#[derive(Debug, Clone)]
pub struct KinematicsWorkspace {
    chains: Vec<ChainWorkspace>,
    /// Stacked task-space point `f(q)` after the last FK call.
    pub x: DVector<f64>,
    /// Stacked block-diagonal task Jacobian (m × n) after [`Kinematics::jacobian`].
    pub jac: DMatrix<f64>,
    /// Pseudo-inverse scratch.
    pub pinv: PinvWorkspace,
    /// Stacked `dJ|_q[δ]` (m × n) after [`Kinematics::jacobian_derivative`].
    pub jac_dot: DMatrix<f64>,
}

impl KinematicsWorkspace {
    /// Workspace of chain `i` (tip pose and 6 × n geometric Jacobian after FK/Jacobian).
    pub fn chain(&self, i: usize) -> &ChainWorkspace {
        &self.chains[i]
    }
}

impl Kinematics {
    /// Builds the chains `specs` of `model`, holding joints in `held` fixed (rad or m).
    pub fn new(
        model: &RobotModel,
        specs: &[ChainSpec],
        held: &HashMap<String, f64>,
        settings: &KinematicsSettings,
    ) -> Result<Self, KinematicsError> {
        if specs.is_empty() {
            return Err(KinematicsError::InvalidSetting {
                field: "robot.chains".into(),
                message: "at least one chain is required".into(),
            });
        }
        let mut chains = Vec::with_capacity(specs.len());
        let mut owner: HashMap<String, String> = HashMap::new();
        for spec in specs {
            let chain = Chain::new(model, spec, held)?;
            for j in &chain.joint_names {
                if let Some(first) = owner.insert(j.clone(), chain.name.clone()) {
                    return Err(KinematicsError::SharedJoint {
                        joint: j.clone(),
                        first,
                        second: chain.name.clone(),
                    });
                }
            }
            chains.push(chain);
        }
        let mut q_offsets = Vec::new();
        let mut x_offsets = Vec::new();
        let (mut n, mut m) = (0, 0);
        let mut joint_names = Vec::new();
        let mut limits = Vec::new();
        for c in &chains {
            q_offsets.push(n);
            x_offsets.push(m);
            n += c.dof();
            m += c.task.dim();
            joint_names.extend(c.joint_names.iter().cloned());
            limits.extend(c.limits.iter().copied());
        }
        let metric = match &settings.metric_diagonal {
            None => Metric::identity(n),
            Some(d) if d.len() == n => Metric::diagonal(d)?,
            Some(d) => {
                return Err(KinematicsError::InvalidSetting {
                    field: "kinematics.metric_diagonal".into(),
                    message: format!("has {} entries, the robot has {n} joints", d.len()),
                })
            }
        };
        // Chains share no joint and the metric is diagonal: J and J M⁻¹ Jᵀ are block
        // diagonal, one block per chain, and the pseudo-inverse is computed per chain.
        let blocks = chains
            .iter()
            .enumerate()
            .map(|(i, c)| JacobianBlock {
                rows: x_offsets[i]..x_offsets[i] + c.task.dim(),
                cols: q_offsets[i]..q_offsets[i] + c.dof(),
            })
            .collect();
        let pinv = DampedPinv::new(metric, settings.damping, settings.singular_manipulability)?
            .with_blocks(blocks)?;
        Ok(Self {
            robot: model.name.clone(),
            chains,
            q_offsets,
            x_offsets,
            joint_names,
            limits,
            n,
            m,
            pinv,
            source: Arc::new(model.clone()),
            held: held.clone(),
        })
    }

    /// The URDF tree the chains were built from (whole-body derivations use it).
    pub fn model(&self) -> &RobotModel {
        &self.source
    }

    /// Movable joints outside the chains held at these values (rad or m).
    pub fn held(&self) -> &HashMap<String, f64> {
        &self.held
    }

    /// Joint-space dimension `n = dim Q`.
    pub fn dof(&self) -> usize {
        self.n
    }

    /// Task-space dimension `m = dim X`.
    pub fn task_dim(&self) -> usize {
        self.m
    }

    /// The chains in stacking order.
    pub fn chains(&self) -> &[Chain] {
        &self.chains
    }

    /// Offset of chain `i`'s joints in `q`.
    pub fn q_offset(&self, i: usize) -> usize {
        self.q_offsets[i]
    }

    /// Offset of chain `i`'s coordinates in `x`.
    pub fn x_offset(&self, i: usize) -> usize {
        self.x_offsets[i]
    }

    /// Controlled joint names in `q` order.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// Limits in `q` order.
    pub fn limits(&self) -> &[JointLimits] {
        &self.limits
    }

    /// The same robot with other limits (one per controlled joint, `q` order), e.g. a
    /// tightened envelope; `None` when the count differs.
    pub fn with_limits(mut self, limits: Vec<JointLimits>) -> Option<Self> {
        if limits.len() != self.n {
            return None;
        }
        self.limits = limits;
        Some(self)
    }

    /// The configured pseudo-inverse (metric, damping, threshold).
    pub fn pinv(&self) -> &DampedPinv {
        &self.pinv
    }

    /// A workspace for this robot (allocates; setup only).
    pub fn workspace(&self) -> KinematicsWorkspace {
        KinematicsWorkspace {
            chains: self.chains.iter().map(Chain::workspace).collect(),
            x: DVector::zeros(self.m),
            jac: DMatrix::zeros(self.m, self.n),
            pinv: self.pinv.workspace(self.m),
            jac_dot: DMatrix::zeros(self.m, self.n),
        }
    }

    /// Stacked forward kinematics `x = f(q)` into `ws.x`. Allocation-free.
    pub fn forward<'w>(&self, q: &[f64], ws: &'w mut KinematicsWorkspace) -> &'w DVector<f64> {
        assert_eq!(
            q.len(),
            self.n,
            "robot `{}`: expected {} joint values",
            self.robot,
            self.n
        );
        for (i, c) in self.chains.iter().enumerate() {
            let qi = &q[self.q_offsets[i]..self.q_offsets[i] + c.dof()];
            c.forward(qi, &mut ws.chains[i]);
            let xo = self.x_offsets[i];
            c.task_point(
                &ws.chains[i],
                &mut ws.x.as_mut_slice()[xo..xo + c.task.dim()],
            );
        }
        &ws.x
    }

    /// Forward kinematics and the stacked task Jacobian into `ws.x`, `ws.jac`. Allocation-free.
    pub fn jacobian(&self, q: &[f64], ws: &mut KinematicsWorkspace) {
        assert_eq!(
            q.len(),
            self.n,
            "robot `{}`: expected {} joint values",
            self.robot,
            self.n
        );
        for (i, c) in self.chains.iter().enumerate() {
            let (qo, xo, d) = (self.q_offsets[i], self.x_offsets[i], c.task.dim());
            c.jacobian(&q[qo..qo + c.dof()], &mut ws.chains[i]);
            c.task_point(&ws.chains[i], &mut ws.x.as_mut_slice()[xo..xo + d]);
            let jc = &ws.chains[i].jacobian;
            for col in 0..c.dof() {
                for r in 0..d {
                    ws.jac[(xo + r, qo + col)] = jc[(r, col)];
                }
            }
        }
    }

    /// Directional derivative `dJ|_q[δ]` of the stacked task Jacobian along `δ` (rad or m
    /// per joint) into `ws.jac_dot`, at the `q` of the last [`Kinematics::jacobian`] call
    /// (see [`Chain::position_jacobian_derivative`]). Allocation-free.
    pub fn jacobian_derivative(&self, delta: &[f64], ws: &mut KinematicsWorkspace) {
        debug_assert_eq!(delta.len(), self.n);
        for (i, c) in self.chains.iter().enumerate() {
            let (qo, xo, d) = (self.q_offsets[i], self.x_offsets[i], c.task.dim());
            let cw = &mut ws.chains[i];
            c.position_jacobian_derivative(&delta[qo..qo + c.dof()], cw);
            for col in 0..c.dof() {
                let v = cw.jacobian_dot(col);
                for r in 0..d {
                    ws.jac_dot[(xo + r, qo + col)] = v[r];
                }
            }
        }
    }

    /// Horizontal lift `out = J⁺(q) ẋ` (eqs. 13, 17) at `q`; also leaves `f(q)` in `ws.x`.
    /// Allocation-free.
    pub fn lift(
        &self,
        q: &[f64],
        xdot: &[f64],
        out: &mut [f64],
        ws: &mut KinematicsWorkspace,
    ) -> PinvReport {
        self.jacobian(q, ws);
        let report = self.pinv.factor(&ws.jac, &mut ws.pinv);
        self.pinv.solve(&mut ws.pinv, xdot, out);
        report
    }

    /// Factors the pseudo-inverse of the Jacobian currently in `ws.jac`. Allocation-free.
    pub fn factor(&self, ws: &mut KinematicsWorkspace) -> PinvReport {
        self.pinv.factor(&ws.jac, &mut ws.pinv)
    }

    /// `out = J⁺ v` for the last [`Kinematics::factor`]. Allocation-free.
    pub fn solve(&self, ws: &mut KinematicsWorkspace, v: &[f64], out: &mut [f64]) {
        self.pinv.solve(&mut ws.pinv, v, out);
    }

    /// True when every joint value is inside its position limits.
    pub fn within_limits(&self, q: &[f64]) -> bool {
        q.iter().zip(&self.limits).all(|(&v, l)| l.contains(v))
    }
}
