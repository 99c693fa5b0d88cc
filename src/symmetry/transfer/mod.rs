//! Transfer of symmetries between configuration space `Q` and task space `X` (Sec. IV).
//!
//! - [`flow`]: integrating generators into group actions (eqs. 7, 18).
//! - [`lift`]: horizontal lift of task fields and the lifted action (eqs. 13–18).

pub mod flow;
pub mod lift;
