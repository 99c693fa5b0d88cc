//! Kinematics: URDF robot model, serial chains, forward kinematics `f: Q → X`,
//! the Jacobian `J = df`, and the metric-weighted damped pseudo-inverse `J⁺` (eq. 13).
//!
//! The forward kinematics map is the bridge of the paper (Sec. II-C, IV): symmetries
//! descend through `f` when it is equivariant (eq. 8) and lift through `J⁺` (eqs. 13–17).
//!
//! - [`model`]: the immutable URDF tree ([`RobotModel`]).
//! - [`chain`]: one serial chain, FK and 6 × n geometric Jacobian ([`Chain`]).
//! - [`robot`]: several chains stacked as `Q = ∏ Q_i`, `X = ∏ X_i` ([`Kinematics`]).
//! - [`tree`]: every link pose of a URDF subtree at once ([`LinkTree`]).
//! - [`pinv`]: `J⁺ = M⁻¹Jᵀ(J M⁻¹Jᵀ + λ²I)⁻¹`, nullspace projector, manipulability.
//! - [`null_space`]: redundancy resolution, `J⁺ v + (I − J⁺J) v₀(q)` toward a rest posture
//!   and away from the limits.
//!
//! Per-tick functions take caller-owned workspaces and allocate nothing.

pub mod chain;
pub mod conditioning;
pub mod error;
pub mod model;
pub mod null_space;
pub mod pinv;
pub mod robot;
pub mod tree;

pub use chain::{
    Chain, ChainFactors, ChainSpec, ChainWorkspace, FactorsError, JointFactor, RigidFactor,
    TaskSpace, ToolOffset,
};
pub use error::KinematicsError;
pub use model::{JointKind, JointLimits, JointModel, Mimic, RobotModel};
pub use null_space::{
    lift_with_secondary, NullSpaceError, NullSpaceSettings, NullSpaceTerm, SecondaryWorkspace,
};
pub use pinv::{
    condition_number, DampedPinv, JacobianBlock, Metric, PinvReport, PinvStatus, PinvWorkspace,
};
pub use robot::{Kinematics, KinematicsSettings, KinematicsWorkspace};
pub use tree::{LinkTree, LinkTreeWorkspace, TreeLink};

/// The tests' skips (`SKIP: why`; a failure under `CROSSYM_NO_SKIP`, recorded in
/// `CROSSYM_SKIP_LOG`): the one implementation of the repository's tests.
#[cfg(test)]
#[path = "../../../../tests/support/skip.rs"]
mod skip;

/// The vendor RB-Y1 URDF (`robots/rby1a/`, shipped), or `None` after a skip
/// (unit tests only; integration tests have their own fixture).
#[cfg(test)]
pub(crate) fn test_rby1_urdf() -> Option<std::path::PathBuf> {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../robots/rby1a/model.urdf");
    if p.exists() {
        Some(p)
    } else {
        skip::skip(format!(
            "{} absent (shipped in robots/rby1a/: a partial checkout?)",
            p.display()
        ));
        None
    }
}

/// Uniform joint values within `limits` (±3 where a side is unbounded); unit tests only.
#[cfg(test)]
pub(crate) fn test_random_q(rng: &mut rand::rngs::StdRng, limits: &[JointLimits]) -> Vec<f64> {
    use rand::Rng;
    limits
        .iter()
        .map(|l| {
            let lo = if l.lower.is_finite() { l.lower } else { -3.0 };
            let hi = if l.upper.is_finite() { l.upper } else { 3.0 };
            rng.random_range(lo..=hi)
        })
        .collect()
}
