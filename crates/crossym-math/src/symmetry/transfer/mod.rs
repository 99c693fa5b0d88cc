//! Transfer of symmetries between configuration space `Q` and task space `X` (Sec. IV).
//!
//! - [`flow`]: integrating generators into group actions (eqs. 7, 18).
//! - [`lift`]: horizontal lift of task fields and the lifted action (eqs. 13–18).
//! - [`composed`]: the composed lifted action of one condition (eq. 23), its exact inverse
//!   and push-forward (canonicalisation).
//! - [`descend`]: equivariance test of `f` and the descended task action (eqs. 8–10).
//! - [`morpho`]: morphological symmetries derived from the URDF: the swap of two chains
//!   (eqs. 4, 9; Example 1) and the reflection groups of a whole kinematic tree.

pub mod composed;
pub mod descend;
pub mod flow;
pub mod lift;
pub mod morpho;
