//! Command-line interface: raw arguments → validated configuration → library calls.
//! `anyhow` is used here only, at the binary's edge.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use crossym::config::Config;

/// Cross-space symmetry compositions for robot policies.
#[derive(Debug, Parser)]
#[command(name = "crossym", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Load a robot config and print its chains, joints, limits and FK at a configuration.
    Info {
        /// Config file (TOML).
        #[arg(long, short)]
        config: PathBuf,
        /// Joint values (rad or m), comma-separated, in the robot's joint order; zeros by default.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        q: Option<Vec<f64>>,
    },
    /// Track the letters into joint space and augment them with the composed group;
    /// prints counts (train/test per sub-group), drops by reason and timing.
    Augment {
        /// Config file (TOML) with [letters], [augmentation], [[symmetries]], [composition].
        #[arg(long, short)]
        config: PathBuf,
    },
    /// Transfer and compose the configured symmetries and print the numerical checks.
    /// Exits 1 when a requested composition is impossible or a transfer fails.
    Check {
        /// Config file (TOML) with [[symmetries]] and [composition].
        #[arg(long, short)]
        config: PathBuf,
    },
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Info { config, q } => info(&config, q),
        Command::Check { config } => check(&config),
        Command::Augment { config } => augment(&config),
    }
}

fn info(path: &PathBuf, q: Option<Vec<f64>>) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(path)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let q = q.unwrap_or_else(|| vec![0.0; kin.dof()]);
    anyhow::ensure!(
        q.len() == kin.dof(),
        "--q has {} values, robot `{}` has {} controlled joints",
        q.len(),
        kin.robot,
        kin.dof()
    );
    println!("robot `{}` from {}", kin.robot, robot.model.origin);
    println!(
        "  dim Q = {}, dim X = {}, damping λ = {}",
        kin.dof(),
        kin.task_dim(),
        kin.pinv().damping()
    );
    let mut ws = kin.workspace();
    kin.jacobian(&q, &mut ws);
    let report = kin.factor(&mut ws);
    for (i, c) in kin.chains().iter().enumerate() {
        let tip = ws.chain(i).tip.translation.vector;
        println!(
            "  chain `{}`: {} → {} ({} joints, task {:?}), tip at q = [{:.4}, {:.4}, {:.4}]",
            c.name,
            c.base,
            c.tip,
            c.dof(),
            c.task,
            tip.x,
            tip.y,
            tip.z
        );
        for (name, l) in c.joint_names.iter().zip(&c.limits) {
            let acc = l.acceleration.map_or("-".to_string(), |a| format!("{a}"));
            println!(
                "    {name:<16} [{:>9.5}, {:>9.5}] vel {:>8.4} acc {acc}",
                l.lower, l.upper, l.velocity
            );
        }
    }
    println!(
        "  manipulability {:.6e} ({:?}), condition number {:.3}",
        report.manipulability,
        report.status,
        crossym::kinematics::condition_number(&ws.jac)
    );
    std::io::Write::flush(&mut std::io::stdout()).context("stdout")?;
    Ok(ExitCode::SUCCESS)
}

fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.1e}")
    }
}

fn check(path: &PathBuf) -> anyhow::Result<ExitCode> {
    use crossym::symmetry::compose::Composition;
    let cfg = Config::from_file(path)?;
    anyhow::ensure!(
        !cfg.symmetries.is_empty(),
        "{}: no [[symmetries]] to check",
        path.display()
    );
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let report =
        crossym::symmetry::check::check(kin, &cfg.symmetries, &cfg.composition.order, &cfg.check)
            .with_context(|| format!("checking {}", path.display()))?;
    println!(
        "robot `{}`: dim Q = {}, dim X = {}, metric {}, damping λ = {}, {} sampled configurations",
        report.robot,
        kin.dof(),
        kin.task_dim(),
        if cfg.kinematics.metric_diagonal.is_some() {
            "diagonal"
        } else {
            "identity"
        },
        kin.pinv().damping(),
        report.samples
    );
    println!();
    println!(
        "{:<6} {:<6} {:<4} {:<16} {:>12} {:>12} {:>10}  verdict",
        "symm", "group", "on", "transfer", "equivariance", "2π drift", "bracket⊥"
    );
    for r in &report.symmetries {
        println!(
            "{:<6} {:<6} {:<4} {:<16} {:>12} {:>12} {:>10}  {}",
            r.name,
            r.group,
            r.acts_on,
            r.transfer,
            sci(r.equivariance),
            r.periodicity_drift
                .map_or("-".into(), |d| format!("{d:.3} rad")),
            r.bracket_vertical.map_or("-".into(), sci),
            if r.ok { "ok" } else { "FAILED" }
        );
        for n in &r.notes {
            println!("{:>13}{n}", "");
        }
    }
    println!();
    println!(
        "{:<8} {:<5} {:<13} {:>12} {:>12}  details",
        "pair", "space", "composition", "residual", "lifted ⊥"
    );
    for p in &report.pairs {
        let (residual, details) = match &p.composition {
            Composition::Direct { residual } => (*residual, "actions commute".to_string()),
            Composition::SemiDirect {
                automorphism,
                residual,
                ..
            } => (
                *residual,
                format!(
                    "automorphism C = {:?}",
                    automorphism
                        .iter()
                        .map(|v| (v * 1e3).round() / 1e3)
                        .collect::<Vec<_>>()
                ),
            ),
            Composition::Incompatible {
                commutation,
                automorphism,
            } => (
                *commutation,
                format!("no automorphism (fit residual {})", sci(*automorphism)),
            ),
        };
        println!(
            "{:<8} {:<5} {:<13} {:>12} {:>12}  {}{}",
            format!("{}·{}", p.a, p.b),
            p.space,
            p.composition.kind(),
            sci(residual),
            p.lifted_vertical.map_or("-".into(), sci),
            details,
            if p.requested || cfg.composition.order.is_empty() {
                ""
            } else {
                " (not requested)"
            }
        );
    }
    println!();
    if !cfg.composition.order.is_empty() {
        match report.group_expression(&cfg.composition.order) {
            Some(g) => println!(
                "composed group: {g}   (order outer → inner: {}, eq. 23)",
                cfg.composition.order.join(", ")
            ),
            None => println!("composed group: none — a requested pair is incompatible"),
        }
    }
    if report.ok() {
        println!("verdict: ok");
        Ok(ExitCode::SUCCESS)
    } else {
        println!("verdict: FAILED (a transfer failed or a requested composition is impossible)");
        Ok(ExitCode::from(1))
    }
}

fn augment(path: &PathBuf) -> anyhow::Result<ExitCode> {
    use crossym::data::augmentation::{letter_group, Augmenter, DropReason, SubGroup};
    use crossym::symmetry::transfer::flow::FlowSettings;
    use crossym::symmetry::transfer::lift::LiftedAction;
    let cfg = Config::from_file(path)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let letters = cfg
        .letters
        .as_ref()
        .with_context(|| format!("{}: no [letters] section", path.display()))?;
    let aug = cfg
        .augmentation
        .as_ref()
        .with_context(|| format!("{}: no [augmentation] section", path.display()))?;
    aug.train
        .validate()
        .map_err(anyhow::Error::msg)
        .context("[augmentation] train")?;
    aug.test
        .validate()
        .map_err(anyhow::Error::msg)
        .context("[augmentation] test")?;
    let t0 = std::time::Instant::now();
    let demos = letters.build(kin, &cfg.base_dir)?;
    println!(
        "tracked {} demonstrations of {} samples in {:.2} s; max tracking error {:.3e} (task units)",
        demos.demos.len(),
        demos.demos.first().map_or(0, |d| d.len()),
        t0.elapsed().as_secs_f64(),
        demos.max_tracking_error
    );
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries)?;
    let (rho, rot, sc) =
        letter_group(&built, &cfg.composition.order).map_err(anyhow::Error::msg)?;
    let flow = FlowSettings {
        rtol: 1e-8,
        atol: 1e-10,
        ..Default::default()
    };
    let augmenter = Augmenter::new(
        kin,
        LiftedAction::new(kin, rot, flow).map_err(anyhow::Error::msg)?,
        LiftedAction::new(kin, sc, flow).map_err(anyhow::Error::msg)?,
        rho,
    )
    .map_err(anyhow::Error::msg)?;
    println!(
        "{:<6} {:<9} {:>6} {:>8} {:>9} {:>8}",
        "set", "group", "kept", "dropped", "singular", "limits"
    );
    for (label, grid, which) in [
        ("train", &aug.train, &demos.train),
        ("test", &aug.test, &demos.test),
    ] {
        let sel = demos.select(which);
        let bar = indicatif::ProgressBar::new((sel.len() * grid.scales.len()) as u64);
        bar.set_style(
            indicatif::ProgressStyle::with_template(
                "  {msg} [{bar:30}] {pos}/{len} (demo, scale) tasks {elapsed}",
            )
            .expect("static template")
            .progress_chars("=> "),
        );
        bar.set_message(format!("augmenting {label}"));
        let t = std::time::Instant::now();
        let set = augmenter.augment(&sel, grid, &|| bar.inc(1));
        bar.finish_and_clear();
        let secs = t.elapsed().as_secs_f64();
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
                    .filter(|d| d.2 == DropReason::JointLimits)
                    .count(),
            );
        }
        println!(
            "{label}: G_MRT augmentation took {secs:.2} s on {} threads",
            rayon::current_num_threads()
        );
    }
    println!("paper (G_MRT): 780 train / 600 test trajectories");
    Ok(ExitCode::SUCCESS)
}
