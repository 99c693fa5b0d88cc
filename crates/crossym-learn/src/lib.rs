//! # crossym-learn — the learning floor of crossym
//!
//! Symmetry-conditioned policies learned by imitation (paper Sec. VI-A):
//! - [`data`]: demonstrations from every source (LASA letters, reaches, rosbag2 recordings,
//!   CSV), their cleaning, and the augmentation by the lifted composed group (eq. 23);
//! - [`policy`]: the policy `π(q, s) → q̇` (joint-space MLP, canonicalised, task-space head),
//!   allocation-free inference, training with candle, safetensors + JSON persistence;
//! - [`eval`]: rollouts and Table II scores in both protocols, and the figures.
//!
//! Built on [`crossym_math`] (kinematics, symmetries) and [`crossym_io`] (bags); knows
//! nothing of the node, DDS or config files.

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod data;
pub mod eval;
pub mod policy;
