//! Canonicalised policies: the composed lifted action's inverse, and the
//! conjugacy of the closed loops, `q_s(t) = Φ_g(q_e(t))`, checked in task space against the
//! task-space group action `g · x` (descended reflection, rotation and scaling acting on
//! `X`, not the lifted flows under test).

use crossym::policy::{EquivariantPolicy, Policy};
use crossym::symmetry::built::BuiltSymmetry;
use crossym::symmetry::compose::{apply_condition, Condition};
use crossym::symmetry::transfer::composed::{ComposedLift, LiftIntegrator};
use crossym::symmetry::transfer::flow::FlowSettings;

use crate::common;

/// Off the training grid: θ not a multiple of 30°, λ outside {0.5, …, 1}, both σ.
const CONDITIONS: [Condition; 3] = [
    Condition {
        theta: 0.296_705_972_839_036, // 17°
        scale: 0.73,
        reflection: -1,
    },
    Condition {
        theta: -1.745_329_251_994_33, // −100°
        scale: 0.37,
        reflection: 1,
    },
    Condition {
        theta: 2.967_059_728_390_36, // 170°
        scale: 1.15,
        reflection: -1,
    },
];

/// `g · x` from the *task-space* actions of the configured symmetries (ρ_X of `M`, the
/// rotation `R` and, when the task has one, the scaling `S`, acting on X) — not from any
/// policy's own map.
pub(crate) fn task_action(built: &[BuiltSymmetry], s: &Condition, x: &[f64]) -> Vec<f64> {
    let find = |name: &str| built.iter().find(|b| b.name() == name);
    let Some(BuiltSymmetry::Finite {
        rho_x: Some(rho_x), ..
    }) = find("M")
    else {
        panic!("M descends to X")
    };
    let lie = |name: &str| match find(name) {
        Some(BuiltSymmetry::Lie { action, .. }) => Some(action.as_ref()),
        None => None,
        _ => panic!("{name} is a Lie symmetry"),
    };
    let rot = lie("R").expect("R");
    let sc = lie("S");
    let mut out = vec![0.0; x.len()];
    assert!(apply_condition(
        s,
        rho_x,
        &|t, p, o| rot.act_on(&[t], p, o),
        &|t, p, o| match sc {
            Some(sc) => sc.act_on(&[t], p, o),
            None => {
                assert_eq!(t, 0.0, "a task without scaling gets λ = 1");
                o.copy_from_slice(p);
                true
            }
        },
        x,
        &mut out
    ));
    out
}

/// One step of the closed loop `q̇ = F(q)`: explicit Euler, or classical RK4.
pub(crate) fn step(q: &mut [f64], h: f64, rk4: bool, f: &mut dyn FnMut(&[f64], &mut [f64])) {
    let n = q.len();
    if !rk4 {
        let mut v = vec![0.0; n];
        f(q, &mut v);
        q.iter_mut().zip(&v).for_each(|(q, v)| *q += h * v);
        return;
    }
    let mut k = vec![vec![0.0; n]; 4];
    let mut y = vec![0.0; n];
    for (i, c) in [0.0, 0.5, 0.5, 1.0].into_iter().enumerate() {
        for j in 0..n {
            y[j] = q[j] + if i == 0 { 0.0 } else { c * h * k[i - 1][j] };
        }
        f(&y, &mut k[i]);
    }
    for j in 0..n {
        q[j] += h / 6.0 * (k[0][j] + 2.0 * k[1][j] + 2.0 * k[2][j] + k[3][j]);
    }
}

/// Largest task-space distance over the rollout between `f(q_s(t_k))` under `s` and
/// `g · f(q_e(t_k))` under the identity, both integrated with step `h` for `steps`.
#[allow(clippy::too_many_arguments)]
fn conjugacy_gap(
    kin: &crossym::kinematics::Kinematics,
    built: &[BuiltSymmetry],
    eq: &EquivariantPolicy,
    base: &Policy,
    s: &Condition,
    q_start: &[f64],
    h: f64,
    steps: usize,
    rk4: bool,
) -> f64 {
    let n = q_start.len();
    let mut ews = eq.workspace();
    let mut pws = base.workspace();
    let mut kws = kin.workspace();
    let mut lws = eq.lift().workspace();
    let mut q_e = q_start.to_vec();
    let mut q_s = vec![0.0; n];
    let mut scratch = vec![0.0; n];
    eq.lift()
        .act_with_differential(s, q_start, &vec![0.0; n], &mut q_s, &mut scratch, &mut lws)
        .unwrap();
    let mut gap: f64 = 0.0;
    for k in 0..=steps {
        let x_e = kin.forward(&q_e, &mut kws).as_slice().to_vec();
        let x_s = kin.forward(&q_s, &mut kws).as_slice().to_vec();
        gap = gap.max(common::dist(&x_s, &task_action(built, s, &x_e)));
        if k == steps {
            break;
        }
        step(&mut q_e, h, rk4, &mut |q, v| {
            base.velocity(q, &Condition::IDENTITY, v, &mut pws)
        });
        step(&mut q_s, h, rk4, &mut |q, v| {
            eq.velocity(q, s, v, &mut ews).expect("feasible")
        });
    }
    gap
}

#[test]
fn closed_loop_under_any_feasible_condition_is_conjugate_to_the_identity_one() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let flow = FlowSettings {
        rtol: 1e-11,
        atol: 1e-13,
        ..FlowSettings::default()
    };
    let lift = ComposedLift::from_symmetries(
        kin,
        &built,
        &cfg.composition.order,
        LiftIntegrator::Adaptive { settings: flow },
    )
    .unwrap();
    let base = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let eq = EquivariantPolicy::new(base.clone(), lift).unwrap();
    let q_start = demos.demos[0].q(0).to_vec();
    // Reach: the largest task-space distance from the base over the demonstration.
    let reach = demos.demos[0]
        .x
        .chunks(2)
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    for s in &CONDITIONS {
        // The forward map lands on g · x in X, and the inverse undoes it (round trip in Q).
        let mut ws = eq.lift().workspace();
        let (mut qg, mut v, mut back) = (vec![0.0; 8], vec![0.0; 8], vec![0.0; 8]);
        eq.lift()
            .act_with_differential(s, &q_start, &[0.0; 8], &mut qg, &mut v, &mut ws)
            .unwrap();
        eq.lift().inverse(s, &qg, &mut back, &mut ws).unwrap();
        assert!(common::dist(&back, &q_start) < 1e-8, "{s:?}");
        let mut kws = kin.workspace();
        let x = kin.forward(&q_start, &mut kws).as_slice().to_vec();
        let xg = kin.forward(&qg, &mut kws).as_slice().to_vec();
        assert!(
            common::dist(&task_action(&built, s, &x), &xg) < 1e-8 * reach,
            "{s:?}"
        );
        // Continuous flow (RK4, 2 s): conjugate to ≤ 1e-6 × reach in task space.
        let rk4 = conjugacy_gap(kin, &built, &eq, &base, s, &q_start, 0.01, 200, true);
        // Euler at the node's step and at half of it: first-order discretisation error.
        let e1 = conjugacy_gap(kin, &built, &eq, &base, s, &q_start, 0.01, 200, false);
        let e2 = conjugacy_gap(kin, &built, &eq, &base, s, &q_start, 0.005, 400, false);
        println!(
            "{s:?}: RK4 gap {rk4:.3e} ({:.1e} × reach {reach:.2}); Euler 0.01 s {e1:.3e}, 0.005 s {e2:.3e}",
            rk4 / reach
        );
        assert!(rk4 <= 1e-6 * reach, "{s:?}: RK4 gap {rk4}");
        assert!(
            e2 < 0.6 * e1 && e1 < 1e-2 * reach,
            "{s:?}: Euler {e1} → {e2}"
        );
    }
}

/// The push-forward of the node's integrator (DOPRI5 at rtol 1e-5): its task component is
/// `Dg J(q) v` to rounding — checked against the task-space action on points,
/// `Dg u = g·(x + u) − g·x` (`g` affine), not the lift's own differential — and the whole
/// vector is within 5e-4 (relative) of a push-forward by flows at rtol 1e-11 (without the
/// task-space correction: 1.4e-3 on this path).
#[test]
fn push_forward_task_component_is_exact_and_the_rest_close_to_the_tight_flow() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let lift = |integrator| {
        ComposedLift::from_symmetries(kin, &built, &cfg.composition.order, integrator).unwrap()
    };
    let node = lift(crossym::pipeline::canonical_integrator());
    let tight = lift(LiftIntegrator::Adaptive {
        settings: FlowSettings {
            rtol: 1e-11,
            atol: 1e-13,
            ..FlowSettings::default()
        },
    });
    let base = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let mut pws = base.workspace();
    let (mut ws, mut wt, mut kws) = (node.workspace(), tight.workspace(), kin.workspace());
    let n = kin.dof();
    let (mut q, mut qg, mut qt, mut w, mut w_ref, mut v) = (
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
        vec![0.0; n],
    );
    let jv = |kws: &mut crossym::kinematics::KinematicsWorkspace, q: &[f64], v: &[f64]| {
        kin.jacobian(q, kws);
        (&kws.jac * nalgebra::DVector::from_column_slice(v))
            .as_slice()
            .to_vec()
    };
    let (mut worst_task, mut worst_rel) = (0.0f64, 0.0f64);
    // Along a smooth path of joint states around the demonstration's start (10 ms apart,
    // as the node sees them: the integrator warm-starts from the previous call's step).
    let q_start = demos.demos[0].q(0);
    let path: Vec<Vec<f64>> = (0..120)
        .map(|k| {
            (0..n)
                .map(|j| q_start[j] + 0.05 * (0.0315 * k as f64 + j as f64).sin())
                .collect()
        })
        .collect();
    for s in &CONDITIONS {
        for (k, q_path) in path.iter().enumerate() {
            // From the path's state, or, where the inverse is feasible, from its canonical
            // point Φ_g⁻¹(q_path) (as a canonicalised policy pushes π₀ forward).
            let canonical = tight.inverse(s, q_path, &mut q, &mut wt).is_ok();
            let q = if canonical { q.as_slice() } else { q_path };
            base.velocity(q, &Condition::IDENTITY, &mut v, &mut pws);
            node.act_with_differential(s, q, &v, &mut qg, &mut w, &mut ws)
                .unwrap();
            tight
                .act_with_differential(s, q, &v, &mut qt, &mut w_ref, &mut wt)
                .unwrap();
            // Dg u on points: g·(x + u) − g·x.
            let x = kin.forward(q, &mut kws).as_slice().to_vec();
            let u = jv(&mut kws, q, &v);
            let xu: Vec<f64> = x.iter().zip(&u).map(|(a, b)| a + b).collect();
            let (gxu, gx) = (task_action(&built, s, &xu), task_action(&built, s, &x));
            let dg_u: Vec<f64> = gxu.iter().zip(&gx).map(|(a, b)| a - b).collect();
            let jw = jv(&mut kws, &qg, &w);
            let task = common::dist(&jw, &dg_u) / common::dist(&dg_u, &vec![0.0; u.len()]);
            let scale = w_ref.iter().fold(0.0f64, |m, a| m.max(a.abs()));
            let rel = w
                .iter()
                .zip(&w_ref)
                .fold(0.0f64, |m, (a, b)| m.max((a - b).abs()))
                / scale;
            if k % 20 == 0 {
                println!(
                    "{s:?} state {k} (canonical {canonical}): task defect {task:.1e}, \
                     push-forward error {rel:.1e}"
                );
            }
            worst_task = worst_task.max(task);
            worst_rel = worst_rel.max(rel);
        }
    }
    println!("worst: task defect {worst_task:.1e}, push-forward error {worst_rel:.1e}");
    assert!(worst_task < 1e-9, "task component off by {worst_task:.2e}");
    assert!(worst_rel < 5e-4, "push-forward off by {worst_rel:.2e}");
}

/// Evaluated like any policy (`eval::score`, Euler at the demonstrations' 0.01 s), the
/// canonicalised policy's error on a transformed test demonstration is its error on the
/// original one times λ — rotations and the reflection are isometries of the task space,
/// the scaling scales distances — for conditions off the training grid, to the Euler
/// rollouts' discretisation (≤ 0.5 %); the plain policy's is not (it was only trained to be
/// approximately equivariant).
#[test]
fn canonicalised_policy_error_is_the_original_error_times_the_scale() {
    use crossym::data::augmentation::letter_flow;
    use crossym::eval::score;
    use crossym::pipeline::nominal_trajectories;
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let lift = ComposedLift::from_symmetries(
        kin,
        &built,
        &cfg.composition.order,
        LiftIntegrator::Adaptive {
            settings: letter_flow(),
        },
    )
    .unwrap();
    let base = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let eq = EquivariantPolicy::new(base.clone(), lift).unwrap();
    let mut plain_spread: f64 = 0.0;
    for &d in &demos.test {
        let demo = demos.demos.iter().find(|t| t.demo == d).unwrap();
        let original = score(&eq, kin, demo, &Condition::IDENTITY, &cfg.eval).rmse;
        let plain_original = score(&base, kin, demo, &Condition::IDENTITY, &cfg.eval).rmse;
        for s in CONDITIONS.iter().filter(|s| s.scale <= 1.0) {
            let nominal = nominal_trajectories(&cfg, kin, demo, &[*s])
                .unwrap()
                .remove(0)
                .traj;
            let r = score(&eq, kin, &nominal, s, &cfg.eval).rmse;
            let plain = score(&base, kin, &nominal, s, &cfg.eval).rmse;
            println!(
                "demo {d} {s:?}: canonicalised {r:.5} = {:.5} × λ (plain {plain:.5} vs {:.5})",
                r / s.scale,
                plain_original * s.scale
            );
            assert!(
                (r - s.scale * original).abs() < 5e-3 * s.scale * original,
                "demo {d} {s:?}: {r} vs λ × {original}"
            );
            plain_spread = plain_spread.max((plain / s.scale / plain_original - 1.0).abs());
        }
    }
    assert!(
        plain_spread > 0.01,
        "the plain policy is not exactly equivariant"
    );
}

/// `crossym eval --canonicalise` names a policy label of the command; an unknown one is a
/// clear error (exit 2) and writes nothing.
#[test]
fn canonicalise_of_an_unknown_label_is_refused() {
    let dir = common::temp_dir("canonicalise-cli");
    let out = common::crossym(["eval", "--canonicalise", "pi_x", "--policy"])
        .arg(format!(
            "pi={}",
            common::path("data/policies/pi_mrt_planar.safetensors").display()
        ))
        .arg("--config")
        .arg(common::path("config/letters.toml"))
        .arg("--out")
        .arg(&dir)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--canonicalise pi_x: no policy labelled `pi_x`"),
        "{err}"
    );
    assert!(!dir.join("table2.md").exists());
}

/// A canonicalised policy saved and loaded again evaluates bit for bit like the one in
/// memory; a sidecar whose composition is not the config's — the rotation about another
/// centre, another order — is refused with what differs; a plain policy loads as plain.
#[test]
fn canonicalised_sidecar_round_trips_and_a_foreign_composition_is_refused() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let plain_file = common::path("data/policies/pi_mrt_planar.safetensors");
    let base = Policy::load(&plain_file).unwrap();
    let any = crossym::pipeline::canonicalise(&cfg, kin, base).unwrap();
    let dir = common::temp_dir("eq-sidecar");
    let file = dir.join("pi_eq.safetensors");
    any.network().save(&file).unwrap();
    let loaded = crossym::pipeline::load_any_policy(&cfg, kin, &file).unwrap();
    assert!(loaded.composition().is_some(), "loads canonicalised");
    assert_eq!(loaded.composition(), any.composition());
    let q = demos.demos[0].q(0);
    let (mut wa, mut wb) = (any.workspace(), loaded.workspace());
    let (mut va, mut vb) = (vec![0.0; 8], vec![0.0; 8]);
    for s in CONDITIONS.iter().take(1).chain([&Condition::IDENTITY]) {
        any.velocity(q, s, &mut va, &mut wa).unwrap();
        loaded.velocity(q, s, &mut vb, &mut wb).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&va), bits(&vb), "{s:?}");
    }
    // The plain file stays plain.
    let plain = crossym::pipeline::load_any_policy(&cfg, kin, &plain_file).unwrap();
    assert!(plain.composition().is_none());

    // Foreign compositions, written as another tool (or an older config) would.
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("pi_eq.json")).unwrap()).unwrap();
    let foreign = |name: &str, edit: &dyn Fn(&mut serde_json::Value)| -> String {
        let mut json = sidecar.clone();
        edit(&mut json["canonicalised"]);
        json["weights_file"] = format!("{name}.safetensors").into();
        std::fs::copy(&file, dir.join(format!("{name}.safetensors"))).unwrap();
        std::fs::write(
            dir.join(format!("{name}.json")),
            serde_json::to_string_pretty(&json).unwrap(),
        )
        .unwrap();
        let err = match crossym::pipeline::load_any_policy(
            &cfg,
            kin,
            &dir.join(format!("{name}.safetensors")),
        ) {
            Ok(_) => panic!("{name}: a foreign composition was accepted"),
            Err(e) => e.to_string(),
        };
        println!("{name}: {err}");
        err
    };
    // Rotation about a point 0.5 further along x: b' = b − A (0.5 e_x) for h(x) = A x + b.
    let err = foreign("moved_centre", &|c| {
        let rot = &mut c["task"]["rotation"];
        let m = rot["offset"].as_array().unwrap().len();
        for i in 0..m {
            let a = rot["linear"][i * m].as_f64().unwrap();
            let b = rot["offset"][i].as_f64().unwrap();
            rot["offset"][i] = (b - 0.5 * a).into();
        }
    });
    assert!(
        err.contains("another composition") && err.contains("rotation"),
        "{err}"
    );
    let err = foreign("other_order", &|c| {
        c["order"] = serde_json::json!(["M", "S", "R"]);
    });
    assert!(err.contains("order"), "{err}");
}

/// `crossym train --equivariant` writes a policy whose sidecar records the config's
/// composition (the network trained on the original demonstrations only), and `crossym
/// rollout` loads it like any policy and follows an off-grid condition.
#[test]
fn train_equivariant_writes_a_canonicalised_policy_that_rollout_loads() {
    let dir = common::temp_dir("train-equivariant");
    let out = dir.join("pi_eq.safetensors");
    let config = common::path("config/letters.toml");
    let train = common::crossym(["train", "--equivariant", "--iterations", "30", "--config"])
        .arg(&config)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&train.stdout);
    assert!(
        train.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&train.stderr)
    );
    assert!(
        stdout.contains("of Original"),
        "trains on the originals: {stdout}"
    );
    let sidecar: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("pi_eq.json")).unwrap()).unwrap();
    assert_eq!(
        sidecar["canonicalised"]["order"],
        serde_json::json!(["M", "R", "S"])
    );
    let rollout = common::crossym(["rollout", "--condition", "0.2967:0.73:-1", "--config"])
        .arg(&config)
        .arg("--policy")
        .arg(&out)
        .arg("--out")
        .arg(dir.join("rollout.csv"))
        .output()
        .unwrap();
    assert!(
        rollout.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&rollout.stdout),
        String::from_utf8_lossy(&rollout.stderr)
    );
    // Refused next to --group (π₀ is always trained on the originals).
    let both = common::crossym(["train", "--equivariant", "--group", "MRT", "--config"])
        .arg(&config)
        .arg("--out")
        .arg(dir.join("x.safetensors"))
        .output()
        .unwrap();
    assert!(!both.status.success());
}

/// A condition accepted where it is feasible becomes infeasible when the robot moves to
/// where its flows fail: the node's tick then commands zero velocity (finite), reports
/// CONDITION_INFEASIBLE and counts the tick as infeasible, not as a non-finite policy
/// output. Infeasible there is shown independently: the canonical pen point
/// `g⁻¹ f(q) = f(q)/λ` (rotation and scaling about the base, as the config's generators
/// are) lies beyond the arm's reach, the sum of its link lengths read off the URDF.
#[test]
fn condition_that_becomes_infeasible_mid_motion_is_reported_and_braked() {
    use crossym::control::{NodeConfig, NodeCore, StatusCode};
    use crossym::msg;
    use crossym::safety::SafetySettings;
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = robot.kinematics.clone();
    let base = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let policy = crossym::pipeline::canonicalise(&cfg, &kin, base).unwrap();
    let s = CONDITIONS[0]; // 17°, λ = 0.73, σ = −1
    let q_ok = demos.demos[0].q(0).to_vec();
    let q_far = cfg.check.reference_q.clone().unwrap();
    // Reach: the URDF's joint offsets along each arm (origin xyz of each joint after the
    // first, and of the end effector), summed — not the kinematics under test.
    let urdf = std::fs::read_to_string(common::path("urdf/planar_dual_arm.urdf")).unwrap();
    let reach: f64 = urdf
        .split("<joint ")
        .filter(|j| j.contains("name=\"left_"))
        .filter_map(|j| j.split("xyz=\"").nth(1))
        .map(|xyz| {
            xyz.split_whitespace()
                .next()
                .unwrap()
                .parse::<f64>()
                .unwrap()
                .abs()
        })
        .sum();
    assert!(reach > 0.0, "reach from the URDF");
    let mut kws = kin.workspace();
    let pen = |q: &[f64], kws: &mut crossym::kinematics::KinematicsWorkspace| {
        let x = kin.forward(q, kws);
        x[0].hypot(x[1]).max(x[2].hypot(x[3]))
    };
    let (r_ok, r_far) = (
        pen(&q_ok, &mut kws) / s.scale,
        pen(&q_far, &mut kws) / s.scale,
    );
    println!(
        "reach {reach}; canonical pen distance {r_ok:.3} at the start, {r_far:.3} at the reference"
    );
    assert!(r_ok < reach && r_far > reach);

    let names = kin.joint_names().to_vec();
    let mut core = NodeCore::new(
        kin,
        policy,
        SafetySettings::default(),
        NodeConfig {
            check_stamps: false,
            ..NodeConfig::default()
        },
    )
    .unwrap();
    let mut cmd = core.command();
    let js = |q: &[f64]| msg::JointState {
        name: names.clone(),
        position: q.to_vec(),
        ..Default::default()
    };
    core.on_joint_state(&js(&q_ok), 0.0).unwrap();
    core.on_condition(&msg::SymmetryCondition {
        theta: s.theta,
        scale: s.scale,
        reflection: s.reflection,
        ..Default::default()
    })
    .expect("feasible at the start");
    let r = core.tick(0.0, &mut cmd);
    assert!(
        matches!(r.code, StatusCode::NoWarning | StatusCode::JointBound),
        "{:?}",
        r.code
    );
    assert!(cmd.velocities.iter().any(|v| *v != 0.0));
    // The robot is now where the condition's flows fail.
    for k in 1..=5 {
        let t = k as f64 * 0.01;
        core.on_joint_state(&js(&q_far), t).unwrap();
        let r = core.tick(t, &mut cmd);
        assert_eq!(r.code, StatusCode::ConditionInfeasible, "tick {k}");
        assert!(r.publish && cmd.velocities.iter().all(|v| v.is_finite()));
    }
    let st = core.status();
    assert_eq!(st.infeasible_ticks, 5);
    assert_eq!(st.nonfinite_ticks, 0);
    // Braking: the velocity decreases to zero under the acceleration bound.
    let mut last = f64::INFINITY;
    for k in 6..200 {
        let t = k as f64 * 0.01;
        core.on_joint_state(&js(&q_far), t).unwrap();
        core.tick(t, &mut cmd);
        let speed = cmd.velocities.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(speed <= last + 1e-12, "tick {k}: {speed} after {last}");
        last = speed;
    }
    assert!(last < 1e-9, "stopped: {last}");
}

/// `crossym density --equivariant P` adds the canonicalised policy's curve: its RMSE is the
/// same at every test rotation θ (to the Euler rollouts' 0.5 %), read back from the CSV —
/// the augmented π_R's is not required to be; a plain policy is refused.
#[test]
fn density_curve_of_the_canonicalised_policy_is_flat() {
    let dir = common::temp_dir("density-eq");
    let config = common::path("config/letters.toml");
    let out = common::crossym([
        "density",
        "--steps",
        "90",
        "--eval-step",
        "45",
        "--iterations",
        "20",
        "--config",
    ])
    .arg(&config)
    .arg("--equivariant")
    .arg(common::path("data/policies/pi_eq_planar.safetensors"))
    .arg("--out")
    .arg(&dir)
    .output()
    .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(dir.join("density.csv")).unwrap();
    let eq: Vec<(f64, f64)> = csv
        .lines()
        .filter(|l| l.starts_with("eq,"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[1].parse().unwrap(), f[2].parse().unwrap())
        })
        .collect();
    assert_eq!(eq.len(), 9, "θ = −180°, −135°, …, 180°: {csv}");
    let at0 = eq.iter().find(|(t, _)| t.abs() < 1e-9).unwrap().1;
    for (theta, rmse) in &eq {
        assert!(
            (rmse - at0).abs() <= 5e-3 * at0,
            "θ = {theta}°: {rmse} vs {at0} at 0°"
        );
    }
    assert!(dir.join("density.png").exists());
    let plain = common::crossym(["density", "--steps", "90", "--iterations", "1", "--config"])
        .arg(&config)
        .arg("--equivariant")
        .arg(common::path("data/policies/pi_mrt_planar.safetensors"))
        .arg("--out")
        .arg(dir.join("plain"))
        .output()
        .unwrap();
    assert!(!plain.status.success());
    assert!(String::from_utf8_lossy(&plain.stderr).contains("not a canonicalised policy"));
}

/// Task-space heads: `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`. Under any
/// condition the task point of the closed loop is `g ·` the identity closed loop's task
/// point, checked against the task-space action of the configured symmetries (not the
/// head's own map), from `Φ_g(q_start)` (a configuration drawing `g · f(q_start)`), with
/// RK4 at 0.01 s for 2 s; the identity closed loop runs the same head.
#[test]
fn task_head_closed_loop_is_g_times_the_identity_one_in_task_space() {
    use crossym::policy::AnyPolicy;
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let file = common::path("data/policies/pi_mrt_head_planar.safetensors");
    let any = crossym::pipeline::load_any_policy(&cfg, kin, &file).unwrap();
    let AnyPolicy::TaskHead(head) = &any else {
        panic!("{} is not a task head", file.display())
    };
    // The shipped head is a four-seed ensemble: its block-diagonal hidden layer runs packed
    // (the golden bag, recorded dense, replays bit for bit through it: bag.rs).
    assert_eq!(head.head().mlp().layer_blocks(1), 4);
    let lift = ComposedLift::from_symmetries(
        kin,
        &built,
        &cfg.composition.order,
        LiftIntegrator::Adaptive {
            settings: FlowSettings {
                rtol: 1e-11,
                atol: 1e-13,
                ..FlowSettings::default()
            },
        },
    )
    .unwrap();
    let q_start = demos.demos[0].q(0).to_vec();
    let reach = demos.demos[0]
        .x
        .chunks(2)
        .map(|p| p[0].hypot(p[1]))
        .fold(0.0, f64::max);
    let (mut hws, mut kws, mut lws) = (head.workspace(), kin.workspace(), lift.workspace());
    for s in &CONDITIONS {
        let mut q_s = vec![0.0; 8];
        let mut scratch = vec![0.0; 8];
        lift.act_with_differential(s, &q_start, &[0.0; 8], &mut q_s, &mut scratch, &mut lws)
            .unwrap();
        let mut q_e = q_start.clone();
        let mut gap: f64 = 0.0;
        let mut travelled: f64 = 0.0;
        let x0 = kin.forward(&q_e, &mut kws).as_slice().to_vec();
        for k in 0..=200 {
            let x_e = kin.forward(&q_e, &mut kws).as_slice().to_vec();
            let x_s = kin.forward(&q_s, &mut kws).as_slice().to_vec();
            gap = gap.max(common::dist(&x_s, &task_action(&built, s, &x_e)));
            travelled = travelled.max(common::dist(&x_e, &x0));
            if k == 200 {
                break;
            }
            step(&mut q_e, 0.01, true, &mut |q, v| {
                head.velocity(q, &Condition::IDENTITY, v, &mut hws)
                    .expect("regular")
            });
            step(&mut q_s, 0.01, true, &mut |q, v| {
                head.velocity(q, s, v, &mut hws).expect("regular")
            });
        }
        println!(
            "{s:?}: task-space gap {gap:.3e} over a motion of {travelled:.3} (reach {reach:.2})"
        );
        assert!(travelled > 0.1 * reach, "{s:?}: the head barely moved");
        assert!(gap <= 1e-6 * reach, "{s:?}: gap {gap}");
    }
}
