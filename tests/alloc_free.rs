//! Allocation audit of the per-tick kinematics functions.
//!
//! The kinematics module promises that, once the model, the chains and their workspaces
//! are built, FK, Jacobians, the lift and the pseudo-inverse allocate nothing. This test
//! binary installs a counting global allocator and checks that promise on three robots:
//! an embedded 3-joint arm (always), the planar dual arm of the paper (when
//! `urdf/planar_dual_arm.urdf` exists) and RB-Y1 (when the vendor URDF exists in
//! `robots/rby1a/`). It checks the same of the whole control tick — FK, the policy, the
//! safety QP on each of its paths (passthrough, the active-set solver, Clarabel) — and of
//! the node's tick with its inputs and operator requests: zero allocations on every tick.
//!
//! Counting is per thread (tests run in parallel): a thread-local flag switches it on
//! around the measured calls only. The first allocation of a measured section records a
//! backtrace, printed in the failure message.

#[path = "support/skip.rs"]
mod skip;

use std::alloc::{GlobalAlloc, Layout, System};
use std::backtrace::Backtrace;
use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::path::Path;

use crossym::kinematics::{
    Chain, ChainSpec, ChainWorkspace, JointLimits, Kinematics, KinematicsSettings,
    KinematicsWorkspace, PinvStatus, RobotModel, TaskSpace, ToolOffset,
};
use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

// ---------------------------------------------------------------------------------------
// Counting allocator.
// ---------------------------------------------------------------------------------------

struct CountingAlloc;

thread_local! {
    // `const` initialisers: no lazy initialisation, hence no allocation, in the allocator.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static COUNT: Cell<usize> = const { Cell::new(0) };
    static FIRST: RefCell<Option<Backtrace>> = const { RefCell::new(None) };
}

/// Records one allocation if this thread is counting.
fn note_allocation() {
    // `try_with`: the allocator may run while thread-locals are being torn down.
    let _ = COUNTING.try_with(|counting| {
        if !counting.get() {
            return;
        }
        // Switch counting off while recording: capturing a backtrace allocates.
        counting.set(false);
        COUNT.with(|n| n.set(n.get() + 1));
        FIRST.with(|first| {
            let mut first = first.borrow_mut();
            if first.is_none() {
                *first = Some(Backtrace::force_capture());
            }
        });
        counting.set(true);
    });
}

unsafe impl GlobalAlloc for CountingAlloc {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

/// Runs `f` with counting on; returns its result, the number of allocations and the
/// backtrace of the first one.
fn count_allocs<R>(f: impl FnOnce() -> R) -> (R, usize, Option<Backtrace>) {
    COUNT.set(0);
    FIRST.take();
    COUNTING.set(true);
    let r = f();
    COUNTING.set(false);
    (r, COUNT.get(), FIRST.take())
}

/// Allocation tally of one function on one robot.
struct Tally {
    name: String,
    count: usize,
    first: Option<Backtrace>,
}

struct Audit {
    robot: String,
    tallies: Vec<Tally>,
}

impl Audit {
    fn new(robot: &str) -> Self {
        Self {
            robot: robot.into(),
            tallies: Vec::new(),
        }
    }

    /// Adds the allocations of one measured call to the tally `name`.
    fn measure<R>(&mut self, name: &str, f: impl FnOnce() -> R) -> R {
        let (r, count, first) = count_allocs(f);
        let i = match self.tallies.iter().position(|t| t.name == name) {
            Some(i) => i,
            None => {
                self.tallies.push(Tally {
                    name: name.into(),
                    count: 0,
                    first: None,
                });
                self.tallies.len() - 1
            }
        };
        let t = &mut self.tallies[i];
        t.count += count;
        if t.first.is_none() {
            t.first = first;
        }
        r
    }

    /// Prints every tally, then asserts each is zero (the message carries a backtrace).
    fn finish(self) {
        for t in &self.tallies {
            eprintln!("[{}] {:<48} allocations: {}", self.robot, t.name, t.count);
        }
        // A short call path (library frames only) for every allocating function, so that
        // all offenders are visible even though the first failed assertion stops the test.
        for t in self.tallies.iter().filter(|t| t.count > 0) {
            let Some(bt) = &t.first else { continue };
            let text = bt.to_string();
            let mut lines = text.lines();
            let mut path = Vec::new();
            while let Some(line) = lines.next() {
                let frame = line.trim();
                let ours = ["crossym::", "nalgebra::", "matrixmultiply::", "clarabel::"]
                    .iter()
                    .any(|k| frame.contains(k));
                if ours && frame.contains(": ") {
                    let at = lines.next().map(str::trim).unwrap_or_default();
                    path.push(format!("    {frame}\n        {at}"));
                }
            }
            eprintln!(
                "[{}] {} — first allocation, library frames (innermost first):\n{}",
                self.robot,
                t.name,
                path.join("\n")
            );
        }
        for t in &self.tallies {
            let at = t.first.as_ref().map(|b| b.to_string()).unwrap_or_default();
            assert_eq!(
                t.count, 0,
                "[{}] {} allocated {} times; first allocation at:\n{at}",
                self.robot, t.name, t.count
            );
        }
    }
}

// ---------------------------------------------------------------------------------------
// Fixtures.
// ---------------------------------------------------------------------------------------

/// A small 3-joint arm: revolute about z, revolute about a tilted axis, prismatic, and a
/// fixed tool joint with a rotated origin.
const ARM3_URDF: &str = r#"<?xml version="1.0"?>
<robot name="arm3">
  <link name="base"/>
  <link name="l1"/>
  <link name="l2"/>
  <link name="l3"/>
  <link name="tool"/>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.2" rpy="0 0 0"/>
    <axis xyz="0 0 1"/>
    <limit lower="-3.0" upper="3.0" effort="10" velocity="2.0"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="l1"/><child link="l2"/>
    <origin xyz="0.1 0 0.3" rpy="0.2 -0.1 0.3"/>
    <axis xyz="0 0.6 0.8"/>
    <limit lower="-2.0" upper="2.0" effort="10" velocity="2.0"/>
  </joint>
  <joint name="j3" type="prismatic">
    <parent link="l2"/><child link="l3"/>
    <origin xyz="0 0.05 0.25" rpy="0 0.4 0"/>
    <axis xyz="1 0 0"/>
    <limit lower="0.05" upper="0.3" effort="50" velocity="0.5"/>
  </joint>
  <joint name="tool_joint" type="fixed">
    <parent link="l3"/><child link="tool"/>
    <origin xyz="0.02 0 0.1" rpy="0 0 0.5"/>
  </joint>
</robot>
"#;

const PLANAR_URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/urdf/planar_dual_arm.urdf");
const RBY1_URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/robots/rby1a/model.urdf");

/// Configurations per measured function.
const N_CONFIGS: usize = 200;

fn random_q(rng: &mut StdRng, limits: &[JointLimits]) -> Vec<f64> {
    let pi = std::f64::consts::PI;
    limits
        .iter()
        .map(|l| {
            let lo = if l.lower.is_finite() { l.lower } else { -pi };
            let hi = if l.upper.is_finite() { l.upper } else { pi };
            rng.random_range(lo..=hi)
        })
        .collect()
}

/// Probe `k` of the policy audits: a posture near `q_ref` (mostly feasible) or, every third,
/// anywhere in the limits (some singular); an off-grid condition, σ alternating.
fn posture_and_condition(
    k: usize,
    rng: &mut StdRng,
    limits: &[JointLimits],
    q_ref: &[f64],
) -> (Vec<f64>, crossym::symmetry::compose::Condition) {
    let q = if k % 3 == 2 {
        random_q(rng, limits)
    } else {
        q_ref
            .iter()
            .map(|x| x + rng.random_range(-0.2..0.2))
            .collect()
    };
    let s = crossym::symmetry::compose::Condition {
        theta: rng.random_range(-3.0..3.0),
        scale: rng.random_range(0.3..1.4),
        reflection: if k % 2 == 0 { 1 } else { -1 },
    };
    (q, s)
}

fn all_finite<'a>(v: impl IntoIterator<Item = &'a f64>) -> bool {
    v.into_iter().all(|x| x.is_finite())
}

/// Audits every per-tick function of `model` with chains `specs`.
///
/// The lift and pseudo-inverse functions run twice: with the identity metric and
/// `λ = 0` (the shipped configurations), and with a diagonal metric and `λ > 0` (the
/// `J M⁻¹` product path of `DampedPinv::factor`).
fn audit(robot: &str, model: &RobotModel, specs: &[ChainSpec], seed: u64) {
    let held = HashMap::new();
    let mut audit = Audit::new(robot);
    let mut rng = StdRng::seed_from_u64(seed);

    // --- Setup (allocates, not counted). ---
    let chains: Vec<Chain> = specs
        .iter()
        .map(|s| Chain::new(model, s, &held).expect("chain builds"))
        .collect();
    let mut chain_ws: Vec<ChainWorkspace> = chains.iter().map(Chain::workspace).collect();
    let identity = KinematicsSettings {
        damping: 0.0,
        metric_diagonal: None,
        singular_manipulability: 1e-6,
    };
    let kin = Kinematics::new(model, specs, &held, &identity).expect("kinematics builds");
    let (n, m) = (kin.dof(), kin.task_dim());
    let diag: Vec<f64> = (0..n).map(|i| 0.5 + 0.25 * i as f64).collect();
    let weighted = KinematicsSettings {
        damping: 0.01,
        metric_diagonal: Some(diag),
        singular_manipulability: 1e-6,
    };
    let kin_m = Kinematics::new(model, specs, &held, &weighted).expect("kinematics builds");
    let variants: [(&str, &Kinematics); 2] = [("", &kin), (" [diagonal metric, λ=0.01]", &kin_m)];

    let qs: Vec<Vec<f64>> = (0..N_CONFIGS)
        .map(|_| random_q(&mut rng, kin.limits()))
        .collect();
    let xdots: Vec<Vec<f64>> = (0..N_CONFIGS)
        .map(|_| (0..m).map(|_| rng.random_range(-1.0..=1.0)).collect())
        .collect();
    let mut out = vec![0.0; n];
    let mut jp = DMatrix::zeros(n, m);
    let mut proj = DMatrix::zeros(n, n);

    // --- Chain::forward / Chain::jacobian. ---
    for (c, (chain, ws)) in chains.iter().zip(&mut chain_ws).enumerate() {
        let off = kin.q_offset(c);
        for q in &qs {
            let qc = &q[off..off + chain.dof()];
            let tip = audit.measure("Chain::forward", || *chain.forward(qc, ws));
            assert!(all_finite(tip.translation.vector.iter()), "finite FK");
            assert!(all_finite(tip.rotation.matrix().iter()), "finite FK");
            audit.measure("Chain::jacobian", || chain.jacobian(qc, ws));
            assert!(all_finite(ws.jacobian.iter()), "finite Jacobian");
            // Something real: the Jacobian's position rows match a finite difference.
            let h = 1e-6;
            let mut qh = qc.to_vec();
            qh[0] += h;
            let mut ws2 = chain.workspace();
            let p1 = chain.position(&qh, &mut ws2);
            let fd = (p1 - ws.tip.translation.vector) / h;
            let col = ws.jacobian.fixed_view::<3, 1>(0, 0);
            assert!(
                (fd - col).amax() < 1e-4,
                "Jacobian column 0 ≈ finite difference"
            );
        }
    }

    // --- Kinematics::forward / jacobian / lift / factor + solve / pinv matrix / projector. ---
    for (label, k) in variants {
        let mut ws: KinematicsWorkspace = k.workspace();
        for (q, xd) in qs.iter().zip(&xdots) {
            if label.is_empty() {
                let finite = audit.measure("Kinematics::forward", || {
                    all_finite(k.forward(q, &mut ws).iter())
                });
                assert!(finite, "finite stacked FK");
                audit.measure("Kinematics::jacobian", || k.jacobian(q, &mut ws));
                assert!(all_finite(ws.jac.iter()), "finite stacked Jacobian");
            }

            let report = audit.measure(&format!("Kinematics::lift{label}"), || {
                k.lift(q, xd, &mut out, &mut ws)
            });
            assert!(all_finite(&out), "finite lift");
            let regular = report.status == PinvStatus::Regular;
            if regular && k.pinv().damping() == 0.0 {
                let back = &ws.jac * DVector::from_column_slice(&out);
                let err = (back - DVector::from_column_slice(xd)).amax();
                assert!(err < 1e-6, "J J⁺ ẋ = ẋ (error {err:e})");
            }

            k.jacobian(q, &mut ws); // not counted: isolates factor + solve
            let report = audit.measure(&format!("Kinematics::factor+solve{label}"), || {
                let r = k.factor(&mut ws);
                k.solve(&mut ws, xd, &mut out);
                r
            });
            assert!(report.manipulability.is_finite(), "finite manipulability");
            assert!(all_finite(&out), "finite solve");

            audit.measure(&format!("DampedPinv::matrix{label}"), || {
                k.pinv().matrix(&mut ws.pinv, &mut jp)
            });
            assert!(all_finite(jp.iter()), "finite J⁺");
            // Something real: J⁺ ẋ from the matrix equals the solve.
            let via_matrix = &jp * DVector::from_column_slice(xd);
            let err = (via_matrix - DVector::from_column_slice(&out)).amax();
            assert!(err < 1e-9 * (1.0 + out.iter().fold(0.0f64, |a, v| a.max(v.abs()))));

            audit.measure(&format!("DampedPinv::nullspace_projector{label}"), || {
                crossym::kinematics::DampedPinv::nullspace_projector(&ws.jac, &jp, &mut proj)
            });
            assert!(all_finite(proj.iter()), "finite projector");
            if regular && k.pinv().damping() == 0.0 {
                let jn = &ws.jac * &proj;
                assert!(jn.amax() < 1e-6, "J N = 0 (got {:e})", jn.amax());
            }
        }
    }

    audit.finish();
}

// ---------------------------------------------------------------------------------------
// Tests.
// ---------------------------------------------------------------------------------------

#[test]
fn counting_allocator_counts() {
    // The instrument itself: an allocation inside the window is seen, none outside.
    let (v, count, first) = count_allocs(|| vec![1.0f64; 16]);
    assert_eq!(v.len(), 16);
    assert_eq!(count, 1);
    assert!(first.is_some());
    let (_, count, _) = count_allocs(|| 1 + 1);
    assert_eq!(count, 0);
}

#[test]
fn three_joint_arm_is_allocation_free() {
    let model = RobotModel::from_urdf_str(ARM3_URDF, "<arm3>").expect("arm3 loads");
    let mut s = ChainSpec::new("arm", "base", "tool", TaskSpace::Xyz);
    s.tool = ToolOffset {
        xyz: [0.0, 0.0, 0.05],
        rpy: [0.1, 0.0, 0.0],
    };
    audit("arm3", &model, &[s], 1);
}

#[test]
fn planar_dual_arm_is_allocation_free() {
    if !Path::new(PLANAR_URDF).exists() {
        skip::skip(format!("{PLANAR_URDF} is absent"));
        return;
    }
    let model = RobotModel::from_urdf_file(PLANAR_URDF).expect("planar loads");
    let specs = [
        ChainSpec::new("left", "base", "left_ee", TaskSpace::Xy),
        ChainSpec::new("right", "base", "right_ee", TaskSpace::Xy),
    ];
    audit("planar_dual_arm", &model, &specs, 2);
}

#[test]
fn rby1_is_allocation_free() {
    if !Path::new(RBY1_URDF).exists() {
        skip::skip(format!(
            "{RBY1_URDF} is absent (shipped in robots/rby1a/: a partial checkout?)"
        ));
        return;
    }
    let model = RobotModel::from_urdf_file(RBY1_URDF).expect("RB-Y1 loads");
    let specs = [
        ChainSpec::new("left", "link_torso_5", "ee_left", TaskSpace::Xyz),
        ChainSpec::new("right", "link_torso_5", "ee_right", TaskSpace::Xyz),
    ];
    audit("rby1", &model, &specs, 3);
}

/// A policy with deterministic pseudo-random weights (hidden [128, 128, 128], tanh) and,
/// when the config composes a letter group (`[M, R, S]` or `[M, R]`), canonical task
/// features `x̃ = g(s)⁻¹ f(q)` as the shipped letter policies have.
fn tick_policy(
    cfg: &crossym::config::Config,
    kin: &crossym::kinematics::Kinematics,
) -> crossym::policy::Policy {
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries).unwrap();
    let task = crossym::policy::TaskFeatures::for_robot(kin, &built, &cfg.composition.order).ok();
    assert!(
        task.is_some() || cfg.composition.order.is_empty(),
        "{}: letter group without task features",
        cfg.path.display()
    );
    crossym::policy::Policy::synthetic_with(
        kin.dof(),
        kin.joint_names().to_vec(),
        &[128, 128, 128],
        11,
        task,
    )
}

/// The whole control tick — FK + Jacobian, MLP forward, safety QP — allocates nothing once
/// set up, on every path of the filter: passthrough, the active-set solver and Clarabel
/// (vendored: its timers are kept across solves, vendor/README.md). With `barrier`, the QP
/// has the end-effector row and every tick passes a row (a random gradient and value) that
/// the clamp of the request often violates, which the active-set solver leaves to
/// Clarabel; the test requires Clarabel to have run.
fn audit_tick(robot: &str, cfg: &crossym::config::Config, seed: u64, barrier: bool) {
    let loaded = cfg.load_robot().unwrap();
    let kin = &loaded.kinematics;
    use crossym::safety::{Anchor, Barrier, SafetyFilter, SafetySettings, SafetyStatus};
    use crossym::symmetry::compose::Condition;
    let n = kin.dof();
    let policy = tick_policy(cfg, kin);
    assert!(policy.task_features().is_some());
    let mut pws = policy.workspace();
    let mut kws = kin.workspace();
    let mut filter = SafetyFilter::new(
        kin.limits(),
        SafetySettings {
            default_acceleration: 10.0,
            min_ee_distance: barrier.then_some(0.1),
            ..Default::default()
        },
    )
    .unwrap();
    let robot = if barrier {
        format!("{robot} + barrier row")
    } else {
        robot.to_string()
    };
    let mut rng = StdRng::seed_from_u64(seed);
    let mut v = vec![0.0; n];
    let mut out = vec![0.0; n];
    let mut gradient = vec![0.0; n];
    let mut audit = Audit::new(&robot);
    let mut statuses = HashMap::new();
    let (mut solver_ticks, mut clarabel_ticks) = (0usize, 0usize);
    for k in 0..300 {
        let q = random_q(&mut rng, kin.limits());
        let s = Condition {
            theta: rng.random_range(-3.0..3.0),
            scale: rng.random_range(0.5..1.0),
            reflection: if k % 2 == 0 { 1 } else { -1 },
        };
        gradient
            .iter_mut()
            .for_each(|g| *g = rng.random_range(-1.0..1.0));
        let row = Barrier {
            gradient: &gradient,
            value: rng.random_range(-0.5..0.5),
        };
        audit.measure("Kinematics::jacobian", || kin.jacobian(&q, &mut kws));
        audit.measure("Policy::velocity", || {
            policy.velocity(&q, &s, &mut v, &mut pws)
        });
        // Every third tick: an out-of-bounds request, so the QP solver runs; every third
        // tick repeats the last command, which is feasible unless a position bound moved.
        if k % 3 == 0 {
            v.iter_mut().for_each(|x| *x *= 50.0);
        } else if k % 3 == 1 {
            v.copy_from_slice(filter.last_command());
        }
        let before = filter.clarabel_solves();
        let rep = audit.measure("SafetyFilter::filter", || {
            // A state measured 1.5 periods ago: the horizon and its command window run.
            let now = k as f64 * 0.01;
            let anchor = Anchor::Measured {
                q: &q,
                time_s: now - 0.015,
            };
            let row = barrier.then_some(row);
            filter.filter(now, anchor, &v, Some(&kws.jac), row, &mut out)
        });
        solver_ticks += usize::from(rep.iterations > 0);
        clarabel_ticks += (filter.clarabel_solves() - before) as usize;
        *statuses.entry(format!("{:?}", rep.status)).or_insert(0) += 1;
        assert!(all_finite(&out));
    }
    eprintln!(
        "[{robot}] tick statuses: {statuses:?}; {solver_ticks} ticks ran a QP solver, \
         {clarabel_ticks} of them Clarabel"
    );
    assert!(
        statuses.contains_key(&format!("{:?}", SafetyStatus::Filtered)),
        "solver path exercised"
    );
    assert!(
        statuses.contains_key(&format!("{:?}", SafetyStatus::Passthrough)),
        "fast path exercised"
    );
    assert!(solver_ticks > 0, "[{robot}] no tick ran a QP solver");
    if barrier {
        assert!(
            clarabel_ticks >= 10,
            "[{robot}] Clarabel ran on {clarabel_ticks} ticks: its path is not exercised"
        );
    }
    audit.finish();
}

#[test]
fn control_tick_is_allocation_free() {
    use crossym::config::Config;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let planar = Config::from_file(root.join("config/letters.toml")).unwrap();
    audit_tick("planar", &planar, 5, false);
    audit_tick("planar", &planar, 7, true);
    if root.join("robots/rby1a/model.urdf").exists() {
        let rby1 = Config::from_file(root.join("config/rby1-letters.toml")).unwrap();
        audit_tick("rby1", &rby1, 6, false);
        audit_tick("rby1", &rby1, 8, true);
    } else {
        skip::skip("rby1 tick: robots/rby1a/model.urdf absent");
    }
}

/// The node's own tick — `NodeCore::tick` with the end-effector barrier — allocates nothing
/// on any tick, whichever path its QP takes (passthrough, active set, Clarabel), and neither
/// does the validation of each joint state the
/// control thread reads (`NodeCore::on_joint_state`) nor a separate gate's hand-over
/// (`InputGate::on_joint_state` + `load_inputs`, as the offline tools use).
#[test]
fn node_core_tick_is_allocation_free() {
    use crossym::config::Config;
    use crossym::control::{NodeConfig, NodeCore};
    use crossym::msg;
    use crossym::safety::{SafetySettings, SafetyStatus};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cfg = Config::from_file(root.join("config/letters.toml")).unwrap();
    let kin = cfg.load_robot().unwrap().kinematics;
    let n = kin.dof();
    let names = kin.joint_names().to_vec();
    let policy = tick_policy(&cfg, &kin);
    assert!(policy.task_features().is_some());
    let safety = SafetySettings {
        min_ee_distance: Some(0.5),
        ..Default::default()
    };
    let limits = kin.limits().to_vec();
    let mut core = NodeCore::new(kin, policy, safety, NodeConfig::default()).unwrap();
    let mut gate = core.input_gate();
    let mut cmd = core.command();
    let mut m = msg::JointState {
        name: names.clone(),
        position: vec![0.0; n],
        ..Default::default()
    };
    // A smooth path through the workspace (fast path) with a jump every 50 ticks (solver).
    let mut rng = StdRng::seed_from_u64(21);
    let mut base = random_q(&mut rng, &limits);
    let mut statuses = HashMap::new();
    for k in 0..300 {
        if k % 50 == 49 {
            base = random_q(&mut rng, &limits);
        }
        for (j, (p, b)) in m.position.iter_mut().zip(&base).enumerate() {
            *p = b + 0.2 * (0.02 * k as f64 + j as f64).sin();
        }
        let now = k as f64 * 0.01;
        let (r, count, _) = if k % 2 == 0 {
            count_allocs(|| core.on_joint_state(&m, now))
        } else {
            count_allocs(|| {
                let r = gate.on_joint_state(&m, now);
                core.load_inputs(gate.inputs());
                r
            })
        };
        assert!(r.is_ok());
        assert_eq!(count, 0, "joint state validation allocated");
        let (rep, count, first) = count_allocs(|| core.tick(now, &mut cmd));
        assert!(cmd.velocities.iter().all(|v| v.is_finite()));
        let text = first.map(|b| b.to_string()).unwrap_or_default();
        assert_eq!(
            count, 0,
            "node tick {k} ({:?}) allocated:\n{text}",
            rep.safety
        );
        *statuses.entry(format!("{:?}", rep.safety)).or_insert(0) += 1;
    }
    eprintln!("node tick: 300 ticks with 0 allocations; statuses {statuses:?}");
    assert!(
        statuses.contains_key(&format!("{:?}", Some(SafetyStatus::Filtered))),
        "no tick ran the QP"
    );
}

/// A canonicalised policy `π(q, s) = dΦ_g π₀(Φ_g⁻¹ q)` (issue 18) allocates nothing per
/// call — inverse flows, push-forward, `π₀` — on the planar arms and on RB-Y1, whether the
/// flows succeed or stop at a singularity; and neither does the node's tick with it, nor the
/// gate's feasibility check of an incoming condition.
#[test]
fn canonicalised_policy_and_its_node_tick_are_allocation_free() {
    use crossym::config::Config;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut configs = vec![("planar", "config/letters.toml")];
    if root.join("robots/rby1a/model.urdf").exists() {
        configs.push(("rby1", "config/rby1-letters.toml"));
    } else {
        skip::skip("rby1 canonicalised: robots/rby1a/model.urdf absent");
    }
    for (robot, file) in configs {
        let cfg = Config::from_file(root.join(file)).unwrap();
        let kin = cfg.load_robot().unwrap().kinematics;
        let n = kin.dof();
        let policy = crossym::pipeline::canonicalise(&cfg, &kin, tick_policy(&cfg, &kin)).unwrap();
        assert!(policy.composition().is_some());
        let mut ws = policy.workspace();
        let mut v = vec![0.0; n];
        let q_ref = cfg
            .check
            .reference_q
            .clone()
            .unwrap_or_else(|| vec![0.0; n]);
        let mut rng = StdRng::seed_from_u64(31);
        let (mut ok, mut failed) = (0usize, 0usize);
        for k in 0..60 {
            let (q, s) = posture_and_condition(k, &mut rng, kin.limits(), &q_ref);
            let (r, count, first) = count_allocs(|| policy.velocity(&q, &s, &mut v, &mut ws));
            let text = first.map(|b| b.to_string()).unwrap_or_default();
            assert_eq!(
                count, 0,
                "[{robot}] canonicalised velocity ({r:?}) allocated:\n{text}"
            );
            if r.is_ok() {
                assert!(all_finite(&v));
                ok += 1;
            } else {
                failed += 1;
            }
        }
        eprintln!("[{robot}] canonicalised velocity: {ok} evaluated, {failed} stopped at a flow failure, 0 allocations");
        assert!(ok > 0, "[{robot}] no condition was feasible");

        // The node's tick and the gate's feasibility check.
        node_ticks_allocate_nothing(
            &format!("[{robot}] canonicalised"),
            kin,
            policy,
            &q_ref,
            &mut rng,
            0.3..1.4,
        );
    }
}

/// A task-space head (issue 17) evaluates and ticks the node without allocating, on both
/// robots: FK with Jacobian, the `m × m` factor, the head's network, the group's action —
/// with the plain lift and with the null-space term (issue 37).
#[test]
fn task_head_and_its_node_tick_are_allocation_free() {
    use crossym::config::Config;
    use crossym::policy::SubGroup;
    use crossym::policy::{task_coordinate_names, AnyPolicy, Policy};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut configs = vec![("planar", "config/letters.toml")];
    if root.join("robots/rby1a/model.urdf").exists() {
        configs.push(("rby1", "config/rby1-letters.toml"));
    } else {
        skip::skip("rby1 task head: robots/rby1a/model.urdf absent");
    }
    for (robot, file) in configs {
        let cfg = Config::from_file(root.join(file)).unwrap();
        let kin = cfg.load_robot().unwrap().kinematics;
        let (n, m) = (kin.dof(), kin.task_dim());
        let mut head = Policy::synthetic(m, task_coordinate_names(&kin), &[64, 64], 5);
        head.meta.task_head =
            Some(crossym::pipeline::group_map(&cfg, &kin, SubGroup::MRT).unwrap());
        let plain = AnyPolicy::new(head, &kin).unwrap();
        assert!(plain.task_head().is_some());
        // The lift with the null-space term (issue 37), as `[redundancy]` adds it.
        let q_rest = cfg.check.reference_q.clone().unwrap();
        let term = crossym::kinematics::NullSpaceTerm::new(
            crossym::kinematics::NullSpaceSettings {
                weight: 1.0,
                ..Default::default()
            },
            &q_rest,
            kin.limits(),
        )
        .unwrap();
        let (with_term, added) = plain.clone().with_null_space(term).unwrap();
        assert!(added);
        for (variant, policy) in [("", plain), (" + null space", with_term)] {
            let robot = format!("{robot}{variant}");
            let kin = kin.clone();
            let mut ws = policy.workspace();
            let mut v = vec![0.0; n];
            let q_ref = cfg
                .check
                .reference_q
                .clone()
                .unwrap_or_else(|| vec![0.0; n]);
            let mut rng = StdRng::seed_from_u64(37);
            let mut ok = 0usize;
            for k in 0..60 {
                let (q, s) = posture_and_condition(k, &mut rng, kin.limits(), &q_ref);
                let (r, count, first) = count_allocs(|| policy.velocity(&q, &s, &mut v, &mut ws));
                let text = first.map(|b| b.to_string()).unwrap_or_default();
                assert_eq!(count, 0, "[{robot}] task head ({r:?}) allocated:\n{text}");
                if r.is_ok() {
                    assert!(all_finite(&v));
                    ok += 1;
                }
            }
            assert!(ok > 0, "[{robot}] the task head never evaluated");

            node_ticks_allocate_nothing(
                &format!("[{robot}] task head"),
                kin,
                policy,
                &q_ref,
                &mut rng,
                0.5..1.0,
            );
        }
    }
}

/// 120 node ticks along a path around `q_ref` with a condition every 20 ticks (scales drawn
/// from `scales`) and an operator request before every tick (pause, resume, reset, every
/// runtime parameter, as the control thread applies them between ticks): the gate's
/// condition check, the requests and every tick allocate nothing.
fn node_ticks_allocate_nothing(
    label: &str,
    kin: crossym::kinematics::Kinematics,
    policy: crossym::policy::AnyPolicy,
    q_ref: &[f64],
    rng: &mut StdRng,
    scales: std::ops::Range<f64>,
) {
    use crossym::control::{NodeConfig, NodeCore};
    use crossym::msg;
    use crossym::safety::{SafetySettings, SafetyStatus};
    let limits = kin.limits().to_vec();
    let names = kin.joint_names().to_vec();
    let mut core = NodeCore::new(
        kin,
        policy,
        SafetySettings::default(),
        NodeConfig::default(),
    )
    .unwrap();
    let mut gate = core.input_gate();
    let mut cmd = core.command();
    let mut m = msg::JointState {
        name: names,
        position: q_ref.to_vec(),
        ..Default::default()
    };
    let mut filtered = 0usize;
    for k in 0..120 {
        for (j, (p, b)) in m.position.iter_mut().zip(q_ref).enumerate() {
            *p = (b + 0.1 * (0.02 * k as f64 + j as f64).sin())
                .clamp(limits[j].lower, limits[j].upper);
        }
        let now = k as f64 * 0.01;
        assert!(gate.on_joint_state(&m, now).is_ok());
        if k % 20 == 5 {
            let c = msg::SymmetryCondition {
                theta: rng.random_range(-3.0..3.0),
                scale: rng.random_range(scales.clone()),
                reflection: if k % 40 == 5 { 1 } else { -1 },
                ..Default::default()
            };
            let (r, count, first) = count_allocs(|| gate.on_condition(&c));
            let text = first.map(|b| b.to_string()).unwrap_or_default();
            assert_eq!(
                count, 0,
                "{label} condition check ({r:?}) allocated:\n{text}"
            );
        }
        let request = operator_request(k, &core);
        let (rep, count, first) = count_allocs(|| {
            let _ = core.apply(request);
            core.load_inputs(gate.inputs());
            core.tick(now, &mut cmd)
        });
        assert!(cmd.velocities.iter().all(|v| v.is_finite()));
        let text = first.map(|b| b.to_string()).unwrap_or_default();
        assert_eq!(
            count, 0,
            "{label} node tick {k} ({:?}) allocated:\n{text}",
            rep.safety
        );
        filtered += usize::from(rep.safety == Some(SafetyStatus::Filtered));
    }
    eprintln!("{label}: 120 ticks with 0 allocations, {filtered} filtered by the QP");
}

/// The operator request applied before tick `k`: each kind in turn, with values inside and
/// outside what the node accepts.
fn operator_request(
    k: usize,
    core: &crossym::control::NodeCore,
) -> crossym::control::OperatorRequest {
    use crossym::control::OperatorRequest as R;
    let max_t = core.runtime_bounds().max_stale_timeout_s;
    match k % 12 {
        0 => R::Pause(true),
        1 => R::Pause(false),
        2 => R::VelocityScale(0.5 + 0.04 * (k % 10) as f64),
        3 => R::VelocityScale(f64::NAN),
        4 => R::StaleTimeout(0.8 * max_t),
        5 => R::Margin(0.01),
        6 => R::Margin(1e9),
        7 => R::AcceptUntrained(k % 24 == 7),
        8 => R::DefaultCondition(crossym::symmetry::compose::Condition {
            theta: 0.1,
            scale: 1.0,
            reflection: -1,
        }),
        9 => R::Reset,
        10 => R::StaleTimeout(max_t),
        _ => R::VelocityScale(1.0),
    }
}

/// The singularity band's look-ahead (a second Jacobian, every chain's condition number by
/// Jacobi rotations) allocates nothing: the planar left arm nearly stretched, moving toward
/// and away from the singularity.
#[test]
fn singularity_band_is_allocation_free() {
    use crossym::control::node::{SingularityBand, SingularityStatus};
    use crossym::control::SingularitySettings;
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cfg = crossym::config::Config::from_file(root.join("config/letters.toml")).unwrap();
    let kin = cfg.load_robot().unwrap().kinematics;
    let mut band = SingularityBand::new(SingularitySettings::default(), &kin);
    let mut ws = kin.workspace();
    let q = [0.5, 0.03, 0.02, 0.01, -0.5, -0.8, -0.6, -0.4];
    kin.jacobian(&q, &mut ws);
    let mut seen = Vec::new();
    for sign in [-1.0, 1.0] {
        let mut v = [0.0, sign * 0.3, sign * 0.2, sign * 0.1, 0.0, 0.0, 0.0, 0.0];
        let (r, count, first) = count_allocs(|| band.apply(&kin, &ws, &q, &mut v, 0.01));
        let text = first.map(|b| b.to_string()).unwrap_or_default();
        assert_eq!(count, 0, "band ({r:?}) allocated:\n{text}");
        seen.push(r.status);
    }
    assert_eq!(seen, [SingularityStatus::Halt, SingularityStatus::Clear]);
}
