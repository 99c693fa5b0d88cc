//! Immutable robot model loaded from URDF.
//!
//! A URDF describes a tree of links connected by joints. Each joint `j` carries a
//! fixed transform `T_origin(j)` from its parent link frame to the joint frame
//! (URDF `<origin xyz rpy>`, with `rpy` the fixed-axis roll–pitch–yaw convention
//! `R = Rz(yaw)·Ry(pitch)·Rx(roll)`), a unit axis expressed in the joint frame and
//! limits. The child link frame is `T_origin(j) · Motion(axis, q_j)`.
//!
//! Besides the standard attributes, vendor URDFs such as RB-Y1's carry
//! `<limit acceleration="…">` on URDF 1.0 files, which `urdf-rs` drops for
//! versions below 1.2. We read it back from the XML so that it is kept when present.

use std::collections::HashMap;
use std::path::Path;

use nalgebra::{IsometryMatrix3, Rotation3, Translation3, Unit, Vector3};

use super::error::KinematicsError;

/// Kind of a URDF joint as far as kinematics is concerned.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum JointKind {
    /// Rotation about the axis, bounded by position limits (rad).
    Revolute,
    /// Rotation about the axis without position limits (rad).
    Continuous,
    /// Translation along the axis (m).
    Prismatic,
    /// No motion.
    Fixed,
    /// Floating, planar or spherical joints: loaded but not usable inside a chain.
    Unsupported,
}

impl JointKind {
    /// True for joints with one degree of freedom (revolute, continuous, prismatic).
    pub fn is_movable(self) -> bool {
        matches!(self, Self::Revolute | Self::Continuous | Self::Prismatic)
    }
}

/// Limits of one joint in SI units (rad or m, per second, per second squared).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointLimits {
    /// Lower position limit (rad or m); `-inf` for continuous joints.
    pub lower: f64,
    /// Upper position limit (rad or m); `+inf` for continuous joints.
    pub upper: f64,
    /// Velocity limit magnitude (rad/s or m/s); `+inf` when absent.
    pub velocity: f64,
    /// Effort limit magnitude (N·m or N); `+inf` when absent.
    pub effort: f64,
    /// Acceleration limit magnitude (rad/s² or m/s²) when the URDF or config gives one.
    pub acceleration: Option<f64>,
}

impl JointLimits {
    /// Limits that bound nothing.
    pub const UNBOUNDED: Self = Self {
        lower: f64::NEG_INFINITY,
        upper: f64::INFINITY,
        velocity: f64::INFINITY,
        effort: f64::INFINITY,
        acceleration: None,
    };

    /// The middle of the range (rad or m); 0 where a side is unbounded.
    pub fn centre(&self) -> f64 {
        if self.lower.is_finite() && self.upper.is_finite() {
            0.5 * (self.lower + self.upper)
        } else {
            0.0
        }
    }

    /// True when `q` lies in `[lower, upper]` (rad or m).
    pub fn contains(&self, q: f64) -> bool {
        q >= self.lower && q <= self.upper
    }
}

/// One joint of the model.
#[derive(Debug, Clone)]
pub struct JointModel {
    /// URDF joint name.
    pub name: String,
    /// Joint type.
    pub kind: JointKind,
    /// Index of the parent link in [`RobotModel::links`].
    pub parent: usize,
    /// Index of the child link in [`RobotModel::links`].
    pub child: usize,
    /// Transform from the parent link frame to the joint frame.
    pub origin: IsometryMatrix3<f64>,
    /// Unit joint axis in the joint frame.
    pub axis: Unit<Vector3<f64>>,
    /// Position/velocity/effort/acceleration limits.
    pub limits: JointLimits,
    /// URDF `<mimic>`: the joint follows another and is not an independent DoF.
    pub mimic: Option<Mimic>,
}

/// A mimic joint's relation to its leader: `q = multiplier · q_leader + offset`.
#[derive(Debug, Clone, PartialEq)]
pub struct Mimic {
    /// Name of the leader joint.
    pub leader: String,
    /// Multiplier (dimensionless; 1 when absent).
    pub multiplier: f64,
    /// Offset (rad or m; 0 when absent).
    pub offset: f64,
}

impl JointModel {
    /// Transform from the joint frame to the child link frame at joint value `q` (rad or m).
    pub fn motion(&self, q: f64) -> IsometryMatrix3<f64> {
        match self.kind {
            JointKind::Revolute | JointKind::Continuous => IsometryMatrix3::from_parts(
                Translation3::identity(),
                Rotation3::from_axis_angle(&self.axis, q),
            ),
            JointKind::Prismatic => IsometryMatrix3::from_parts(
                Translation3::from(self.axis.into_inner() * q),
                Rotation3::identity(),
            ),
            JointKind::Fixed | JointKind::Unsupported => IsometryMatrix3::identity(),
        }
    }
}

/// An immutable kinematic tree loaded from URDF.
#[derive(Debug, Clone)]
pub struct RobotModel {
    /// Robot name from `<robot name>`.
    pub name: String,
    /// Where the model came from (file path or `<string>`), for error messages.
    pub origin: String,
    /// Link names, indexed by link id.
    pub links: Vec<String>,
    /// Joints in URDF order.
    pub joints: Vec<JointModel>,
    /// For every link, the joint whose child it is (`None` for the root).
    pub parent_joint: Vec<Option<usize>>,
    link_index: HashMap<String, usize>,
    joint_index: HashMap<String, usize>,
}

fn urdf_pose(p: &urdf_rs::Pose) -> IsometryMatrix3<f64> {
    let [x, y, z] = p.xyz.0;
    let [r, pi, ya] = p.rpy.0;
    IsometryMatrix3::from_parts(
        Translation3::new(x, y, z),
        Rotation3::from_euler_angles(r, pi, ya),
    )
}

impl RobotModel {
    /// Loads a URDF file. Errors name the file and the offending element.
    pub fn from_urdf_file(path: impl AsRef<Path>) -> Result<Self, KinematicsError> {
        let path = path.as_ref();
        let xml = std::fs::read_to_string(path).map_err(|source| KinematicsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_urdf_str(&xml, &path.display().to_string())
    }

    /// Parses URDF text; `origin` labels the source in error messages.
    pub fn from_urdf_str(xml: &str, origin: &str) -> Result<Self, KinematicsError> {
        let robot = urdf_rs::read_from_string(xml).map_err(|e| KinematicsError::Urdf {
            origin: origin.to_string(),
            message: e.to_string(),
        })?;
        let mut model = Self::build(&robot, origin)?;
        // urdf-rs drops `acceleration` for URDF < 1.2; read it back from the XML.
        let accel = acceleration_attributes(xml, origin)?;
        for (name, a) in accel {
            if let Some(&j) = model.joint_index.get(&name) {
                model.joints[j].limits.acceleration = Some(a);
            }
        }
        Ok(model)
    }

    fn build(robot: &urdf_rs::Robot, origin: &str) -> Result<Self, KinematicsError> {
        let (links, link_index) = index_links(robot, origin)?;
        let mut parent_joint = vec![None; links.len()];
        let mut joints = Vec::with_capacity(robot.joints.len());
        let mut joint_index = HashMap::new();
        for j in &robot.joints {
            let joint = joint_model(j, &link_index, origin)?;
            let child = joint.child;
            if parent_joint[child].is_some() {
                return Err(KinematicsError::BadTree {
                    origin: origin.into(),
                    link: j.child.link.clone(),
                    message: "link is the child of more than one joint".into(),
                });
            }
            parent_joint[child] = Some(joints.len());
            if joint_index.insert(j.name.clone(), joints.len()).is_some() {
                return Err(bad_joint(origin, j, "joint defined twice".into()));
            }
            joints.push(joint);
        }
        let model = Self {
            name: robot.name.clone(),
            origin: origin.into(),
            links,
            joints,
            parent_joint,
            link_index,
            joint_index,
        };
        model.check_acyclic()?;
        Ok(model)
    }

    fn check_acyclic(&self) -> Result<(), KinematicsError> {
        for start in 0..self.links.len() {
            let mut link = start;
            let mut steps = 0;
            while let Some(j) = self.parent_joint[link] {
                link = self.joints[j].parent;
                steps += 1;
                if steps > self.links.len() {
                    return Err(KinematicsError::BadTree {
                        origin: self.origin.clone(),
                        link: self.links[start].clone(),
                        message: "the joint graph has a cycle".into(),
                    });
                }
            }
        }
        Ok(())
    }

    /// Index of the link called `name`.
    pub fn link(&self, name: &str) -> Result<usize, KinematicsError> {
        self.link_index
            .get(name)
            .copied()
            .ok_or_else(|| KinematicsError::UnknownLink {
                robot: self.name.clone(),
                link: name.into(),
                known: truncated_list(self.links.iter()),
            })
    }

    /// Index of the joint called `name`.
    pub fn joint_id(&self, name: &str) -> Result<usize, KinematicsError> {
        self.joint_index
            .get(name)
            .copied()
            .ok_or_else(|| KinematicsError::UnknownJoint {
                robot: self.name.clone(),
                joint: name.into(),
                known: truncated_list(
                    self.joints
                        .iter()
                        .filter(|j| j.kind.is_movable())
                        .map(|j| &j.name),
                ),
            })
    }

    /// The joint called `name`.
    pub fn joint(&self, name: &str) -> Result<&JointModel, KinematicsError> {
        Ok(&self.joints[self.joint_id(name)?])
    }

    /// Overrides (or supplies) the acceleration limit of a joint (rad/s² or m/s²).
    pub fn set_acceleration_limit(&mut self, joint: &str, a: f64) -> Result<(), KinematicsError> {
        if !(a.is_finite() && a > 0.0) {
            return Err(KinematicsError::InvalidSetting {
                field: format!("limits.{joint}.acceleration"),
                message: format!("{a} is not a positive finite number"),
            });
        }
        let id = self.joint_id(joint)?;
        self.joints[id].limits.acceleration = Some(a);
        Ok(())
    }

    /// Overrides the velocity limit of a joint (rad/s or m/s).
    pub fn set_velocity_limit(&mut self, joint: &str, v: f64) -> Result<(), KinematicsError> {
        if !(v.is_finite() && v > 0.0) {
            return Err(KinematicsError::InvalidSetting {
                field: format!("limits.{joint}.velocity"),
                message: format!("{v} is not a positive finite number"),
            });
        }
        let id = self.joint_id(joint)?;
        self.joints[id].limits.velocity = v;
        Ok(())
    }

    /// Narrows the position range of a joint to `[lower, upper]` (rad or m; `None` keeps
    /// that side): a workcell that forbids part of a joint's range. Refuses to widen the
    /// URDF's range, an empty range, and non-finite values.
    pub fn narrow_position_limits(
        &mut self,
        joint: &str,
        lower: Option<f64>,
        upper: Option<f64>,
    ) -> Result<(), KinematicsError> {
        let id = self.joint_id(joint)?;
        let l = self.joints[id].limits;
        let (lo, hi) = (lower.unwrap_or(l.lower), upper.unwrap_or(l.upper));
        let bad = |message: String| KinematicsError::InvalidSetting {
            field: format!("limits.{joint}"),
            message,
        };
        for (side, v) in [("lower", lower), ("upper", upper)] {
            if v.is_some_and(|v| !v.is_finite()) {
                return Err(bad(format!("{side} = {v:?} is not finite")));
            }
        }
        if lo < l.lower || hi > l.upper {
            return Err(bad(format!(
                "[{lo}, {hi}] widens the URDF's range [{}, {}]; limits may only narrow it",
                l.lower, l.upper
            )));
        }
        if lo >= hi {
            return Err(bad(format!("lower {lo} is not below upper {hi}")));
        }
        self.joints[id].limits.lower = lo;
        self.joints[id].limits.upper = hi;
        Ok(())
    }

    /// Joints on the path from `base` to `tip`, in order from base to tip.
    pub fn path(&self, base: usize, tip: usize) -> Option<Vec<usize>> {
        let mut out = Vec::new();
        let mut link = tip;
        while link != base {
            let j = self.parent_joint[link]?;
            out.push(j);
            link = self.joints[j].parent;
        }
        out.reverse();
        Some(out)
    }
}

impl TryFrom<&urdf_rs::Robot> for RobotModel {
    type Error = KinematicsError;
    /// Converts a parsed `urdf-rs` robot. Acceleration limits survive only for URDF ≥ 1.2
    /// here; use [`RobotModel::from_urdf_str`] to keep them on older files.
    fn try_from(robot: &urdf_rs::Robot) -> Result<Self, Self::Error> {
        Self::build(robot, "<urdf_rs::Robot>")
    }
}

fn positive_or_inf(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        f64::INFINITY
    }
}

/// The URDF's link names in order and their indices; a link defined twice is refused.
fn index_links(
    robot: &urdf_rs::Robot,
    origin: &str,
) -> Result<(Vec<String>, HashMap<String, usize>), KinematicsError> {
    let mut link_index = HashMap::new();
    let mut links = Vec::with_capacity(robot.links.len());
    for l in &robot.links {
        if link_index.insert(l.name.clone(), links.len()).is_some() {
            return Err(KinematicsError::BadTree {
                origin: origin.into(),
                link: l.name.clone(),
                message: "link defined twice".into(),
            });
        }
        links.push(l.name.clone());
    }
    Ok((links, link_index))
}

/// The error for a bad joint `j` of the URDF `origin`.
fn bad_joint(origin: &str, j: &urdf_rs::Joint, message: String) -> KinematicsError {
    KinematicsError::BadJoint {
        origin: origin.into(),
        joint: j.name.clone(),
        message,
    }
}

/// One URDF joint checked and converted (links, kind, axis, origin, limits, mimic).
fn joint_model(
    j: &urdf_rs::Joint,
    link_index: &HashMap<String, usize>,
    origin: &str,
) -> Result<JointModel, KinematicsError> {
    let bad = |message: String| bad_joint(origin, j, message);
    let parent = *link_index
        .get(&j.parent.link)
        .ok_or_else(|| bad(format!("parent link `{}` is not defined", j.parent.link)))?;
    let child = *link_index
        .get(&j.child.link)
        .ok_or_else(|| bad(format!("child link `{}` is not defined", j.child.link)))?;
    let kind = match j.joint_type {
        urdf_rs::JointType::Revolute => JointKind::Revolute,
        urdf_rs::JointType::Continuous => JointKind::Continuous,
        urdf_rs::JointType::Prismatic => JointKind::Prismatic,
        urdf_rs::JointType::Fixed => JointKind::Fixed,
        _ => JointKind::Unsupported,
    };
    let a = Vector3::from(j.axis.xyz.0);
    if kind.is_movable() && !(a.norm() > 1e-9 && a.iter().all(|v| v.is_finite())) {
        return Err(bad(format!(
            "axis {:?} is not a non-zero finite vector",
            a.as_slice()
        )));
    }
    let axis = if a.norm() > 1e-9 {
        Unit::new_normalize(a)
    } else {
        Vector3::x_axis()
    };
    let pose = urdf_pose(&j.origin);
    if !pose.translation.vector.iter().all(|v| v.is_finite())
        || !pose.rotation.matrix().iter().all(|v| v.is_finite())
    {
        return Err(bad("origin is not finite".into()));
    }
    let limits = joint_limits(kind, &j.limit).map_err(bad)?;
    Ok(JointModel {
        name: j.name.clone(),
        kind,
        parent,
        child,
        origin: pose,
        axis,
        limits,
        mimic: j.mimic.as_ref().map(|m| Mimic {
            leader: m.joint.clone(),
            multiplier: m.multiplier.unwrap_or(1.0),
            offset: m.offset.unwrap_or(0.0),
        }),
    })
}

/// A joint's limits by its kind; position limits that are not an interval are refused.
fn joint_limits(kind: JointKind, lim: &urdf_rs::JointLimit) -> Result<JointLimits, String> {
    Ok(match kind {
        JointKind::Continuous => JointLimits {
            lower: f64::NEG_INFINITY,
            upper: f64::INFINITY,
            velocity: positive_or_inf(lim.velocity),
            effort: positive_or_inf(lim.effort),
            acceleration: None,
        },
        JointKind::Revolute | JointKind::Prismatic => {
            if lim.lower.is_nan() || lim.upper.is_nan() || lim.lower > lim.upper {
                return Err(format!(
                    "position limits [{}, {}] are not an interval",
                    lim.lower, lim.upper
                ));
            }
            JointLimits {
                lower: lim.lower,
                upper: lim.upper,
                velocity: positive_or_inf(lim.velocity),
                effort: positive_or_inf(lim.effort),
                acceleration: lim.acceleration.is_finite().then_some(lim.acceleration),
            }
        }
        _ => JointLimits::UNBOUNDED,
    })
}

fn truncated_list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let all: Vec<&str> = names.map(String::as_str).collect();
    if all.len() > 24 {
        format!("{}, … ({} in all)", all[..24].join(", "), all.len())
    } else {
        all.join(", ")
    }
}

/// `(joint name, acceleration)` for every `<joint><limit acceleration=…>` in the XML.
fn acceleration_attributes(xml: &str, origin: &str) -> Result<Vec<(String, f64)>, KinematicsError> {
    let doc = roxmltree::Document::parse(xml).map_err(|e| KinematicsError::Urdf {
        origin: origin.into(),
        message: e.to_string(),
    })?;
    let mut out = Vec::new();
    for joint in doc.descendants().filter(|n| n.has_tag_name("joint")) {
        let Some(name) = joint.attribute("name") else {
            continue;
        };
        for limit in joint.children().filter(|n| n.has_tag_name("limit")) {
            if let Some(text) = limit.attribute("acceleration") {
                let a: f64 = text.trim().parse().map_err(|_| KinematicsError::BadJoint {
                    origin: origin.into(),
                    joint: name.into(),
                    message: format!("limit acceleration `{text}` is not a number"),
                })?;
                if !(a.is_finite() && a > 0.0) {
                    return Err(KinematicsError::BadJoint {
                        origin: origin.into(),
                        joint: name.into(),
                        message: format!("limit acceleration {a} is not positive and finite"),
                    });
                }
                out.push((name.to_string(), a));
            }
        }
    }
    Ok(out)
}
