//! # crossym-policy — policy inference of crossym (the learning floor's run-time half)
//!
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
//! - [`equivariant`]: exactly equivariant policies by canonicalisation through the lifted
//!   flows ([`EquivariantPolicy`]).
//! - [`any`]: a policy as loaded from a file, plain or canonicalised ([`AnyPolicy`]).
//! - [`domain`]: the box of conditions a policy was trained on ([`ConditionDomain`]), which
//!   the node enforces on incoming conditions.
//! - [`mlp`]: architecture ([`MlpSpec`]), allocation-free `f64` inference
//!   ([`MlpInference`]) and the control-loop [`Policy`].
//! - [`train_config`]: the training settings a policy stores ([`TrainConfig`]); training
//!   itself (candle) lives in `crossym-learn`.
//! - [`grid`]: finite grids of conditions and the sub-groups of Table II ([`GroupGrid`],
//!   [`SubGroup`]).
//! - [`trajectory`]: sampled joint-space trajectories ([`JointTrajectory`]).
//! - [`io`]: safetensors weights + JSON sidecar ([`Policy::save`], [`Policy::load`]).
//!
//! This crate is what the real-time node links: no candle, no plotting, no dataset
//! readers. [`Policy::velocity`] is plain `f64` code that allocates nothing, with a
//! caller-owned [`PolicyWorkspace`]. Training (candle), data and evaluation are in
//! `crossym-learn`, which builds on this crate.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod activation;
pub mod any;
pub mod canonical;
pub mod domain;
pub mod equivariant;
pub mod error;
pub mod features;
pub mod grid;
pub mod io;
pub mod mlp;
pub mod task_head;
pub mod train_config;
pub mod trajectory;

pub use activation::{tanh, Activation};
pub use any::{AnyPolicy, AnyWorkspace};
pub use canonical::{TaskFeatureSpec, TaskFeatureWorkspace, TaskFeatures};
pub use domain::{ConditionDomain, DomainViolation};
pub use equivariant::{EquivariantPolicy, EquivariantWorkspace};
pub use error::{GridError, PolicyError, PolicyFitError};
pub use features::{encode_condition, Normalizer, CONDITION_FEATURES, STD_FLOOR};
pub use grid::{GroupGrid, SubGroup};
pub use io::{sidecar_path, FORMAT, FORMAT_VERSION};
pub use mlp::{
    dot_kernel, MlpInference, MlpSpec, MlpWorkspace, Policy, PolicyMeta, PolicyWorkspace,
};
pub use task_head::{
    task_coordinate_names, task_path_trajectory, TaskHeadPolicy, TaskHeadWorkspace,
};
pub use train_config::{LrSchedule, TrainConfig};
pub use trajectory::JointTrajectory;
