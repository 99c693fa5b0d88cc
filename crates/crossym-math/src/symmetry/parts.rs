//! The parts of a composition `order = [M, R, S]` (outer → inner, eq. 23): a finite
//! symmetry `M` on `Q`, an SO(2) `R` and an optional scaling `S` acting on `X`, picked by
//! name from the built symmetries. A task without scaling (grasping a pan) names `[M, R]`.

use super::built::BuiltSymmetry;
use super::finite::SignedPermutation;
use super::lie::{LieGroupSpec, TaskGroupAction};

/// `(ρ_Q, rotation, scaling)` of a composition order.
pub struct CompositionParts<'b> {
    /// `ρ_Q` of the finite symmetry `M`.
    pub reflection: SignedPermutation,
    /// The SO(2) action `R` on `X`.
    pub rotation: &'b dyn TaskGroupAction,
    /// The scaling `S` on `X`, when the order names one.
    pub scaling: Option<&'b dyn TaskGroupAction>,
}

/// Why the parts of a composition order cannot be picked ([`composition_parts`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PartsError {
    /// The order names no built symmetry of this name.
    #[error("no symmetry `{name}`")]
    Unknown {
        /// The name.
        name: String,
    },
    /// The order has neither three nor two names.
    #[error("[composition] order must name (M, R, S) or (M, R), got {order:?}")]
    Order {
        /// The order given.
        order: Vec<String>,
    },
    /// `M` is not a finite symmetry.
    #[error("`{name}` must be a morphological (finite) symmetry")]
    NotFinite {
        /// Its name.
        name: String,
    },
    /// `R` or `S` is not the affine group it must be.
    #[error("`{name}` must be {what}")]
    WrongKind {
        /// Its name.
        name: String,
        /// What it must be (`an SO(2) rotation`, `a scaling`).
        what: &'static str,
    },
}

/// Picks the parts named in `order` (`[M, R, S]` or `[M, R]`) from `built`; an order of
/// another length, a missing name or a symmetry of the wrong kind is an error naming it.
pub fn composition_parts<'b>(
    built: &'b [BuiltSymmetry],
    order: &[String],
) -> Result<CompositionParts<'b>, PartsError> {
    let find = |name: &str| {
        built
            .iter()
            .find(|b| b.name() == name)
            .ok_or_else(|| PartsError::Unknown { name: name.into() })
    };
    let (m, r, s) = match order {
        [m, r, s] => (m, r, Some(s)),
        [m, r] => (m, r, None),
        _ => {
            return Err(PartsError::Order {
                order: order.to_vec(),
            })
        }
    };
    let rho = match find(m)? {
        BuiltSymmetry::Finite { rho_q, .. } => rho_q.clone(),
        _ => return Err(PartsError::NotFinite { name: m.clone() }),
    };
    let lie = |name: &str, want: fn(&LieGroupSpec) -> bool, what: &'static str| match find(name)? {
        BuiltSymmetry::Lie {
            action,
            affine: Some(spec),
            ..
        } if want(spec) => Ok(action.as_ref()),
        _ => Err(PartsError::WrongKind {
            name: name.into(),
            what,
        }),
    };
    let rot = lie(
        r,
        |s| matches!(s, LieGroupSpec::So2 { .. }),
        "an SO(2) rotation",
    )?;
    let sc = match s {
        Some(s) => Some(lie(s, |s| matches!(s, LieGroupSpec::Scaling), "a scaling")?),
        None => None,
    };
    Ok(CompositionParts {
        reflection: rho,
        rotation: rot,
        scaling: sc,
    })
}
