//! Import benchmark: 10 rosbag2 recordings of 60 s at 500 Hz of RB-Y1's full
//! joint list (300 000 `sensor_msgs/msg/JointState` messages) into demonstrations, with the
//! read / resample / differentiate split, for both storage formats (MCAP and SQLite3).
//!
//! Setup (not timed): the recordings are written to a fresh directory under the system
//! temp dir (removed at the end), each bag once as MCAP (crossym's [`BagWriter`]) and once
//! as SQLite3 (rosbag2 Humble's `.db3` layout, schema version 3, written with rusqlite).
//! Every message names every non-fixed joint of the vendor URDF (28: wheels, torso, arms,
//! grippers, head, in URDF order) with positions, velocities and efforts as the
//! joint_state_broadcaster fills them: smooth motions (sums of three sines inside the joint
//! limits, idle for the first and last 2 s) plus Gaussian encoder noise (σ = 0.1 mrad),
//! header stamps every 2 ms with Gaussian jitter (σ = 20 µs), receive times 0.2–0.5 ms later.
//!
//! Configuration: the 14 arm joints of `config/rby1.toml`'s chains, Δt = 0.01 s, default
//! cleaning ([`CleanConfig::default`]: Savitzky–Golay h = 7, p = 2).
//!
//! Groups, per storage `s` ∈ {mcap, sqlite3}, each iteration over all 10 recordings:
//! - `import/s/total`: [`open_joint_states`] + [`clean`] per bag → demonstrations.
//! - `import/s/read`: [`open_joint_states`] (open bag, decode CDR, map names).
//! - `import/s/resample`: [`resample`] of the recordings read beforehand.
//! - `import/s/differentiate`: [`differentiate`] of the resampled positions.
//!
//! Criterion's throughput is in JointState messages per second, except `differentiate`'s
//! (resampled grid samples per second).
//!
//! After criterion, a summary per storage (median of 3 plain passes) prints messages,
//! seconds, the split and messages per second. The vendor URDF is needed at
//! `robots/rby1a/model.urdf` (shipped); without it the benchmark fails and says why.

use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use criterion::{Criterion, SamplingMode, Throughput};
use crossym::bag::{cdr, BagWriter, Qos};
use crossym::config::Config;
use crossym::data::clean::{clean, differentiate, resample, CleanConfig, CleanDemo};
use crossym::data::recording::{open_joint_states, JointRecording, StampSource};
use crossym::kinematics::JointLimits;
use crossym::lerobot::{read_states, write_dataset, EpisodeFrames};
use crossym::msg::{Header, JointState, Time};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

const RBY1_URDF: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/robots/rby1a/model.urdf");
const RBY1_CONFIG: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/config/rby1.toml");
const TOPIC: &str = "/joint_states";
/// Publishing period of the driver (ns): 500 Hz.
const PERIOD_NS: i64 = 2_000_000;
/// Resampling step of the demonstrations (s).
const DT: f64 = 0.01;
/// Recording start of the first bag (s since the Unix epoch).
const EPOCH_S: i64 = 1_760_000_000;

/// A movable joint of the URDF and the motion generated for it.
struct JointSpec {
    name: String,
    /// Centre of the motion (rad or m).
    center: f64,
    /// Range the position is kept in (rad or m; infinite for continuous joints).
    lower: f64,
    upper: f64,
    /// Largest total amplitude of the sines (rad or m).
    amplitude: f64,
    /// Typical effort magnitude (N·m or N).
    effort: f64,
}

/// Every non-fixed joint of the URDF, in file order.
fn urdf_joints(path: &Path) -> anyhow::Result<Vec<JointSpec>> {
    let robot = urdf_rs::read_file(path)?;
    Ok(robot
        .joints
        .iter()
        .filter(|j| !matches!(j.joint_type, urdf_rs::JointType::Fixed))
        .map(|j| {
            let (lo, hi) = (j.limit.lower, j.limit.upper);
            let bounded = hi > lo;
            let (lower, upper) = if bounded {
                (lo, hi)
            } else {
                (f64::NEG_INFINITY, f64::INFINITY)
            };
            JointSpec {
                name: j.name.clone(),
                center: if bounded { 0.5 * (lo + hi) } else { 0.0 },
                lower,
                upper,
                amplitude: if bounded {
                    (0.15 * (hi - lo)).min(0.3)
                } else {
                    0.3
                },
                effort: 0.05 * j.limit.effort.clamp(1.0, 100.0),
            }
        })
        .collect())
}

/// A standard normal sample (Box–Muller).
fn gauss(rng: &mut StdRng) -> f64 {
    let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// Smooth step 0 → 1 over x ∈ [0, 1] and its derivative.
fn smoothstep(x: f64) -> (f64, f64) {
    let x = x.clamp(0.0, 1.0);
    (x * x * (3.0 - 2.0 * x), 6.0 * x * (1.0 - x))
}

/// The JointState messages of recording `seed` (`count` at 500 Hz) with their receive
/// times (ns since the Unix epoch), CDR-encoded, in order.
fn recording_messages(joints: &[JointSpec], seed: u64, count: usize) -> Vec<(u64, Vec<u8>)> {
    let mut rng = StdRng::seed_from_u64(seed);
    let duration = count as f64 * PERIOD_NS as f64 * 1e-9;
    // Three sines per joint: amplitudes summing to the joint's amplitude, 0.05–0.4 Hz.
    let waves: Vec<[(f64, f64, f64); 3]> = joints
        .iter()
        .map(|j| {
            let w: [f64; 3] = [rng.random(), rng.random(), rng.random()];
            let s: f64 = w.iter().sum::<f64>().max(1e-9);
            w.map(|wi| {
                (
                    j.amplitude * wi / s,
                    std::f64::consts::TAU * rng.random_range(0.05..0.4),
                    rng.random_range(0.0..std::f64::consts::TAU),
                )
            })
        })
        .collect();
    let names: Vec<String> = joints.iter().map(|j| j.name.clone()).collect();
    let start_ns = (EPOCH_S + 100 * seed as i64) * 1_000_000_000;
    let mut out = Vec::with_capacity(count);
    for k in 0..count {
        let t = k as f64 * PERIOD_NS as f64 * 1e-9;
        // Idle `edge` at each end, ramps of `edge` in and out (2 s for 60 s).
        let edge = (duration / 30.0).min(2.0);
        let (a, da) = smoothstep((t - edge) / edge);
        let (b, db) = smoothstep((duration - edge - t) / edge);
        let (env, denv) = (a * b, (da * b - a * db) / edge);
        let mut position = Vec::with_capacity(joints.len());
        let mut velocity = Vec::with_capacity(joints.len());
        let mut effort = Vec::with_capacity(joints.len());
        for (j, w) in joints.iter().zip(&waves) {
            let (mut m, mut dm) = (0.0, 0.0);
            for &(amp, om, ph) in w {
                m += amp * (om * t + ph).sin();
                dm += amp * om * (om * t + ph).cos();
            }
            let q = j.center + env * m + 1e-4 * gauss(&mut rng);
            position.push(q.clamp(j.lower, j.upper));
            velocity.push(denv * m + env * dm + 2e-3 * gauss(&mut rng));
            effort.push(j.effort * (0.6 + 0.3 * m / j.amplitude) + 0.02 * gauss(&mut rng));
        }
        let jitter = (20_000.0 * gauss(&mut rng)).clamp(-200_000.0, 200_000.0) as i64;
        let stamp_ns = start_ns + k as i64 * PERIOD_NS + jitter;
        let receive_ns = stamp_ns + rng.random_range(200_000..500_000);
        let js = JointState {
            header: Header {
                stamp: Time {
                    sec: (stamp_ns / 1_000_000_000) as i32,
                    nanosec: (stamp_ns % 1_000_000_000) as u32,
                },
                frame_id: String::new(),
            },
            name: names.clone(),
            position,
            velocity,
            effort,
        };
        out.push((
            receive_ns as u64,
            cdr::encode(&js).expect("JointState encodes"),
        ));
    }
    out
}

/// Writes `msgs` as an MCAP bag directory `dir` with crossym's writer.
fn write_mcap(dir: &Path, msgs: &[(u64, Vec<u8>)]) -> anyhow::Result<()> {
    let mut w = BagWriter::create(dir)?;
    let topic = w.add_topic::<JointState>(TOPIC, Qos::reliable(10))?;
    for (k, (ns, data)) in msgs.iter().enumerate() {
        w.write_raw(topic, data, *ns, *ns, k as u32)?;
    }
    w.finish()?;
    Ok(())
}

/// Writes `msgs` as a rosbag2 SQLite3 bag directory `dir` (Humble layout, schema 3).
fn write_db3(dir: &Path, msgs: &[(u64, Vec<u8>)]) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    let base = dir.file_name().unwrap().to_string_lossy().into_owned();
    let file = format!("{base}_0.db3");
    let mut conn = rusqlite::Connection::open(dir.join(&file))?;
    conn.execute_batch(
        "CREATE TABLE schema(schema_version INTEGER PRIMARY KEY,ros_distro TEXT NOT NULL);
         INSERT INTO schema VALUES (3, 'humble');
         CREATE TABLE topics(id INTEGER PRIMARY KEY,name TEXT NOT NULL,type TEXT NOT NULL,\
         serialization_format TEXT NOT NULL,offered_qos_profiles TEXT NOT NULL);
         CREATE TABLE messages(id INTEGER PRIMARY KEY,topic_id INTEGER NOT NULL,\
         timestamp INTEGER NOT NULL, data BLOB NOT NULL);
         CREATE INDEX timestamp_idx ON messages (timestamp ASC);",
    )?;
    let qos = Qos::reliable(10).yaml();
    conn.execute(
        "INSERT INTO topics VALUES (1, ?1, 'sensor_msgs/msg/JointState', 'cdr', ?2)",
        rusqlite::params![TOPIC, qos],
    )?;
    let tx = conn.transaction()?;
    {
        let mut st =
            tx.prepare("INSERT INTO messages (topic_id, timestamp, data) VALUES (1, ?1, ?2)")?;
        for (ns, data) in msgs {
            st.execute(rusqlite::params![*ns as i64, data])?;
        }
    }
    tx.commit()?;
    let (start, end) = (msgs[0].0, msgs[msgs.len() - 1].0);
    let n = msgs.len();
    std::fs::write(
        dir.join("metadata.yaml"),
        format!(
            "rosbag2_bagfile_information:\n  version: 5\n  storage_identifier: sqlite3\n  duration:\n    nanoseconds: {d}\n  starting_time:\n    nanoseconds_since_epoch: {start}\n  message_count: {n}\n  topics_with_message_count:\n    - topic_metadata:\n        name: {TOPIC}\n        type: sensor_msgs/msg/JointState\n        serialization_format: cdr\n        offered_qos_profiles: {qos:?}\n      message_count: {n}\n  compression_format: \"\"\n  compression_mode: \"\"\n  relative_file_paths:\n    - {file}\n  files:\n    - path: {file}\n      starting_time:\n        nanoseconds_since_epoch: {start}\n      duration:\n        nanoseconds: {d}\n      message_count: {n}\n",
            d = end - start
        ),
    )?;
    Ok(())
}

/// The temp directory with the bags; removed on drop.
struct Fixture {
    dir: PathBuf,
    /// Bag directories per storage: `("mcap", …)`, `("sqlite3", …)`.
    storages: Vec<(&'static str, Vec<PathBuf>)>,
    /// JointState messages per storage (count).
    messages: usize,
    /// Names per message (count).
    names: usize,
    /// The same recordings as one LeRobotDataset (v3.0, one episode per recording, the
    /// state named by every movable joint, float64; crossym's writer).
    lerobot: PathBuf,
}

impl Drop for Fixture {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Total size of the files under `dir` (bytes).
fn dir_bytes(dir: &Path) -> u64 {
    std::fs::read_dir(dir)
        .map(|rd| {
            rd.filter_map(Result::ok)
                .filter_map(|e| e.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0)
}

fn write_fixture(joints: &[JointSpec], bags: usize, count: usize) -> anyhow::Result<Fixture> {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)?
        .as_nanos();
    let dir = std::env::temp_dir().join(format!(
        "crossym-import-bench-{}-{nanos}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir)?;
    let mut fx = Fixture {
        dir: dir.clone(),
        storages: vec![("mcap", Vec::new()), ("sqlite3", Vec::new())],
        messages: bags * count,
        names: joints.len(),
        lerobot: dir.join("lerobot"),
    };
    let mut episodes: Vec<(Vec<f64>, Vec<f64>)> = Vec::new();
    for b in 0..bags {
        let msgs = recording_messages(joints, b as u64, count);
        let m = dir.join(format!("mcap/demo_{b:02}"));
        std::fs::create_dir_all(m.parent().unwrap())?;
        write_mcap(&m, &msgs)?;
        let s = dir.join(format!("sqlite3/demo_{b:02}"));
        write_db3(&s, &msgs)?;
        fx.storages[0].1.push(m);
        fx.storages[1].1.push(s);
        let (mut t, mut state) = (Vec::new(), Vec::new());
        for (_, bytes) in &msgs {
            let js: JointState = cdr::decode(bytes)?;
            t.push(js.header.stamp.as_secs_f64());
            state.extend_from_slice(&js.position);
        }
        episodes.push((t, state));
    }
    let frames: Vec<EpisodeFrames<'_>> = episodes
        .iter()
        .map(|(t, state)| EpisodeFrames {
            task_index: 0,
            t,
            state,
        })
        .collect();
    let names: Vec<String> = joints.iter().map(|j| j.name.clone()).collect();
    write_dataset(
        &fx.lerobot,
        1e9 / PERIOD_NS as f64,
        &names,
        &["bench".to_string()],
        &frames,
    )?;
    Ok(fx)
}

/// The LeRobot import: the dataset read, each episode's state mapped to the configured
/// joints by name, then cleaned as a recording; also returns the read time (s).
fn import_lerobot(
    dir: &Path,
    joints: &[String],
    cfg: &CleanConfig,
    limits: &[JointLimits],
) -> (Vec<CleanDemo>, f64) {
    let t0 = Instant::now();
    let data = read_states(dir, "observation.state", &[]).expect("dataset reads");
    let cols: Vec<usize> = joints
        .iter()
        .map(|j| data.names.iter().position(|n| n == j).expect("joint named"))
        .collect();
    let w = data.names.len();
    let recs: Vec<JointRecording> = data
        .episodes
        .iter()
        .map(|e| JointRecording {
            bag: e.file.clone(),
            topic: format!("episode {}", e.index),
            joints: joints.to_vec(),
            t: e.t.iter().map(|t| t - e.t[0]).collect(),
            start_ns: 0,
            q: e.state
                .chunks(w)
                .flat_map(|row| cols.iter().map(|&c| row[c]))
                .collect(),
            ignored: Vec::new(),
        })
        .collect();
    let read = t0.elapsed().as_secs_f64();
    let mut demos = Vec::new();
    for r in &recs {
        demos.extend(clean(r, DT, cfg, Some(limits)).expect("episode cleans").0);
    }
    (demos, read)
}

/// The import under test: every bag read and cleaned into demonstrations.
fn import(
    bags: &[PathBuf],
    joints: &[String],
    cfg: &CleanConfig,
    limits: &[JointLimits],
) -> Vec<CleanDemo> {
    let mut demos = Vec::new();
    for b in bags {
        let rec = open_joint_states(b, TOPIC, joints, StampSource::Header).expect("bag reads");
        let (d, _) = clean(&rec, DT, cfg, Some(limits)).expect("recording cleans");
        demos.extend(d);
    }
    demos
}

fn read_all(bags: &[PathBuf], joints: &[String]) -> Vec<JointRecording> {
    bags.iter()
        .map(|b| open_joint_states(b, TOPIC, joints, StampSource::Header).expect("bag reads"))
        .collect()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // `cargo bench` passes `--bench`; without it (e.g. `cargo test --benches`) criterion
    // runs each function once as a smoke test, on 2 recordings of 4 s.
    let bench_mode = std::env::args().any(|a| a == "--bench");
    // The vendor URDF is shipped (robots/rby1a/): without it the checkout is broken, and a
    // benchmark that measured nothing must not pass.
    let urdf = Path::new(RBY1_URDF);
    assert!(
        urdf.exists(),
        "import benchmark: the RB-Y1 vendor URDF is not at {} (shipped in the repository \
         under robots/rby1a/: restore it, e.g. `git checkout HEAD -- robots/rby1a`)",
        urdf.display()
    );
    let spec = urdf_joints(urdf).expect("the RB-Y1 URDF parses");
    let config = Config::from_file(RBY1_CONFIG).expect("config/rby1.toml loads");
    let robot = config.load_robot().expect("the RB-Y1 robot loads");
    let kin = &robot.kinematics;
    let joints = kin.joint_names().to_vec();
    let limits = kin.limits().to_vec();
    let cfg = CleanConfig::default();
    let (bags, count) = if bench_mode { (10, 30_000) } else { (2, 2_000) };

    let t = Instant::now();
    let fx = write_fixture(&spec, bags, count).expect("bags written");
    println!(
        "setup: {bags} recordings × {count} JointState messages ({} names each, {} configured) \
         written as MCAP ({:.1} MB) and SQLite3 ({:.1} MB) in {:.1} s under {}",
        fx.names,
        joints.len(),
        fx.storages[0].1.iter().map(|d| dir_bytes(d)).sum::<u64>() as f64 * 1e-6,
        fx.storages[1].1.iter().map(|d| dir_bytes(d)).sum::<u64>() as f64 * 1e-6,
        t.elapsed().as_secs_f64(),
        fx.dir.display()
    );
    // The import succeeds and gives what the recordings hold (not timed).
    for (storage, paths) in &fx.storages {
        for p in paths {
            let rec = open_joint_states(p, TOPIC, &joints, StampSource::Header).unwrap();
            assert_eq!(rec.len(), count, "{storage} {}", p.display());
            assert_eq!(rec.ignored.len(), fx.names - joints.len());
            let (d, rep) = clean(&rec, DT, &cfg, Some(&limits)).unwrap();
            assert_eq!(d.len(), 1);
            assert_eq!(
                rep.outside_limits, 0,
                "{storage}: samples outside the limits"
            );
        }
    }

    let mut c = Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .configure_from_args();
    for (storage, paths) in &fx.storages {
        let mut g = c.benchmark_group(format!("import/{storage}"));
        g.sample_size(10)
            .sampling_mode(SamplingMode::Flat)
            .measurement_time(Duration::from_secs(30))
            .throughput(Throughput::Elements(fx.messages as u64));
        g.bench_function("total", |b| {
            b.iter(|| black_box(import(paths, &joints, &cfg, &limits)))
        });
        g.bench_function("read", |b| b.iter(|| black_box(read_all(paths, &joints))));
        let recs = read_all(paths, &joints);
        g.measurement_time(Duration::from_secs(5));
        g.bench_function("resample", |b| {
            b.iter(|| {
                for r in &recs {
                    black_box(resample(black_box(r), DT, &cfg).unwrap());
                }
            })
        });
        let qs: Vec<Vec<f64>> = recs
            .iter()
            .map(|r| resample(r, DT, &cfg).unwrap().0)
            .collect();
        // Throughput of this one in grid samples (Δt = 0.01 s), not messages.
        g.throughput(Throughput::Elements(
            qs.iter().map(|q| (q.len() / joints.len()) as u64).sum(),
        ));
        g.bench_function("differentiate", |b| {
            b.iter(|| {
                for q in &qs {
                    black_box(differentiate(
                        black_box(q),
                        joints.len(),
                        DT,
                        cfg.differentiator,
                    ));
                }
            })
        });
        g.finish();
    }
    c.final_summary();

    // Plain-loop summary: median over 3 passes of each part, per storage.
    println!();
    println!(
        "import summary ({bags} recordings, {} JointState messages of {} joints, {} configured, \
         Δt = {DT} s; median of 3 passes):",
        fx.messages,
        fx.names,
        joints.len()
    );
    for (storage, paths) in &fx.storages {
        let (mut read, mut res, mut diff, mut cl) = (vec![], vec![], vec![], vec![]);
        for _ in 0..3 {
            let (mut r, mut s, mut d, mut c) = (0.0, 0.0, 0.0, 0.0);
            for p in paths {
                let t0 = Instant::now();
                let rec = open_joint_states(p, TOPIC, &joints, StampSource::Header).unwrap();
                let t1 = Instant::now();
                black_box(clean(&rec, DT, &cfg, Some(&limits)).unwrap());
                let t2 = Instant::now();
                let (q, _) = resample(&rec, DT, &cfg).unwrap();
                let t3 = Instant::now();
                black_box(differentiate(&q, joints.len(), DT, cfg.differentiator));
                let t4 = Instant::now();
                r += (t1 - t0).as_secs_f64();
                c += (t2 - t1).as_secs_f64();
                s += (t3 - t2).as_secs_f64();
                d += (t4 - t3).as_secs_f64();
            }
            read.push(r);
            cl.push(c);
            res.push(s);
            diff.push(d);
        }
        let (r, c, s, d) = (median(read), median(cl), median(res), median(diff));
        let total = r + c;
        println!(
            "  {storage:>7}: {} messages in {total:.3} s = read {r:.3} s + clean {c:.4} s \
             (resample {s:.4} s, differentiate {d:.4} s, rest {:.4} s); {:.0} messages/s; \
             ≤ 3 s: {}",
            fx.messages,
            (c - s - d).max(0.0),
            fx.messages as f64 / total,
            if total <= 3.0 { "yes" } else { "no" }
        );
    }
    // The same frames as a LeRobotDataset (one Parquet file, float64 lists).
    let (mut total, mut read) = (Vec::new(), Vec::new());
    let mut n_demos = 0;
    for _ in 0..3 {
        let t0 = Instant::now();
        let (d, r) = import_lerobot(&fx.lerobot, &joints, &cfg, &limits);
        total.push(t0.elapsed().as_secs_f64());
        read.push(r);
        n_demos = black_box(d).len();
    }
    let (t, r) = (median(total), median(read));
    println!(
        "  lerobot: {} frames in {t:.3} s = read {r:.3} s + clean {:.4} s; {:.0} frames/s; \
         {n_demos} demonstrations; ≤ 3 s: {}",
        fx.messages,
        t - r,
        fx.messages as f64 / t,
        if t <= 3.0 { "yes" } else { "no" }
    );
}
