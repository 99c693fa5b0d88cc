//! `crossym export-lerobot`: the configured demonstrations written as a LeRobotDataset
//! (v3.0), so data taught from bags or CSV files can be used by the LeRobot tools
//! ([`crossym::lerobot::write_dataset`]).
// Without the `teach` feature only the options remain (`run` says how to get the command).
#![cfg_attr(not(feature = "teach"), allow(dead_code, unused_imports))]

use std::path::PathBuf;
use std::process::ExitCode;

use crossym::config::Config;
#[cfg(feature = "teach")]
use crossym::lerobot::{write_dataset, EpisodeFrames};

/// Options of `crossym export-lerobot`.
#[derive(Debug, clap::Args)]
pub struct ExportLerobotArgs {
    /// Config with [robot] and [demonstrations].
    #[arg(long, short)]
    pub config: PathBuf,
    /// The new dataset's directory (must not exist or be empty).
    #[arg(long)]
    pub out: PathBuf,
    /// The task string every episode gets (default: the config file's name).
    #[arg(long)]
    pub task: Option<String>,
}

/// Without the `teach` feature: an error saying how to build the command.
#[cfg(not(feature = "teach"))]
pub fn run(_: &ExportLerobotArgs) -> anyhow::Result<ExitCode> {
    super::common::needs_teach("export-lerobot")
}

/// `crossym export-lerobot`: one episode per demonstration, in demonstration order, frames
/// every `[demonstrations] dt`, `observation.state` named by the robot's joints.
#[cfg(feature = "teach")]
pub fn run(a: &ExportLerobotArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let demos = cfg.load_demonstrations(kin)?;
    anyhow::ensure!(!demos.demos.is_empty(), "no demonstration to export");
    let dt = demos.demos[0].dt;
    let task = a.task.clone().unwrap_or_else(|| {
        a.config
            .file_stem()
            .map_or("crossym".into(), |s| s.to_string_lossy().into_owned())
    });
    let times: Vec<Vec<f64>> = demos
        .demos
        .iter()
        .map(|d| (0..d.len()).map(|k| k as f64 * d.dt).collect())
        .collect();
    let episodes: Vec<EpisodeFrames<'_>> = demos
        .demos
        .iter()
        .zip(&times)
        .map(|(d, t)| EpisodeFrames {
            task_index: 0,
            t,
            state: &d.q,
        })
        .collect();
    write_dataset(&a.out, 1.0 / dt, kin.joint_names(), &[task], &episodes)?;
    let frames: usize = times.iter().map(Vec::len).sum();
    println!(
        "export-lerobot: {} episodes, {frames} frames at {} fps, {} joints → {} (LeRobotDataset v3.0)",
        episodes.len(),
        1.0 / dt,
        kin.dof(),
        a.out.display()
    );
    for (k, name) in (0..demos.demos.len()).map(|k| (k, demos.name(k + 1))) {
        println!("  episode {k}: {name}");
    }
    Ok(ExitCode::SUCCESS)
}
