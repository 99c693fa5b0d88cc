//! Kinematics: FK against closed form, Jacobians against finite differences, the
//! pseudo-inverse identities, URDF limits (including RB-Y1's acceleration attribute)
//! and clear errors on broken input.

use std::collections::HashMap;

use crossym::kinematics::{
    Chain, ChainSpec, DampedPinv, JointKind, Kinematics, KinematicsError, KinematicsSettings,
    Metric, PinvStatus, RobotModel, TaskSpace, ToolOffset,
};
use nalgebra::DMatrix;

use crate::common;

fn test_arm() -> (RobotModel, Chain) {
    let model = RobotModel::from_urdf_file(common::path("urdf/test_arm_7dof.urdf")).unwrap();
    let spec = ChainSpec {
        name: "arm".into(),
        base: "base_link".into(),
        tip: "tool0".into(),
        tool: ToolOffset {
            xyz: [0.0, 0.01, 0.03],
            rpy: [0.1, 0.0, -0.2],
        },
        task: TaskSpace::Xyz,
    };
    let chain = Chain::new(&model, &spec, &HashMap::new()).unwrap();
    (model, chain)
}

/// Central-difference check of the 6 × n geometric Jacobian of one chain (≤ 1e-7).
fn check_chain_jacobian(chain: &Chain, q: &[f64]) -> f64 {
    let mut ws = chain.workspace();
    chain.jacobian(q, &mut ws);
    let j = ws.jacobian.clone();
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for i in 0..chain.dof() {
        let (mut qp, mut qm) = (q.to_vec(), q.to_vec());
        qp[i] += h;
        qm[i] -= h;
        let tp = *chain.forward(&qp, &mut ws);
        let tm = *chain.forward(&qm, &mut ws);
        let dp = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
        // Angular velocity from dR Rᵀ (skew part) by central differences.
        let dr = (tp.rotation.matrix() - tm.rotation.matrix()) / (2.0 * h);
        let t0 = *chain.forward(q, &mut ws);
        let w = dr * t0.rotation.matrix().transpose();
        let omega = nalgebra::Vector3::new(w[(2, 1)], w[(0, 2)], w[(1, 0)]);
        for r in 0..3 {
            worst = worst.max((j[(r, i)] - dp[r]).abs());
            worst = worst.max((j[(3 + r, i)] - omega[r]).abs());
        }
    }
    worst
}

#[test]
fn jacobian_matches_finite_differences_on_every_robot() {
    let mut rng = common::rng(1);
    let (_, arm) = test_arm();
    for _ in 0..50 {
        let q = common::random_q(&mut rng, &arm.limits);
        let e = check_chain_jacobian(&arm, &q);
        assert!(e <= 1e-7, "test arm Jacobian error {e:e} at {q:?}");
    }
    let planar = common::planar();
    for c in planar.kinematics.chains() {
        for _ in 0..50 {
            let q = common::random_q(&mut rng, &c.limits);
            let e = check_chain_jacobian(c, &q);
            // Links are 3.0 long: scale the tolerance by the arm's reach (12).
            assert!(e <= 1e-7 * 12.0, "planar Jacobian error {e:e}");
        }
    }
    if let Some(rby1) = common::rby1() {
        for c in rby1.kinematics.chains() {
            for _ in 0..100 {
                let q = common::random_q(&mut rng, &c.limits);
                let e = check_chain_jacobian(c, &q);
                assert!(e <= 1e-7, "RB-Y1 {} Jacobian error {e:e}", c.name);
            }
        }
    }
}

#[test]
fn stacked_jacobian_is_block_diagonal_and_matches_finite_differences() {
    let mut rng = common::rng(2);
    let mut robots = vec![common::planar()];
    robots.extend(common::rby1());
    for robot in robots {
        let k = &robot.kinematics;
        let mut ws = k.workspace();
        for _ in 0..20 {
            let q = common::random_q(&mut rng, k.limits());
            k.jacobian(&q, &mut ws);
            let j = ws.jac.clone();
            let h = 1e-6;
            for c in 0..k.dof() {
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[c] += h;
                qm[c] -= h;
                let xp = k.forward(&qp, &mut ws).clone();
                let xm = k.forward(&qm, &mut ws).clone();
                for r in 0..k.task_dim() {
                    let fd = (xp[r] - xm[r]) / (2.0 * h);
                    assert!(
                        (fd - j[(r, c)]).abs() <= 1e-7 * 12.0,
                        "{} J[{r},{c}]",
                        k.robot
                    );
                }
            }
            // Off-diagonal blocks are exactly zero.
            let (n0, m0) = (k.chains()[0].dof(), k.chains()[0].task.dim());
            assert_eq!(j.view((0, n0), (m0, k.dof() - n0)).amax(), 0.0);
            assert_eq!(j.view((m0, 0), (k.task_dim() - m0, n0)).amax(), 0.0);
        }
    }
}

#[test]
fn planar_fk_matches_closed_form() {
    let planar = common::planar();
    let k = &planar.kinematics;
    assert_eq!((k.dof(), k.task_dim()), (8, 4));
    let mut ws = k.workspace();
    let mut rng = common::rng(3);
    for _ in 0..100 {
        let q = common::random_q(&mut rng, k.limits());
        let x = k.forward(&q, &mut ws).clone();
        for arm in 0..2 {
            let (mut cx, mut cy, mut phi) = (0.0, 0.0, 0.0);
            for i in 0..4 {
                phi += q[4 * arm + i];
                cx += 3.0 * phi.cos();
                cy += 3.0 * phi.sin();
            }
            assert!((x[2 * arm] - cx).abs() < 1e-12 && (x[2 * arm + 1] - cy).abs() < 1e-12);
        }
    }
    // The paper's rest posture: q0 = [π/4, −π/6, −π/8, −π/10] for the left arm and −q0 for
    // the right give mirror images across the x-axis.
    let pi = std::f64::consts::PI;
    let q0 = [pi / 4.0, -pi / 6.0, -pi / 8.0, -pi / 10.0];
    let q: Vec<f64> = q0
        .iter()
        .chain(q0.iter())
        .enumerate()
        .map(|(i, v)| if i < 4 { *v } else { -v })
        .collect();
    let x = k.forward(&q, &mut ws).clone();
    assert!((x[0] - x[2]).abs() < 1e-12 && (x[1] + x[3]).abs() < 1e-12);
}

#[test]
fn pseudo_inverse_identities() {
    let mut rng = common::rng(4);
    let mut robots = vec![common::planar()];
    robots.extend(common::rby1());
    for robot in robots {
        let k = &robot.kinematics;
        let (n, m) = (k.dof(), k.task_dim());
        let mut ws = k.workspace();
        let mut checked = 0;
        for metric in [
            Metric::identity(n),
            Metric::diagonal(&(0..n).map(|i| 1.0 + i as f64 * 0.3).collect::<Vec<_>>()).unwrap(),
        ] {
            let pinv = DampedPinv::new(metric, 0.0, 1e-6).unwrap();
            let mut pws = pinv.workspace(m);
            let mut jp = DMatrix::zeros(n, m);
            let mut proj = DMatrix::zeros(n, n);
            for _ in 0..30 {
                let q = common::random_q(&mut rng, k.limits());
                k.jacobian(&q, &mut ws);
                let rep = pinv.factor(&ws.jac, &mut pws);
                if rep.status != PinvStatus::Regular {
                    continue;
                }
                checked += 1;
                pinv.matrix(&mut pws, &mut jp);
                let jjp = &ws.jac * &jp;
                assert!(
                    (jjp - DMatrix::<f64>::identity(m, m)).amax() < 1e-8,
                    "J J⁺ ≠ I for {}",
                    k.robot
                );
                DampedPinv::nullspace_projector(&ws.jac, &jp, &mut proj);
                assert!((&ws.jac * &proj).amax() < 1e-8, "J N ≠ 0 for {}", k.robot);
                // N is idempotent, and J⁺ is M-orthogonal to the nullspace: Nᵀ M J⁺ = 0.
                assert!((&proj * &proj - &proj).amax() < 1e-8);
                let m_mat = pinv.metric().inverse().clone().try_inverse().unwrap();
                assert!(
                    (proj.transpose() * &m_mat * &jp).amax() < 1e-8,
                    "lift is not M-horizontal"
                );
                assert!(rep.manipulability > 0.0);
            }
        }
        assert!(checked > 20, "too few regular samples for {}", k.robot);
    }
}

#[test]
fn damping_is_applied_and_singularities_are_reported() {
    let planar = common::planar();
    let model = &planar.model;
    let specs: Vec<ChainSpec> = planar
        .kinematics
        .chains()
        .iter()
        .map(|c| ChainSpec {
            name: c.name.clone(),
            base: c.base.clone(),
            tip: c.tip.clone(),
            tool: ToolOffset::default(),
            task: c.task,
        })
        .collect();
    let k = Kinematics::new(
        model,
        &specs,
        &HashMap::new(),
        &KinematicsSettings {
            damping: 0.1,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(k.pinv().damping(), 0.1);
    let mut ws = k.workspace();
    // Fully stretched arms (q = 0) are singular: the Jacobian loses rank.
    let q = vec![0.0; 8];
    k.jacobian(&q, &mut ws);
    let rep = k.factor(&mut ws);
    assert_ne!(rep.status, PinvStatus::Regular);
    assert!(rep.manipulability < 1e-6);
    // The damped solution stays bounded: |J⁺ ẋ| ≤ |ẋ| / (2λ) for any unit ẋ.
    let mut out = vec![0.0; 8];
    k.solve(&mut ws, &[0.0, 1.0, 1.0, 0.0], &mut out);
    assert!(out.iter().all(|v| v.is_finite()));
    assert!(out.iter().map(|v| v * v).sum::<f64>().sqrt() <= 2f64.sqrt() / (2.0 * 0.1) + 1e-9);
    // Undamped at the singularity: no solution is formed, zeros are returned.
    let k0 = Kinematics::new(
        model,
        &specs,
        &HashMap::new(),
        &KinematicsSettings::default(),
    )
    .unwrap();
    let mut ws0 = k0.workspace();
    k0.jacobian(&q, &mut ws0);
    assert_eq!(k0.factor(&mut ws0).status, PinvStatus::Singular);
    k0.solve(&mut ws0, &[0.0, 1.0, 1.0, 0.0], &mut out);
    assert!(out.iter().all(|v| *v == 0.0));
    assert!(
        crossym::kinematics::condition_number(&ws0.jac).is_infinite()
            || crossym::kinematics::condition_number(&ws0.jac) > 1e8
    );
}

#[test]
#[allow(clippy::approx_constant)] // the URDF writes π as 3.141592654: compare with its text
fn rby1_limits_and_acceleration_attribute_are_parsed() {
    let Some(urdf) = common::rby1_urdf() else {
        return;
    };
    let model = RobotModel::from_urdf_file(&urdf).unwrap();
    let l1 = model.joint("left_arm_1").unwrap().limits;
    let r1 = model.joint("right_arm_1").unwrap().limits;
    assert!((l1.lower + 0.017453293).abs() < 1e-12 && (l1.upper - 3.141592654).abs() < 1e-12);
    assert!((r1.lower + 3.141592654).abs() < 1e-12 && (r1.upper - 0.017453293).abs() < 1e-12);
    for side in ["left", "right"] {
        for i in 0..7 {
            let j = model.joint(&format!("{side}_arm_{i}")).unwrap();
            assert_eq!(j.kind, JointKind::Revolute);
            assert_eq!(j.limits.acceleration, Some(10.0), "{side}_arm_{i}");
        }
    }
    assert_eq!(
        model.joint("torso_0").unwrap().limits.acceleration,
        Some(5.0)
    );
    assert_eq!(model.joint("head_0").unwrap().limits.acceleration, None);
    assert!(model
        .joint("right_wheel")
        .unwrap()
        .limits
        .upper
        .is_infinite());
    // The RB-Y1 config controls exactly the 14 arm joints.
    let rby1 = common::rby1().unwrap();
    let names: Vec<String> = ["left", "right"]
        .iter()
        .flat_map(|s| (0..7).map(move |i| format!("{s}_arm_{i}")))
        .collect();
    assert_eq!(rby1.kinematics.joint_names(), &names[..]);
}

#[test]
fn config_overrides_supply_acceleration_limits() {
    let text = format!(
        "[robot]\nurdf = \"{}\"\n[[robot.chains]]\nname = \"arm\"\nbase = \"base_link\"\ntip = \"tool0\"\n[robot.limits.j2]\nacceleration = 4.5\nvelocity = 1.25\n",
        common::path("urdf/test_arm_7dof.urdf").display()
    );
    let cfg =
        crossym::config::Config::from_toml_str(&text, std::path::Path::new("inline.toml")).unwrap();
    let robot = cfg.load_robot().unwrap();
    let lim = robot.kinematics.limits();
    assert_eq!(lim[0].acceleration, Some(8.0), "URDF value kept");
    assert_eq!(lim[1].acceleration, Some(4.5), "config supplies it");
    assert_eq!(lim[1].velocity, 1.25);
    assert!(
        lim[2].lower.is_infinite(),
        "continuous joint j3 is unbounded"
    );
}

/// `[robot.limits] j = { lower, upper }` narrows a joint's range (a workcell); widening the
/// URDF's range, an empty range and a position range in `hardware_limits` are refused.
#[test]
fn config_overrides_narrow_position_ranges_and_refuse_widening() {
    let load = |extra: &str| {
        let text = format!(
            "[robot]\nurdf = \"{}\"\n{extra}\n[[robot.chains]]\nname = \"arm\"\nbase = \"base_link\"\ntip = \"tool0\"\n",
            common::path("urdf/test_arm_7dof.urdf").display()
        );
        crossym::config::Config::from_toml_str(&text, std::path::Path::new("inline.toml"))
            .unwrap()
            .load_robot()
    };
    let urdf = load("").unwrap().kinematics.limits()[1];
    let (lo, hi) = (urdf.lower + 0.25, urdf.upper - 0.5);
    let narrowed = load(&format!(
        "limits = {{ j2 = {{ lower = {lo}, upper = {hi} }} }}"
    ))
    .unwrap()
    .kinematics
    .limits()[1];
    assert_eq!((narrowed.lower, narrowed.upper), (lo, hi));
    assert_eq!(narrowed.velocity, urdf.velocity, "velocity untouched");
    let upper_only = load(&format!("limits = {{ j2 = {{ upper = {hi} }} }}"))
        .unwrap()
        .kinematics
        .limits()[1];
    assert_eq!((upper_only.lower, upper_only.upper), (urdf.lower, hi));
    for (extra, needle) in [
        (
            format!("limits = {{ j2 = {{ upper = {} }} }}", urdf.upper + 0.1),
            "widens",
        ),
        (
            format!("limits = {{ j2 = {{ lower = {hi}, upper = {lo} }} }}"),
            "not below",
        ),
        ("hardware_limits = { upper = 0.5 }".to_string(), "per joint"),
    ] {
        let Err(e) = load(&extra) else {
            panic!("{extra}: accepted");
        };
        let e = e.to_string();
        assert!(e.contains(needle), "{extra}: {e}");
    }
}

#[test]
fn held_joints_are_frozen_into_the_chain() {
    let (model, _) = test_arm();
    let spec = ChainSpec {
        name: "arm".into(),
        base: "base_link".into(),
        tip: "tool0".into(),
        tool: ToolOffset::default(),
        task: TaskSpace::Xyz,
    };
    let held: HashMap<String, f64> = [("j3".to_string(), 0.7)].into();
    let six = Chain::new(&model, &spec, &held).unwrap();
    let seven = Chain::new(&model, &spec, &HashMap::new()).unwrap();
    assert_eq!((six.dof(), seven.dof()), (6, 7));
    let q7 = [0.1, -0.2, 0.7, 0.4, 0.05, -0.3, 0.9];
    let q6 = [0.1, -0.2, 0.4, 0.05, -0.3, 0.9];
    let (mut w6, mut w7) = (six.workspace(), seven.workspace());
    let p6 = six.position(&q6, &mut w6);
    let p7 = seven.position(&q7, &mut w7);
    assert!((p6 - p7).norm() < 1e-12);
}

#[test]
fn broken_input_gives_clear_errors() {
    // Malformed XML names the source.
    let e = RobotModel::from_urdf_str("<robot name='x'><link name='a'/>", "bad.urdf").unwrap_err();
    assert!(e.to_string().contains("bad.urdf"), "{e}");
    // A joint pointing at an undefined link names the joint and the link.
    let xml = r#"<robot name="r"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
    let e = RobotModel::from_urdf_str(xml, "mem.urdf").unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("mem.urdf"), "{msg}");
    assert!(msg.contains('b'), "{msg}");
    // A zero axis on a movable joint.
    let xml = r#"<robot name="r"><link name="a"/><link name="b"/><joint name="j0" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#;
    let e = RobotModel::from_urdf_str(xml, "axis.urdf").unwrap_err();
    assert!(
        matches!(e, KinematicsError::BadJoint { ref joint, .. } if joint == "j0"),
        "{e}"
    );
    // A non-numeric acceleration attribute.
    let xml = r#"<robot name="r"><link name="a"/><link name="b"/><joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1" acceleration="fast"/></joint></robot>"#;
    let e = RobotModel::from_urdf_str(xml, "acc.urdf").unwrap_err();
    assert!(
        e.to_string().contains("fast") && e.to_string().contains("j1"),
        "{e}"
    );
    // Missing file names the path.
    let e = RobotModel::from_urdf_file("/nonexistent/robot.urdf").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/robot.urdf"));
    // Unknown link and not-a-chain in configuration.
    let (model, _) = test_arm();
    let spec = ChainSpec {
        name: "arm".into(),
        base: "base_link".into(),
        tip: "nope".into(),
        tool: ToolOffset::default(),
        task: TaskSpace::Xyz,
    };
    let e = Chain::new(&model, &spec, &HashMap::new()).unwrap_err();
    assert!(
        matches!(e, KinematicsError::UnknownLink { ref link, .. } if link == "nope"),
        "{e}"
    );
    let spec = ChainSpec {
        name: "arm".into(),
        base: "tool0".into(),
        tip: "base_link".into(),
        tool: ToolOffset::default(),
        task: TaskSpace::Xyz,
    };
    assert!(matches!(
        Chain::new(&model, &spec, &HashMap::new()),
        Err(KinematicsError::NotAChain { .. })
    ));
    // Unknown held joint and bad settings.
    let spec = ChainSpec {
        name: "arm".into(),
        base: "base_link".into(),
        tip: "tool0".into(),
        tool: ToolOffset::default(),
        task: TaskSpace::Xyz,
    };
    let held: HashMap<String, f64> = [("jX".to_string(), 0.0)].into();
    assert!(matches!(
        Chain::new(&model, &spec, &held),
        Err(KinematicsError::UnknownJoint { .. })
    ));
    let bad = KinematicsSettings {
        damping: -1.0,
        ..Default::default()
    };
    assert!(matches!(
        Kinematics::new(&model, std::slice::from_ref(&spec), &HashMap::new(), &bad),
        Err(KinematicsError::InvalidSetting { .. })
    ));
    assert!(Metric::diagonal(&[1.0, f64::NAN]).is_err());
    // A config with a typo'd key is rejected with the file name.
    let e = crossym::config::Config::from_toml_str(
        "[robot]\nurdf='x'\nchains=[]\ndampnig=1\n",
        std::path::Path::new("typo.toml"),
    )
    .unwrap_err();
    assert!(
        e.to_string().contains("typo.toml") && e.to_string().contains("dampnig"),
        "{e}"
    );
}

/// crossym's FK (z-aligned joint frames) against the `k` crate's (per-joint axis-angle
/// transforms) on the test arm, whose axes include a tilted one and −z, and on the
/// RB-Y1 arms when the vendor URDF is present: tip pose to 1e-12.
#[test]
fn fk_matches_the_k_crate() {
    /// `base_joint`: k's joint whose child is the chain's base link (None: the root).
    fn compare(
        urdf: &std::path::Path,
        base: &str,
        base_joint: Option<&str>,
        tip: &str,
        end_joint: &str,
    ) {
        let model = RobotModel::from_urdf_file(urdf).unwrap();
        let spec = ChainSpec {
            name: "c".into(),
            base: base.into(),
            tip: tip.into(),
            tool: ToolOffset::default(),
            task: TaskSpace::Xyz,
        };
        let chain = Chain::new(&model, &spec, &HashMap::new()).unwrap();
        let tree = k::Chain::<f64>::from_urdf_file(urdf).unwrap();
        let end = tree.find(end_joint).unwrap().clone();
        let serial = k::SerialChain::from_end(&end);
        // k's serial chain starts at the root: joints above the base stay at 0.
        let names: Vec<String> = serial.iter_joints().map(|j| j.name.clone()).collect();
        let mut rng = common::rng(7);
        let mut ws = chain.workspace();
        for _ in 0..50 {
            let q = common::random_q(&mut rng, &chain.limits);
            let full: Vec<f64> = names
                .iter()
                .map(|n| {
                    chain
                        .joint_names
                        .iter()
                        .position(|c| c == n)
                        .map_or(0.0, |i| q[i])
                })
                .collect();
            serial.set_joint_positions_unchecked(&full);
            serial.update_transforms();
            let base_world = base_joint.map_or_else(k::nalgebra::Isometry3::identity, |j| {
                tree.find(j).unwrap().world_transform().unwrap()
            });
            let theirs = base_world.inverse() * end.world_transform().unwrap();
            let ours = chain.forward(&q, &mut ws);
            // Two nalgebra versions: compare entries.
            let (tp, tr) = (
                theirs.translation.vector,
                theirs.rotation.to_rotation_matrix(),
            );
            let dp = (0..3)
                .map(|i| (ours.translation.vector[i] - tp[i]).abs())
                .fold(0.0, f64::max);
            let dr = (0..9)
                .map(|i| (ours.rotation.matrix()[(i / 3, i % 3)] - tr[(i / 3, i % 3)]).abs())
                .fold(0.0, f64::max);
            assert!(
                dp < 1e-12 && dr < 1e-12,
                "{tip}: Δp {dp:e}, ΔR {dr:e} at {q:?}"
            );
        }
    }
    compare(
        &common::path("urdf/test_arm_7dof.urdf"),
        "base_link",
        None,
        "tool0",
        "tool_joint",
    );
    match common::rby1_urdf() {
        Some(urdf) => {
            for side in ["left", "right"] {
                let end = format!("FT_Sensor_END_{side}");
                compare(
                    &urdf,
                    "link_torso_5",
                    Some("torso_5"),
                    &format!("ee_{side}"),
                    &end,
                );
            }
        }
        None => crate::skip::skip("RB-Y1 part: vendor URDF absent"),
    }
}

/// `dJ|_q[δ]` (`Kinematics::jacobian_derivative`) against central differences of the
/// stacked task Jacobian, on the planar dual arm and RB-Y1.
#[test]
fn jacobian_derivative_matches_finite_differences() {
    fn check(k: &Kinematics, seed: u64) {
        let mut rng = common::rng(seed);
        let mut ws = k.workspace();
        let h = 1e-6;
        for _ in 0..30 {
            let q = common::random_q(&mut rng, k.limits());
            let delta: Vec<f64> = common::random_q(&mut rng, k.limits())
                .iter()
                .zip(&q)
                .map(|(a, b)| a - b)
                .collect();
            let shifted =
                |s: f64| -> Vec<f64> { q.iter().zip(&delta).map(|(a, d)| a + s * d).collect() };
            k.jacobian(&shifted(h), &mut ws);
            let jp = ws.jac.clone();
            k.jacobian(&shifted(-h), &mut ws);
            let fd = (jp - &ws.jac) / (2.0 * h);
            k.jacobian(&q, &mut ws);
            k.jacobian_derivative(&delta, &mut ws);
            let err = (&ws.jac_dot - &fd).amax();
            let scale = fd.amax().max(1.0);
            assert!(
                err < 1e-6 * scale,
                "{}: dJ error {err:e} (scale {scale})",
                k.robot
            );
        }
    }
    check(&common::planar().kinematics, 3);
    match common::rby1() {
        Some(r) => check(&r.kinematics, 4),
        None => crate::skip::skip("RB-Y1 part: vendor URDF absent"),
    }
}
