//! Kinematics benchmarks: crossym against the `k` crate (v0.32) on the RB-Y1 arms,
//! plus the horizontal lift (FK + Jacobian + damped pseudo-inverse solve).
//!
//! Groups (all measured in the same run):
//! - `fk_jac/{crossym,k}/rby1_arm7`: FK + 6 × 7 geometric Jacobian of the left arm
//!   (`link_torso_5` → `ee_left`, joints `left_arm_0..6`).
//! - `fk_jac/{crossym,k}/rby1_dual14`: both arms, 14 joints (crossym: stacked task
//!   Jacobian via `Kinematics::jacobian`; k: two serial chains).
//! - `lift/crossym/{rby1_dual14,planar_dual8}`: `Kinematics::lift`.
//!
//! The RB-Y1 groups need the vendor URDF at `robots/rby1a/model.urdf` (shipped); the
//! planar group needs `urdf/planar_dual_arm.urdf`. Missing files skip their groups.
//!
//! Before timing, the setup checks that k and crossym agree on the tip pose and the full
//! 6 × n Jacobian to 1e-9 at every benchmarked configuration (an independent check of
//! our FK). After the criterion groups, each function is also timed with a plain loop
//! (median of 5 repeats) to print the k/crossym ratios; criterion's figures remain the
//! primary ones.

#![allow(clippy::needless_range_loop)] // numeric loops over several arrays

#[path = "../tests/support/skip.rs"]
mod skip;

use std::collections::HashMap;
use std::hint::black_box;
use std::path::Path;
use std::time::{Duration, Instant};

use criterion::{BenchmarkGroup, Criterion};
use crossym::kinematics::{
    Chain, ChainSpec, ChainWorkspace, JointLimits, Kinematics, KinematicsSettings,
    KinematicsWorkspace, RobotModel, TaskSpace,
};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const RBY1_URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/robots/rby1a/model.urdf");
const PLANAR_URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/urdf/planar_dual_arm.urdf");

/// Number of fixed random configurations cycled through by every benchmark.
const N_CONFIGS: usize = 64;
/// Tolerance of the k ↔ crossym cross-check.
const TOL: f64 = 1e-9;

/// One benchmarked operation with its own state; `run` performs exactly one call.
trait Case {
    fn run(&mut self);
}

/// `count` random configurations inside `limits` (unbounded joints in [-π, π]).
fn random_configs(rng: &mut StdRng, limits: &[JointLimits], count: usize) -> Vec<Vec<f64>> {
    let pi = std::f64::consts::PI;
    (0..count)
        .map(|_| {
            limits
                .iter()
                .map(|l| {
                    let lo = if l.lower.is_finite() { l.lower } else { -pi };
                    let hi = if l.upper.is_finite() { l.upper } else { pi };
                    rng.random_range(lo..=hi)
                })
                .collect()
        })
        .collect()
}

// ---------------------------------------------------------------------------------------
// RB-Y1 fixture: crossym chains and k serial chains over the same 7 + 7 joints.
// ---------------------------------------------------------------------------------------

struct Rby1 {
    left: Chain,
    kin: Kinematics,
    k_left: k::SerialChain<f64>,
    k_right: k::SerialChain<f64>,
    k_left_end: k::Node<f64>,
    k_right_end: k::Node<f64>,
    /// Left-arm configurations (7).
    q_arm: Vec<Vec<f64>>,
    /// Both-arm configurations (14, left then right).
    q_dual: Vec<Vec<f64>>,
    /// Task velocities for the lift (6: left xyz, right xyz; m/s).
    xdot: Vec<Vec<f64>>,
}

/// Builds the k serial chain `link_torso_5 → ee_<side>`.
///
/// k can cut a chain at a root node (`from_end_to_root`), but its `jacobian` mixes the
/// chain-local end pose (`end_transform`, relative to the first node's parent) with the
/// world (robot-root) joint transforms, which disagree unless the chain starts at the
/// robot root. We therefore detach `<side>_arm_0` from `torso_5`, making it a root whose
/// parent frame is `link_torso_5`: the k chain then has exactly the 7 movable joints
/// `<side>_arm_0..6` plus the fixed `tool_<side>` and `FT_Sensor_END_<side>`, with poses
/// and Jacobian expressed in `link_torso_5` — the same chain and frame as crossym's.
fn k_arm(tree: &k::Chain<f64>, side: &str) -> (k::SerialChain<f64>, k::Node<f64>) {
    let first = tree
        .find(&format!("{side}_arm_0"))
        .unwrap_or_else(|| panic!("k: no joint {side}_arm_0"))
        .clone();
    let torso = first.parent().expect("k: arm_0 has a parent (torso_5)");
    assert_eq!(torso.joint().name, "torso_5", "k: arm_0 hangs off torso_5");
    first.remove_parent(&torso);
    let end = tree
        .find(&format!("FT_Sensor_END_{side}"))
        .unwrap_or_else(|| panic!("k: no joint FT_Sensor_END_{side}"))
        .clone();
    let serial = k::SerialChain::from_end(&end);
    assert_eq!(serial.dof(), 7, "k: {side} arm has 7 movable joints");
    (serial, end)
}

/// Runs k's FK + Jacobian; returns (tip position, tip rotation (row-major), 6 × n Jacobian).
fn k_eval(
    arm: &k::SerialChain<f64>,
    end: &k::Node<f64>,
    q: &[f64],
) -> ([f64; 3], [[f64; 3]; 3], Vec<[f64; 6]>) {
    arm.set_joint_positions_unchecked(q);
    let j = k::jacobian(arm);
    let t = end.world_transform().expect("k: transforms updated");
    let p = t.translation.vector;
    let r = t.rotation.to_rotation_matrix();
    let mut rot = [[0.0; 3]; 3];
    for (a, row) in rot.iter_mut().enumerate() {
        for (b, v) in row.iter_mut().enumerate() {
            *v = r[(a, b)];
        }
    }
    let cols = (0..j.ncols())
        .map(|c| std::array::from_fn(|r| j[(r, c)]))
        .collect();
    ([p.x, p.y, p.z], rot, cols)
}

impl Rby1 {
    fn load() -> Option<Self> {
        if !Path::new(RBY1_URDF).exists() {
            skip::skip(format!("RB-Y1 groups: {RBY1_URDF} is absent"));
            return None;
        }
        let model = RobotModel::from_urdf_file(RBY1_URDF).expect("RB-Y1 URDF loads");
        let held = HashMap::new();
        let specs = [
            ChainSpec::new("left", "link_torso_5", "ee_left", TaskSpace::Xyz),
            ChainSpec::new("right", "link_torso_5", "ee_right", TaskSpace::Xyz),
        ];
        let left = Chain::new(&model, &specs[0], &held).expect("left chain");
        let settings = KinematicsSettings {
            damping: 0.0,
            metric_diagonal: None,
            singular_manipulability: 1e-4,
        };
        let kin = Kinematics::new(&model, &specs, &held, &settings).expect("RB-Y1 kinematics");
        assert_eq!(left.dof(), 7);
        assert_eq!(kin.dof(), 14);

        let tree = k::Chain::<f64>::from_urdf_file(RBY1_URDF).expect("k loads the RB-Y1 URDF");
        let (k_left, k_left_end) = k_arm(&tree, "left");
        let (k_right, k_right_end) = k_arm(&tree, "right");

        let mut rng = StdRng::seed_from_u64(0x5eed_0001);
        let q_arm = random_configs(&mut rng, &left.limits, N_CONFIGS);
        let q_dual = random_configs(&mut rng, kin.limits(), N_CONFIGS);
        let xdot = (0..N_CONFIGS)
            .map(|_| (0..6).map(|_| rng.random_range(-0.1..=0.1)).collect())
            .collect();
        let fx = Self {
            left,
            kin,
            k_left,
            k_right,
            k_left_end,
            k_right_end,
            q_arm,
            q_dual,
            xdot,
        };
        fx.cross_check();
        Some(fx)
    }

    /// Asserts that k and crossym agree on joint order, tip pose and 6 × n Jacobian.
    fn cross_check(&self) {
        let k_names: Vec<String> = self.k_left.iter_joints().map(|j| j.name.clone()).collect();
        assert_eq!(
            k_names, self.left.joint_names,
            "same movable joints, same order"
        );

        // One arm: crossym Chain::jacobian vs k.
        let mut ws = self.left.workspace();
        let (mut dp, mut dr, mut dj) = (0.0f64, 0.0f64, 0.0f64);
        for q in &self.q_arm {
            self.left.jacobian(q, &mut ws);
            let (p, rot, jac) = k_eval(&self.k_left, &self.k_left_end, q);
            for (a, (pa, row)) in p.iter().zip(&rot).enumerate() {
                dp = dp.max((ws.tip.translation.vector[a] - pa).abs());
                for (b, rab) in row.iter().enumerate() {
                    dr = dr.max((ws.tip.rotation.matrix()[(a, b)] - rab).abs());
                }
            }
            for (c, col) in jac.iter().enumerate() {
                for (r, v) in col.iter().enumerate() {
                    dj = dj.max((ws.jacobian[(r, c)] - v).abs());
                }
            }
        }
        println!(
            "cross-check rby1_arm7 ({N_CONFIGS} configs): max |Δp| = {dp:.2e} m, \
             max |ΔR| = {dr:.2e}, max |ΔJ| (6×7, [v; ω]) = {dj:.2e}"
        );
        assert!(
            dp < TOL && dr < TOL && dj < TOL,
            "k and crossym disagree (arm7)"
        );

        // Both arms: stacked task Jacobian (6 × 14, block-diagonal) vs k's two chains.
        let mut ws = self.kin.workspace();
        let (mut dp, mut dj) = (0.0f64, 0.0f64);
        for q in &self.q_dual {
            self.kin.jacobian(q, &mut ws);
            let sides = [
                (&self.k_left, &self.k_left_end, &q[..7]),
                (&self.k_right, &self.k_right_end, &q[7..]),
            ];
            for (s, (arm, end, qs)) in sides.into_iter().enumerate() {
                let (p, _, jac) = k_eval(arm, end, qs);
                for (a, pa) in p.iter().enumerate() {
                    dp = dp.max((ws.x[3 * s + a] - pa).abs());
                }
                // Rows 3s..3s+3 of the stacked Jacobian: k's position rows in the
                // columns of arm s, zeros in the other arm's columns.
                for c in 0..14 {
                    let col = (c / 7 == s).then(|| &jac[c % 7]);
                    for r in 0..3 {
                        let expect = col.map_or(0.0, |col| col[r]);
                        dj = dj.max((ws.jac[(3 * s + r, c)] - expect).abs());
                    }
                }
            }
        }
        println!(
            "cross-check rby1_dual14 ({N_CONFIGS} configs): max |Δx| = {dp:.2e} m, \
             max |ΔJ| (6×14 position Jacobian) = {dj:.2e}"
        );
        assert!(dp < TOL && dj < TOL, "k and crossym disagree (dual14)");
    }
}

// ---------------------------------------------------------------------------------------
// Cases.
// ---------------------------------------------------------------------------------------

struct CrossymArm<'a> {
    chain: &'a Chain,
    ws: ChainWorkspace,
    qs: &'a [Vec<f64>],
    i: usize,
}

impl Case for CrossymArm<'_> {
    #[inline]
    fn run(&mut self) {
        self.i = (self.i + 1) % self.qs.len();
        self.chain
            .jacobian(black_box(&self.qs[self.i]), &mut self.ws);
        black_box(&self.ws.tip);
        black_box(&self.ws.jacobian);
    }
}

struct KArm<'a> {
    arm: &'a k::SerialChain<f64>,
    end: &'a k::Node<f64>,
    qs: &'a [Vec<f64>],
    i: usize,
}

impl Case for KArm<'_> {
    #[inline]
    fn run(&mut self) {
        self.i = (self.i + 1) % self.qs.len();
        self.arm
            .set_joint_positions_unchecked(black_box(&self.qs[self.i]));
        // `jacobian` runs `end_transform` and `update_transforms` (the FK) itself; the
        // tip pose is then a cached read.
        let j = k::jacobian(self.arm);
        black_box(&j);
        black_box(self.end.world_transform());
    }
}

struct CrossymDual<'a> {
    kin: &'a Kinematics,
    ws: KinematicsWorkspace,
    qs: &'a [Vec<f64>],
    i: usize,
}

impl Case for CrossymDual<'_> {
    #[inline]
    fn run(&mut self) {
        self.i = (self.i + 1) % self.qs.len();
        self.kin.jacobian(black_box(&self.qs[self.i]), &mut self.ws);
        black_box(&self.ws.x);
        black_box(&self.ws.jac);
    }
}

struct KDual<'a> {
    fx: &'a Rby1,
    i: usize,
}

impl Case for KDual<'_> {
    #[inline]
    fn run(&mut self) {
        self.i = (self.i + 1) % self.fx.q_dual.len();
        let q = black_box(&self.fx.q_dual[self.i]);
        let fx = self.fx;
        fx.k_left.set_joint_positions_unchecked(&q[..7]);
        fx.k_right.set_joint_positions_unchecked(&q[7..]);
        let jl = k::jacobian(&fx.k_left);
        let jr = k::jacobian(&fx.k_right);
        black_box((&jl, &jr));
        black_box(fx.k_left_end.world_transform());
        black_box(fx.k_right_end.world_transform());
    }
}

struct Lift<'a> {
    kin: &'a Kinematics,
    ws: KinematicsWorkspace,
    qs: &'a [Vec<f64>],
    xdot: &'a [Vec<f64>],
    out: Vec<f64>,
    i: usize,
}

impl Case for Lift<'_> {
    #[inline]
    fn run(&mut self) {
        self.i = (self.i + 1) % self.qs.len();
        let report = self.kin.lift(
            black_box(&self.qs[self.i]),
            black_box(&self.xdot[self.i]),
            &mut self.out,
            &mut self.ws,
        );
        black_box(report);
        black_box(&self.out);
    }
}

impl<'a> Lift<'a> {
    fn new(kin: &'a Kinematics, qs: &'a [Vec<f64>], xdot: &'a [Vec<f64>]) -> Self {
        // Sanity: the lift is finite and reproduces ẋ (J q̇ = ẋ for λ = 0, regular q).
        let mut ws = kin.workspace();
        let mut out = vec![0.0; kin.dof()];
        for (q, xd) in qs.iter().zip(xdot) {
            let report = kin.lift(q, xd, &mut out, &mut ws);
            assert!(out.iter().all(|v| v.is_finite()), "lift is finite");
            if report.status == crossym::kinematics::PinvStatus::Regular {
                let back = &ws.jac * nalgebra::DVector::from_column_slice(&out);
                let err = (back - nalgebra::DVector::from_column_slice(xd)).amax();
                assert!(err < 1e-6, "J J⁺ ẋ = ẋ (error {err:e})");
            }
        }
        Self {
            kin,
            ws,
            qs,
            xdot,
            out,
            i: 0,
        }
    }
}

// ---------------------------------------------------------------------------------------
// Planar dual arm (paper Sec. VI-A).
// ---------------------------------------------------------------------------------------

struct Planar {
    kin: Kinematics,
    qs: Vec<Vec<f64>>,
    xdot: Vec<Vec<f64>>,
}

impl Planar {
    fn load() -> Option<Self> {
        if !Path::new(PLANAR_URDF).exists() {
            skip::skip(format!("planar group: {PLANAR_URDF} is absent"));
            return None;
        }
        let model = RobotModel::from_urdf_file(PLANAR_URDF).expect("planar URDF loads");
        let specs = [
            ChainSpec::new("left", "base", "left_ee", TaskSpace::Xy),
            ChainSpec::new("right", "base", "right_ee", TaskSpace::Xy),
        ];
        let settings = KinematicsSettings {
            damping: 0.0,
            metric_diagonal: None,
            singular_manipulability: 1e-3,
        };
        let kin =
            Kinematics::new(&model, &specs, &HashMap::new(), &settings).expect("planar kinematics");
        assert_eq!((kin.dof(), kin.task_dim()), (8, 4));
        let mut rng = StdRng::seed_from_u64(0x5eed_0002);
        let qs = random_configs(&mut rng, kin.limits(), N_CONFIGS);
        let xdot = (0..N_CONFIGS)
            .map(|_| (0..4).map(|_| rng.random_range(-1.0..=1.0)).collect())
            .collect();
        Some(Self { kin, qs, xdot })
    }
}

// ---------------------------------------------------------------------------------------
// Timing.
// ---------------------------------------------------------------------------------------

fn bench<C: Case>(
    group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>,
    id: &str,
    mut case: C,
) {
    group.bench_function(id, |b| b.iter(|| case.run()));
}

/// Median time per call (ns) over 5 repeats of a plain loop (≤ 200k calls, ~0.3 s each).
fn time_case<C: Case>(mut case: C) -> f64 {
    // Calibrate (also a warm-up).
    let start = Instant::now();
    let mut calls = 0u64;
    while start.elapsed() < Duration::from_millis(50) {
        for _ in 0..100 {
            case.run();
        }
        calls += 100;
    }
    let per = start.elapsed().as_secs_f64() / calls as f64;
    let iters = ((0.3 / per) as u64).clamp(10_000, 200_000);
    let mut times: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..iters {
                case.run();
            }
            t.elapsed().as_secs_f64() * 1e9 / iters as f64
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[2]
}

fn fmt_ns(ns: f64) -> String {
    if ns >= 1000.0 {
        format!("{:.3} µs", ns / 1000.0)
    } else {
        format!("{ns:.1} ns")
    }
}

fn main() {
    // `cargo bench` passes `--bench`; without it (e.g. `cargo test --benches`) criterion
    // runs each function once as a smoke test and the manual timings are skipped.
    let bench_mode = std::env::args().any(|a| a == "--bench");
    let mut c = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3))
        .sample_size(50)
        .configure_from_args();

    let rby1 = Rby1::load();
    let planar = Planar::load();

    if let Some(fx) = &rby1 {
        let mut g = c.benchmark_group("fk_jac");
        bench(
            &mut g,
            "crossym/rby1_arm7",
            CrossymArm {
                chain: &fx.left,
                ws: fx.left.workspace(),
                qs: &fx.q_arm,
                i: 0,
            },
        );
        bench(
            &mut g,
            "k/rby1_arm7",
            KArm {
                arm: &fx.k_left,
                end: &fx.k_left_end,
                qs: &fx.q_arm,
                i: 0,
            },
        );
        bench(
            &mut g,
            "crossym/rby1_dual14",
            CrossymDual {
                kin: &fx.kin,
                ws: fx.kin.workspace(),
                qs: &fx.q_dual,
                i: 0,
            },
        );
        bench(&mut g, "k/rby1_dual14", KDual { fx, i: 0 });
        g.finish();
    }
    {
        let mut g = c.benchmark_group("lift");
        if let Some(fx) = &rby1 {
            bench(
                &mut g,
                "crossym/rby1_dual14",
                Lift::new(&fx.kin, &fx.q_dual, &fx.xdot),
            );
        }
        if let Some(p) = &planar {
            bench(
                &mut g,
                "crossym/planar_dual8",
                Lift::new(&p.kin, &p.qs, &p.xdot),
            );
        }
        g.finish();
    }
    c.final_summary();

    if !bench_mode {
        return;
    }
    println!();
    println!("manual timing (median of 5 plain-loop repeats, per call):");
    if let Some(fx) = &rby1 {
        let cx = time_case(CrossymArm {
            chain: &fx.left,
            ws: fx.left.workspace(),
            qs: &fx.q_arm,
            i: 0,
        });
        let kk = time_case(KArm {
            arm: &fx.k_left,
            end: &fx.k_left_end,
            qs: &fx.q_arm,
            i: 0,
        });
        println!(
            "ratio k/crossym fk+jac arm7: {:.1}x (k {}, crossym {})",
            kk / cx,
            fmt_ns(kk),
            fmt_ns(cx)
        );
        let cx = time_case(CrossymDual {
            kin: &fx.kin,
            ws: fx.kin.workspace(),
            qs: &fx.q_dual,
            i: 0,
        });
        let kk = time_case(KDual { fx, i: 0 });
        println!(
            "ratio k/crossym fk+jac dual14: {:.1}x (k {}, crossym {})",
            kk / cx,
            fmt_ns(kk),
            fmt_ns(cx)
        );
        let l = time_case(Lift::new(&fx.kin, &fx.q_dual, &fx.xdot));
        println!("lift crossym rby1_dual14: {}", fmt_ns(l));
    }
    if let Some(p) = &planar {
        let l = time_case(Lift::new(&p.kin, &p.qs, &p.xdot));
        println!("lift crossym planar_dual8: {}", fmt_ns(l));
    }
}
