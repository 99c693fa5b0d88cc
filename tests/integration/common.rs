//! Shared fixtures: paths to shipped files, robots, seeded samplers.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crossym::config::{Config, LoadedRobot};
use crossym::data::demonstrations::Demonstrations;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The highest ROS_DOMAIN_ID a test may use: `tools/netns-run` hands out ephemeral ports
/// from 60000 on, above every DDS port of domains 0–209 (7400 + 250·domain + 0..249). A
/// socket on an ephemeral port that is another domain's port receives that domain's traffic
/// (Cyclone DDS binds its unicast ports there): a peer in domain 197 once paused a node in 102.
pub const MAX_DOMAIN: u16 = 209;

/// The crate root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The vendor's RB-Y1 models shipped for the tests (`robots/rby1a/`, its README.md).
pub fn rby1_dir() -> PathBuf {
    root().join("robots/rby1a")
}

/// The vendor RB-Y1 URDF, or `None` (with a printed reason) when it is absent.
pub fn rby1_urdf() -> Option<PathBuf> {
    let p = rby1_dir().join("model.urdf");
    if p.exists() {
        Some(p)
    } else {
        crate::skip::skip(format!(
            "{} is absent (shipped in robots/rby1a/: a partial checkout?)",
            p.display()
        ));
        None
    }
}

/// The `robots` directory of PyPI `example-robot-data` (installed by `tests/robots/install.sh`;
/// `CROSSYM_EXAMPLE_ROBOTS` overrides), or `None` with a printed reason.
pub fn example_robots() -> Option<PathBuf> {
    let dir = match std::env::var_os("CROSSYM_EXAMPLE_ROBOTS") {
        Some(d) => PathBuf::from(d),
        None => {
            let python = std::env::var("PYTHON").unwrap_or("python3".into());
            let purelib = Command::new(&python)
                .args([
                    "-c",
                    "import sysconfig; print(sysconfig.get_paths()['purelib'])",
                ])
                .output();
            match purelib {
                Ok(out) if out.status.success() => {
                    PathBuf::from(String::from_utf8_lossy(&out.stdout).trim())
                        .join("cmeel.prefix/share/example-robot-data/robots")
                }
                failed => {
                    let why = match failed {
                        Ok(out) => format!(
                            "exited with {}: {}",
                            out.status,
                            String::from_utf8_lossy(&out.stderr).trim()
                        ),
                        Err(e) => format!("does not start: {e}"),
                    };
                    crate::skip::skip(format!(
                        "example-robot-data: `{python}` (PYTHON) {why} (install python3, then \
                         `bash tests/robots/install.sh`)"
                    ));
                    return None;
                }
            }
        }
    };
    if dir.is_dir() {
        Some(dir)
    } else {
        crate::skip::skip(format!(
            "{} is absent (run `bash tests/robots/install.sh` for PyPI example-robot-data)",
            dir.display()
        ));
        None
    }
}

/// Loads a shipped config file from `config/`.
pub fn load_config(name: &str) -> Config {
    Config::from_file(root().join("config").join(name)).expect("shipped config loads")
}

/// The planar dual arm of the paper (always available: shipped in `urdf/`).
pub fn planar() -> LoadedRobot {
    load_config("planar_dual_arm.toml")
        .load_robot()
        .expect("planar robot loads")
}

/// RB-Y1 both arms, when the vendor URDF is present.
pub fn rby1() -> Option<LoadedRobot> {
    rby1_urdf()?;
    Some(load_config("rby1.toml").load_robot().expect("RB-Y1 loads"))
}

/// A seeded RNG (tests are deterministic).
pub fn rng(seed: u64) -> StdRng {
    StdRng::seed_from_u64(seed)
}

/// A random configuration inside the limits (continuous/unbounded joints in [-π, π]).
pub fn random_q(rng: &mut StdRng, limits: &[crossym::kinematics::JointLimits]) -> Vec<f64> {
    limits
        .iter()
        .map(|l| {
            let lo = if l.lower.is_finite() {
                l.lower
            } else {
                -std::f64::consts::PI
            };
            let hi = if l.upper.is_finite() {
                l.upper
            } else {
                std::f64::consts::PI
            };
            rng.random_range(lo..=hi)
        })
        .collect()
}

/// Path relative to the crate root.
pub fn path(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(rel)
}

/// A fresh, unique temporary directory for one test (`crossym-<tag>-<pid>-<n>`).
pub fn temp_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static N: AtomicUsize = AtomicUsize::new(0);
    let d = std::env::temp_dir().join(format!(
        "crossym-{tag}-{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&d).expect("create temp dir");
    d
}

/// `crossym ARGS…` (the binary under test), ready to run.
pub fn crossym<I, S>(args: I) -> std::process::Command
where
    I: IntoIterator<Item = S>,
    S: AsRef<std::ffi::OsStr>,
{
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_crossym"));
    c.args(args);
    c
}

/// Runs `cmd` to completion and returns its stdout; panics with its exit status, stdout and
/// stderr when it fails.
pub fn run_ok(cmd: &mut std::process::Command) -> String {
    let out = cmd.output().expect("command starts");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?} exited with {:?}\n{stdout}\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Euclidean distance of two points.
pub fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// A shipped task config, its robot and its demonstrations (`[demonstrations]`).
pub fn task(name: &str) -> (Config, LoadedRobot, Demonstrations) {
    let cfg = load_config(name);
    let robot = cfg.load_robot().expect("robot loads");
    let demos = cfg
        .load_demonstrations(&robot.kinematics)
        .expect("demonstrations load");
    (cfg, robot, demos)
}

/// The demonstrations of `cfg` after `edit` changed its `[demonstrations]` section.
pub fn demos_with(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    edit: impl FnOnce(&mut crossym::data::demonstrations::DemonstrationsConfig),
) -> Result<Demonstrations, crossym::data::DataError> {
    let mut d = cfg.demonstrations.clone().expect("[demonstrations]");
    edit(&mut d);
    Demonstrations::load(&d, |p| cfg.resolve(p), kin)
}

/// The last 30 lines of a log file (for failure messages).
pub fn log_tail(p: &Path) -> String {
    let s = std::fs::read_to_string(p).unwrap_or_default();
    let lines: Vec<&str> = s.lines().collect();
    lines[lines.len().saturating_sub(30)..].join("\n")
}

/// `crossym lifecycle set TRANSITION` on the node of `config` in `domain` (over DDS, as an
/// operator would); panics with the tool's output when it fails.
pub fn lifecycle_set(config: &Path, domain: u16, transition: &str) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_crossym"))
        .args([
            "lifecycle",
            "set",
            transition,
            "--timeout-s",
            "10",
            "--config",
        ])
        .arg(config)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("ROS_LOCALHOST_ONLY", "1")
        .env("ROS_DISTRO", "humble")
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).into_owned() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "crossym lifecycle set {transition}: {text}"
    );
    text
}

/// A child process (its output in a log file, ROS environment for `domain`) killed on drop; `term` sends SIGTERM and returns the exit code.
pub struct Proc {
    child: Option<Child>,
    name: String,
}

impl Proc {
    pub fn spawn(mut cmd: Command, name: &str, domain: u16, log: &Path) -> Proc {
        assert!(
            domain <= MAX_DOMAIN,
            "{name}: domain {domain} above {MAX_DOMAIN}, whose ports tools/netns-run keeps \
             clear of ephemeral ports"
        );
        let f = std::fs::File::create(log).unwrap();
        let child = cmd
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_LOCALHOST_ONLY", "1")
            .env("ROS_DISTRO", "humble")
            .stdout(Stdio::from(f.try_clone().unwrap()))
            .stderr(Stdio::from(f))
            .spawn()
            .unwrap_or_else(|e| panic!("starting {name}: {e}"));
        Proc {
            child: Some(child),
            name: name.into(),
        }
    }

    /// The process id.
    pub fn id(&self) -> u32 {
        self.child.as_ref().expect("running").id()
    }

    /// Waits up to `limit` for the process to exit by itself; its exit code, or a panic.
    pub fn wait(&mut self, limit: Duration, log: &Path) -> i32 {
        let mut c = self.child.take().expect("running");
        let t0 = Instant::now();
        loop {
            if let Some(s) = c.try_wait().unwrap() {
                return s.code().unwrap_or(-1);
            }
            if t0.elapsed() > limit {
                let _ = c.kill();
                let _ = c.wait();
                panic!(
                    "{} did not finish within {limit:?}\n{}",
                    self.name,
                    log_tail(log)
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    pub fn term(&mut self) -> i32 {
        let mut c = self.child.take().expect("running");
        assert!(
            c.try_wait().unwrap().is_none(),
            "{} exited before SIGTERM",
            self.name
        );
        let ok = Command::new("kill")
            .args(["-TERM", &c.id().to_string()])
            .status()
            .unwrap()
            .success();
        assert!(ok, "kill -TERM {}", self.name);
        for _ in 0..150 {
            if let Some(s) = c.try_wait().unwrap() {
                return s.code().unwrap_or(-1);
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let _ = c.kill();
        panic!("{} did not stop within 15 s of SIGTERM", self.name);
    }
}

impl Drop for Proc {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// True when `python3` imports `module`.
pub fn python_has(module: &str) -> bool {
    std::process::Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// True when PyPI `cyclonedds` (the independent DDS peer's library) imports.
pub fn python_has_cyclonedds() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import cyclonedds.domain"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .map(|s| s.success())
        .unwrap_or(false)
}

/// Waits until the file at `p` contains `needle`; false after `deadline`.
pub fn wait_for_text(p: &Path, needle: &str, deadline: std::time::Duration) -> bool {
    wait_for_text_from(p, 0, needle, deadline)
}

/// Waits until the file at `p` contains `needle` at or after byte `offset` (text written
/// since a moment the caller noted with the file's length); false after `deadline`.
pub fn wait_for_text_from(p: &Path, offset: usize, needle: &str, deadline: Duration) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < deadline {
        let text = std::fs::read_to_string(p).unwrap_or_default();
        if text.get(offset..).is_some_and(|t| t.contains(needle)) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}

/// A DDS observer in the test process: a node's `~/status` and the joint states, so a test
/// waits for counts and events (with generous deadlines) instead of sleeping.
pub struct Watch {
    pub status: ros2_client::Subscription<crossym::msg::Status>,
    pub joint_states: ros2_client::Subscription<crossym::msg::JointState>,
    _node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

impl Watch {
    /// Subscribes on `domain` (localhost) to `status` (reliable) and `joint_states`
    /// (sensor QoS) as node `crossym_test_<tag>_<pid>_<domain>`.
    pub fn new(domain: u16, tag: &str, status: &str, joint_states: &str) -> Watch {
        use crossym::ros::dds;
        let ctx = dds::DdsSettings {
            domain_id: domain,
            range: dds::DiscoveryRange::Localhost,
            distro: dds::DEFAULT_DISTRO,
            security: Default::default(),
        }
        .context()
        .expect("DDS context");
        let name = format!("crossym_test_{tag}_{}_{domain}", std::process::id());
        let mut node = ctx
            .new_node(
                dds::node_name("/", &name).unwrap(),
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .expect("DDS node");
        let status = dds::subscription(&mut node, status, dds::qos_reliable(100))
            .expect("status subscription");
        let joint_states = dds::subscription(&mut node, joint_states, dds::qos_sensor())
            .expect("joint-state subscription");
        Watch {
            status,
            joint_states,
            _node: node,
            _ctx: ctx,
        }
    }

    /// The first status (oldest first) for which `pred` holds, or `None` after `timeout`
    /// (polling every 5 ms).
    pub fn wait_status(
        &self,
        timeout: std::time::Duration,
        mut pred: impl FnMut(&crossym::msg::Status) -> bool,
    ) -> Option<crossym::msg::Status> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            while let Ok(Some((s, _))) = self.status.take() {
                if pred(&s) {
                    return Some(s);
                }
            }
            if std::time::Instant::now() > deadline {
                return None;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    }
}

/// Waits until the file at `p` contains `needle` after the first `after`; false after
/// `deadline`.
pub fn wait_for_text_after(p: &Path, after: &str, needle: &str, deadline: Duration) -> bool {
    let t0 = Instant::now();
    while t0.elapsed() < deadline {
        let text = std::fs::read_to_string(p).unwrap_or_default();
        if let Some(i) = text.find(after) {
            if text[i..].contains(needle) {
                return true;
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    false
}
