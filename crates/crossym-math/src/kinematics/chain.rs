//! Serial kinematic chain: forward kinematics and the geometric Jacobian.
//!
//! A chain from a base link `b` to a tip link `t` is the joint path `j_1 … j_n` of the
//! URDF tree. Fixed joints and movable joints held at configured values are folded
//! into constant transforms, so that
//!
//! `T_bt(q) = A_0 · M_1(q_1) · A_1 · M_2(q_2) ⋯ M_n(q_n) · A_n`,
//!
//! with `M_i` a rotation about (revolute) or translation along (prismatic) the unit
//! axis `a_i`, and `A_n` including the configured tool offset. The geometric Jacobian
//! (base frame, reference point at the tip, twist `[v; ω]`) has columns
//! `[z_i × (p_t − p_i); z_i]` for revolute and `[z_i; 0]` for prismatic joints, with
//! `z_i` the world axis and `p_i` the world origin of joint `i` (Siciliano et al.,
//! *Robotics: Modelling, Planning and Control*, eq. 3.30). This is `J(q) = df|_q`
//! of the paper (Sec. II-C).
//!
//! Each joint frame is rotated by a constant `R_i` with `R_i e_z = a_i` (folded into the
//! neighbouring constants: `M_i(q) = R_i M_z(q) R_iᵀ`), so every joint moves about or
//! along `z`: a revolute joint then only mixes two columns of the accumulated rotation
//! with `(cos q, sin q)`, and constants without rotation only translate.
//!
//! All per-tick functions write into a caller-owned [`ChainWorkspace`] and allocate nothing.

use std::collections::HashMap;

use nalgebra::{IsometryMatrix3, Matrix3xX, Matrix6xX, Rotation3, Unit, Vector3};
use serde::{Deserialize, Serialize};

use super::error::KinematicsError;
use super::model::{JointKind, JointLimits, JointModel, RobotModel};

/// Which coordinates of the tip form the task-space point `x = f(q)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum TaskSpace {
    /// Tip position `(x, y)` in the base frame (planar robots); `X = R²`.
    Xy,
    /// Tip position `(x, y, z)` in the base frame; `X = R³`.
    #[default]
    Xyz,
}

impl TaskSpace {
    /// Dimension of the task space (2 or 3).
    pub const fn dim(self) -> usize {
        match self {
            Self::Xy => 2,
            Self::Xyz => 3,
        }
    }
}

/// What a chain is made of, by name (from configuration).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainSpec {
    /// Chain name (e.g. `left`), used in messages and as a key.
    pub name: String,
    /// Base link name; task-space points are expressed in this link's frame.
    pub base: String,
    /// Tip link name.
    pub tip: String,
    /// Tool offset from the tip link frame: translation (m) and roll-pitch-yaw (rad).
    #[serde(default)]
    pub tool: ToolOffset,
    /// Task-space coordinates of this chain.
    #[serde(default)]
    pub task: TaskSpace,
}

impl ChainSpec {
    /// The chain `name` from link `base` to link `tip`, task coordinates `task`, no tool offset.
    pub fn new(name: &str, base: &str, tip: &str, task: TaskSpace) -> Self {
        Self {
            name: name.into(),
            base: base.into(),
            tip: tip.into(),
            tool: ToolOffset::default(),
            task,
        }
    }
}

/// A fixed transform from the tip link frame to the tool point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ToolOffset {
    /// Translation in the tip link frame (m).
    #[serde(default)]
    pub xyz: [f64; 3],
    /// Fixed-axis roll, pitch, yaw (rad).
    #[serde(default)]
    pub rpy: [f64; 3],
}

impl ToolOffset {
    /// The offset as a rigid transform.
    pub fn isometry(&self) -> IsometryMatrix3<f64> {
        IsometryMatrix3::from_parts(
            Vector3::from(self.xyz).into(),
            Rotation3::from_euler_angles(self.rpy[0], self.rpy[1], self.rpy[2]),
        )
    }
}

/// A rigid transform as plain numbers: row-major rotation (3×3) and translation (m).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidFactor {
    /// Rotation matrix, row-major (`rotation[3 * row + col]`).
    pub rotation: [f64; 9],
    /// Translation (m).
    pub translation: [f64; 3],
}

/// One movable joint: constant transform before it, then rotation about / translation along z.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointFactor {
    /// Constant transform from the previous joint's moved frame to this joint's z-aligned frame.
    pub pre: RigidFactor,
    /// Translation along z (m) when true, rotation about z (rad) otherwise.
    pub prismatic: bool,
}

/// The chain's FK as a product `T(q) = Π_i pre_i M_z(q_i) · tail` (joint frames z-aligned):
/// everything FK needs, without the URDF.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChainFactors {
    /// Chain name (e.g. `left`).
    pub name: String,
    /// Task-space coordinates of the tool point (in the chain base frame).
    pub task: TaskSpace,
    /// Movable joints, base to tip.
    pub joints: Vec<JointFactor>,
    /// Constant transform from the last joint's moved frame to the tool point (tool offset included).
    pub tail: RigidFactor,
}

impl RigidFactor {
    /// The numbers of a rigid transform (bit for bit).
    fn from_isometry(t: &IsometryMatrix3<f64>) -> Self {
        let m = t.rotation.matrix();
        let mut rotation = [0.0; 9];
        for row in 0..3 {
            for col in 0..3 {
                rotation[3 * row + col] = m[(row, col)];
            }
        }
        Self {
            rotation,
            translation: t.translation.vector.into(),
        }
    }

    /// The transform, after checking the numbers are finite and the rotation orthonormal with
    /// determinant +1 (to 1e-9); `what` names the factor in the error.
    fn to_isometry(self, what: &str) -> Result<IsometryMatrix3<f64>, FactorsError> {
        if let Some(&value) = self.rotation.iter().find(|v| !v.is_finite()) {
            return Err(FactorsError::NonFinite {
                factor: what.into(),
                part: "rotation",
                value,
            });
        }
        if let Some(&value) = self.translation.iter().find(|v| !v.is_finite()) {
            return Err(FactorsError::NonFinite {
                factor: what.into(),
                part: "translation",
                value,
            });
        }
        let m = nalgebra::Matrix3::from_row_slice(&self.rotation);
        let err = (m.transpose() * m - nalgebra::Matrix3::identity()).amax();
        if err > ORTHONORMAL_TOL {
            return Err(FactorsError::NotOrthonormal {
                factor: what.into(),
                deviation: err,
            });
        }
        let det = m.determinant();
        if (det - 1.0).abs() > ORTHONORMAL_TOL {
            return Err(FactorsError::Determinant {
                factor: what.into(),
                determinant: det,
            });
        }
        Ok(IsometryMatrix3::from_parts(
            Vector3::from(self.translation).into(),
            Rotation3::from_matrix_unchecked(m),
        ))
    }
}

/// Tolerance of the orthonormality and determinant checks of [`Chain::from_factors`].
const ORTHONORMAL_TOL: f64 = 1e-9;

/// Why factors do not describe a chain ([`Chain::from_factors`]); `factor` names the
/// offending one (`chain `c`: joint 2 pre`, `chain `c`: tail`).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum FactorsError {
    /// The chain has no joint.
    #[error("chain `{chain}`: no joints")]
    NoJoints {
        /// Chain name.
        chain: String,
    },
    /// A rotation or translation entry is not finite.
    #[error("{factor}: {part} entry {value} is not finite")]
    NonFinite {
        /// Which factor.
        factor: String,
        /// `rotation` or `translation`.
        part: &'static str,
        /// The entry.
        value: f64,
    },
    /// The rotation is not orthonormal to 1e-9.
    #[error("{factor}: rotation is not orthonormal (max |RᵀR − I| = {deviation:e} > {tol:e})", tol = ORTHONORMAL_TOL)]
    NotOrthonormal {
        /// Which factor.
        factor: String,
        /// `max |RᵀR − I|`.
        deviation: f64,
    },
    /// The rotation's determinant is not +1 (a reflection).
    #[error("{factor}: rotation has determinant {determinant} (must be +1, not a reflection)")]
    Determinant {
        /// Which factor.
        factor: String,
        /// `det R`.
        determinant: f64,
    },
}

/// One movable joint in a frame whose z axis is the joint axis (see [`Chain::new`]).
#[derive(Debug, Clone)]
struct Segment {
    /// Constant transform from the previous joint's moved (z-aligned) frame to this
    /// joint's z-aligned frame.
    pre: IsometryMatrix3<f64>,
    /// `pre`'s rotation is exactly the identity (only its translation is applied).
    pre_translation_only: bool,
    prismatic: bool,
}

/// The segments of a chain being built along its joint path, with the constant transform
/// accumulated since the last movable joint.
struct SegmentFold {
    segments: Vec<Segment>,
    joint_names: Vec<String>,
    limits: Vec<JointLimits>,
    acc: IsometryMatrix3<f64>,
    prev_align: Rotation3<f64>,
}

impl SegmentFold {
    /// An empty fold at the chain's base.
    fn new() -> Self {
        Self {
            segments: Vec::new(),
            joint_names: Vec::new(),
            limits: Vec::new(),
            acc: IsometryMatrix3::identity(),
            prev_align: Rotation3::identity(),
        }
    }

    /// Folds the next joint of the path: fixed and held joints into `acc`, movable ones as segments.
    fn fold_joint(
        &mut self,
        joint: &JointModel,
        spec: &ChainSpec,
        held: &HashMap<String, f64>,
    ) -> Result<(), KinematicsError> {
        match joint.kind {
            JointKind::Unsupported => {
                return Err(KinematicsError::UnsupportedJoint {
                    chain: spec.name.clone(),
                    joint: joint.name.clone(),
                    kind: "floating/planar/spherical".into(),
                })
            }
            JointKind::Fixed => self.acc *= joint.origin,
            _ => {
                if let Some(&v) = held.get(&joint.name) {
                    if !v.is_finite() {
                        return Err(KinematicsError::InvalidSetting {
                            field: format!("held.{}", joint.name),
                            message: format!("{v} is not finite"),
                        });
                    }
                    self.acc = self.acc * joint.origin * joint.motion(v);
                } else {
                    self.push_movable(joint);
                }
            }
        }
        Ok(())
    }

    /// Ends the current segment at the movable joint `joint`.
    fn push_movable(&mut self, joint: &JointModel) {
        // Previous z-aligned frame → this joint's z-aligned frame.
        let align = z_to(&joint.axis);
        let pre = IsometryMatrix3::from_parts(
            nalgebra::Translation3::identity(),
            self.prev_align.inverse(),
        ) * self.acc
            * joint.origin
            * IsometryMatrix3::from_parts(nalgebra::Translation3::identity(), align);
        self.prev_align = align;
        self.segments.push(Segment {
            pre_translation_only: pre.rotation == Rotation3::identity(),
            pre,
            prismatic: joint.kind == JointKind::Prismatic,
        });
        self.joint_names.push(joint.name.clone());
        self.limits.push(joint.limits);
        self.acc = IsometryMatrix3::identity();
    }
}

/// A rotation `A` with `A e_z = a` (the identity for `a = e_z`).
fn z_to(a: &Unit<Vector3<f64>>) -> Rotation3<f64> {
    if a.into_inner() == Vector3::z() {
        return Rotation3::identity();
    }
    Rotation3::rotation_between(&Vector3::z(), a)
        // a = −e_z: half a turn about x.
        .unwrap_or_else(|| Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI))
}

/// A serial chain with its movable joints, ready for FK and Jacobians.
#[derive(Debug, Clone)]
pub struct Chain {
    /// Chain name from configuration.
    pub name: String,
    /// Base link name.
    pub base: String,
    /// Tip link name.
    pub tip: String,
    /// Task-space coordinates.
    pub task: TaskSpace,
    /// Names of the movable joints, base to tip.
    pub joint_names: Vec<String>,
    /// Limits of the movable joints, base to tip.
    pub limits: Vec<JointLimits>,
    segments: Vec<Segment>,
    tail: IsometryMatrix3<f64>,
}

/// Scratch state of one chain, owned by the caller and reused every tick.
#[derive(Debug, Clone)]
pub struct ChainWorkspace {
    /// Pose of the tool point in the base frame after the last FK call.
    pub tip: IsometryMatrix3<f64>,
    /// World (base-frame) joint origins `p_i` (m).
    origins: Vec<Vector3<f64>>,
    /// World (base-frame) unit joint axes `z_i`.
    axes: Vec<Vector3<f64>>,
    /// Geometric Jacobian `[v; ω]` (6 × n) after [`Chain::jacobian`].
    pub jacobian: Matrix6xX<f64>,
    /// Columns of `dJ_p[δ]` after [`Chain::position_jacobian_derivative`] (m/rad).
    jacobian_dot: Vec<Vector3<f64>>,
}

impl Chain {
    /// Builds the chain `spec` of `model`; movable joints named in `held` are frozen at the given value (rad or m).
    pub fn new(
        model: &RobotModel,
        spec: &ChainSpec,
        held: &HashMap<String, f64>,
    ) -> Result<Self, KinematicsError> {
        let base = model.link(&spec.base)?;
        let tip = model.link(&spec.tip)?;
        for name in held.keys() {
            model.joint_id(name)?;
        }
        let path = model
            .path(base, tip)
            .ok_or_else(|| KinematicsError::NotAChain {
                chain: spec.name.clone(),
                base: spec.base.clone(),
                tip: spec.tip.clone(),
            })?;
        let mut fold = SegmentFold::new();
        for &j in &path {
            fold.fold_joint(&model.joints[j], spec, held)?;
        }
        let SegmentFold {
            segments,
            joint_names,
            limits,
            acc,
            prev_align,
        } = fold;
        if segments.is_empty() {
            return Err(KinematicsError::EmptyChain {
                chain: spec.name.clone(),
                base: spec.base.clone(),
                tip: spec.tip.clone(),
            });
        }
        Ok(Self {
            name: spec.name.clone(),
            base: spec.base.clone(),
            tip: spec.tip.clone(),
            task: spec.task,
            joint_names,
            limits,
            segments,
            tail: IsometryMatrix3::from_parts(
                nalgebra::Translation3::identity(),
                prev_align.inverse(),
            ) * acc
                * spec.tool.isometry(),
        })
    }

    /// This chain's factors (for storing FK beside a policy, or building it in another framework).
    pub fn factors(&self) -> ChainFactors {
        ChainFactors {
            name: self.name.clone(),
            task: self.task,
            joints: self
                .segments
                .iter()
                .map(|s| JointFactor {
                    pre: RigidFactor::from_isometry(&s.pre),
                    prismatic: s.prismatic,
                })
                .collect(),
            tail: RigidFactor::from_isometry(&self.tail),
        }
    }

    /// A chain rebuilt from factors: same FK (bit for bit) as the chain they came from;
    /// joint names `"{name}_joint{i}"`, limits unbounded, base/tip strings `""`. Validates
    /// that rotations are orthonormal to 1e-9 with det +1 and values finite; the error says
    /// what is wrong.
    pub fn from_factors(f: &ChainFactors) -> Result<Chain, FactorsError> {
        if f.joints.is_empty() {
            return Err(FactorsError::NoJoints {
                chain: f.name.clone(),
            });
        }
        let mut segments = Vec::with_capacity(f.joints.len());
        for (i, j) in f.joints.iter().enumerate() {
            let pre = j
                .pre
                .to_isometry(&format!("chain `{}`: joint {i} pre", f.name))?;
            segments.push(Segment {
                // Exactly as in `Chain::new`, so that FK takes the same path.
                pre_translation_only: pre.rotation == Rotation3::identity(),
                pre,
                prismatic: j.prismatic,
            });
        }
        let tail = f.tail.to_isometry(&format!("chain `{}`: tail", f.name))?;
        let n = segments.len();
        Ok(Self {
            name: f.name.clone(),
            base: String::new(),
            tip: String::new(),
            task: f.task,
            joint_names: (0..n).map(|i| format!("{}_joint{i}", f.name)).collect(),
            limits: vec![JointLimits::UNBOUNDED; n],
            segments,
            tail,
        })
    }

    /// Number of movable joints `n`.
    pub fn dof(&self) -> usize {
        self.segments.len()
    }

    /// A workspace sized for this chain (allocates; call once at setup).
    pub fn workspace(&self) -> ChainWorkspace {
        let n = self.dof();
        ChainWorkspace {
            tip: IsometryMatrix3::identity(),
            origins: vec![Vector3::zeros(); n],
            axes: vec![Vector3::zeros(); n],
            jacobian: Matrix6xX::zeros(n),
            jacobian_dot: vec![Vector3::zeros(); n],
        }
    }

    /// Forward kinematics: pose of the tool point in the base frame for `q` (rad or m).
    ///
    /// Also records the world joint origins and axes for a following [`Chain::jacobian`].
    /// Panics if `q.len() != self.dof()` (a programming error, checked at setup elsewhere).
    #[inline]
    pub fn forward<'w>(&self, q: &[f64], ws: &'w mut ChainWorkspace) -> &'w IsometryMatrix3<f64> {
        assert_eq!(
            q.len(),
            self.dof(),
            "chain `{}`: wrong number of joint values",
            self.name
        );
        let mut t = IsometryMatrix3::identity();
        for (i, (seg, &qi)) in self.segments.iter().zip(q).enumerate() {
            if seg.pre_translation_only {
                t.translation.vector += t.rotation * seg.pre.translation.vector;
            } else {
                t *= seg.pre;
            }
            let r = t.rotation.matrix_mut_unchecked();
            let z = r.column(2).into_owned();
            ws.origins[i] = t.translation.vector;
            ws.axes[i] = z;
            if seg.prismatic {
                t.translation.vector += z * qi;
            } else {
                // R ← R R_z(q): columns (x, y) ← (c x + s y, −s x + c y).
                let (s, c) = qi.sin_cos();
                for row in 0..3 {
                    let (x, y) = (r[(row, 0)], r[(row, 1)]);
                    r[(row, 0)] = c * x + s * y;
                    r[(row, 1)] = c * y - s * x;
                }
            }
        }
        ws.tip = t * self.tail;
        &ws.tip
    }

    /// Tool-point position in the base frame (m) for `q`; see [`Chain::forward`].
    #[inline]
    pub fn position(&self, q: &[f64], ws: &mut ChainWorkspace) -> Vector3<f64> {
        self.forward(q, ws).translation.vector
    }

    /// Forward kinematics followed by the 6 × n geometric Jacobian into `ws.jacobian`.
    #[inline]
    pub fn jacobian(&self, q: &[f64], ws: &mut ChainWorkspace) {
        self.forward(q, ws);
        let p = ws.tip.translation.vector;
        for (i, seg) in self.segments.iter().enumerate() {
            let z = ws.axes[i];
            let (v, w) = if seg.prismatic {
                (z, Vector3::zeros())
            } else {
                (z.cross(&(p - ws.origins[i])), z)
            };
            let mut col = ws.jacobian.column_mut(i);
            col.fixed_rows_mut::<3>(0).copy_from(&v);
            col.fixed_rows_mut::<3>(3).copy_from(&w);
        }
    }

    /// Directional derivative `dJ_p|_q[δ]` of the 3 × n position Jacobian along `δ`
    /// (rad or m per joint) at the `q` of the last [`Chain::jacobian`] call; column `i`
    /// is then [`ChainWorkspace::jacobian_dot`]`(i)`. Allocation-free.
    ///
    /// On a planar two-link arm (links 1, joints about z) the tip is
    /// `p = (c₁ + c₁₂, s₁ + s₁₂)`, the Jacobian's first column `(−s₁ − s₁₂, c₁ + c₁₂)`,
    /// and its derivative along `δ = (1, 0)` is `(−c₁ − c₁₂, −s₁ − s₁₂)`:
    ///
    /// ```
    /// use std::collections::HashMap;
    /// use crossym_math::kinematics::{Chain, ChainSpec, RobotModel, TaskSpace, ToolOffset};
    ///
    /// let urdf = r#"<robot name="two_link">
    ///   <link name="base"/><link name="l1"/><link name="tip"/>
    ///   <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    ///     <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
    ///   <joint name="j2" type="revolute"><parent link="l1"/><child link="tip"/>
    ///     <origin xyz="1 0 0"/><axis xyz="0 0 1"/>
    ///     <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
    /// </robot>"#;
    /// let model = RobotModel::from_urdf_str(urdf, "doc")?;
    /// let spec = ChainSpec {
    ///     name: "arm".into(),
    ///     base: "base".into(),
    ///     tip: "tip".into(),
    ///     tool: ToolOffset { xyz: [1.0, 0.0, 0.0], rpy: [0.0; 3] },
    ///     task: TaskSpace::Xy,
    /// };
    /// let chain = Chain::new(&model, &spec, &HashMap::new())?;
    /// let mut ws = chain.workspace();
    /// let (q1, q2) = (0.3f64, 0.8f64);
    /// chain.jacobian(&[q1, q2], &mut ws);
    /// let p = ws.tip.translation.vector;
    /// assert!((p.x - (q1.cos() + (q1 + q2).cos())).abs() < 1e-12);
    /// assert!((p.y - (q1.sin() + (q1 + q2).sin())).abs() < 1e-12);
    /// chain.position_jacobian_derivative(&[1.0, 0.0], &mut ws);
    /// let d = ws.jacobian_dot(0);
    /// assert!((d.x + q1.cos() + (q1 + q2).cos()).abs() < 1e-12);
    /// assert!((d.y + q1.sin() + (q1 + q2).sin()).abs() < 1e-12);
    /// # Ok::<(), crossym_math::kinematics::KinematicsError>(())
    /// ```
    ///
    /// With `ω_i = Σ_{k<i, revolute} δ_k z_k`, joint `i`'s axis and origin move as
    /// `ż_i = ω_i × z_i`, `ṗ_i = Σ_{k<i} J_k^{(p_i)} δ_k = ω_i × p_i − Σ_{k<i, rev.} δ_k z_k × p_k
    /// + Σ_{k<i, prism.} δ_k z_k`, the tip as `ṗ = J_p δ`, so the columns
    /// `z_i × (p − p_i)` (revolute) and `z_i` (prismatic) have derivatives
    /// `ż_i × (p − p_i) + z_i × (ṗ − ṗ_i)` and `ż_i`.
    pub fn position_jacobian_derivative(&self, delta: &[f64], ws: &mut ChainWorkspace) {
        debug_assert_eq!(delta.len(), self.dof());
        let p = ws.tip.translation.vector;
        let mut pdot = Vector3::zeros();
        for (i, &d) in delta.iter().enumerate() {
            pdot += ws.jacobian.fixed_view::<3, 1>(0, i) * d;
        }
        let (mut omega, mut c, mut t) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
        for (i, (seg, &d)) in self.segments.iter().zip(delta).enumerate() {
            let (z, pi) = (ws.axes[i], ws.origins[i]);
            let zdot = omega.cross(&z);
            ws.jacobian_dot[i] = if seg.prismatic {
                t += z * d;
                zdot
            } else {
                let pidot = omega.cross(&pi) - c + t;
                omega += z * d;
                c += z.cross(&pi) * d;
                zdot.cross(&(p - pi)) + z.cross(&(pdot - pidot))
            };
        }
    }

    /// Copies the task-space point (2 or 3 coordinates) of the last FK into `out`.
    #[inline]
    pub fn task_point(&self, ws: &ChainWorkspace, out: &mut [f64]) {
        let p = ws.tip.translation.vector;
        out[..self.task.dim()].copy_from_slice(&p.as_slice()[..self.task.dim()]);
    }

    /// The 3 × n position Jacobian (top rows of the geometric Jacobian) after [`Chain::jacobian`].
    pub fn position_jacobian(
        ws: &ChainWorkspace,
    ) -> nalgebra::MatrixView<'_, f64, nalgebra::U3, nalgebra::Dyn, nalgebra::U1, nalgebra::U6>
    {
        ws.jacobian.fixed_rows::<3>(0)
    }

    /// Allocating convenience: the 3 × n position Jacobian at `q` (setup and tests only).
    pub fn position_jacobian_at(&self, q: &[f64]) -> Matrix3xX<f64> {
        let mut ws = self.workspace();
        self.jacobian(q, &mut ws);
        ws.jacobian.fixed_rows::<3>(0).into_owned()
    }
}

impl ChainWorkspace {
    /// World (base-frame) origin `p_i` of movable joint `i` after the last FK call (m).
    pub fn joint_origin(&self, i: usize) -> Vector3<f64> {
        self.origins[i]
    }

    /// World (base-frame) unit axis `z_i` of movable joint `i` after the last FK call.
    pub fn joint_axis(&self, i: usize) -> Vector3<f64> {
        self.axes[i]
    }

    /// Column `i` of `dJ_p[δ]` after [`Chain::position_jacobian_derivative`] (m/rad).
    pub fn jacobian_dot(&self, i: usize) -> Vector3<f64> {
        self.jacobian_dot[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    const PLANAR_URDF: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../urdf/planar_dual_arm.urdf"
    );

    fn planar_chains() -> Vec<Chain> {
        let model = RobotModel::from_urdf_file(PLANAR_URDF).expect("planar loads");
        [("left", "left_ee"), ("right", "right_ee")]
            .iter()
            .map(|(n, t)| {
                Chain::new(
                    &model,
                    &ChainSpec::new(n, "base", t, TaskSpace::Xy),
                    &HashMap::new(),
                )
                .expect("chain builds")
            })
            .collect()
    }

    fn rby1_chains() -> Option<Vec<Chain>> {
        let model =
            RobotModel::from_urdf_file(super::super::test_rby1_urdf()?).expect("RB-Y1 loads");
        let tool = ToolOffset {
            xyz: [0.01, -0.02, 0.1],
            rpy: [0.1, -0.2, 0.3],
        };
        Some(
            [("left", "ee_left"), ("right", "ee_right")]
                .iter()
                .map(|(n, t)| {
                    let mut s = ChainSpec::new(n, "link_torso_5", t, TaskSpace::Xyz);
                    if *n == "right" {
                        s.tool = tool; // a non-trivial tail as well
                    }
                    Chain::new(&model, &s, &HashMap::new()).expect("chain builds")
                })
                .collect(),
        )
    }

    fn random_q(rng: &mut StdRng, c: &Chain) -> Vec<f64> {
        crate::kinematics::test_random_q(rng, &c.limits)
    }

    /// `from_factors(factors())` has bit-identical FK, task point and Jacobian.
    fn assert_round_trip(c: &Chain, seed: u64) {
        let f = c.factors();
        assert_eq!(f.joints.len(), c.dof());
        assert_eq!(f.task, c.task);
        let r = Chain::from_factors(&f).expect("factors of a real chain are valid");
        assert_eq!(r.dof(), c.dof());
        assert_eq!(r.name, c.name);
        assert_eq!(r.joint_names[0], format!("{}_joint0", c.name));
        assert!(r.limits.iter().all(|l| *l == JointLimits::UNBOUNDED));
        assert_eq!(r.factors(), f, "factors are a fixed point");
        let (mut wa, mut wb) = (c.workspace(), r.workspace());
        let mut rng = StdRng::seed_from_u64(seed);
        let d = c.task.dim();
        let (mut xa, mut xb) = (vec![0.0; d], vec![0.0; d]);
        for _ in 0..50 {
            let q = random_q(&mut rng, c);
            let (ta, tb) = (*c.forward(&q, &mut wa), *r.forward(&q, &mut wb));
            assert_eq!(
                ta.translation.vector.as_slice(),
                tb.translation.vector.as_slice(),
                "chain `{}` q {q:?}",
                c.name
            );
            assert_eq!(
                ta.rotation.matrix().as_slice(),
                tb.rotation.matrix().as_slice()
            );
            c.task_point(&wa, &mut xa);
            r.task_point(&wb, &mut xb);
            assert_eq!(xa, xb);
            assert!(xa.iter().all(|v| v.is_finite()));
            c.jacobian(&q, &mut wa);
            r.jacobian(&q, &mut wb);
            assert_eq!(wa.jacobian.as_slice(), wb.jacobian.as_slice());
        }
    }

    #[test]
    fn from_factors_reproduces_planar_fk_bit_for_bit() {
        for (i, c) in planar_chains().iter().enumerate() {
            assert_round_trip(c, 7 + i as u64);
        }
    }

    #[test]
    fn from_factors_reproduces_rby1_fk_bit_for_bit() {
        let Some(chains) = rby1_chains() else { return };
        for (i, c) in chains.iter().enumerate() {
            assert_eq!(c.dof(), 7);
            assert_round_trip(c, 17 + i as u64);
        }
    }

    #[test]
    fn chain_factors_serde_round_trip() {
        let mut chains = planar_chains();
        chains.extend(rby1_chains().unwrap_or_default());
        for c in &chains {
            let f = c.factors();
            let json = serde_json::to_string(&f).expect("serialises");
            let back: ChainFactors = serde_json::from_str(&json).expect("deserialises");
            assert_eq!(back, f);
            let r = Chain::from_factors(&back).expect("valid");
            let q = vec![0.3; c.dof()];
            let (mut wa, mut wb) = (c.workspace(), r.workspace());
            assert_eq!(*c.forward(&q, &mut wa), *r.forward(&q, &mut wb));
        }
        // Unknown fields are rejected.
        let json = serde_json::to_string(&chains[0].factors()).unwrap();
        let bad = json.replacen("\"name\"", "\"extra\":1,\"name\"", 1);
        assert!(serde_json::from_str::<ChainFactors>(&bad).is_err());
    }

    #[test]
    fn from_factors_rejects_invalid_factors() {
        let good = planar_chains()[0].factors();

        let mut f = good.clone();
        f.joints[1].pre.rotation[0] = 1.001; // first column no longer unit
        let e = Chain::from_factors(&f).unwrap_err().to_string();
        assert!(
            e.contains("joint 1 pre") && e.contains("orthonormal"),
            "{e}"
        );

        let mut f = good.clone();
        f.tail.rotation = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, -1.0]; // a reflection
        let e = Chain::from_factors(&f).unwrap_err().to_string();
        assert!(e.contains("tail") && e.contains("determinant"), "{e}");

        let mut f = good.clone();
        f.joints[0].pre.translation[2] = f64::NAN;
        let e = Chain::from_factors(&f).unwrap_err().to_string();
        assert!(e.contains("joint 0 pre") && e.contains("not finite"), "{e}");

        let mut f = good.clone();
        f.tail.rotation[4] = f64::INFINITY;
        let e = Chain::from_factors(&f).unwrap_err().to_string();
        assert!(e.contains("tail") && e.contains("not finite"), "{e}");

        let mut f = good.clone();
        f.joints.clear();
        let e = Chain::from_factors(&f).unwrap_err().to_string();
        assert!(e.contains("no joints"), "{e}");

        // A slightly perturbed but still orthonormal (to 1e-9) rotation is accepted.
        let mut f = good;
        f.tail.rotation[0] += 1e-12;
        assert!(Chain::from_factors(&f).is_ok());
    }
}
