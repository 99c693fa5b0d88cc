//! The node's operator controls from outside, over DDS (run inside
//! `tools/netns-run`, as `.ci/run` does): `crossym node` as a child process and an
//! independent peer (`tests/peer/operator_peer.py`, PyPI `cyclonedds`, no crossym code)
//! playing both the robot (the rest posture at 100 Hz, never moving, so the policy's
//! command is constant) and the operator (`~/pause`, `~/reset`, parameter sets in
//! ros2-client's Enhanced request/reply mapping). ROS_DOMAIN_ID 121 (no other test uses it).
//!
//! No rate is asserted; the one wall-clock bound is the peer's braking check (time to zero
//! after `~/pause` ≤ max |v| / a + 3 periods + 0.3 s, which a pause that does nothing fails).

use std::path::PathBuf;
use std::process::Command;

use crate::common;
use crate::common::Proc;

/// The peer's checks, in order (see the docs of `operator_peer.py`).
const CHECKS: usize = 22;

#[test]
fn pause_resume_scale_and_refusals_from_an_independent_peer() {
    assert!(
        common::python_has_cyclonedds(),
        "PyPI cyclonedds is missing: run `bash tests/peer/install.sh` (.ci/run does)"
    );
    let dir =
        std::env::temp_dir().join(format!("crossym-operator-services-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let domain = 121u16;
    let node_log = dir.join("node.log");
    let cfg = common::root().join("config/letters.toml");
    let mut cmd = Command::new(PathBuf::from(env!("CARGO_BIN_EXE_crossym")));
    cmd.args(["node", "--config", cfg.to_str().unwrap()]);
    let mut node = Proc::spawn(cmd, "node", domain, &node_log);
    let json = dir.join("operator.json");
    let out = Command::new("python3")
        .arg(common::root().join("tests/peer/operator_peer.py"))
        .args(["--config", cfg.to_str().unwrap()])
        .args(["--domain", &domain.to_string(), "--timeout", "10", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    // `crossym param` (no ROS tools) on the still running node.
    let param = |args: &[&str]| {
        let o = Command::new(env!("CARGO_BIN_EXE_crossym"))
            .arg("param")
            .args(args)
            .args(["--config", cfg.to_str().unwrap()])
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_LOCALHOST_ONLY", "1")
            .env_remove("ROS_DISTRO")
            .output()
            .unwrap();
        (
            o.status.code(),
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    let cli = [
        param(&["set", "velocity_scale", "0.25"]),
        param(&["get", "velocity_scale"]),
        param(&["set", "period_s", "0.5"]),
        param(&["get", "no_such_parameter"]),
    ];
    assert_eq!(node.term(), 0, "{}", common::log_tail(&node_log));
    assert!(
        out.status.success(),
        "operator peer failed ({:?}):\n{stdout}\n{}\n--- node log\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr),
        common::log_tail(&node_log)
    );
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let checks = summary["checks"].as_array().expect("checks");
    assert_eq!(checks.len(), CHECKS, "{stdout}");
    assert!(
        checks
            .iter()
            .all(|c| c["ok"] == serde_json::Value::Bool(true)),
        "{stdout}"
    );

    let (set, get, ro, none) = (&cli[0], &cli[1], &cli[2], &cli[3]);
    assert!(
        set.0 == Some(0) && set.1.contains("velocity_scale = 0.25: set"),
        "{set:?}"
    );
    assert!(
        get.0 == Some(0) && get.1.contains("velocity_scale = 0.25"),
        "{get:?}"
    );
    assert!(
        ro.0 == Some(1) && ro.1.contains("`period_s` needs a restart"),
        "{ro:?}"
    );
    assert!(
        none.0 == Some(1) && none.1.contains("no parameter `no_such_parameter`"),
        "{none:?}"
    );

    // The node's log: the startup line, then each request and its application, in order.
    let log = std::fs::read_to_string(&node_log).unwrap();
    let mut at = 0;
    for needle in [
        "services: /crossym/pause (std_srvs/srv/SetBool)",
        "~/pause true from",
        "service: pause (applied)",
        "~/pause false from",
        "service: resume (applied)",
        "parameter: velocity_scale = 0.5 (applied)",
        "parameter: velocity_scale = 1 (applied)",
        "~/reset from",
        "service: reset (applied)",
        "parameter: velocity_scale = 0.25 (applied)",
        "parameter: set of `period_s` refused: `period_s` needs a restart",
    ] {
        match log[at..].find(needle) {
            Some(i) => at += i + needle.len(),
            None => panic!("`{needle}` not in the node log after byte {at}:\n{log}"),
        }
    }
    // The refused sets changed nothing, so nothing was applied; each refusal is logged.
    for needle in [
        "parameter: set of `velocity_scale` refused: velocity_scale must be in (0, 1], got -1",
        "parameter: set of `safety.margin` refused: safety.margin must be in [0,",
    ] {
        assert!(
            log.contains(needle),
            "`{needle}` not in the node log:\n{log}"
        );
    }
    for needle in [
        "velocity_scale = NaN (applied)",
        "velocity_scale = -1 (applied)",
        "velocity_scale = 1.5 (applied)",
        "period_s = 0.02 (applied)",
        "safety.margin = 10 (applied)",
    ] {
        assert!(!log.contains(needle), "`{needle}` in the node log:\n{log}");
    }
}
