//! Symmetry-conditioned joint-space policies `π(q, s) → q̇`, `s = (θ, λ, σ)` (paper
//! Sec. VI-A), learned by imitation as in CONDOR (Pérez-Dattari & Kober 2023).
//!
//! The policy is an MLP on `u = [(q − μ) ⊘ σ_q, (x̃ − μ_x) ⊘ σ_x, cos θ, sin θ, ln λ, σ]`
//! (the canonical task point `x̃ = g(s)⁻¹ f(q)` only with [`TaskFeatures`]) predicting
//! `y = q̇ ⊘ v`; it is trained by rolling it out with Euler steps
//! `q_{k+1} = q_k + Δt π(q_k, s)` over short windows of the demonstrations and matching
//! the demonstrated positions (plus a weighted velocity term).
//!
//! - [`features`]: input encoding and the [`Normalizer`].
//! - [`canonical`]: optional canonical task-space inputs `x̃ = g(s)⁻¹ f(q)`
//!   ([`TaskFeatures`]), with the robot's FK stored in the policy.
//! - [`task_fk`]: batched differentiable FK in candle ([`CandleFk`]), for those features.
//! - [`equivariant`]: exactly equivariant policies by canonicalisation through the lifted
//!   flows ([`EquivariantPolicy`]).
//! - [`any`]: a policy as loaded from a file, plain or canonicalised ([`AnyPolicy`]).
//! - [`domain`]: the box of conditions a policy was trained on ([`ConditionDomain`]), which
//!   the node enforces on incoming conditions.
//! - [`mlp`]: architecture ([`MlpSpec`]), allocation-free `f64` inference
//!   ([`MlpInference`]) and the control-loop [`Policy`].
//! - [`train`](mod@train): training with candle ([`train()`], [`TrainConfig`], [`TrainReport`]).
//! - [`io`]: safetensors weights + JSON sidecar ([`Policy::save`], [`Policy::load`]).
//!
//! Only training uses candle; [`Policy::velocity`] is plain `f64` code that allocates
//! nothing, with a caller-owned [`PolicyWorkspace`].

pub mod activation;
pub mod any;
pub mod canonical;
pub mod domain;
pub mod equivariant;
pub mod error;
pub mod features;
pub mod io;
pub mod mlp;
pub mod task_fk;
pub mod task_head;
pub mod train;
pub mod train_config;

pub use activation::{tanh, Activation};
pub use any::{AnyPolicy, AnyWorkspace};
pub use canonical::{CanonicalMap, TaskFeatureSpec, TaskFeatureWorkspace, TaskFeatures};
pub use domain::{ConditionDomain, DomainViolation};
pub use equivariant::{EquivariantPolicy, EquivariantWorkspace};
pub use error::{PolicyError, PolicyFitError};
pub use features::{encode_condition, Normalizer, CONDITION_FEATURES, STD_FLOOR};
pub use io::{sidecar_path, FORMAT, FORMAT_VERSION};
pub use mlp::{
    dot_kernel, MlpInference, MlpSpec, MlpWorkspace, Policy, PolicyMeta, PolicyWorkspace,
};
pub use task_fk::CandleFk;
pub use task_head::{
    task_coordinate_names, task_path_trajectory, TaskHeadPolicy, TaskHeadWorkspace,
};
pub use train::{train, train_with_features, CandleMlp, LrSchedule, TrainConfig, TrainReport};
