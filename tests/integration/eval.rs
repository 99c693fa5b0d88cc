//! Evaluation (Table II machinery): a policy scored on its own rollout has zero RMSE, a
//! wrong condition does not, and a runaway policy is counted as diverged; `crossym
//! rollout` writes what the library's rollout computes and scores it as eval does.

use crossym::eval::{evaluate, rollout, score, EvalConfig, RolloutStatus};
use crossym::pipeline::nominal_trajectories;
use crossym::policy::JointTrajectory;
use crossym::policy::{Activation, MlpInference, MlpSpec, Normalizer, Policy, PolicyMeta};
use crossym::symmetry::compose::Condition;
use rand::Rng;

use crate::common;

fn small_policy(n: usize, gain: f64, seed: u64) -> Policy {
    let spec = MlpSpec {
        input: n + 4,
        hidden: vec![16],
        output: n,
        activation: Activation::Tanh,
    };
    let mut rng = common::rng(seed);
    let weights = vec![
        (0..16 * (n + 4))
            .map(|_| rng.random_range(-0.5..0.5))
            .collect(),
        (0..n * 16)
            .map(|_| gain * rng.random_range(-0.5..0.5))
            .collect(),
    ];
    let biases = vec![vec![0.0; 16], vec![0.0; n]];
    let mlp = MlpInference::new(spec, weights, biases).unwrap();
    let names = (0..n).map(|i| format!("j{i}")).collect();
    Policy::new(
        Normalizer::identity(n),
        mlp,
        PolicyMeta::new("planar_dual_arm", names, serde_json::Value::Null),
    )
    .unwrap()
}

fn own_rollout(policy: &Policy, s: &Condition, q0: &[f64], steps: usize) -> JointTrajectory {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let q = policy.rollout(q0, s, 0.01, steps);
    let mut ws = kin.workspace();
    let x: Vec<f64> = q
        .chunks(8)
        .flat_map(|qi| kin.forward(qi, &mut ws).as_slice().to_vec())
        .collect();
    JointTrajectory {
        demo: 1,
        n: 8,
        m: 4,
        dt: 0.01,
        qdot: vec![0.0; q.len()],
        q,
        x,
    }
}

#[test]
fn own_rollout_scores_zero_and_wrong_condition_does_not() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let policy = small_policy(8, 1.0, 1);
    let s = Condition {
        theta: 0.3,
        scale: 0.8,
        reflection: -1,
    };
    let q0 = [0.78, -0.52, -0.39, -0.31, -0.78, 0.52, 0.39, 0.31];
    let traj = own_rollout(&policy, &s, &q0, 200);
    let cfg = EvalConfig::default();
    let sc = score(&policy, kin, &traj, &s, &cfg);
    assert_eq!(sc.rmse, 0.0);
    assert!(!sc.diverged);
    let other = Condition {
        theta: -1.0,
        scale: 0.5,
        reflection: 1,
    };
    let sc = score(&policy, kin, &traj, &other, &cfg);
    assert!(sc.rmse > 1e-3 && sc.rmse.is_finite(), "{sc:?}");
    let cell = evaluate(&policy, kin, &[(&traj, s), (&traj, other)], &cfg);
    assert_eq!((cell.count, cell.diverged), (2, usize::from(sc.diverged)));
    assert!((cell.mean - sc.rmse / 2.0).abs() < 1e-12 && (cell.std - sc.rmse / 2.0).abs() < 1e-12);
}

#[test]
fn runaway_policy_is_counted_as_diverged() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let calm = small_policy(8, 0.01, 2);
    let s = Condition::IDENTITY;
    let q0 = [0.78, -0.52, -0.39, -0.31, -0.78, 0.52, 0.39, 0.31];
    let traj = own_rollout(&calm, &s, &q0, 300);
    let wild = small_policy(8, 400.0, 3);
    let sc = score(
        &wild,
        kin,
        &traj,
        &s,
        &EvalConfig {
            divergence_threshold: 1.0,
            ..EvalConfig::default()
        },
    );
    assert!(sc.diverged && sc.rmse.is_finite(), "{sc:?}");
    // The threshold only labels the rollout: its whole path is scored, not capped there.
    let uncapped = score(
        &wild,
        kin,
        &traj,
        &s,
        &EvalConfig {
            divergence_threshold: 1e9,
            ..EvalConfig::default()
        },
    );
    assert!(!uncapped.diverged, "{uncapped:?}");
    assert_eq!(uncapped.rmse, sc.rmse);
    assert!(sc.rmse > 1.0, "{sc:?}");
}

#[test]
fn per_arm_rmse_splits_the_stacked_error() {
    let (_, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let traj = &demos.demos[0];
    // The right arm's path shifted by (0.3, 0.4): per-arm RMSE 0 and 0.5, stacked 0.5.
    let mut path = traj.x.clone();
    for k in 0..traj.len() {
        path[k * traj.m + 2] += 0.3;
        path[k * traj.m + 3] += 0.4;
    }
    let r = crossym::eval::chain_rmse(kin, traj, &path);
    assert_eq!(r.len(), 2);
    assert!(r[0].abs() < 1e-12 && (r[1] - 0.5).abs() < 1e-12, "{r:?}");
    // A rollout that turns non-finite keeps its last finite error.
    path[(traj.len() - 1) * traj.m + 2] = f64::NAN;
    let r = crossym::eval::chain_rmse(kin, traj, &path);
    assert!((r[1] - 0.5).abs() < 1e-12, "{r:?}");
}

#[test]
fn demo_reference_finds_the_nearest_demo_and_scores_against_the_mean() {
    let (_, _, demos) = common::task("letters.toml");
    let test = &demos.demos[0];
    // Two references: the test path shifted by (0.3, 0.4) in every coordinate pair, and by
    // (0.6, 0.8): nearest RMSE √2·0.5 (two arms), mean-path RMSE √2·0.75.
    let shifted = |a: f64, b: f64| {
        let mut t = test.clone();
        for k in 0..t.len() {
            for arm in 0..2 {
                t.x[k * t.m + 2 * arm] += a;
                t.x[k * t.m + 2 * arm + 1] += b;
            }
        }
        t
    };
    let (r1, r2) = (shifted(0.3, 0.4), shifted(0.6, 0.8));
    let (nearest, mean) = crossym::eval::demo_reference(test, &[&r2, &r1]).unwrap();
    let s2 = std::f64::consts::SQRT_2;
    assert!((nearest - s2 * 0.5).abs() < 1e-12, "{nearest}");
    assert!((mean - s2 * 0.75).abs() < 1e-12, "{mean}");
    assert!(crossym::eval::demo_reference(test, &[]).is_none());
    // Per coordinate: the same error spread over the 4 coordinates, divided by √4.
    let sc = |rmse| crossym::eval::RolloutScore {
        rmse,
        diverged: false,
    };
    let cell = crossym::eval::Cell::from_scores(&[sc(nearest), sc(mean)]);
    let pc = cell.per_coordinate(test.m);
    assert!((pc.mean - cell.mean / 2.0).abs() < 1e-12 && (pc.std - cell.std / 2.0).abs() < 1e-12);
    assert_eq!((pc.count, pc.diverged), (2, 0));
    // Per coordinate equals numpy's sqrt(mean((a - b)**2)) over the T × m array.
    let flat: f64 = test
        .x
        .iter()
        .zip(&r1.x)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        / test.x.len() as f64;
    assert!((flat.sqrt() - nearest / 2.0).abs() < 1e-12);
}

#[test]
fn rollout_records_states_velocities_and_task_path() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let policy = small_policy(8, 1.0, 4);
    let s = Condition {
        theta: -0.4,
        scale: 0.6,
        reflection: 1,
    };
    let q0 = [0.78, -0.52, -0.39, -0.31, -0.78, 0.52, 0.39, 0.31];
    let r = rollout(&policy, kin, &q0, &s, 0.01, 50);
    let t = &r.traj;
    assert_eq!((t.len(), t.n, t.m, t.dt, t.demo), (50, 8, 4, 0.01, 0));
    assert_eq!(r.status, RolloutStatus::Finite);
    // The same Euler positions as the policy's own joint-space rollout.
    assert_eq!(t.q, policy.rollout(&q0, &s, 0.01, 49));
    let (mut ws, mut kws) = (policy.workspace(), kin.workspace());
    let mut v = [0.0; 8];
    for k in 0..50 {
        assert_eq!(t.x(k), kin.forward(t.q(k), &mut kws).as_slice());
        policy.velocity(t.q(k), &s, &mut v, &mut ws);
        let expect = if k + 1 < 50 { v } else { [0.0; 8] };
        assert_eq!(t.qdot(k), &expect);
    }
    // An overflowing policy: the state turns infinite within a few steps; the samples
    // before are finite, from there on everything is NaN.
    let wild = small_policy(8, 1e308, 5);
    let r = rollout(&wild, kin, &q0, &s, 0.01, 20);
    let RolloutStatus::NonFinite { sample } = r.status else {
        panic!("{:?}", r.status)
    };
    assert!((1..20).contains(&sample), "{sample}");
    let t = &r.traj;
    assert_eq!((t.q.len(), t.qdot.len(), t.x.len()), (160, 160, 80));
    assert_eq!(t.q(0), &q0);
    assert!(t.x[..sample * 4].iter().all(|v| v.is_finite()));
    assert!(t.x[sample * 4..].iter().all(|v| v.is_nan()));
    assert!(t.q[sample * 8..].iter().all(|v| v.is_nan()));
}

/// The Euclidean RMSE `crossym rollout` printed against the nominal.
fn reported_rmse(text: &str) -> f64 {
    text.split("RMSE against the nominal over ")
        .nth(1)
        .and_then(|t| t.split(": ").nth(1))
        .and_then(|t| t.split(' ').next())
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("no RMSE in {text}"))
}

#[test]
fn rollout_cli_writes_the_library_rollout_and_scores_it_as_eval() {
    let dir = common::temp_dir("rollout");
    let csv = dir.join("r.csv");
    let png = dir.join("r.png");
    let config = common::path("config/letters.toml");
    let text = common::run_ok(
        common::crossym([
            "rollout",
            "--demo",
            "6",
            "--condition",
            "0.5235987755982988:0.8:-1",
        ])
        .arg("--config")
        .arg(&config)
        .arg("--policy")
        .arg(common::path("data/policies/pi_mrt_planar.safetensors"))
        .arg("--out")
        .arg(&csv)
        .arg("--plot")
        .arg(&png),
    );
    // The figure explains itself: read back by an independent PNG decoder (Python's
    // standard library), the title strip, the legend strip, the panel caption and the axis
    // names at the bottom carry text (dark pixels), not only the paths.
    let ink = std::process::Command::new("python3")
        .arg(common::path("tests/tools/png_ink.py"))
        .arg(&png)
        .args(["0:38", "38:64", "64:90", "670:704"])
        .output()
        .expect("python3");
    assert!(
        ink.status.success(),
        "{}",
        String::from_utf8_lossy(&ink.stderr)
    );
    let ink = String::from_utf8(ink.stdout).unwrap();
    let mut lines = ink.lines();
    assert_eq!(lines.next(), Some("640 704"), "figure size");
    for (band, n) in ["title", "legend", "caption", "x-axis name"]
        .iter()
        .zip(lines)
    {
        let n: usize = n.parse().unwrap();
        assert!(
            n > 100,
            "{band}: {n} dark pixels, no text in {}",
            png.display()
        );
    }
    // What eval computes for the same nominal trajectory and the shipped policy.
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let s = Condition {
        theta: 0.5235987755982988,
        scale: 0.8,
        reflection: -1,
    };
    let demo = demos.demos.iter().find(|d| d.demo == 6).unwrap();
    let nominal = nominal_trajectories(&cfg, kin, demo, &[s])
        .unwrap()
        .remove(0)
        .traj;
    let policy = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let expect = score(&policy, kin, &nominal, &s, &cfg.eval);
    let reported = reported_rmse(&text);
    assert!(
        (reported - expect.rmse).abs() < 1e-4,
        "{reported} vs {expect:?}"
    );
    let r = rollout(&policy, kin, nominal.q(0), &s, nominal.dt, nominal.len()).traj;
    let body = std::fs::read_to_string(&csv).unwrap();
    let mut lines = body.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    assert_eq!(header.len(), 1 + 8 + 8 + 4 + 4);
    assert_eq!((header[1], header[24]), ("q_left_joint1", "x3_nominal"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), nominal.len());
    for (k, row) in rows.iter().enumerate() {
        assert!((row[0] - k as f64 * nominal.dt).abs() < 1e-9);
        assert_eq!(&row[1..9], r.q(k));
        assert_eq!(&row[9..17], r.qdot(k));
        assert_eq!(&row[17..21], r.x(k));
        assert_eq!(&row[21..25], nominal.x(k));
    }
    // Bad input: a clear message and exit code 2, nothing written.
    for (args, message) in [
        (
            vec!["--q", "0.1,0.2"],
            "--q has 2 values, the robot has 8 joints",
        ),
        (vec!["--demo", "99"], "no demonstration 99"),
        (vec!["--condition", "0:nan:1"], "scale"),
        (
            vec!["--condition", "0:1"],
            "expected theta_rad:scale:reflection",
        ),
        (vec!["--dt", "-1"], "--dt -1 must be positive"),
    ] {
        let bad = dir.join("bad.csv");
        let out = common::crossym(["rollout"])
            .args(&args)
            .arg("--config")
            .arg(&config)
            .arg("--out")
            .arg(&bad)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(message), "{args:?}: {err}");
        assert!(!bad.exists(), "{args:?}");
    }
}

/// `crossym rollout --dt` finer than the demonstration's step integrates over the
/// demonstration's *time* length and scores against the nominal at the same times: the
/// nominal column is the demonstration interpolated in time (checked here from the
/// nominal samples), the reported RMSE is the one of the CSV's own columns (recomputed
/// here) and close to the one at the demonstration's step (a rollout compared index by
/// index against the 0.01 s samples would report 1.4 and "DIVERGED").
#[test]
fn rollout_at_another_step_is_scored_by_time() {
    let dir = common::temp_dir("rollout-dt");
    let csv = dir.join("r.csv");
    let config = common::path("config/letters.toml");
    let text = common::run_ok(
        common::crossym([
            "rollout",
            "--demo",
            "6",
            "--condition",
            "0:1:1",
            "--dt",
            "0.002",
        ])
        .arg("--config")
        .arg(&config)
        .arg("--policy")
        .arg(common::path("data/policies/pi_mrt_planar.safetensors"))
        .arg("--out")
        .arg(&csv),
    );
    assert!(!text.contains("DIVERGED"), "{text}");
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let nominal = demos.demos.iter().find(|d| d.demo == 6).unwrap();
    let body = std::fs::read_to_string(&csv).unwrap();
    let rows: Vec<Vec<f64>> = body
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    // 5 steps of 0.002 s per 0.01 s sample: (len − 1) · 5 + 1 rows, the last at the
    // demonstration's end time.
    assert_eq!(nominal.dt, 0.01);
    assert_eq!(rows.len(), (nominal.len() - 1) * 5 + 1);
    let end = (nominal.len() - 1) as f64 * 0.01;
    assert!((rows.last().unwrap()[0] - end).abs() < 1e-9);
    let mut sum = 0.0;
    for (k, row) in rows.iter().enumerate() {
        // Sample j and the next one, weight (k mod 5) / 5.
        let (j, w) = (k / 5, (k % 5) as f64 / 5.0);
        let (a, b) = (nominal.x(j), nominal.x((j + 1).min(nominal.len() - 1)));
        for i in 0..4 {
            let expect = a[i] + w * (b[i] - a[i]);
            assert!((row[21 + i] - expect).abs() < 1e-9, "row {k} x{i}");
            sum += (row[17 + i] - row[21 + i]).powi(2);
        }
    }
    let rmse = (sum / rows.len() as f64).sqrt();
    let reported = reported_rmse(&text);
    assert!((reported - rmse).abs() < 1e-3, "{reported} vs {rmse}");
    // At the demonstration's own step (the library's eval), within 5 %.
    let policy = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let at_step = score(&policy, kin, nominal, &Condition::IDENTITY, &cfg.eval).rmse;
    assert!(
        (rmse - at_step).abs() < 0.05 * at_step,
        "{rmse} at 0.002 s vs {at_step} at 0.01 s"
    );
}

/// `pipeline::paper::table2_paper` on a small grid (training {identity, (90°, 0.5, −1)},
/// test {identity, (45°, 0.7, 1)}): the pool is the training and test trajectories
/// together (counts per nested set), and the Original cell equals the protocol recomputed
/// here from plain rollouts: every identity trajectory (5 training + 2 test) rolled out
/// from sample 60 for `min(len) − 60` samples, `√(mean of the per-trajectory MSEs)` and the
/// population std of those MSEs.
#[test]
fn paper_protocol_table_pools_train_and_test_and_matches_a_recomputation() {
    use crossym::policy::GroupGrid;
    let (mut cfg, robot, _) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let grid = |c: Vec<[f64; 3]>| GroupGrid {
        conditions: Some(c),
        ..GroupGrid::identity()
    };
    let aug = cfg.augmentation.as_mut().unwrap();
    aug.train = grid(vec![[0.0, 1.0, 1.0], [90.0, 0.5, -1.0]]);
    aug.test = grid(vec![[0.0, 1.0, 1.0], [45.0, 0.7, 1.0]]);
    let p = crossym::pipeline::build(&cfg, kin, crossym::pipeline::paper::splits(&cfg), &|_| {})
        .unwrap();
    assert_eq!(
        (p.train.trajectories.len(), p.test.trajectories.len()),
        (10, 4)
    );
    let policy = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let dir = common::temp_dir("paper-protocol");
    let mut rows = Vec::new();
    let files = crossym::pipeline::paper::table2_paper(
        &cfg,
        kin,
        &[("pi_MRT".into(), policy.clone())],
        &p,
        &dir,
        |r| rows.push(r.to_string()),
    )
    .unwrap();
    let md = std::fs::read_to_string(&files.markdown).unwrap();
    assert!(
        md.contains("| Policy | Original (7) | G_R (7) | G_RT (9) | G_MRT (14) |"),
        "{md}"
    );
    assert_eq!(rows.len(), 1);
    let csv = std::fs::read_to_string(&files.csv).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "policy,test_set,value,std,std_of,count,diverged");
    assert_eq!(lines.len(), 5);
    let original: Vec<&str> = lines[1].split(',').collect();
    assert_eq!(&original[..2], &["pi_MRT", "Original"]);
    assert_eq!((original[4], original[5]), ("std_mse", "7"));
    // Independent recomputation of the Original cell.
    let all: Vec<_> = p
        .train
        .trajectories
        .iter()
        .chain(&p.test.trajectories)
        .collect();
    let horizon = all.iter().map(|a| a.traj.len()).min().unwrap() - 60;
    let mses: Vec<f64> = all
        .iter()
        .filter(|a| a.condition == Condition::IDENTITY)
        .map(|a| {
            let t = &a.traj;
            let mut q = t.q(60).to_vec();
            let mut v = vec![0.0; 8];
            let mut ws = policy.workspace();
            let mut kws = kin.workspace();
            let mut sum = 0.0;
            for k in 0..horizon {
                let x = kin.forward(&q, &mut kws);
                for i in 0..4 {
                    sum += (x[i] - t.x(60 + k)[i]).powi(2);
                }
                policy.velocity(&q, &Condition::IDENTITY, &mut v, &mut ws);
                for j in 0..8 {
                    q[j] += t.dt * v[j];
                }
            }
            sum / (horizon * 4) as f64
        })
        .collect();
    assert_eq!(mses.len(), 7);
    let mean = mses.iter().sum::<f64>() / 7.0;
    let std = (mses.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / 7.0).sqrt();
    let value: f64 = original[2].parse().unwrap();
    let reported_std: f64 = original[3].parse().unwrap();
    assert!(
        (value - mean.sqrt()).abs() < 1e-9,
        "{value} vs {}",
        mean.sqrt()
    );
    assert!((reported_std - std).abs() < 1e-9, "{reported_std} vs {std}");
}

/// `pipeline::fit::write_fit`: a row per training and test demonstration, each value the
/// RMSE per coordinate of the policy rolled out from that demonstration's first
/// configuration under the identity condition — recomputed here from a plain Euler loop
/// over the demonstration's samples.
#[test]
fn fit_table_scores_every_demonstration_against_itself() {
    let (cfg, robot, demos) = common::task("letters.toml");
    let kin = &robot.kinematics;
    let policy = Policy::load(common::path("data/policies/pi_mrt_planar.safetensors")).unwrap();
    let dir = common::temp_dir("fit");
    let mut rows = Vec::new();
    let files = crossym::pipeline::fit::write_fit(
        &cfg,
        kin,
        &demos,
        &[("pi_MRT".to_string(), policy.clone())],
        &dir,
        |r| rows.push(r.to_string()),
    )
    .unwrap();
    assert_eq!(rows.len(), 1);
    let md = std::fs::read_to_string(&files.markdown).unwrap();
    assert!(md.starts_with("| Policy | train #1 |"), "{md}");
    let csv = std::fs::read_to_string(&files.csv).unwrap();
    let lines: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let picked: Vec<(String, usize)> = demos
        .train
        .iter()
        .map(|&d| ("train".to_string(), d))
        .chain(demos.test.iter().map(|&d| ("test".to_string(), d)))
        .collect();
    assert_eq!(lines.len(), picked.len());
    for (line, (split, demo)) in lines.iter().zip(&picked) {
        assert_eq!((line[0], line[1]), ("pi_MRT", split.as_str()));
        assert_eq!(line[2].parse::<usize>().unwrap(), *demo);
        // Independent recomputation: Euler at the demonstration's step, sample by sample.
        let t = &demos.demos[demo - 1];
        let mut q = t.q(0).to_vec();
        let (mut v, mut ws, mut kws) = (vec![0.0; 8], policy.workspace(), kin.workspace());
        let mut sum = 0.0;
        for k in 0..t.len() {
            let x = kin.forward(&q, &mut kws);
            for i in 0..4 {
                sum += (x[i] - t.x(k)[i]).powi(2);
            }
            policy.velocity(&q, &Condition::IDENTITY, &mut v, &mut ws);
            for j in 0..8 {
                q[j] += t.dt * v[j];
            }
        }
        let rmse = (sum / (t.len() * 4) as f64).sqrt();
        let reported: f64 = line[4].parse().unwrap();
        assert!(
            (reported - rmse).abs() < 1e-9,
            "demo {demo}: {reported} vs {rmse}"
        );
        assert_eq!(line[5], "false");
    }
}
