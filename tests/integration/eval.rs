//! Evaluation (Table II machinery): a policy scored on its own rollout has zero RMSE, a
//! wrong condition does not, and a runaway policy is counted as diverged.

use crossym::data::letters::JointTrajectory;
use crossym::eval::{evaluate, score, EvalConfig};
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
