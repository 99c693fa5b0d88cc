//! `crossym node … --ros-args …`, as `launch_ros` starts a node (run inside
//! `tools/netns-run`, as `.ci/run` does): the node renamed and moved by
//! `__node`/`__ns`, its parameters from a `--params-file` and `-p` (the later `-p` over the
//! file), its joint states read from a remapped topic — each read back over DDS with
//! crossym's own clients (`crossym param get`, `crossym status`) and the mock hardware
//! publishing on the remapped topic; and the refusals at start (exit 2, the reason naming
//! the parameter or argument and where it came from). ROS_DOMAIN_ID 141 (no other test
//! uses it). Each test collects every failed check and reports them together.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;
use crate::common::Proc;

const DOMAIN: u16 = 141;

fn crossym() -> Command {
    Command::new(PathBuf::from(env!("CARGO_BIN_EXE_crossym")))
}

/// A fresh directory for one test.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("crossym-ros-args-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A crossym client command on the test's domain: exit code and stdout + stderr.
fn client(args: &[&str]) -> (Option<i32>, String) {
    let o = crossym()
        .args(args)
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("ROS_DISTRO", "humble")
        .output()
        .unwrap();
    (
        o.status.code(),
        String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr),
    )
}

/// `crossym node --config config/letters.toml --ros-args -r __ns:=/robot1 -r __node:=arm
/// --params-file P.yaml -p velocity_scale:=0.5 -r /joint_states:=/robot1/js`, and the mock
/// hardware publishing its joint states on `/robot1/js` only; the node's log.
fn start_node_and_robot(d: &Path, cfg: &str) -> (Proc, Proc, PathBuf) {
    let params = d.join("P.yaml");
    let yaml =
        "/**:\n  ros__parameters:\n    velocity_scale: 0.3\n    safety:\n      margin: 0.02\n";
    std::fs::write(&params, yaml).unwrap();
    let node_log = d.join("node.log");
    let mut cmd = crossym();
    cmd.args(["node", "--config", cfg, "--ros-args"])
        .args(["-r", "__ns:=/robot1", "-r", "__node:=arm", "--params-file"])
        .arg(&params)
        .args([
            "-p",
            "velocity_scale:=0.5",
            "-r",
            "/joint_states:=/robot1/js",
        ]);
    let node = Proc::spawn(cmd, "node", DOMAIN, &node_log);
    let mut hw = crossym();
    hw.args([
        "mock-hw",
        "--config",
        cfg,
        "--ros-args",
        "-r",
        "/joint_states:=/robot1/js",
    ]);
    let hw = Proc::spawn(hw, "mock-hw", DOMAIN, &d.join("mock_hw.log"));
    (node, hw, node_log)
}

#[test]
fn ros_args_rename_parameterise_and_remap_a_running_node() {
    let d = dir("run");
    let cfg = common::root().join("config/letters.toml");
    let cfg = cfg.to_str().unwrap();
    let (mut node, mut hw, node_log) = start_node_and_robot(&d, cfg);
    let at = ["--config", cfg, "--name", "arm", "--namespace", "/robot1"];
    let get = |name: &str| client(&[&["param", "get", name][..], &at[..]].concat());
    let (scale, margin) = (get("velocity_scale"), get("safety.margin"));
    // `crossym status` subscribes to `~/status` of /robot1/arm: /robot1/arm/status.
    let status = client(
        &[
            &["status", "--count", "30", "--timeout-s", "10"][..],
            &at[..],
        ]
        .concat(),
    );
    let at_root = client(&[
        "param",
        "get",
        "velocity_scale",
        "--config",
        cfg,
        "--timeout-s",
        "2",
    ]);
    assert_eq!(node.term(), 0, "{}", common::log_tail(&node_log));
    hw.term();
    let log = std::fs::read_to_string(&node_log).unwrap();

    let mut failed = Vec::new();
    let mut check = |ok: bool, what: String| {
        if !ok {
            failed.push(what);
        }
    };
    check(
        scale.0 == Some(0) && scale.1.contains("velocity_scale = 0.5"),
        format!("-p velocity_scale:=0.5 after the file's 0.3: {scale:?}"),
    );
    check(
        margin.0 == Some(0) && margin.1.contains("safety.margin = 0.02"),
        format!("the file's safety.margin (nested key): {margin:?}"),
    );
    check(
        at_root.0 != Some(0),
        format!("no node at /crossym: {at_root:?}"),
    );
    // Status lines only (`crossym status` names the topic it watches on stderr).
    let lines: Vec<&str> = status
        .1
        .lines()
        .filter(|l| l.contains(" | joint state age "))
        .collect();
    let last = lines.last().copied().unwrap_or_default();
    check(
        status.0 == Some(0)
            && status.1.contains("watching /robot1/arm/status")
            && last.contains(" | ")
            && !last.starts_with("STALE_JOINT_STATES"),
        format!("status on /robot1/arm/status, joint states from /robot1/js: {status:?}"),
    );
    for line in [
        "[arm]: ROS arguments: node /robot1/arm; parameters: velocity_scale = 0.5 (-p (ROS argument 12)), safety.margin = 0.02 (--params-file ",
        "[arm]: remap: topic /joint_states → /robot1/js (ROS argument 14)",
        "topics: in /robot1/js (JointState",
        "/robot1/arm/status (Status",
        "joint states received",
    ] {
        check(log.contains(line), format!("`{line}` not in the node log"));
    }
    assert!(
        failed.is_empty(),
        "{} check(s) failed:\n- {}\n--- node log\n{log}",
        failed.len(),
        failed.join("\n- ")
    );
}

/// `crossym node --config config/letters.toml --ros-args ARGS…`: its exit code (`None`:
/// still running after 20 s, killed: a node that does not refuse runs on) and output.
fn refused(d: &Path, name: &str, args: &[&str]) -> (Option<i32>, String) {
    let log = d.join(format!("{name}.log"));
    let f = std::fs::File::create(&log).unwrap();
    let cfg = common::root().join("config/letters.toml");
    let mut child = crossym()
        .args(["node", "--config", cfg.to_str().unwrap(), "--ros-args"])
        .args(args)
        .env("ROS_DOMAIN_ID", (DOMAIN + 1).to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("ROS_DISTRO", "humble")
        .stdout(Stdio::from(f.try_clone().unwrap()))
        .stderr(Stdio::from(f))
        .spawn()
        .unwrap();
    let t0 = Instant::now();
    let code = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s.code();
        }
        if t0.elapsed() > Duration::from_secs(20) {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    (code, std::fs::read_to_string(&log).unwrap())
}

#[test]
fn ros_args_refusals_stop_the_node_at_start() {
    let d = dir("refusals");
    let ro = d.join("RO.yaml");
    std::fs::write(&ro, "/**:\n  ros__parameters:\n    period_s: 0.5\n").unwrap();
    let ro_at = format!(
        "parameter `period_s` from --params-file {}:3: `period_s` is read-only",
        ro.display()
    );
    let cases: [(&str, Vec<&str>, &str); 6] = [
        (
            "unknown_parameter",
            vec!["-p", "no_such_parameter:=1"],
            "error: parameter `no_such_parameter` from -p (ROS argument 6): the node declares no parameter `no_such_parameter`",
        ),
        ("read_only", vec!["--params-file", ro.to_str().unwrap()], &ro_at),
        (
            "wrong_type",
            vec!["-p", "velocity_scale:=fast"],
            "error: parameter `velocity_scale` from -p (ROS argument 6): `velocity_scale` takes a double in (0, 1], got String(\"fast\")",
        ),
        (
            "integer_array",
            vec!["-p", "default_condition:=[0, 1, 1]"],
            "parameter `default_condition` from -p (ROS argument 6): `default_condition` takes a double[3]",
        ),
        (
            "unknown_ros_argument",
            vec!["-r", "__ns:=/robot1", "--no-such-flag"],
            "error: ROS argument 7: unknown ROS argument `--no-such-flag`",
        ),
        (
            "bad_rule",
            vec!["-r", "/joint_states"],
            "error: ROS argument 6: remap rule `/joint_states`: expected [node:]from:=to",
        ),
    ];
    let mut failed = Vec::new();
    for (name, args, want) in &cases {
        let (code, out) = refused(&d, name, args);
        if code != Some(2) || !out.contains(want) {
            failed.push(format!(
                "{name}: exit {code:?}, want 2 and `{want}` in:\n{out}"
            ));
        }
    }
    assert!(
        failed.is_empty(),
        "{} refusal(s) failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
}
