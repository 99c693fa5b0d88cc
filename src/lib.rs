//! # crossym — cross-space symmetry compositions for robot policies
//!
//! Implements *Symmetries Here and There, Combined Everywhere: Cross-space Symmetry
//! Compositions in Robotics* (Hadjiloizou, Pérez-Dattari, Jaquier): symmetries of a
//! robot's configuration space `Q` and task space `X` are transferred across the
//! forward kinematics `f: Q → X` (descended by equivariance, eq. 8; lifted by the
//! horizontal lift, eqs. 13–18), composed by direct or semi-direct products
//! (eqs. 19–23), and used to train symmetry-conditioned joint-space policies.
//!
//! Modules:
//! - [`kinematics`]: URDF model, FK, Jacobian, metric pseudo-inverse.
//! - [`config`]: TOML configuration, validated once at startup.
//! - [`symmetry`]: groups, actions, transfer (descend/lift) and composition.
//! - [`policy`]: the symmetry-conditioned policy `π(q, s) → q̇`: features, allocation-free
//!   inference, CONDOR-style training (candle), safetensors + JSON persistence.
//! - [`safety`]: the QP joint-limit safety filter (Clarabel).
//! - [`ros`]: the ROS 2 node without DDS: message mirrors, `.msg` parser, control-tick core.
//! - [`data`]: demonstrations from every source (LASA letters, reaches, rosbag2 recordings,
//!   CSV) and the readers behind them.
//! - [`pipeline`]: demonstrations → augmentation → training → evaluation, as library calls.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod bag;
pub mod config;
pub mod data;
pub mod eval;
pub mod kinematics;
pub mod pipeline;
pub mod policy;
pub mod ros;
pub mod safety;
pub mod sim;
pub mod symmetry;
