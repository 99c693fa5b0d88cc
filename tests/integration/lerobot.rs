//! LeRobot datasets: datasets written by an independent tool
//! (PyPI pyarrow, `tests/lerobot/write_dataset.py`, to LeRobot's documented layout; LeRobot's
//! own writer needs torch, which CI does not install) read back sample for sample in both
//! format versions, both state layouts and three codecs; each refusal names the file, the
//! column or the episode; a `lerobot` demonstration source loads one demonstration per
//! episode on RB-Y1.

use std::path::PathBuf;
use std::process::Command;

use crossym::lerobot::read_states;

use super::common;

/// Writes a dataset; returns its directory and the writer's dump.
fn write(tag: &str, args: &[&str]) -> (PathBuf, serde_json::Value) {
    let (out, dump) = write_only(tag, args, true);
    let v = serde_json::from_str(&std::fs::read_to_string(dump).unwrap()).unwrap();
    (out, v)
}

/// Writes a dataset (and its dump, if asked); returns the directory and the dump's path.
fn write_only(tag: &str, args: &[&str], dump: bool) -> (PathBuf, PathBuf) {
    let dir = common::temp_dir(&format!("lerobot-{tag}"));
    let out = dir.join("dataset");
    let dump_path = dir.join("dump.json");
    let mut cmd = Command::new("python3");
    cmd.arg(common::path("tests/lerobot/write_dataset.py"))
        .arg(&out)
        .args(args);
    if dump {
        cmd.arg("--dump").arg(&dump_path);
    }
    common::run_ok(&mut cmd);
    (out, dump_path)
}

fn arm_joints(dump: &serde_json::Value) -> Vec<String> {
    serde_json::from_value(dump["joints"].clone()).unwrap()
}

/// Every timestamp and every arm joint's value equals what the writer was given (float32
/// values, exactly), episode by episode; the state's names are the writer's shuffled ones.
#[test]
fn datasets_written_by_pyarrow_read_as_written() {
    assert!(
        common::python_has("pyarrow"),
        "PyPI pyarrow is missing: run `bash tests/bags/install.sh` (.ci/run does)"
    );
    for (tag, args) in [
        ("v3-list-snappy", vec!["--version", "v3.0"]),
        (
            "v21-list-zstd",
            vec!["--version", "v2.1", "--compression", "zstd"],
        ),
        (
            "v3-scalars-none",
            vec![
                "--version",
                "v3.0",
                "--layout",
                "scalars",
                "--compression",
                "none",
            ],
        ),
    ] {
        let (dir, dump) = write(tag, &args);
        let joints = arm_joints(&dump);
        let scalars: Vec<String> = if tag.contains("scalars") {
            joints.iter().map(|j| format!("{j}.pos")).collect()
        } else {
            Vec::new()
        };
        let d = read_states(&dir, "observation.state", &scalars).unwrap();
        assert_eq!(
            d.version,
            if tag.starts_with("v21") {
                "v2.1"
            } else {
                "v3.0"
            }
        );
        assert_eq!(d.fps, 50.0);
        let names: Vec<String> = if scalars.is_empty() {
            serde_json::from_value(dump["names"].clone()).unwrap()
        } else {
            scalars.clone()
        };
        assert_eq!(d.names, names, "{tag}");
        let eps = dump["episodes"].as_array().unwrap();
        assert_eq!(d.episodes.len(), eps.len(), "{tag}");
        for (e, want) in d.episodes.iter().zip(eps) {
            assert_eq!(e.index, want["episode_index"].as_i64().unwrap());
            assert_eq!(e.task_index, want["task_index"].as_i64().unwrap());
            let t: Vec<f64> = serde_json::from_value(want["t"].clone()).unwrap();
            assert_eq!(e.t, t, "{tag} episode {}", e.index);
            let q: Vec<Vec<f64>> = serde_json::from_value(want["q"].clone()).unwrap();
            let n = d.names.len();
            for (k, row) in q.iter().enumerate() {
                for (j, name) in joints.iter().enumerate() {
                    let col = d
                        .names
                        .iter()
                        .position(|x| x == name || x.strip_suffix(".pos") == Some(name))
                        .unwrap();
                    assert_eq!(
                        e.state[k * n + col],
                        row[j],
                        "{tag} ep {} frame {k} {name}",
                        e.index
                    );
                }
            }
        }
    }
}

/// Each fault the writer can plant is refused with the file (or dataset), the column or
/// episode, and the problem; nothing is repaired.
#[test]
fn bad_datasets_are_refused_by_name() {
    assert!(common::python_has("pyarrow"), "PyPI pyarrow is missing");
    let refused = |fault: &str| {
        let (dir, _) = write_only(
            &format!("fault-{fault}"),
            &["--version", "v3.0", "--fault", fault],
            false,
        );
        let e = read_states(&dir, "observation.state", &[])
            .unwrap_err()
            .to_string();
        (dir, e)
    };
    let (_, e) = refused("nan");
    assert!(
        e.contains("file-000.parquet")
            && e.contains("column `observation.state`")
            && e.contains("not finite"),
        "{e}"
    );
    let (_, e) = refused("backwards");
    assert!(
        e.contains("episode 1") && e.contains("timestamp of frame 40"),
        "{e}"
    );
    let (_, e) = refused("gap");
    assert!(
        e.contains("episode 1") && e.contains("frame_index jumps from 39 to 50"),
        "{e}"
    );
    let (_, e) = refused("shape");
    assert!(
        e.contains("meta/info.json") && e.contains("shape") && e.contains("20 names"),
        "{e}"
    );
    let (_, e) = refused("version");
    assert!(
        e.contains("codebase_version `v1.6` is not supported"),
        "{e}"
    );
    let (_, e) = refused("noinfo");
    assert!(e.contains("not a LeRobot dataset"), "{e}");
    let (_, e) = refused("truncate");
    assert!(
        e.contains("file-000.parquet") && e.contains("not a readable Parquet file"),
        "{e}"
    );
    // A state feature that does not exist.
    let (dir, _) = write("nofeature", &["--version", "v2.1"]);
    let e = read_states(&dir, "observation.joints", &[])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("no feature `observation.joints`") && e.contains("observation.state"),
        "{e}"
    );
}

/// A `lerobot` source on RB-Y1: one demonstration per episode named `<source>#<episode>`,
/// extra state names (torso, head, grippers) ignored and listed; `episodes` picks; a dataset
/// in degrees with `units = "deg"` gives the same demonstrations as one in radians; a
/// missing controlled joint is refused by name.
#[test]
fn a_lerobot_source_teaches_rby1_episodes() {
    if common::rby1_urdf().is_none() {
        return;
    }
    assert!(common::python_has("pyarrow"), "PyPI pyarrow is missing");
    let (rad, _) = write("src-rad", &["--version", "v3.0"]);
    let (deg, _) = write("src-deg", &["--version", "v2.1", "--degrees"]);
    let base = std::fs::read_to_string(common::path("config/rby1.toml")).unwrap();
    let base = base.replace(
        "\"../robots/",
        &format!("\"{}/", common::rby1_dir().parent().unwrap().display()),
    );
    let robot = &base[base.find("[robot]").unwrap()..base.find("[kinematics]").unwrap()];
    let dir = common::temp_dir("lerobot-src");
    let cfg = |dataset: &PathBuf, extra: &str| {
        let p = dir.join(format!("c{}.toml", extra.len()));
        std::fs::write(
            &p,
            format!(
                "{robot}\n[demonstrations]\ndt = 0.02\ntrain = [\"lr\"]\n[[demonstrations.sources]]\nname = \"lr\"\ndataset = \"{}\"\n{extra}\n",
                dataset.display()
            ),
        )
        .unwrap();
        p
    };
    let out = common::run_ok(common::crossym(["demos", "--config"]).arg(cfg(&rad, "")));
    assert!(
        out.contains("lr (lerobot): 3 episodes → 3 demonstrations"),
        "{out}"
    );
    assert!(
        out.contains(
            "ignored state names: gripper_left, gripper_right, head_0, head_1, torso_0, torso_1"
        ),
        "{out}"
    );
    for name in ["lr#0", "lr#1", "lr#2"] {
        assert!(out.contains(&format!(" {name}: ")), "{name}: {out}");
    }
    let one =
        common::run_ok(common::crossym(["demos", "--config"]).arg(cfg(&rad, "episodes = [2]")));
    assert!(
        one.contains("1 episode → 1 demonstration") && one.contains(" lr#2: "),
        "{one}"
    );
    // `task` picks by the task string (v3.0: meta/tasks.parquet; v2.1: meta/tasks.jsonl).
    let pan = common::run_ok(
        common::crossym(["demos", "--config"]).arg(cfg(&rad, "task = \"grasp the pan\"")),
    );
    assert!(
        pan.contains("1 episode → 1 demonstration") && pan.contains(" lr#1: "),
        "{pan}"
    );
    let letters = common::run_ok(
        common::crossym(["demos", "--config"])
            .arg(cfg(&deg, "units = \"deg\"\ntask = \"draw the letters\"")),
    );
    assert!(
        letters.contains("2 episodes → 2 demonstrations")
            && letters.contains(" lr#0: ")
            && letters.contains(" lr#2: "),
        "{letters}"
    );
    let unknown = common::crossym(["demos", "--config"])
        .arg(cfg(&rad, "task = \"fold the towel\""))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&unknown.stdout);
    assert!(!unknown.status.success());
    assert!(
        text.contains("no task `fold the towel`") && text.contains("`grasp the pan`"),
        "{text}"
    );
    let in_deg =
        common::run_ok(common::crossym(["demos", "--config"]).arg(cfg(&deg, "units = \"deg\"")));
    let lines = |s: &str| -> Vec<String> {
        s.lines()
            .filter(|l| l.contains(" lr#"))
            .map(String::from)
            .collect()
    };
    assert_eq!(
        lines(&in_deg),
        lines(&out),
        "degrees converted:\n{in_deg}\n{out}"
    );
    // A controlled joint the dataset does not name: refused with its name.
    let (scal, dump) = write("src-scalars", &["--version", "v3.0", "--layout", "scalars"]);
    let thirteen: Vec<String> = arm_joints(&dump)[..13]
        .iter()
        .map(|j| format!("\"{j}.pos\""))
        .collect();
    let missing = common::crossym(["demos", "--config"])
        .arg(cfg(&scal, &format!("features = [{}]", thirteen.join(", "))))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&missing.stdout).into_owned()
        + &String::from_utf8_lossy(&missing.stderr);
    assert!(!missing.status.success(), "{text}");
    assert!(text.contains("names no joint `right_arm_6`"), "{text}");
}

/// Round trip: demonstrations taught from bags written by rosbags (planar arms) →
/// `crossym export-lerobot` → pyarrow reads the export and sees the documented schema →
/// a `lerobot` source of the export gives the same demonstrations: positions and task paths
/// to the last bit, velocities (re-estimated) to 1e-9 but near the episodes' ends.
#[test]
fn bags_exported_to_lerobot_come_back_the_same() {
    assert!(common::python_has("pyarrow"), "PyPI pyarrow is missing");
    let dir = common::temp_dir("lerobot-roundtrip");
    for (name, storage) in [("pick_1", "sqlite3"), ("pick_2", "mcap")] {
        common::run_ok(
            Command::new("python3")
                .arg(common::path("tests/bags/write_recording.py"))
                .arg(dir.join(name))
                .args(["--storage", storage, "--motion", "teach", "--seed"])
                .arg(if name == "pick_1" { "7" } else { "8" }),
        );
    }
    let text = std::fs::read_to_string(common::path("config/letters.toml")).unwrap();
    let robot = text[text.find("[robot]").unwrap()..text.find("[[symmetries]]").unwrap()].replace(
        "../urdf/planar_dual_arm.urdf",
        common::path("urdf/planar_dual_arm.urdf").to_str().unwrap(),
    );
    // No idle trimming on re-import: the export holds the trimmed demonstrations, whose
    // first samples move slower than the idle speed near a start from rest.
    let write_cfg = |name: &str, sources: &str, cleaning: &str| {
        let p = dir.join(name);
        std::fs::write(
            &p,
            format!("{robot}\n[demonstrations]\ndt = 0.01\n{cleaning}{sources}"),
        )
        .unwrap();
        p
    };
    let bags = write_cfg(
        "bags.toml",
        "[[demonstrations.sources]]\nname = \"pick_1\"\nbag = \"pick_1\"\n\
         [[demonstrations.sources]]\nname = \"pick_2\"\nbag = \"pick_2\"\n",
        "",
    );
    let export = dir.join("exported");
    let out = common::run_ok(
        common::crossym(["export-lerobot", "--config"])
            .arg(&bags)
            .arg("--out")
            .arg(&export),
    );
    assert!(
        out.contains("2 episodes") && out.contains("episode 1: pick_2"),
        "{out}"
    );
    // An existing dataset is not overwritten.
    let again = common::crossym(["export-lerobot", "--config"])
        .arg(&bags)
        .arg("--out")
        .arg(&export)
        .output()
        .unwrap();
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("not empty"));
    // pyarrow's view of the export.
    let schema = common::run_ok(Command::new("python3").arg("-c").arg(format!(
        "import pyarrow.parquet as pq, json; t = pq.read_table('{}'); \
         print(t.schema); print(t.num_rows); \
         print(json.load(open('{}'))['features']['observation.state']['names'])",
        export.join("data/chunk-000/file-000.parquet").display(),
        export.join("meta/info.json").display()
    )));
    for needle in [
        "timestamp: double",
        "frame_index: int64",
        "episode_index: int64",
        "index: int64",
        "task_index: int64",
        "observation.state: list<element: double",
        "action: list<element: double",
        "left_joint1",
    ] {
        assert!(schema.contains(needle), "`{needle}` not in:\n{schema}");
    }
    let back = write_cfg(
        "back.toml",
        &format!(
            "[[demonstrations.sources]]\nname = \"lr\"\ndataset = \"{}\"\n",
            export.display()
        ),
        "[demonstrations.cleaning]\nidle_speed = 0.0\n",
    );
    let load = |p: &PathBuf| {
        let cfg = crossym::config::Config::from_file(p).unwrap();
        let robot = cfg.load_robot().unwrap();
        cfg.load_demonstrations(&robot.kinematics).unwrap()
    };
    let (a, b) = (load(&bags), load(&back));
    assert_eq!(a.demos.len(), 2);
    assert_eq!(b.demos.len(), 2);
    for (x, y) in a.demos.iter().zip(&b.demos) {
        assert_eq!(x.len(), y.len());
        assert_eq!(x.q, y.q, "positions");
        assert_eq!(x.x, y.x, "task paths");
        // Velocities are re-estimated from the positions (LeRobot has no velocity field):
        // the same Savitzky–Golay filter (half window 7) gives the same values inside, and
        // its one-sided estimates within 7 samples of each end of the exported (already
        // trimmed) episode, where the first pass had the recording's samples around them.
        let n = x.n;
        let (mut inner, mut edge) = (0.0f64, 0.0f64);
        for k in 0..x.len() {
            for j in 0..n {
                let d = (x.qdot[k * n + j] - y.qdot[k * n + j]).abs();
                if k < 7 || k + 7 >= x.len() {
                    edge = edge.max(d);
                } else {
                    inner = inner.max(d);
                }
            }
        }
        assert!(inner <= 1e-9, "interior velocities differ by {inner}");
        assert!(edge <= 0.05, "edge velocities differ by {edge} rad/s");
        println!("velocities: interior {inner:.1e}, within 7 samples of the ends {edge:.1e} rad/s");
    }
}

/// A dataset written by LeRobot 0.4.4 itself (committed: LeRobot needs torch, not installed
/// in CI; `tests/data/lerobot/lerobot-0.4.4-rby1/README.md`): every arm joint's value of every
/// frame as the writer was given it, episodes and fps from its metadata, its tasks (pandas'
/// `__index_level_0__` column) read by name.
#[test]
fn a_dataset_written_by_lerobot_itself_reads_as_written() {
    let root = common::path("tests/data/lerobot/lerobot-0.4.4-rby1");
    let want: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(root.join("expected.json")).unwrap())
            .unwrap();
    let joints = arm_joints(&want);
    let d = read_states(&root.join("dataset"), "observation.state", &[]).unwrap();
    assert_eq!((d.version.as_str(), d.fps), ("v3.0", 50.0));
    let names: Vec<String> = serde_json::from_value(want["names"].clone()).unwrap();
    assert_eq!(d.names, names);
    let q: Vec<Vec<Vec<f64>>> = serde_json::from_value(want["q"].clone()).unwrap();
    assert_eq!(d.episodes.len(), q.len());
    let n = d.names.len();
    for (e, rows) in d.episodes.iter().zip(&q) {
        assert_eq!(e.t.len(), rows.len());
        assert_eq!(e.task_index, e.index % 2);
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(
                e.t[k],
                f64::from(k as f32 / 50.0),
                "episode {} t[{k}]",
                e.index
            );
            for (j, name) in joints.iter().enumerate() {
                let col = d.names.iter().position(|x| x == name).unwrap();
                assert_eq!(
                    e.state[k * n + col],
                    row[j],
                    "episode {} frame {k} {name}",
                    e.index
                );
            }
        }
    }
    let tasks = crossym::lerobot::read_tasks(&root.join("dataset")).unwrap();
    let mut tasks: Vec<(i64, String)> = tasks;
    tasks.sort();
    assert_eq!(tasks, [(0, "draw".to_string()), (1, "grasp".to_string())]);
}
