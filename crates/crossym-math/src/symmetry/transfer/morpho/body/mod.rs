//! Reflection planes of a whole kinematic tree, found from the URDF alone (eqs. 4, 9).
//!
//! Let `T_L(q)` be the pose of every link `L` of the subtree below a base link (frame of
//! the base, [`LinkTree`](crate::kinematics::LinkTree)) and `S = I − 2nnᵀ` the reflection
//! across the plane through the base origin with unit normal `n`. The plane is a
//! morphological symmetry of the tree when a signed permutation `ρ_Q`,
//! `(ρ_Q q)_i = s_i q_{π(i)}`, satisfies for all `q`
//!
//! `T_{π(L)}(ρ_Q q) = S · T_L(q) · E_L`  (positions: `p_{π(L)}(ρ_Q q) = S p_L(q)`)
//!
//! with a constant body reflection `E_L` per link. Joints may pair across the plane
//! (`π(i) ≠ i`: a left and a right shoulder) or map onto themselves (`π(i) = i`: a waist
//! yaw with `s = −1`, a waist pitch with `s = +1`). The derivation:
//!
//! 1. **Candidate planes.** The base frame's three coordinate planes, and the perpendicular
//!    bisector of every pair of joint origins at `q = 0` that are equally far from the base
//!    origin (only such a plane can swap them), deduplicated.
//! 2. **Pairing** at `q = 0` (held joints at their held values) for one orthogonal map `O`
//!    (`O = S` here; products of planes below): joint `i` may map to joint `k` of the same
//!    kind and depth when `O` maps the axis line of `i` onto the axis line of `k`. The
//!    direction gives the sign by the axial-vector rule: a rotation axis maps to
//!    `det(O)·O z_i`, a translation axis to `O z_i`, and `s_i = ±1` as that equals `±z_k`.
//!    The tree must be preserved: `π(parent(i)) = parent(π(i))`, searched depth first in
//!    topological order with backtracking over ambiguous candidates (collinear axes, a
//!    wheel axle), the partner whose joint origin is the mirrored point tried first, and on
//!    a tie (two arms drawn on top of each other) the swap before the joint itself.
//! 3. **Verification** on seeded configurations inside the limits, at every sample: every
//!    joint's axis line and direction (`O` maps the line of `i` at `q` onto the line of
//!    `π(i)` at `ρ_Q q`), and every link paired at `q = 0` by its mirrored position (`O p_L =
//!    p_M` in the image body) in position and orientation. The residual is reported relative
//!    to the robot's size (the farthest link origin from the base at `q = 0`). Mimic joints
//!    follow their leaders (`q_j = m q_leader + c`); when the pairing's sign for a leader
//!    disagrees with how its mimic follower is mirrored (a gripper whose driven finger
//!    mirrors onto the other gripper's mimic finger), the opposite sign is tried for that
//!    pair. Links without a mirrored partner (a sensor frame on one side, a tool frame
//!    offset to one side) are listed with the element; `strict_links` refuses the plane
//!    instead, and named links can be left out.
//! 4. **Group.** The accepted reflections generate a finite group of pairs `(O, ρ_Q)`,
//!    closed under `(O₁, ρ₁)(O₂, ρ₂) = (O₁O₂, ρ₁ρ₂)`: one plane gives C2, two perpendicular
//!    planes the Klein four-group K4 = C2 × C2 whose third element is the rotation by π
//!    about their intersection (a quadruped's front-left ↔ hind-right). Every element is
//!    verified as in 3.
//! 5. **Limits.** A pair maps consistently when `[lo_i, hi_i] = [lo_k, hi_k]` for `s = +1`
//!    and `[−hi_k, −lo_k]` for `s = −1`; mismatches are reported, not failed.
//!
//! The task-space action of each element on a point of the base frame is `O` itself; on a
//! configured task space it is the descended action (eq. 9) computed by the symmetry check.

mod derive;
mod pairing;
mod structure;
#[cfg(test)]
mod tests;
mod verify;

pub use derive::derive_body_symmetries;

use nalgebra::{Matrix3, Vector3};

use super::chains::LimitMismatch;
use crate::symmetry::finite::SignedPermutation;

/// Settings of the whole-body derivation.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySettings {
    /// Verification samples per group element.
    pub samples: usize,
    /// Seed of the sampler (runs are deterministic).
    pub seed: u64,
    /// Largest distance between a mirrored axis line or link origin and its partner,
    /// relative to the robot's size (dimensionless).
    pub position_tolerance: f64,
    /// Largest distance between a mirrored unit axis and `±` its partner's (dimensionless).
    pub axis_tolerance: f64,
    /// Largest verification residual counted as a symmetry, relative to the robot's size.
    pub residual_tolerance: f64,
    /// Largest difference of mapped joint limits counted as consistent (rad or m).
    pub limit_tolerance: f64,
    /// Only these plane normals (base frame); `None` searches every candidate.
    pub planes: Option<Vec<Vector3<f64>>>,
    /// Links left out of the link check (e.g. a sensor frame mounted on one side only).
    pub ignore_links: Vec<String>,
    /// Refuse a plane that leaves any (not ignored) link without a mirrored partner. Off by
    /// default: such links (typically sensor frames) are listed with the element instead.
    pub strict_links: bool,
    /// Refuse a plane under which some joint limits do not map into each other (its mirror
    /// image of a reachable configuration may be unreachable). Off by default: listed.
    pub require_consistent_limits: bool,
    /// Largest group order accepted.
    pub max_order: usize,
}

impl Default for BodySettings {
    fn default() -> Self {
        Self {
            samples: 64,
            seed: 0x3a3a_0f0f,
            position_tolerance: 1e-4,
            axis_tolerance: 1e-4,
            residual_tolerance: 1e-4,
            limit_tolerance: 1e-6,
            planes: None,
            ignore_links: Vec::new(),
            strict_links: false,
            require_consistent_limits: false,
            max_order: 64,
        }
    }
}

/// What one group element does to space.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum ElementKind {
    /// The identity.
    Identity,
    /// Reflection across the plane through the base origin with this unit normal.
    Reflection {
        /// Unit normal (base frame).
        normal: Vector3<f64>,
    },
    /// Rotation about an axis through the base origin.
    Rotation {
        /// Unit axis (base frame).
        axis: Vector3<f64>,
        /// Angle (rad).
        angle: f64,
    },
    /// A rotation followed by a reflection that is not a plain reflection.
    Rotoreflection,
}

/// One element `(O, ρ_Q)` of the derived group with its verification.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyElement {
    /// What `O` is.
    pub kind: ElementKind,
    /// `O`: the action on points of the base frame (orthogonal 3 × 3).
    pub space: Matrix3<f64>,
    /// `ρ_Q` on the tree's joints, in [`BodySymmetries::joints`] order.
    pub rho_q: SignedPermutation,
    /// `(L, M)`: link `L` maps onto link `M` (names), for every link with a partner.
    pub link_pairs: Vec<(String, String)>,
    /// Links with no mirrored partner (the element is refused unless they are ignored).
    pub unmatched_links: Vec<String>,
    /// Worst position residual over samples, links and axis lines, relative to the size.
    pub relative_residual: f64,
    /// Worst entry of `R_M(ρq) − O R_L(q) E_L` over samples and paired links.
    pub orientation_residual: f64,
    /// Where the worst residual occurs (`link L`, `axis of joint J`), for diagnosis.
    pub worst: String,
    /// Pairs whose joint limits do not map into each other.
    pub limit_mismatches: Vec<LimitMismatch>,
}

impl BodyElement {
    /// True when both residuals (position relative to the size, orientation) are within `tol`.
    pub fn within(&self, tol: f64) -> bool {
        self.relative_residual <= tol && self.orientation_residual <= tol
    }

    /// Short label: `identity`, `reflection n=(0,1,0)`, `rotation π about (0,0,1)`.
    pub fn label(&self) -> String {
        let v = |v: &Vector3<f64>| format!("({})", fmt_vec(v));
        match self.kind {
            ElementKind::Identity => "identity".into(),
            ElementKind::Reflection { normal } => format!("reflection n={}", v(&normal)),
            ElementKind::Rotation { axis, angle } => {
                if (angle - std::f64::consts::PI).abs() < 1e-9 {
                    format!("rotation π about {}", v(&axis))
                } else {
                    format!("rotation {:.4} rad about {}", angle, v(&axis))
                }
            }
            ElementKind::Rotoreflection => "rotoreflection".into(),
        }
    }
}

fn fmt_vec(v: &Vector3<f64>) -> String {
    v.iter()
        .map(|x| {
            let r = (x * 1e6).round() / 1e6;
            if r == 0.0 {
                "0".to_string()
            } else {
                format!("{r}")
            }
        })
        .collect::<Vec<_>>()
        .join(",")
}

/// A plane tried and refused, with the reason.
#[derive(Debug, Clone, PartialEq)]
pub struct RejectedPlane {
    /// Unit normal (base frame).
    pub normal: Vector3<f64>,
    /// Why it is not a symmetry.
    pub reason: String,
}

/// The morphological symmetry group of a kinematic tree.
#[derive(Debug, Clone, PartialEq)]
pub struct BodySymmetries {
    /// Robot name from the URDF.
    pub robot: String,
    /// Base link: planes pass through its origin, normals are in its frame.
    pub base: String,
    /// Joints forming `q`, in order.
    pub joints: Vec<String>,
    /// Size of the robot: the farthest link origin from the base at `q = 0` (m).
    pub size: f64,
    /// Group name: `trivial`, `C2`, `K4`, `D{m}` or `order N`.
    pub group: String,
    /// Every element, identity first, then the reflections found (generators), then products.
    pub elements: Vec<BodyElement>,
    /// How many of `elements` (after the identity) are generating reflections.
    pub generators: usize,
    /// Coordinate planes (and requested planes) that are not symmetries, with the reason.
    pub rejected: Vec<RejectedPlane>,
    /// Candidate planes tried.
    pub candidates: usize,
    /// Verification samples per element.
    pub samples: usize,
}

impl BodySymmetries {
    /// The generating reflections.
    pub fn reflections(&self) -> &[BodyElement] {
        &self.elements[1..1 + self.generators]
    }

    /// Worst relative residual over all elements.
    pub fn worst_relative_residual(&self) -> f64 {
        self.elements
            .iter()
            .map(|e| e.relative_residual)
            .fold(0.0, f64::max)
    }
}
