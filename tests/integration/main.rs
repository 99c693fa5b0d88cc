//! The one integration-test binary (ripgrep style): shared fixtures in `common`,
//! one module per concept.

mod common;
mod descend;
mod kinematics;
mod lift_compose;
mod safety;
mod task_induced;
