//! Shared fixtures: paths to shipped and shared files, robots, seeded samplers.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use crossym::config::{Config, LoadedRobot};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The crate root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// `../shared` beside the repository.
pub fn shared() -> PathBuf {
    root().join("../shared")
}

/// The vendor RB-Y1 URDF, or `None` (with a printed reason) when `../shared` is absent.
pub fn rby1_urdf() -> Option<PathBuf> {
    let p = shared().join("robots/rby1a/model.urdf");
    if p.exists() {
        Some(p)
    } else {
        eprintln!(
            "SKIP: {} is absent (RB-Y1 tests need ../shared)",
            p.display()
        );
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

/// A shipped task config, its robot and its tracked demonstrations (`[letters]`).
pub fn task(name: &str) -> (Config, LoadedRobot, crossym::data::letters::LetterDemos) {
    let cfg = load_config(name);
    let robot = cfg.load_robot().expect("robot loads");
    let demos = cfg
        .letters
        .as_ref()
        .expect("[letters]")
        .build(&robot.kinematics, &cfg.base_dir)
        .expect("demonstrations build");
    (cfg, robot, demos)
}
