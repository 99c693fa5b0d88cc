//! Reflection planes of a whole kinematic tree, found from the URDF alone (eqs. 4, 9).
//!
//! Let `T_L(q)` be the pose of every link `L` of the subtree below a base link (frame of
//! the base, [`LinkTree`]) and `S = I − 2nnᵀ` the reflection across the plane through the
//! base origin with unit normal `n`. The plane is a morphological symmetry of the tree
//! when a signed permutation `ρ_Q`, `(ρ_Q q)_i = s_i q_{π(i)}`, satisfies for all `q`
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

use std::collections::HashMap;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::chains::{LimitMismatch, MorphoError};
use crate::kinematics::{JointKind, LinkTree, LinkTreeWorkspace, RobotModel};
use crate::symmetry::finite::SignedPermutation;
use crate::symmetry::transfer::descend::{sample_within_limits, SplitMix64};

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

/// Geometry of the tree at `q = 0` and the joint structure the pairing needs.
struct Structure {
    tree: LinkTree,
    /// Per joint of `q`: slot of its child link.
    child_slot: Vec<usize>,
    /// Per joint: nearest joint of `q` above it.
    parent: Vec<Option<usize>>,
    /// Per joint: number of joints of `q` above it.
    depth: Vec<usize>,
    /// Per joint: rotation (false) or translation (true).
    prismatic: Vec<bool>,
    /// Per slot: nearest joint of `q` at or above the link (the rigid body it belongs to).
    owner: Vec<Option<usize>>,
    /// Joint limits per joint of `q`.
    limits: Vec<crate::kinematics::JointLimits>,
    /// Per joint of `q`: its order in the topological (breadth-first) traversal.
    topo: Vec<usize>,
    /// Per joint of `q`: whether some mimic joint follows it.
    leads_mimic: Vec<bool>,
    size: f64,
}

/// Axis line `(point, unit direction)` of every joint of `q` at the poses in `ws`.
fn axis_lines(st: &Structure, ws: &LinkTreeWorkspace, out: &mut [(Vector3<f64>, Vector3<f64>)]) {
    for (i, &c) in st.child_slot.iter().enumerate() {
        let l = &st.tree.links[c];
        let (Some(p), Some(j)) = (l.parent, &l.joint) else {
            continue;
        };
        let frame = ws.poses[p] * j.origin;
        out[i] = (
            frame.translation.vector,
            frame.rotation * j.axis.into_inner(),
        );
    }
}

fn structure(
    model: &RobotModel,
    base: usize,
    joints: &[usize],
    held: &HashMap<String, f64>,
) -> Result<Structure, MorphoError> {
    let tree = LinkTree::new(model, base, joints, |j| {
        held.get(&model.joints[j].name).copied().unwrap_or(0.0)
    })
    .map_err(|e| MorphoError::Body {
        message: e.to_string(),
    })?;
    let n = joints.len();
    let mut owner = vec![None; tree.links.len()];
    let mut child_slot = vec![0; n];
    let mut topo_slots = Vec::with_capacity(n);
    for (s, l) in tree.links.iter().enumerate().skip(1) {
        let p = l.parent.expect("non-root link has a parent");
        owner[s] = match (l.q_index, l.mimic) {
            (Some(i), _) => {
                child_slot[i] = s;
                topo_slots.push(i);
                Some(i)
            }
            // A mimic follower's link moves with its leader.
            (None, Some((i, _, _))) => Some(i),
            (None, None) => owner[p],
        };
    }
    let mut parent = vec![None; n];
    let mut depth = vec![0; n];
    for &i in &topo_slots {
        let p = tree.links[child_slot[i]]
            .parent
            .expect("joint child has a parent");
        parent[i] = owner[p];
        depth[i] = parent[i].map_or(0, |k| depth[k] + 1);
    }
    let mut leads_mimic = vec![false; n];
    for l in &tree.links {
        if let Some((i, _, _)) = l.mimic {
            leads_mimic[i] = true;
        }
    }
    let mut topo = vec![0; n];
    for (order, &i) in topo_slots.iter().enumerate() {
        topo[i] = order;
    }
    let prismatic = joints
        .iter()
        .map(|&j| model.joints[j].kind == JointKind::Prismatic)
        .collect();
    let limits = joints.iter().map(|&j| model.joints[j].limits).collect();
    let mut ws = tree.workspace();
    tree.forward(&vec![0.0; n], &mut ws);
    let size = ws
        .poses
        .iter()
        .map(|p| p.translation.vector.norm())
        .fold(0.0, f64::max);
    let size = if size > 0.0 && size.is_finite() {
        size
    } else {
        1.0
    };
    Ok(Structure {
        tree,
        child_slot,
        parent,
        depth,
        prismatic,
        owner,
        limits,
        topo,
        leads_mimic,
        size,
    })
}

/// Resolves `base` (default: the root link) and `joints` (default: every movable joint
/// below the base without a `<mimic>`, in URDF order) to model indices.
fn selection(
    model: &RobotModel,
    base: Option<&str>,
    joints: Option<&[String]>,
) -> Result<(usize, Vec<usize>), MorphoError> {
    let err = |message: String| MorphoError::Body { message };
    let base = match base {
        Some(b) => model.link(b).map_err(|e| err(e.to_string()))?,
        None => {
            let roots: Vec<usize> = (0..model.links.len())
                .filter(|&l| model.parent_joint[l].is_none())
                .collect();
            match roots[..] {
                [r] => r,
                _ => return Err(err(format!("the URDF has {} root links", roots.len()))),
            }
        }
    };
    let below = |j: usize| {
        let mut link = model.joints[j].child;
        loop {
            if link == base {
                return true;
            }
            match model.parent_joint[link] {
                Some(p) => link = model.joints[p].parent,
                None => return false,
            }
        }
    };
    let ids = match joints {
        Some(names) => names
            .iter()
            .map(|n| model.joint_id(n).map_err(|e| err(e.to_string())))
            .collect::<Result<Vec<_>, _>>()?,
        None => (0..model.joints.len())
            .filter(|&j| {
                let jm = &model.joints[j];
                jm.kind.is_movable() && jm.mimic.is_none() && below(j)
            })
            .collect(),
    };
    if ids.is_empty() {
        return Err(err(format!(
            "no movable joint below link `{}`",
            model.links[base]
        )));
    }
    Ok((base, ids))
}

/// Derives the reflection group of the subtree of `model` below `base` (default: the root
/// link) acting on `joints` (default: every movable non-mimic joint below it), with other
/// movable joints held at `held` (0 when absent).
pub fn derive_body_symmetries(
    model: &RobotModel,
    base: Option<&str>,
    joints: Option<&[String]>,
    held: &HashMap<String, f64>,
    settings: &BodySettings,
) -> Result<BodySymmetries, MorphoError> {
    if settings.samples == 0 {
        return Err(MorphoError::NoSamples);
    }
    let (base, ids) = selection(model, base, joints)?;
    let st = structure(model, base, &ids, held)?;
    let n = ids.len();
    let mut ws = st.tree.workspace();
    st.tree.forward(&vec![0.0; n], &mut ws);
    let mut lines0 = vec![(Vector3::zeros(), Vector3::zeros()); n];
    axis_lines(&st, &ws, &mut lines0);

    let (candidates, requested) = match &settings.planes {
        Some(p) => {
            for v in p {
                if !(v.norm() > 0.0 && v.iter().all(|x| x.is_finite())) {
                    return Err(MorphoError::InvalidNormal {
                        normal: (*v).into(),
                    });
                }
            }
            (p.iter().map(|v| v.normalize()).collect(), true)
        }
        None => (candidate_normals(&st, &lines0, settings), false),
    };

    let mut reflections: Vec<(Matrix3<f64>, SignedPermutation, Vector3<f64>)> = Vec::new();
    let mut rejected = Vec::new();
    for (c, &normal) in candidates.iter().enumerate() {
        let s = Matrix3::identity() - 2.0 * normal * normal.transpose();
        let report = |reason: String, rejected: &mut Vec<RejectedPlane>| {
            // Coordinate planes (the first three candidates) and requested planes only:
            // the other candidates are guesses.
            if requested || c < 3 {
                rejected.push(RejectedPlane { normal, reason });
            }
        };
        let rho = match pair_joints(&st, &lines0, &s, settings) {
            Ok(rho) => rho,
            Err(reason) => {
                report(reason, &mut rejected);
                continue;
            }
        };
        if rho.is_identity() {
            report(
                "the plane contains the whole tree: it acts as the identity on the joints".into(),
                &mut rejected,
            );
            continue;
        }
        if reflections.iter().any(|(_, r, _)| *r == rho) {
            continue;
        }
        let (rho, el) = refine_mimic_signs(&st, model, &s, rho, settings);
        if settings.require_consistent_limits && !el.limit_mismatches.is_empty() {
            report(
                format!(
                    "the tree maps onto itself, but {} joint pair(s) have limits that do not: {}",
                    el.limit_mismatches.len(),
                    short_list(
                        &el.limit_mismatches
                            .iter()
                            .map(|m| format!("{}↔{}", m.joint_a, m.joint_b))
                            .collect::<Vec<_>>()
                    )
                ),
                &mut rejected,
            );
            continue;
        }
        if settings.strict_links && !el.unmatched_links.is_empty() {
            report(
                format!(
                    "the joints pair, but {} link(s) have no mirrored counterpart: {}",
                    el.unmatched_links.len(),
                    short_list(&el.unmatched_links)
                ),
                &mut rejected,
            );
            continue;
        }
        if !el.within(settings.residual_tolerance) {
            report(
                format!(
                    "the joints pair, but the sampled residual (position {:.2e} of the size, orientation {:.2e}) exceeds {:.1e}, worst at {}",
                    el.relative_residual, el.orientation_residual, settings.residual_tolerance, el.worst
                ),
                &mut rejected,
            );
            continue;
        }
        reflections.push((s, rho, normal));
    }

    // The group generated by the reflections, each element verified.
    let mut pairs: Vec<(Matrix3<f64>, SignedPermutation)> =
        vec![(Matrix3::identity(), SignedPermutation::identity(n))];
    pairs.extend(reflections.iter().map(|(s, r, _)| (*s, r.clone())));
    let generators = reflections.len();
    let mut frontier = 0;
    while frontier < pairs.len() {
        let (o, r) = pairs[frontier].clone();
        for (s, g, _) in &reflections {
            let c = (s * o, g.compose(&r));
            let known = pairs
                .iter()
                .any(|(o2, r2)| *r2 == c.1 && (o2 - c.0).amax() < 1e-9);
            if !known {
                if pairs.len() >= settings.max_order {
                    return Err(MorphoError::Body {
                        message: format!(
                            "the reflections generate more than {} elements",
                            settings.max_order
                        ),
                    });
                }
                pairs.push(c);
            }
        }
        frontier += 1;
    }
    let elements: Vec<BodyElement> = pairs
        .iter()
        .map(|(o, r)| verify(&st, model, o, r, settings))
        .collect();
    let order = elements.len();
    let involutions = elements
        .iter()
        .all(|e| e.rho_q.compose(&e.rho_q).is_identity());
    let group = match order {
        1 => "trivial".to_string(),
        2 => "C2".to_string(),
        4 if involutions => "K4".to_string(),
        _ if generators >= 2 && order % 2 == 0 => format!("D{}", order / 2),
        _ => format!("order {order}"),
    };
    Ok(BodySymmetries {
        robot: model.name.clone(),
        base: model.links[base].clone(),
        joints: ids.iter().map(|&j| model.joints[j].name.clone()).collect(),
        size: st.size,
        group,
        elements,
        generators,
        rejected,
        candidates: candidates.len(),
        samples: settings.samples,
    })
}

/// The first names of a list, with a count of the rest.
fn short_list(names: &[String]) -> String {
    if names.len() > 6 {
        format!("{}, … ({} in all)", names[..6].join(", "), names.len())
    } else {
        names.join(", ")
    }
}

/// Coordinate-plane normals first, then bisectors of equidistant joint-origin pairs.
fn candidate_normals(
    st: &Structure,
    lines0: &[(Vector3<f64>, Vector3<f64>)],
    settings: &BodySettings,
) -> Vec<Vector3<f64>> {
    let tol = settings.position_tolerance * st.size;
    let mut out: Vec<Vector3<f64>> = vec![Vector3::x(), Vector3::y(), Vector3::z()];
    let n = lines0.len();
    for i in 0..n {
        for k in i + 1..n {
            if st.prismatic[i] != st.prismatic[k] || st.depth[i] != st.depth[k] {
                continue;
            }
            let (pi, pk) = (lines0[i].0, lines0[k].0);
            let d = pi - pk;
            if d.norm() <= tol || (pi.norm() - pk.norm()).abs() > tol {
                continue;
            }
            let v = d.normalize();
            let dup = out.iter().any(|u| {
                (u - v).norm() < 10.0 * settings.axis_tolerance
                    || (u + v).norm() < 10.0 * settings.axis_tolerance
            });
            if !dup {
                out.push(v);
            }
        }
    }
    out
}

/// Where `O` sends joint `i`'s axis direction: `det(O)·O z` for rotations (axial vector),
/// `O z` for translations (polar vector).
fn mapped_direction(o: &Matrix3<f64>, z: &Vector3<f64>, prismatic: bool) -> Vector3<f64> {
    let m = o * z;
    if prismatic || o.determinant() > 0.0 {
        m
    } else {
        -m
    }
}

/// Sign with which `O` maps the line `(p, z)` of joint `i` onto the line `(pk, zk)` of
/// joint `k`, if it does within the tolerances; and the worst line distance.
fn line_match(
    o: &Matrix3<f64>,
    (p, z): (Vector3<f64>, Vector3<f64>),
    (pk, zk): (Vector3<f64>, Vector3<f64>),
    prismatic: bool,
    pos_tol: f64,
    axis_tol: f64,
) -> Option<f64> {
    let d = mapped_direction(o, &z, prismatic);
    let sign = if (d - zk).norm() <= axis_tol {
        1.0
    } else if (d + zk).norm() <= axis_tol {
        -1.0
    } else {
        return None;
    };
    ((o * p - pk).cross(&zk).norm() <= pos_tol).then_some(sign)
}

/// The signed permutation under which `O` maps the joint tree onto itself at `q = 0`.
fn pair_joints(
    st: &Structure,
    lines0: &[(Vector3<f64>, Vector3<f64>)],
    o: &Matrix3<f64>,
    settings: &BodySettings,
) -> Result<SignedPermutation, String> {
    let n = lines0.len();
    let pos_tol = settings.position_tolerance * st.size;
    let cand: Vec<Vec<(usize, f64)>> = (0..n)
        .map(|i| {
            (0..n)
                .filter(|&k| st.prismatic[k] == st.prismatic[i] && st.depth[k] == st.depth[i])
                .filter_map(|k| {
                    line_match(
                        o,
                        lines0[i],
                        lines0[k],
                        st.prismatic[i],
                        pos_tol,
                        settings.axis_tolerance,
                    )
                    .map(|s| (k, s))
                })
                .collect::<Vec<_>>()
        })
        .collect();
    // Several lines may coincide (wheels on one axle, collinear wrist axes): try first the
    // partner whose joint origin is the mirrored point.
    let cand: Vec<Vec<(usize, f64)>> = cand
        .into_iter()
        .enumerate()
        .map(|(i, mut c)| {
            // On a tie (two arms drawn on top of each other at q = 0) the swap comes first.
            let key = |k: usize| {
                let gap = (o * lines0[i].0 - lines0[k].0).norm();
                (gap > pos_tol, gap, k == i)
            };
            c.sort_by(|a, b| {
                let (ka, kb) = (key(a.0), key(b.0));
                ka.0.cmp(&kb.0)
                    .then(if ka.0 {
                        ka.1.total_cmp(&kb.1)
                    } else {
                        std::cmp::Ordering::Equal
                    })
                    .then(ka.2.cmp(&kb.2))
            });
            c
        })
        .collect();
    if let Some(i) = (0..n).find(|&i| cand[i].is_empty()) {
        return Err(format!(
            "joint `{}` has no mirrored counterpart",
            st.tree.links[st.child_slot[i]]
                .joint
                .as_ref()
                .map_or("?", |j| j.name.as_str())
        ));
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by_key(|&i| st.topo[i]);
    let mut image: Vec<Option<(usize, f64)>> = vec![None; n];
    let mut preimage: Vec<Option<usize>> = vec![None; n];
    let mut budget = 200_000_usize;
    if !assign(0, &order, &cand, st, &mut image, &mut preimage, &mut budget) {
        return Err(if budget == 0 {
            "the pairing search gave up (too many ambiguous axes)".into()
        } else {
            "no pairing of the joints preserves the tree".into()
        });
    }
    let (perm, signs): (Vec<usize>, Vec<f64>) = image
        .iter()
        .map(|c| c.expect("every joint assigned"))
        .unzip();
    // (ρ q)_i = s_i q_{π⁻¹... }: joint i's value lands on its image; for the involutions
    // found here π = π⁻¹, and in general the output slot k receives s · q_i for k = π(i).
    let mut out_perm = vec![0; n];
    let mut out_signs = vec![1.0; n];
    for i in 0..n {
        out_perm[perm[i]] = i;
        out_signs[perm[i]] = signs[i];
    }
    SignedPermutation::new(out_perm, out_signs)
}

/// Depth-first assignment of joint images in topological order, preserving parents.
fn assign(
    at: usize,
    order: &[usize],
    cand: &[Vec<(usize, f64)>],
    st: &Structure,
    image: &mut [Option<(usize, f64)>],
    preimage: &mut [Option<usize>],
    budget: &mut usize,
) -> bool {
    let Some(&i) = order.get(at) else {
        return true;
    };
    for &(k, s) in &cand[i] {
        if *budget == 0 {
            return false;
        }
        *budget -= 1;
        if preimage[k].is_some() {
            continue;
        }
        let parent_ok = match (st.parent[i], st.parent[k]) {
            (None, None) => true,
            (Some(pi), Some(pk)) => image[pi].map(|(x, _)| x) == Some(pk),
            _ => false,
        };
        if !parent_ok {
            continue;
        }
        image[i] = Some((k, s));
        preimage[k] = Some(i);
        if assign(at + 1, order, cand, st, image, preimage, budget) {
            return true;
        }
        image[i] = None;
        preimage[k] = None;
    }
    false
}

/// Verifies `(O, ρ)`; when it fails and some paired joints lead mimic joints, tries the
/// opposite sign on each such pair and keeps the flips that lower the residual.
fn refine_mimic_signs(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    mut rho: SignedPermutation,
    settings: &BodySettings,
) -> (SignedPermutation, BodyElement) {
    let mut el = verify(st, model, o, &rho, settings);
    if el.within(settings.residual_tolerance) {
        return (rho, el);
    }
    for i in (0..rho.dim()).filter(|&i| st.leads_mimic[i]) {
        let k = rho.perm[i];
        if k < i && st.leads_mimic[k] {
            continue; // the pair was tried from k
        }
        let mut flipped = rho.clone();
        flipped.signs[i] = -flipped.signs[i];
        if k != i {
            flipped.signs[k] = -flipped.signs[k];
        }
        let e = verify(st, model, o, &flipped, settings);
        if e.relative_residual.max(e.orientation_residual)
            < el.relative_residual.max(el.orientation_residual)
        {
            rho = flipped;
            el = e;
        }
    }
    (rho, el)
}

/// Verifies `(O, ρ)` on sampled configurations: axis lines of every joint and poses of every
/// link paired at `q = 0`.
fn verify(
    st: &Structure,
    model: &RobotModel,
    o: &Matrix3<f64>,
    rho: &SignedPermutation,
    settings: &BodySettings,
) -> BodyElement {
    let n = rho.dim();
    let tree = &st.tree;
    let (mut wa, mut wb) = (tree.workspace(), tree.workspace());
    let zero = vec![0.0; n];
    tree.forward(&zero, &mut wa);
    let tol = settings.position_tolerance * st.size;
    // Joint of q that each joint's value moves to: q_i lands on slot π(i) with ρ's inverse.
    let inv = rho.inverse();
    // Link pairs at q = 0: same image body, mirrored origin.
    let mut link_pairs = Vec::new();
    let mut unmatched = Vec::new();
    for (s, l) in tree.links.iter().enumerate() {
        let body = st.owner[s].map(|i| inv.perm[i]);
        let target = o * wa.poses[s].translation.vector;
        // The nearest link of the image body within the tolerance (itself on a tie).
        let gap = |m: usize| (wa.poses[m].translation.vector - target).norm();
        let m = (0..tree.links.len())
            .filter(|&m| st.owner[m] == body && gap(m) <= tol)
            .min_by(|&a, &b| gap(a).total_cmp(&gap(b)).then((a != s).cmp(&(b != s))));
        match m {
            Some(m) => {
                let e =
                    wa.poses[s].rotation.matrix().transpose() * o * wa.poses[m].rotation.matrix();
                link_pairs.push((s, m, e));
            }
            None => {
                let name = &model.links[l.link];
                if !settings.ignore_links.contains(name) {
                    unmatched.push(name.clone());
                }
            }
        }
    }
    let mut rng = SplitMix64::new(settings.seed);
    let (mut q, mut q_img) = (vec![0.0; n], vec![0.0; n]);
    let mut lines = vec![(Vector3::zeros(), Vector3::zeros()); n];
    let mut lines_img = lines.clone();
    let (mut pos_res, mut rot_res) = (0.0_f64, 0.0_f64);
    let mut worst = (0.0_f64, String::new());
    let bad = |r: f64| if r.is_finite() { r } else { f64::INFINITY };
    let joint_name = |i: usize| {
        tree.links[st.child_slot[i]]
            .joint
            .as_ref()
            .map_or("?", |j| j.name.as_str())
    };
    for _ in 0..settings.samples {
        sample_within_limits(&st.limits, &mut rng, &mut q);
        rho.apply(&q, &mut q_img);
        tree.forward(&q, &mut wa);
        tree.forward(&q_img, &mut wb);
        for &(s, m, e) in &link_pairs {
            let (a, b) = (&wa.poses[s], &wb.poses[m]);
            let r = bad((b.translation.vector - o * a.translation.vector).norm());
            let rr = bad((b.rotation.matrix() - o * a.rotation.matrix() * e).amax());
            if r / st.size > worst.0 || rr > worst.0 {
                worst = (
                    (r / st.size).max(rr),
                    format!("link `{}`", model.links[tree.links[s].link]),
                );
            }
            pos_res = pos_res.max(r);
            rot_res = rot_res.max(rr);
        }
        axis_lines(st, &wa, &mut lines);
        axis_lines(st, &wb, &mut lines_img);
        for i in 0..n {
            let k = inv.perm[i];
            let (p, z) = lines[i];
            let (pk, zk) = lines_img[k];
            let d = mapped_direction(o, &z, st.prismatic[i]);
            // The sign of a joint leading mimic joints may follow its mirrored follower
            // rather than its own axis: only the line is checked there.
            let dir = if st.leads_mimic[i] {
                (d - zk).norm().min((d + zk).norm())
            } else {
                (d - inv.signs[i] * zk).norm()
            };
            let off = bad((o * p - pk).cross(&zk).norm()).max(bad(dir * st.size));
            if off / st.size > worst.0 {
                worst = (off / st.size, format!("axis of joint `{}`", joint_name(i)));
            }
            pos_res = pos_res.max(off);
        }
    }
    // Each pair once (i ≤ its image), joints on themselves included.
    let limit_mismatches = (0..n)
        .filter(|&i| i <= inv.perm[i])
        .filter_map(|i| {
            let (k, s) = (inv.perm[i], inv.signs[i]);
            let (li, lk) = (st.limits[i], st.limits[k]);
            let expected = if s > 0.0 {
                [lk.lower, lk.upper]
            } else {
                [-lk.upper, -lk.lower]
            };
            let close = |x: f64, y: f64| x == y || (x - y).abs() <= settings.limit_tolerance;
            let name = |j: usize| {
                tree.links[st.child_slot[j]]
                    .joint
                    .as_ref()
                    .map_or(String::new(), |j| j.name.clone())
            };
            (!(close(li.lower, expected[0]) && close(li.upper, expected[1]))).then(|| {
                LimitMismatch {
                    joint_a: name(i),
                    joint_b: name(k),
                    sign: s,
                    limits_a: [li.lower, li.upper],
                    limits_b: [lk.lower, lk.upper],
                    expected_a: expected,
                }
            })
        })
        .collect();
    BodyElement {
        kind: classify(o),
        space: *o,
        rho_q: rho.clone(),
        link_pairs: link_pairs
            .iter()
            .map(|&(s, m, _)| {
                (
                    model.links[tree.links[s].link].clone(),
                    model.links[tree.links[m].link].clone(),
                )
            })
            .collect(),
        unmatched_links: unmatched,
        relative_residual: pos_res / st.size,
        orientation_residual: rot_res,
        worst: worst.1,
        limit_mismatches,
    }
}

/// Identity, reflection (normal), rotation (axis, angle) or rotoreflection.
fn classify(o: &Matrix3<f64>) -> ElementKind {
    if (o - Matrix3::identity()).amax() < 1e-9 {
        return ElementKind::Identity;
    }
    if o.determinant() < 0.0 {
        // A reflection is symmetric with eigenvalues (−1, 1, 1): I − O = 2nnᵀ.
        let m = (Matrix3::identity() - o) * 0.5;
        if (o - o.transpose()).amax() < 1e-9 && (m.trace() - 1.0).abs() < 1e-9 {
            let c = (0..3)
                .max_by(|&a, &b| m.column(a).norm().total_cmp(&m.column(b).norm()))
                .unwrap_or(0);
            let mut n = m.column(c).normalize();
            if n.iter().find(|x| x.abs() > 1e-12).is_some_and(|x| *x < 0.0) {
                n = -n;
            }
            return ElementKind::Reflection { normal: n };
        }
        return ElementKind::Rotoreflection;
    }
    let angle = ((o.trace() - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
    let axis = if std::f64::consts::PI - angle < 1e-6 {
        // R = 2aaᵀ − I at angle π: the axis is the largest column of (R + I)/2.
        let m = (o + Matrix3::identity()) * 0.5;
        let c = (0..3)
            .max_by(|&a, &b| m.column(a).norm().total_cmp(&m.column(b).norm()))
            .unwrap_or(0);
        m.column(c).normalize()
    } else {
        match Rotation3::from_matrix_unchecked(*o).axis() {
            Some(a) => a.into_inner(),
            None => return ElementKind::Identity,
        }
    };
    let mut a = axis;
    // At π the sense is irrelevant: the axis is written with its first non-zero entry positive.
    if std::f64::consts::PI - angle < 1e-6
        && a.iter().find(|x| x.abs() > 1e-12).is_some_and(|x| *x < 0.0)
    {
        a = -a;
    }
    ElementKind::Rotation { axis: a, angle }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A torso yaw on the plane, two 2-joint arms at y = ±0.2 mirrored across y = 0.
    fn humanoid_ish() -> RobotModel {
        let arm = |side: &str, y: f64, roll_axis: f64| {
            format!(
                r#"<link name="{side}_1"/><link name="{side}_2"/><link name="{side}_hand"/>
                <joint name="{side}_pitch" type="revolute"><parent link="torso"/><child link="{side}_1"/>
                  <origin xyz="0 {y} 0.3"/><axis xyz="0 1 0"/><limit lower="-2" upper="1" effort="1" velocity="1"/></joint>
                <joint name="{side}_roll" type="revolute"><parent link="{side}_1"/><child link="{side}_2"/>
                  <origin xyz="0 {y2} -0.1"/><axis xyz="{roll_axis} 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
                <joint name="{side}_hand_fix" type="fixed"><parent link="{side}_2"/><child link="{side}_hand"/>
                  <origin xyz="0.1 0 -0.3"/></joint>"#,
                y2 = y / 4.0
            )
        };
        let xml = format!(
            r#"<robot name="h"><link name="base"/><link name="torso"/>
            <joint name="waist_yaw" type="revolute"><parent link="base"/><child link="torso"/>
              <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
            {}{}</robot>"#,
            arm("left", 0.2, 1.0),
            arm("right", -0.2, -1.0)
        );
        RobotModel::from_urdf_str(&xml, "h").unwrap()
    }

    fn reflection(g: &BodySymmetries, n: Vector3<f64>) -> Option<&BodyElement> {
        g.reflections().iter().find(
            |e| matches!(e.kind, ElementKind::Reflection { normal } if (normal - n).norm() < 1e-12),
        )
    }

    fn strict() -> BodySettings {
        BodySettings {
            strict_links: true,
            ..BodySettings::default()
        }
    }

    #[test]
    fn sagittal_plane_of_a_small_humanoid() {
        let m = humanoid_ish();
        let g = derive_body_symmetries(&m, None, None, &HashMap::new(), &strict()).unwrap();
        assert_eq!(g.group, "C2", "{:?}", g.rejected);
        let r = reflection(&g, Vector3::y()).expect("sagittal plane");
        // joints: waist_yaw, left_pitch, left_roll, right_pitch, right_roll.
        // Yaw about z on the plane flips; pitch about y keeps its sign; the roll axes are
        // written +x and −x, so the mirrored roll (axial: −S x = −x) equals the right's +1.
        assert_eq!(r.rho_q.perm, vec![0, 3, 4, 1, 2]);
        assert_eq!(r.rho_q.signs, vec![-1.0, 1.0, 1.0, 1.0, 1.0]);
        assert!(r.relative_residual < 1e-12);
        assert!(r.unmatched_links.is_empty(), "{:?}", r.unmatched_links);
        // Pitch limits [-2, 1] map onto themselves (s = +1); yaw [-1, 1] is symmetric.
        assert!(r.limit_mismatches.is_empty(), "{:?}", r.limit_mismatches);
        // The joints alone pair across the frontal plane x = 0 too (every axis line lies in
        // it or is normal to it) but the hands, offset forward by 0.1 m, do not: with
        // `strict_links` the plane is refused naming them, the transverse plane for its joints.
        assert_eq!(g.rejected.len(), 2, "{:?}", g.rejected);
        let x = g
            .rejected
            .iter()
            .find(|r| r.normal == Vector3::x())
            .unwrap();
        assert!(x.reason.contains("left_hand"), "{}", x.reason);
        // By default the frontal plane is kept and the hands are listed with it.
        let g = derive_body_symmetries(&m, None, None, &HashMap::new(), &BodySettings::default())
            .unwrap();
        assert_eq!(g.group, "K4", "{:?}", g.rejected);
        let x = reflection(&g, Vector3::x()).expect("frontal plane");
        assert_eq!(x.unmatched_links, vec!["left_hand", "right_hand"]);
        assert!(reflection(&g, Vector3::y())
            .unwrap()
            .unmatched_links
            .is_empty());
        // Ignoring the hands by name: K4 under the strict check, whose third element is the
        // rotation by π about the vertical axis.
        let mut s = strict();
        s.ignore_links = vec!["left_hand".into(), "right_hand".into()];
        let g = derive_body_symmetries(&m, None, None, &HashMap::new(), &s).unwrap();
        assert_eq!(g.group, "K4", "{:?}", g.rejected);
        assert_eq!(g.elements.len(), 4);
        let kinds: Vec<ElementKind> = g.elements.iter().map(|e| e.kind).collect();
        assert!(
            kinds.iter().any(|k| matches!(k,
                ElementKind::Rotation { axis, angle } if (axis - Vector3::z()).norm() < 1e-9
                    && (angle - std::f64::consts::PI).abs() < 1e-9)),
            "{kinds:?}"
        );
    }

    #[test]
    fn broken_mirror_is_refused_and_tolerance_is_relative() {
        let m = humanoid_ish();
        let mut m2 = m.clone();
        let j = m2.joint_id("right_roll").unwrap();
        // 10 µm off on a robot of size ~1 m: accepted at the default 1e-4 relative.
        m2.joints[j].origin.translation.vector.z += 1e-5;
        let g = derive_body_symmetries(&m2, None, None, &HashMap::new(), &strict()).unwrap();
        assert_eq!(g.group, "C2");
        let r = g.reflections()[0].relative_residual;
        assert!(r > 1e-6 && r < 1e-4, "{r}");
        // 1 cm off: refused.
        m2.joints[j].origin.translation.vector.z += 1e-2;
        let g = derive_body_symmetries(&m2, None, None, &HashMap::new(), &strict()).unwrap();
        assert_eq!(g.group, "trivial", "{:?}", g.elements.len());
        assert!(g
            .rejected
            .iter()
            .any(|r| (r.normal - Vector3::y()).norm() < 1e-12));
    }
}
