//! The kinematic tree below the base as the derivation sees it: the joints of `q`, their
//! parents, depths and kinds, the rigid body each link belongs to, and the axis lines.

use std::collections::HashMap;

use nalgebra::Vector3;

use super::super::chains::MorphoError;
use crate::kinematics::{JointKind, LinkTree, LinkTreeWorkspace, RobotModel};

/// Geometry of the tree at `q = 0` and the joint structure the pairing needs.
pub(super) struct Structure {
    pub(super) tree: LinkTree,
    /// Per joint of `q`: slot of its child link.
    pub(super) child_slot: Vec<usize>,
    /// Per joint: nearest joint of `q` above it.
    pub(super) parent: Vec<Option<usize>>,
    /// Per joint: number of joints of `q` above it.
    pub(super) depth: Vec<usize>,
    /// Per joint: rotation (false) or translation (true).
    pub(super) prismatic: Vec<bool>,
    /// Per slot: nearest joint of `q` at or above the link (the rigid body it belongs to).
    pub(super) owner: Vec<Option<usize>>,
    /// Joint limits per joint of `q`.
    pub(super) limits: Vec<crate::kinematics::JointLimits>,
    /// Per joint of `q`: its order in the topological (breadth-first) traversal.
    pub(super) topo: Vec<usize>,
    /// Per joint of `q`: whether some mimic joint follows it.
    pub(super) leads_mimic: Vec<bool>,
    pub(super) size: f64,
}

/// Axis line `(point, unit direction)` of every joint of `q` at the poses in `ws`.
pub(super) fn axis_lines(
    st: &Structure,
    ws: &LinkTreeWorkspace,
    out: &mut [(Vector3<f64>, Vector3<f64>)],
) {
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

pub(super) fn structure(
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
pub(super) fn selection(
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
