//! `crossym demo`: the main job. Mock hardware + node as processes, this process as the
//! user publishing symmetry conditions, a per-condition table and a PNG of the letters.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitCode, Stdio};
use std::time::Duration;

use anyhow::Context;
use crossym::config::Config;
use crossym::eval::plot::{condition_label, write_paths_grid, PathFigure, PathPanel, XY_VIEW};
use crossym::eval::{score, EvalConfig};
use crossym::pipeline::nominal_trajectories;
use crossym::ros::dds::{DdsSettings, DiscoveryRange};
use crossym::sim::scenario::{self, ScenarioStep, ScenarioTopics};
use crossym::sim::MockHwSummary;
use crossym::symmetry::compose::Condition;

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
    #[arg(long)]
    pub plant: Option<crossym::sim::physics::Plant>,
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

fn default_conditions() -> Vec<(String, Condition)> {
    let r = std::f64::consts::FRAC_PI_6;
    let c = |theta, scale, reflection| Condition {
        theta,
        scale,
        reflection,
    };
    vec![
        ("original".into(), c(0.0, 1.0, 1)),
        ("rotated 30°".into(), c(r, 1.0, 1)),
        ("scaled 0.8".into(), c(0.0, 0.8, 1)),
        ("reflected".into(), c(0.0, 1.0, -1)),
        ("rot 30° + scale 0.8 + refl".into(), c(r, 0.8, -1)),
    ]
}

/// Conditions off every training grid, for a canonicalised policy (exactly equivariant
/// wherever the lifted flows are feasible): θ = 17°, λ = 0.73 and θ = 170°, λ = 1.15 (a
/// scale above the grid's largest, 1), both reflected.
fn off_grid_conditions() -> Vec<(String, Condition)> {
    vec![
        (
            "off-grid: rot 17° + scale 0.73 + refl".into(),
            Condition {
                theta: 17f64.to_radians(),
                scale: 0.73,
                reflection: -1,
            },
        ),
        (
            "off-grid: rot 170° + scale 1.15 + refl".into(),
            Condition {
                theta: 170f64.to_radians(),
                scale: 1.15,
                reflection: -1,
            },
        ),
    ]
}

/// A child process that is terminated (SIGTERM, then killed) when dropped.
struct Proc {
    name: &'static str,
    child: Option<Child>,
}

impl Proc {
    fn spawn(name: &'static str, mut cmd: Command, log: &Path) -> anyhow::Result<Self> {
        let f = std::fs::File::create(log).with_context(|| format!("{}", log.display()))?;
        let child = cmd
            .stdout(Stdio::from(f.try_clone()?))
            .stderr(Stdio::from(f))
            .spawn()
            .with_context(|| format!("starting {name}"))?;
        Ok(Self {
            name,
            child: Some(child),
        })
    }

    /// SIGTERM and wait (up to 10 s); the exit code.
    fn stop(&mut self) -> anyhow::Result<i32> {
        let Some(mut c) = self.child.take() else {
            return Ok(0);
        };
        if let Some(status) = c.try_wait()? {
            anyhow::bail!("{} exited early with {status}", self.name);
        }
        let _ = Command::new("kill")
            .args(["-TERM", &c.id().to_string()])
            .status();
        for _ in 0..100 {
            if let Some(s) = c.try_wait()? {
                return Ok(s.code().unwrap_or(-1));
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        let _ = c.kill();
        anyhow::bail!("{} did not stop within 10 s of SIGTERM", self.name)
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

/// `crossym demo`.
pub fn demo(a: &DemoArgs) -> anyhow::Result<ExitCode> {
    if !a.no_isolation {
        if let Some(code) = isolate()? {
            return Ok(code);
        }
    }
    let cfg = Config::from_file(&a.config)?;
    let overrides = super::ros::NodeOverrides {
        policy: a.policy.clone(),
        ..Default::default()
    };
    let node_cfg = super::ros::node_config(&cfg, &overrides)?;
    let hw_cfg = cfg.mock_hw.clone().unwrap_or_default();
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let demos = super::letter_demos(&cfg, kin)?;
    let demo = crossym::pipeline::pick_demo(&demos, a.demo)?;
    let which = demo.demo;
    let policy_path = node_cfg
        .policy
        .clone()
        .context("[node] policy is not set")?;
    let policy = crossym::pipeline::load_any_policy(&cfg, kin, &policy_path)?;
    // The node rejects conditions outside a plain policy's trained box: refuse them here
    // with the reason (given ones) or leave them out (defaults), instead of a node that
    // ignores them. A canonicalised policy has no box (the node checks feasibility).
    let domain = node_cfg
        .condition_domain(&policy)
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("policy {}", policy_path.display()))?;
    let conditions: Vec<(String, Condition)> = if a.conditions.is_empty() {
        let mut kept = default_conditions();
        if policy.composition().is_some() {
            kept.extend(off_grid_conditions());
        }
        if let Some(d) = &domain {
            kept.retain(|(label, c)| {
                let ok = d.check(c).is_ok();
                if !ok {
                    println!(
                        "  leaving out default condition `{label}`: the policy was trained on {}",
                        d.describe()
                    );
                }
                ok
            });
        }
        anyhow::ensure!(
            !kept.is_empty(),
            "no default condition lies in the policy's trained box; give --condition"
        );
        kept
    } else {
        let given = a
            .conditions
            .iter()
            .map(|s| super::parse_condition(s))
            .collect::<anyhow::Result<Vec<_>>>()?;
        if let Some(d) = &domain {
            for (s, c) in &given {
                if let Err(part) = d.check(c) {
                    anyhow::bail!(
                        "--condition `{s}`: {part} lies outside the conditions the policy was trained \
                         on ({}); set [node] accept_untrained_conditions = true to let it extrapolate",
                        d.describe()
                    );
                }
            }
        }
        given
    };
    println!(
        "crossym demo: {} on {} ({} joints), demo {which}, policy {}",
        a.config.display(),
        kin.robot,
        kin.dof(),
        policy_path.display()
    );
    anyhow::ensure!(
        a.max_ratio.is_finite() && a.max_ratio > 0.0,
        "--max-ratio must be positive"
    );
    let plant = a.plant.unwrap_or(hw_cfg.plant);
    let max_excess = a.max_excess.unwrap_or(match plant {
        crossym::sim::physics::Plant::Kinematic => 0.0,
        crossym::sim::physics::Plant::Mujoco => 0.01,
    });
    anyhow::ensure!(
        max_excess.is_finite() && max_excess >= 0.0,
        "--max-excess must be finite and ≥ 0"
    );
    let conds: Vec<Condition> = conditions.iter().map(|c| c.1).collect();
    let nominal = nominal_trajectories(&cfg, kin, demo, &conds).map_err(anyhow::Error::msg)?;
    let mut steps = Vec::new();
    for ((label, c), aug) in conditions.iter().zip(nominal) {
        let mut t = aug.traj;
        if let Some(d) = a.duration_s {
            anyhow::ensure!(d > 0.0, "--duration-s must be positive");
            let keep = ((d / t.dt).round() as usize + 1).clamp(2, t.len());
            t.q.truncate(keep * t.n);
            t.qdot.truncate(keep * t.n);
            t.x.truncate(keep * t.m);
        }
        steps.push(ScenarioStep {
            label: label.clone(),
            condition: *c,
            nominal: t,
        });
    }
    let offline: Vec<f64> = steps
        .iter()
        .map(|s| {
            score(
                &policy,
                kin,
                &s.nominal,
                &s.condition,
                &EvalConfig::default(),
            )
            .rmse
        })
        .collect();

    std::fs::create_dir_all(&a.out).with_context(|| format!("{}", a.out.display()))?;
    let exe = std::env::current_exe()?;
    let mut settings = DdsSettings::from_env()?;
    settings.range = DiscoveryRange::Localhost;
    let child = |sub: &str| {
        let mut c = Command::new(&exe);
        c.arg(sub)
            .arg("--config")
            .arg(&a.config)
            .env("ROS_LOCALHOST_ONLY", "1")
            .env("ROS_DOMAIN_ID", settings.domain_id.to_string());
        c
    };
    let summary_path = a.out.join("mock_hw_summary.json");
    let _ = std::fs::remove_file(&summary_path);
    let mut hw_cmd = child("mock-hw");
    hw_cmd.arg("--summary").arg(&summary_path);
    if let Some(p) = a.plant {
        hw_cmd.arg("--plant").arg(match p {
            crossym::sim::physics::Plant::Kinematic => "kinematic",
            crossym::sim::physics::Plant::Mujoco => "mujoco",
        });
    }
    let mut hw = Proc::spawn("mock-hw", hw_cmd, &a.out.join("mock_hw.log"))?;
    let bag_dir = a.out.join("bag");
    if bag_dir.exists() {
        std::fs::remove_dir_all(&bag_dir).with_context(|| format!("{}", bag_dir.display()))?;
    }
    let mut node_cmd = child("node");
    node_cmd.arg("--record").arg(&bag_dir);
    if let Some(p) = &a.policy {
        node_cmd.arg("--policy").arg(p);
    }
    let mut node = Proc::spawn("node", node_cmd, &a.out.join("node.log"))?;
    println!(
        "  started mock-hw and node (domain {}, localhost only); logs in {}",
        settings.domain_id,
        a.out.display()
    );
    let topics = ScenarioTopics::new(&node_cfg, &hw_cfg.reset_topic);
    let results = scenario::run(
        settings,
        &topics,
        kin,
        kin.joint_names(),
        &steps,
        Duration::from_secs(30),
    );
    let node_rc = node.stop();
    let hw_rc = hw.stop();
    let results = results?;
    let node_rc = node_rc?;
    let hw_rc = hw_rc?;
    let summary: MockHwSummary = {
        let text = std::fs::read_to_string(&summary_path)
            .with_context(|| format!("reading {}", summary_path.display()))?;
        serde_json::from_str(&text).context("mock-hw summary")?
    };

    // Report.
    let mut md = String::from(
        "| # | condition | θ (rad) | λ | σ | RMSE closed loop | RMSE offline rollout | ratio | RMSE paper protocol | samples | status on a bound | tick median / max (µs) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    let mut csv = String::from(
        "step,label,theta,scale,reflection,rmse_closed_loop,rmse_offline,ratio,rmse_paper_protocol,samples,statuses_on_bound,statuses,tick_median_us,tick_max_us\n",
    );
    let mut failures = Vec::new();
    for (i, (r, off)) in results.iter().zip(&offline).enumerate() {
        let ratio = r.rmse / off.max(1e-12);
        // `[eval] paper_protocol` on the measured path (the resampled, real-robot script).
        let nominal = &steps[i].nominal;
        let paper =
            crossym::pipeline::paper::paper_path_error(&cfg, kin, &r.path, &nominal.x, nominal.m);
        let paper_md = paper.map_or("–".to_string(), |e| format!("{:.4}", e.error));
        let paper_csv = paper.map_or(String::new(), |e| e.error.to_string());
        md.push_str(&format!(
            "| {} | {} | {:.4} | {} | {} | {:.4} | {:.4} | {:.2} | {paper_md} | {} | {}/{} | {:.1} / {:.1} |\n",
            i + 1,
            r.label,
            r.theta,
            r.scale,
            r.reflection,
            r.rmse,
            off,
            ratio,
            r.samples,
            r.statuses_on_bound,
            r.statuses,
            r.tick_median_us,
            r.tick_max_us
        ));
        csv.push_str(&format!(
            "{},{},{},{},{},{},{},{},{paper_csv},{},{},{},{},{}\n",
            i + 1,
            r.label,
            r.theta,
            r.scale,
            r.reflection,
            r.rmse,
            off,
            ratio,
            r.samples,
            r.statuses_on_bound,
            r.statuses,
            r.tick_median_us,
            r.tick_max_us
        ));
        if !(r.rmse.is_finite() && r.rmse <= a.max_ratio * off + max_excess) {
            failures.push(format!(
                "step {} ({}): closed-loop RMSE {:.4} is {:.2}× the offline rollout's {:.4} (limit {}× + {})",
                i + 1,
                r.label,
                r.rmse,
                ratio,
                off,
                a.max_ratio,
                max_excess
            ));
        }
        if !r.abnormal_codes.is_empty() {
            failures.push(format!(
                "step {} ({}): node status codes {:?} seen",
                i + 1,
                r.label,
                r.abnormal_codes
            ));
        }
    }
    if summary.violation_count > 0 {
        failures.push(format!(
            "mock hardware saw {} limit violations (first: {:?})",
            summary.violation_count,
            summary.violations.first()
        ));
    }
    if node_rc != 0 {
        failures.push(format!("node exited with {node_rc}"));
    }
    // The recorded bag replays bit for bit through the node's logic.
    let replay_line = match replay_bag(&bag_dir, &a.config, &overrides) {
        Ok((commands, dev)) => {
            if dev > 1e-9 {
                failures.push(format!(
                    "replay of {} deviates by {dev:e} from the recorded commands",
                    bag_dir.display()
                ));
            }
            format!(
                "\nBag `{}`: offline replay recomputed {commands} commands, max deviation {dev:.1e}.\n",
                bag_dir.display()
            )
        }
        Err(e) => {
            failures.push(format!("replay of {}: {e:#}", bag_dir.display()));
            String::new()
        }
    };
    if hw_rc != 0 {
        failures.push(format!("mock-hw exited with {hw_rc}"));
    }
    md.push_str(&format!(
        "\nMock hardware: {} steps, {} commands received, {} invalid, {} limit violations; largest |q̇| per joint (rad/s): {:?}.\n",
        summary.steps,
        summary.commands_received,
        summary.commands_invalid,
        summary.violation_count,
        summary
            .max_abs_velocity
            .iter()
            .map(|v| (v * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>()
    ));
    if let Some(line) = summary.plant_line() {
        md.push_str(&format!("\n{line}\n"));
    }
    md.push_str(&replay_line);
    md.push_str("\nFigure `demo.png`: one panel per step, in table order, captioned with its condition; grey = nominal paths (transformed demonstration), colour = end-effector paths executed over DDS (blue left arm, red right arm).\n");
    let arm_dim = kin.chains().first().map_or(2, |c| c.task.dim());
    let view = cfg.eval.view.unwrap_or(XY_VIEW);
    let panels: Vec<PathPanel> = results
        .iter()
        .zip(&steps)
        .enumerate()
        .map(|(i, (r, s))| {
            PathPanel::single(
                s.nominal.m,
                arm_dim,
                view,
                s.nominal.x.clone(),
                r.path.clone(),
                format!("{}. {}", i + 1, condition_label(&s.condition)),
            )
        })
        .collect();
    let fig = PathFigure {
        executed_name: "executed over DDS".into(),
        ..PathFigure::for_robot(
            format!(
                "crossym demo: {} on {}, demonstration {which}, closed loop through the node",
                super::file_name(&policy_path),
                kin.robot
            ),
            kin,
            &cfg.eval,
        )
    };
    let png = a.out.join("demo.png");
    write_paths_grid(&png, &fig, &panels, panels.len().min(5), 360).map_err(anyhow::Error::msg)?;
    std::fs::write(a.out.join("demo.md"), &md)?;
    std::fs::write(a.out.join("demo.csv"), &csv)?;
    println!("{md}");
    println!(
        "  wrote {}, {}, {}",
        a.out.join("demo.md").display(),
        a.out.join("demo.csv").display(),
        png.display()
    );
    if failures.is_empty() {
        println!("demo: OK");
        Ok(ExitCode::SUCCESS)
    } else {
        for f in &failures {
            eprintln!("demo: FAILED: {f}");
        }
        Ok(ExitCode::from(1))
    }
}

/// Replays the recorded bag; (commands compared, max deviation).
fn replay_bag(
    dir: &Path,
    config: &Path,
    overrides: &super::ros::NodeOverrides,
) -> anyhow::Result<(usize, f64)> {
    use crossym::ros::replay::{replay, ReplayTopics};
    let bag = crossym::bag::Bag::open(dir)?;
    let (_, mut core) = super::ros::build_core(config, overrides)?;
    let topics = ReplayTopics::for_node(core.config());
    let r = replay(&bag, &mut core, &topics)?;
    anyhow::ensure!(
        r.unmatched == 0 && r.commands > 0,
        "{} commands without their input snapshot, {} compared",
        r.unmatched,
        r.commands
    );
    Ok((r.commands, r.max()))
}
