//! Symmetries of robot configuration and task spaces, their transfer across the
//! forward kinematics, and their composition (paper Secs. III–V).
//!
//! - [`field`]: vector fields and the Lie bracket (Sec. II-B).
//! - [`affine`]: one-parameter affine groups in closed form (rotations, scalings,
//!   translations), serialisable.
//! - [`finite`]: signed-permutation representations of finite groups (eqs. 4–5).
//! - [`lie`]: SO(2), SO(3), scaling and translations acting on task space (Sec. III-B).
//! - [`compose`]: direct and semi-direct products, the composed action (eqs. 19–23).
//! - [`task_induced`]: symmetries from a task cost: discovery, closure/completeness checks, flow action (Sec. III-C, eq. 7).
//! - [`parts`]: the parts `(M, R, S)` of a composition order, picked by name.
//! - [`spec`]: symmetry configuration; [`check`]: the numerical report of `crossym check`.

pub mod affine;
pub mod built;
pub mod check;
pub mod compose;
pub mod field;
pub mod finite;
pub mod lie;
pub mod parts;
pub mod spec;
pub mod task_induced;
pub mod transfer;
