//! `crossym rollout`: integrate a policy open loop from a start state, under one symmetry
//! condition, and write the states to CSV (and the task-space path to PNG). Started from a
//! demonstration, the rollout is also scored against that demonstration transformed by the
//! condition (the nominal trajectory of Table II).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::eval::plot::{condition_label, write_paths_png, PathFigure, PathPanel, XY_VIEW};
use crossym::eval::{nominal_at, rollout, samples_spanning, score_path_timed, RolloutStatus};
use crossym::kinematics::Kinematics;
use crossym::pipeline::figures::file_name;
use crossym::pipeline::nominal_trajectories;
use crossym::policy::JointTrajectory;
use crossym::setup::{node_config, parse_condition, NodeOverrides};
use crossym::symmetry::compose::Condition;

/// Options of `crossym rollout`.
#[derive(Debug, clap::Args)]
pub struct RolloutArgs {
    /// Config file (TOML) with [robot]; [demonstrations], [[symmetries]] and [composition] for
    /// `--demo`; [node] policy when no `--policy` is given.
    #[arg(long, short, default_value = "config/letters.toml")]
    pub config: PathBuf,
    /// Policy weights (`.safetensors`); default: `[node] policy` of the config.
    #[arg(long)]
    pub policy: Option<PathBuf>,
    /// Symmetry condition `theta_rad:scale:reflection`.
    #[arg(long, default_value = "0:1:1", allow_hyphen_values = true)]
    pub condition: String,
    /// Start from this demonstration (1-based) transformed by the condition, and score the
    /// rollout against it; default (without `--q`): the first of `[demonstrations] test`.
    #[arg(long, conflicts_with = "q")]
    pub demo: Option<usize>,
    /// Start configuration (rad or m), comma-separated, in the robot's joint order.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub q: Option<Vec<f64>>,
    /// Integration step Δt (s); default: the demonstration's, else `[node] period_s`.
    #[arg(long, allow_hyphen_values = true)]
    pub dt: Option<f64>,
    /// Duration (s); default: the demonstration's time length (whatever `--dt`), else 10 s.
    #[arg(long, allow_hyphen_values = true)]
    pub duration_s: Option<f64>,
    /// Output CSV: `t`, then `q_<joint>`, `qdot_<joint>`, `x<i>` (and `x<i>_nominal` with a
    /// demonstration) per sample.
    #[arg(long, default_value = "results/rollout.csv")]
    pub out: PathBuf,
    /// Also draw the task-space path (grey nominal, colour rollout) into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `crossym rollout`. Exits 1 when the rollout turned non-finite.
pub fn run(a: &RolloutArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let condition = parse_condition(&a.condition)?;
    let policy_path = policy_path(a, &cfg)?;
    let policy = crossym::pipeline::load_any_policy(&cfg, kin, &policy_path)?;
    let (q0, nominal, label) = start_state(a, &cfg, kin, &condition)?;
    let (dt, len) = step_and_length(a, &cfg, nominal.as_ref())?;
    let r = rollout(&policy, kin, &q0, &condition, dt, len);
    let t = &r.traj;

    let csv = csv(kin, t, nominal.as_ref(), dt)?;
    crossym::pipeline::create_parent(&a.out)?;
    std::fs::write(&a.out, &csv).with_context(|| format!("writing {}", a.out.display()))?;

    println!(
        "rollout of {} on {} from {label} under θ = {} rad, λ = {}, σ = {}: {} samples, Δt = {dt} s",
        policy_path.display(),
        kin.robot,
        condition.theta,
        condition.scale,
        condition.reflection,
        t.len()
    );
    let finite = print_end(kin, t, r.status, dt);
    if let Some(nom) = &nominal {
        print_score(&cfg, nom, t, dt, finite);
    }
    println!("  wrote {}", a.out.display());
    if let Some(png) = &a.plot {
        let caption = format!(
            "{label}, {}, {:.1} s at Δt = {} s",
            condition_label(&condition),
            (t.len().max(1) - 1) as f64 * dt,
            dt
        );
        plot(png, &cfg, kin, &policy_path, caption, t, nominal.as_ref())?;
    }
    Ok(if finite {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The policy file: `--policy`, else `[node] policy` of the config.
fn policy_path(a: &RolloutArgs, cfg: &Config) -> anyhow::Result<PathBuf> {
    Ok(match &a.policy {
        Some(p) => p.clone(),
        None => node_config(cfg, &NodeOverrides::default())?
            .policy
            .with_context(|| {
                format!(
                    "{}: no --policy given and [node] policy is not set",
                    a.config.display()
                )
            })?,
    })
}

/// The integration step and the number of samples: `--dt` and `--duration-s`, else the
/// `nominal` demonstration's, else `[node] period_s` and 10 s.
fn step_and_length(
    a: &RolloutArgs,
    cfg: &Config,
    nominal: Option<&JointTrajectory>,
) -> anyhow::Result<(f64, usize)> {
    let dt = match (a.dt, nominal) {
        (Some(dt), _) => dt,
        (None, Some(t)) => t.dt,
        (None, None) => cfg.node_config().period_s,
    };
    anyhow::ensure!(dt.is_finite() && dt > 0.0, "--dt {dt} must be positive");
    let len = match (a.duration_s, nominal) {
        (Some(d), _) => {
            anyhow::ensure!(
                d.is_finite() && d > 0.0,
                "--duration-s {d} must be positive"
            );
            (d / dt).round() as usize + 1
        }
        (None, Some(t)) => samples_spanning(t, dt),
        (None, None) => (10.0 / dt).round() as usize + 1,
    };
    Ok((dt, len))
}

/// How the rollout `t` ended (its last state, or where it turned non-finite) and its samples
/// outside the joint limits; whether it stayed finite.
fn print_end(kin: &Kinematics, t: &JointTrajectory, status: RolloutStatus, dt: f64) -> bool {
    let outside = (0..t.len())
        .filter(|&k| t.q(k).iter().all(|v| v.is_finite()) && !kin.within_limits(t.q(k)))
        .count();
    let finite = match status {
        RolloutStatus::Finite => true,
        RolloutStatus::NonFinite { sample } => {
            println!(
                "  NON-FINITE from sample {sample} (t = {} s)",
                sample as f64 * dt
            );
            false
        }
        _ => false,
    };
    if finite {
        let last = t.len() - 1;
        let speed = t
            .qdot(last.saturating_sub(1))
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt();
        println!(
            "  final x = {:?} (task units); last |q̇| = {speed:.3e} rad/s",
            t.x(last)
        );
    }
    println!("  samples outside the joint limits: {outside}");
    finite
}

/// The rollout `t` scored against the nominal trajectory `nom` (and, when it stayed
/// `finite`, its distance to the nominal's goal).
fn print_score(cfg: &Config, nom: &JointTrajectory, t: &JointTrajectory, dt: f64, finite: bool) {
    // Sample by sample at the same times (the nominal interpolated when `--dt` differs
    // from its step, its goal past its end).
    let s = score_path_timed(nom, &t.x, dt, &cfg.eval);
    println!(
        "  RMSE against the nominal over {} samples ({:.2} s): {:.4} Euclidean, {:.4} per coordinate (task units){}",
        t.len(),
        (t.len() - 1) as f64 * dt,
        s.rmse,
        s.rmse / (t.m as f64).sqrt(),
        if s.diverged { "; DIVERGED" } else { "" }
    );
    if finite {
        let d = distance(t.x(t.len() - 1), nom.x(nom.len() - 1));
        println!("  final distance to the nominal's goal: {d:.4} (task units)");
    }
}

/// The start state and, from a demonstration, the nominal trajectory and a label.
fn start_state(
    a: &RolloutArgs,
    cfg: &Config,
    kin: &Kinematics,
    condition: &Condition,
) -> anyhow::Result<(Vec<f64>, Option<JointTrajectory>, String)> {
    Ok(match &a.q {
        Some(q) => {
            anyhow::ensure!(
                q.len() == kin.dof(),
                "--q has {} values, the robot has {} joints {:?}",
                q.len(),
                kin.dof(),
                kin.joint_names()
            );
            anyhow::ensure!(
                q.iter().all(|v| v.is_finite()),
                "--q has a non-finite value"
            );
            if !kin.within_limits(q) {
                eprintln!("warning: --q is outside the joint limits");
            }
            (q.clone(), None, "--q".to_string())
        }
        None => {
            let demos = cfg.load_demonstrations(kin)?;
            let demo = crossym::pipeline::pick_demo(&demos, a.demo)?;
            let which = demo.demo;
            let aug = nominal_trajectories(cfg, kin, demo, &[*condition])
                .map_err(anyhow::Error::msg)
                .with_context(|| format!("demonstration {which} under {}", a.condition))?
                .pop()
                .context("no nominal trajectory")?;
            (
                aug.traj.q(0).to_vec(),
                Some(aug.traj),
                format!("demo {which}"),
            )
        }
    })
}

/// The CSV: `t`, then `q_<joint>`, `qdot_<joint>`, `x<i>` (and `x<i>_nominal` with a
/// nominal trajectory), one row per sample `dt` apart.
fn csv(
    kin: &Kinematics,
    t: &JointTrajectory,
    nominal: Option<&JointTrajectory>,
    dt: f64,
) -> Result<String, std::fmt::Error> {
    let m = t.m;
    let names = kin.joint_names();
    let mut csv = String::from("t");
    for j in names {
        write!(csv, ",q_{j}")?;
    }
    for j in names {
        write!(csv, ",qdot_{j}")?;
    }
    for i in 0..m {
        write!(csv, ",x{i}")?;
    }
    if nominal.is_some() {
        for i in 0..m {
            write!(csv, ",x{i}_nominal")?;
        }
    }
    csv.push('\n');
    let mut x_nominal = vec![0.0; m];
    for k in 0..t.len() {
        write!(csv, "{}", k as f64 * dt)?;
        for v in t.q(k).iter().chain(t.qdot(k)).chain(t.x(k)) {
            write!(csv, ",{v}")?;
        }
        if let Some(nom) = nominal {
            // At the sample's time; past the nominal's end its goal stands.
            nominal_at(nom, k as f64 * dt, &mut x_nominal);
            for v in &x_nominal {
                write!(csv, ",{v}")?;
            }
        }
        csv.push('\n');
    }
    Ok(csv)
}

/// `--plot`: the task-space path, grey nominal, colour rollout.
fn plot(
    png: &Path,
    cfg: &Config,
    kin: &Kinematics,
    policy_path: &Path,
    caption: String,
    t: &JointTrajectory,
    nominal: Option<&JointTrajectory>,
) -> anyhow::Result<()> {
    let arm_dim = kin.chains().first().map_or(2, |c| c.task.dim());
    let view = cfg.eval.view.unwrap_or(XY_VIEW);
    let nominal_x = nominal.map_or_else(Vec::new, |t| t.x.clone());
    let panel = PathPanel::single(t.m, arm_dim, view, nominal_x, t.x.clone(), caption);
    let fig = PathFigure {
        executed_name: "open-loop rollout".into(),
        ..PathFigure::for_robot(
            format!(
                "crossym rollout: {} on {}",
                file_name(policy_path),
                kin.robot
            ),
            kin,
            &cfg.eval,
        )
    };
    write_paths_png(png, &fig, &[panel], 640).map_err(anyhow::Error::msg)?;
    println!("  wrote {}", png.display());
    Ok(())
}

/// Euclidean distance of two points (task units).
fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).powi(2))
        .sum::<f64>()
        .sqrt()
}
