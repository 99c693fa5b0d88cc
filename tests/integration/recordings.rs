//! Joint-state recordings from rosbag2 bags written by an independent tool (PyPI rosbags,
//! `tests/bags/write_recording.py`) in both storage formats, SQLite3 and MCAP: joints
//! matched by name among extra ones in a shuffled order, header or receive stamps, and bad
//! recordings refused with the bag and the problem named.

use std::path::{Path, PathBuf};
use std::process::Command;

use crossym::bag::{Bag, Storage};
use crossym::data::recording::{open_joint_states, RecordingError, StampSource};

use super::common;

/// Writes a recording with rosbags; returns the bag directory (and the dump, if asked).
fn write(
    tag: &str,
    storage: &str,
    fault: &str,
    dump: bool,
) -> (PathBuf, Option<serde_json::Value>) {
    write_with(tag, storage, fault, dump, &[])
}

/// [`write`] with more options of `write_recording.py` (e.g. `--split 3`).
fn write_with(
    tag: &str,
    storage: &str,
    fault: &str,
    dump: bool,
    extra: &[&str],
) -> (PathBuf, Option<serde_json::Value>) {
    let dir = common::temp_dir(&format!("rec-{tag}"));
    let bag = dir.join("bag");
    let json = dir.join("dump.json");
    let mut cmd = Command::new("python3");
    cmd.arg(common::path("tests/bags/write_recording.py"))
        .arg(&bag)
        .args(["--storage", storage, "--fault", fault])
        .args(extra);
    if dump {
        cmd.arg("--dump").arg(&json);
    }
    common::run_ok(&mut cmd);
    let dump =
        dump.then(|| serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap());
    (bag, dump)
}

fn planar_joints() -> Vec<String> {
    common::planar().kinematics.joint_names().to_vec()
}

/// Every sample equals what rosbags wrote, joint by joint by name, in both formats and with
/// both stamp sources.
#[test]
fn recordings_from_rosbags_match_what_was_written_in_both_storages() {
    let joints = planar_joints();
    for (storage, kind) in [("sqlite3", Storage::Sqlite3), ("mcap", Storage::Mcap)] {
        let (dir, dump) = write(storage, storage, "none", true);
        let dump = dump.unwrap();
        assert_eq!(Bag::open(&dir).unwrap().storage, kind);
        // The dump's joint order is the robot's (left_joint1..4, right_joint1..4); the bag's
        // is shuffled among four joints the robot does not have.
        let dumped: Vec<String> = serde_json::from_value(dump["joints"].clone()).unwrap();
        assert_eq!(dumped, joints);
        let order: Vec<String> = serde_json::from_value(dump["order"].clone()).unwrap();
        assert_ne!(&order[..8], &joints[..], "the writer shuffles");
        let rows = dump["rows"].as_array().unwrap();
        for stamps in [StampSource::Header, StampSource::Receive] {
            let r = open_joint_states(&dir, "/joint_states", &joints, stamps).unwrap();
            assert_eq!(r.len(), rows.len(), "{storage}");
            assert_eq!(
                r.ignored,
                [
                    "gripper_left_finger",
                    "gripper_right_finger",
                    "head_pan",
                    "torso_joint"
                ]
            );
            let key = match stamps {
                StampSource::Header => "stamp_ns",
                StampSource::Receive => "receive_ns",
            };
            let t0 = rows[0][key].as_i64().unwrap();
            assert_eq!(r.start_ns, i128::from(t0));
            for (k, row) in rows.iter().enumerate() {
                let q: Vec<f64> = serde_json::from_value(row["q"].clone()).unwrap();
                assert_eq!(r.q(k), &q[..], "{storage} sample {k}");
                let t = (row[key].as_i64().unwrap() - t0) as f64 * 1e-9;
                assert!((r.t[k] - t).abs() < 1e-12, "{storage} {stamps:?} t[{k}]");
            }
        }
    }
}

/// A split bag (three storage files and one metadata.yaml, as `ros2 bag record
/// --max-bag-duration` writes it; rosbags' Reader reads it back before the writer exits)
/// reads as the one recording it is, in both storages: every sample as written, the
/// topic counts summed; a fault in its second file is refused with the bag directory and
/// the message's index in the whole recording.
#[test]
fn split_bags_read_as_one_recording() {
    let joints = planar_joints();
    for (storage, kind, ext) in [
        ("sqlite3", Storage::Sqlite3, "db3"),
        ("mcap", Storage::Mcap, "mcap"),
    ] {
        let (dir, dump) = write_with(
            &format!("split-{storage}"),
            storage,
            "none",
            true,
            &["--split", "3"],
        );
        let files = std::fs::read_dir(&dir)
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .path()
                    .extension()
                    .is_some_and(|x| x == ext)
            })
            .count();
        assert_eq!(files, 3, "{storage}: the writer splits");
        let bag = Bag::open(&dir).unwrap();
        assert_eq!(bag.storage, kind);
        let info = bag.info();
        assert_eq!(info.message_count, 301, "{storage}");
        let mut counts: Vec<_> = info
            .topics
            .iter()
            .map(|t| (t.name.as_str(), t.count))
            .collect();
        counts.sort();
        assert_eq!(
            counts,
            [("/joint_states", 300), ("/robot_description", 1)],
            "{storage}"
        );
        let rows = dump.unwrap()["rows"].as_array().unwrap().clone();
        let r = open_joint_states(&dir, "/joint_states", &joints, StampSource::Header).unwrap();
        assert_eq!(r.len(), rows.len(), "{storage}");
        let t0 = rows[0]["stamp_ns"].as_i64().unwrap();
        for (k, row) in rows.iter().enumerate() {
            let q: Vec<f64> = serde_json::from_value(row["q"].clone()).unwrap();
            assert_eq!(r.q(k), &q[..], "{storage} sample {k}");
            let t = (row["stamp_ns"].as_i64().unwrap() - t0) as f64 * 1e-9;
            assert!((r.t[k] - t).abs() < 1e-12, "{storage} t[{k}]");
        }
        let (bad, _) = write_with(
            &format!("split-nan-{storage}"),
            storage,
            "nan",
            false,
            &["--split", "3"],
        );
        let e = open_joint_states(&bad, "/joint_states", &joints, StampSource::Header)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(bad.to_str().unwrap())
                && e.contains("message 150")
                && e.contains("`right_joint2` is NaN"),
            "{storage}: {e}"
        );
    }
}

fn refused(storage: &str, fault: &str, stamps: StampSource) -> String {
    let (dir, _) = write(&format!("{storage}-{fault}"), storage, fault, false);
    let e = open_joint_states(&dir, "/joint_states", &planar_joints(), stamps).unwrap_err();
    let text = e.to_string();
    let db = if storage == "sqlite3" {
        "bag.db3"
    } else {
        "bag.mcap"
    };
    assert!(text.contains(db), "the error names the bag file: {text}");
    text
}

/// Each fault rosbags writes into the middle of a recording is refused, naming the message
/// (index 150 of 300) and the problem.
#[test]
fn bad_recordings_are_refused_with_the_bag_and_the_problem() {
    for storage in ["sqlite3", "mcap"] {
        let nan = refused(storage, "nan", StampSource::Header);
        assert!(
            nan.contains("message 150") && nan.contains("`right_joint2` is NaN"),
            "{nan}"
        );
        let back = refused(storage, "backwards", StampSource::Header);
        assert!(
            back.contains("message 150") && back.contains("not after the previous one (-0.005"),
            "{back}"
        );
        let dup = refused(storage, "duplicate", StampSource::Header);
        assert!(dup.contains("a duplicate"), "{dup}");
        let missing = refused(storage, "missing-joint", StampSource::Header);
        assert!(missing.contains("`left_joint3` is missing"), "{missing}");
        let zero = refused(storage, "zero-stamps", StampSource::Header);
        assert!(
            zero.contains("message 1 ") && zero.contains("a duplicate"),
            "{zero}"
        );
        // A driver without stamps is still usable through the receive time.
        let (dir, _) = write(&format!("{storage}-zero-ok"), storage, "zero-stamps", false);
        let r = open_joint_states(
            &dir,
            "/joint_states",
            &planar_joints(),
            StampSource::Receive,
        )
        .unwrap();
        assert_eq!(r.len(), 300);
    }
}

/// Bags that are not what was asked for: topic absent, wrong type, truncated storage file,
/// a directory that is not a bag.
#[test]
fn unreadable_or_unsuitable_bags_are_refused() {
    let joints = planar_joints();
    let (dir, _) = write("topics", "sqlite3", "none", false);
    let e = open_joint_states(&dir, "/arm/joint_states", &joints, StampSource::Header)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no topic /arm/joint_states")
            && e.contains("/joint_states (sensor_msgs/msg/JointState)"),
        "{e}"
    );
    let e =
        open_joint_states(&dir, "/robot_description", &joints, StampSource::Header).unwrap_err();
    assert!(matches!(e, RecordingError::WrongType { .. }), "{e}");
    // Truncated storage files, in both formats.
    for storage in ["sqlite3", "mcap"] {
        let (dir, _) = write(&format!("trunc-{storage}"), storage, "none", false);
        let file = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|p| p.extension().is_some_and(|x| x == "db3" || x == "mcap"))
            .unwrap();
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..bytes.len() / 3]).unwrap();
        let e = open_joint_states(&dir, "/joint_states", &joints, StampSource::Header)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(file.file_name().unwrap().to_str().unwrap()),
            "{e}"
        );
        assert!(e.contains("not a readable"), "{storage}: {e}");
    }
    // A directory without a storage file, and a file that is not a database.
    let empty = common::temp_dir("rec-not-a-bag");
    let e = open_joint_states(&empty, "/joint_states", &joints, StampSource::Header)
        .unwrap_err()
        .to_string();
    assert!(e.contains("not a rosbag2 bag"), "{e}");
    let fake = empty.join("x.db3");
    std::fs::write(
        &fake,
        b"this is not an SQLite database, it is plain text....",
    )
    .unwrap();
    let e = open_joint_states(&fake, "/joint_states", &joints, StampSource::Header)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("x.db3") && e.contains("not a readable rosbag2 SQLite3 file"),
        "{e}"
    );
    assert!(!Path::new(&empty.join("missing.db3")).exists());
    let e = open_joint_states(
        &empty.join("missing.db3"),
        "/joint_states",
        &joints,
        StampSource::Header,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("missing.db3"), "{e}");
    assert!(
        !empty.join("missing.db3").exists(),
        "reading must not create a database"
    );
}

/// `crossym bag info` reads an SQLite3 bag like an MCAP one.
#[test]
fn bag_info_reads_sqlite3_bags() {
    let (dir, _) = write("info", "sqlite3", "none", false);
    let text = common::run_ok(common::crossym(["bag", "info"]).arg(&dir));
    assert!(text.contains("Storage id:    sqlite3"), "{text}");
    assert!(
        text.contains("Topic: /joint_states | Type: sensor_msgs/msg/JointState | Count: 300"),
        "{text}"
    );
}

/// `crossym demos` on a config with recorded sources (SQLite3 and MCAP, one with a NaN):
/// a report line per source, the bad one refused by name (exit 1), figures with text; exit
/// 0 once the bad source is left out.
#[test]
fn demos_cli_reports_every_source_and_refuses_the_bad_one() {
    let dir = common::temp_dir("rec-demos-cli");
    for (name, storage, fault) in [
        ("pick_1", "sqlite3", "none"),
        ("pick_2", "mcap", "none"),
        ("pick_3", "mcap", "nan"),
        ("pick_4", "sqlite3", "gap"),
    ] {
        common::run_ok(
            Command::new("python3")
                .arg(common::path("tests/bags/write_recording.py"))
                .arg(dir.join(name))
                .args(["--storage", storage, "--fault", fault]),
        );
    }
    let robot = std::fs::read_to_string(common::path("config/letters.toml")).unwrap();
    let robot = &robot[robot.find("[robot]").unwrap()..robot.find("[kinematics]").unwrap()];
    let robot = robot.replace(
        "../urdf/planar_dual_arm.urdf",
        common::path("urdf/planar_dual_arm.urdf").to_str().unwrap(),
    );
    let sources = |names: &[&str]| {
        names
            .iter()
            .map(|n| format!("[[demonstrations.sources]]\nname = \"{n}\"\nbag = \"{n}\"\n"))
            .collect::<String>()
    };
    let cfg = dir.join("teach.toml");
    std::fs::write(
        &cfg,
        format!(
            "{robot}\n[demonstrations]\ndt = 0.01\ntrain = [\"pick_1\", \"pick_2\"]\ntest = [\"pick_3\"]\n{}",
            sources(&["pick_1", "pick_2", "pick_3", "pick_4"])
        ),
    )
    .unwrap();
    let out = common::crossym(["demos", "--config"])
        .arg(&cfg)
        .arg("--plot")
        .arg(dir.join("figs"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(1), "{text}");
    assert!(text.contains("pick_1.db3 (300 samples"), "{text}");
    assert!(text.contains("pick_2.mcap (300 samples"), "{text}");
    assert!(
        text.contains("REFUSED: source `pick_3`: ")
            && text.contains("position of `right_joint2` is NaN"),
        "{text}"
    );
    // The dropout bag is refused by name, with where and how long the gap is.
    assert!(
        text.contains("REFUSED: source `pick_4`: ") && text.contains("a gap of 0.3"),
        "{text}"
    );
    assert!(
        text.contains("ignored joints: gripper_left_finger"),
        "{text}"
    );
    assert!(
        text.contains("1 pick_1: 299 samples") && text.contains("(train)"),
        "{text}"
    );
    for png in ["demos_task.png", "demos_joints.png"] {
        let ink = common::run_ok(
            Command::new("python3")
                .arg(common::path("tests/tools/png_ink.py"))
                .arg(dir.join("figs").join(png))
                .arg("0:36"),
        );
        let n: usize = ink.lines().nth(1).unwrap().parse().unwrap();
        assert!(n > 100, "{png}: no title ({n} dark pixels)");
    }
    // Without the bad source, and with a name that is not a source: exit 0, then a config
    // error naming it.
    std::fs::write(
        &cfg,
        format!(
            "{robot}\n[demonstrations]\ndt = 0.01\ntrain = [\"pick_1\"]\ntest = [\"pick_2\"]\n{}",
            sources(&["pick_1", "pick_2"])
        ),
    )
    .unwrap();
    let ok = common::run_ok(common::crossym(["demos", "--config"]).arg(&cfg));
    assert!(!ok.contains("OUTSIDE"), "{ok}");
    // A narrower range for left_joint1 than the wave (0.785 ± 0.3 rad) keeps to: the samples
    // beyond it are flagged in the report.
    let narrowed = robot.replacen(
        "[robot]\n",
        "[robot]\nlimits = { left_joint1 = { upper = 0.9 } }\n",
        1,
    );
    assert_ne!(narrowed, robot);
    std::fs::write(
        &cfg,
        format!(
            "{narrowed}\n[demonstrations]\ndt = 0.01\ntrain = [\"pick_1\"]\ntest = [\"pick_2\"]\n{}",
            sources(&["pick_1", "pick_2"])
        ),
    )
    .unwrap();
    let flagged = common::run_ok(common::crossym(["demos", "--config"]).arg(&cfg));
    assert!(
        flagged.contains("samples OUTSIDE the joint limits"),
        "{flagged}"
    );
    std::fs::write(
        &cfg,
        format!(
            "{robot}\n[demonstrations]\ndt = 0.01\ntrain = [\"pick_9\"]\n{}",
            sources(&["pick_1"])
        ),
    )
    .unwrap();
    let out = common::crossym(["demos", "--config"])
        .arg(&cfg)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("`pick_9` is not a source"),
        "{err}"
    );
}

/// The planar robot's `[robot]` … `[kinematics]` sections with an absolute URDF path.
fn planar_robot_toml() -> String {
    let text = std::fs::read_to_string(common::path("config/letters.toml")).unwrap();
    let robot = &text[text.find("[robot]").unwrap()..text.find("[[symmetries]]").unwrap()];
    robot.replace(
        "../urdf/planar_dual_arm.urdf",
        common::path("urdf/planar_dual_arm.urdf").to_str().unwrap(),
    )
}

/// A minimum-jerk phase `s(τ)` held at 0 before and 1 after.
fn min_jerk(tau: f64) -> f64 {
    let t = tau.clamp(0.0, 1.0);
    t * t * t * (10.0 - 15.0 * t + 6.0 * t * t)
}

/// A CSV of joint positions (columns shuffled, an extra column, irregular `t`) and a CSV of
/// task positions become demonstrations through the same `[demonstrations]` schema as bags:
/// the joint file's samples match the analytic motion on the `dt` grid after idle trimming,
/// and the task file is tracked into joint space from `start` with its FK on the targets.
#[test]
fn csv_sources_of_joint_and_task_positions_load_as_demonstrations() {
    let dir = common::temp_dir("csv-sources");
    let robot = common::planar();
    let kin = &robot.kinematics;
    let joints = kin.joint_names().to_vec();
    use std::f64::consts::PI;
    let rest = [
        PI / 4.0,
        -PI / 6.0,
        -PI / 8.0,
        -PI / 10.0,
        -PI / 4.0,
        PI / 6.0,
        PI / 8.0,
        PI / 10.0,
    ];
    let delta = [0.4, -0.3, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0];
    // q(t) = rest + s((t − 0.5)/2) Δ: 0.5 s idle, 2 s motion, 0.5 s idle.
    let q_at = |t: f64| -> Vec<f64> {
        let s = min_jerk((t - 0.5) / 2.0);
        rest.iter().zip(&delta).map(|(r, d)| r + s * d).collect()
    };
    let mut order: Vec<usize> = (0..8).rev().collect();
    order.swap(0, 5);
    let mut csv = String::from("gripper,");
    csv += &order
        .iter()
        .map(|&j| joints[j].as_str())
        .collect::<Vec<_>>()
        .join(",");
    csv += ",t\n";
    let mut t = 0.0;
    let mut k = 0;
    while t <= 3.0 {
        let q = q_at(t);
        csv += &format!(
            "0.5,{},{t}\n",
            order
                .iter()
                .map(|&j| q[j].to_string())
                .collect::<Vec<_>>()
                .join(",")
        );
        // 2 ms stamps with a deterministic ±0.3 ms wobble.
        k += 1;
        t = k as f64 * 0.002 + 0.0003 * ((k * 7919) % 13) as f64 / 13.0;
    }
    std::fs::write(dir.join("joints.csv"), csv).unwrap();
    // Task CSV: the left hand draws a small circle (every dt), the right holds `start`.
    let mut ws = kin.workspace();
    let x0 = kin.forward(&rest, &mut ws).as_slice().to_vec();
    let mut task = String::from("t,left.x,left.y\n");
    let targets: Vec<[f64; 2]> = (0..300)
        .map(|i| {
            let a = i as f64 / 299.0 * std::f64::consts::TAU;
            [x0[0] + 0.3 * (1.0 - a.cos()), x0[1] + 0.3 * a.sin()]
        })
        .collect();
    for (i, p) in targets.iter().enumerate() {
        task += &format!("{},{},{}\n", i as f64 * 0.01, p[0], p[1]);
    }
    std::fs::write(dir.join("task.csv"), task).unwrap();
    let text = format!(
        "{}\n[demonstrations]\ndt = 0.01\ntrain = [\"joints\"]\ntest = [\"circle\"]\n\
         [[demonstrations.sources]]\nname = \"joints\"\ncsv = \"joints.csv\"\n\
         [[demonstrations.sources]]\nname = \"circle\"\ncsv = \"task.csv\"\nstart = {:?}\n",
        planar_robot_toml(),
        rest
    );
    let cfg_path = dir.join("csv.toml");
    std::fs::write(&cfg_path, &text).unwrap();
    let cfg = crossym::config::Config::from_file(&cfg_path).unwrap();
    let d = cfg.load_demonstrations(kin).unwrap();
    assert_eq!(d.names, ["joints", "circle"]);
    assert_eq!(
        (d.train.as_slice(), d.test.as_slice()),
        (&[1][..], &[2][..])
    );
    // Joints: idle trimmed to the last idle sample before motion — the minimum-jerk onset
    // passes idle_speed = 0.02 rad/s at τ ≈ 0.058, t ≈ 0.62 s, and ends as it falls below it
    // (≈ 1.77 s of motion) — every sample on the analytic motion (linear interpolation of
    // 2 ms samples: ≤ 1e-5 rad).
    let j = &d.demos[0];
    let crossym::data::demonstrations::SourceDetail::Recorded(r) = &d.sources[0].detail else {
        panic!("a joint CSV is a recording");
    };
    assert_eq!(r.ignored, ["gripper"]);
    let t0 = r.starts_s[0];
    assert!((0.58..=0.63).contains(&t0), "motion starts at {t0}");
    for i in 0..j.len() {
        let want = q_at(t0 + i as f64 * 0.01);
        let err = common::dist(j.q(i), &want);
        assert!(err < 1e-5, "sample {i}: {err:e}");
    }
    assert!(
        (j.len() as f64 * 0.01 - 1.77).abs() < 0.05,
        "{} samples",
        j.len()
    );
    // Task: FK of the tracked joint path on the targets (one DLS step per sample: the
    // error is the per-step lag, a few 1e-4 on this 1.9-unit circle), the right arm still.
    let c = &d.demos[1];
    assert_eq!(
        c.len(),
        299,
        "300 samples minus the forward difference's last"
    );
    for (i, target) in targets.iter().take(c.len()).enumerate() {
        let x = kin.forward(c.q(i), &mut ws).as_slice().to_vec();
        assert!(common::dist(&x[..2], target) < 1e-3, "sample {i}");
        assert!(
            common::dist(&c.q(i)[4..], &rest[4..]) < 1e-9,
            "right arm moved"
        );
    }
    // Refusals name the file and the problem.
    for (body, needle) in [
        ("t,left.x\n0,1\n", "needs all of its 2 task columns"),
        (
            "left_joint1,left_joint2\n0,0\n",
            "no column for joint `left_joint3`",
        ),
        ("t,left.x,left.y\n0,1,nan\n", "is not a finite number"),
        ("t,left.x,left.y\n0,1,1\n0.5,1,1\n", "sampled every dt"),
    ] {
        std::fs::write(dir.join("task.csv"), body).unwrap();
        let e = cfg.load_demonstrations(kin).unwrap_err().to_string();
        assert!(e.contains("task.csv") && e.contains(needle), "{body}: {e}");
    }
}

/// A config written for the previous release, with a `[letters]` section, loads the same
/// demonstrations, bit for bit, as the shipped `config/letters.toml` in the
/// `[demonstrations]` schema; both sections at once are refused.
#[test]
fn a_legacy_letters_section_loads_the_same_demonstrations() {
    let shipped = common::load_config("letters.toml");
    let text = std::fs::read_to_string(common::path("config/letters.toml")).unwrap();
    let (a, b) = (
        text.find("[demonstrations]").unwrap(),
        text.find("[augmentation]").unwrap(),
    );
    let legacy = format!(
        "{}[letters]\n\
         arms = [\n\
         {{ chain = \"left\", letter = \"../data/lasa/CShape.mat\", rest = [0.7853981633974483, -0.5235987755982988, -0.39269908169872414, -0.3141592653589793], offset = [5.0, -1.5] }},\n\
         {{ chain = \"right\", letter = \"../data/lasa/NShape.mat\", rest = [-0.7853981633974483, 0.5235987755982988, 0.39269908169872414, 0.3141592653589793], offset = [5.0, 1.5] }},\n\
         ]\nhalf_range = 1.5\ntracking_damping = 1e-3\ndt = 0.01\ndrop = [10, 2, 10, 1]\n\
         train = [1, 2, 3, 4, 5]\ntest = [6, 7]\n\n{}",
        &text[..a],
        &text[b..]
    );
    let path = common::path("config/legacy-letters.toml");
    let mut cfg = crossym::config::Config::from_toml_str(&legacy, &path).unwrap();
    cfg.base_dir = shipped.base_dir.clone();
    let robot = shipped.load_robot().unwrap();
    let kin = &robot.kinematics;
    let (old, new) = (
        cfg.load_demonstrations(kin).unwrap(),
        shipped.load_demonstrations(kin).unwrap(),
    );
    assert_eq!(old.demos, new.demos);
    assert_eq!((old.train, old.test), (new.train, new.test));
    let both = legacy.replace("[augmentation]", &format!("{}[augmentation]", &text[a..b]));
    let e = crossym::config::Config::from_toml_str(&both, &path).unwrap_err();
    assert!(
        e.to_string()
            .contains("both [letters] and [demonstrations]"),
        "{e}"
    );
}

/// `crossym train` on a config whose bag source is bad (a NaN position, a truncated file)
/// fails with the source, the bag and the problem named, and writes nothing: no policy, no
/// sidecar, no loss log.
#[test]
fn training_refuses_a_bad_recording_and_writes_nothing() {
    let dir = common::temp_dir("rec-train-refuses");
    for (name, storage, fault) in [("good", "mcap", "none"), ("bad", "sqlite3", "nan")] {
        common::run_ok(
            Command::new("python3")
                .arg(common::path("tests/bags/write_recording.py"))
                .arg(dir.join(name))
                .args(["--storage", storage, "--fault", fault]),
        );
    }
    // A copy of the good bag with its MCAP file cut in half.
    let cut = dir.join("cut");
    std::fs::create_dir_all(&cut).unwrap();
    for e in std::fs::read_dir(dir.join("good")).unwrap() {
        let p = e.unwrap().path();
        let bytes = std::fs::read(&p).unwrap();
        let name = p
            .file_name()
            .unwrap()
            .to_string_lossy()
            .replace("good", "cut");
        let keep = if name.ends_with(".mcap") {
            bytes.len() / 2
        } else {
            bytes.len()
        };
        let text = String::from_utf8_lossy(&bytes[..keep]).replace("good", "cut");
        if name.ends_with(".yaml") {
            std::fs::write(cut.join(name), text).unwrap();
        } else {
            std::fs::write(cut.join(name), &bytes[..keep]).unwrap();
        }
    }
    let text = std::fs::read_to_string(common::path("config/letters.toml")).unwrap();
    let head = &text[text.find("[robot]").unwrap()..text.find("[demonstrations]").unwrap()];
    let head = head.replace(
        "../urdf/planar_dual_arm.urdf",
        common::path("urdf/planar_dual_arm.urdf").to_str().unwrap(),
    );
    for (bad, needle) in [
        (
            "bad",
            "message 150 (t = 1.499 s): position of `right_joint2` is NaN",
        ),
        ("cut", "cut.mcap: not a readable MCAP file"),
    ] {
        let cfg = dir.join(format!("train-{bad}.toml"));
        std::fs::write(
            &cfg,
            format!(
                "{head}\n[demonstrations]\ndt = 0.01\ntrain = [\"good\", \"{bad}\"]\n\
                 [[demonstrations.sources]]\nname = \"good\"\nbag = \"good\"\n\
                 [[demonstrations.sources]]\nname = \"{bad}\"\nbag = \"{bad}\"\n\
                 [augmentation]\ntrain = {{ reflection = true }}\ntest = {{ reflection = true }}\n\
                 [train]\nhidden = [8]\niterations = 2\nbatch_size = 4\n"
            ),
        )
        .unwrap();
        let out = dir.join(format!("policy-{bad}.safetensors"));
        let o = common::crossym(["train", "--config"])
            .arg(&cfg)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{bad}: training succeeded");
        assert!(
            err.contains(&format!("source `{bad}`")) && err.contains(needle),
            "{bad}: {err}"
        );
        for f in [
            out.clone(),
            out.with_extension("json"),
            out.with_extension("loss.csv"),
        ] {
            assert!(!f.exists(), "{bad}: {} was written", f.display());
        }
    }
}
