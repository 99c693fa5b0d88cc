//! `crossym demos`: the demonstrations of `[demonstrations]` (any source) loaded, one report
//! line per source and per demonstration (number, name, role, duration, peak joint speed,
//! smallest limit margin), figures of the task-space paths and the first demonstration's
//! joint positions.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use crossym::config::Config;
use crossym::data::demonstrations::{
    load_each, Demonstrations, DemonstrationsConfig, Pick, SourceDemos, SourceDetail,
};
use crossym::eval::plot::{
    write_curves_png, write_paths_grid, CurveFigure, PathFigure, PathPanel, XY_VIEW,
};
use crossym::policy::JointTrajectory;

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

/// Peak joint speed (value, joint) and smallest margin to a position limit (value, joint;
/// negative: outside) of a demonstration.
fn peak_and_margin(
    d: &JointTrajectory,
    limits: &[crossym::kinematics::JointLimits],
) -> ((f64, usize), Option<(f64, usize)>) {
    let mut peak = (0.0f64, 0usize);
    let mut margin: Option<(f64, usize)> = None;
    for i in 0..d.len() {
        for (j, (v, q)) in d.qdot(i).iter().zip(d.q(i)).enumerate() {
            if v.abs() > peak.0 {
                peak = (v.abs(), j);
            }
            let l = &limits[j];
            let m = (q - l.lower).min(l.upper - q);
            if m.is_finite() && margin.is_none_or(|(b, _)| m < b) {
                margin = Some((m, j));
            }
        }
    }
    (peak, margin)
}

/// `crossym demos`. Exits 1 when a source was refused.
pub fn run(a: &DemosArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let dcfg = cfg
        .demonstrations
        .as_ref()
        .with_context(|| format!("{}: no [demonstrations] section", a.config.display()))?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    println!(
        "crossym demos: {} sources, Δt = {} s, {} joints of {}",
        dcfg.sources.len(),
        dcfg.dt,
        kin.dof(),
        kin.robot
    );
    let loaded = load_each(dcfg, |p| cfg.resolve(p), kin);
    let refused = loaded.iter().filter(|(_, r)| r.is_err()).count();
    for (_, r) in &loaded {
        if let Err(e) = r {
            println!("REFUSED: {e}");
        }
    }
    let ok: Vec<SourceDemos> = loaded.into_iter().filter_map(|(_, r)| r.ok()).collect();
    // Numbers and roles (when every source loaded, the selection is checked too).
    let all = select(dcfg, ok, refused)?;
    print_demonstrations(&all, dcfg, refused > 0, kin);
    if let Some(dir) = &a.plot {
        plot(dir, &cfg, kin, &all)?;
    }
    Ok(if refused > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// The demonstrations of the sources that loaded, numbered; with a source `refused`,
/// without the train / test selection (its numbers would shift).
fn select(
    dcfg: &DemonstrationsConfig,
    ok: Vec<SourceDemos>,
    refused: usize,
) -> anyhow::Result<Demonstrations> {
    Ok(if refused == 0 {
        Demonstrations::from_sources(dcfg, ok)?
    } else {
        let mut d = Demonstrations::from_sources(
            &DemonstrationsConfig {
                train: Vec::new(),
                test: Vec::new(),
                ..dcfg.clone()
            },
            ok,
        )?;
        d.train.clear();
        d.test.clear();
        d
    })
}

/// One report line per source and per demonstration: number, name, role, duration, peak
/// speed, smallest limit margin.
fn print_demonstrations(
    all: &Demonstrations,
    dcfg: &DemonstrationsConfig,
    refused: bool,
    kin: &crossym::kinematics::Kinematics,
) {
    let names = kin.joint_names();
    let mut number = 1;
    for s in &all.sources {
        print_source(s);
        for (k, (dn, d)) in s.demos.iter().enumerate() {
            let role = role(dcfg, all, refused, &s.name, dn, number);
            let start = match &s.detail {
                SourceDetail::Recorded(r) => format!(" from t = {:.2} s", r.starts_s[k]),
                SourceDetail::Tracked { .. } | SourceDetail::Episodes(_) => String::new(),
            };
            let (peak, margin) = peak_and_margin(d, kin.limits());
            println!(
                "  {number:>3} {dn}: {} samples, {:.2} s{start} ({role}); peak speed {:.3} ({}){}",
                d.len(),
                (d.len().max(1) - 1) as f64 * d.dt,
                peak.0,
                names[peak.1],
                margin.map_or_else(String::new, |(m, j)| format!(
                    ", smallest limit margin {m:.3} ({})",
                    names[j]
                )),
            );
            number += 1;
        }
    }
}

/// Demonstration `number` (`dn` of `source`): test, train or unused; with a source
/// `refused`, by name only (–: not named).
fn role(
    dcfg: &DemonstrationsConfig,
    all: &Demonstrations,
    refused: bool,
    source: &str,
    dn: &str,
    number: usize,
) -> &'static str {
    // With a refused source numbers shift: roles by name only.
    let named = |picks: &[Pick]| {
        picks
            .iter()
            .any(|p| matches!(p, Pick::Name(n) if n == dn || n == source))
    };
    if refused {
        if named(&dcfg.test) {
            "test"
        } else if named(&dcfg.train) {
            "train"
        } else {
            "–"
        }
    } else if all.test.contains(&number) {
        "test"
    } else if all.train.contains(&number) {
        "train"
    } else {
        "unused"
    }
}

/// `; N samples OUTSIDE the joint limits`, or nothing.
fn outside(samples: usize) -> String {
    if samples > 0 {
        format!("; {samples} samples OUTSIDE the joint limits")
    } else {
        String::new()
    }
}

/// One source's report line (and its ignored joints).
fn print_source(s: &SourceDemos) {
    match &s.detail {
        SourceDetail::Tracked { max_tracking_error } => println!(
            "{} ({}): {} demonstration{} tracked into joint space, max tracking error {:.3e} (task units)",
            s.name,
            s.kind.label(),
            s.demos.len(),
            if s.demos.len() == 1 { "" } else { "s" },
            max_tracking_error
        ),
        SourceDetail::Recorded(r) => {
            let rep = &r.report;
            println!(
                "{} ({}): {} ({} samples over {:.2} s, largest stamp step {:.1} ms) → {} demonstration{}, idle trimmed {:.2} s / {:.2} s{}",
                s.name,
                s.kind.label(),
                r.file.display(),
                r.raw.0,
                r.raw.1,
                rep.max_gap_s * 1e3,
                rep.segments,
                if rep.segments == 1 { "" } else { "s" },
                rep.trimmed_s.0,
                rep.trimmed_s.1,
                outside(rep.outside_limits)
            );
            if !r.ignored.is_empty() {
                println!("  ignored joints: {}", r.ignored.join(", "));
            }
        }
        SourceDetail::Episodes(eps) => {
            println!(
                "{} ({}): {} episode{} → {} demonstration{}",
                s.name,
                s.kind.label(),
                eps.len(),
                if eps.len() == 1 { "" } else { "s" },
                s.demos.len(),
                if s.demos.len() == 1 { "" } else { "s" },
            );
            for (index, r) in eps {
                let rep = &r.report;
                println!(
                    "  episode {index} ({}): {} frames over {:.2} s, largest stamp step {:.1} ms, idle trimmed {:.2} s / {:.2} s{}",
                    r.file.display(),
                    r.raw.0,
                    r.raw.1,
                    rep.max_gap_s * 1e3,
                    rep.trimmed_s.0,
                    rep.trimmed_s.1,
                    outside(rep.outside_limits)
                );
            }
            if let Some((_, r)) = eps.first() {
                if !r.ignored.is_empty() {
                    println!("  ignored state names: {}", r.ignored.join(", "));
                }
            }
        }
    }
}

/// `--plot`: the task-space paths (one panel per demonstration) and the first
/// demonstration's joint positions against time.
fn plot(
    dir: &Path,
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    all: &Demonstrations,
) -> anyhow::Result<()> {
    let names = kin.joint_names();
    anyhow::ensure!(!all.demos.is_empty(), "no demonstration to plot");
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let m = kin.task_dim();
    let panels: Vec<PathPanel> = all
        .demos
        .iter()
        .map(|d| {
            PathPanel::single(
                m,
                kin.chains().first().map_or(2, |c| c.task.dim()),
                cfg.eval.view.unwrap_or(XY_VIEW),
                Vec::new(),
                d.x.clone(),
                format!(
                    "{} {}: {:.2} s",
                    d.demo,
                    all.name(d.demo),
                    (d.len().max(1) - 1) as f64 * d.dt
                ),
            )
        })
        .collect();
    let fig = PathFigure {
        executed_name: "demonstration (FK of the joint path)".into(),
        ..PathFigure::for_robot(format!("Demonstrations on {}", kin.robot), kin, &cfg.eval)
    };
    let task = dir.join("demos_task.png");
    write_paths_grid(&task, &fig, &panels, panels.len().min(4), 360).map_err(anyhow::Error::msg)?;
    let d = &all.demos[0];
    let curves: Vec<Vec<(f64, f64)>> = (0..d.n)
        .map(|j| (0..d.len()).map(|k| (k as f64 * d.dt, d.q(k)[j])).collect())
        .collect();
    let joints = dir.join("demos_joints.png");
    let cfig = CurveFigure {
        title: format!("Demonstration 1 ({}): joint positions", all.name(1)),
        x_desc: "time since the demonstration's start (s)".into(),
        y_desc: "joint position (rad or m)".into(),
        names: names.to_vec(),
        categorical: true,
        ramp: None,
    };
    write_curves_png(&joints, &cfig, &curves, 900, 460).map_err(anyhow::Error::msg)?;
    println!("wrote {} and {}", task.display(), joints.display());
    Ok(())
}
