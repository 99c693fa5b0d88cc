//! rosbag2 MCAP bags: round trip, the independent tools (PyPI rosbags, mcap +
//! mcap-ros2-support) reading crossym's bags and writing bags crossym reads, the golden
//! bag's exact replay, and broken files.

use std::path::{Path, PathBuf};
use std::process::Command;

use crossym::bag::{Bag, BagError, BagWriter, Qos};
use crossym::config::Config;
use crossym::control::NodeCore;
use crossym::msg;
use crossym::policy::Policy;
use crossym::ros::replay::{replay, ReplayTopics};

use crate::common;

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("crossym-bag-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn names() -> Vec<String> {
    (1..=4)
        .map(|i| format!("left_joint{i}"))
        .chain((1..=4).map(|i| format!("right_joint{i}")))
        .collect()
}

fn js(k: usize) -> msg::JointState {
    msg::JointState {
        header: msg::Header {
            stamp: msg::Time::from_secs_f64(1.7e9 + k as f64 * 0.01),
            frame_id: "base".into(),
        },
        name: names(),
        position: (0..8).map(|j| 0.1 * j as f64 + 0.001 * k as f64).collect(),
        velocity: vec![0.5; 8],
        effort: Vec::new(),
    }
}

/// Writes a bag with all four node topics; returns (dir, messages per topic).
fn write_sample(dir: &Path) -> [usize; 4] {
    let mut w = BagWriter::create(dir).unwrap();
    let tj = w
        .add_topic::<msg::JointState>("/joint_states", Qos::best_effort(5))
        .unwrap();
    let tc = w
        .add_topic::<msg::SymmetryCondition>("/crossym/symmetry_condition", Qos::reliable(10))
        .unwrap();
    let tm = w
        .add_topic::<msg::Float64MultiArray>(
            "/forward_velocity_controller/commands",
            Qos::reliable(10),
        )
        .unwrap();
    let ts = w
        .add_topic::<msg::Status>("/crossym/status", Qos::reliable(10))
        .unwrap();
    let t0 = 1_700_000_000_000_000_000u64;
    let mut counts = [0; 4];
    for k in 0..100usize {
        let t = t0 + k as u64 * 10_000_000;
        w.write(tj, &js(k), t, k as u32).unwrap();
        counts[0] += 1;
        w.write(
            tm,
            &msg::Float64MultiArray {
                layout: Default::default(),
                data: (0..8).map(|j| 0.01 * (j + k) as f64).collect(),
            },
            t + 1000,
            0,
        )
        .unwrap();
        counts[2] += 1;
        if k % 50 == 0 {
            w.write(
                tc,
                &msg::SymmetryCondition {
                    header: Default::default(),
                    theta: 0.5 * k as f64 / 50.0,
                    scale: 0.8,
                    reflection: -1,
                },
                t + 500,
                0,
            )
            .unwrap();
            counts[1] += 1;
        }
        if k % 10 == 0 {
            w.write(
                ts,
                &msg::Status {
                    code: 5,
                    message: "joint bound".into(),
                    ticks: k as u64,
                    condition: msg::SymmetryCondition {
                        header: Default::default(),
                        theta: 0.1,
                        scale: 1.0,
                        reflection: 1,
                    },
                    ..Default::default()
                },
                t + 2000,
                0,
            )
            .unwrap();
            counts[3] += 1;
        }
    }
    w.finish().unwrap();
    counts
}

#[test]
fn write_then_read_round_trips() {
    let dir = tmp("roundtrip");
    let counts = write_sample(&dir);
    let meta = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
    assert!(meta.contains("storage_identifier: mcap"), "{meta}");
    assert!(meta.contains("rosbag2_bagfile_information"));
    let bag = Bag::open(&dir).unwrap();
    let info = bag.info();
    assert_eq!(info.message_count, counts.iter().sum::<usize>());
    let j = bag.topic("/joint_states").unwrap();
    assert_eq!(bag.topics[j].count, counts[0]);
    assert_eq!(bag.topics[j].ros_type, "sensor_msgs/msg/JointState");
    assert!(bag.topics[j]
        .qos
        .as_deref()
        .unwrap()
        .contains("reliability: 2"));
    // Log-time order, exact values.
    assert!(bag.messages.windows(2).all(|w| w[0].log_ns <= w[1].log_ns));
    let mut k = 0;
    for (i, m) in bag.messages.iter().enumerate() {
        if m.topic == j {
            let d: msg::JointState = bag.decode(i).unwrap();
            assert_eq!(d, js(k));
            assert_eq!(m.sequence, k as u32);
            k += 1;
        }
    }
    assert_eq!(k, 100);
    // Decoding as the wrong type is an error naming the topic, not a panic.
    let first_js = bag.messages.iter().position(|m| m.topic == j).unwrap();
    let e = bag.decode::<msg::Status>(first_js).unwrap_err().to_string();
    assert!(e.contains("/joint_states"), "{e}");
    // The text of `crossym bag info`.
    let text = info.to_string();
    assert!(text.contains("Topic: /crossym/status | Type: crossym_msgs/msg/Status | Count: 10"));
}

fn python_tools() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import rosbags, mcap, mcap_ros2, yaml"])
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    assert!(
        ok,
        "PyPI rosbags / mcap / mcap-ros2-support are missing: run `bash tests/bags/install.sh` (.ci/run does)"
    );
    ok
}

/// rosbags' AnyReader and mcap + mcap-ros2-support read a crossym bag and decode every
/// message identically; metadata.yaml agrees with the MCAP file.
#[test]
fn independent_tools_read_crossym_bags() {
    python_tools();
    let dir = tmp("for-python");
    write_sample(&dir);
    for bag in [
        dir.clone(),
        common::root().join("tests/data/golden_letters"),
    ] {
        let out = Command::new("python3")
            .arg(common::root().join("tests/bags/read_bag.py"))
            .arg(&bag)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(
            out.status.success() && stdout.contains("read_bag: ALL OK"),
            "{}:\n{stdout}\n{}",
            bag.display(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
}

/// The bag tools' own self-test (`tests/bags/selftest.sh`): bags written by rosbags pass
/// `read_bag.py`, and a bag whose metadata.yaml claims one message too many fails it on that
/// count — the checker can fail, so its ALL OK above means something.
#[test]
fn bag_tools_selftest_detects_a_corrupted_bag() {
    python_tools();
    let out = Command::new("bash")
        .arg(common::root().join("tests/bags/selftest.sh"))
        .env("PYTHON", "python3")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let report = format!("{stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(
        out.status.success(),
        "selftest.sh exited with {:?}:\n{report}",
        out.status.code()
    );
    for step in ["default", "all_topics", "v8_zstd", "no_qos", "long"] {
        assert!(
            stdout.contains(&format!("selftest: {step} OK (read_bag: ALL OK")),
            "step {step}:\n{report}"
        );
    }
    let line = stdout
        .lines()
        .find(|l| l.starts_with("selftest: corrupted bag detected OK"))
        .unwrap_or_else(|| panic!("no corrupted-bag step:\n{report}"));
    assert!(line.ends_with("checks FAILED)"), "{line}");
}

fn letters() -> (Config, NodeCore) {
    let cfg = Config::from_file(common::root().join("config/letters.toml")).unwrap();
    let core = crossym::setup::node_core(&cfg, cfg.node_config()).unwrap();
    (cfg, core)
}

/// A bag written by rosbags (MCAP storage, versions 9 and 8) is read by crossym and its
/// inputs drive the node's logic: every command finite and inside the velocity limits.
#[test]
fn crossym_reads_and_replays_rosbags_bags() {
    python_tools();
    for version in ["9", "8"] {
        let dir = tmp(&format!("rosbags-v{version}"));
        let stdout = common::run_ok(
            Command::new("python3")
                .arg(common::root().join("tests/bags/write_bag.py"))
                .arg(&dir)
                .arg("--msgs")
                .arg(common::root().join("msgs/msg"))
                .args(["--seconds", "2", "--all-topics", "--version", version]),
        );
        let summary: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        let bag = Bag::open(&dir).unwrap();
        let (_, mut core) = letters();
        let j = bag.topic("/joint_states").unwrap();
        let c = bag.topic("/crossym/symmetry_condition").unwrap();
        assert_eq!(bag.topics[j].count, 200, "{summary}");
        assert_eq!(bag.topics[c].count, 2);
        let s = bag.topic("/crossym/status").unwrap();
        let m = bag.topic("/forward_velocity_controller/commands").unwrap();
        let mut cmd = core.command();
        let mut ticks = 0;
        for (i, raw) in bag.messages.iter().enumerate() {
            let now = raw.log_ns as f64 * 1e-9;
            if raw.topic == j {
                let js: msg::JointState = bag.decode(i).unwrap();
                core.on_joint_state(&js, now).unwrap();
                core.tick(now, &mut cmd);
                ticks += 1;
                for (v, l) in cmd.velocities.iter().zip(core.limits()) {
                    assert!(v.is_finite() && v.abs() <= l.velocity + 1e-12);
                }
            } else if raw.topic == c {
                let sc: msg::SymmetryCondition = bag.decode(i).unwrap();
                core.on_condition(&sc).unwrap();
            } else if raw.topic == s {
                let st: msg::Status = bag.decode(i).unwrap();
                assert_eq!(st.condition.reflection.abs(), 1);
            } else if raw.topic == m {
                let a: msg::Float64MultiArray = bag.decode(i).unwrap();
                assert_eq!(a.data.len(), 8);
            }
        }
        assert_eq!(ticks, 200);
        assert_eq!((core.condition().theta * 1e4).round(), 5236.0);
    }
}

fn replay_topics(core: &NodeCore) -> ReplayTopics {
    ReplayTopics::for_node(core.config())
}

/// The golden bag (a closed-loop run of the shipped policy with a condition switch,
/// recorded by `crossym demo` on an AVX2 + FMA CPU) replays bit for bit there; a CPU taking
/// the portable dot-product kernel rounds the MLP differently and replays to 1e-9.
#[test]
fn golden_bag_replays_exactly() {
    let bag = Bag::open(&common::root().join("tests/data/golden_letters")).unwrap();
    let (_, mut core) = letters();
    let topics = replay_topics(&core);
    let r = replay(&bag, &mut core, &topics).unwrap();
    assert!(r.commands > 200, "{r:?}");
    assert_eq!(r.unmatched, 0);
    if crossym::policy::dot_kernel() == "avx2+fma" {
        assert_eq!(r.max(), 0.0, "{r:?}");
    } else {
        eprintln!("portable dot kernel: replay to rounding, not bit for bit");
        assert!(r.max() <= 1e-9, "{r:?}");
    }
    // The CLI says the same and exits 0.
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .arg("replay")
        .arg(common::root().join("tests/data/golden_letters"))
        .arg("--config")
        .arg(common::root().join("config/letters.toml"))
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("replay: OK"));
    // A different policy does not reproduce it: replay detects the change.
    let cfg = Config::from_file(common::root().join("config/letters.toml")).unwrap();
    let robot = cfg.load_robot().unwrap();
    let n = cfg.node.clone().unwrap();
    let other = Policy::synthetic(8, names(), &[16], 3);
    let mut core = NodeCore::new(robot.kinematics, other, n.safety, n).unwrap();
    let r = replay(&bag, &mut core, &topics).unwrap();
    assert!(r.max() > 1e-6, "{r:?}");
}

#[test]
fn broken_bags_are_clear_errors() {
    let dir = tmp("broken");
    write_sample(&dir);
    let mcap = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "mcap"))
        .unwrap();
    let bytes = std::fs::read(&mcap).unwrap();
    let check = |name: &str, data: &[u8], want: &str| {
        let p =
            std::env::temp_dir().join(format!("crossym-bag-{name}-{}.mcap", std::process::id()));
        std::fs::write(&p, data).unwrap();
        let e = match Bag::open(&p) {
            Err(e) => e,
            Ok(b) => panic!("{name}: opened with {} messages", b.messages.len()),
        };
        let text = e.to_string();
        assert!(text.contains(p.to_str().unwrap()), "{name}: {text}");
        assert!(text.contains(want), "{name}: `{text}` lacks `{want}`");
        e
    };
    // Truncated mid-file.
    check(
        "truncated",
        &bytes[..bytes.len() / 2],
        "not a readable MCAP",
    );
    // Not MCAP at all.
    check("garbage", b"this is not a bag", "not a readable MCAP");
    // A corrupt chunk: flip bytes inside the data section.
    let summary = mcap::Summary::read(&bytes).unwrap().unwrap();
    let chunk = &summary.chunk_indexes[0];
    let mid = (chunk.chunk_start_offset + chunk.chunk_length / 2) as usize;
    let mut corrupt = bytes.clone();
    for b in &mut corrupt[mid..mid + 64] {
        *b ^= 0x5a;
    }
    let e = check("corrupt", &corrupt, "");
    assert!(matches!(
        e,
        BagError::Mcap { .. } | BagError::NotRos2 { .. }
    ));
    // Wrong profile and a non-CDR channel, written with the mcap crate directly.
    for (name, profile, encoding, want) in [
        ("profile", "ros1", "cdr", "profile is `ros1`"),
        ("encoding", "ros2", "json", "message encoding `json`"),
    ] {
        let mut buf = std::io::Cursor::new(Vec::new());
        {
            let mut w = mcap::WriteOptions::new()
                .profile(profile)
                .create(&mut buf)
                .unwrap();
            let s = w
                .add_schema("sensor_msgs/msg/JointState", "ros2msg", b"int32 x\n")
                .unwrap();
            let c = w
                .add_channel(s, "/joint_states", encoding, &Default::default())
                .unwrap();
            w.write_to_known_channel(
                &mcap::records::MessageHeader {
                    channel_id: c,
                    sequence: 0,
                    log_time: 1,
                    publish_time: 1,
                },
                &[0, 1, 0, 0, 1, 0, 0, 0],
            )
            .unwrap();
            w.finish().unwrap();
        }
        check(name, buf.get_ref(), want);
    }
    // Fuzz regression: a chunk declaring a huge uncompressed size (the mcap crate would
    // reserve it and abort) is refused before decompression.
    for f in [
        "bag_reader_chunk_size.mcap",
        "bag_reader_record_length.mcap",
    ] {
        let crash = common::root().join("tests/data/fuzz").join(f);
        let e = Bag::open(&crash).unwrap_err().to_string();
        assert!(e.contains("not a readable MCAP"), "{f}: {e}");
    }
    // A payload that is not CDR decodes to an error.
    let mut w = BagWriter::create(&tmp("badcdr")).unwrap();
    let t = w
        .add_topic::<msg::JointState>("/joint_states", Qos::reliable(1))
        .unwrap();
    w.write_raw(t, &[0, 1, 0, 0, 255, 255], 1, 1, 0).unwrap();
    let d = w.finish().unwrap();
    let bag = Bag::open(&d).unwrap();
    let e = bag.decode::<msg::JointState>(0).unwrap_err().to_string();
    assert!(
        e.contains("/joint_states") && e.contains("message 0"),
        "{e}"
    );
    // An existing output directory is refused (nothing is overwritten).
    assert!(BagWriter::create(&d).is_err());
    // The CLI maps these to exit 2 with the file named.
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .args(["bag", "info", "/nonexistent/bag"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/bag"));
}
