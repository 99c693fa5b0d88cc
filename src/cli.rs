//! Command-line interface: raw arguments → validated configuration → library calls.
//! `anyhow` is used here only, at the binary's edge.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use crossym::config::Config;
use crossym::eval::AnyPolicy;
use crossym::pipeline::Splits;
use crossym::symmetry::compose::Condition;

mod demo;
mod demos;
mod density;
mod ping;
mod rollout;
mod ros;
mod status;
mod stress;
mod symmetries;

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
    /// Load the demonstrations ([demonstrations]) and augment them with the composed group;
    /// prints counts (train/test per sub-group), drops by reason and timing.
    Augment {
        /// Config file (TOML) with [demonstrations], [augmentation], [[symmetries]], [composition].
        #[arg(long, short)]
        config: PathBuf,
        /// Also draw the first training demonstration and its augmented copies, one panel
        /// per sub-group, into this PNG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Train a symmetry-conditioned policy on the demonstrations augmented with a sub-group.
    Train {
        /// Config file (TOML) with [demonstrations], [augmentation], [train].
        #[arg(long, short)]
        config: PathBuf,
        /// Sub-group used for augmentation: identity, R, RT or MRT (default MRT).
        #[arg(long)]
        group: Option<String>,
        /// Train `π₀` on the original demonstrations only and save it canonicalised by
        /// the config's composition: exactly equivariant, any feasible condition (the
        /// sidecar records the composition; every command loads it like any policy).
        #[arg(long, conflicts_with = "group")]
        equivariant: bool,
        /// Train a task-space head `h` on the original demonstrations' task paths and save
        /// it canonicalised by `--group`'s action on X and lifted to Q by the horizontal
        /// lift: `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`, exactly equivariant in X under the
        /// group (the sidecar records the action; every command loads it like any policy).
        #[arg(long, conflicts_with = "equivariant")]
        task_head: bool,
        /// Output weights (`.safetensors`; a `.json` sidecar and the loss log `.loss.csv`
        /// are written beside it).
        #[arg(long)]
        out: PathBuf,
        /// Override `[train] iterations`.
        #[arg(long)]
        iterations: Option<usize>,
    },
    /// Evaluate policies on the test sets of every sub-group (Table II): task-space RMSE.
    Eval {
        /// Config file (TOML).
        #[arg(long, short)]
        config: PathBuf,
        /// `label=path.safetensors`, repeatable (e.g. `pi_MRT=policies/pi_mrt.safetensors`).
        /// Without it, `[eval] policies` of the config.
        #[arg(long = "policy")]
        policies: Vec<String>,
        /// Directory for `table2.md` and `table2.csv` (`table2_paper.*` with `--protocol
        /// paper`), and `fit.md` / `fit.csv` (held-out protocol: every training and test
        /// demonstration rolled out from its own start, identity condition).
        #[arg(long, default_value = "results")]
        out: PathBuf,
        /// `heldout`: the test demonstrations under the test grid, whole trajectories
        /// (ours, stricter); `paper`: the authors' evaluation code (`[eval] paper_protocol`:
        /// training and test pooled with warm-up and common horizon, or resampled for the
        /// real-robot tasks).
        #[arg(long, value_enum, default_value_t = Protocol::Heldout)]
        protocol: Protocol,
        /// Evaluate the policy of this label canonicalised (repeatable): `π(q, s) =
        /// dΦ_g π₀(Φ_g⁻¹ q)` with `π₀` the policy at the identity condition and `Φ_g` the
        /// composed lifted action of `[composition]` — exactly equivariant for any
        /// feasible condition.
        #[arg(long = "canonicalise")]
        canonicalise: Vec<String>,
    },
    /// The main job: mock hardware + node (in a private network namespace), symmetry
    /// conditions published as a user would, a per-condition table and a PNG of the letters.
    /// Exits 1 if a check failed (limit violation, RMSE ratio, node error).
    Demo(demo::DemoArgs),
    /// Integrate a policy open loop from a start state (a demonstration transformed by the
    /// condition, or --q) and write the states to CSV; scored against the demonstration.
    /// Exits 1 when the rollout turned non-finite.
    Rollout(rollout::RolloutArgs),
    /// Fault campaign: randomized closed-loop episodes of the node core and a simulated
    /// robot (input faults, latency, adversarial policies, tight limits); a table of limit
    /// violations. Exits 1 on any violation or non-finite command.
    Stress(stress::StressArgs),
    /// A live one-line view of a running node's ~/status (code, condition, joint-state age,
    /// tick time, counters, last error). Exits 1 when no node answers within --timeout-s.
    Status(status::StatusArgs),
    /// Round trip joint state → command of a running node, from this process: median, p99,
    /// p99.9, max and lost probes (run the node with --trigger joint_states).
    Ping(ping::PingArgs),
    /// Morphological symmetry group of a robot from its URDF: every reflection plane through
    /// the base that maps the kinematic tree onto itself, the group they generate (C2, K4,
    /// …), each element's signed joint permutation; written as TOML and MorphoSymm YAML.
    Symmetries(symmetries::SymmetriesArgs),
    /// The augmentation-density experiment: π_R trained per rotation step Δθ, RMSE against
    /// the test rotation θ (CSV, Markdown and a PNG of the curves).
    Density(density::DensityArgs),
    /// Recorded demonstrations of [demonstrations] (rosbag2 bags, MCAP or SQLite3): read by
    /// joint name, resampled, differentiated, idle trimmed; a report per source and figures.
    /// Exits 1 when a source was refused.
    Demos(demos::DemosArgs),
    /// Run the ROS 2 node: joint states + symmetry condition → policy → safety QP → command.
    /// Honours ROS_DOMAIN_ID, ROS_LOCALHOST_ONLY, ROS_AUTOMATIC_DISCOVERY_RANGE.
    Node {
        /// Config file (TOML) with [robot] and [node].
        #[arg(long, short)]
        config: PathBuf,
        #[command(flatten)]
        overrides: ros::NodeOverrides,
        /// Record joint states, conditions, commands and status to this new rosbag2 (MCAP)
        /// directory.
        #[arg(long)]
        record: Option<PathBuf>,
    },
    /// Record topics over DDS into a new rosbag2 MCAP bag until Ctrl-C (the node's own
    /// `--record` also stores what offline replay needs; this recorder does not).
    Record {
        /// Output bag directory (must not exist).
        #[arg(long, short)]
        out: PathBuf,
        /// Record the four topics of the node configured here.
        #[arg(long, short)]
        config: Option<PathBuf>,
        /// Extra topic `NAME:pkg/msg/Type`, repeatable.
        #[arg(long = "topic")]
        topics: Vec<String>,
        /// Stop after this many seconds.
        #[arg(long)]
        duration_s: Option<f64>,
    },
    /// Inspect a rosbag2 MCAP bag.
    Bag {
        #[command(subcommand)]
        what: BagCommand,
    },
    /// Replay a recorded bag offline through the node's logic and compare the commands.
    /// Exits 1 when a command deviates beyond the tolerance.
    Replay {
        /// Bag directory or .mcap file.
        bag: PathBuf,
        /// Config file (TOML) the node ran with.
        #[arg(long, short)]
        config: PathBuf,
        #[command(flatten)]
        overrides: ros::NodeOverrides,
        /// Largest accepted |recorded − recomputed| (rad/s or rad).
        #[arg(long, default_value_t = 1e-9)]
        tolerance: f64,
        /// Instead: publish the recorded joint states and conditions over DDS at the
        /// recorded rate (like `ros2 bag play`), for a node or driver under test.
        #[arg(long)]
        live: bool,
        /// Playback rate factor (with --live).
        #[arg(long, default_value_t = 1.0)]
        rate: f64,
        /// Keep the recorded header stamps (with --live; by default they are set to the
        /// publish time, as a node checking stamps needs).
        #[arg(long)]
        keep_stamps: bool,
        /// Wait this long for discovery before the first message (s, with --live).
        #[arg(long, default_value_t = 1.0)]
        delay_s: f64,
    },
    /// Run the mock hardware: integrate commands, publish /joint_states, log limit violations.
    /// Exits 1 when it saw a limit violation.
    MockHw {
        /// Config file (TOML) with [robot], [node] and optionally [mock_hw].
        #[arg(long, short)]
        config: PathBuf,
        /// Write the run's summary (JSON) here on exit.
        #[arg(long)]
        summary: Option<PathBuf>,
        /// Initial positions of the controlled joints (rad), comma-separated.
        #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
        initial_q: Option<Vec<f64>>,
        /// How commands are interpreted (velocity, position, trajectory); default: [mock_hw]
        /// command, else the node's output.
        #[arg(long)]
        command: Option<String>,
        /// The robot: `kinematic` (commands executed exactly) or `mujoco` (the physics RB-Y1
        /// of `[mock_hw.mujoco]`, `physics/rby1_mujoco.py`); default: [mock_hw] plant.
        #[arg(long)]
        plant: Option<crossym::sim::physics::Plant>,
    },
    /// Transfer and compose the configured symmetries and print the numerical checks.
    /// Exits 1 when a requested composition is impossible or a transfer fails.
    Check {
        /// Config file (TOML) with [[symmetries]] and [composition].
        #[arg(long, short)]
        config: PathBuf,
    },
}

/// Evaluation protocol of `crossym eval`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Protocol {
    /// Held-out test trajectories, whole length (`table2.*`).
    Heldout,
    /// The authors' evaluation code (`table2_paper.*`).
    Paper,
}

#[derive(Debug, Subcommand)]
enum BagCommand {
    /// Topics, types, counts and duration (like `ros2 bag info`).
    Info {
        /// Bag directory or .mcap file.
        bag: PathBuf,
    },
}

impl Cli {
    /// One-shot commands whose output may be piped into `head`; the long-running node
    /// and mock hardware handle their own shutdown (a final command) and keep the default.
    pub fn ends_quietly_on_closed_pipe(&self) -> bool {
        !matches!(
            self.command,
            Command::Node { .. } | Command::MockHw { .. } | Command::Demo(_)
        )
    }
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Info { config, q } => info(&config, q),
        Command::Check { config } => check(&config),
        Command::Demo(a) => demo::demo(&a),
        Command::Density(a) => density::density(&a),
        Command::Demos(a) => demos::demos(&a),
        Command::Ping(a) => ping::ping(&a),
        Command::Rollout(a) => rollout::rollout_cmd(&a),
        Command::Stress(a) => stress::stress(&a),
        Command::Status(a) => status::status(&a),
        Command::Symmetries(a) => symmetries::symmetries(&a),
        Command::Node {
            config,
            overrides,
            record,
        } => ros::node(&config, &overrides, record.as_deref()),
        Command::Record {
            out,
            config,
            topics,
            duration_s,
        } => ros::record(&out, &topics, config.as_deref(), duration_s),
        Command::Bag {
            what: BagCommand::Info { bag },
        } => ros::bag_info(&bag),
        Command::Replay {
            bag,
            config,
            overrides,
            tolerance,
            live,
            rate,
            keep_stamps,
            delay_s,
        } => {
            if live {
                ros::replay_live(&bag, &config, rate, keep_stamps, delay_s)
            } else {
                ros::replay(&bag, &config, &overrides, tolerance)
            }
        }
        Command::MockHw {
            config,
            summary,
            initial_q,
            command,
            plant,
        } => ros::mock_hw(
            &config,
            summary.as_deref(),
            initial_q,
            command.as_deref(),
            plant,
        ),
        Command::Augment { config, plot } => augment(&config, plot.as_deref()),
        Command::Train {
            config,
            group,
            equivariant,
            task_head,
            out,
            iterations,
        } => train(
            &config,
            group.as_deref().unwrap_or("MRT"),
            TrainKind::from_flags(equivariant, task_head),
            &out,
            iterations,
        ),
        Command::Eval {
            config,
            policies,
            out,
            protocol,
            canonicalise,
        } => eval(&config, &policies, &out, protocol, &canonicalise),
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

/// Parses `theta_rad:scale:reflection` into a validated condition (and echoes the text as
/// its label).
pub(crate) fn parse_condition(s: &str) -> anyhow::Result<(String, Condition)> {
    let parts: Vec<&str> = s.split(':').collect();
    anyhow::ensure!(
        parts.len() == 3,
        "--condition `{s}`: expected theta_rad:scale:reflection"
    );
    let c = Condition {
        theta: parts[0]
            .parse()
            .with_context(|| format!("theta in `{s}`"))?,
        scale: parts[1]
            .parse()
            .with_context(|| format!("scale in `{s}`"))?,
        reflection: parts[2]
            .parse()
            .with_context(|| format!("reflection in `{s}`"))?,
    };
    c.validate()
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("--condition `{s}`"))?;
    Ok((s.to_string(), c))
}

/// The demonstrations of `[demonstrations]` (or a legacy `[letters]`).
fn letter_demos(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
) -> anyhow::Result<crossym::data::demonstrations::Demonstrations> {
    Ok(cfg.load_demonstrations(kin)?)
}

/// A progress bar for [`crossym::pipeline::build`]'s augmentation steps.
fn progress_bar() -> impl Fn(crossym::pipeline::Progress<'_>) + Sync {
    use crossym::pipeline::Progress;
    let bar = indicatif::ProgressBar::hidden();
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  {msg} [{bar:30}] {pos}/{len} (demo, scale) tasks {elapsed}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    move |p| match p {
        Progress::Start { label, tasks } => {
            bar.reset();
            bar.set_length(tasks as u64);
            bar.set_message(label.to_string());
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
        Progress::Tick => bar.inc(1),
        Progress::Done => bar.finish_and_clear(),
    }
}

/// [`crossym::pipeline::build`] with a progress bar.
fn pipeline(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    splits: Splits,
) -> anyhow::Result<crossym::pipeline::Pipeline> {
    Ok(crossym::pipeline::build(cfg, kin, splits, &progress_bar())?)
}

/// A file's name for a figure title (the whole path when it has none).
fn file_name(p: &std::path::Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    )
}

fn augment(path: &PathBuf, plot: Option<&std::path::Path>) -> anyhow::Result<ExitCode> {
    use crossym::data::augmentation::{DropReason, SubGroup};
    let cfg = Config::from_file(path)?;
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
        let mut by_cond: std::collections::BTreeMap<(i64, i64, i8, String), usize> =
            Default::default();
        for (_, c, r) in &set.dropped {
            *by_cond
                .entry((
                    (c.theta.to_degrees() * 1e3).round() as i64,
                    (c.scale * 1e3).round() as i64,
                    c.reflection,
                    match r {
                        DropReason::JointLimits { joint } => {
                            format!("limits of {}", robot.kinematics.joint_names()[*joint])
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
    println!("paper (G_MRT): 780 train / 600 test trajectories");
    if let Some(png) = plot {
        use crossym::eval::plot::{write_paths_grid, PathFigure, PathPanel, XY_VIEW};
        let kin = &robot.kinematics;
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
    }
    Ok(ExitCode::SUCCESS)
}

/// What `crossym train` trains.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum TrainKind {
    /// `π(q, s)` on the demonstrations augmented with the group.
    Augmented,
    /// `π₀` on the originals, canonicalised by the composition (`--equivariant`).
    Equivariant,
    /// A task-space head on the originals' task paths (`--task-head`).
    TaskHead,
}

impl TrainKind {
    fn from_flags(equivariant: bool, task_head: bool) -> Self {
        match (equivariant, task_head) {
            (true, _) => Self::Equivariant,
            (_, true) => Self::TaskHead,
            _ => Self::Augmented,
        }
    }
}

fn train(
    path: &PathBuf,
    group: &str,
    kind: TrainKind,
    out: &std::path::Path,
    iterations: Option<usize>,
) -> anyhow::Result<ExitCode> {
    use crossym::data::augmentation::SubGroup;
    let cfg = Config::from_file(path)?;
    // A task head may be written for several sub-groups at once (one network).
    let groups: Vec<SubGroup> = if kind == TrainKind::Equivariant {
        vec![SubGroup::Identity]
    } else {
        group
            .split(',')
            .map(|g| {
                SubGroup::parse(g.trim())
                    .with_context(|| format!("--group `{g}`: expected identity, R, RT or MRT"))
            })
            .collect::<anyhow::Result<_>>()?
    };
    anyhow::ensure!(
        groups.len() == 1
            || (kind == TrainKind::TaskHead && out.to_string_lossy().contains("{group}")),
        "--group with several sub-groups needs --task-head and `{{group}}` in --out"
    );
    let g = groups[0];
    let section = match kind {
        TrainKind::TaskHead if cfg.train_task_head.is_some() => &cfg.train_task_head,
        _ => &cfg.train,
    };
    let mut tc = section
        .clone()
        .with_context(|| format!("{}: no [train] section", path.display()))?;
    if let Some(it) = iterations {
        tc.iterations = it;
    }
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let p = pipeline(
        &cfg,
        kin,
        Splits {
            // A task head trains on the originals' task paths: no augmentation.
            train: kind != TrainKind::TaskHead,
            ..Splits::default()
        },
    )?;
    match kind {
        TrainKind::TaskHead => println!(
            "training a task-space head on the task paths of {} original demonstrations, \
             canonicalised by {} ({} iterations × {} ensemble member(s))",
            p.demos.train.len(),
            groups
                .iter()
                .map(|g| g.label())
                .collect::<Vec<_>>()
                .join(", "),
            tc.iterations,
            tc.ensemble
        ),
        _ => println!(
            "training {}on {} trajectories of {} ({} iterations)",
            if kind == TrainKind::Equivariant {
                "π₀ (canonicalised by the composition) "
            } else {
                ""
            },
            p.train.subset(g).len(),
            g.label(),
            tc.iterations
        ),
    }
    let total_iterations = tc.iterations * tc.ensemble;
    let bar = indicatif::ProgressBar::new(total_iterations as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  [{bar:30}] {pos}/{len} it, loss {msg} {elapsed}/{duration}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    // The loss log: every logged iteration to CSV, a tenth of the run to stdout.
    let mut log = String::from("iteration,loss,learning_rate\n");
    let tenth = total_iterations.div_ceil(10).max(1);
    let mut next_line = tenth;
    let on_iteration = |it: usize, loss: f64| {
        // Ensemble members report one after another: the schedule restarts per member.
        let lr = tc
            .lr_schedule
            .at(tc.learning_rate, (it - 1) % tc.iterations, tc.iterations);
        log.push_str(&format!("{it},{loss:e},{lr:e}\n"));
        bar.set_position(it as u64);
        bar.set_message(format!("{loss:.4e}"));
        if it >= next_line || it == total_iterations {
            bar.suspend(|| {
                println!("  iteration {it}/{total_iterations}: loss {loss:.4e}, lr {lr:.2e}")
            });
            next_line = it + tenth;
        }
    };
    let trained = match kind {
        TrainKind::Equivariant => {
            crossym::pipeline::train_equivariant(&cfg, kin, &p, &tc, on_iteration)?
        }
        TrainKind::TaskHead => {
            crossym::pipeline::train_task_head(&cfg, kin, &p, g, &tc, on_iteration)?
        }
        TrainKind::Augmented => crossym::pipeline::train(&cfg, kin, &p, g, &tc, on_iteration)?,
    };
    let (policy, report) = (trained.policy, trained.report);
    bar.finish_and_clear();
    let mut written = Vec::new();
    for &gk in &groups {
        let file = PathBuf::from(
            out.to_string_lossy()
                .replace("{group}", &gk.label().replace("G_", "").to_lowercase()),
        );
        let p = if gk == g {
            policy.clone()
        } else {
            crossym::pipeline::task_head_for(&cfg, kin, &policy, gk)?
        };
        crossym::pipeline::create_parent(&file)?;
        p.save(&file)?;
        written.push(file);
    }
    let out = &written[0];
    if written.len() > 1 {
        let names: Vec<String> = written.iter().map(|f| f.display().to_string()).collect();
        println!(
            "one task head, written for each sub-group: {}",
            names.join(", ")
        );
    }
    let log_path = out.with_extension("loss.csv");
    std::fs::write(&log_path, &log).with_context(|| format!("writing {}", log_path.display()))?;
    println!(
        "loss {:.4e} → {:.4e} in {} iterations, {:.1} s; saved {} (loss log {})",
        report.initial_loss,
        report.final_loss,
        report.iterations,
        report.seconds,
        out.display(),
        log_path.display()
    );
    Ok(ExitCode::SUCCESS)
}

fn eval(
    path: &PathBuf,
    policies: &[String],
    out: &std::path::Path,
    protocol: Protocol,
    canonicalise: &[String],
) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(path)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    // `--policy label=path` (relative to the working directory), else `[eval] policies`
    // (relative to the config file).
    let specs: Vec<(String, PathBuf)> = if policies.is_empty() {
        anyhow::ensure!(
            !cfg.eval.policies.is_empty(),
            "{}: no --policy given and no [eval] policies",
            path.display()
        );
        cfg.eval
            .policies
            .iter()
            .map(|(l, p)| (l.clone(), cfg.base_dir.join(p)))
            .collect()
    } else {
        policies
            .iter()
            .map(|spec| {
                spec.split_once('=')
                    .map(|(l, p)| (l.to_string(), PathBuf::from(p)))
                    .with_context(|| format!("--policy `{spec}`: expected label=path"))
            })
            .collect::<anyhow::Result<_>>()?
    };
    if let Some(l) = canonicalise
        .iter()
        .find(|l| !specs.iter().any(|(label, _)| label == *l))
    {
        anyhow::bail!("--canonicalise {l}: no policy labelled `{l}`");
    }
    let mut loaded = Vec::new();
    for (label, file) in specs {
        let policy = crossym::pipeline::load_any_policy(&cfg, kin, &file)?;
        let policy = match policy {
            AnyPolicy::Plain(p) if canonicalise.contains(&label) => {
                crossym::pipeline::canonicalise(&cfg, kin, *p)
                    .with_context(|| format!("--canonicalise {label}"))?
            }
            other => other,
        };
        loaded.push((label, policy));
    }
    if protocol == Protocol::Paper {
        let p = pipeline(&cfg, kin, crossym::pipeline::paper::splits(&cfg))?;
        let files = crossym::pipeline::paper::table2_paper(&cfg, kin, &loaded, &p, out, |row| {
            println!("{row}")
        })?;
        println!(
            "wrote {} and {}",
            files.markdown.display(),
            files.csv.display()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let p = pipeline(
        &cfg,
        kin,
        Splits {
            test: true,
            reference: true,
            ..Splits::default()
        },
    )?;
    let files =
        crossym::pipeline::table2::table2(&cfg, kin, &loaded, &p, out, |row| println!("{row}"))?;
    println!(
        "wrote {}, {}, {} and {} figure(s) (trajectories_*.png)",
        files.markdown.display(),
        files.csv.display(),
        files.conditions.display(),
        files.figures.len()
    );
    println!("\nFit to the demonstrations (identity condition, RMSE per coordinate):");
    let fit = crossym::pipeline::fit::write_fit(&cfg, kin, &p.demos, &loaded, out, |row| {
        println!("{row}")
    })?;
    println!("wrote {} and {}", fit.markdown.display(), fit.csv.display());
    Ok(ExitCode::SUCCESS)
}
