//! Canonical task-space features: the end-effector positions mapped back by the inverse
//! of the conditioning group element, `x̃ = g(s)⁻¹ · f(q)` (paper eqs. 7, 23).
//!
//! For the letter task `g(s) = ρ_X(σ) ∘ Φ_R(θ) ∘ Φ_S(ln λ)` acts on `X` (the composition
//! order of eq. 23), so
//!
//! `x̃ = Φ_S(−ln λ, Φ_R(−θ, ρ_X(σ)⁻¹ f(q)))`.
//!
//! Every transformed demonstration then lands on its original letter: the network sees
//! where the pen is *on the letter* whatever rotation, scaling or mirror the condition asks
//! for, alongside the joint positions and the condition itself. By equivariance of `f`
//! (`f(Φ^Q_g q) = Φ^X_g f(q)`, eq. 7) this is a function of `(q, s)` only, so the policy
//! is still `π(q, s)`.
//!
//! Each continuous factor is a one-parameter affine group `exp(t H)`,
//! `H = [[A, b], [0, 0]]` (the infinitesimal generator `x ↦ A x + b`, eq. 2), evaluated in
//! closed form from `H`'s minimal polynomial, checked numerically when the map is built:
//!
//! - rotations, `H³ = −H`: `exp(tH) = I + sin t H + (1 − cos t) H²` (Rodrigues);
//! - scalings, `H² = H`: `exp(tH) = I + (eᵗ − 1) H`;
//! - translations, `H² = 0`: `exp(tH) = I + t H`.
//!
//! `f` is evaluated with the robot's chains stored as [`ChainFactors`], so a policy file
//! carries its own FK and needs no URDF at run time. Everything per call is
//! allocation-free, with a caller-owned [`TaskFeatureWorkspace`].

use super::error::PolicyFitError;
use serde::{Deserialize, Serialize};

use crossym_math::kinematics::{Chain, ChainFactors, ChainWorkspace, Kinematics};
use crossym_math::symmetry::built::BuiltSymmetry;
use crossym_math::symmetry::compose::Condition;

use crossym_math::symmetry::affine::max_diff;
use crossym_math::symmetry::affine::CanonicalMap;

/// One chain of the policy's FK: where it reads `q`, and its factors.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskChain {
    /// Index of the chain's first joint in `q`.
    pub q_offset: usize,
    /// The chain's FK (base frame of the chain; m or rad).
    pub factors: ChainFactors,
}

/// Everything the canonical features need, as stored in the policy sidecar.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskFeatureSpec {
    /// The chains whose task points form `x = f(q)`, in the order of `X`.
    pub chains: Vec<TaskChain>,
    /// `x ↦ g(s)⁻¹ x`.
    pub map: CanonicalMap,
    /// Mean of `x̃` over the training samples (m).
    pub mean: Vec<f64>,
    /// Std of `x̃` over the training samples, floored at [`super::STD_FLOOR`] (m).
    pub std: Vec<f64>,
}

/// Canonical task-space features ready to evaluate: the spec plus its rebuilt chains.
#[derive(Debug, Clone)]
pub struct TaskFeatures {
    spec: TaskFeatureSpec,
    chains: Vec<Chain>,
}

impl PartialEq for TaskFeatures {
    fn eq(&self, other: &Self) -> bool {
        self.spec == other.spec
    }
}

/// Scratch state of [`TaskFeatures::encode`].
#[derive(Debug, Clone)]
pub struct TaskFeatureWorkspace {
    chains: Vec<ChainWorkspace>,
    x: Vec<f64>,
    xt: Vec<f64>,
    h: Vec<f64>,
    h2: Vec<f64>,
}

impl TaskFeatureWorkspace {
    /// Total number of `f64` scratch values held (for checking that it never grows).
    pub fn capacity(&self) -> usize {
        self.x.capacity() + self.xt.capacity() + self.h.capacity() + self.h2.capacity()
    }
}

impl TaskFeatures {
    /// Features for `kin`'s chains and the group `order` of `built`, with the identity
    /// normalisation (fit it with [`TaskFeatures::fit`]).
    pub fn for_robot(
        kin: &Kinematics,
        built: &[BuiltSymmetry],
        order: &[String],
    ) -> Result<Self, PolicyFitError> {
        Self::for_robot_inner(kin, built, order).map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::for_robot`], failing with a message.
    fn for_robot_inner(
        kin: &Kinematics,
        built: &[BuiltSymmetry],
        order: &[String],
    ) -> Result<Self, String> {
        let map = CanonicalMap::from_symmetries(kin, built, order).map_err(|e| e.to_string())?;
        let chains = kin
            .chains()
            .iter()
            .enumerate()
            .map(|(i, c)| TaskChain {
                q_offset: kin.q_offset(i),
                factors: c.factors(),
            })
            .collect();
        let m = map.dim;
        Ok(Self::new(TaskFeatureSpec {
            chains,
            map,
            mean: vec![0.0; m],
            std: vec![1.0; m],
        })?)
    }

    /// Keeps only the factors of the sub-group the policy is trained on (`Original`: none,
    /// so `x̃ = f(q)`; `G_R`: the rotation; `G_RT`: rotation and scaling; `G_MRT`: all): a
    /// policy trained without a symmetry must not have it undone in its inputs either.
    pub fn restrict_to(&mut self, group: crate::grid::SubGroup) {
        use crate::grid::SubGroup;
        let map = &mut self.spec.map;
        if group != SubGroup::MRT {
            map.reflection = None;
        }
        if matches!(group, SubGroup::Identity | SubGroup::R) {
            map.scaling = None;
        }
        if group == SubGroup::Identity {
            map.rotation = None;
        }
    }

    /// Rebuilds the chains of `spec` and checks it; says what is wrong.
    pub fn new(spec: TaskFeatureSpec) -> Result<Self, PolicyFitError> {
        Self::new_inner(spec).map_err(PolicyFitError::features)
    }

    // The checks of [`Self::new`], failing with a message.
    fn new_inner(spec: TaskFeatureSpec) -> Result<Self, String> {
        spec.map.validate().map_err(|e| format!("map: {e}"))?;
        let m = spec.map.dim;
        let chains: Vec<Chain> = spec
            .chains
            .iter()
            .enumerate()
            .map(|(i, c)| Chain::from_factors(&c.factors).map_err(|e| format!("chain {i}: {e}")))
            .collect::<Result<_, _>>()?;
        let sum: usize = chains.iter().map(|c| c.task.dim()).sum();
        if sum != m {
            return Err(format!(
                "the chains give {sum} task coordinates, the map acts on {m}"
            ));
        }
        if spec.mean.len() != m || spec.std.len() != m {
            return Err(format!(
                "normalisation has {} means and {} stds for {m} coordinates",
                spec.mean.len(),
                spec.std.len()
            ));
        }
        if let Some(j) = spec.mean.iter().position(|v| !v.is_finite()) {
            return Err(format!("mean[{j}] is not finite"));
        }
        if let Some(j) = spec.std.iter().position(|v| !(v.is_finite() && *v > 0.0)) {
            return Err(format!(
                "std[{j}] = {} must be positive and finite",
                spec.std[j]
            ));
        }
        Ok(Self { spec, chains })
    }

    /// The stored description.
    pub fn spec(&self) -> &TaskFeatureSpec {
        &self.spec
    }

    /// Number of features `m` (the task-space dimension).
    pub fn dim(&self) -> usize {
        self.spec.map.dim
    }

    /// Number of joints read: one past the highest joint any chain reads.
    pub fn joints_read(&self) -> usize {
        self.spec
            .chains
            .iter()
            .zip(&self.chains)
            .map(|(t, c)| t.q_offset + c.dof())
            .max()
            .unwrap_or(0)
    }

    /// Checks that the stored FK is `kin`'s: same task dimension and the same `f(q)` to
    /// 1e-9 (m) at zero and at 16 pseudo-random configurations within ±π; says where not.
    pub fn check_kinematics(&self, kin: &Kinematics) -> Result<(), PolicyFitError> {
        self.check_kinematics_inner(kin)
            .map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::check_kinematics`], failing with a message.
    fn check_kinematics_inner(&self, kin: &Kinematics) -> Result<(), String> {
        if kin.task_dim() != self.dim() || kin.dof() < self.joints_read() {
            return Err(format!(
                "the policy's FK reads {} joints into {} task coordinates, the robot has {} \
                 joints and {}",
                self.joints_read(),
                self.dim(),
                kin.dof(),
                kin.task_dim()
            ));
        }
        let mut kw = kin.workspace();
        let mut fw = self.workspace();
        let mut q = vec![0.0; kin.dof()];
        for k in 0..17u32 {
            for (j, v) in q.iter_mut().enumerate() {
                // A fixed, irrational-step sequence in (−π, π): no RNG needed.
                let u = ((k as f64 + 1.0) * 0.618_033_988_75 + j as f64 * 0.414_213_562_37).fract();
                *v = if k == 0 {
                    0.0
                } else {
                    (2.0 * u - 1.0) * std::f64::consts::PI
                };
            }
            let want = kin.forward(&q, &mut kw);
            let got = self.forward(&q, &mut fw);
            let err = max_diff(got, want.as_slice());
            if err.is_nan() || err > 1e-9 {
                return Err(format!(
                    "the policy's FK differs from the robot's by {err:.2e} at q = {q:?}: it \
                     was trained on another robot geometry"
                ));
            }
        }
        Ok(())
    }

    /// A workspace for [`TaskFeatures::encode`] (allocates; setup only).
    pub fn workspace(&self) -> TaskFeatureWorkspace {
        let m = self.dim();
        TaskFeatureWorkspace {
            chains: self.chains.iter().map(Chain::workspace).collect(),
            x: vec![0.0; m],
            xt: vec![0.0; m],
            h: vec![0.0; m],
            h2: vec![0.0; m],
        }
    }

    /// `x = f(q)` into the workspace and returned (m, chain base frames).
    pub fn forward<'w>(&self, q: &[f64], ws: &'w mut TaskFeatureWorkspace) -> &'w [f64] {
        let mut xo = 0;
        for ((t, c), cw) in self
            .spec
            .chains
            .iter()
            .zip(&self.chains)
            .zip(&mut ws.chains)
        {
            c.forward(&q[t.q_offset..t.q_offset + c.dof()], cw);
            let d = c.task.dim();
            c.task_point(cw, &mut ws.x[xo..xo + d]);
            xo += d;
        }
        &ws.x
    }

    /// Un-normalised canonical point `x̃ = g(s)⁻¹ f(q)` (m) into `out`.
    pub fn canonical(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut TaskFeatureWorkspace,
    ) {
        self.forward(q, ws);
        let TaskFeatureWorkspace { x, h, h2, .. } = ws;
        self.spec.map.apply_inverse(s, x, out, h, h2);
    }

    /// The network's features `(x̃ − mean) ⊘ std` into `out` (length `m`). Allocation-free.
    #[inline]
    pub fn encode(&self, q: &[f64], s: &Condition, out: &mut [f64], ws: &mut TaskFeatureWorkspace) {
        self.forward(q, ws);
        // Borrow the point out of the workspace (an empty Vec does not allocate).
        let x = std::mem::take(&mut ws.x);
        self.encode_at(&x, s, out, ws);
        ws.x = x;
    }

    /// [`TaskFeatures::encode`] from a task point `x = f(q)` (m, the stacked chain points in
    /// their base frames, as `KinematicsWorkspace::x`) the caller has already computed:
    /// the node's tick reuses the FK of its safety filter. Allocation-free.
    #[inline]
    pub fn encode_at(
        &self,
        x: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut TaskFeatureWorkspace,
    ) {
        debug_assert_eq!(x.len(), self.dim(), "task point length");
        let TaskFeatureWorkspace { xt, h, h2, .. } = ws;
        self.spec.map.apply_inverse(s, x, xt, h, h2);
        for (j, o) in out.iter_mut().enumerate() {
            *o = (xt[j] - self.spec.mean[j]) / self.spec.std[j];
        }
    }

    /// The affine map `x ↦ (g(s)⁻¹ x − mean) ⊘ std` as `(E, e)`, `E` row-major `m × m`:
    /// what training applies to its differentiable FK. Allocates.
    pub fn affine_for(&self, s: &Condition) -> (Vec<f64>, Vec<f64>) {
        let m = self.dim();
        let (mut h, mut h2) = (vec![0.0; m], vec![0.0; m]);
        let mut e = vec![0.0; m];
        self.spec
            .map
            .apply_inverse(s, &vec![0.0; m], &mut e, &mut h, &mut h2);
        let mut big = vec![0.0; m * m];
        let mut col = vec![0.0; m];
        for j in 0..m {
            let mut u = vec![0.0; m];
            u[j] = 1.0;
            self.spec
                .map
                .apply_inverse(s, &u, &mut col, &mut h, &mut h2);
            for i in 0..m {
                big[i * m + j] = (col[i] - e[i]) / self.spec.std[i];
            }
        }
        for i in 0..m {
            e[i] = (e[i] - self.spec.mean[i]) / self.spec.std[i];
        }
        (big, e)
    }

    /// Fits the normalisation of `x̃` over every sample of `data` (mean and std, floored at
    /// [`super::STD_FLOOR`]).
    pub fn fit<'a>(
        &mut self,
        data: impl IntoIterator<Item = (&'a crate::trajectory::JointTrajectory, Condition)>,
    ) -> Result<(), PolicyFitError> {
        self.fit_inner(data).map_err(PolicyFitError::robot)
    }

    // The checks of [`Self::fit`], failing with a message.
    fn fit_inner<'a>(
        &mut self,
        data: impl IntoIterator<Item = (&'a crate::trajectory::JointTrajectory, Condition)>,
    ) -> Result<(), String> {
        let m = self.dim();
        let mut ws = self.workspace();
        let mut xt = vec![0.0; m];
        let mut all = Vec::new();
        for (t, s) in data {
            if t.n < self.joints_read() {
                return Err(format!(
                    "demonstration {} has {} joints, the features read {}",
                    t.demo,
                    t.n,
                    self.joints_read()
                ));
            }
            self.spec.map.supports(&s).map_err(|e| e.to_string())?;
            for i in 0..t.len() {
                self.canonical(t.q(i), &s, &mut xt, &mut ws);
                all.extend_from_slice(&xt);
            }
        }
        let count = all.len() / m;
        if count == 0 {
            return Err("no samples to fit the task features on".into());
        }
        let c = count as f64;
        let mut mean = vec![0.0; m];
        for row in all.chunks_exact(m) {
            for j in 0..m {
                mean[j] += row[j] / c;
            }
        }
        let mut var = vec![0.0; m];
        for row in all.chunks_exact(m) {
            for j in 0..m {
                var[j] += (row[j] - mean[j]).powi(2) / c;
            }
        }
        self.spec.std = var.iter().map(|v| v.sqrt().max(super::STD_FLOOR)).collect();
        self.spec.mean = mean;
        if self.spec.mean.iter().any(|v| !v.is_finite()) {
            return Err("the canonical task points are not finite".into());
        }
        Ok(())
    }
}
