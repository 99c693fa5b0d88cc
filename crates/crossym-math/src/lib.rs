//! # crossym-math — the maths floor of crossym
//!
//! Implements the geometry of *Symmetries Here and There, Combined Everywhere: Cross-space
//! Symmetry Compositions in Robotics* (Hadjiloizou, Pérez-Dattari, Jaquier): symmetries of
//! a robot's configuration space `Q` and task space `X` are transferred across the forward
//! kinematics `f: Q → X` (descended by equivariance, eq. 8; lifted by the horizontal lift,
//! eqs. 13–18) and composed by direct or semi-direct products (eqs. 19–23).
//!
//! - [`kinematics`]: URDF model, FK, Jacobian, metric pseudo-inverse.
//! - [`symmetry`]: groups, actions, transfer (descend / lift), composition, morphological
//!   symmetries of a URDF, and the numerical checks.
//!
//! This crate knows no task (letters, pans), no file format beyond URDF and its own TOML
//! specs, no network: every crate of the workspace sits above it.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod kinematics;
pub mod symmetry;
