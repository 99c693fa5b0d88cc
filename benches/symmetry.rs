//! Lifting one configuration by θ = 30° (the lifted SO(2) flow, eq. 18) on the planar dual
//! arm and on RB-Y1, with and without the velocity differential, and one `crossym check`
//! of the letter task. Run: `cargo bench --bench symmetry`.

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
    // RB-Y1 (vendor URDF from ../shared; skipped when absent).
    let rcfg = root().join("config/rby1.toml");
    if root().join("../shared/robots/rby1a/model.urdf").exists() {
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
        eprintln!("SKIP rby1: ../shared/robots/rby1a/model.urdf absent");
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

criterion_group!(benches, bench_lift);
criterion_main!(benches);
