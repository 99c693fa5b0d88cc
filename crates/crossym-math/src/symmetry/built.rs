//! A symmetry as built from configuration ([`BuiltSymmetry`]): a finite group acting on
//! `Q` (with its descended action on `X`) or a Lie group acting on `X` (lifted to `Q`).
//! What [`check::build`](super::check::build) makes from `[[symmetries]]`, and what
//! composition, augmentation and canonicalisation consume.

use super::finite::SignedPermutation;
use super::lie::{LieGroupSpec, TaskGroupAction};

/// A symmetry built from configuration, in the space where it is composed.
pub enum BuiltSymmetry {
    /// A finite group acting on `Q` by `rho_q`, descended to `X` as `rho_x`.
    Finite {
        /// Name.
        name: String,
        /// Action on `Q`.
        rho_q: SignedPermutation,
        /// Descended action on `X` (when it descends to a signed permutation).
        rho_x: Option<SignedPermutation>,
    },
    /// A Lie group acting on `X`, lifted to `Q`.
    Lie {
        /// Name.
        name: String,
        /// The task-space action (affine isometry/scaling or task-induced flow).
        action: Box<dyn TaskGroupAction>,
        /// Which affine group it is (`None` for task-induced ones): picks test elements.
        affine: Option<LieGroupSpec>,
    },
}

impl BuiltSymmetry {
    /// Name from configuration.
    pub fn name(&self) -> &str {
        match self {
            Self::Finite { name, .. } | Self::Lie { name, .. } => name,
        }
    }
}
