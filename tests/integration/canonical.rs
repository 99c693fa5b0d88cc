//! Canonical task-space features `x̃ = g(s)⁻¹ f(q)`: they undo the augmentation (every
//! transformed letter maps back onto the original one), the training-side affine map agrees
//! with inference, and a policy with them trains, saves, loads, checks its robot and
//! refuses broken files.

use crossym::pipeline::nominal_trajectories;
#[cfg(feature = "teach")]
use crossym::policy::{JointTrajectory, LrSchedule, PolicyMeta, TrainConfig};
use crossym::policy::{Policy, TaskFeatures};
use crossym::symmetry::check::build;
use crossym::symmetry::compose::Condition;
#[cfg(feature = "teach")]
use crossym::train::train_with_features;

use crate::common;

fn letter_features() -> (
    crossym::config::Config,
    crossym::config::LoadedRobot,
    crossym::data::demonstrations::Demonstrations,
    TaskFeatures,
) {
    let (cfg, robot, demos) = common::task("letters.toml");
    let (built, _) = build(&robot.kinematics, &cfg.symmetries).unwrap();
    let f = TaskFeatures::for_robot(&robot.kinematics, &built, &cfg.composition.order).unwrap();
    (cfg, robot, demos, f)
}

fn conditions() -> Vec<Condition> {
    let mut out = Vec::new();
    for (theta, scale) in [
        (0.0, 1.0),
        (std::f64::consts::FRAC_PI_4, 0.7),
        (-2.0943951023931953, 0.5),
    ] {
        for reflection in [1, -1] {
            out.push(Condition {
                theta,
                scale,
                reflection,
            });
        }
    }
    out
}

#[test]
fn canonical_points_of_augmented_letters_are_the_original_letters() {
    let (cfg, robot, demos, f) = letter_features();
    let kin = &robot.kinematics;
    let demo = &demos.demos[0];
    let nominal = nominal_trajectories(&cfg, kin, demo, &conditions()).unwrap();
    let mut ws = f.workspace();
    let m = f.dim();
    let mut xt = vec![0.0; m];
    for a in &nominal {
        let (mut worst, mut moved) = (0.0f64, 0.0f64);
        for k in 0..a.traj.len() {
            f.canonical(a.traj.q(k), &a.condition, &mut xt, &mut ws);
            let orig = &demo.x[k * m..(k + 1) * m];
            worst = worst.max(common::dist(&xt, orig));
            // The transformed letter itself is elsewhere (except for the identity).
            moved = moved.max(common::dist(&a.traj.x[k * m..(k + 1) * m], orig));
        }
        // The lifted flows are integrated to ≈ 3e-7 task-space equivariance.
        assert!(
            worst < 1e-5,
            "{:?}: x̃ off the letter by {worst:e}",
            a.condition
        );
        if a.condition != Condition::IDENTITY {
            assert!(moved > 0.5, "{:?}: the letter did not move", a.condition);
        }
    }
}

#[test]
fn training_affine_map_equals_inference_encoding() {
    let (_, robot, demos, mut f) = letter_features();
    let kin = &robot.kinematics;
    let demo = &demos.demos[1];
    f.fit(conditions().into_iter().map(|s| (demo, s))).unwrap();
    assert!(f.spec().std.iter().all(|&s| s > 0.1), "{:?}", f.spec().std);
    let m = f.dim();
    let (mut ws, mut kws) = (f.workspace(), kin.workspace());
    let mut enc = vec![0.0; m];
    for s in conditions() {
        let (e_mat, e_off) = f.affine_for(&s);
        for k in (0..demo.len()).step_by(37) {
            let q = demo.q(k);
            f.encode(q, &s, &mut enc, &mut ws);
            let x = kin.forward(q, &mut kws);
            for i in 0..m {
                let lin: f64 = (0..m).map(|j| e_mat[i * m + j] * x[j]).sum();
                assert!((lin + e_off[i] - enc[i]).abs() < 1e-12, "{s:?} row {i}");
            }
        }
    }
    f.check_kinematics(kin).unwrap();
}

#[cfg(feature = "teach")]
fn tiny_config() -> TrainConfig {
    TrainConfig {
        hidden: vec![16, 16],
        horizon: 4,
        stride: 5,
        velocity_weight: 0.0,
        learning_rate: 3e-3,
        lr_schedule: LrSchedule::Constant,
        iterations: 60,
        batch_size: 32,
        seed: 3,
        log_every: 10,
        pad_end: true,
        task_features: true,
        ..TrainConfig::default()
    }
}

#[cfg(feature = "teach")]
#[test]
fn task_feature_policy_trains_saves_loads_and_checks_its_robot() {
    let (cfg, robot, demos, f) = letter_features();
    let kin = &robot.kinematics;
    let demo = &demos.demos[0];
    let conds = [conditions()[0], conditions()[3]];
    let nominal = nominal_trajectories(&cfg, kin, demo, &conds).unwrap();
    let data: Vec<(&JointTrajectory, Condition)> =
        nominal.iter().map(|a| (&a.traj, a.condition)).collect();
    let meta = PolicyMeta::new(
        &kin.robot,
        kin.joint_names().to_vec(),
        serde_json::Value::Null,
    );

    // The flag and the features must come together.
    let e = train_with_features(&data, &tiny_config(), meta.clone(), None, |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("task_features"), "{e}");

    let (p, report) = train_with_features(&data, &tiny_config(), meta, Some(f), |_, _| {}).unwrap();
    assert!(
        report.final_loss < 0.7 * report.initial_loss,
        "{} → {}",
        report.initial_loss,
        report.final_loss
    );
    let n = kin.dof();
    assert_eq!(p.mlp().spec().input, n + 4 + 4);
    let t = p.task_features().expect("features kept");
    t.check_kinematics(kin).unwrap();

    // Inference equals candle on the encoded input.
    let candle = crossym::train::CandleMlp::from_inference(p.mlp()).unwrap();
    let mut ws = p.workspace();
    let mut tw = t.workspace();
    let (mut v, mut feat) = (vec![0.0; n], vec![0.0; 4]);
    for (k, (traj, s)) in data.iter().enumerate() {
        let q = traj.q(17 * k + 5);
        p.velocity(q, s, &mut v, &mut ws);
        let mut u = vec![0.0; n];
        p.normalizer().normalize_q(q, &mut u);
        t.encode(q, s, &mut feat, &mut tw);
        u.extend_from_slice(&feat);
        u.extend_from_slice(&[
            s.theta.cos(),
            s.theta.sin(),
            s.scale.ln(),
            f64::from(s.reflection),
        ]);
        let y = candle.forward_rows(&u, 1).unwrap();
        for j in 0..n {
            let want = p.normalizer().v_scale[j] * y[j];
            assert!(
                (v[j] - want).abs() < 1e-5 * (1.0 + want.abs()),
                "{j}: {} vs {want}",
                v[j]
            );
        }
    }

    // Save / load round trip: equal policy, equal velocities.
    let dir = common::temp_dir("canonical");
    let path = dir.join("pi.safetensors");
    p.save(&path).unwrap();
    let back = Policy::load(&path).unwrap();
    assert_eq!(back, p);
    let mut wb = back.workspace();
    let mut vb = vec![0.0; n];
    let s = conds[1];
    back.velocity(demo.q(40), &s, &mut vb, &mut wb);
    p.velocity(demo.q(40), &s, &mut v, &mut ws);
    assert_eq!(v, vb);

    // Another robot geometry (one link 0.1 longer) is refused with the reason.
    let mut moved = robot.model.clone();
    let j = moved.joint_id(&kin.joint_names()[1]).unwrap();
    moved.joints[j].origin.translation.vector.x += 0.1;
    let kin2 = crossym::kinematics::Kinematics::new(
        &moved,
        &cfg.robot.chains,
        &Default::default(),
        &cfg.kinematics,
    )
    .unwrap();
    let e = back
        .task_features()
        .unwrap()
        .check_kinematics(&kin2)
        .unwrap_err();
    assert!(
        matches!(&e, crossym::policy::PolicyFitError::Robot { message }
            if message.contains("another robot geometry")),
        "{e:?}"
    );

    // A broken sidecar names the field.
    let side = crossym::policy::sidecar_path(&path);
    let text = std::fs::read_to_string(&side).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["task_features"]["std"][0] = serde_json::json!(-1.0);
    std::fs::write(&side, serde_json::to_string(&json).unwrap()).unwrap();
    let e = Policy::load(&path).unwrap_err().to_string();
    assert!(e.contains("task_features") && e.contains("std[0]"), "{e}");
    json["task_features"]["std"][0] = serde_json::json!(1.0);
    json["task_features"]["map"]["reflection"]["perm"] = serde_json::json!([0, 0, 1, 2]);
    std::fs::write(&side, serde_json::to_string(&json).unwrap()).unwrap();
    let e = Policy::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("task_features") && e.contains("permutation"),
        "{e}"
    );
    // A generator stored under the wrong closed form is caught, not silently misapplied.
    json["task_features"]["map"]["reflection"]["perm"] = serde_json::json!([2, 3, 0, 1]);
    json["task_features"]["map"]["scaling"]["kind"] = serde_json::json!("rotation");
    std::fs::write(&side, serde_json::to_string(&json).unwrap()).unwrap();
    let e = Policy::load(&path).unwrap_err().to_string();
    assert!(
        e.contains("stored as Rotation") && e.contains("Scaling"),
        "{e}"
    );
}

#[test]
fn canonical_features_undo_the_rby1_letter_and_pan_groups() {
    if common::rby1_urdf().is_none() {
        return;
    }
    for (name, scale) in [("rby1-letters.toml", 0.8), ("rby1-pan.toml", 1.0)] {
        let (cfg, robot, demos) = common::task(name);
        let kin = &robot.kinematics;
        let (built, _) = build(kin, &cfg.symmetries).unwrap();
        let f = TaskFeatures::for_robot(kin, &built, &cfg.composition.order).unwrap();
        f.check_kinematics(kin).unwrap();
        assert_eq!(f.spec().map.scaling.is_some(), scale != 1.0, "{name}");
        let demo = &demos.demos[0];
        let conds: Vec<Condition> = [(0.0, 1), (0.3, -1), (-0.2, 1)]
            .iter()
            .map(|&(theta, reflection)| Condition {
                theta,
                scale,
                reflection,
            })
            .collect();
        let nominal = nominal_trajectories(&cfg, kin, demo, &conds).unwrap();
        let (m, mut ws) = (f.dim(), f.workspace());
        let mut xt = vec![0.0; m];
        for a in &nominal {
            let mut worst = 0.0f64;
            for k in 0..a.traj.len() {
                f.canonical(a.traj.q(k), &a.condition, &mut xt, &mut ws);
                worst = worst.max(common::dist(&xt, &demo.x[k * m..(k + 1) * m]));
            }
            assert!(worst < 1e-5, "{name} {:?}: x̃ off by {worst:e}", a.condition);
        }
    }
}

#[test]
fn features_of_a_sub_group_policy_undo_only_that_sub_group() {
    use crossym::policy::SubGroup;
    let (cfg, robot, demos, full) = letter_features();
    let demo = &demos.demos[0];
    let m = full.dim();
    let rot = Condition {
        theta: 0.5,
        ..Condition::IDENTITY
    };
    let scaled = Condition { scale: 0.6, ..rot };
    let mirrored = Condition {
        reflection: -1,
        ..scaled
    };
    let nominal =
        nominal_trajectories(&cfg, &robot.kinematics, demo, &[rot, scaled, mirrored]).unwrap();
    // Largest distance of x̃ from the original letter over each trajectory.
    let off = |f: &TaskFeatures, k: usize| {
        let (mut ws, mut xt) = (f.workspace(), vec![0.0; m]);
        let a = &nominal[k];
        (0..a.traj.len())
            .map(|i| {
                f.canonical(a.traj.q(i), &a.condition, &mut xt, &mut ws);
                common::dist(&xt, &demo.x[i * m..(i + 1) * m])
            })
            .fold(0.0, f64::max)
    };
    for (group, undone) in [
        (SubGroup::Identity, [false, false, false]),
        (SubGroup::R, [true, false, false]),
        (SubGroup::RT, [true, true, false]),
        (SubGroup::MRT, [true, true, true]),
    ] {
        let mut f = full.clone();
        f.restrict_to(group);
        let map = &f.spec().map;
        assert_eq!(
            [
                map.rotation.is_some(),
                map.scaling.is_some(),
                map.reflection.is_some()
            ],
            undone,
            "{group:?}"
        );
        for (k, &u) in undone.iter().enumerate() {
            let d = off(&f, k);
            assert_eq!(d < 1e-5, u, "{group:?}, trajectory {k}: x̃ off by {d}");
        }
    }
}

#[test]
fn velocity_from_the_callers_fk_equals_the_policys_own_fk_bit_for_bit() {
    // The node's tick feeds `Policy::velocity_at` with the FK of its safety filter instead
    // of letting the policy recompute it: same bits, so replays of recorded bags still match.
    let robot = common::planar();
    let kin = &robot.kinematics;
    let policy = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    assert!(
        policy.task_features().is_some(),
        "the shipped policy reads x̃"
    );
    let n = policy.dim();
    let (mut ws, mut kws) = (policy.workspace(), kin.workspace());
    let (mut own, mut given) = (vec![0.0; n], vec![0.0; n]);
    let mut rng = common::rng(11);
    let mut moved = 0.0f64;
    for _ in 0..50 {
        let q = common::random_q(&mut rng, kin.limits());
        kin.jacobian(&q, &mut kws);
        for s in conditions() {
            policy.velocity(&q, &s, &mut own, &mut ws);
            policy.velocity_at(&q, kws.x.as_slice(), &s, &mut given, &mut ws);
            assert_eq!(own, given, "q = {q:?}, {s:?}");
            assert!(own.iter().all(|v| v.is_finite()));
            moved = moved.max(own.iter().fold(0.0f64, |a, v| a.max(v.abs())));
        }
        // A different point gives a different velocity: `x` is really read.
        let mut shifted = kws.x.as_slice().to_vec();
        shifted[0] += 0.5;
        policy.velocity_at(&q, &shifted, &Condition::IDENTITY, &mut given, &mut ws);
        policy.velocity(&q, &Condition::IDENTITY, &mut own, &mut ws);
        assert_ne!(own, given);
    }
    assert!(moved > 1e-3, "the policy is not moving: {moved}");
}
