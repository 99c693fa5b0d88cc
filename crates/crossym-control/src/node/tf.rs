//! A TF tree for frame lookups: the edges `/tf` and `/tf_static` carry
//! (`tf2_msgs/TFMessage`), each the pose of a child frame in its parent, and the transform
//! between any two frames of one tree.
//!
//! `T_target←source` is found through the frames' nearest common ancestor `F`:
//! `T_target←source = (T_F←target)⁻¹ ∘ T_F←source`, each side the product of the edges
//! on the way up. Unlike tf2 there is no interpolation in time: each edge keeps its latest
//! transform (a newer stamp replaces an older one; `/tf_static` edges never age), and a
//! lookup at time `t` refuses a moving edge on the path whose stamp is more than the
//! tolerance away from `t`. A perceived object's pose changes at camera rate while the
//! frames between the camera and the robot's base move slowly or not at all; interpolating
//! between two edges gains nothing at that scale.

use std::collections::HashMap;

use crossym_io::msg;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use super::quat::unit_quat;

/// Longest chain of edges followed up a tree (a loop in the edges ends there).
const MAX_DEPTH: usize = 64;

/// Why a transform could not be found or stored.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TfError {
    /// The two frames are not connected by the edges received so far.
    #[error("no transform from `{from}` to `{to}` in /tf or /tf_static (frames known: {known})")]
    NoPath {
        /// The source frame.
        from: String,
        /// The target frame.
        to: String,
        /// The frames received so far, comma-separated.
        known: String,
    },
    /// A moving edge on the path is too far in time from the lookup's time.
    #[error(
        "transform `{parent}` → `{child}` is {age_s:.3} s from the pose's stamp (> {max_s} s)"
    )]
    Stale {
        /// The edge's parent frame.
        parent: String,
        /// The edge's child frame.
        child: String,
        /// |lookup time − the edge's stamp| (s).
        age_s: f64,
        /// The tolerance (s).
        max_s: f64,
    },
    /// An edge with a non-finite or zero transform, or a frame its own parent.
    #[error("transform `{parent}` → `{child}` refused: {why}")]
    BadEdge {
        /// The edge's parent frame.
        parent: String,
        /// The edge's child frame.
        child: String,
        /// What is wrong.
        why: &'static str,
    },
}

#[derive(Debug, Clone)]
struct Edge {
    parent: String,
    /// The child's pose in the parent: `p_parent = pose · p_child`.
    pose: Isometry3<f64>,
    stamp_s: f64,
    fixed: bool,
}

/// The latest edge per child frame (see the module docs).
#[derive(Debug, Clone, Default)]
pub struct TfBuffer {
    edges: HashMap<String, Edge>,
}

/// One frame on the way up from a lookup's end: its transform from the end's frame and the
/// most out-of-date moving edge passed (`(parent, child, age)`).
struct Up<'a> {
    frame: &'a str,
    from_end: Isometry3<f64>,
    worst: Option<(&'a str, &'a str, f64)>,
}

impl TfBuffer {
    /// An empty tree.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stores the edges of a TF message (`fixed`: from `/tf_static`); a refused edge is
    /// reported and the others kept.
    pub fn insert_message(&mut self, m: &msg::TFMessage, fixed: bool) -> Result<(), TfError> {
        let mut first_error = Ok(());
        for t in &m.transforms {
            if let Err(e) = self.insert(t, fixed) {
                if first_error.is_ok() {
                    first_error = Err(e);
                }
            }
        }
        first_error
    }

    /// Stores one edge: replaces the child's edge unless that one is newer (static edges
    /// always replace).
    pub fn insert(&mut self, t: &msg::TransformStamped, fixed: bool) -> Result<(), TfError> {
        let bad = |why| TfError::BadEdge {
            parent: t.header.frame_id.clone(),
            child: t.child_frame_id.clone(),
            why,
        };
        if t.child_frame_id.is_empty() || t.header.frame_id.is_empty() {
            return Err(bad("an empty frame name"));
        }
        if t.child_frame_id == t.header.frame_id {
            return Err(bad("a frame cannot be its own parent"));
        }
        let (v, r) = (t.transform.translation, t.transform.rotation);
        let translation = [v.x, v.y, v.z];
        if !translation.iter().all(|x| x.is_finite()) {
            return Err(bad("non-finite translation"));
        }
        let [x, y, z, w] =
            unit_quat([r.x, r.y, r.z, r.w]).ok_or_else(|| bad("zero or non-finite rotation"))?;
        let stamp_s = t.header.stamp.as_secs_f64();
        if let Some(old) = self.edges.get(&t.child_frame_id) {
            if !fixed && !old.fixed && old.stamp_s > stamp_s {
                return Ok(());
            }
        }
        self.edges.insert(
            t.child_frame_id.clone(),
            Edge {
                parent: t.header.frame_id.clone(),
                pose: Isometry3::from_parts(
                    Translation3::new(translation[0], translation[1], translation[2]),
                    UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z)),
                ),
                stamp_s,
                fixed,
            },
        );
        Ok(())
    }

    /// Number of edges stored.
    pub fn len(&self) -> usize {
        self.edges.len()
    }

    /// True before any edge arrived.
    pub fn is_empty(&self) -> bool {
        self.edges.is_empty()
    }

    /// The frames from `end` up to its tree's root.
    fn up<'a>(&'a self, end: &'a str, at_s: f64) -> Vec<Up<'a>> {
        let mut chain = vec![Up {
            frame: end,
            from_end: Isometry3::identity(),
            worst: None,
        }];
        while chain.len() <= MAX_DEPTH {
            let last = &chain[chain.len() - 1];
            let Some(edge) = self.edges.get(last.frame) else {
                break;
            };
            let age = (at_s - edge.stamp_s).abs();
            let worst = match last.worst {
                Some(w) if edge.fixed || w.2 >= age => Some(w),
                _ if edge.fixed => None,
                _ => Some((edge.parent.as_str(), last.frame, age)),
            };
            let next = Up {
                frame: edge.parent.as_str(),
                from_end: edge.pose * last.from_end,
                worst,
            };
            chain.push(next);
        }
        chain
    }

    /// `T_target←source` at time `at_s` (s): maps a point stated in `source` to `target`;
    /// a moving edge on the path whose stamp is more than `tolerance_s` from `at_s` refuses.
    pub fn lookup(
        &self,
        target: &str,
        source: &str,
        at_s: f64,
        tolerance_s: f64,
    ) -> Result<Isometry3<f64>, TfError> {
        let from_source = self.up(source, at_s);
        for t in self.up(target, at_s) {
            let Some(s) = from_source.iter().find(|s| s.frame == t.frame) else {
                continue;
            };
            for (parent, child, age) in [s.worst, t.worst].into_iter().flatten() {
                if age > tolerance_s {
                    return Err(TfError::Stale {
                        parent: parent.into(),
                        child: child.into(),
                        age_s: age,
                        max_s: tolerance_s,
                    });
                }
            }
            return Ok(t.from_end.inverse() * s.from_end);
        }
        let mut known: Vec<&str> = self
            .edges
            .iter()
            .flat_map(|(c, e)| [c.as_str(), e.parent.as_str()])
            .collect();
        known.sort_unstable();
        known.dedup();
        Err(TfError::NoPath {
            from: source.into(),
            to: target.into(),
            known: known.join(", "),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Point3, Vector3};

    fn edge(parent: &str, child: &str, t: [f64; 3], yaw: f64, stamp: f64) -> msg::TransformStamped {
        msg::TransformStamped {
            header: msg::Header {
                stamp: msg::Time::from_secs_f64(stamp),
                frame_id: parent.into(),
            },
            child_frame_id: child.into(),
            transform: msg::Transform {
                translation: msg::Vector3 {
                    x: t[0],
                    y: t[1],
                    z: t[2],
                },
                rotation: msg::Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: (yaw / 2.0).sin(),
                    w: (yaw / 2.0).cos(),
                },
            },
        }
    }

    fn close(a: Point3<f64>, b: [f64; 3]) -> bool {
        (a - Point3::from(b)).norm() < 1e-12
    }

    fn at(t: &Isometry3<f64>, p: [f64; 3]) -> Point3<f64> {
        t * Point3::from(p)
    }

    /// base ← torso (static, 0.3 up) ← head (moving, yawed 90°) ← camera (static, 0.1
    /// forward), and base ← arm (static, 0.2 left): points mapped between branches agree
    /// with composing the edges by hand; the inverse lookup undoes the lookup.
    #[test]
    fn lookups_compose_through_the_common_ancestor() {
        let mut tf = TfBuffer::new();
        let half_pi = std::f64::consts::FRAC_PI_2;
        tf.insert(&edge("base", "torso", [0.0, 0.0, 0.3], 0.0, 0.0), true)
            .unwrap();
        tf.insert(
            &edge("torso", "head", [0.0, 0.0, 0.2], half_pi, 10.0),
            false,
        )
        .unwrap();
        tf.insert(&edge("head", "camera", [0.1, 0.0, 0.0], 0.0, 0.0), true)
            .unwrap();
        tf.insert(&edge("base", "arm", [0.0, 0.2, 0.0], 0.0, 0.0), true)
            .unwrap();
        // A point 1 m in front of the camera: the camera looks along the head's x, which the
        // yaw turns onto the torso's y; in base it is (0, 1.1, 0.5), in arm (0, 0.9, 0.5).
        let t = tf.lookup("base", "camera", 10.0, 0.1).unwrap();
        assert!(close(at(&t, [1.0, 0.0, 0.0]), [0.0, 1.1, 0.5]), "{t:?}");
        let t = tf.lookup("arm", "camera", 10.05, 0.1).unwrap();
        assert!(close(at(&t, [1.0, 0.0, 0.0]), [0.0, 0.9, 0.5]), "{t:?}");
        let back = tf.lookup("camera", "arm", 10.0, 0.1).unwrap();
        assert!(close(back * at(&t, [0.3, -0.2, 0.7]), [0.3, -0.2, 0.7]));
        assert!((t.rotation * Vector3::x() - Vector3::y()).norm() < 1e-12);
        // The same frame: the identity.
        assert_eq!(
            tf.lookup("head", "head", 0.0, 0.1).unwrap(),
            Isometry3::identity()
        );
    }

    #[test]
    fn stale_moving_edges_unknown_frames_and_bad_edges_are_refused() {
        let mut tf = TfBuffer::new();
        tf.insert(&edge("base", "head", [0.0; 3], 0.0, 10.0), false)
            .unwrap();
        tf.insert(&edge("head", "camera", [0.0; 3], 0.0, 0.0), true)
            .unwrap();
        let e = tf.lookup("base", "camera", 10.5, 0.1).unwrap_err();
        assert!(
            matches!(&e, TfError::Stale { child, .. } if child == "head"),
            "{e}"
        );
        // Static edges never age; a newer moving edge replaces, an older one does not.
        assert!(tf.lookup("head", "camera", 1e6, 0.1).is_ok());
        tf.insert(&edge("base", "head", [0.0; 3], 0.0, 10.5), false)
            .unwrap();
        tf.insert(&edge("base", "head", [9.0; 3], 0.0, 10.2), false)
            .unwrap();
        let t = tf.lookup("base", "camera", 10.5, 0.1).unwrap();
        assert_eq!(t.translation.vector, Vector3::zeros());
        let e = tf.lookup("base", "gripper", 10.5, 0.1).unwrap_err();
        assert_eq!(
            e.to_string(),
            "no transform from `gripper` to `base` in /tf or /tf_static (frames known: base, camera, head)"
        );
        let mut nan = edge("base", "x", [f64::NAN, 0.0, 0.0], 0.0, 0.0);
        assert!(matches!(
            tf.insert(&nan, true),
            Err(TfError::BadEdge { .. })
        ));
        nan.transform.translation.x = 0.0;
        nan.transform.rotation = msg::Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 0.0,
        };
        assert!(matches!(
            tf.insert(&nan, true),
            Err(TfError::BadEdge { .. })
        ));
        assert!(tf
            .insert(&edge("x", "x", [0.0; 3], 0.0, 0.0), true)
            .is_err());
        // A loop in the edges ends at the depth limit instead of spinning.
        tf.insert(&edge("a", "b", [0.0; 3], 0.0, 0.0), true)
            .unwrap();
        tf.insert(&edge("b", "a", [0.0; 3], 0.0, 0.0), true)
            .unwrap();
        assert!(matches!(
            tf.lookup("base", "a", 0.0, 0.1),
            Err(TfError::NoPath { .. })
        ));
    }
}
