//! `crossym demo`: the main job, run by [`crossym::demo`] — mock hardware + node as
//! processes (re-executed in a private network namespace first), this process as the user
//! publishing symmetry conditions, a per-condition table and a PNG of the letters.

use std::path::PathBuf;
use std::process::{Command, ExitCode};

use anyhow::Context;
use crossym::demo::{self, DemoSettings};

use super::common::PlantArg;

/// Options of `crossym demo`.
#[derive(Debug, clap::Args)]
pub struct DemoArgs {
    /// Config file (TOML) with [robot], [demonstrations], [[symmetries]], [composition], [node].
    #[arg(long, short, default_value = "config/letters.toml")]
    pub config: PathBuf,
    /// Test demonstration to draw (1-based; default: the first of `[demonstrations] test`).
    #[arg(long)]
    pub demo: Option<usize>,
    /// Conditions `theta_rad:scale:reflection`, repeatable; default: original, rotated
    /// 30°, scaled 0.8, reflected, and all three composed (a canonicalised policy also gets
    /// two conditions off the training grid: 17° + 0.73 + reflected, 170° + 1.15 + reflected).
    #[arg(long = "condition", allow_hyphen_values = true)]
    pub conditions: Vec<String>,
    /// Policy file (`.safetensors` with its sidecar) instead of `[node] policy`, e.g. the
    /// canonicalised `data/policies/pi_eq_planar.safetensors` (any feasible condition).
    #[arg(long)]
    pub policy: Option<PathBuf>,
    /// Draw only the first seconds of each letter (default: the whole letter).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Output directory for `demo.md`, `demo.csv`, `demo.png` and the process logs.
    #[arg(long, default_value = "results/demo")]
    pub out: PathBuf,
    /// Largest accepted ratio closed-loop RMSE / offline-rollout RMSE.
    #[arg(long, default_value_t = 1.5)]
    pub max_ratio: f64,
    /// Absolute allowance on top of `max_ratio × offline` (task units, e.g. m): the loop
    /// samples states and sends commands a control period apart, which costs about
    /// `period × end-effector speed` however small the offline error is. Default 0 on the
    /// kinematic mock, 0.01 on the physics robot (a servo lags a ramp by ≈ 0.1 s, ≈ 1 cm
    /// at the hand speeds of the shipped tasks).
    #[arg(long)]
    pub max_excess: Option<f64>,
    /// The robot: `kinematic` mock (default) or `mujoco` (the physics RB-Y1 of
    /// `[mock_hw.mujoco]`; `bash physics/install.sh` first).
    #[arg(long, value_enum)]
    pub plant: Option<PlantArg>,
    /// Do not re-run inside a private network namespace (then ROS_LOCALHOST_ONLY=1 is
    /// still set for every process).
    #[arg(long)]
    pub no_isolation: bool,
}

const NETNS_ENV: &str = "CROSSYM_PRIVATE_NETNS";

/// Re-executes this command inside `unshare --net` with loopback multicast (the network
/// rule: DDS discovery never leaves the machine). Returns `None` when already inside.
fn isolate() -> anyhow::Result<Option<ExitCode>> {
    if std::env::var_os(NETNS_ENV).is_some() {
        return Ok(None);
    }
    let exe = std::env::current_exe().context("locating the crossym executable")?;
    let status = Command::new("unshare")
        .args([
            "--net",
            "--",
            "bash",
            "-c",
            "ip link set lo up && ip link set lo multicast on && \
             ip route add 224.0.0.0/4 dev lo && exec \"$@\"",
            "crossym-netns",
        ])
        .arg(exe)
        .args(std::env::args_os().skip(1))
        .env(NETNS_ENV, "1")
        .status()
        .context(
            "running `unshare --net` (needs util-linux and permission to create a network \
             namespace; use --no-isolation to run with ROS_LOCALHOST_ONLY=1 only)",
        )?;
    Ok(Some(match status.code() {
        Some(0) => ExitCode::SUCCESS,
        Some(c) => ExitCode::from(c.clamp(1, 255) as u8),
        None => ExitCode::from(2),
    }))
}

impl DemoArgs {
    /// The library's settings (everything but `--no-isolation`).
    fn settings(&self) -> DemoSettings {
        DemoSettings {
            config: self.config.clone(),
            demo: self.demo,
            conditions: self.conditions.clone(),
            policy: self.policy.clone(),
            duration_s: self.duration_s,
            out: self.out.clone(),
            max_ratio: self.max_ratio,
            max_excess: self.max_excess,
            plant: self.plant.map(Into::into),
        }
    }
}

/// `crossym demo`: exits 1 when a check failed.
pub fn run(a: &DemoArgs) -> anyhow::Result<ExitCode> {
    if !a.no_isolation {
        if let Some(code) = isolate()? {
            return Ok(code);
        }
    }
    let s = a.settings();
    let p = demo::prepare(&s)?;
    if let Some(d) = &p.domain {
        for label in &p.left_out {
            println!(
                "  leaving out default condition `{label}`: the policy was trained on {}",
                d.describe()
            );
        }
    }
    let kin = &p.robot.kinematics;
    println!(
        "crossym demo: {} on {} ({} joints), demo {}, policy {}",
        s.config.display(),
        kin.robot,
        kin.dof(),
        p.demo,
        p.policy_path.display()
    );
    let exe = std::env::current_exe().context("locating the crossym executable")?;
    let started = demo::start(&s, &exe)?;
    println!(
        "  started mock-hw and node (domain {}, localhost only); logs in {}",
        started.domain_id(),
        s.out.display()
    );
    let run = started.finish(&p)?;
    let report = demo::report(&s, &p, &run);
    let files = demo::write(&s, &p, &run, &report)?;
    println!("{}", report.markdown);
    println!(
        "  wrote {}, {}, {}",
        files.markdown.display(),
        files.csv.display(),
        files.figure.display()
    );
    if report.failures.is_empty() {
        println!("demo: OK");
        Ok(ExitCode::SUCCESS)
    } else {
        for f in &report.failures {
            eprintln!("demo: FAILED: {f}");
        }
        Ok(ExitCode::from(1))
    }
}
