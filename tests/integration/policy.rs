//! The symmetry-conditioned policy: inference vs candle, CONDOR-style training on a
//! synthetic condition-dependent linear system, reproducibility, save/load and its errors.

use std::f64::consts::FRAC_PI_2;
use std::path::PathBuf;
use std::sync::OnceLock;

use crossym::policy::JointTrajectory;
use crossym::policy::{
    sidecar_path, LrSchedule, MlpSpec, Policy, PolicyError, PolicyMeta, TrainConfig,
};
use crossym::symmetry::compose::Condition;
use crossym::train::{train, CandleMlp, TrainReport};
use rand::Rng;

use crate::common::rng;

const DT: f64 = 0.01;
const LEN: usize = 200;
const RATE: f64 = 1.5;

/// Goal of the synthetic system: `g(s) = λ R(θ) [σ 0.5, 0.3]` padded with zeros to `n`.
fn goal(s: &Condition, n: usize) -> Vec<f64> {
    let (x, y) = (0.5 * f64::from(s.reflection), 0.3);
    let (c, si) = (s.theta.cos(), s.theta.sin());
    let mut g = vec![0.0; n];
    g[0] = s.scale * (c * x - si * y);
    g[1] = s.scale * (si * x + c * y);
    g
}

/// `q̇ = −k (q − g(s))` sampled exactly from `q0`: `q(t) = g + (q0 − g) e^{−kt}`.
fn demo(q0: &[f64], s: &Condition, demo: usize) -> JointTrajectory {
    let n = q0.len();
    let g = goal(s, n);
    let (mut q, mut qdot) = (Vec::new(), Vec::new());
    for i in 0..LEN {
        let e = (-RATE * i as f64 * DT).exp();
        for j in 0..n {
            let qj = g[j] + (q0[j] - g[j]) * e;
            q.push(qj);
            qdot.push(-RATE * (qj - g[j]));
        }
    }
    let x = q.clone();
    JointTrajectory {
        demo,
        n,
        m: n,
        dt: DT,
        q,
        qdot,
        x,
    }
}

/// 12 conditions × 2 starts of the 2-D system.
fn dataset() -> Vec<(JointTrajectory, Condition)> {
    let mut out = Vec::new();
    let starts = [[-0.8, -0.6], [0.7, -0.9]];
    for theta in [-FRAC_PI_2, 0.0, FRAC_PI_2] {
        for scale in [0.6, 1.0] {
            for reflection in [1, -1] {
                let s = Condition {
                    theta,
                    scale,
                    reflection,
                };
                for (k, q0) in starts.iter().enumerate() {
                    out.push((demo(q0, &s, k + 1), s));
                }
            }
        }
    }
    out
}

fn small_config(iterations: usize, seed: u64) -> TrainConfig {
    TrainConfig {
        hidden: vec![16, 16],
        horizon: 6,
        velocity_weight: 1.0,
        learning_rate: 1e-2,
        lr_schedule: LrSchedule::Cosine {
            final_learning_rate: 1e-4,
        },
        iterations,
        batch_size: 32,
        seed,
        log_every: 40,
        ..TrainConfig::default()
    }
}

fn meta() -> PolicyMeta {
    PolicyMeta::new(
        "synthetic",
        vec!["j0".into(), "j1".into()],
        serde_json::json!({ "group": "SO(2) x S x C2", "test": true }),
    )
}

/// A trained policy, its report and the progress log `(iteration, loss)`.
type Run = (Policy, TrainReport, Vec<(usize, f64)>);

fn run(config: &TrainConfig) -> Run {
    let data = dataset();
    let pairs: Vec<(&JointTrajectory, Condition)> = data.iter().map(|(t, s)| (t, *s)).collect();
    let mut log = Vec::new();
    let (p, r) = train(&pairs, config, meta(), |k, l| log.push((k, l))).expect("training runs");
    (p, r, log)
}

/// The policy trained once for 120 iterations (shared by several tests).
fn trained() -> &'static Run {
    static T: OnceLock<Run> = OnceLock::new();
    T.get_or_init(|| run(&small_config(120, 7)))
}

/// RMSE (rad) of the policy's Euler rollout against a demonstration.
fn rollout_rmse(p: &Policy, t: &JointTrajectory, s: &Condition) -> f64 {
    let r = p.rollout(t.q(0), s, t.dt, t.len() - 1);
    let se: f64 = r.iter().zip(&t.q).map(|(a, b)| (a - b).powi(2)).sum();
    (se / r.len() as f64).sqrt()
}

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("crossym-policy-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

#[test]
fn inference_matches_candle_forward() {
    let mut r = rng(11);
    for (hidden, seed) in [(vec![32, 16, 24], 3), (vec![], 4), (vec![256, 256], 5)] {
        let spec = MlpSpec {
            input: 8,
            hidden,
            output: 4,
            activation: Default::default(),
        };
        let net = CandleMlp::init(&spec, seed).unwrap();
        let inf = net.to_inference().unwrap();
        let rows = 64;
        let x: Vec<f64> = (0..rows * spec.input)
            .map(|_| r.random_range(-2.0..2.0))
            .collect();
        // Inputs exactly representable in f32, so both sides see the same numbers.
        let x: Vec<f64> = x.iter().map(|&v| f64::from(v as f32)).collect();
        let reference = net.forward_rows(&x, rows).unwrap();
        let mut ws = inf.workspace();
        let mut out = vec![0.0; spec.output];
        let mut worst = 0.0f64;
        for i in 0..rows {
            inf.forward(&x[i * spec.input..(i + 1) * spec.input], &mut out, &mut ws);
            for j in 0..spec.output {
                worst = worst.max((out[j] - reference[i * spec.output + j]).abs());
            }
        }
        assert!(
            worst <= 1e-5,
            "hidden {:?}: max |Δ| = {worst:e}",
            spec.hidden
        );
    }
}

#[test]
fn training_reduces_loss_and_tracks_demos() {
    let (policy, report, log) = trained();
    eprintln!("{report:?}");
    assert_eq!(report.iterations, 120);
    assert!(report.final_loss.is_finite());
    assert!(
        report.final_loss < 0.5 * report.initial_loss,
        "loss {} → {}",
        report.initial_loss,
        report.final_loss
    );
    // Progress every 40 iterations, the last one at 120.
    let iters: Vec<usize> = log.iter().map(|(k, _)| *k).collect();
    assert_eq!(iters, vec![40, 80, 120]);
    assert_eq!(report.windows, 24 * (LEN - 6));
    assert_eq!(report.skipped_short, 0);
    assert_eq!(policy.meta.train_config, Some(small_config(120, 7)));

    let (untrained, _, _) = run(&small_config(0, 7));
    let data = dataset();
    let (mut e_trained, mut e_untrained) = (0.0, 0.0);
    for (t, s) in &data {
        e_trained += rollout_rmse(policy, t, s);
        e_untrained += rollout_rmse(&untrained, t, s);
    }
    let (e_trained, e_untrained) = (e_trained / 24.0, e_untrained / 24.0);
    eprintln!("mean rollout RMSE: trained {e_trained:.4} rad, untrained {e_untrained:.4} rad");
    assert!(
        3.0 * e_trained < e_untrained,
        "trained {e_trained} vs untrained {e_untrained}"
    );
}

#[test]
fn training_is_reproducible() {
    let (a, ra, la) = run(&small_config(30, 99));
    let (b, rb, lb) = run(&small_config(30, 99));
    assert_eq!(
        a.mlp(),
        b.mlp(),
        "same seed must give bit-identical weights"
    );
    assert_eq!(a.normalizer(), b.normalizer());
    assert_eq!(ra.final_loss.to_bits(), rb.final_loss.to_bits());
    assert_eq!(la, lb);
    let (c, _, _) = run(&small_config(30, 100));
    assert_ne!(a.mlp(), c.mlp(), "another seed gives other weights");
}

#[test]
fn save_load_round_trip() {
    let (policy, _, _) = trained();
    let path = tmp("roundtrip.safetensors");
    policy.save(&path).unwrap();
    assert!(sidecar_path(&path).exists());
    let back = Policy::load(&path).unwrap();
    assert_eq!(&back, policy);
    // The sidecar path works too.
    assert_eq!(&Policy::load(sidecar_path(&path)).unwrap(), policy);
    let s = Condition {
        theta: 0.3,
        scale: 0.8,
        reflection: -1,
    };
    let (mut wa, mut wb) = (policy.workspace(), back.workspace());
    let (mut va, mut vb) = ([0.0; 2], [0.0; 2]);
    let mut r = rng(5);
    for _ in 0..100 {
        let q = [r.random_range(-1.0..1.0), r.random_range(-1.0..1.0)];
        policy.velocity(&q, &s, &mut va, &mut wa);
        back.velocity(&q, &s, &mut vb, &mut wb);
        assert_eq!(va.map(f64::to_bits), vb.map(f64::to_bits));
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(sidecar_path(&path)).unwrap()).unwrap();
    assert_eq!(json["format_version"], 1);
    assert_eq!(json["mlp"]["hidden"], serde_json::json!([16, 16]));
    assert_eq!(json["robot"], "synthetic");
    assert_eq!(json["crate_version"], env!("CARGO_PKG_VERSION"));
    assert_eq!(json["train_config"]["horizon"], 6);
}

/// Saves the trained policy under `name` and returns the weights path.
fn saved(name: &str) -> PathBuf {
    let path = tmp(name);
    trained().0.save(&path).unwrap();
    path
}

fn edit_sidecar(path: &std::path::Path, f: impl FnOnce(&mut serde_json::Value)) {
    let side = sidecar_path(path);
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&side).unwrap()).unwrap();
    f(&mut v);
    std::fs::write(&side, serde_json::to_string(&v).unwrap()).unwrap();
}

#[test]
fn corrupt_files_give_clear_errors() {
    // Missing file.
    let missing = tmp("absent.safetensors");
    let e = Policy::load(&missing).unwrap_err();
    assert!(matches!(e, PolicyError::Io { .. }), "{e}");
    assert!(e.to_string().contains("absent.json"), "{e}");

    // Truncated weights.
    let p = saved("truncated.safetensors");
    let bytes = std::fs::read(&p).unwrap();
    std::fs::write(&p, &bytes[..bytes.len() / 2]).unwrap();
    let e = Policy::load(&p).unwrap_err();
    assert!(matches!(e, PolicyError::Weights { .. }), "{e}");
    assert!(e.to_string().contains("truncated.safetensors"), "{e}");

    // Sidecar layer sizes that disagree with the tensors.
    let p = saved("layers.safetensors");
    edit_sidecar(&p, |v| v["mlp"]["hidden"] = serde_json::json!([16, 8]));
    let e = Policy::load(&p).unwrap_err();
    match &e {
        PolicyError::Shape { tensor, .. } => assert_eq!(tensor, "layers.1.weight"),
        other => panic!("expected a shape error, got {other}"),
    }
    assert!(e.to_string().contains("[8, 16]"), "{e}");

    // One layer more in the sidecar than in the file.
    let p = saved("extra_layer.safetensors");
    edit_sidecar(&p, |v| v["mlp"]["hidden"] = serde_json::json!([16, 16, 16]));
    let e = Policy::load(&p).unwrap_err();
    assert!(
        matches!(
            e,
            PolicyError::Shape { .. } | PolicyError::MissingTensor { .. }
        ),
        "{e}"
    );

    // Layer sizes that do not fit n.
    let p = saved("io_width.safetensors");
    edit_sidecar(&p, |v| v["mlp"]["input"] = serde_json::json!(5));
    let e = Policy::load(&p).unwrap_err();
    match &e {
        PolicyError::Invalid { field, .. } => assert_eq!(field, "mlp"),
        other => panic!("expected an invalid-field error, got {other}"),
    }

    // Unsupported format version.
    let p = saved("version.safetensors");
    edit_sidecar(&p, |v| v["format_version"] = serde_json::json!(2));
    let e = Policy::load(&p).unwrap_err();
    assert!(
        matches!(
            e,
            PolicyError::Version {
                found: 2,
                supported: 1,
                ..
            }
        ),
        "{e}"
    );

    // Non-positive normaliser scale.
    let p = saved("normalizer.safetensors");
    edit_sidecar(&p, |v| v["normalizer"]["q_std"][1] = serde_json::json!(0.0));
    let e = Policy::load(&p).unwrap_err();
    assert!(
        matches!(&e, PolicyError::Invalid { field, .. } if field == "normalizer"),
        "{e}"
    );

    // Malformed JSON.
    let p = saved("json.safetensors");
    std::fs::write(sidecar_path(&p), "{ not json").unwrap();
    let e = Policy::load(&p).unwrap_err();
    assert!(matches!(e, PolicyError::Sidecar { .. }), "{e}");

    // NaN weight: rewrite the file with one NaN in layers.0.weight.
    let p = saved("nan.safetensors");
    let bytes = std::fs::read(&p).unwrap();
    let st = safetensors::SafeTensors::deserialize(&bytes).unwrap();
    let owned: Vec<(String, safetensors::Dtype, Vec<usize>, Vec<u8>)> = st
        .tensors()
        .into_iter()
        .map(|(n, t)| (n, t.dtype(), t.shape().to_vec(), t.data().to_vec()))
        .collect();
    let mut owned = owned;
    for (name, _, _, data) in owned.iter_mut() {
        if name == "layers.0.weight" {
            data[8 * 3..8 * 4].copy_from_slice(&f64::NAN.to_le_bytes());
        }
    }
    let views: Vec<(String, safetensors::tensor::TensorView<'_>)> = owned
        .iter()
        .map(|(n, d, s, b)| {
            (
                n.clone(),
                safetensors::tensor::TensorView::new(*d, s.clone(), b).unwrap(),
            )
        })
        .collect();
    std::fs::write(&p, safetensors::serialize(views, None).unwrap()).unwrap();
    let e = Policy::load(&p).unwrap_err();
    match &e {
        PolicyError::NonFinite { tensor, index, .. } => {
            assert_eq!((tensor.as_str(), *index), ("layers.0.weight", 3))
        }
        other => panic!("expected a non-finite error, got {other}"),
    }
    assert!(e.to_string().contains("nan.safetensors"), "{e}");
}

#[test]
fn training_rejects_bad_setup() {
    let data = dataset();
    let pairs: Vec<(&JointTrajectory, Condition)> = data.iter().map(|(t, s)| (t, *s)).collect();
    let e = train(&[], &small_config(1, 0), meta(), |_, _| {}).unwrap_err();
    assert!(matches!(e, PolicyError::Data { .. }), "{e}");
    let mut c = small_config(1, 0);
    c.horizon = LEN;
    let e = train(&pairs, &c, meta(), |_, _| {}).unwrap_err();
    assert!(matches!(e, PolicyError::Data { .. }), "{e}");
    let mut c = small_config(1, 0);
    c.learning_rate = -1.0;
    let e = train(&pairs, &c, meta(), |_, _| {}).unwrap_err();
    assert!(
        matches!(&e, PolicyError::Config { field, .. } if field == "learning_rate"),
        "{e}"
    );
    let mut bad = pairs.clone();
    bad[0].1.scale = 0.0;
    let e = train(&bad, &small_config(1, 0), meta(), |_, _| {}).unwrap_err();
    assert!(e.to_string().contains("scale"), "{e}");
    // Joint names must match n.
    let mut m = meta();
    m.joint_names.push("extra".into());
    let e = train(&pairs, &small_config(1, 0), m, |_, _| {}).unwrap_err();
    assert!(
        matches!(&e, PolicyError::Invalid { field, .. } if field == "joint_names"),
        "{e}"
    );
}

#[test]
fn strided_noisy_curriculum_training_learns() {
    // Strided windows padded at the end, start-state noise and a horizon curriculum: the
    // rollout-only loss (no velocity term) still drops and the rollouts beat an untrained net.
    let config = TrainConfig {
        stride: 4,
        pad_end: true,
        horizon_start: 2,
        curriculum_fraction: 0.5,
        start_noise: 0.02,
        velocity_weight: 0.0,
        weight_decay: 1e-6,
        ..small_config(120, 7)
    };
    assert_eq!(config.horizon_at(0), 2);
    assert_eq!(config.horizon_at(60), 6);
    assert_eq!(config.horizon_at(119), 6);
    let (policy, report, _) = run(&config);
    eprintln!("{report:?}");
    // Every sample but the last starts a window when windows are padded.
    assert_eq!(report.windows, 24 * (LEN - 1));
    assert!(
        report.final_loss < 0.5 * report.initial_loss,
        "loss {} → {}",
        report.initial_loss,
        report.final_loss
    );
    let (untrained, _, _) = run(&TrainConfig {
        iterations: 0,
        ..config.clone()
    });
    let data = dataset();
    let (mut e_trained, mut e_untrained) = (0.0, 0.0);
    for (t, s) in &data {
        e_trained += rollout_rmse(&policy, t, s);
        e_untrained += rollout_rmse(&untrained, t, s);
    }
    assert!(
        3.0 * e_trained < e_untrained,
        "trained {e_trained} vs untrained {e_untrained}"
    );
    // Same configuration, same weights (the noise has its own seeded stream).
    let (again, _, _) = run(&config);
    assert_eq!(policy.mlp(), again.mlp());
    // Without padding, a window of horizon × stride samples must fit in every demo.
    let mut c = config.clone();
    c.pad_end = false;
    c.stride = LEN;
    let data = dataset();
    let pairs: Vec<(&JointTrajectory, Condition)> = data.iter().map(|(t, s)| (t, *s)).collect();
    let e = train(&pairs, &c, meta(), |_, _| {}).unwrap_err();
    assert!(matches!(e, PolicyError::Data { .. }), "{e}");
}

#[test]
fn train_config_rejects_bad_recipe_fields() {
    let base = small_config(1, 0);
    for (field, c) in [
        (
            "stride",
            TrainConfig {
                stride: 0,
                ..base.clone()
            },
        ),
        (
            "horizon_start",
            TrainConfig {
                horizon_start: 7,
                ..base.clone()
            },
        ),
        (
            "curriculum_fraction",
            TrainConfig {
                curriculum_fraction: 1.5,
                ..base.clone()
            },
        ),
        (
            "start_noise",
            TrainConfig {
                start_noise: -0.1,
                ..base.clone()
            },
        ),
        (
            "weight_decay",
            TrainConfig {
                weight_decay: f64::NAN,
                ..base.clone()
            },
        ),
    ] {
        let e = c.validate().unwrap_err();
        assert!(
            matches!(&e, PolicyError::Config { field: f, .. } if f == field),
            "{field}: {e}"
        );
    }
}

#[test]
fn train_config_toml_defaults_and_unknown_fields() {
    let c: TrainConfig = toml::from_str("horizon = 12\nseed = 3").unwrap();
    assert_eq!(c.horizon, 12);
    assert_eq!(c.hidden, vec![256, 256, 256]);
    assert_eq!(c.batch_size, 256);
    let c: TrainConfig =
        toml::from_str("lr_schedule = { kind = \"constant\" }\niterations = 5").unwrap();
    assert_eq!(c.lr_schedule, LrSchedule::Constant);
    assert!(toml::from_str::<TrainConfig>("horizn = 12").is_err());
}

#[test]
fn shipped_policy_loads_for_the_planar_robot() {
    let path = crate::common::path("data/policies/pi_mrt_planar.safetensors");
    let policy = crossym::policy::Policy::load(&path).expect("shipped policy loads");
    let robot = crate::common::planar();
    assert_eq!(policy.meta.joint_names, robot.kinematics.joint_names());
    assert_eq!(policy.meta.robot, "planar_dual_arm");
    let q0 = [0.785, -0.524, -0.393, -0.314, -0.785, 0.524, 0.393, 0.314];
    let mut ws = policy.workspace();
    let mut v = [0.0; 8];
    for s in [
        Condition::IDENTITY,
        Condition {
            theta: 1.0,
            scale: 0.6,
            reflection: -1,
        },
    ] {
        policy.velocity(&q0, &s, &mut v, &mut ws);
        assert!(
            v.iter().all(|x| x.is_finite()) && v.iter().any(|x| x.abs() > 1e-6),
            "{v:?}"
        );
    }
}

#[test]
fn train_cli_writes_weights_sidecar_and_loss_log() {
    // `crossym train` end to end on a tiny letter recipe: one demonstration, a coarse grid.
    let dir = crate::common::temp_dir("train-cli");
    let root = crate::common::path("");
    let text = std::fs::read_to_string(crate::common::path("config/letters.toml"))
        .unwrap()
        .replace("\"../", &format!("\"{}/", root.display()))
        .replace("train = [1, 2, 3, 4, 5]", "train = [1]")
        .replace(
            "train = { rotation_step_deg = 30.0,",
            "train = { rotation_step_deg = 180.0,",
        )
        .replace("hidden = [128, 128, 128]", "hidden = [16]")
        .replace("batch_size = 256", "batch_size = 8")
        .lines()
        .map(|l| {
            if l.starts_with("iterations = ") {
                "iterations = 30"
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let config = dir.join("tiny.toml");
    std::fs::write(&config, text).unwrap();
    let out_path = dir.join("p.safetensors");
    let stdout = crate::common::run_ok(
        crate::common::crossym(["train", "--group", "RT", "--config"])
            .arg(&config)
            .arg("--out")
            .arg(&out_path),
    );
    assert!(stdout.contains("iteration 30/30: loss"), "{stdout}");
    let policy = Policy::load(&out_path).unwrap();
    assert!(sidecar_path(&out_path).exists());
    let tc = policy.meta.train_config.clone().unwrap();
    assert_eq!((tc.iterations, tc.hidden.clone()), (30, vec![16]));
    // The shipped recipe reads the canonical task point, restricted to G_RT (no reflection).
    assert!(tc.task_features);
    let map = &policy.task_features().expect("task features").spec().map;
    assert!(map.rotation.is_some() && map.scaling.is_some() && map.reflection.is_none());
    // The loss log: every `log_every` iterations, with the schedule's learning rate.
    let log = std::fs::read_to_string(dir.join("p.loss.csv")).unwrap();
    let mut lines = log.lines();
    assert_eq!(lines.next(), Some("iteration,loss,learning_rate"));
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(
        rows.iter().map(|r| r[0] as usize).collect::<Vec<_>>(),
        vec![10, 20, 30]
    );
    for r in &rows {
        assert!(r[1].is_finite() && r[1] > 0.0, "{r:?}");
        let lr = tc.lr_schedule.at(tc.learning_rate, r[0] as usize - 1, 30);
        assert!((r[2] - lr).abs() <= 1e-12 * lr, "{r:?} vs {lr}");
    }
    // The trained policy rolls out through the CLI.
    crate::common::run_ok(
        crate::common::crossym(["rollout", "--demo", "1", "--duration-s", "1", "--config"])
            .arg(&config)
            .arg("--policy")
            .arg(&out_path)
            .arg("--out")
            .arg(dir.join("r.csv")),
    );
    let csv = std::fs::read_to_string(dir.join("r.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 101);
}
