//! The control-loop policy `π(q, s) → q̇` ([`Policy`]): normaliser, network, optional
//! canonical task features and provenance ([`PolicyMeta`]).

use serde::{Deserialize, Serialize};

use super::inference::MlpInference;
use super::spec::{MlpSpec, MlpWorkspace};
use crate::activation::Activation;
use crate::canonical::{TaskFeatureWorkspace, TaskFeatures};
use crate::error::PolicyError;
use crate::features::{encode_condition, Normalizer, CONDITION_FEATURES};
use crate::train_config::TrainConfig;
use crossym_math::symmetry::compose::Condition;

/// Provenance stored in the sidecar: robot, joints, symmetry, training setup, crate version.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PolicyMeta {
    /// Robot name (free text, e.g. the URDF's robot name).
    pub robot: String,
    /// Joint names in the order of `q` (empty, or exactly `n` names).
    pub joint_names: Vec<String>,
    /// The symmetry the policy was trained with, as given by the caller (free-form).
    pub symmetry: serde_json::Value,
    /// The training configuration, when the policy was trained by `crossym_learn::train::train`.
    pub train_config: Option<TrainConfig>,
    /// Version of `crossym` that created or last saved the policy.
    pub crate_version: String,
    /// For a canonicalised policy `π(q, s) = dΦ_g π₀(Φ_g⁻¹ q)`: the composition `Φ_g` is
    /// built from (this network is `π₀`); `None` for a plain `π(q, s)`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub canonicalised: Option<crossym_math::symmetry::transfer::composed::ComposedSpec>,
    /// For a task-space head `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`
    /// ([`crate::TaskHeadPolicy`]): the group's action on `X` (this network is `h`, over
    /// the task coordinates); `None` otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task_head: Option<crossym_math::symmetry::affine::CanonicalMap>,
}

impl PolicyMeta {
    /// Metadata with the current crate version and no training configuration.
    pub fn new(
        robot: impl Into<String>,
        joint_names: Vec<String>,
        symmetry: serde_json::Value,
    ) -> Self {
        Self {
            robot: robot.into(),
            joint_names,
            symmetry,
            train_config: None,
            crate_version: env!("CARGO_PKG_VERSION").to_string(),
            canonicalised: None,
            task_head: None,
        }
    }
}

impl Default for PolicyMeta {
    fn default() -> Self {
        Self::new("", Vec::new(), serde_json::Value::Null)
    }
}

/// Scratch buffers for [`Policy::velocity`].
#[derive(Debug, Clone)]
pub struct PolicyWorkspace {
    input: Vec<f64>,
    y: Vec<f64>,
    mlp: MlpWorkspace,
    task: Option<TaskFeatureWorkspace>,
}

impl PolicyWorkspace {
    /// Total number of `f64` held (for checking that it never grows).
    pub fn capacity(&self) -> usize {
        self.input.capacity()
            + self.y.capacity()
            + 2 * self.mlp.capacity()
            + self.task.as_ref().map_or(0, TaskFeatureWorkspace::capacity)
    }
}

/// A symmetry-conditioned joint-space policy `π(q, s) → q̇` ready for the control loop.
///
/// Its input is `[ (q − μ) ⊘ σ_q, x̃ features (when it has [`TaskFeatures`]), cos θ, sin θ,
/// ln λ, σ ]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Policy {
    normalizer: Normalizer,
    mlp: MlpInference,
    task: Option<TaskFeatures>,
    /// Provenance (free to edit; checked against `n` when saving and loading).
    pub meta: PolicyMeta,
}

impl Policy {
    /// Couples a normaliser and a network; checks `input = n + 4`, `output = n` and the
    /// joint-name count.
    pub fn new(
        normalizer: Normalizer,
        mlp: MlpInference,
        meta: PolicyMeta,
    ) -> Result<Self, PolicyError> {
        Self::with_task_features(normalizer, mlp, None, meta)
    }

    /// As [`Policy::new`], with canonical task-space features (`input = n + m + 4`).
    pub fn with_task_features(
        normalizer: Normalizer,
        mlp: MlpInference,
        task: Option<TaskFeatures>,
        meta: PolicyMeta,
    ) -> Result<Self, PolicyError> {
        let p = Self {
            normalizer,
            mlp,
            task,
            meta,
        };
        p.check(std::path::Path::new("<memory>"))?;
        Ok(p)
    }

    /// The ensemble of `members` as one policy: the mean of their outputs
    /// ([`MlpInference::average`]). Members must share the normaliser, the task features
    /// and the layer sizes' shape; the first member's metadata is kept.
    pub fn average(members: &[Policy]) -> Result<Self, PolicyError> {
        let bad = |message: String| PolicyError::Config {
            field: "ensemble".into(),
            message,
        };
        let first = members
            .first()
            .ok_or_else(|| bad("an ensemble of no policies".into()))?;
        if let Some(k) = members
            .iter()
            .position(|p| p.normalizer != first.normalizer || p.task != first.task)
        {
            return Err(bad(format!(
                "member {k} has another normaliser or task features than member 0"
            )));
        }
        let nets: Vec<MlpInference> = members.iter().map(|p| p.mlp.clone()).collect();
        let mlp = MlpInference::average(&nets).map_err(|e| bad(e.to_string()))?;
        Self::with_task_features(
            first.normalizer.clone(),
            mlp,
            first.task.clone(),
            first.meta.clone(),
        )
    }

    /// A policy with deterministic pseudo-random weights (tanh, uniform in ±0.2, biases
    /// 0.01) and an identity normaliser: the shape of a real one, for benchmarks and tests.
    /// Not a trained policy.
    pub fn synthetic(n: usize, joint_names: Vec<String>, hidden: &[usize], seed: u64) -> Self {
        Self::synthetic_with(n, joint_names, hidden, seed, None)
    }

    /// [`Policy::synthetic`] with canonical task features (input `n + m + 4`): the shape of
    /// a real one, for benchmarks and tests. Not a trained policy.
    ///
    /// # Panics
    /// When `task` reads more than `n` joints.
    pub fn synthetic_with(
        n: usize,
        joint_names: Vec<String>,
        hidden: &[usize],
        seed: u64,
        task: Option<TaskFeatures>,
    ) -> Self {
        use rand::{Rng, SeedableRng};
        let spec = MlpSpec {
            input: n + 4 + task.as_ref().map_or(0, TaskFeatures::dim),
            hidden: hidden.to_vec(),
            output: n,
            activation: Activation::Tanh,
        };
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let sizes = spec.layer_sizes();
        let weights = sizes
            .windows(2)
            .map(|w| {
                (0..w[0] * w[1])
                    .map(|_| rng.random_range(-0.2..0.2))
                    .collect()
            })
            .collect();
        let biases = sizes[1..].iter().map(|&o| vec![0.01; o]).collect();
        let mlp = MlpInference::new(spec, weights, biases).expect("synthetic shapes are valid");
        Policy::with_task_features(
            Normalizer::identity(n),
            mlp,
            task,
            PolicyMeta::new("synthetic", joint_names, serde_json::Value::Null),
        )
        .expect("synthetic policy is consistent")
    }

    /// Consistency checks shared by [`Policy::new`], save and load.
    pub(crate) fn check(&self, path: &std::path::Path) -> Result<(), PolicyError> {
        let invalid = |field: &str, message: String| PolicyError::Invalid {
            path: path.to_path_buf(),
            field: field.into(),
            message,
        };
        self.normalizer
            .validate()
            .map_err(|m| invalid("normalizer", m.to_string()))?;
        let n = self.normalizer.dim();
        let spec = self.mlp.spec();
        if let Some(t) = &self.task {
            if t.joints_read() > n {
                return Err(invalid(
                    "task_features",
                    format!(
                        "the chains read {} joints, the policy has {n}",
                        t.joints_read()
                    ),
                ));
            }
        }
        if spec.input != self.input_dim() {
            return Err(invalid(
                "mlp.input",
                format!(
                    "{} but the policy has {n} joints and {} task features (input must be \
                     n + m + 4 = {})",
                    spec.input,
                    self.task.as_ref().map_or(0, TaskFeatures::dim),
                    self.input_dim()
                ),
            ));
        }
        if spec.output != n {
            return Err(invalid(
                "mlp.output",
                format!("{} but the normaliser has {n} joints", spec.output),
            ));
        }
        if !(self.meta.joint_names.is_empty() || self.meta.joint_names.len() == n) {
            return Err(invalid(
                "joint_names",
                format!("{} names for {n} joints", self.meta.joint_names.len()),
            ));
        }
        Ok(())
    }

    /// Joint-space dimension `n`.
    pub fn dim(&self) -> usize {
        self.normalizer.dim()
    }

    /// The input/output normalisation.
    pub fn normalizer(&self) -> &Normalizer {
        &self.normalizer
    }

    /// The network.
    pub fn mlp(&self) -> &MlpInference {
        &self.mlp
    }

    /// The canonical task-space features, when the policy has them.
    pub fn task_features(&self) -> Option<&TaskFeatures> {
        self.task.as_ref()
    }

    /// Network input width `n + m + 4` (`m = 0` without task features).
    pub fn input_dim(&self) -> usize {
        self.normalizer.input_dim() + self.task.as_ref().map_or(0, TaskFeatures::dim)
    }

    /// A workspace sized for this policy (allocate once, before the control loop).
    pub fn workspace(&self) -> PolicyWorkspace {
        PolicyWorkspace {
            input: vec![0.0; self.input_dim()],
            y: vec![0.0; self.dim()],
            mlp: self.mlp.workspace(),
            task: self.task.as_ref().map(TaskFeatures::workspace),
        }
    }

    /// `out = π(q, s)`: joint velocity (rad/s) at joint position `q` (rad) for condition
    /// `s`. Allocates nothing; `s` is not validated here (validate it once, upstream).
    ///
    /// # Panics
    /// When `q` or `out` is not of length `n`, or `ws` was built for a smaller policy.
    pub fn velocity(&self, q: &[f64], s: &Condition, out: &mut [f64], ws: &mut PolicyWorkspace) {
        self.velocity_impl(q, None, s, out, ws);
    }

    /// [`Policy::velocity`] with the task point `x = f(q)` (m, stacked chain points in their
    /// base frames, as `KinematicsWorkspace::x` after `Kinematics::jacobian(q)`) supplied by
    /// the caller instead of recomputed from the policy's stored chains: the node's tick
    /// already has it. Same result bit for bit when `x` is that FK (the stored chains are
    /// checked against the robot with [`TaskFeatures::check_kinematics`]); `x` is unused by
    /// a policy without task features. Allocates nothing.
    ///
    /// # Panics
    /// As [`Policy::velocity`]; in debug builds also when `x` has the wrong length.
    pub fn velocity_at(
        &self,
        q: &[f64],
        x: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut PolicyWorkspace,
    ) {
        self.velocity_impl(q, Some(x), s, out, ws);
    }

    fn velocity_impl(
        &self,
        q: &[f64],
        x: Option<&[f64]>,
        s: &Condition,
        out: &mut [f64],
        ws: &mut PolicyWorkspace,
    ) {
        let n = self.dim();
        assert_eq!(q.len(), n, "policy q length");
        assert_eq!(out.len(), n, "policy output length");
        let PolicyWorkspace {
            input,
            y,
            mlp,
            task,
        } = ws;
        let input = &mut input[..self.input_dim()];
        let y = &mut y[..n];
        self.normalizer.normalize_q(q, &mut input[..n]);
        let mut c = n;
        if let (Some(t), Some(tw)) = (&self.task, task.as_mut()) {
            c += t.dim();
            match x {
                Some(x) => t.encode_at(x, s, &mut input[n..c], tw),
                None => t.encode(q, s, &mut input[n..c], tw),
            }
        }
        encode_condition(s, &mut input[c..c + CONDITION_FEATURES]);
        self.mlp.forward(input, y, mlp);
        self.normalizer.denormalize_qdot(y, out);
    }

    /// Euler rollout `q_{k+1} = q_k + Δt π(q_k, s)` for `steps` steps from `q0` (rad);
    /// returns the `(steps + 1) × n` row-major positions, `q0` first (rad). Allocates.
    pub fn rollout(&self, q0: &[f64], s: &Condition, dt: f64, steps: usize) -> Vec<f64> {
        let n = self.dim();
        let mut ws = self.workspace();
        let mut traj = Vec::with_capacity((steps + 1) * n);
        traj.extend_from_slice(q0);
        let mut v = vec![0.0; n];
        let mut q = q0.to_vec();
        for _ in 0..steps {
            self.velocity(&q, s, &mut v, &mut ws);
            for j in 0..n {
                q[j] += dt * v[j];
            }
            traj.extend_from_slice(&q);
        }
        traj
    }
}
