//! What an operator sees without ROS tools, checked as an outsider would: `crossym node` and
//! `crossym mock-hw` as separate processes over DDS (private namespace), bad inputs
//! published from this process, the node's console log read from its output file, and
//! `crossym status` run as its own process.

use std::process::Command;
use std::time::Duration;

use crossym::msg;
use crossym::ros::dds::{self, DdsSettings, DiscoveryRange};

use crate::common::{self, Proc};

fn cfg() -> String {
    common::root()
        .join("config/letters.toml")
        .display()
        .to_string()
}

/// `crossym status ARGS` on `domain` (its own process): exit code and stdout, stderr.
fn status(domain: u16, args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .args(["status", "--config", &cfg()])
        .args(args)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env_remove("ROS_DISTRO")
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// `[SEVERITY] [secs.nanos] [name]: text` (rcutils' default console format).
fn is_rcutils_line(l: &str, node: &str) -> bool {
    let Some(rest) = ["[INFO] [", "[WARN] [", "[ERROR] [", "[DEBUG] ["]
        .iter()
        .find_map(|p| l.strip_prefix(p))
    else {
        return false;
    };
    let Some((time, rest)) = rest.split_once("] [") else {
        return false;
    };
    let time_ok = time
        .split_once('.')
        .is_some_and(|(s, n)| s.parse::<u64>().is_ok() && n.len() == 9 && n.parse::<u64>().is_ok());
    time_ok && rest.starts_with(&format!("{node}]: "))
}

#[test]
fn node_talks_on_the_terminal_and_status_shows_it() {
    let dir = common::temp_dir("operator");
    let domain = 71u16;
    let node_log = dir.join("node.log");
    let hw_log = dir.join("hw.log");
    let c = cfg();
    let mut node = Proc::spawn(
        {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_crossym"));
            cmd.args(["node", "--config", &c]);
            cmd
        },
        "node",
        domain,
        &node_log,
    );
    let mut hw = Proc::spawn(
        {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_crossym"));
            cmd.args(["mock-hw", "--config", &c]);
            cmd
        },
        "mock-hw",
        domain,
        &hw_log,
    );
    assert!(
        common::wait_for_text(&node_log, "joint states received", Duration::from_secs(60)),
        "{}",
        common::log_tail(&node_log)
    );

    // `crossym status` in its own process: three one-line views, exit 0; no ROS_DISTRO nag.
    let (code, out, err) = status(domain, &["--count", "3", "--timeout-s", "30"]);
    assert_eq!(code, 0, "{out}\n{err}");
    let lines: Vec<&str> = out.lines().collect();
    assert_eq!(lines.len(), 3, "{out}");
    for l in &lines {
        assert!(
            l.starts_with("NO_WARNING |") || l.starts_with("JOINT_BOUND |"),
            "{l}"
        );
        assert!(l.contains("joint state age") && l.contains("ticks"), "{l}");
    }
    assert!(!err.contains("ROS_DISTRO"), "{err}");

    // Bad inputs from this process: 60 joint states without the last joint (at ~200 Hz,
    // interleaved with the mock hardware's valid ones), a NaN condition, then a new valid one.
    let settings = DdsSettings {
        domain_id: domain,
        range: DiscoveryRange::Localhost,
        distro: dds::DEFAULT_DISTRO,
        security: Default::default(),
    };
    let ctx = settings.context().unwrap();
    let mut pnode = ctx
        .new_node(
            dds::node_name(
                "/",
                &format!("crossym_operator_test_{}", std::process::id()),
            )
            .unwrap(),
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .unwrap();
    let js = dds::publisher::<msg::JointState>(&mut pnode, "/joint_states", dds::qos_reliable(10))
        .unwrap();
    let cond = dds::publisher::<msg::SymmetryCondition>(
        &mut pnode,
        "/crossym/symmetry_condition",
        dds::qos_reliable(10),
    )
    .unwrap();
    let names = common::planar().kinematics.joint_names().to_vec();
    // Batches of 60 until the node has logged a rejection (discovery takes its time; a
    // batch sent before it is lost), deadline 30 s.
    let t0 = std::time::Instant::now();
    let mut seen = false;
    while !seen && t0.elapsed() < Duration::from_secs(30) {
        for _ in 0..60 {
            let n = names.len() - 1;
            js.publish(msg::JointState {
                header: msg::Header {
                    stamp: msg::Time::from_secs_f64(dds::wall_time_s()),
                    frame_id: String::new(),
                },
                name: names[..n].to_vec(),
                position: vec![0.0; n],
                velocity: vec![],
                effort: vec![],
            })
            .unwrap();
            std::thread::sleep(Duration::from_millis(5));
        }
        seen = common::wait_for_text(
            &node_log,
            "rejected joint_states",
            Duration::from_millis(200),
        );
    }
    assert!(
        seen,
        "the node never logged a rejected joint state\n{}",
        common::log_tail(&node_log)
    );
    let condition = |theta: f64| msg::SymmetryCondition {
        header: msg::Header {
            stamp: msg::Time::from_secs_f64(dds::wall_time_s()),
            frame_id: String::new(),
        },
        theta,
        scale: 1.0,
        reflection: 1,
    };
    cond.publish(condition(f64::NAN)).unwrap();
    std::thread::sleep(Duration::from_millis(100));
    cond.publish(condition(0.5)).unwrap();
    assert!(
        common::wait_for_text(
            &node_log,
            "symmetry condition accepted: θ = 0.5000 rad",
            Duration::from_secs(60)
        ),
        "{}",
        common::log_tail(&node_log)
    );

    // The robot goes silent: the node says it brakes.
    assert_eq!(hw.term(), 0);
    assert!(
        common::wait_for_text(
            &node_log,
            "joint states stale (age",
            Duration::from_secs(60)
        ),
        "{}",
        common::log_tail(&node_log)
    );
    assert_eq!(node.term(), 0);

    let text = std::fs::read_to_string(&node_log).unwrap();
    let node_lines: Vec<&str> = text
        .lines()
        .filter(|l| l.contains("] [crossym]: "))
        .collect();
    for l in &node_lines {
        assert!(is_rcutils_line(l, "crossym"), "not rcutils format: {l}");
    }
    let has = |s: &str| node_lines.iter().any(|l| l.contains(s));
    for s in [
        "robot `planar_dual_arm`: 8 controlled joints",
        "policy ",
        "topics: in /joint_states (JointState, best effort",
        "output velocity at 100 Hz",
        "safety: QP filter",
        "[WARN]",
        "rejected joint_states",
        "rejected symmetry_condition (keeping θ = 0.0000 rad",
        "joint states received (age",
        "joint states stale (age",
        "stopped: ",
    ] {
        assert!(has(s), "no line with `{s}`:\n{text}");
    }
    // 60 rejected joint states in ~0.5 s: the first at once, the rest counted, not printed.
    let rejected: Vec<&&str> = node_lines
        .iter()
        .filter(|l| l.contains("rejected joint_states"))
        .collect();
    assert!(
        !rejected.is_empty() && rejected.len() <= 3,
        "{} rejection lines:\n{text}",
        rejected.len()
    );
    assert!(
        has("more since the last report") || has("suppressed by the rate limit"),
        "{text}"
    );
    assert!(!text.contains("ROS_DISTRO"), "{text}");
    // RustDDS internals stay quiet at the default level.
    assert!(
        text.lines().count() < node_lines.len() + 5,
        "other lines in the node's output:\n{text}"
    );

    // No node on another domain: exit 1 with a reason.
    let (code, _, err) = status(domain + 1, &["--timeout-s", "1"]);
    assert_eq!(code, 1, "{err}");
    assert!(err.contains("no status on /crossym/status"), "{err}");
}

/// `crossym ping` as its own process against `crossym node --trigger joint_states` (another
/// process): every probe answered by a command, order statistics printed; without a node,
/// exit 1 with a reason.
#[test]
fn ping_measures_round_trips_to_a_running_node() {
    let dir = common::temp_dir("ping");
    let domain = 91u16;
    let node_log = dir.join("node.log");
    let c = cfg();
    let mut node = Proc::spawn(
        {
            let mut cmd = Command::new(env!("CARGO_BIN_EXE_crossym"));
            cmd.args(["node", "--config", &c, "--trigger", "joint_states"]);
            cmd
        },
        "node",
        domain,
        &node_log,
    );
    let ping = |domain: u16, args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_crossym"))
            .args(["ping", "--config", &c, "--trigger", "joint_states"])
            .args(args)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_LOCALHOST_ONLY", "1")
            .output()
            .unwrap()
    };
    // At the node's own rate (100 Hz): every command must answer its probe. A node that
    // also ticked one period after each joint state would race the next probe and publish
    // commands before it ("stray"), and ping would have scored them as replies. ping tells
    // strays by their DDS source stamps from the node's stale-input ticks (when ping itself
    // stalls past the node's 100 ms stale timeout, the node rightly commands at its period)
    // and from late answers to lost probes, so a stalled probe cannot fail this.
    let out = ping(domain, &["--count", "300", "--rate", "100"]);
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}\n{}",
        String::from_utf8_lossy(&out.stderr),
        common::log_tail(&node_log)
    );
    // "ping: N round trips at R Hz: median … µs, p99 … µs, p99.9 … µs, max … µs; L lost …"
    let line = text.lines().find(|l| l.starts_with("ping: ")).unwrap();
    let num = |after: &str| number_after(line, after);
    let (n, median, p99, max) = (num("ping: "), num("median "), num("p99 "), num("max "));
    let lost = num("µs; ");
    let stray = num("ms), ");
    assert_eq!(n + lost, 300.0, "{line}");
    assert!(lost <= 15.0, "{line}");
    assert_eq!(stray, 0.0, "{text}");
    assert!(0.0 < median && median <= p99 && p99 <= max, "{line}");
    // The split of each round trip by the DDS stamps: the probe's command was published
    // after the probe (a positive forward part) and the parts are in order.
    let part = |label: &str| -> f64 {
        number_after(
            text.lines().find(|l| l.contains(label)).expect(label),
            "median ",
        )
    };
    let (fwd, back, wake) = (
        part("probe published → command published"),
        part("command published → received here"),
        part("received here → held by ping"),
    );
    assert!(fwd > 0.0 && back > 0.0 && wake >= 0.0, "{text}");
    assert!(fwd + back + wake <= 2.0 * median + 100.0, "{text}");
    assert_eq!(node.term(), 0, "{}", common::log_tail(&node_log));
    // The node's own per-hop histograms in its shutdown summary, one sample per probe.
    let log = std::fs::read_to_string(&node_log).unwrap();
    let hops = log
        .lines()
        .find(|l| l.contains("joint state → command hops"))
        .expect("hops line");
    assert!(
        hops.contains("DDS in (publisher → this node) median"),
        "{hops}"
    );
    assert!(
        hops.contains("DDS receive → control thread median"),
        "{hops}"
    );
    // ping's probes hold a posture where the default policy (a task-space head, singular
    // on the stretched arms at q = 0) runs: the node never fell back to zero velocity.
    assert!(
        !log.contains("undefined at the current joint state"),
        "the node did not run its policy on ping's probes:\n{}",
        common::log_tail(&node_log)
    );

    // No node on another domain: exit 1 with a reason.
    let out = ping(domain + 1, &["--connect-timeout-s", "1"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("no command on /forward_velocity_controller/commands"),
        "{err}"
    );
}

/// The number that follows the first `after` in `line` (panics with the line otherwise).
fn number_after(line: &str, after: &str) -> f64 {
    line.split(after)
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after `{after}` in: {line}"))
}

/// The scheduling policy (0 = SCHED_OTHER, 1 = SCHED_FIFO) and real-time priority of thread
/// `comm` of process `pid`, as the kernel reports them (`/proc/<pid>/task/<tid>/stat`).
fn thread_policy(pid: u32, comm: &str) -> Option<(u32, u32)> {
    for e in std::fs::read_dir(format!("/proc/{pid}/task")).ok()? {
        // A thread may exit while the list is read: skip it, not the whole scan.
        let Ok(dir) = e.map(|e| e.path()) else {
            continue;
        };
        match std::fs::read_to_string(dir.join("comm")) {
            Ok(c) if c.trim() == comm => {}
            _ => continue,
        }
        let stat = std::fs::read_to_string(dir.join("stat")).ok()?;
        // Fields after "pid (comm)": state is field 3; rt_priority 40, policy 41.
        let rest: Vec<&str> = stat[stat.rfind(')')? + 2..].split(' ').collect();
        return Some((rest[41 - 3].parse().ok()?, rest[40 - 3].parse().ok()?));
    }
    None
}

/// `[node] realtime = { priority = 10, lock_memory = true, dds_priority = 9,
/// cpu_latency_us = 0, idle_poll = true }`: with the privilege the kernel shows the control
/// thread (which is also the DDS event loop: no `RustDDS Participant` thread is left) under
/// SCHED_FIFO at priority 10, RustDDS's discovery thread at 9, the memory
/// locked and its PM QoS CPU latency target at 0 while the node runs (back afterwards);
/// without it (CAP_SYS_NICE and CAP_IPC_LOCK dropped from the bounding set) the node says
/// what was refused and how to grant it, keeps commanding at normal priority, and exits 0.
/// Either way (lowering needs no privilege) one idle poller per CPU runs under SCHED_IDLE.
#[test]
fn realtime_settings_apply_or_say_why_not() {
    let dir = common::temp_dir("realtime");
    let text = std::fs::read_to_string(cfg()).unwrap();
    let text = text.replace(
        "[node]\n",
        "[node]\nrealtime = { priority = 10, lock_memory = true, dds_priority = 9, cpu_latency_us = 0, idle_poll = true }\n",
    );
    let text = text.replace("\"../", &format!("\"{}/", common::root().display()));
    // The CPUs the node may run on, as the kernel says (its affinity is this process's).
    // SAFETY: a zeroed cpu_set_t is an empty set, filled by the call.
    let cpus: Vec<usize> = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        assert_eq!(
            libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set),
            0
        );
        (0..libc::CPU_SETSIZE as usize)
            .filter(|&c| libc::CPU_ISSET(c, &set))
            .collect()
    };
    let path = dir.join("rt.toml");
    std::fs::write(&path, text).unwrap();
    let path = path.display().to_string();
    let fifo_allowed = can_sched_fifo();
    for (k, privileged) in [(0u16, true), (1, false)] {
        let log = dir.join(format!("node{k}.log"));
        let mut cmd = if privileged {
            Command::new(env!("CARGO_BIN_EXE_crossym"))
        } else {
            let mut c = Command::new("setpriv");
            c.args([
                "--bounding-set",
                "-sys_nice,-ipc_lock",
                env!("CARGO_BIN_EXE_crossym"),
            ]);
            c
        };
        cmd.args(["node", "--config", &path]);
        let mut node = Proc::spawn(cmd, "node", 93 + k, &log);
        assert!(
            common::wait_for_text(&log, "realtime: memory locked", Duration::from_secs(60)),
            "{}",
            common::log_tail(&log)
        );
        let text = std::fs::read_to_string(&log).unwrap();
        // A new thread names itself once it runs: give it a moment after the log line.
        let find = |comm: &str| {
            (0..100).find_map(|_| {
                thread_policy(node.id(), comm).or_else(|| {
                    std::thread::sleep(Duration::from_millis(20));
                    None
                })
            })
        };
        let (policy, prio) = find("crossym-control").expect("control thread");
        let dds = find("RustDDS discove").expect("RustDDS discovery thread");
        assert_eq!(
            thread_policy(node.id(), "RustDDS Partici"),
            None,
            "the DDS event loop runs on the control thread"
        );
        for &c in &cpus {
            // SCHED_IDLE = 5.
            let idle = find(&format!("crossym-idle{c}"));
            assert_eq!(idle, Some((5, 0)), "poller on CPU {c}\n{text}");
        }
        assert!(
            text.contains(&format!(
                "realtime: idle CPUs poll instead of halting ({} SCHED_IDLE thread",
                cpus.len()
            )),
            "{text}"
        );
        let locked_kb: u64 = std::fs::read_to_string(format!("/proc/{}/status", node.id()))
            .unwrap()
            .lines()
            .find(|l| l.starts_with("VmLck:"))
            .and_then(|l| l.split_whitespace().nth(1)?.parse().ok())
            .unwrap();
        if privileged && !fifo_allowed {
            // The test process itself could not get SCHED_FIFO: nothing to hold the node to.
            crate::skip::skip(format!(
                "real-time grant: this process cannot set SCHED_FIFO (no CAP_SYS_NICE / \
                 RLIMIT_RTPRIO): {text}"
            ));
        } else if privileged {
            // Checked independently of the node: this process could set SCHED_FIFO, so the
            // unconfined node must have (a node that always refuses fails here).
            assert!(
                text.contains("realtime: control thread SCHED_FIFO priority 10"),
                "{text}"
            );
            assert_eq!((policy, prio), (1, 10), "{text}");
            assert!(
                text.contains("realtime: RustDDS threads SCHED_FIFO priority 9 (1 thread)"),
                "{text}"
            );
            assert_eq!(dds, (1, 9), "{text}");
            match cpu_latency_target() {
                Some(us) => assert_eq!(us, 0, "{text}"),
                None => crate::skip::skip("cpu_latency_us check: /dev/cpu_dma_latency unreadable"),
            }
            assert!(locked_kb > 1000, "VmLck {locked_kb} kB\n{text}");
        } else {
            assert!(
                text.contains("control thread SCHED_FIFO priority 10 REFUSED")
                    && text.contains("CAP_SYS_NICE")
                    && text.contains("running without it"),
                "{text}"
            );
            assert!(
                text.contains("mlockall") && text.contains("CAP_IPC_LOCK"),
                "{text}"
            );
            assert!(
                text.contains("RustDDS threads SCHED_FIFO priority 9 REFUSED"),
                "{text}"
            );
            assert_eq!(policy, 0, "{text}");
            assert_eq!(dds.0, 0, "{text}");
            assert_eq!(locked_kb, 0, "{text}");
        }
        assert_eq!(node.term(), 0, "{}", common::log_tail(&log));
        if let Some(us) = cpu_latency_target() {
            assert_ne!(us, 0, "the CPU latency request outlived the node");
        }
    }
}

/// The kernel's current PM QoS CPU latency target (µs), read from `/dev/cpu_dma_latency`
/// (`None` when it cannot be read, e.g. without root).
fn cpu_latency_target() -> Option<i32> {
    let b = std::fs::read("/dev/cpu_dma_latency").ok()?;
    Some(i32::from_ne_bytes(b.get(..4)?.try_into().ok()?))
}

/// Whether a thread of this process may switch itself to SCHED_FIFO (priority 1): the
/// test's own reading of the grant the node asks for, on a throwaway thread.
fn can_sched_fifo() -> bool {
    std::thread::spawn(|| {
        let param = libc::sched_param { sched_priority: 1 };
        // SAFETY: changes only the calling (throwaway) thread's scheduling policy.
        unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) == 0 }
    })
    .join()
    .unwrap_or(false)
}
