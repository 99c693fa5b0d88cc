//! Tests of the whole-body derivation.

use std::collections::HashMap;

use super::*;
use crate::kinematics::RobotModel;

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
    let g =
        derive_body_symmetries(&m, None, None, &HashMap::new(), &BodySettings::default()).unwrap();
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
