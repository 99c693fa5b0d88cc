//! # crossym-learn — the learning floor of crossym
//!
//! Symmetry-conditioned policies learned by imitation (paper Sec. VI-A):
//! - [`data`]: demonstrations from every source (LASA letters, reaches, rosbag2 recordings,
//!   CSV), their cleaning, and the augmentation by the lifted composed group (eq. 23);
//! - `train` (cargo feature `train`): training the policies of `crossym-policy` (joint-space MLP,
//!   canonicalised, task-space head) with candle;
//! - [`eval`]: rollouts and Table II scores in both protocols, and the figures.
//!
//! Built on [`crossym_policy`] (the policies and their allocation-free inference, which the
//! node links without this crate), [`crossym_math`] (kinematics, symmetries) and
//! [`crossym_io`] (bags); knows nothing of the node, DDS or config files.
//!
//! ## Example: a policy `π(q, s)` over a grid of conditions
//!
//! The paper's training grid of `G_MRT` without scaling: θ every 30° in [−180°, 180°] and
//! both reflections, 26 conditions `s = (θ, λ, σ)`; a tiny untrained policy (random weights
//! in the shape of a trained one, as `train::train()` returns) evaluated at each.
//!
//! ```
//! use crossym_policy::GroupGrid;
//! use crossym_policy::Policy;
//!
//! let grid = GroupGrid { rotation_step_deg: Some(30.0), reflection: true, ..GroupGrid::identity() };
//! grid.validate()?;
//! let conditions = grid.conditions();
//! assert_eq!(conditions.len(), 13 * 2);
//!
//! let joints = vec!["j1".to_string(), "j2".to_string()];
//! let policy = Policy::synthetic(2, joints, &[16, 16], 1);
//! let (q, mut qdot, mut ws) = ([0.4, 1.2], [0.0; 2], policy.workspace()); // rad, rad/s
//! for s in &conditions {
//!     policy.velocity(&q, s, &mut qdot, &mut ws);
//!     assert!(qdot.iter().all(|v| v.is_finite()));
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod data;
pub mod eval;
#[cfg(feature = "train")]
pub mod train;
