//! `crossym demos`: the recorded demonstrations of `[demonstrations]`, read and cleaned,
//! one report line per source (and per segment), figures of the joint trajectories and
//! task-space paths.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use crossym::config::Config;
use crossym::data::recorded::load_sources;
use crossym::eval::plot::{
    write_curves_png, write_paths_grid, CurveFigure, PathFigure, PathPanel, XY_VIEW,
};

/// Arguments of `crossym demos`.
#[derive(Debug, Args)]
pub struct DemosArgs {
    /// Config file (TOML) with [robot] and [demonstrations].
    #[arg(long, short)]
    pub config: PathBuf,
    /// Directory for `demos_task.png` (task-space paths, one panel per demonstration) and
    /// `demos_joints.png` (joint positions of the first demonstration against time).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `crossym demos`. Exits 1 when a source was refused.
pub fn demos(a: &DemosArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let dcfg = cfg
        .demonstrations
        .as_ref()
        .with_context(|| format!("{}: no [demonstrations] section", a.config.display()))?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let names = kin.joint_names();
    println!(
        "crossym demos: {} sources, Δt = {} s, {} joints of {}",
        dcfg.sources.len(),
        dcfg.dt,
        kin.dof(),
        kin.robot
    );
    let loaded = load_sources(dcfg, |p| cfg.resolve(p), kin);
    let mut refused = 0;
    let mut all = Vec::new();
    for (name, r) in &loaded {
        match r {
            Err(e) => {
                refused += 1;
                println!("{name}: REFUSED: {e}");
            }
            Ok(s) => {
                let rep = &s.report;
                println!(
                    "{name}: {} ({} samples over {:.2} s, largest stamp step {:.1} ms) → {} demonstration{}, idle trimmed {:.2} s / {:.2} s; peak speed {:.3} ({}); {}{}",
                    s.file.display(),
                    s.raw.0,
                    s.raw.1,
                    rep.max_gap_s * 1e3,
                    rep.segments,
                    if rep.segments == 1 { "" } else { "s" },
                    rep.trimmed_s.0,
                    rep.trimmed_s.1,
                    rep.peak_speed.0,
                    names[rep.peak_speed.1],
                    rep.min_margin.map_or_else(String::new, |(m, j)| format!(
                        "smallest limit margin {m:.3} ({})",
                        names[j]
                    )),
                    if rep.outside_limits > 0 {
                        format!("; {} samples OUTSIDE the joint limits", rep.outside_limits)
                    } else {
                        String::new()
                    }
                );
                if !s.ignored.is_empty() {
                    println!("  ignored joints: {}", s.ignored.join(", "));
                }
                for (dn, d) in &s.demos {
                    let role = if dcfg.test.iter().any(|t| t == dn || t == &s.name) {
                        "test"
                    } else if dcfg.train.iter().any(|t| t == dn || t == &s.name) {
                        "train"
                    } else {
                        "unused"
                    };
                    println!(
                        "  {dn}: {} samples, {:.2} s from t = {:.2} s ({role})",
                        d.len(),
                        (d.len().max(1) - 1) as f64 * d.dt,
                        d.start_s
                    );
                    all.push((dn, d));
                }
            }
        }
    }
    if let Some(dir) = &a.plot {
        anyhow::ensure!(!all.is_empty(), "no demonstration to plot");
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let mut ws = kin.workspace();
        let m = kin.task_dim();
        let panels: Vec<PathPanel> = all
            .iter()
            .map(|(dn, d)| {
                let mut x = Vec::with_capacity(d.len() * m);
                for q in d.q.chunks_exact(d.n) {
                    x.extend_from_slice(kin.forward(q, &mut ws).as_slice());
                }
                PathPanel::single(
                    m,
                    kin.chains().first().map_or(2, |c| c.task.dim()),
                    cfg.eval.view.unwrap_or(XY_VIEW),
                    Vec::new(),
                    x,
                    format!("{dn}: {:.2} s", (d.len().max(1) - 1) as f64 * d.dt),
                )
            })
            .collect();
        let fig = PathFigure {
            executed_name: "recorded (FK of the clean joint path)".into(),
            ..PathFigure::for_robot(
                format!("Recorded demonstrations on {}", kin.robot),
                kin,
                &cfg.eval,
            )
        };
        let task = dir.join("demos_task.png");
        write_paths_grid(&task, &fig, &panels, panels.len().min(4), 360)
            .map_err(anyhow::Error::msg)?;
        let (first, d) = &all[0];
        let curves: Vec<Vec<(f64, f64)>> = (0..d.n)
            .map(|j| {
                (0..d.len())
                    .map(|k| (d.start_s + k as f64 * d.dt, d.q[k * d.n + j]))
                    .collect()
            })
            .collect();
        let joints = dir.join("demos_joints.png");
        let cfig = CurveFigure {
            title: format!("Demonstration {first}: joint positions after cleaning"),
            x_desc: "time since the recording's first stamp (s)".into(),
            y_desc: "joint position (rad or m)".into(),
            names: names.to_vec(),
            categorical: true,
        };
        write_curves_png(&joints, &cfig, &curves, 900, 460).map_err(anyhow::Error::msg)?;
        println!("wrote {} and {}", task.display(), joints.display());
    }
    Ok(if refused > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
