//! The node as a managed (lifecycle) node, from outside, over DDS (run inside
//! `tools/netns-run`, as `.ci/run` does): `crossym node --config config/rby1-letters.toml`
//! (`[node] autostart = false`) and `crossym mock-hw` as child processes, driven with
//! `crossym lifecycle set` (the `lifecycle_msgs` services) and observed through the mock
//! robot's joint states and the node's status, as an operator would see them.
//! ROS_DOMAIN_ID 147 (no other test uses it). ROS 2's own lifecycle client (rclpy) drives
//! the same services in `rclpy::` (Jazzy and Kilted).
//!
//! Checked, each against what the robot does (its joint states), not what the node says:
//! inactive at start — 2 s of joint states with no joint moving and no command received by
//! the robot; `activate` — the arms move within 1 s; `deactivate` — the motion stops within
//! the braking time (max |v| / a + 2 periods + the DDS round trip) and stays stopped; no
//! joint ever past a limit (the mock robot's own count); `shutdown` → finalized; the
//! recorded run replays bit for bit (the transitions are in the bag).

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::common::{self, Proc, Watch};
use crossym::ros::sim::MockHwSummary;

const DOMAIN: u16 = 147;

/// The largest joint displacement over the joint states received during `span` (rad).
fn motion_over(w: &Watch, span: Duration) -> (f64, usize) {
    let t0 = Instant::now();
    let mut first: Option<Vec<f64>> = None;
    let (mut max, mut n) = (0.0f64, 0usize);
    while t0.elapsed() < span {
        while let Ok(Some((m, _))) = w.joint_states.take() {
            n += 1;
            match &first {
                None => first = Some(m.position.clone()),
                Some(f) => {
                    for (a, b) in f.iter().zip(&m.position) {
                        max = max.max((a - b).abs());
                    }
                }
            }
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    (max, n)
}

fn drain(w: &Watch) {
    while let Ok(Some(_)) = w.joint_states.take() {}
    while let Ok(Some(_)) = w.status.take() {}
}

#[test]
fn starts_inactive_and_moves_only_while_active() {
    let dir = common::temp_dir("lifecycle");
    let cfg = common::root().join("config/rby1-letters.toml");
    let c = cfg.to_str().unwrap();
    let (hw_log, node_log) = (dir.join("hw.log"), dir.join("node.log"));
    let summary = dir.join("hw.json");
    let spawn = |args: &[&str], name: &str, log: &Path| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_crossym"));
        cmd.args(args);
        Proc::spawn(cmd, name, DOMAIN, log)
    };
    let mut hw = spawn(
        &[
            "mock-hw",
            "--config",
            c,
            "--summary",
            summary.to_str().unwrap(),
        ],
        "mock-hw",
        &hw_log,
    );
    let bag = dir.join("run");
    let mut node = spawn(
        &["node", "--config", c, "--record", bag.to_str().unwrap()],
        "node",
        &node_log,
    );
    let w = Watch::new(DOMAIN, "lifecycle", "/crossym/status", "/joint_states");
    let inactive = crossym::control::StatusCode::Inactive.value();
    assert!(
        w.wait_status(Duration::from_secs(20), |s| s.code == inactive)
            .is_some(),
        "no INACTIVE status: {}",
        common::log_tail(&node_log)
    );
    // Inactive: the robot stands still while joint states flow.
    drain(&w);
    let (moved, n) = motion_over(&w, Duration::from_secs(2));
    assert!(n > 100, "only {n} joint states in 2 s");
    assert_eq!(
        moved, 0.0,
        "a joint moved by {moved} rad while the node was inactive"
    );

    let said = common::lifecycle_set(&cfg, DOMAIN, "activate");
    assert!(said.contains("active [3]"), "{said}");
    drain(&w);
    let (moved, _) = motion_over(&w, Duration::from_secs(1));
    assert!(
        moved > 1e-3,
        "active for 1 s and the arms moved only {moved} rad"
    );

    let said = common::lifecycle_set(&cfg, DOMAIN, "deactivate");
    assert!(said.contains("inactive [2]"), "{said}");
    assert!(w
        .wait_status(Duration::from_secs(2), |s| s.code == inactive)
        .is_some());
    // Braking: max |v| 1 rad/s at 1 rad/s² ([robot] limits of the letters config) is ≤ 1 s;
    // 1.5 s covers it with the round trip; then nothing moves.
    std::thread::sleep(Duration::from_millis(1500));
    drain(&w);
    let (moved, n) = motion_over(&w, Duration::from_secs(1));
    assert!(n > 50, "only {n} joint states in 1 s");
    assert_eq!(
        moved, 0.0,
        "still moving {moved} rad after the deactivation's braking"
    );

    let said = common::lifecycle_set(&cfg, DOMAIN, "shutdown");
    assert!(said.contains("finalized [4]"), "{said}");
    assert_eq!(node.term(), 0, "{}", common::log_tail(&node_log));
    assert_eq!(hw.term(), 0, "{}", common::log_tail(&hw_log));
    let s: MockHwSummary =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    assert_eq!(s.violation_count, 0, "{:?}", s.violations);
    let log = std::fs::read_to_string(&node_log).unwrap();
    for needle in [
        "lifecycle: inactive ([node] autostart = false",
        "lifecycle: inactive → active (activate from",
        "lifecycle: active → inactive (deactivate from",
        "lifecycle: inactive → finalized (shutdown from",
    ] {
        assert!(
            log.contains(needle),
            "`{needle}` not in the node log:\n{log}"
        );
    }
    // The bag holds the transitions as the node applied them: the run replays bit for bit
    // (the braking commands after `deactivate` included).
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .args(["replay", "--config", c])
        .arg(&bag)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && text.contains("replay: OK (max deviation 0.000e0"),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}
