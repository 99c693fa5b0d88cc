//! Transfer of symmetries between configuration space `Q` and task space `X` (Sec. IV).
//!
//! - [`flow`]: integrating generators into group actions (eqs. 7, 18).
//! - [`lift`]: horizontal lift of task fields and the lifted action (eqs. 13–18).
//! - [`descend`]: equivariance test of `f` and the descended task action (eqs. 8–10).
//! - [`morpho`]: morphological symmetry `ρ_Q`, `ρ_X` derived from the URDF (eqs. 4, 9; Example 1).

pub mod descend;
pub mod flow;
pub mod lift;
pub mod morpho;
