//! Lifting one configuration by θ = 30° (the lifted SO(2) flow, eq. 18) on the planar dual
//! arm and on RB-Y1, with and without the velocity differential, and one `crossym check`
//! of the letter task; the whole-body morphological group of real robots' URDFs (PyPI
//! `example-robot-data`, skipped when absent) against the two-chain derivation on RB-Y1.
//! Run: `cargo bench --bench symmetry`.

#[path = "../tests/support/skip.rs"]
mod skip;

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{criterion_group, criterion_main, Criterion};
use crossym::config::Config;
use crossym::symmetry::lie::{AffineAction, LieGroupSpec};
use crossym::symmetry::transfer::flow::FlowSettings;
use crossym::symmetry::transfer::lift::LiftedAction;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn bench_lift(c: &mut Criterion) {
    let mut g = c.benchmark_group("lift30");
    g.measurement_time(std::time::Duration::from_secs(3))
        .warm_up_time(std::time::Duration::from_secs(1))
        .sample_size(50);
    let theta = std::f64::consts::FRAC_PI_6;
    // Planar dual arm at the letter task's rest posture.
    let cfg = Config::from_file(root().join("config/letters.toml")).unwrap();
    let robot = cfg.load_robot().unwrap();
    let kin = &robot.kinematics;
    let r = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 2, None).unwrap();
    let q = cfg.check.reference_q.clone().unwrap();
    for (label, settings) in [
        ("planar_dual8/rtol1e-10", FlowSettings::default()),
        (
            "planar_dual8/rtol1e-8",
            FlowSettings {
                rtol: 1e-8,
                atol: 1e-10,
                ..Default::default()
            },
        ),
    ] {
        let lifted = LiftedAction::new(kin, &r, settings).unwrap();
        let mut ws = lifted.workspace();
        let mut out = vec![0.0; q.len()];
        let mut vout = vec![0.0; q.len()];
        let v = vec![0.1; q.len()];
        g.bench_function(format!("{label}/position"), |b| {
            b.iter(|| {
                lifted
                    .act(black_box(&[theta]), black_box(&q), &mut out, &mut ws)
                    .unwrap()
            })
        });
        g.bench_function(format!("{label}/with_differential"), |b| {
            b.iter(|| {
                lifted
                    .act_with_differential(
                        black_box(&[theta]),
                        black_box(&q),
                        &v,
                        &mut out,
                        &mut vout,
                        &mut ws,
                    )
                    .unwrap()
            })
        });
    }
    // RB-Y1 (the vendor URDF in robots/rby1a; skipped when absent).
    let rcfg = root().join("config/rby1.toml");
    if root().join("robots/rby1a/model.urdf").exists() {
        let cfg = Config::from_file(&rcfg).unwrap();
        let robot = cfg.load_robot().unwrap();
        let kin = &robot.kinematics;
        let r3 = AffineAction::new(
            "R",
            LieGroupSpec::So2 {
                axis: Some([0.0, 0.0, 1.0]),
            },
            3,
            2,
            Some(&[0.3, 0.0, -0.35]),
        )
        .unwrap();
        let lifted = LiftedAction::new(kin, &r3, FlowSettings::default()).unwrap();
        let mut ws = lifted.workspace();
        let q = cfg.check.reference_q.clone().unwrap();
        let mut out = vec![0.0; q.len()];
        // 30° about the pan axis moves the hands by ~0.2 m; it stays regular from this posture.
        g.bench_function("rby1_dual14/rtol1e-10/position", |b| {
            b.iter(|| {
                lifted
                    .act(black_box(&[theta]), black_box(&q), &mut out, &mut ws)
                    .unwrap()
            })
        });
    } else {
        skip::skip("rby1: robots/rby1a/model.urdf absent");
    }
    g.finish();
    let mut g = c.benchmark_group("check");
    g.sample_size(10)
        .measurement_time(std::time::Duration::from_secs(5));
    let cfg = Config::from_file(root().join("config/letters.toml")).unwrap();
    let robot = cfg.load_robot().unwrap();
    g.bench_function("letters", |b| {
        b.iter(|| {
            crossym::symmetry::check::check(
                &robot.kinematics,
                &cfg.symmetries,
                &cfg.composition.order,
                &cfg.check,
            )
            .unwrap()
        })
    });
    g.finish();
}

/// The `robots` directory of PyPI `example-robot-data`, when installed.
fn example_robots() -> Option<PathBuf> {
    let out = std::process::Command::new("python3")
        .args([
            "-c",
            "import sysconfig; print(sysconfig.get_paths()['purelib'])",
        ])
        .output()
        .ok()?;
    let d = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
        .join("cmeel.prefix/share/example-robot-data/robots");
    d.is_dir().then_some(d)
}

/// Times `n` single calls of `f` and prints median, p99 and max (ms): the tails criterion's
/// per-sample means hide.
fn tails(label: &str, n: usize, mut f: impl FnMut()) {
    let mut t: Vec<f64> = (0..n)
        .map(|_| {
            let s = std::time::Instant::now();
            f();
            s.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(f64::total_cmp);
    let q = |p: f64| t[((p * (n - 1) as f64).round() as usize).min(n - 1)];
    eprintln!(
        "morpho/{label}: single calls median {:.3} ms, p99 {:.3} ms, max {:.3} ms over {n}",
        q(0.5),
        q(0.99),
        t[n - 1]
    );
}

fn bench_morpho(c: &mut Criterion) {
    use crossym::kinematics::RobotModel;
    use crossym::symmetry::transfer::morpho::{
        derive_body_symmetries, derive_morphological, BodySettings, MorphoSettings,
    };
    use std::collections::HashMap;
    let mut g = c.benchmark_group("morpho");
    g.sample_size(20)
        .measurement_time(std::time::Duration::from_secs(3))
        .warm_up_time(std::time::Duration::from_secs(1));
    let rby1 = root().join("robots/rby1a/model.urdf");
    if rby1.exists() {
        // Reference: today's two-chain derivation on RB-Y1's arms (256 samples per direction),
        // then the whole tree (28 joints, 64 samples per element).
        let cfg = Config::from_file(root().join("config/rby1.toml")).unwrap();
        let robot = cfg.load_robot().unwrap();
        let two = || {
            derive_morphological(
                &robot.kinematics,
                0,
                1,
                nalgebra::Vector3::y(),
                &MorphoSettings::default(),
            )
            .unwrap()
        };
        g.bench_function("rby1/two_chains", |b| b.iter(two));
        tails("rby1/two_chains", 500, || {
            black_box(two());
        });
        let model = RobotModel::from_urdf_file(&rby1).unwrap();
        let whole = || {
            derive_body_symmetries(
                &model,
                None,
                None,
                &HashMap::new(),
                &BodySettings::default(),
            )
            .unwrap()
        };
        g.bench_function("rby1/whole_body", |b| b.iter(whole));
        tails("rby1/whole_body", 500, || {
            black_box(whole());
        });
    } else {
        eprintln!("morpho: robots/rby1a/model.urdf absent, RB-Y1 left out");
    }
    let Some(dir) = example_robots() else {
        eprintln!("morpho: example-robot-data absent (bash tests/robots/install.sh)");
        g.finish();
        return;
    };
    for (name, urdf, tol) in [
        ("solo12", "solo_description/robots/solo12.urdf", 1e-4),
        ("g1", "g1_description/urdf/g1_29dof_rev_1_0.urdf", 1e-4),
        ("talos", "talos_data/robots/talos_full_v2.urdf", 1e-4),
        // The largest: 101 joints, mirrored to 3 mm only.
        (
            "tiago_dual",
            "tiago_description/robots/tiago_dual.urdf",
            2.3e-3,
        ),
    ] {
        let model = RobotModel::from_urdf_file(dir.join(urdf)).unwrap();
        let settings = BodySettings {
            position_tolerance: tol,
            axis_tolerance: tol,
            residual_tolerance: tol,
            ..BodySettings::default()
        };
        let out = derive_body_symmetries(&model, None, None, &HashMap::new(), &settings).unwrap();
        eprintln!(
            "morpho/{name}: {} of order {}",
            out.group,
            out.elements.len()
        );
        let run =
            || derive_body_symmetries(&model, None, None, &HashMap::new(), &settings).unwrap();
        g.bench_function(name, |b| b.iter(run));
        tails(name, 500, || {
            black_box(run());
        });
    }
    g.finish();
}

criterion_group!(benches, bench_lift, bench_morpho);
criterion_main!(benches);
