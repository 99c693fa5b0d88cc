//! The node against a physics RB-Y1 (a robot with dynamics): the vendor SDK's MuJoCo
//! model behind an emulation of the vendor's ROS 2 stack (`physics/rby1_mujoco.py`, Cyclone
//! DDS, a separate process), driven by `crossym demo --plant mujoco` over DDS.
//!
//! Needs `robots/rby1a/` (the vendor's model files, shipped) and PyPI `mujoco` + `cyclonedds`
//! (`physics/install.sh`, run by `.ci/run`); missing either is a failure, not a skip.
//! The tests run in real time against a robot paced by the wall clock: `.ci/run` runs them
//! in their own step, one at a time (`--ignored --test-threads=1`), not beside the suite,
//! and checks that the step ran as many as this file (and `physics_*.rs`) declare.

use std::path::{Path, PathBuf};
use std::time::Duration;

use super::common::{crossym, rby1_dir, root, temp_dir};

/// The RB-Y1 letters config with absolute paths and `edit` applied (text replacements).
fn letters_config(dir: &Path, edit: &[(&str, &str)]) -> PathBuf {
    rby1_config("rby1-letters.toml", dir, edit)
}

/// A shipped RB-Y1 config (`config/<name>`) with absolute paths and `edit` applied.
fn rby1_config(name: &str, dir: &Path, edit: &[(&str, &str)]) -> PathBuf {
    let mut text = std::fs::read_to_string(root().join("config").join(name)).unwrap();
    text = text
        .replace("\"../robots/", &format!("\"{}/robots/", root().display()))
        .replace("\"../data/", &format!("\"{}/data/", root().display()));
    for (from, to) in edit {
        assert!(text.contains(from), "config has no `{from}`");
        text = text.replace(from, to);
    }
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The physics robot's Python packages and the vendor's MuJoCo model (both physics test
/// modules).
pub(super) fn require_physics() {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import mujoco, cyclonedds.domain"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "python3 cannot import mujoco and cyclonedds: run `bash physics/install.sh`"
    );
    assert!(
        rby1_dir().join("vendor-sdk/mujoco/model_act.xml").exists(),
        "the vendor's MuJoCo model is missing: robots/rby1a/vendor-sdk/mujoco"
    );
}

struct Run {
    /// Closed-loop RMSE of each step (m).
    rmse: Vec<f64>,
    /// The node's log.
    node_log: String,
    /// The physics robot's summary.
    summary: serde_json::Value,
    /// The demo's exit status and output.
    ok: bool,
    output: String,
}

/// `crossym demo --plant mujoco` on `config` with `conditions`, the first `seconds` of the
/// letter each.
fn demo(config: &Path, out: &Path, conditions: &[&str], seconds: &str) -> Run {
    demo_on("mujoco", config, out, conditions, seconds)
}

/// `crossym demo --plant <plant>` (`mujoco` or `kinematic`).
fn demo_on(plant: &str, config: &Path, out: &Path, conditions: &[&str], seconds: &str) -> Run {
    let mut cmd = crossym([
        "demo",
        "--no-isolation",
        "--plant",
        plant,
        "--config",
        config.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--duration-s",
        seconds,
    ]);
    for c in conditions {
        cmd.arg("--condition").arg(c);
    }
    let o = cmd.output().expect("crossym demo starts");
    let output = format!(
        "{}\n{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let rmse = csv_column(out, 5).unwrap_or_default();
    let node_log = std::fs::read_to_string(out.join("node.log")).unwrap_or_default();
    let summary = serde_json::from_str(
        &std::fs::read_to_string(out.join("mock_hw_summary.json")).unwrap_or_default(),
    )
    .unwrap_or(serde_json::Value::Null);
    Run {
        rmse,
        node_log,
        summary,
        ok: o.status.success(),
        output,
    }
}

/// A run the node followed through: at most one restart (the demo's teleport to the
/// start), the robot never reported as not following, no limit crossed.
fn assert_followed(r: &Run) {
    let n = restarts(&r.node_log);
    assert!(
        n <= 1,
        "{n} restarts (the teleport makes one)\n{}",
        r.node_log
    );
    assert!(
        !r.node_log.contains("does not follow"),
        "robot reported as not following:\n{}",
        r.node_log
    );
    assert_eq!(r.summary["violation_count"], 0, "{}", r.summary);
}

/// The largest "(N in all" count of the node's restart log lines (0 when none).
fn restarts(log: &str) -> u64 {
    log.lines()
        .filter(|l| l.contains("commands restarted from the measured state"))
        .filter_map(|l| {
            let i = l.find(" in all")?;
            let head = &l[..i];
            head[head.rfind('(')? + 1..].parse().ok()
        })
        .max()
        .unwrap_or(0)
}

/// A lagging, sagging RB-Y1 (no gravity compensation) draws a rotated letter (30°) with the
/// shipped letters policy (the task-space head of `config/rby1-letters.toml`): under the
/// paper's resampled protocol (the demo's `RMSE paper protocol` column, the script the
/// authors scored their real robot with) at or below the paper's real-robot 0.033 m —
/// measured 0.0059 m (closed loop 0.0118 m over time, offline rollout 0.0142 m), so the bound
/// has 5.6× headroom; the old rule's run below scores 0.061 m. The demo itself passes (its
/// closed loop within 1.5× the offline rollout, no error status, the bag replays), with
/// one restart (the demo's teleport to the start) and no limit crossed. The same run with
/// the fixed 2 mrad rule of before (no lag window) is seen to fail: the node restarts again
/// and again and then reports the robot as not following.
#[test]
#[ignore = "run by .ci/run on its own (one at a time: real time on 2 cores)"]
fn physics_rby1_draws_a_letter_and_the_old_tracking_rule_does_not() {
    require_physics();
    let dir = temp_dir("physics-letter");
    let cfg = letters_config(&dir, &[]);
    let r = demo(&cfg, &dir.join("new"), &["0.5235987755982988:1:1"], "6");
    assert_eq!(r.rmse.len(), 1, "{}", r.output);
    let paper = paper_column(&dir.join("new"));
    assert!(
        paper[0] <= 0.033,
        "paper-protocol RMSE {} m on the physics robot, above the paper's real robot's \
         0.033 m (measured 0.0059 m: 5.6× headroom)\n{}",
        paper[0],
        r.output
    );
    assert!(r.ok, "the demo failed on the physics robot:\n{}", r.output);
    assert_followed(&r);
    assert!(r.summary["commands_received"].as_u64().unwrap() > 300);
    assert_eq!(r.summary["commands_invalid"], 0, "{}", r.summary);

    // The control arm: the tracking rule of before (2 mrad around the commands since the
    // measurement).
    let old = letters_config(
        &dir,
        &[(
            "tracking_tolerance = 0.02, tracking_window_s = 0.6",
            "tracking_tolerance = 0.002, tracking_window_s = 0.0",
        )],
    );
    let b = demo(&old, &dir.join("old"), &["0.5235987755982988:1:1"], "6");
    assert!(!b.ok, "the old rule passed:\n{}", b.output);
    assert!(
        restarts(&b.node_log) > 3 || b.node_log.contains("does not follow"),
        "the old rule neither restarted repeatedly nor halted:\n{}",
        b.node_log
    );
}

/// A joint frozen while the robot draws (the robot stops following): the node holds within
/// a bounded time (more than 2 restarts within 5 s: the lock found, and the tries of a
/// robot then read as held, each counted) and says so on the terminal and in its status.
#[test]
#[ignore = "run by .ci/run on its own (one at a time: real time on 2 cores)"]
fn physics_rby1_that_stops_following_is_held_and_reported() {
    require_physics();
    let dir = temp_dir("physics-freeze");
    let cfg = letters_config(
        &dir,
        &[(
            "version = \"1.0\"",
            "version = \"1.0\"\nfreeze_joint = \"left_arm_0\"\nfreeze_after_s = 3.0",
        )],
    );
    let r = demo(&cfg, &dir.join("run"), &["0:1:1"], "10");
    assert!(!r.ok, "the demo passed with a frozen joint:\n{}", r.output);
    assert!(
        r.output.contains("node status codes") && r.output.contains("23"),
        "ROBOT_NOT_FOLLOWING (23) not in the node's status:\n{}",
        r.output
    );
    let start = r.summary["started_wall_time_s"]
        .as_f64()
        .unwrap_or_else(|| panic!("summary: {}", r.summary));
    let frozen_at = start + 3.0;
    let halted_at = r
        .node_log
        .lines()
        .find(|l| l.contains("[ERROR]") && l.contains("does not follow"))
        .and_then(|l| {
            let s = &l[l.find("] [")? + 3..];
            s[..s.find(']')?].parse::<f64>().ok()
        })
        .unwrap_or_else(|| panic!("no `does not follow` error:\n{}", r.node_log));
    let delay = halted_at - frozen_at;
    assert!(
        (0.0..=6.0).contains(&delay),
        "held {delay:.2} s after the joint froze (bound 6 s)\n{}",
        r.node_log
    );
    assert_eq!(r.summary["violation_count"], 0, "{}", r.summary);
}

/// Input faults while the physics robot draws, one run per kind (its published joint states
/// fail; its motors keep following the last commands): a NaN position, a missing joint,
/// silence (stale states). Across a condition switch, the node commands nothing non-finite,
/// the robot crosses no URDF limit (position or velocity, checked by the robot on every
/// physics step), and the node says what happened. The demo fails only by its own rules on
/// the faulted run (the node's input-fault status, an RMSE over the faulted states).
#[test]
#[ignore = "run by .ci/run on its own (one at a time: real time on 2 cores)"]
fn physics_rby1_survives_input_faults_while_it_moves() {
    require_physics();
    for (kind, log_needle) in [
        ("nan_position", "non-finite position"),
        ("missing_joint", "a controlled joint is missing"),
        ("silent", "joint states stale"),
    ] {
        let dir = temp_dir(&format!("physics-fault-{kind}"));
        let fault = format!(
            "[mock_hw]\nrate_hz = 200.0\nfault = \"{kind}\"\nfault_joint = \"left_arm_3\"\n\
             fault_after_s = 4.0\nfault_duration_s = 0.6"
        );
        let cfg = letters_config(&dir, &[("[mock_hw]\nrate_hz = 200.0", &fault)]);
        let r = demo(
            &cfg,
            &dir.join("run"),
            &["0.5235987755982988:1:1", "0:0.8:-1"],
            "4",
        );
        let (summary, log, output) = (&r.summary, &r.node_log, &r.output);
        assert!(
            summary.is_object(),
            "{kind}: no physics robot summary\n{output}"
        );
        assert!(
            summary["joint_states_faulted"].as_u64().unwrap() > 0,
            "{kind}: the fault never began: {summary}\n{output}"
        );
        assert_eq!(summary["violation_count"], 0, "{kind}: {summary}");
        assert_eq!(summary["commands_invalid"], 0, "{kind}: {summary}");
        assert!(
            summary["commands_received"].as_u64().unwrap() > 300,
            "{kind}"
        );
        assert!(
            log.contains(log_needle),
            "{kind}: `{log_needle}` not logged:\n{log}"
        );
        assert!(
            !output.contains("node exited with"),
            "{kind}: the node failed:\n{output}"
        );
        // The demo scores what the robot reported: the faulted states make it fail by its
        // own rules (the node's input-fault status codes, an RMSE over NaN positions), and
        // for no other reason (no limit crossed, no process failed, the bag replays).
        let failures: Vec<&str> = output
            .lines()
            .filter(|l| l.starts_with("demo: FAILED:"))
            .collect();
        assert!(
            r.ok || !failures.is_empty(),
            "{kind}: the demo failed without saying why:\n{output}"
        );
        let other: Vec<&&str> = failures
            .iter()
            .filter(|l| !(l.contains("node status codes") || l.contains("closed-loop RMSE")))
            .collect();
        assert!(
            other.is_empty(),
            "{kind}: the demo failed for more than the fault: {other:?}\n{output}"
        );
    }
}

/// The pan grasped with the shipped policy (`config/rby1-pan.toml`'s node default, the
/// task-space head `pi_mr_head_rby1_pan`) on the physics robot (no gravity compensation) and
/// on the kinematic mock, same condition (45°, the demonstrated right arm). The physics robot
/// adds its servo's lag to the kinematic mock's error, an amount that does not scale with the
/// policy's own error (the joint-space π_MR this test ran before lagged by as much, from
/// twice the kinematic error): physics closed-loop RMSE ≤ kinematic + 0.012 m (measured
/// 0.0147–0.0152 m against 0.0079 m: the servo adds 0.007 m); under the paper's resampled
/// protocol at or below the paper's real-robot 0.017 m (measured 0.0060–0.0062 m). Both
/// demos pass (closed loop within 1.5× the offline rollout, no error status, the bag
/// replays); one restart (the demo's teleport to the start), no robot reported as not
/// following, no limit crossed, and no actuator at its torque limit for long: < 0.6 s in
/// all. The head holds `right_arm_5` there for 0.484 s (the same in every run; π_MR stayed
/// under 0.3 s, this test's bound before it tested the head).
#[test]
#[ignore = "run by .ci/run on its own (one at a time: real time on 2 cores)"]
fn physics_rby1_grasps_the_pan_as_the_kinematic_mock_does() {
    require_physics();
    let dir = temp_dir("physics-pan");
    let cfg = rby1_config("rby1-pan.toml", &dir, &[]);
    let cond = ["0.7853981633974483:1:1"];
    let r = demo(&cfg, &dir.join("physics"), &cond, "10");
    assert_eq!(r.rmse.len(), 1, "{}", r.output);
    let k = demo_on("kinematic", &cfg, &dir.join("kinematic"), &cond, "10");
    assert_eq!(k.rmse.len(), 1, "{}", k.output);
    assert!(k.ok, "the demo failed on the kinematic mock:\n{}", k.output);
    let (physics, kin) = (r.rmse[0], k.rmse[0]);
    assert!(
        physics <= kin + 0.012,
        "physics RMSE {physics} m vs kinematic {kin} m: the servo adds {} m (measured \
         0.007 m, bound 0.012 m)\n{}",
        physics - kin,
        r.output
    );
    let paper = paper_column(&dir.join("physics"));
    assert!(
        paper[0] <= 0.017,
        "paper-protocol RMSE {} m on the physics robot, above the paper's real robot's \
         0.017 m (measured 0.0060–0.0062 m)\n{}",
        paper[0],
        r.output
    );
    assert!(r.ok, "the demo failed on the physics robot:\n{}", r.output);
    assert_followed(&r);
    assert_eq!(r.summary["commands_invalid"], 0, "{}", r.summary);
    let torque = r.summary["torque_limit_time_s"]
        .as_object()
        .unwrap_or_else(|| panic!("no torque_limit_time_s: {}", r.summary));
    let worst = torque
        .values()
        .filter_map(|v| v.as_f64())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.6,
        "an actuator spent {worst} s at its torque limit (the head: 0.484 s, right_arm_5): {}",
        r.summary["torque_limit_time_s"]
    );
}

/// The paper-protocol RMSE column of a demo's `demo.csv`.
fn paper_column(out: &Path) -> Vec<f64> {
    csv_column(out, 8).expect("demo.csv with a paper-protocol column")
}

/// Column `k` of `out/demo.csv` as numbers (`None` without the file).
fn csv_column(out: &Path, k: usize) -> Option<Vec<f64>> {
    let csv = std::fs::read_to_string(out.join("demo.csv")).ok()?;
    Some(
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').nth(k).unwrap().parse::<f64>().unwrap())
            .collect(),
    )
}

/// A joint range narrowed in the config (`[robot] limits`, as for a workcell) that the
/// letter pushes against (the original letter takes `left_arm_1` from 0.649 to 0.757 rad;
/// the range ends at 0.70), with a sensor fault while the arm heads for the bound (a NaN
/// position of that joint, silence, or frozen encoders) and the letter going on after it:
/// the physics robot, checking the same narrowed range on every physics step, sees the joint
/// come within 0.03 rad of the bound and never cross it. The node and the physics robot
/// run as a user starts them (`crossym mock-hw --plant mujoco`, `crossym node`, the config's
/// default condition).
#[test]
#[ignore = "run by .ci/run on its own (one at a time: real time on 2 cores)"]
fn physics_rby1_keeps_a_narrowed_range_under_faults() {
    require_physics();
    // The original letter's start posture (demo 6 at the identity condition).
    let start = "[-0.3550, 0.6492, -0.3583, -1.9584, -0.0029, 0.1475, 0.0, \
                 -0.2670, -0.6156, 0.4593, -1.8497, -0.0041, 0.1863, 0.0]";
    // (fault, what the node logs when it sees it, and when it sees valid states again);
    // frozen encoders (fresh stamps, stuck values) look like a robot that lags: nothing to
    // wait for but the fault window itself.
    for (kind, seen) in [
        ("nan_position", Some(("non-finite position", "fresh again"))),
        ("silent", Some(("joint states stale", "fresh again"))),
        ("frozen", None),
    ] {
        let dir = temp_dir(&format!("physics-bound-{kind}"));
        let hw = format!(
            "[mock_hw]\nrate_hz = 200.0\ninitial_q = {start}\nfault = \"{kind}\"\n\
             fault_joint = \"left_arm_1\"\nfault_after_s = 1.5\nfault_duration_s = 0.8"
        );
        let cfg = letters_config(
            &dir,
            &[
                (
                    "urdf_name = \"RBY1_A_v1.0\"",
                    "urdf_name = \"RBY1_A_v1.0\"\nlimits = { left_arm_1 = { upper = 0.70 } }",
                ),
                ("[mock_hw]\nrate_hz = 200.0", &hw),
                // The joint-space π_MRT, which pushes the left shoulder against the narrowed
                // bound: the shipped head's null-space term keeps that joint 5 cm (rad) away
                // (10 % band), so the filter's bound would go untested.
                (
                    "pi_mrt_head_rby1_letters.safetensors\"\nperiod_s",
                    "pi_mrt_rby1_letters.safetensors\"\nperiod_s",
                ),
            ],
        );
        let cfg = cfg.to_str().unwrap();
        let summary_path = dir.join("summary.json");
        let (hw_log, node_log) = (dir.join("hw.log"), dir.join("node.log"));
        let spawn = |args: &[&str], log: &Path| {
            let f = std::fs::File::create(log).unwrap();
            crossym(args)
                .env("ROS_DOMAIN_ID", "0")
                .env("ROS_LOCALHOST_ONLY", "1")
                .stdout(f.try_clone().unwrap())
                .stderr(f)
                .spawn()
                .expect("crossym starts")
        };
        let mut robot = spawn(
            &[
                "mock-hw",
                "--plant",
                "mujoco",
                "--config",
                cfg,
                "--summary",
                summary_path.to_str().unwrap(),
            ],
            &hw_log,
        );
        let mut node = spawn(&["node", "--config", cfg], &node_log);
        // The RB-Y1 configs start the node inactive: say go, as an operator would.
        super::common::lifecycle_set(Path::new(cfg), 0, "activate");
        // Events, with generous deadlines: the node commands, sees the fault, sees valid
        // joint states again; then 3 s more of the letter (the bound is reached ≈ 2 s after
        // the fault window).
        let deadline = Duration::from_secs(30);
        let wait = super::common::wait_for_text;
        let waited = wait(&node_log, "joint states received", deadline)
            && match seen {
                Some((fault, again)) => {
                    wait(&node_log, fault, deadline)
                        && super::common::wait_for_text_after(&node_log, fault, again, deadline)
                }
                None => {
                    std::thread::sleep(Duration::from_secs_f64(1.5 + 0.8));
                    true
                }
            };
        if waited {
            std::thread::sleep(Duration::from_secs(3));
        }
        let term = |c: &mut std::process::Child| {
            // SAFETY: signals a child process of this test.
            unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
            c.wait().unwrap()
        };
        let node_rc = term(&mut node);
        term(&mut robot);
        let log = std::fs::read_to_string(&node_log).unwrap_or_default();
        assert!(
            waited,
            "{kind}: the node never saw the fault and recovered:\n{log}\n--- robot\n{}",
            std::fs::read_to_string(&hw_log).unwrap_or_default()
        );
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&summary_path).unwrap_or_default())
                .unwrap_or_else(|e| panic!("{kind}: no summary ({e})"));
        assert!(
            summary["joint_states_faulted"].as_u64().unwrap() > 0,
            "{kind}: the fault never began: {summary}"
        );
        let margin = summary["min_limit_margin"]["left_arm_1"]
            .as_f64()
            .unwrap_or_else(|| panic!("{kind}: no margin of left_arm_1: {summary}"));
        assert!(
            margin < 0.03,
            "{kind}: left_arm_1 never came near its narrowed bound (margin {margin} rad): the \
             test does not test the bound\n{log}"
        );
        assert_eq!(
            summary["violation_count"], 0,
            "{kind}: limit violations, the first {}; margins {}\n{log}",
            summary["violations"][0], summary["min_limit_margin"]
        );
        assert_eq!(summary["commands_invalid"], 0, "{kind}: {summary}");
        assert!(node_rc.success(), "{kind}: node exit {node_rc}\n{log}");
    }
}
