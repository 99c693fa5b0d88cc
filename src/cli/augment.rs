//! `crossym augment`: the demonstrations augmented with the composed group; counts per
//! sub-group, drops by reason, timing, and optionally a figure of the augmented copies.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::pipeline::Splits;

use super::common::pipeline;

/// Options of `crossym augment`.
#[derive(Debug, clap::Args)]
pub struct AugmentArgs {
    /// Config file (TOML) with [demonstrations], [augmentation], [[symmetries]], [composition].
    #[arg(long, short)]
    pub config: PathBuf,
    /// Also draw the first training demonstration and its augmented copies, one panel
    /// per sub-group, into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `crossym augment`.
pub fn run(a: &AugmentArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let robot = cfg.load_robot()?;
    let p = pipeline(
        &cfg,
        &robot.kinematics,
        Splits {
            train: true,
            test: true,
            reference: false,
        },
    )?;
    println!(
        "{} demonstrations from {} source(s) ({} train, {} test; {} samples each on average); max tracking error {:.3e} (task units)",
        p.demos.demos.len(),
        p.demos.sources.len(),
        p.demos.train.len(),
        p.demos.test.len(),
        p.demos.demos.iter().map(|d| d.len()).sum::<usize>() / p.demos.demos.len().max(1),
        p.demos.max_tracking_error
    );
    println!(
        "{:<6} {:<9} {:>6} {:>8} {:>9} {:>8}",
        "set", "group", "kept", "dropped", "singular", "limits"
    );
    for (label, set, secs) in [
        ("train", &p.train, p.train_secs),
        ("test", &p.test, p.test_secs),
    ] {
        print_set(label, set, secs, &robot.kinematics);
    }
    println!("paper (G_MRT): 780 train / 600 test trajectories");
    if let Some(png) = &a.plot {
        plot(&cfg, &robot.kinematics, &p, png)?;
    }
    Ok(ExitCode::SUCCESS)
}

/// One augmented set (`label`, augmented in `secs`): kept and dropped per sub-group, the
/// time it took, the dropped conditions by reason.
fn print_set(
    label: &str,
    set: &crossym::data::augmentation::AugmentedSet,
    secs: f64,
    kin: &crossym::kinematics::Kinematics,
) {
    use crossym::data::augmentation::DropReason;
    use crossym::policy::SubGroup;
    for g in SubGroup::ALL {
        let dropped: Vec<_> = set.dropped.iter().filter(|d| g.contains(&d.1)).collect();
        println!(
            "{:<6} {:<9} {:>6} {:>8} {:>9} {:>8}",
            label,
            g.label(),
            set.subset(g).len(),
            dropped.len(),
            dropped
                .iter()
                .filter(|d| d.2 == DropReason::Singular)
                .count(),
            dropped
                .iter()
                .filter(|d| matches!(d.2, DropReason::JointLimits { .. }))
                .count(),
        );
    }
    println!(
        "{label}: G_MRT augmentation took {secs:.2} s on {} threads",
        rayon::current_num_threads()
    );
    // Dropped conditions, aggregated over demonstrations.
    let mut by_cond: std::collections::BTreeMap<(i64, i64, i8, String), usize> = Default::default();
    for (_, c, r) in &set.dropped {
        *by_cond
            .entry((
                (c.theta.to_degrees() * 1e3).round() as i64,
                (c.scale * 1e3).round() as i64,
                c.reflection,
                match r {
                    DropReason::JointLimits { joint } => {
                        format!("limits of {}", kin.joint_names()[*joint])
                    }
                    other => format!("{other:?}"),
                },
            ))
            .or_default() += 1;
    }
    if !by_cond.is_empty() {
        let list: Vec<String> = by_cond
            .iter()
            .map(|((t, l, s, r), n)| {
                format!("({}°, {}, {s}) {r} ×{n}", *t as f64 / 1e3, *l as f64 / 1e3)
            })
            .collect();
        println!("{label}: dropped (θ, λ, σ): {}", list.join("; "));
    }
}

/// `--plot`: the first training demonstration and its augmented copies, one panel per
/// sub-group.
fn plot(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    p: &crossym::pipeline::Pipeline,
    png: &Path,
) -> anyhow::Result<()> {
    use crossym::eval::plot::{write_paths_grid, PathFigure, PathPanel, XY_VIEW};
    use crossym::policy::SubGroup;
    let first = p.demos.train.first().copied();
    let original = first
        .and_then(|d| p.demos.demos.iter().find(|t| t.demo == d))
        .context("no training demonstration to plot")?;
    let panels: Vec<PathPanel> = (0..SubGroup::ALL.len())
        .map(|gi| {
            let (shown, label) =
                crossym::pipeline::figures::figure_conditions(&p.train, gi, first, 8);
            PathPanel {
                m: kin.task_dim(),
                arm_dim: kin.chains().first().map_or(2, |c| c.task.dim()),
                view: cfg.eval.view.unwrap_or(XY_VIEW),
                label,
                paths: shown
                    .iter()
                    .map(|a| (original.x.clone(), a.traj.x.clone()))
                    .collect(),
            }
        })
        .filter(|panel| !panel.paths.is_empty())
        .collect();
    let fig = PathFigure {
        nominal_name: "tracked demonstration".into(),
        executed_name: "augmented copy".into(),
        ..PathFigure::for_robot(
            format!(
                "Demonstration {} on {} and its augmented copies (FK of the lifted joint paths)",
                original.demo, kin.robot
            ),
            kin,
            &cfg.eval,
        )
    };
    crossym::pipeline::create_parent(png)?;
    write_paths_grid(png, &fig, &panels, panels.len(), 400).map_err(anyhow::Error::msg)?;
    println!("wrote {}", png.display());
    Ok(())
}
