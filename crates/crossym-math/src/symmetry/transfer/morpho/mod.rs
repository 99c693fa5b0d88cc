//! Morphological symmetries derived from the robot description (paper eqs. 4, 9; Example 1).
//!
//! A morphological symmetry is a reflection (or a product of reflections) of space that maps
//! the robot's kinematic tree onto itself; it acts on `Q` as a signed permutation `ρ_Q`
//! (eq. 4) and descends to task space through `f` (eq. 9). MorphoSymm (Ordoñez-Apraez et
//! al.) writes these tables by hand per robot; here they are read off the URDF:
//!
//! - [`chains`]: the bilateral swap of two configured serial chains across one plane
//!   (`ρ_Q = [[0, P], [P⁻¹, 0]]`, Example 1).
//! - [`body`]: every reflection plane through the base that maps a whole kinematic tree
//!   onto itself (joints paired across it or mapped to themselves) and the group they
//!   generate (C2, K4 = C2 × C2, …).
//! - [`export`]: the derived group as crossym TOML and as MorphoSymm's YAML layout.

pub mod body;
pub mod chains;
pub mod export;

pub use body::{
    derive_body_symmetries, BodyElement, BodySettings, BodySymmetries, ElementKind, RejectedPlane,
};
pub use chains::{
    derive_morphological, LimitMismatch, MorphoError, MorphoReport, MorphoSettings, MorphoStatus,
};
