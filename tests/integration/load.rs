//! A node held off the CPU (a loaded computer at its worst), checked as an outsider would:
//! `crossym node` and `crossym mock-hw` as separate processes over DDS (private namespace),
//! the node stopped with SIGSTOP for a wall-clock time this test measures, then continued;
//! `~/status` (read by `crossym status`, its own process) and the node's log must say how
//! many ticks never ran, the robot must stay inside its limits. The measured figures under
//! `stress-ng` are bench/load.sh's (docs/PERFORMANCE.md, "Under load").

use std::process::Command;
use std::time::{Duration, Instant};

use crate::common::{self, Proc};

const DOMAIN: u16 = 57;
/// `config/letters.toml`: timer ticks every 10 ms.
const PERIOD_S: f64 = 0.01;

fn signal(pid: u32, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &pid.to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill {sig} {pid}");
}

/// The number after `before` in `text` (the first occurrence after `from`).
fn count_after(text: &str, from: &str, before: &str) -> Option<u64> {
    let rest = &text[text.find(from)?..];
    let n = rest[rest.find(before)? + before.len()..]
        .split(|c: char| !c.is_ascii_digit())
        .next()?;
    n.parse().ok()
}

#[test]
fn a_node_held_off_the_cpu_says_how_many_ticks_never_ran() {
    let dir = common::temp_dir("load-stall");
    let cfg = common::root().join("config/letters.toml");
    let (node_log, hw_log, summary) = (
        dir.join("node.log"),
        dir.join("hw.log"),
        dir.join("mock.json"),
    );
    let spawn = |args: &[&str], name: &str, log: &std::path::Path| {
        let mut cmd = Command::new(env!("CARGO_BIN_EXE_crossym"));
        cmd.args(args);
        Proc::spawn(cmd, name, DOMAIN, log)
    };
    let c = cfg.to_str().unwrap();
    let s = summary.to_str().unwrap();
    let mut node = spawn(&["node", "--config", c], "node", &node_log);
    let mut hw = spawn(
        &["mock-hw", "--config", c, "--summary", s],
        "mock-hw",
        &hw_log,
    );
    assert!(
        common::wait_for_text(&node_log, "joint states received", Duration::from_secs(60)),
        "{}",
        common::log_tail(&node_log)
    );
    std::thread::sleep(Duration::from_millis(500));
    // Held off the CPU for ≈ 0.3 s of wall clock, measured here. Only the log written
    // since then counts: a late tick at start warns with the same words.
    let before = std::fs::read_to_string(&node_log).unwrap().len();
    let t0 = Instant::now();
    signal(node.id(), "-STOP");
    std::thread::sleep(Duration::from_millis(300));
    signal(node.id(), "-CONT");
    let stalled = t0.elapsed().as_secs_f64();
    // Timer ticks due during the stall never ran: ⌊stall / period⌋, give or take one (the
    // stop lands anywhere within a period).
    let expect = (stalled / PERIOD_S).floor() as u64;
    let warned = common::wait_for_text_from(
        &node_log,
        before,
        "never ran since the last status",
        Duration::from_secs(10),
    );
    let log = std::fs::read_to_string(&node_log).unwrap();
    assert!(
        warned,
        "no late-tick warning after a {stalled:.3} s stall\n{log}"
    );
    let missed = count_after(
        &log[before..],
        "started more than half a period late and",
        "late and ",
    )
    .expect("a missed count");
    assert!(
        missed + 1 >= expect && missed <= expect + 1,
        "the node says {missed} ticks never ran in a {stalled:.3} s stall at {PERIOD_S} s: \
         expected {expect} ± 1\n{log}"
    );
    eprintln!("stalled {stalled:.3} s: {missed} ticks never ran (expected {expect} ± 1)");
    let warn_line = log[before..]
        .lines()
        .find(|l| l.contains("never ran since the last status"))
        .unwrap();
    assert!(warn_line.starts_with("[WARN]"), "{warn_line}");
    // `crossym status`, its own process: the totals since start.
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .args(["status", "--config", c, "--count", "1", "--timeout-s", "30"])
        .env("ROS_DOMAIN_ID", DOMAIN.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .output()
        .unwrap();
    let line = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(out.status.success(), "{line}");
    let total = count_after(&line, "| late ticks", "missed ").expect("missed total on the line");
    assert!(total >= missed, "status: {line}");
    assert_eq!(node.term(), 0, "node exit code\n{log}");
    assert_eq!(
        hw.term(),
        0,
        "mock-hw exit code\n{}",
        common::log_tail(&hw_log)
    );
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&summary).unwrap()).unwrap();
    assert_eq!(s["violation_count"], 0, "{s}");
    assert_eq!(s["commands_invalid"], 0, "{s}");
    // The stop summary's totals agree.
    let log = std::fs::read_to_string(&node_log).unwrap();
    let stop_line = log
        .lines()
        .rev()
        .find(|l| l.contains("tick start after its time"))
        .expect("the node's stop summary");
    let at_stop = count_after(stop_line, "tick start", "half a period late, ")
        .expect("a missed total at stop");
    assert!(at_stop >= total, "{stop_line}");
}
