//! Kinematics: URDF robot model, serial chains, forward kinematics `f: Q → X`,
//! the Jacobian `J = df`, and the metric-weighted damped pseudo-inverse `J⁺` (eq. 13).
//!
//! The forward kinematics map is the bridge of the paper (Sec. II-C, IV): symmetries
//! descend through `f` when it is equivariant (eq. 8) and lift through `J⁺` (eqs. 13–17).
//!
//! - [`model`]: the immutable URDF tree ([`RobotModel`]).
//! - [`chain`]: one serial chain, FK and 6 × n geometric Jacobian ([`Chain`]).
//! - [`robot`]: several chains stacked as `Q = ∏ Q_i`, `X = ∏ X_i` ([`Kinematics`]).
//! - [`pinv`]: `J⁺ = M⁻¹Jᵀ(J M⁻¹Jᵀ + λ²I)⁻¹`, nullspace projector, manipulability.
//!
//! Per-tick functions take caller-owned workspaces and allocate nothing.

pub mod chain;
pub mod error;
pub mod model;
pub mod pinv;
pub mod robot;

pub use chain::{Chain, ChainSpec, ChainWorkspace, TaskSpace, ToolOffset};
pub use error::KinematicsError;
pub use model::{JointKind, JointLimits, JointModel, RobotModel};
pub use pinv::{
    condition_number, DampedPinv, JacobianBlock, Metric, PinvReport, PinvStatus, PinvWorkspace,
};
pub use robot::{Kinematics, KinematicsSettings, KinematicsWorkspace};
