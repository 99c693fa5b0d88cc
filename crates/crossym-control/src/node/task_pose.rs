//! Conditions from what the robot sees: the pose of the task's object (a perception node's
//! `geometry_msgs/PoseStamped` on `~/task_pose`) mapped to the condition `s = (θ, λ, σ)`
//! relative to the pose the demonstrations were made with.
//!
//! With `M = I − 2nnᵀ` the mirror (plane normal `n` through `c`), `a` the rotation axis
//! (in the mirror plane, through the object) and `p_s` a point fixed on the object
//! (`side_point`, in the object's frame, e.g. the pan's handle), seen at `d = R p_s` from
//! the object's origin (`d_ref = R_ref p_s` in the demonstrations), `d⊥` its part
//! perpendicular to `a`:
//!
//! - **σ** by side: σ = +1 when `p + d` lies on the same side of the mirror plane as in
//!   the demonstrations, −1 otherwise (the other arm takes over, as the arm swap does).
//! - **θ** by the side point's bearing: `g = M^σ R_a(θ)` (eq. 23's order, reflection last)
//!   maps `d_ref⊥` onto `d⊥`, so `R_a(θ) d_ref⊥ = M^σ d⊥`: θ is the signed angle about `a`
//!   from `d_ref⊥` to `M^σ d⊥`. The object's tilt (the angle between its rotated axis
//!   `R R_refᵀ a` and `a`) is not part of the condition; it is reported.
//! - **λ**: the configured `scale` (no size is observed; 1 where the task has no scaling).
//!
//! The condition then goes through the node's input gate like a condition message (its
//! box or feasibility checks). A pose stated in another frame is first carried into the
//! configured one through the TF tree (`/tf`, `/tf_static`; see [`super::tf`]) when `tf` is
//! on. Pose-specific refusals: another frame without TF (or no path, or a moving transform
//! too far in time from the pose's stamp), a non-finite pose, a zero quaternion, a
//! stamp older than `max_age_s` when it arrives, an object moved farther than
//! `position_tolerance_m` from where the demonstrations had it.

use serde::{Deserialize, Serialize};

use crossym_io::msg;
use crossym_math::symmetry::compose::Condition;

use nalgebra::{Point3, Quaternion, UnitQuaternion};

use super::quat::{dot, normalised, q_conj, q_mul, q_rotate, unit_quat, Quat};
use super::tf::{TfBuffer, TfError};

/// `[node.task_pose]`: where poses come from and the reference they are compared with.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskPoseConfig {
    /// Topic (`~/` is the node's namespace and name).
    #[serde(default = "default_topic")]
    pub topic: String,
    /// The frame poses must be stated in (`header.frame_id`), e.g. the chains' base link.
    pub frame: String,
    /// The object's position in the demonstrations (m, in `frame`).
    pub reference_position: [f64; 3],
    /// The object's orientation in the demonstrations, `[x, y, z, w]`.
    #[serde(default = "identity_quaternion")]
    pub reference_orientation: [f64; 4],
    /// The rotation axis of the task's `R` symmetry (in `frame`; normalised).
    pub axis: [f64; 3],
    /// Normal of the mirror plane (in `frame`; normalised), through `mirror_point`.
    pub mirror_normal: [f64; 3],
    /// A point of the mirror plane (m).
    #[serde(default)]
    pub mirror_point: [f64; 3],
    /// The point of the object whose side of the mirror plane decides σ (m, object frame).
    #[serde(default)]
    pub side_point: [f64; 3],
    /// λ sent with every pose.
    #[serde(default = "one")]
    pub scale: f64,
    /// A pose whose stamp is older than this when it arrives is refused (s).
    #[serde(default = "default_max_age")]
    pub max_age_s: f64,
    /// A pose farther than this from `reference_position` is refused (m): a moved object
    /// is no condition of the task's group (its symmetries turn and mirror the object
    /// about the reference, they do not carry it elsewhere).
    #[serde(default = "default_position_tolerance")]
    pub position_tolerance_m: f64,
    /// Carry poses stated in another frame into `frame` through `/tf` and `/tf_static`
    /// (the node then subscribes to both; off: such poses are refused).
    #[serde(default)]
    pub tf: bool,
    /// A moving transform on the way from the pose's frame is used when its stamp is at
    /// most this far from the pose's stamp (s; `/tf_static` transforms never age).
    #[serde(default = "default_tf_tolerance")]
    pub tf_tolerance_s: f64,
}

fn default_topic() -> String {
    "~/task_pose".into()
}
fn identity_quaternion() -> [f64; 4] {
    [0.0, 0.0, 0.0, 1.0]
}
fn one() -> f64 {
    1.0
}
fn default_max_age() -> f64 {
    0.5
}
fn default_position_tolerance() -> f64 {
    0.03
}
fn default_tf_tolerance() -> f64 {
    0.1
}

/// Why a pose gives no condition.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PoseRejection {
    /// The pose is stated in another frame and TF lookups are off.
    #[error("pose in frame `{got}`, expected `{want}` (TF lookups are off: set `tf = true` or publish it in `{want}`)")]
    Frame {
        /// The message's frame.
        got: String,
        /// The configured frame.
        want: String,
    },
    /// The pose's frame could not be carried into the configured one.
    #[error("pose in frame `{got}`: {error}")]
    Transform {
        /// The message's frame.
        got: String,
        /// Why not.
        error: TfError,
    },
    /// A position or orientation component is not finite.
    #[error("non-finite pose")]
    NonFinite,
    /// The orientation quaternion is (near) zero.
    #[error("zero orientation quaternion")]
    ZeroQuaternion,
    /// The object is not where the demonstrations had it.
    #[error("object {distance_m:.3} m from the reference position (> {tolerance_m} m): not a condition of the task's group")]
    Moved {
        /// Its distance from `reference_position` (m).
        distance_m: f64,
        /// The tolerance (m).
        tolerance_m: f64,
    },
    /// The side point lies on the rotation axis (the object is tilted onto it): no bearing.
    #[error("the side point lies on the rotation axis: no bearing for θ")]
    SideOnAxis,
    /// The pose is older than `max_age_s`.
    #[error("stale pose (age {age_s:.3} s > {max_s} s)")]
    Stale {
        /// Its age when it arrived (s).
        age_s: f64,
        /// The limit (s).
        max_s: f64,
    },
}

/// A setting of `[node.task_pose]` that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("[node.task_pose] {key}: {why}")]
pub struct TaskPoseConfigError {
    /// The setting.
    pub key: &'static str,
    /// What is wrong.
    pub why: String,
}

/// The condition a pose gives, and how far the object is tilted out of the rotation's
/// plane (rad; ignored by θ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseCondition {
    /// The condition.
    pub condition: Condition,
    /// Swing angle of the relative rotation (rad).
    pub tilt: f64,
}

/// [`TaskPoseConfig`] checked and ready: normalised axes, the reference side.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskPoseMap {
    cfg: TaskPoseConfig,
    axis: [f64; 3],
    normal: [f64; 3],
    reference: Quat,
    /// Signed distance of the reference side point to the mirror plane (m).
    reference_side: f64,
    /// `d_ref⊥`, normalised.
    reference_bearing: [f64; 3],
}

impl TaskPoseMap {
    /// Checks `cfg` once (axes non-zero, the axis in the mirror plane, the reference side
    /// point off the plane, a valid scale and age).
    pub fn new(cfg: TaskPoseConfig) -> Result<Self, TaskPoseConfigError> {
        let bad = |key, why: String| TaskPoseConfigError { key, why };
        let axis = normalised(cfg.axis).ok_or_else(|| bad("axis", "must be non-zero".into()))?;
        let normal = normalised(cfg.mirror_normal)
            .ok_or_else(|| bad("mirror_normal", "must be non-zero".into()))?;
        if dot(axis, normal).abs() > 1e-9 {
            return Err(bad(
                "axis",
                "must lie in the mirror plane (M R(θ) M = R(−θ))".into(),
            ));
        }
        let reference = unit_quat(cfg.reference_orientation).ok_or_else(|| {
            bad(
                "reference_orientation",
                "must be a non-zero quaternion".into(),
            )
        })?;
        if !(cfg.scale.is_finite() && cfg.scale > 0.0) {
            return Err(bad("scale", format!("{} must be positive", cfg.scale)));
        }
        if !(cfg.position_tolerance_m.is_finite() && cfg.position_tolerance_m > 0.0) {
            return Err(bad(
                "position_tolerance_m",
                format!("{} must be positive", cfg.position_tolerance_m),
            ));
        }
        if !(cfg.max_age_s.is_finite() && cfg.max_age_s > 0.0) {
            return Err(bad(
                "max_age_s",
                format!("{} must be positive", cfg.max_age_s),
            ));
        }
        if !(cfg.tf_tolerance_s.is_finite() && cfg.tf_tolerance_s > 0.0) {
            return Err(bad(
                "tf_tolerance_s",
                format!("{} must be positive", cfg.tf_tolerance_s),
            ));
        }
        if cfg.frame.is_empty() {
            return Err(bad("frame", "must name a frame".into()));
        }
        let mut map = Self {
            axis,
            normal,
            reference,
            reference_side: 0.0,
            reference_bearing: [0.0; 3],
            cfg,
        };
        map.reference_bearing = map.bearing(reference).ok_or_else(|| {
            bad(
                "side_point",
                "lies on the rotation axis in the reference pose: θ would be undecided".into(),
            )
        })?;
        map.reference_side = map.side(map.cfg.reference_position, reference);
        if map.reference_side.abs() < 1e-6 {
            return Err(bad(
                "side_point",
                "lies on the mirror plane in the reference pose: σ would be undecided".into(),
            ));
        }
        Ok(map)
    }

    /// The settings.
    pub fn config(&self) -> &TaskPoseConfig {
        &self.cfg
    }

    /// Signed distance of the side point of an object at `p` with orientation `q` to the
    /// mirror plane (m).
    fn side(&self, p: [f64; 3], q: Quat) -> f64 {
        let s = q_rotate(q, self.cfg.side_point);
        let x = [p[0] + s[0], p[1] + s[1], p[2] + s[2]];
        let c = self.cfg.mirror_point;
        dot([x[0] - c[0], x[1] - c[1], x[2] - c[2]], self.normal)
    }

    /// The condition of the pose `m`, received at `now_s` (wall clock, s); a pose in
    /// another frame is carried into the configured one through `tf` (`None`: refused).
    pub fn condition(
        &self,
        m: &msg::PoseStamped,
        now_s: f64,
        tf: Option<&TfBuffer>,
    ) -> Result<PoseCondition, PoseRejection> {
        let (p, o) = (m.pose.position, m.pose.orientation);
        let p = [p.x, p.y, p.z];
        let q = [o.x, o.y, o.z, o.w];
        if !p.iter().chain(&q).all(|v| v.is_finite()) {
            return Err(PoseRejection::NonFinite);
        }
        let q = unit_quat(q).ok_or(PoseRejection::ZeroQuaternion)?;
        let stamp = m.header.stamp.as_secs_f64();
        let age = now_s - stamp;
        if age > self.cfg.max_age_s {
            return Err(PoseRejection::Stale {
                age_s: age,
                max_s: self.cfg.max_age_s,
            });
        }
        let (p, q) = self.in_frame(m, stamp, p, q, tf)?;
        let r0 = self.cfg.reference_position;
        let moved =
            ((p[0] - r0[0]).powi(2) + (p[1] - r0[1]).powi(2) + (p[2] - r0[2]).powi(2)).sqrt();
        if moved > self.cfg.position_tolerance_m {
            return Err(PoseRejection::Moved {
                distance_m: moved,
                tolerance_m: self.cfg.position_tolerance_m,
            });
        }
        let same_side = self.side(p, q).signum() == self.reference_side.signum();
        let reflection: i8 = if same_side { 1 } else { -1 };
        let d = self.bearing(q).ok_or(PoseRejection::SideOnAxis)?;
        let target = if same_side {
            d
        } else {
            let k = 2.0 * dot(d, self.normal);
            [
                d[0] - k * self.normal[0],
                d[1] - k * self.normal[1],
                d[2] - k * self.normal[2],
            ]
        };
        let r = self.reference_bearing;
        let cross = [
            r[1] * target[2] - r[2] * target[1],
            r[2] * target[0] - r[0] * target[2],
            r[0] * target[1] - r[1] * target[0],
        ];
        let theta = dot(cross, self.axis).atan2(dot(r, target));
        let rel = q_mul(q, q_conj(self.reference));
        let tilt = dot(q_rotate(rel, self.axis), self.axis)
            .clamp(-1.0, 1.0)
            .acos();
        Ok(PoseCondition {
            condition: Condition {
                theta,
                scale: self.cfg.scale,
                reflection,
            },
            tilt,
        })
    }

    /// The pose `(p, q)` of `m` (stamped `stamp`) in the configured frame: as is when `m`
    /// is in it, else carried through `tf` (`None`, or no transform: refused).
    fn in_frame(
        &self,
        m: &msg::PoseStamped,
        stamp: f64,
        p: [f64; 3],
        q: Quat,
        tf: Option<&TfBuffer>,
    ) -> Result<([f64; 3], Quat), PoseRejection> {
        if m.header.frame_id == self.cfg.frame {
            return Ok((p, q));
        }
        let tf = tf.ok_or_else(|| PoseRejection::Frame {
            got: m.header.frame_id.clone(),
            want: self.cfg.frame.clone(),
        })?;
        let t = tf
            .lookup(
                &self.cfg.frame,
                &m.header.frame_id,
                stamp,
                self.cfg.tf_tolerance_s,
            )
            .map_err(|error| PoseRejection::Transform {
                got: m.header.frame_id.clone(),
                error,
            })?;
        let p = t * Point3::from(p);
        let r = t.rotation * UnitQuaternion::new_unchecked(Quaternion::new(q[3], q[0], q[1], q[2]));
        Ok(([p.x, p.y, p.z], [r.i, r.j, r.k, r.w]))
    }

    /// The side point's direction from the object's origin perpendicular to the axis,
    /// normalised; `None` when it lies on the axis.
    fn bearing(&self, q: Quat) -> Option<[f64; 3]> {
        let d = q_rotate(q, self.cfg.side_point);
        let along = dot(d, self.axis);
        normalised([
            d[0] - along * self.axis[0],
            d[1] - along * self.axis[1],
            d[2] - along * self.axis[2],
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pan: axis z through the pan, mirror plane y = 0, handle 0.18 m along the pan's
    /// −y (the right side) in the reference pose.
    fn pan() -> TaskPoseMap {
        TaskPoseMap::new(TaskPoseConfig {
            topic: default_topic(),
            frame: "link_torso_5".into(),
            reference_position: [0.38, 0.0, -0.25],
            reference_orientation: [0.0, 0.0, 0.0, 1.0],
            axis: [0.0, 0.0, 1.0],
            mirror_normal: [0.0, 1.0, 0.0],
            mirror_point: [0.0, 0.0, 0.0],
            side_point: [0.0, -0.18, 0.0],
            scale: 1.0,
            max_age_s: 0.5,
            position_tolerance_m: 0.03,
            tf: false,
            tf_tolerance_s: 0.1,
        })
        .unwrap()
    }

    fn yaw(angle: f64) -> msg::Quaternion {
        msg::Quaternion {
            x: 0.0,
            y: 0.0,
            z: (angle / 2.0).sin(),
            w: (angle / 2.0).cos(),
        }
    }

    fn pose(frame: &str, angle: f64, stamp: f64) -> msg::PoseStamped {
        msg::PoseStamped {
            header: msg::Header {
                stamp: msg::Time::from_secs_f64(stamp),
                frame_id: frame.into(),
            },
            pose: msg::Pose {
                position: msg::Point {
                    x: 0.38,
                    y: 0.0,
                    z: -0.25,
                },
                orientation: yaw(angle),
            },
        }
    }

    /// The handle turned by θ about the pan's axis and still on the right: (θ, 1, +1);
    /// turned past the mirror plane onto the left: σ = −1 with the θ for which `M R(θ)`
    /// maps the reference handle onto it, checked by applying `g` to the handle; a tilt
    /// about the handle's axis changes neither and is reported.
    #[test]
    fn yaw_and_side_give_theta_and_sigma() {
        let m = pan();
        for deg in [-60.0f64, -10.0, 0.0, 25.0, 80.0] {
            let a = deg.to_radians();
            let c = m
                .condition(&pose("link_torso_5", a, 10.0), 10.0, None)
                .unwrap();
            assert_eq!(c.condition.reflection, 1, "{deg}°");
            assert!((c.condition.theta - a).abs() < 1e-12, "{deg}°: {c:?}");
            assert!(c.tilt.abs() < 1e-6);
        }
        // Handle direction after a yaw of `a`: R(a)·(0, −1, 0) = (sin a, −cos a, 0).
        for deg in [120.0f64, 180.0, -135.0, 100.0] {
            let a = deg.to_radians();
            let c = m
                .condition(&pose("link_torso_5", a, 10.0), 10.0, None)
                .unwrap();
            assert_eq!(c.condition.reflection, -1, "{deg}°");
            // g h0 = M R(θ) h0 must be the observed handle direction.
            let t = c.condition.theta;
            let rh = [t.sin(), -t.cos()];
            let mh = [rh[0], -rh[1]];
            let want = [a.sin(), -a.cos()];
            assert!(
                (mh[0] - want[0]).abs() < 1e-12 && (mh[1] - want[1]).abs() < 1e-12,
                "{deg}°: θ {t}"
            );
        }
        // Tilted by 0.2 rad about the handle's own axis (y), yawed by 30°.
        let mut p = pose("link_torso_5", 0.0, 10.0);
        let (a, b) = (30f64.to_radians(), 0.2f64);
        let qz = [0.0, 0.0, (a / 2.0).sin(), (a / 2.0).cos()];
        let qy = [0.0, (b / 2.0).sin(), 0.0, (b / 2.0).cos()];
        let q = q_mul(qz, qy);
        p.pose.orientation = msg::Quaternion {
            x: q[0],
            y: q[1],
            z: q[2],
            w: q[3],
        };
        let c = m.condition(&p, 10.0, None).unwrap();
        assert!((c.condition.theta - a).abs() < 1e-12, "{c:?}");
        assert!((c.tilt - b).abs() < 1e-12, "{c:?}");
    }

    #[test]
    fn bad_poses_are_refused_by_reason() {
        let m = pan();
        let e = m
            .condition(&pose("world", 0.0, 10.0), 10.0, None)
            .unwrap_err();
        assert!(matches!(e, PoseRejection::Frame { .. }), "{e}");
        let mut nan = pose("link_torso_5", 0.0, 10.0);
        nan.pose.position.x = f64::NAN;
        assert_eq!(m.condition(&nan, 10.0, None), Err(PoseRejection::NonFinite));
        let mut zero = pose("link_torso_5", 0.0, 10.0);
        zero.pose.orientation = msg::Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        assert_eq!(
            m.condition(&zero, 10.0, None),
            Err(PoseRejection::ZeroQuaternion)
        );
        let e = m
            .condition(&pose("link_torso_5", 0.0, 9.0), 10.0, None)
            .unwrap_err();
        assert!(matches!(e, PoseRejection::Stale { .. }), "{e}");
        let mut moved = pose("link_torso_5", 0.0, 10.0);
        moved.pose.position.x += 0.05;
        let e = m.condition(&moved, 10.0, None).unwrap_err();
        assert!(matches!(e, PoseRejection::Moved { .. }), "{e}");
    }

    /// A pose stated in a camera's frame (camera at (0.1, 0.3, 0.4) in the torso frame,
    /// yawed by −90° there) gives, through the TF tree, the condition of the same pose in the
    /// torso frame; without TF it is refused by frame; a stale moving camera edge refuses.
    #[test]
    fn poses_in_another_frame_go_through_tf() {
        let m = pan();
        let camera = nalgebra::Isometry3::from_parts(
            nalgebra::Translation3::new(0.1, 0.3, 0.4),
            UnitQuaternion::from_axis_angle(
                &nalgebra::Vector3::z_axis(),
                -0.5 * std::f64::consts::PI,
            ),
        );
        let mut tf = TfBuffer::new();
        let edge = |stamp: f64| msg::TransformStamped {
            header: msg::Header {
                stamp: msg::Time::from_secs_f64(stamp),
                frame_id: "link_torso_5".into(),
            },
            child_frame_id: "camera".into(),
            transform: msg::Transform {
                translation: msg::Vector3 {
                    x: 0.1,
                    y: 0.3,
                    z: 0.4,
                },
                rotation: msg::Quaternion {
                    x: camera.rotation.i,
                    y: camera.rotation.j,
                    z: camera.rotation.k,
                    w: camera.rotation.w,
                },
            },
        };
        tf.insert(&edge(10.0), false).unwrap();
        let inv = camera.inverse();
        for deg in [-40.0f64, 0.0, 30.0, 150.0] {
            let in_torso = pose("link_torso_5", deg.to_radians(), 10.0);
            let want = m.condition(&in_torso, 10.0, None).unwrap();
            // The same pose seen from the camera.
            let o = in_torso.pose.orientation;
            let pp = in_torso.pose.position;
            let p = inv * Point3::new(pp.x, pp.y, pp.z);
            let q =
                inv.rotation * UnitQuaternion::new_unchecked(Quaternion::new(o.w, o.x, o.y, o.z));
            let mut seen = in_torso.clone();
            seen.header.frame_id = "camera".into();
            seen.pose.position = msg::Point {
                x: p[0],
                y: p[1],
                z: p[2],
            };
            seen.pose.orientation = msg::Quaternion {
                x: q.i,
                y: q.j,
                z: q.k,
                w: q.w,
            };
            let got = m.condition(&seen, 10.0, Some(&tf)).unwrap();
            assert_eq!(
                got.condition.reflection, want.condition.reflection,
                "{deg}°"
            );
            assert!(
                (got.condition.theta - want.condition.theta).abs() < 1e-9,
                "{deg}°: {got:?} vs {want:?}"
            );
            let e = m.condition(&seen, 10.0, None).unwrap_err();
            assert!(matches!(e, PoseRejection::Frame { .. }), "{e}");
        }
        let mut late = pose("link_torso_5", 0.0, 10.3);
        late.header.frame_id = "camera".into();
        let e = m.condition(&late, 10.3, Some(&tf)).unwrap_err();
        assert!(
            matches!(
                &e,
                PoseRejection::Transform {
                    error: TfError::Stale { .. },
                    ..
                }
            ),
            "{e}"
        );
        late.header.frame_id = "gripper".into();
        let e = m.condition(&late, 10.3, Some(&tf)).unwrap_err();
        assert!(
            matches!(
                &e,
                PoseRejection::Transform {
                    error: TfError::NoPath { .. },
                    ..
                }
            ),
            "{e}"
        );
    }

    #[test]
    fn bad_settings_are_refused() {
        let base = pan().config().clone();
        let with = |f: &dyn Fn(&mut TaskPoseConfig)| {
            let mut c = base.clone();
            f(&mut c);
            TaskPoseMap::new(c)
        };
        assert!(
            with(&|c| c.axis = [0.0, 1.0, 0.0]).is_err(),
            "axis across the mirror"
        );
        assert!(with(&|c| c.axis = [0.0; 3]).is_err());
        assert!(
            with(&|c| c.side_point = [0.0; 3]).is_err(),
            "side undecided"
        );
        assert!(with(&|c| c.scale = 0.0).is_err());
        assert!(with(&|c| c.frame = String::new()).is_err());
    }
}
