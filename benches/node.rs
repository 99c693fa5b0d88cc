//! The node's control tick and its joint_states → command latency over loopback DDS.
//!
//! - `tick/*` (criterion): `NodeCore::load_inputs` + `NodeCore::tick` (FK + Jacobian, MLP
//!   forward, safety QP, command) along a path of joint states, for the planar dual arm with
//!   the shipped policy (canonical task features `x̃ = g(s)⁻¹ f(q)`), RB-Y1's 14 arm joints
//!   with a synthetic policy of the same shape (`rby1`, around the reference posture: its
//!   output leaves the bounds, so every tick runs the QP) and with the shipped RB-Y1
//!   letter policy (`rby1-letters`, around the first letter's start); `*-no-xt` ticks run a
//!   synthetic policy of the same widths without task features, the reference for what `x̃`
//!   costs; `*-eq-*` ticks run the shipped policy canonicalised, `dΦ_g π₀(Φ_g⁻¹ q)`,
//!   under the off-grid condition θ = 17°, λ = 0.73, σ = −1, flows by adaptive
//!   Dormand–Prince or fixed-step RK4 (`CROSSYM_TICK_ONLY=eq` runs only those);
//!   `planar_8dof-head` runs the shipped task-space head `J⁺ Dg h(g⁻¹ f(q))`
//!   under the same off-grid condition, `rby1-letters_14dof-head` RB-Y1's with the plain
//!   lift and `-head-ns` with its config's null-space term `(I − J⁺J) v₀(q)`.
//!   A second pass times 20 000 single ticks and prints median and p99, and how many of
//!   them the safety QP filtered (Clarabel dominates such a tick).
//! - `latency`: the real node (`ros::node::run`, trigger = joint_states) in this process, a
//!   second DDS participant publishing JointState and timing the arrival of the command the
//!   node computes from it (median, p99 over 2000 round trips). DDS: run inside
//!   `tools/netns-run`.
//!
//! - `floor` (after `latency`, in the same run): the machine's own wake-up floor, the
//!   reference for the round trips: one
//!   thread under `SCHED_FIFO` 95 (when permitted), memory locked, a PM QoS CPU latency
//!   request of 0 µs held, sleeping to absolute deadlines (`clock_nanosleep`) every 1 ms
//!   (20 000) and every 10 ms (3 000); prints how late it woke (median, p99, p99.9, max),
//!   as `cyclictest` does. No round trip can beat the wake-ups it is made of.
//!
//! Run: `tools/netns-run cargo bench --bench node`.

#[path = "../tests/support/skip.rs"]
mod skip;

use std::hint::black_box;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use crossym::config::Config;
use crossym::control::{NodeConfig, NodeCore, OutputMode, StatusCode, Trigger};
use crossym::msg;
use crossym::policy::{Policy, TaskFeatures};
use crossym::ros::dds::{self, DdsSettings, DiscoveryRange};
use crossym::safety::{SafetySettings, SafetyStatus};
use crossym::symmetry::compose::Condition;
use crossym::symmetry::transfer::composed::LiftIntegrator;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `cargo test` runs this bench once as a smoke test (no `--bench` argument, criterion's
/// test mode): the hand-timed passes then run 1/100 of their samples, enough to exercise
/// them, not to measure (`cargo bench` runs them whole).
fn samples(n: usize) -> usize {
    if std::env::args().any(|a| a == "--bench") {
        n
    } else {
        (n / 100).max(10)
    }
}

/// The policy of a tick variant.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    /// Canonical task features `x̃` (the shipped policy; synthetic on `rby1`).
    Features,
    /// A synthetic policy of the same widths without task features.
    NoFeatures,
    /// A canonicalised policy `dΦ_g π₀(Φ_g⁻¹ q)` under an off-grid condition, its flows
    /// integrated by the given integrator.
    Canonicalised(LiftIntegrator),
    /// The shipped task-space head `J⁺ Dg h(g⁻¹ f(q))` under the off-grid
    /// condition; with the config's `[redundancy]` null-space term `(I − J⁺J) v₀(q)`
    /// or the plain lift.
    TaskHead { null_space: bool },
}

/// Off the training grid: θ = 17°, λ = 0.73, σ = −1.
const OFF_GRID: Condition = Condition {
    theta: 0.296_705_972_839_036,
    scale: 0.73,
    reflection: -1,
};

/// The node core and a path of joint states for one robot and policy kind.
fn setup(robot: &str, kind: Kind) -> Option<(NodeCore, Vec<Vec<f64>>)> {
    let features = kind != Kind::NoFeatures;
    let around_demo =
        matches!(kind, Kind::Canonicalised(_) | Kind::TaskHead { .. }) || robot == "rby1-letters";
    let head = matches!(kind, Kind::TaskHead { .. });
    // Config, synthetic policy or not, and the shipped policy otherwise.
    let (cfg_name, synthetic, shipped) = match robot {
        "planar" if head => ("letters.toml", false, "pi_mrt_head_planar"),
        "planar" => ("letters.toml", !features, "pi_mrt_planar"),
        "rby1-letters" if head => ("rby1-letters.toml", false, "pi_mrt_head_rby1_letters"),
        "rby1-letters" => ("rby1-letters.toml", false, "pi_mrt_rby1_letters"),
        _ => ("rby1.toml", true, ""),
    };
    if robot != "planar" && !root().join("robots/rby1a/model.urdf").exists() {
        skip::skip(format!("{robot}: robots/rby1a/model.urdf absent"));
        return None;
    }
    let cfg = Config::from_file(root().join("config").join(cfg_name)).unwrap();
    let robot = cfg.load_robot().unwrap();
    let kin = robot.kinematics;
    let n = kin.dof();
    let mut policy = if synthetic {
        let task = features.then(|| {
            let (built, _) = crossym::symmetry::check::build(&kin, &cfg.symmetries).unwrap();
            TaskFeatures::for_robot(&kin, &built, &cfg.composition.order).unwrap()
        });
        Policy::synthetic_with(n, kin.joint_names().to_vec(), &[128, 128, 128], 1, task)
    } else {
        Policy::load(root().join(format!("data/policies/{shipped}.safetensors"))).unwrap()
    };
    let mut node_cfg = cfg.node.clone().unwrap_or_default();
    // Velocity output whatever the config says: the path of joint states ignores the
    // commands, so a position-mode node (RB-Y1's trajectory output) would restart from the
    // measured state, then hold as ROBOT_NOT_FOLLOWING and time the hold, not the policy
    // (the RB-Y1 cases measured 0.3 µs that way until 2026-12-04). Every tick is checked
    // below to have run the policy.
    node_cfg.output = OutputMode::Velocity;
    if let Kind::Canonicalised(integrator) = kind {
        policy.meta.canonicalised =
            Some(crossym::pipeline::composition(&cfg, &kin, integrator).unwrap());
        node_cfg.default_condition = OFF_GRID;
    }
    if head {
        node_cfg.default_condition = OFF_GRID;
    }
    // Canonicalised and RB-Y1's letters: around the first demonstration's start (the
    // condition is feasible there); otherwise around the reference posture.
    let q0 = if around_demo {
        cfg.load_demonstrations(&kin).unwrap().demos[0]
            .q(0)
            .to_vec()
    } else {
        cfg.check
            .reference_q
            .clone()
            .unwrap_or_else(|| vec![0.0; n])
    };
    // A smooth closed path around that posture (1000 states, 10 ms apart).
    let amplitude = if around_demo { 0.05 } else { 0.1 };
    let path = (0..1000)
        .map(|k| {
            (0..n)
                .map(|j| q0[j] + amplitude * (0.0063 * k as f64 + j as f64).sin())
                .collect()
        })
        .collect();
    let safety = SafetySettings {
        default_acceleration: 10.0,
        ..node_cfg.safety
    };
    // A task head as every command loads it (the config's `[redundancy]` term in its
    // lift), or with the plain lift.
    let any: crossym::policy::AnyPolicy = if let Kind::TaskHead { null_space } = kind {
        let file = root().join(format!("data/policies/{shipped}.safetensors"));
        let any = crossym::pipeline::load_any_policy(&cfg, &kin, &file).unwrap();
        if null_space {
            let has = any.task_head().is_some_and(|h| h.null_space().is_some());
            assert!(has, "{cfg_name} has no [redundancy] null-space term");
            any
        } else {
            any.with_plain_lift().0
        }
    } else {
        policy.into()
    };
    let core = NodeCore::new(kin, any, safety, NodeConfig { ..node_cfg }).unwrap();
    Some((core, path))
}

fn bench_tick(c: &mut Criterion) {
    let mut g = c.benchmark_group("tick");
    g.measurement_time(Duration::from_secs(4))
        .warm_up_time(Duration::from_secs(1));
    let adaptive = crossym::pipeline::canonical_integrator();
    let rk4 = LiftIntegrator::Rk4 { max_step: 0.2 };
    let only = std::env::var("CROSSYM_TICK_ONLY").ok();
    for (robot, kind, suffix) in [
        ("planar", Kind::Features, ""),
        ("planar", Kind::NoFeatures, "-no-xt"),
        ("planar", Kind::Canonicalised(adaptive), "-eq-adaptive"),
        ("planar", Kind::Canonicalised(rk4), "-eq-rk4"),
        ("planar", Kind::TaskHead { null_space: false }, "-head"),
        ("rby1", Kind::Features, ""),
        ("rby1", Kind::NoFeatures, "-no-xt"),
        ("rby1-letters", Kind::Features, ""),
        (
            "rby1-letters",
            Kind::Canonicalised(adaptive),
            "-eq-adaptive",
        ),
        ("rby1-letters", Kind::Canonicalised(rk4), "-eq-rk4"),
        (
            "rby1-letters",
            Kind::TaskHead { null_space: false },
            "-head",
        ),
        (
            "rby1-letters",
            Kind::TaskHead { null_space: true },
            "-head-ns",
        ),
    ] {
        if only
            .as_deref()
            .is_some_and(|o| !format!("{robot}{suffix}").contains(o))
        {
            continue;
        }
        let Some((mut core, path)) = setup(robot, kind) else {
            continue;
        };
        let mut gate = core.input_gate();
        let mut cmd = core.command();
        let mut m = msg::JointState {
            name: core.joint_names().to_vec(),
            position: path[0].clone(),
            ..Default::default()
        };
        let mut k = 0usize;
        let mut infeasible = 0usize;
        // Ticks that did not run the policy and the filter (a hold, a stale input).
        let mut held = 0usize;
        // Ticks whose policy output the filter changed (the QP ran): what the tick costs
        // depends on it (Clarabel is most of a filtered tick).
        let mut filtered = 0usize;
        let mut step = |core: &mut NodeCore| {
            m.position.copy_from_slice(&path[k % path.len()]);
            let now = k as f64 * 0.01;
            gate.on_joint_state(&m, now).unwrap();
            core.load_inputs(gate.inputs());
            let r = core.tick(now, &mut cmd);
            infeasible += usize::from(r.code == StatusCode::ConditionInfeasible);
            held += usize::from(r.safety.is_none());
            k += 1;
            black_box(r).safety != Some(SafetyStatus::Passthrough)
        };
        let label = format!("{robot}_{}dof{suffix}", core.joint_names().len());
        g.bench_function(&label, |b| b.iter(|| step(&mut core)));
        // Percentiles of single ticks.
        let mut t: Vec<f64> = (0..samples(20_000))
            .map(|_| {
                let t0 = Instant::now();
                let f = step(&mut core);
                let t = t0.elapsed().as_secs_f64() * 1e6;
                filtered += usize::from(f);
                t
            })
            .collect();
        t.sort_by(f64::total_cmp);
        println!(
            "tick/{label}: median {:.2} us, p99 {:.2} us, max {:.2} us over {} ticks ({infeasible} infeasible, {filtered} filtered by the QP)",
            t[t.len() / 2],
            t[t.len() * 99 / 100],
            t[t.len() - 1],
            t.len()
        );
        assert_eq!(
            infeasible, 0,
            "{label}: the off-grid condition must stay feasible on the path"
        );
        assert_eq!(
            held, 0,
            "{label}: ticks that ran no policy (a hold) are not what this bench times"
        );
    }
    g.finish();
}

/// joint_states → command latency through the real node over loopback DDS.
fn bench_latency(_c: &mut Criterion) {
    if std::env::var("CROSSYM_TICK_ONLY").is_ok() {
        return;
    }
    let Some((core, path)) = setup("planar", Kind::Features) else {
        return;
    };
    let _ = core; // the node builds its own core below with trigger = joint_states
    let cfg = Config::from_file(root().join("config/letters.toml")).unwrap();
    let robot = cfg.load_robot().unwrap();
    let mut node_cfg = cfg.node_config();
    node_cfg.trigger = Trigger::JointStates;
    node_cfg.check_stamps = false;
    node_cfg.name = "crossym_latency".into();
    let names = robot.kinematics.joint_names().to_vec();
    let core = crossym::setup::node_core(&cfg, node_cfg.clone()).unwrap();
    let settings = DdsSettings {
        domain_id: 77,
        range: DiscoveryRange::Localhost,
        distro: dds::DEFAULT_DISTRO,
        security: Default::default(),
    };
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    let node_settings = settings.clone();
    let node =
        std::thread::spawn(move || crossym::ros::node::run(core, node_settings, Some(stop2), None));

    let ctx = match settings.context() {
        Ok(c) => c,
        Err(e) => {
            skip::skip(format!("latency: {e}"));
            stop.store(true, Ordering::Release);
            let _ = node.join();
            return;
        }
    };
    let mut peer = ctx
        .new_node(
            dds::node_name("/", "latency_peer").unwrap(),
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .unwrap();
    let js_pub =
        dds::publisher::<msg::JointState>(&mut peer, "/joint_states", dds::qos_reliable(10))
            .unwrap();
    let cmd_sub = dds::subscription::<msg::Float64MultiArray>(
        &mut peer,
        &node_cfg.topics.command,
        dds::qos_reliable(10),
    )
    .unwrap();
    let send = |k: usize| {
        js_pub
            .publish(msg::JointState {
                name: names.clone(),
                position: path[k % path.len()].clone(),
                ..Default::default()
            })
            .unwrap();
    };
    // Discovery and warm-up: until commands flow.
    let t_start = Instant::now();
    let mut warm = 0;
    while warm < 50 {
        assert!(
            t_start.elapsed() < Duration::from_secs(30),
            "no commands from the node within 30 s (run inside netns-run?)"
        );
        send(warm);
        std::thread::sleep(Duration::from_millis(10));
        while let Ok(Some(_)) = cmd_sub.take() {
            warm += 1;
        }
    }
    // The peer waits for each command blocked until DDS wakes it, as a driver does (a
    // spinning peer takes one of the machine's cores and its wake-ups land in the tail).
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()
        .unwrap();
    let trips = samples(2000);
    let mut lat = Vec::with_capacity(trips);
    for k in 0..trips {
        while let Ok(Some(_)) = cmd_sub.take() {}
        let t0 = Instant::now();
        send(k);
        // The command computed from this state (the node ticks on arrival and otherwise
        // only after the stale timeout, 0.1 s).
        let got = rt.block_on(async {
            tokio::time::timeout(Duration::from_millis(50), cmd_sub.async_take()).await
        });
        if matches!(got, Ok(Ok(_))) {
            lat.push(t0.elapsed().as_secs_f64() * 1e6);
        }
        std::thread::sleep(Duration::from_millis(2));
    }
    stop.store(true, Ordering::Release);
    let _ = node.join();
    lat.sort_by(f64::total_cmp);
    if lat.is_empty() {
        println!("latency: no replies");
        return;
    }
    println!(
        "latency/joint_states->command (loopback DDS, trigger joint_states): median {:.1} us, p99 {:.1} us, max {:.1} us over {} round trips ({} lost)",
        lat[lat.len() / 2],
        lat[lat.len() * 99 / 100],
        lat[lat.len() - 1],
        lat.len(),
        trips - lat.len()
    );
}

/// The machine's wake-up floor (see the module doc): lateness of a real-time thread's
/// timed wake-ups, at 1 kHz and 100 Hz.
fn bench_floor(_c: &mut Criterion) {
    use crossym::control::realtime::{self, RealtimeConfig, RealtimeOutcome};
    if std::env::var("CROSSYM_TICK_ONLY").is_ok() {
        return;
    }
    let (_request, outcome) = realtime::request_cpu_latency(0);
    let rt = RealtimeConfig {
        priority: 95,
        lock_memory: true,
        dds_priority: None,
        cpu_latency_us: None,
        idle_poll: false,
    };
    std::thread::spawn(move || {
        // SAFETY: pthread_self has no preconditions.
        let mut applied = realtime::apply(&rt, unsafe { libc::pthread_self() });
        applied.push(outcome);
        for o in &applied {
            if let RealtimeOutcome::Refused { what, reason } = o {
                println!("floor: {what} REFUSED ({reason})");
            }
        }
        for (period_ns, n) in [(1_000_000i64, samples(20_000)), (10_000_000, samples(3_000))] {
            let mut late = Vec::with_capacity(n);
            let mut t = libc::timespec {
                tv_sec: 0,
                tv_nsec: 0,
            };
            let mut now = t;
            // SAFETY: valid pointers to local timespecs.
            unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut t) };
            for _ in 0..n {
                t.tv_nsec += period_ns;
                while t.tv_nsec >= 1_000_000_000 {
                    t.tv_nsec -= 1_000_000_000;
                    t.tv_sec += 1;
                }
                // SAFETY: valid pointers to local timespecs.
                unsafe {
                    libc::clock_nanosleep(
                        libc::CLOCK_MONOTONIC,
                        libc::TIMER_ABSTIME,
                        &t,
                        std::ptr::null_mut(),
                    );
                    libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut now);
                }
                let ns = (now.tv_sec - t.tv_sec) * 1_000_000_000 + (now.tv_nsec - t.tv_nsec);
                late.push(ns as f64 * 1e-3);
            }
            late.sort_by(f64::total_cmp);
            println!(
                "floor/timed wake-up every {} ms (SCHED_FIFO 95, cpu latency 0 µs): lateness median {:.0} us, p99 {:.0} us, p99.9 {:.0} us, max {:.0} us over {n}",
                period_ns / 1_000_000,
                late[n / 2],
                late[n * 99 / 100],
                late[n * 999 / 1000],
                late[n - 1],
            );
        }
    })
    .join()
    .unwrap();
}

criterion_group!(benches, bench_tick, bench_latency, bench_floor);
criterion_main!(benches);
