//! Descending symmetries (eqs. 8–10) and the morphological symmetry derived from the URDF
//! (eqs. 4, 9; Example 1: RB-Y1 `P = diag(1, −1, −1, 1, −1, 1, −1)`, `P_X = diag(1, −1, 1)`).

use crossym::kinematics::Kinematics;
use crossym::symmetry::finite::SignedPermutation;
use crossym::symmetry::transfer::descend::{
    descend, descend_with, require_descent, DescendError, DescendSettings, DescendStatus,
};
use crossym::symmetry::transfer::morpho::{
    derive_morphological, MorphoError, MorphoReport, MorphoSettings, MorphoStatus,
};
use nalgebra::Vector3;

use crate::common;

/// Paper Example 1.
const RBY1_P: [f64; 7] = [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, -1.0];

fn morpho(kin: &Kinematics, normal: Vector3<f64>) -> MorphoReport {
    let settings = MorphoSettings {
        samples: 256,
        ..MorphoSettings::default()
    };
    derive_morphological(kin, 0, 1, normal, &settings).expect("valid inputs")
}

fn assert_index_order(report: &MorphoReport) {
    for (i, &(a, b, _)) in report.pairing.iter().enumerate() {
        assert_eq!((a, b), (i, i), "pairing {:?}", report.pairing);
    }
}

#[test]
fn rby1_morphological_symmetry_is_example_1() {
    let Some(robot) = common::rby1() else { return };
    let kin = &robot.kinematics;
    let m = morpho(kin, Vector3::y());
    eprintln!(
        "RB-Y1: P = {:?}, P_X = {:?}, residual {:.3e} m, orientation {:.3e}, ambiguous {:?}",
        m.p_signs, m.p_x.signs, m.max_residual, m.orientation_residual, m.ambiguous
    );
    assert_eq!(m.status, MorphoStatus::Symmetric);
    assert_eq!(m.p_signs, RBY1_P);
    assert_index_order(&m);
    assert_eq!(
        m.p_x,
        SignedPermutation::new(vec![0, 1, 2], vec![1.0, -1.0, 1.0]).unwrap()
    );
    assert_eq!(m.rho_q, SignedPermutation::block_swap(&RBY1_P));
    assert_eq!(m.rho_x, SignedPermutation::block_swap(&[1.0, -1.0, 1.0]));
    assert!(m.unmatched.is_empty());
    // Residual: the shoulders sit at z = 0.080073452 (left) and 0.080073451539 (right) in the
    // vendor URDF, a 4.6e-10 m asymmetry that is the whole residual.
    assert!(m.max_residual <= 1e-9, "residual {:.3e} m", m.max_residual);
    assert!(m.orientation_residual <= 1e-9);
    assert!(m.samples >= 200);
    // left_arm_1 [−0.01745, π] and right_arm_1 [−π, 0.01745] map into each other under P_1 = −1;
    // every other pair is symmetric or sign-consistent.
    assert!(
        m.limit_mismatches.is_empty(),
        "{}",
        m.limit_mismatches
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("; ")
    );
}

#[test]
fn planar_dual_arm_morphological_symmetry_is_minus_identity() {
    let robot = common::planar();
    let m = morpho(&robot.kinematics, Vector3::y());
    assert_eq!(m.status, MorphoStatus::Symmetric);
    assert_eq!(m.p_signs, vec![-1.0; 4]);
    assert_index_order(&m);
    assert_eq!(
        m.p_x,
        SignedPermutation::new(vec![0, 1], vec![1.0, -1.0]).unwrap()
    );
    assert_eq!(m.rho_q, SignedPermutation::block_swap(&[-1.0; 4]));
    assert_eq!(m.rho_x, SignedPermutation::block_swap(&[1.0, -1.0]));
    assert!(m.max_residual <= 1e-9, "residual {:.3e}", m.max_residual);
    assert!(m.orientation_residual <= 1e-9);
    assert!(m.limit_mismatches.is_empty());
    // At q = 0 the joint axes are distinct vertical lines through (0, 0), (3, 0), (6, 0), (9, 0),
    // each fixed by the reflection: the pairing is unique.
    assert!(m.unmatched.is_empty() && m.ambiguous.is_empty());
}

fn assert_descends_to_rho_x(kin: &Kinematics, m: &MorphoReport) {
    let report = descend("bilateral", kin, &m.rho_q, &DescendSettings::default()).unwrap();
    eprintln!(
        "{}: descend residual {:.3e} (relative {:.3e}), fibre {:?}, rank {}",
        kin.robot,
        report.max_residual,
        report.relative_residual,
        report.fibre_residual,
        report.sample_rank
    );
    assert_eq!(report.status, DescendStatus::Equivariant);
    assert!(!report.affine_needed);
    assert_eq!(report.sample_rank, kin.task_dim());
    let action = report.task_action.as_ref().expect("an action");
    assert_eq!(action.as_signed_permutation(), Some(&m.rho_x));
    assert!(report.relative_residual <= 1e-9);
    assert!(
        report.fibre_pairs > 0 && report.fibre_residual.unwrap() <= 1e-9 * report.workspace_size
    );
    // The refusing variant accepts it.
    assert!(require_descent("bilateral", kin, &m.rho_q, &DescendSettings::default()).is_ok());
}

#[test]
fn morphological_symmetry_descends_to_rho_x_planar() {
    let robot = common::planar();
    let m = morpho(&robot.kinematics, Vector3::y());
    assert_descends_to_rho_x(&robot.kinematics, &m);
}

#[test]
fn morphological_symmetry_descends_to_rho_x_rby1() {
    let Some(robot) = common::rby1() else { return };
    let m = morpho(&robot.kinematics, Vector3::y());
    assert_descends_to_rho_x(&robot.kinematics, &m);
}

fn assert_refused(kin: &Kinematics, name: &str, rho: &SignedPermutation) {
    let report = descend(name, kin, rho, &DescendSettings::default()).unwrap();
    eprintln!(
        "{name}: residual {:.3e} (relative {:.3e}), fibre {:?}",
        report.max_residual, report.relative_residual, report.fibre_residual
    );
    assert_eq!(report.status, DescendStatus::NotEquivariant);
    assert!(report.task_action.is_none());
    assert!(report.relative_residual > 1e-2, "{report:?}");
    assert!(report.fibre_residual.unwrap() > 1e-3 * report.workspace_size);
    let err = require_descent(name, kin, rho, &DescendSettings::default()).unwrap_err();
    assert!(matches!(err, DescendError::NotEquivariant { .. }));
    let msg = err.to_string();
    assert!(
        msg.contains(&format!("`{name}`")) && msg.contains("does not descend"),
        "{msg}"
    );
    assert!(
        msg.contains(&format!("{:.3e}", report.max_residual)),
        "{msg}"
    );
}

#[test]
fn wrong_joint_actions_are_refused_planar() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    // Swapping the first two joints within each arm: f(ρq) is not a function of f(q).
    let mut perm: Vec<usize> = (0..8).collect();
    perm.swap(0, 1);
    perm.swap(4, 5);
    let within = SignedPermutation::new(perm, vec![1.0; 8]).unwrap();
    assert_refused(kin, "within-arm swap", &within);
    // Flipping one arm only: f_l(−q_l) = P_X f_l(q_l) would be fine, but flipping only the
    // first joint of it is not.
    let mut signs = vec![1.0; 8];
    signs[0] = -1.0;
    let one = SignedPermutation::new((0..8).collect(), signs).unwrap();
    assert_refused(kin, "first-joint flip", &one);
}

#[test]
fn unsigned_arm_swap_descends_to_plain_swap_planar() {
    // Both planar arms start at the origin with the same conventions, so exchanging them
    // without sign flips is a symmetry too; it descends to the unsigned exchange of the tips.
    let robot = common::planar();
    let swap = SignedPermutation::block_swap(&[1.0; 4]);
    let report = descend(
        "plain swap",
        &robot.kinematics,
        &swap,
        &DescendSettings::default(),
    )
    .unwrap();
    assert_eq!(report.status, DescendStatus::Equivariant);
    assert_eq!(
        report.task_action.unwrap().as_signed_permutation(),
        Some(&SignedPermutation::block_swap(&[1.0, 1.0]))
    );
}

#[test]
fn wrong_joint_actions_are_refused_rby1() {
    let Some(robot) = common::rby1() else { return };
    let kin = &robot.kinematics;
    assert_refused(
        kin,
        "all-plus swap",
        &SignedPermutation::block_swap(&[1.0; 7]),
    );
    let mut perm: Vec<usize> = (0..14).collect();
    perm.swap(2, 4);
    perm.swap(9, 11);
    let within = SignedPermutation::new(perm, vec![1.0; 14]).unwrap();
    assert_refused(kin, "arm_2/arm_4 swap", &within);
}

#[test]
fn non_symmetry_plane_is_reported_rby1() {
    let Some(robot) = common::rby1() else { return };
    let kin = &robot.kinematics;
    let m = morpho(kin, Vector3::x());
    eprintln!(
        "RB-Y1 normal x: {:?}, unmatched {:?}, residual {:.3e}",
        m.status, m.unmatched, m.max_residual
    );
    assert_ne!(m.status, MorphoStatus::Symmetric);
    assert!(!m.unmatched.is_empty() || m.max_residual > 1e-2);
    assert!(m.max_residual > 1e-2 && m.orientation_residual > 1e-2);
    let report = descend(
        "front-back mirror",
        kin,
        &m.rho_q,
        &DescendSettings::default(),
    )
    .unwrap();
    assert_ne!(report.status, DescendStatus::Equivariant);
}

#[test]
fn non_symmetry_plane_is_reported_planar() {
    let robot = common::planar();
    // Reflection across the line y = −x maps the arms' axes onto themselves but not their
    // joint origins (3, 0), (6, 0), (9, 0) at q = 0.
    let m = morpho(&robot.kinematics, Vector3::new(1.0, 1.0, 0.0));
    assert_eq!(m.status, MorphoStatus::NoConsistentPairing);
    assert_eq!(m.unmatched, vec![1, 2, 3]);
    assert!(m.max_residual > 1.0);
}

#[test]
fn invalid_inputs_are_errors() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let s = MorphoSettings::default();
    let zero = derive_morphological(kin, 0, 1, Vector3::zeros(), &s);
    assert!(matches!(zero, Err(MorphoError::InvalidNormal { .. })));
    // A plane tilted out of the xy plane does not act on planar task coordinates.
    let tilted = derive_morphological(kin, 0, 1, Vector3::new(0.0, 1.0, 1.0), &s);
    assert!(matches!(
        tilted,
        Err(MorphoError::NotASignedPermutation { .. })
    ));
    assert!(matches!(
        derive_morphological(kin, 0, 0, Vector3::y(), &s),
        Err(MorphoError::SameChain { .. })
    ));
    assert!(matches!(
        derive_morphological(kin, 0, 2, Vector3::y(), &s),
        Err(MorphoError::ChainIndex { .. })
    ));
    let bad = SignedPermutation::identity(3);
    let err = descend("short", kin, &bad, &DescendSettings::default()).unwrap_err();
    assert!(err.to_string().contains("`short`"), "{err}");
}

#[test]
fn general_action_version_matches_signed_permutation() {
    // eq. 8 for an arbitrary map on Q: the closure form gives the same report.
    let robot = common::planar();
    let kin = &robot.kinematics;
    let rho = SignedPermutation::block_swap(&[-1.0; 4]);
    let a = descend("bilateral", kin, &rho, &DescendSettings::default()).unwrap();
    let b = descend_with(
        "bilateral",
        kin,
        |q, out| rho.apply(q, out),
        &DescendSettings::default(),
    )
    .unwrap();
    assert_eq!(a, b);
    // A joint-space shift by 2π is not a signed permutation, yet it fixes f: it descends to the identity.
    let shift = |q: &[f64], out: &mut [f64]| {
        for (o, v) in out.iter_mut().zip(q) {
            *o = v + std::f64::consts::TAU;
        }
    };
    let c = descend_with("2π shift", kin, shift, &DescendSettings::default()).unwrap();
    assert_eq!(c.status, DescendStatus::Equivariant);
    assert!(c
        .task_action
        .unwrap()
        .as_signed_permutation()
        .unwrap()
        .is_identity());
}

/// A small mirrored dual arm with a prismatic joint, opposite conventions on two joint
/// pairs and a deliberate limit mismatch on the first pair.
const MIRRORED_URDF: &str = r#"<?xml version="1.0"?>
<robot name="mirrored">
  <link name="base"/>
  <link name="l1"/><link name="l2"/><link name="l3"/><link name="l_tip"/>
  <link name="r1"/><link name="r2"/><link name="r3"/><link name="r_tip"/>
  <joint name="left_1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0.2 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="left_2" type="prismatic">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="0" upper="0.1" effort="1" velocity="1"/>
  </joint>
  <joint name="left_3" type="revolute">
    <parent link="l2"/><child link="l3"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="left_tool" type="fixed">
    <parent link="l3"/><child link="l_tip"/>
    <origin xyz="0.1 0.05 0.02" rpy="0 0 0"/>
  </joint>
  <joint name="right_1" type="revolute">
    <parent link="base"/><child link="r1"/>
    <origin xyz="0 -0.2 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="2" effort="1" velocity="1"/>
  </joint>
  <joint name="right_2" type="prismatic">
    <parent link="r1"/><child link="r2"/>
    <origin xyz="0.3 0 0" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-0.1" upper="0" effort="1" velocity="1"/>
  </joint>
  <joint name="right_3" type="revolute">
    <parent link="r2"/><child link="r3"/>
    <origin xyz="0.2 0 0" rpy="0 0 0"/><axis xyz="-1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="right_tool" type="fixed">
    <parent link="r3"/><child link="r_tip"/>
    <origin xyz="0.1 -0.05 0.02" rpy="0 0 0"/>
  </joint>
</robot>"#;

fn mirrored_robot() -> Kinematics {
    use crossym::kinematics::{ChainSpec, KinematicsSettings, RobotModel, TaskSpace, ToolOffset};
    let model = RobotModel::from_urdf_str(MIRRORED_URDF, "<mirrored>").unwrap();
    let spec = |name: &str, tip: &str| ChainSpec {
        name: name.into(),
        base: "base".into(),
        tip: tip.into(),
        tool: ToolOffset::default(),
        task: TaskSpace::Xyz,
    };
    Kinematics::new(
        &model,
        &[spec("left", "l_tip"), spec("right", "r_tip")],
        &Default::default(),
        &KinematicsSettings::default(),
    )
    .unwrap()
}

#[test]
fn prismatic_joints_signs_and_limit_mismatches_are_derived() {
    let kin = mirrored_robot();
    let m = morpho(&kin, Vector3::y());
    // Revolute z: −S z = −z → −1. Prismatic y (polar): S y = −y → −1. Revolute x vs −x: +1.
    assert_eq!(m.status, MorphoStatus::Symmetric);
    assert_eq!(m.p_signs, vec![-1.0, -1.0, 1.0]);
    assert_index_order(&m);
    assert!(m.max_residual <= 1e-12 && m.orientation_residual <= 1e-12);
    // left_1 [−1, 2] vs right_1 [−1, 2] with sign −1 should be [−2, 1]; the prismatic pair
    // [0, 0.1] vs [−0.1, 0] is consistent.
    assert_eq!(m.limit_mismatches.len(), 1, "{:?}", m.limit_mismatches);
    let mm = &m.limit_mismatches[0];
    assert_eq!(
        (mm.joint_a.as_str(), mm.joint_b.as_str()),
        ("left_1", "right_1")
    );
    assert_eq!((mm.limits_a, mm.expected_a), ([-1.0, 2.0], [-2.0, 1.0]));
    assert!(
        mm.to_string().contains("left_1 [-1, 2] vs right_1 [-1, 2]"),
        "{mm}"
    );
    let report = descend("mirror", &kin, &m.rho_q, &DescendSettings::default()).unwrap();
    assert_eq!(report.status, DescendStatus::Equivariant);
    assert_eq!(
        report.task_action.unwrap().as_signed_permutation(),
        Some(&SignedPermutation::block_swap(&[1.0, -1.0, 1.0]))
    );
}

#[test]
fn fibre_consistent_nonlinear_action_is_classified() {
    // Rotating the left arm's first joint by an angle that depends on its own tip distance,
    // Φ(q) = q + α|x_l|² e_1, gives f_l(Φ(q)) = R(α|x_l|²) x_l: a function of f(q) (eq. 8 holds
    // on fibres), but not a linear or affine one.
    use std::cell::RefCell;
    let robot = common::planar();
    let kin = &robot.kinematics;
    let ws = RefCell::new(kin.workspace());
    let twist = |q: &[f64], out: &mut [f64]| {
        let mut ws = ws.borrow_mut();
        let x = kin.forward(q, &mut ws);
        let r2 = x[0] * x[0] + x[1] * x[1];
        out.copy_from_slice(q);
        out[0] += 0.01 * r2;
    };
    let report = descend_with("twist", kin, twist, &DescendSettings::default()).unwrap();
    assert_eq!(report.status, DescendStatus::NonlinearAction, "{report:?}");
    assert!(report.task_action.is_none());
    assert!(report.relative_residual > 1e-2);
    assert!(report.fibre_residual.unwrap() <= 1e-9 * report.workspace_size);
    let err = report.require().unwrap_err();
    assert!(matches!(err, DescendError::NonlinearAction { .. }));
    assert!(err.to_string().contains("`twist`"), "{err}");
}
