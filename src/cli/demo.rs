//! `crossym demo`: the main job, run by [`crossym::demo`] — mock hardware + node as
//! processes (re-executed in a private network namespace first), this process as the user
//! publishing symmetry conditions, a per-condition table and a PNG of the letters.

use std::path::PathBuf;
use std::process::{Command, ExitCode, Stdio};

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

// Isolation. `crossym demo` re-runs itself inside a private network namespace that holds only
// a loopback interface with multicast routed to it, so DDS discovery never leaves the
// machine: `unshare --net` as root; as any other user (or where root may not create a
// network namespace, e.g. a container without CAP_SYS_ADMIN) `unshare --map-root-user
// --net`, a user namespace owning the network namespace (the demo runs as root of that
// namespace; its files are still the caller's). Each way is first probed (the namespace set
// up, `true` run in it) so that a refused namespace is told apart from a failed demo. When
// none works (unprivileged user namespaces disabled, e.g. Ubuntu 24.04's
// `kernel.apparmor_restrict_unprivileged_userns=1`; `unshare` or `ip` missing) the demo runs
// here without a namespace, localhost-only as with `--no-isolation` (every process's
// participant on the loopback interface: `demo::start` sets ROS_LOCALHOST_ONLY=1), after one
// line on stderr saying what failed and how to get isolation.
//
// CROSSYM_DEMO_UNSHARE names the `unshare` program (default: `unshare` on PATH). Tests force
// the fallback with a program that fails, `CROSSYM_DEMO_UNSHARE=/bin/false`
// (tests/integration/demo.rs).

/// Set (to `1`) for the re-executed demo: it already runs inside the namespace.
const NETNS_ENV: &str = "CROSSYM_PRIVATE_NETNS";
/// The `unshare` program to run (default `unshare`).
const UNSHARE_ENV: &str = "CROSSYM_DEMO_UNSHARE";
/// The namespace's setup, then `exec "$@"` (`ip` lives in /usr/sbin on some systems, which
/// is not on every user's PATH).
const NETNS_SETUP: &str = "PATH=$PATH:/usr/sbin:/sbin; ip link set lo up && \
     ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo && exec \"$@\"";

/// How to isolate: the `unshare` program and its namespace flags.
struct Unshare {
    program: std::ffi::OsString,
    flags: &'static [&'static str],
}

impl Unshare {
    /// `program flags -- bash -c SETUP crossym-netns` (the command to run follows).
    fn command(&self) -> Command {
        let mut c = Command::new(&self.program);
        c.args(self.flags)
            .args(["--", "bash", "-c", NETNS_SETUP, "crossym-netns"]);
        c
    }

    /// The command line as the user would type it, for messages.
    fn describe(&self) -> String {
        format!(
            "{} {}",
            self.program.to_string_lossy(),
            self.flags.join(" ")
        )
    }

    /// Sets the namespace up and runs `true` in it: `Err` says why that failed.
    fn probe(&self) -> Result<(), String> {
        let out = self
            .command()
            .arg("true")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .output();
        match out {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Err(format!("{} not found", self.program.to_string_lossy()))
            }
            Err(e) => Err(e.to_string()),
            Ok(o) if o.status.success() => Ok(()),
            Ok(o) => {
                let stderr = String::from_utf8_lossy(&o.stderr);
                Err(stderr
                    .lines()
                    .map(str::trim)
                    .rfind(|l| !l.is_empty())
                    .map_or_else(|| format!("exited with {}", o.status), str::to_owned))
            }
        }
    }
}

/// Re-executes this command inside a private network namespace (see above) and returns
/// its exit code; `None` when already inside, or when no namespace could be made (then
/// after the fallback line: the caller runs the demo localhost-only).
fn isolate() -> anyhow::Result<Option<ExitCode>> {
    if std::env::var_os(NETNS_ENV).is_some() {
        return Ok(None);
    }
    let program = std::env::var_os(UNSHARE_ENV).unwrap_or_else(|| "unshare".into());
    // SAFETY: geteuid has no preconditions and cannot fail.
    let root = unsafe { libc::geteuid() } == 0;
    let ways: &[&'static [&'static str]] = if root {
        &[&["--net"], &["--map-root-user", "--net"]]
    } else {
        &[&["--map-root-user", "--net"]]
    };
    let mut failed = Vec::new();
    for flags in ways {
        let u = Unshare {
            program: program.clone(),
            flags,
        };
        if let Err(why) = u.probe() {
            failed.push(format!("`{}`: {why}", u.describe()));
            continue;
        }
        let exe = std::env::current_exe().context("locating the crossym executable")?;
        let status = u
            .command()
            .arg(exe)
            .args(std::env::args_os().skip(1))
            .env(NETNS_ENV, "1")
            .status()
            .with_context(|| {
                format!(
                    "running the demo under `{}` (it worked a moment ago; \
                     --no-isolation runs it without a namespace, localhost-only)",
                    u.describe()
                )
            })?;
        return Ok(Some(match status.code() {
            Some(0) => ExitCode::SUCCESS,
            Some(c) => ExitCode::from(c.clamp(1, 255) as u8),
            None => ExitCode::from(2),
        }));
    }
    let how = if root {
        "allow this process to create namespaces (a container: --cap-add SYS_ADMIN, or \
         unprivileged user namespaces on the host)"
    } else {
        "run it as root, or allow unprivileged user namespaces (Ubuntu 24.04: \
         `sudo sysctl kernel.apparmor_restrict_unprivileged_userns=0`)"
    };
    eprintln!(
        "crossym demo: no private network namespace ({}); running localhost-only instead \
         (DDS discovery on the loopback interface, as ROS_LOCALHOST_ONLY=1). For isolation \
         (util-linux `unshare` and iproute2 `ip` needed): {how}; --no-isolation skips the \
         attempt.",
        failed.join("; ")
    );
    Ok(None)
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
    let netns = if std::env::var_os(NETNS_ENV).is_some() {
        ", private network namespace"
    } else {
        ""
    };
    println!(
        "  started mock-hw and node (domain {}, localhost only{netns}); logs in {}",
        started.domain_id(),
        s.out.display()
    );
    if let Some(line) = started.security() {
        println!("  {line}");
    }
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
