//! Invalid input from the outside: the robot's joint states turn invalid (a NaN position, then a
//! controlled joint missing) while the arm moves against a joint limit, and the robot keeps
//! integrating the node's velocity commands meanwhile. The limits of the planar letters
//! robot are tightened to `rest ± 0.35 rad` and `0.4 rad/s` in a copy of its URDF; the node
//! (`crossym node`) runs as a separate process over DDS against
//!
//! - an independent robot, `tests/peer/fault_robot.py` (Eclipse Cyclone DDS from PyPI, no
//!   crossym code), which counts limit violations from its own integrated positions, and
//! - `crossym mock-hw` with its `nan_position` / `missing_joint` faults (`[mock_hw]`).
//!
//! Both must see no position beyond the tightened limits and no non-finite command. Run
//! inside `tools/netns-run` (as `.ci/run` does); each run has its own
//! ROS_DOMAIN_ID (81–84), so the tests may run in parallel with the others.

use std::path::PathBuf;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crossym::config::Config;
use crossym::sim::MockHwSummary;
use serde_json::Value;

use crate::common;
use crate::common::{log_tail, Proc};

/// Half-width of the tightened position range around the rest posture (rad).
const HALF_RANGE: f64 = 0.35;
/// Tightened velocity limit (rad/s).
const VELOCITY: f64 = 0.4;

fn crossym_cmd(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_crossym"));
    c.args(args);
    c
}

/// The letters config with its URDF's limits tightened, written into a temp dir.
struct Tight {
    dir: PathBuf,
    urdf: PathBuf,
    config: PathBuf,
    /// Controlled joints in command order.
    joints: Vec<String>,
    /// The rest posture (rad): `[check] reference_q`, where mock-hw starts.
    rest: Vec<f64>,
}

/// Sets `attr="…"` in one XML element's text (the attribute must be present).
fn set_attr(line: &str, attr: &str, value: f64) -> String {
    let key = format!(" {attr}=\"");
    let start = line
        .find(&key)
        .unwrap_or_else(|| panic!("no {attr} in {line}"))
        + key.len();
    let end = start + line[start..].find('"').unwrap();
    format!("{}{value:?}{}", &line[..start], &line[end..])
}

/// `config/letters.toml` on a copy of its URDF with the controlled joints' limits set to
/// `rest ± 0.35 rad` and `0.4 rad/s` (acceleration unchanged), paths made absolute and
/// `[mock_hw]` replaced by `mock_hw` (TOML body of that table).
fn tightened(tag: &str, mock_hw: &str) -> Tight {
    let root = common::root();
    let src = root.join("config/letters.toml");
    let cfg = Config::from_file(&src).unwrap();
    let robot = cfg.load_robot().unwrap();
    let joints: Vec<String> = robot.kinematics.joint_names().to_vec();
    // Where mock-hw starts (`[mock_hw] initial_q`, else `[check] reference_q`).
    let rest = cfg.start_q().expect("letters.toml has [check] reference_q");
    assert_eq!(rest.len(), joints.len());
    let dir = common::temp_dir(&format!("faults-{tag}"));
    let urdf_src = cfg.resolve(&cfg.robot.urdf);
    let text = std::fs::read_to_string(&urdf_src).unwrap();
    let mut out = String::new();
    let mut joint: Option<usize> = None;
    let mut tightened = 0;
    for line in text.lines() {
        if let Some(p) = line.find("<joint name=\"") {
            let rest_of = &line[p + 13..];
            let name = &rest_of[..rest_of.find('"').unwrap()];
            joint = joints.iter().position(|j| j == name);
        }
        if line.contains("<limit ") {
            if let Some(k) = joint.take() {
                let mut l = set_attr(line, "lower", rest[k] - HALF_RANGE);
                l = set_attr(&l, "upper", rest[k] + HALF_RANGE);
                l = set_attr(&l, "velocity", VELOCITY);
                out.push_str(&l);
                out.push('\n');
                tightened += 1;
                continue;
            }
        }
        out.push_str(line);
        out.push('\n');
    }
    assert_eq!(
        tightened,
        joints.len(),
        "every controlled joint has a <limit>"
    );
    let urdf = dir.join("planar_dual_arm_tight.urdf");
    std::fs::write(&urdf, out).unwrap();

    let toml = std::fs::read_to_string(&src).unwrap();
    let root_s = format!("\"{}/", root.display());
    let mut toml = toml.replace("\"../", &root_s);
    let urdf_abs = format!("urdf = \"{}/urdf/planar_dual_arm.urdf\"", root.display());
    assert!(
        toml.contains(&urdf_abs),
        "letters.toml names its URDF as expected"
    );
    toml = toml.replace(&urdf_abs, &format!("urdf = \"{}\"", urdf.display()));
    if let Some(p) = toml.find("\n[mock_hw]") {
        toml.truncate(p + 1);
    }
    toml.push_str("\n[mock_hw]\n");
    toml.push_str(mock_hw);
    let config = dir.join("letters_tight.toml");
    std::fs::write(&config, toml).unwrap();

    // The copy loads, and the node and mock-hw will see the tightened limits.
    let c = Config::from_file(&config).unwrap();
    let lim = c.load_robot().unwrap().kinematics.limits().to_vec();
    for (k, l) in lim.iter().enumerate() {
        assert!(
            (l.upper - rest[k] - HALF_RANGE).abs() < 1e-12
                && (rest[k] - l.lower - HALF_RANGE).abs() < 1e-12
                && l.velocity == VELOCITY,
            "{}: {l:?}",
            joints[k]
        );
    }
    Tight {
        dir,
        urdf,
        config,
        joints,
        rest,
    }
}

/// The independent fault robot needs PyPI cyclonedds: missing, the test fails (as the
/// `dds` and `teach` tests do) rather than passing without its outsider evidence.
fn require_cyclonedds() {
    let ok = Command::new("python3")
        .args(["-c", "import cyclonedds.domain"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    assert!(
        ok,
        "PyPI cyclonedds is missing (run `bash tests/peer/install.sh`; .ci/run does): the \
         independent fault robot cannot run"
    );
}

/// One run of the independent robot: the seed (condition order, random choices), which
/// joint is corrupted, which joint's approach to which bound starts the faults, the
/// warm-up before it may (s) and the condition switch period (s).
struct RobotRun {
    seed: u64,
    fault_joint: &'static str,
    trigger_joint: &'static str,
    bound: &'static str,
    warmup_s: f64,
    switch_s: f64,
}

/// Starts a node on `t`'s config in `domain` (with `policy` instead of the config's when
/// given), runs `runs` of the fault robot against it one after the other, stops the node;
/// the robots' JSON reports.
fn robot_runs(
    t: &Tight,
    domain: u16,
    policy: Option<&str>,
    runs: &[RobotRun],
) -> Vec<(String, Value)> {
    let node_log = t.dir.join(format!("node-{domain}.log"));
    let mut args = vec!["node", "--config", t.config.to_str().unwrap()];
    if let Some(p) = policy {
        args.extend(["--policy", p]);
    }
    let mut node = Proc::spawn(crossym_cmd(&args), "node", domain, &node_log);
    let script = common::root().join("tests/peer/fault_robot.py");
    let rest: Vec<String> = t.rest.iter().map(|x| format!("{x:?}")).collect();
    let mut reports = Vec::new();
    for r in runs {
        let label = format!(
            "domain {domain} ({}) seed {} fault {} trigger {} {} after {} s",
            policy.map_or("config's policy", |_| "--policy"),
            r.seed,
            r.fault_joint,
            r.trigger_joint,
            r.bound,
            r.warmup_s
        );
        let json = t.dir.join(format!("robot-{domain}-{}.json", r.seed));
        let log = t.dir.join(format!("robot-{domain}-{}.log", r.seed));
        let mut cmd = Command::new("python3");
        cmd.arg(&script)
            .arg("--urdf")
            .arg(&t.urdf)
            .args(["--joints", &t.joints.join(",")])
            .args(["--initial-q", &rest.join(",")])
            .args(["--domain", &domain.to_string()])
            .args(["--seed", &r.seed.to_string()])
            .args(["--fault-joint", r.fault_joint])
            .args(["--trigger-joint", r.trigger_joint])
            .args(["--bound", r.bound])
            .args(["--warmup-s", &r.warmup_s.to_string()])
            .args(["--switch-s", &r.switch_s.to_string()])
            .args(["--timeout", "20", "--json"])
            .arg(&json);
        let mut p = Proc::spawn(cmd, "fault_robot.py", domain, &log);
        let rc = p.wait(Duration::from_secs(60), &log);
        let report: Value = std::fs::read_to_string(&json)
            .ok()
            .and_then(|s| serde_json::from_str(&s).ok())
            .unwrap_or_else(|| {
                panic!(
                    "{label}: no report (exit {rc})\n{}\n--- node log\n{}",
                    log_tail(&log),
                    log_tail(&node_log)
                )
            });
        assert_ne!(
            rc,
            2,
            "{label}: nothing received from the node\n{}\n--- node log\n{}",
            log_tail(&log),
            log_tail(&node_log)
        );
        eprintln!("{label}: {}", log_tail(&log));
        reports.push((label, report));
    }
    assert_eq!(node.term(), 0, "node exit code\n{}", log_tail(&node_log));
    reports
}

/// The independent Cyclone DDS robot, faults injected while a joint moves toward a
/// tightened bound, against the default task-space head and the joint-space π_MRT: no
/// position beyond the limits, no non-finite command, in every run.
#[test]
fn independent_robot_input_faults_at_tight_limits() {
    require_cyclonedds();
    let t = tightened("robot", "rate_hz = 200.0\n");
    let run = |seed, fault_joint, trigger_joint, bound, warmup_s, switch_s| RobotRun {
        seed,
        fault_joint,
        trigger_joint,
        bound,
        warmup_s,
        switch_s,
    };
    // Two nodes in parallel (own domains), each driving three robot runs in turn, the
    // corrupted joint being the moving one or another.
    // The config's default policy, the task-space head: its lift ignores the tightened
    // limits, so joints run into their bounds within the first seconds after a condition
    // and stay pinned (2026-12-03: with 2 s switches and these warm-ups, 1 of 6 runs saw an
    // approach at >= 0.3 rad/s; with a 2.5 s warm-up and 1 s switches, 2 of 5): the faults
    // start at the first approach of any joint, conditions switch every second.
    let head = [
        run(1, "random", "any", "any", 0.5, 1.0),
        run(7, "right_joint2", "any", "any", 0.5, 1.0),
        run(9, "right_joint4", "any", "lower", 0.5, 1.0),
    ];
    // The joint-space π_MRT, which sweeps its joints through the range: approaches after
    // condition switches, chosen joints and bounds.
    let joint = [
        run(2, "left_joint1", "left_joint1", "upper", 0.5, 2.0),
        run(8, "random", "any", "any", 2.5, 2.0),
        run(9, "left_joint3", "right_joint2", "lower", 0.5, 2.0),
    ];
    let joint_policy = common::root().join("data/policies/pi_mrt_planar.safetensors");
    let joint_policy = joint_policy.to_str().unwrap();
    let t0 = Instant::now();
    let reports: Vec<(String, Value)> = std::thread::scope(|s| {
        let ha = s.spawn(|| robot_runs(&t, 81, None, &head));
        let hb = s.spawn(|| robot_runs(&t, 82, Some(joint_policy), &joint));
        let mut r = ha.join().unwrap();
        r.extend(hb.join().unwrap());
        r
    });
    eprintln!(
        "fault robot: {} runs in {:.1} s",
        reports.len(),
        t0.elapsed().as_secs_f64()
    );
    let mut failures = Vec::new();
    let mut approached = 0;
    for (label, r) in &reports {
        let n = |k: &str| r[k].as_u64().unwrap_or(u64::MAX);
        assert!(
            n("commands_received") > 300,
            "{label}: too few commands: {r}"
        );
        assert!(
            n("ticks") > 500 && r["phases"].get("after").is_some(),
            "{label}: the run did not reach its last phase: {r}"
        );
        assert_eq!(n("wrong_length_commands"), 0, "{label}: {r}");
        // The robot runs on simulated time; a loop that stalled often did not test the node
        // at 100 Hz: a failed precondition, said as such.
        assert!(
            n("late_ticks") * 50 <= n("ticks"),
            "{label}: precondition failed, the independent robot's loop stalled on {} of {} \
             ticks (more than 2%): the machine was too busy for this run to say anything: {r}",
            n("late_ticks"),
            n("ticks")
        );
        if r["trigger"]["kind"] == "approach" {
            approached += 1;
        }
        if n("violations") != 0 || n("nonfinite_commands") != 0 {
            failures.push(format!(
                "{label}: {} position and {} velocity violations (worst excess {:.3} mrad, {} in \
                 phase {}; by phase {}), {} non-finite commands, trigger {}",
                r["position_violations"],
                r["velocity_violations"],
                r["worst_excess_rad"].as_f64().unwrap_or(f64::NAN) * 1e3,
                r["worst_joint"],
                r["worst_phase"],
                r["violations_by_phase"],
                r["nonfinite_commands"],
                r["trigger"]
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "limit violations seen by the independent robot:\n{}",
        failures.join("\n")
    );
    assert!(
        approached * 2 >= reports.len(),
        "most runs must inject the faults while a joint approaches a bound: {approached} of {}",
        reports.len()
    );
}

/// `crossym mock-hw` with a `nan_position` or `missing_joint` fault window that opens
/// while a joint moves toward a tightened bound; the node runs against it. The mock's
/// summary shows the fault happened and no limit was crossed.
fn mock_hw_fault(kind: &str, domain: u16) -> (MockHwSummary, i32) {
    // From the first approach to a bound (within 0.03 rad, at >= 0.1 rad/s): the
    // fault window opens while the node drives a joint toward it.
    let t = tightened(
        &format!("mock-{kind}"),
        &format!(
            "rate_hz = 200.0\nfault = \"{kind}\"\nfault_after_s = 0.0\nfault_near_limit = 0.03\n\
             fault_duration_s = 2.0\nfault_joint = \"left_joint2\"\nviolation_tolerance = 1e-9\n"
        ),
    );
    let cfg_s = t.config.to_str().unwrap().to_string();
    let summary = t.dir.join("mock.json");
    let (hw_log, node_log) = (t.dir.join("mock.log"), t.dir.join("node.log"));
    let mut hw = Proc::spawn(
        crossym_cmd(&[
            "mock-hw",
            "--config",
            &cfg_s,
            "--summary",
            summary.to_str().unwrap(),
        ]),
        "mock-hw",
        domain,
        &hw_log,
    );
    let mut node = Proc::spawn(
        crossym_cmd(&["node", "--config", &cfg_s]),
        "node",
        domain,
        &node_log,
    );
    // Events, with generous deadlines: the fault begins (mock-hw logs it), the node sees its
    // joint states go stale and, once the 2 s window is over, fresh again; then 2.5 s of
    // valid joint states are wanted after it (4 s waited: a loaded machine's mock may lag
    // the wall clock).
    let deadline = Duration::from_secs(30);
    let began = common::wait_for_text(&hw_log, "mock_hw: fault ", deadline);
    let recovered = began
        && common::wait_for_text_after(&node_log, "joint states stale", "fresh again", deadline);
    if recovered {
        std::thread::sleep(Duration::from_secs(4));
    }
    assert_eq!(node.term(), 0, "node exit code\n{}", log_tail(&node_log));
    std::thread::sleep(Duration::from_millis(300));
    let rc = hw.term();
    let s: MockHwSummary = serde_json::from_str(&std::fs::read_to_string(&summary).unwrap())
        .unwrap_or_else(|e| panic!("{e}\n{}", log_tail(&hw_log)));
    assert!(
        recovered,
        "{kind}: the fault never began or the node never saw valid joint states after it\n{}\n--- node\n{}",
        log_tail(&hw_log),
        log_tail(&node_log)
    );
    eprintln!("mock-hw {kind}: {}", log_tail(&hw_log));
    (s, rc)
}

#[test]
fn mock_hw_input_faults_at_tight_limits() {
    let runs: Vec<(&str, (MockHwSummary, i32))> = std::thread::scope(|s| {
        let a = s.spawn(|| mock_hw_fault("nan_position", 83));
        let b = s.spawn(|| mock_hw_fault("missing_joint", 84));
        vec![
            ("nan_position", a.join().unwrap()),
            ("missing_joint", b.join().unwrap()),
        ]
    });
    for (kind, (s, rc)) in &runs {
        let started = s.fault_started_s.unwrap_or_else(|| {
            panic!("{kind}: the fault never started (no joint approached a bound): {s:?}")
        });
        assert!(
            s.fault_trigger_joint.is_some(),
            "{kind}: started by approach: {s:?}"
        );
        // 2 s at 200 Hz of corrupted joint states, then valid ones again.
        assert!(
            (390..=410).contains(&s.joint_states_faulted),
            "{kind}: {} faulty joint states (fault at {started:.2} s)",
            s.joint_states_faulted
        );
        assert!(
            s.steps as f64 / 200.0 > started + 2.5,
            "{kind}: valid states after the fault window: {s:?}"
        );
        assert!(s.commands_received > 300, "{kind}: {s:?}");
        assert_eq!(
            s.commands_invalid, 0,
            "{kind}: non-finite or wrong-length commands"
        );
        let worst = s
            .violations
            .iter()
            .map(|v| (v.value - v.bound).abs())
            .fold(0.0, f64::max);
        assert_eq!(
            s.violation_count,
            0,
            "{kind}: limit violations (worst excess {:.3} mrad, fault at {started:.2} s, trigger \
             {:?}): {:?}",
            worst * 1e3,
            s.fault_trigger_joint,
            &s.violations[..s.violations.len().min(5)]
        );
        assert_eq!(*rc, 0, "{kind}: mock-hw exit code");
    }
}
