//! Forward kinematics of a whole kinematic subtree: every link pose at once.
//!
//! For the subtree of a URDF below a root link `r`, each link `L` with parent joint `j`
//! has the pose, in the frame of `r`,
//!
//! `T_L(q) = T_{parent(L)}(q) · T_origin(j) · Motion_j(q_j)`,  `T_r = I`,
//!
//! evaluated parents first. A chosen set of movable joints forms `q` (in the given
//! order); a mimic joint follows its leader, `q_j = m · q_leader + c` (URDF `<mimic>`);
//! every other joint is held at a constant value (fixed joints, joints left out). The whole-body morphological derivation
//! ([`crate::symmetry::transfer::morpho`]) checks that a reflection maps every one of
//! these poses onto another.

use nalgebra::IsometryMatrix3;

use super::error::KinematicsError;
use super::model::{JointModel, RobotModel};

/// One link of a [`LinkTree`] in topological order.
#[derive(Debug, Clone)]
pub struct TreeLink {
    /// Index of the link in [`RobotModel::links`].
    pub link: usize,
    /// Slot of the parent link in [`LinkTree::links`] (`None` for the root).
    pub parent: Option<usize>,
    /// The joint whose child this link is (`None` for the root).
    pub joint: Option<JointModel>,
    /// Index of that joint in `q`, when it is one of the tree's joints.
    pub q_index: Option<usize>,
    /// Value at which the joint is held when it is not in `q` (rad or m).
    pub held: f64,
    /// For a mimic joint whose leader is in `q`: `(leader's index in q, multiplier, offset)`.
    pub mimic: Option<(usize, f64, f64)>,
}

/// The subtree below a root link with a chosen joint vector `q`.
#[derive(Debug, Clone)]
pub struct LinkTree {
    /// Links of the subtree, parents before children; `links[0]` is the root.
    pub links: Vec<TreeLink>,
    /// Model indices of the joints forming `q`, in `q` order.
    pub joints: Vec<usize>,
}

/// Caller-owned scratch for [`LinkTree::forward`].
#[derive(Debug, Clone)]
pub struct LinkTreeWorkspace {
    /// Pose of every link of the tree in the root frame (m), in [`LinkTree::links`] order.
    pub poses: Vec<IsometryMatrix3<f64>>,
}

impl LinkTree {
    /// The subtree of `model` below link `root`, with `q` made of the model joints `joints`
    /// (each a movable joint inside the subtree) and every other movable joint held at
    /// `held(joint index)` (rad or m).
    pub fn new(
        model: &RobotModel,
        root: usize,
        joints: &[usize],
        held: impl Fn(usize) -> f64,
    ) -> Result<Self, KinematicsError> {
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); model.links.len()];
        for (j, jm) in model.joints.iter().enumerate() {
            children[jm.parent].push(j);
        }
        let mut links = vec![TreeLink {
            link: root,
            parent: None,
            joint: None,
            q_index: None,
            held: 0.0,
            mimic: None,
        }];
        let mut head = 0;
        while head < links.len() {
            let link = links[head].link;
            for &j in &children[link] {
                let jm = &model.joints[j];
                let q_index = joints.iter().position(|&k| k == j);
                let mimic = jm
                    .mimic
                    .as_ref()
                    .filter(|_| q_index.is_none())
                    .and_then(|m| {
                        let leader = model.joint_id(&m.leader).ok()?;
                        let i = joints.iter().position(|&k| k == leader)?;
                        Some((i, m.multiplier, m.offset))
                    });
                links.push(TreeLink {
                    mimic,
                    link: jm.child,
                    parent: Some(head),
                    joint: Some(jm.clone()),
                    q_index,
                    held: if q_index.is_none() && jm.kind.is_movable() {
                        match &jm.mimic {
                            // A mimic of a held joint follows the held value.
                            Some(m) if mimic.is_none() => model
                                .joint_id(&m.leader)
                                .map_or(0.0, |l| m.multiplier * held(l) + m.offset),
                            _ => held(j),
                        }
                    } else {
                        0.0
                    },
                });
            }
            head += 1;
        }
        for &j in joints {
            let jm = &model.joints[j];
            let inside = links.iter().skip(1).any(|l| l.link == jm.child);
            if !inside || !jm.kind.is_movable() {
                return Err(KinematicsError::InvalidSetting {
                    field: "joints".into(),
                    message: format!(
                        "joint `{}` is not a movable joint below link `{}`",
                        jm.name, model.links[root]
                    ),
                });
            }
        }
        Ok(Self {
            links,
            joints: joints.to_vec(),
        })
    }

    /// Number of joints in `q`.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// A workspace sized for this tree.
    pub fn workspace(&self) -> LinkTreeWorkspace {
        LinkTreeWorkspace {
            poses: vec![IsometryMatrix3::identity(); self.links.len()],
        }
    }

    /// Slot of model link `link` in [`LinkTree::links`], if it is in the subtree.
    pub fn slot(&self, link: usize) -> Option<usize> {
        self.links.iter().position(|l| l.link == link)
    }

    /// Every link pose `T_L(q)` in the root frame (m) into `ws.poses`. Allocation-free.
    pub fn forward(&self, q: &[f64], ws: &mut LinkTreeWorkspace) {
        ws.poses[0] = IsometryMatrix3::identity();
        for (s, l) in self.links.iter().enumerate().skip(1) {
            let (Some(p), Some(j)) = (l.parent, &l.joint) else {
                continue;
            };
            let v = match (l.q_index, l.mimic) {
                (Some(i), _) => q[i],
                (None, Some((i, m, c))) => m * q[i] + c,
                (None, None) => l.held,
            };
            ws.poses[s] = ws.poses[p] * j.origin * j.motion(v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const URDF: &str = r#"<robot name="t">
      <link name="base"/><link name="a"/><link name="b"/><link name="c"/>
      <joint name="j1" type="revolute"><parent link="base"/><child link="a"/>
        <origin xyz="0 1 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="j2" type="prismatic"><parent link="a"/><child link="b"/>
        <origin xyz="1 0 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="f" type="fixed"><parent link="b"/><child link="c"/><origin xyz="0 0 2"/></joint>
    </robot>"#;

    #[test]
    fn poses_compose_origins_and_motions() {
        let m = RobotModel::from_urdf_str(URDF, "t").unwrap();
        let tree = LinkTree::new(&m, 0, &[m.joint_id("j1").unwrap()], |_| 0.5).unwrap();
        let mut ws = tree.workspace();
        tree.forward(&[std::f64::consts::FRAC_PI_2], &mut ws);
        // j1 at π/2 turns x into y; j2 held at 0.5 slides along the rotated x.
        let c = ws.poses[tree.slot(m.link("c").unwrap()).unwrap()]
            .translation
            .vector;
        assert!(
            (c - nalgebra::Vector3::new(0.0, 1.0 + 1.5, 2.0)).norm() < 1e-12,
            "{c}"
        );
        assert!(LinkTree::new(&m, 1, &[m.joint_id("j1").unwrap()], |_| 0.0).is_err());
    }
}
