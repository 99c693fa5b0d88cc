//! Command-line interface: raw arguments → validated configuration → library calls.
//! `anyhow` is used here only, at the binary's edge.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::{Parser, Subcommand};
use crossym::config::Config;
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
    /// Track the letters into joint space and augment them with the composed group;
    /// prints counts (train/test per sub-group), drops by reason and timing.
    Augment {
        /// Config file (TOML) with [letters], [augmentation], [[symmetries]], [composition].
        #[arg(long, short)]
        config: PathBuf,
        /// Also draw the first training demonstration and its augmented copies, one panel
        /// per sub-group, into this PNG.
        #[arg(long)]
        plot: Option<PathBuf>,
    },
    /// Train a symmetry-conditioned policy on the letters augmented with a sub-group.
    Train {
        /// Config file (TOML) with [letters], [augmentation], [train].
        #[arg(long, short)]
        config: PathBuf,
        /// Sub-group used for augmentation: identity, R, RT or MRT.
        #[arg(long, default_value = "MRT")]
        group: String,
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
        /// Directory for `table2.md` and `table2.csv`.
        #[arg(long, default_value = "results")]
        out: PathBuf,
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
    },
    /// Transfer and compose the configured symmetries and print the numerical checks.
    /// Exits 1 when a requested composition is impossible or a transfer fails.
    Check {
        /// Config file (TOML) with [[symmetries]] and [composition].
        #[arg(long, short)]
        config: PathBuf,
    },
}

#[derive(Debug, Subcommand)]
enum BagCommand {
    /// Topics, types, counts and duration (like `ros2 bag info`).
    Info {
        /// Bag directory or .mcap file.
        bag: PathBuf,
    },
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
        } => ros::mock_hw(&config, summary.as_deref(), initial_q, command.as_deref()),
        Command::Augment { config, plot } => augment(&config, plot.as_deref()),
        Command::Train {
            config,
            group,
            out,
            iterations,
        } => train(&config, &group, &out, iterations),
        Command::Eval {
            config,
            policies,
            out,
        } => eval(&config, &policies, &out),
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

/// Letters tracked into joint space and both splits augmented with the full grid.
struct Pipeline {
    demos: crossym::data::letters::LetterDemos,
    train: crossym::data::augmentation::AugmentedSet,
    test: crossym::data::augmentation::AugmentedSet,
    /// The training demonstrations under the test grid (Table II's no-learning reference).
    reference: crossym::data::augmentation::AugmentedSet,
    train_secs: f64,
    test_secs: f64,
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

/// Which augmented sets [`pipeline`] builds (the others stay empty).
#[derive(Debug, Clone, Copy)]
struct Splits {
    train: bool,
    test: bool,
    /// The training demonstrations augmented with the test grid.
    reference: bool,
}

/// The tracked demonstrations of `[letters]` (an error naming the file when it is absent).
fn letter_demos(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
) -> anyhow::Result<crossym::data::letters::LetterDemos> {
    let letters = cfg
        .letters
        .as_ref()
        .with_context(|| format!("{}: no [letters] section", cfg.path.display()))?;
    Ok(letters.build(kin, &cfg.base_dir)?)
}

/// The canonical task-space features `[train] task_features` asks for (`None` without),
/// restricted to the sub-group `group` the policy is trained on.
pub(crate) fn task_features_for(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    built: &[crossym::symmetry::check::BuiltSymmetry],
    tc: &crossym::policy::TrainConfig,
    group: crossym::data::augmentation::SubGroup,
) -> anyhow::Result<Option<crossym::policy::TaskFeatures>> {
    if !tc.task_features {
        return Ok(None);
    }
    let mut f = crossym::policy::TaskFeatures::for_robot(kin, built, &cfg.composition.order)
        .map_err(|e| anyhow::anyhow!("{}: [train] task_features: {e}", cfg.path.display()))?;
    f.restrict_to(group);
    Ok(Some(f))
}

/// Loads a policy and checks that it drives `kin`'s joints, in the same order.
fn load_policy_for(
    kin: &crossym::kinematics::Kinematics,
    file: &std::path::Path,
) -> anyhow::Result<crossym::policy::Policy> {
    let policy = crossym::policy::Policy::load(file)?;
    anyhow::ensure!(
        policy.meta.joint_names == kin.joint_names(),
        "{}: policy joints {:?} differ from the robot's {:?}",
        file.display(),
        policy.meta.joint_names,
        kin.joint_names()
    );
    if let Some(t) = policy.task_features() {
        t.check_kinematics(kin)
            .map_err(|e| anyhow::anyhow!("{}: {e}", file.display()))?;
    }
    Ok(policy)
}

/// Demonstration `which` (1-based) of `demos`, by default the first of `[letters] test`.
fn pick_demo(
    demos: &crossym::data::letters::LetterDemos,
    which: Option<usize>,
) -> anyhow::Result<&crossym::data::letters::JointTrajectory> {
    let which = which
        .or_else(|| demos.test.first().copied())
        .context("no demonstration given and no [letters] test demonstration")?;
    demos
        .demos
        .iter()
        .find(|d| d.demo == which)
        .with_context(|| {
            format!(
                "no demonstration {which} (have {:?})",
                demos.demos.iter().map(|d| d.demo).collect::<Vec<_>>()
            )
        })
}

fn pipeline(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    splits: Splits,
) -> anyhow::Result<Pipeline> {
    use crossym::data::augmentation::{letter_augmenter, AugmentedSet};
    let aug = cfg
        .augmentation
        .as_ref()
        .with_context(|| format!("{}: no [augmentation] section", cfg.path.display()))?;
    aug.train
        .validate()
        .map_err(anyhow::Error::msg)
        .context("[augmentation] train")?;
    aug.test
        .validate()
        .map_err(anyhow::Error::msg)
        .context("[augmentation] test")?;
    let demos = letter_demos(cfg, kin)?;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries)?;
    let augmenter =
        letter_augmenter(kin, &built, &cfg.composition.order).map_err(anyhow::Error::msg)?;
    for (label, grid) in [("train", &aug.train), ("test", &aug.test)] {
        augmenter
            .supports(grid)
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("[augmentation] {label}"))?;
    }
    let run = |label: &str, grid: &crossym::data::augmentation::GroupGrid, which: &[usize]| {
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
        (set, t.elapsed().as_secs_f64())
    };
    let (train, train_secs) = if splits.train {
        run("train", &aug.train, &demos.train)
    } else {
        (AugmentedSet::default(), 0.0)
    };
    let (test, test_secs) = if splits.test {
        run("test", &aug.test, &demos.test)
    } else {
        (AugmentedSet::default(), 0.0)
    };
    let reference = if splits.reference {
        run("reference", &aug.test, &demos.train).0
    } else {
        AugmentedSet::default()
    };
    Ok(Pipeline {
        demos,
        train,
        test,
        reference,
        train_secs,
        test_secs,
    })
}

/// A file's name for a figure title (the whole path when it has none).
fn file_name(p: &std::path::Path) -> String {
    p.file_name().map_or_else(
        || p.display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    )
}

/// Up to `max` augmented trajectories of demonstration `demo` that sub-group
/// `SubGroup::ALL[gi]` adds to the previous one (rotations, then scalings, then the
/// reflection; all of it for the first), evenly strided, and a caption naming the set and
/// the ranges of `θ` and `λ` shown.
fn figure_conditions(
    set: &crossym::data::augmentation::AugmentedSet,
    gi: usize,
    demo: Option<usize>,
    max: usize,
) -> (Vec<&crossym::data::augmentation::Augmented>, String) {
    use crossym::data::augmentation::SubGroup;
    let g = SubGroup::ALL[gi];
    let all: Vec<_> = set
        .subset(g)
        .into_iter()
        .filter(|a| Some(a.traj.demo) == demo)
        .collect();
    let new: Vec<_> = match gi.checked_sub(1) {
        Some(prev) => all
            .iter()
            .copied()
            .filter(|a| !SubGroup::ALL[prev].contains(&a.condition))
            .collect(),
        None => all.clone(),
    };
    let sel = if new.is_empty() { all } else { new };
    let stride = sel.len().div_ceil(max.max(1)).max(1);
    let shown: Vec<_> = sel.into_iter().step_by(stride).collect();
    let range = |f: &dyn Fn(&Condition) -> f64, unit: &str| {
        let (lo, hi) = shown
            .iter()
            .map(|a| f(&a.condition))
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
        let r = crossym::eval::plot::signed;
        if hi - lo < 1e-9 {
            format!("{}{unit}", r(lo))
        } else {
            format!("{}…{}{unit}", r(lo), r(hi))
        }
    };
    let mut label = format!(
        "{}: {} condition{}, θ {}, λ {}",
        g.label(),
        shown.len(),
        if shown.len() == 1 { "" } else { "s" },
        range(&|c| c.theta.to_degrees(), "°"),
        range(&|c| c.scale, "")
    );
    if shown.iter().any(|a| a.condition.reflection < 0) {
        label.push_str(", σ = −1");
    }
    (shown, label)
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
        "tracked {} demonstrations of {} samples; max tracking error {:.3e} (task units)",
        p.demos.demos.len(),
        p.demos.demos.first().map_or(0, |d| d.len()),
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
                let (shown, label) = figure_conditions(&p.train, gi, first, 8);
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
        if let Some(dir) = png.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        }
        write_paths_grid(png, &fig, &panels, panels.len(), 400).map_err(anyhow::Error::msg)?;
        println!("wrote {}", png.display());
    }
    Ok(ExitCode::SUCCESS)
}

fn train(
    path: &PathBuf,
    group: &str,
    out: &PathBuf,
    iterations: Option<usize>,
) -> anyhow::Result<ExitCode> {
    use crossym::data::augmentation::SubGroup;
    let cfg = Config::from_file(path)?;
    let g = SubGroup::parse(group)
        .with_context(|| format!("--group `{group}`: expected identity, R, RT or MRT"))?;
    let mut tc = cfg
        .train
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
            train: true,
            test: false,
            reference: false,
        },
    )?;
    let data: Vec<_> = p
        .train
        .subset(g)
        .into_iter()
        .map(|a| (&a.traj, a.condition))
        .collect();
    println!(
        "training on {} trajectories of {} ({} iterations)",
        data.len(),
        g.label(),
        tc.iterations
    );
    let symmetry = serde_json::json!({
        "group": g.label(),
        "order": cfg.composition.order,
        "grid": cfg.augmentation.as_ref().map(|a| serde_json::to_value(&a.train).unwrap_or_default()),
    });
    let meta = crossym::policy::PolicyMeta::new(&kin.robot, kin.joint_names().to_vec(), symmetry);
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries)?;
    let features = task_features_for(&cfg, kin, &built, &tc, g)?;
    let bar = indicatif::ProgressBar::new(tc.iterations as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  [{bar:30}] {pos}/{len} it, loss {msg} {elapsed}/{duration}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    // The loss log: every logged iteration to CSV, a tenth of the run to stdout.
    let mut log = String::from("iteration,loss,learning_rate\n");
    let tenth = tc.iterations.div_ceil(10).max(1);
    let mut next_line = tenth;
    let (policy, report) =
        crossym::policy::train_with_features(&data, &tc, meta, features, |it, loss| {
            let lr = tc.lr_schedule.at(tc.learning_rate, it - 1, tc.iterations);
            log.push_str(&format!("{it},{loss:e},{lr:e}\n"));
            bar.set_position(it as u64);
            bar.set_message(format!("{loss:.4e}"));
            if it >= next_line || it == tc.iterations {
                bar.suspend(|| {
                    println!(
                        "  iteration {it}/{}: loss {loss:.4e}, lr {lr:.2e}",
                        tc.iterations
                    )
                });
                next_line = it + tenth;
            }
        })?;
    bar.finish_and_clear();
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    policy.save(out)?;
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

fn eval(path: &PathBuf, policies: &[String], out: &PathBuf) -> anyhow::Result<ExitCode> {
    use crossym::data::augmentation::SubGroup;
    use crossym::eval::plot::{write_paths_grid, PathFigure, PathPanel, XY_VIEW};
    use std::fmt::Write as _;
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
    let mut loaded = Vec::new();
    for (label, file) in specs {
        loaded.push((label, load_policy_for(kin, &file)?));
    }
    let p = pipeline(
        &cfg,
        kin,
        Splits {
            train: false,
            test: true,
            reference: true,
        },
    )?;
    let aug = cfg.augmentation.as_ref().expect("checked by pipeline");
    let m = kin.task_dim();
    let header = "| Policy | Original | G_R | G_RT | G_MRT |\n|---|---|---|---|---|\n";
    // Per-coordinate rows (primary) and Euclidean rows, filled side by side.
    let (mut md, mut md_euclid) = (String::from(header), String::from(header));
    let mut csv = String::from(
        "policy,test_set,mean_rmse,std_rmse,count,diverged,mean_rmse_per_coordinate,std_rmse_per_coordinate\n",
    );
    let cell_text = |c: &crossym::eval::Cell| {
        format!(
            " {:.3} ± {:.3}{} |",
            c.mean,
            c.std,
            if c.diverged > 0 {
                format!(" ({} div.)", c.diverged)
            } else {
                String::new()
            }
        )
    };
    let chain_cols: Vec<String> = kin
        .chains()
        .iter()
        .map(|c| format!("mean_rmse_{}", c.name))
        .collect();
    let mut per_cond = format!(
        "policy,theta_deg,scale,reflection,mean_rmse,std_rmse,count,diverged,{}\n",
        chain_cols.join(",")
    );
    let arm_dim = kin.chains().first().map_or(2, |c| c.task.dim());
    let view = cfg.eval.view.unwrap_or(XY_VIEW);
    let first_demo = p.demos.test.first().copied();
    // One table row per scorer: a policy, or a reference built from the training demos.
    let mut add_row = |label: &str, cells: &[Option<crossym::eval::Cell>]| {
        let (mut row, mut row_e) = (format!("| {label} |"), format!("| {label} |"));
        for (g, c) in SubGroup::ALL.iter().zip(cells) {
            let Some(c) = c.filter(|c| c.count > 0) else {
                row.push_str(" – |");
                row_e.push_str(" – |");
                let _ = writeln!(csv, "{label},{},,,0,0,,", g.label());
                continue;
            };
            let pc = c.per_coordinate(m);
            row.push_str(&cell_text(&pc));
            row_e.push_str(&cell_text(&c));
            let _ = writeln!(
                csv,
                "{label},{},{},{},{},{},{},{}",
                g.label(),
                c.mean,
                c.std,
                c.count,
                c.diverged,
                pc.mean,
                pc.std
            );
        }
        println!("{row}");
        for (table, r) in [(&mut md, row), (&mut md_euclid, row_e)] {
            table.push_str(&r);
            table.push('\n');
        }
    };
    // Each test trajectory rolled out once per policy: its score and per-arm RMSE, from
    // which the sub-group cells and the per-condition rows are aggregated.
    let scored: Vec<Vec<(crossym::eval::RolloutScore, Vec<f64>)>> = loaded
        .iter()
        .map(|(_, policy)| {
            use rayon::prelude::*;
            p.test
                .trajectories
                .par_iter()
                .map(|a| {
                    let path = crossym::eval::rollout_path(policy, kin, &a.traj, &a.condition);
                    (
                        crossym::eval::score_path(&a.traj, &path, &cfg.eval),
                        crossym::eval::chain_rmse(kin, &a.traj, &path),
                    )
                })
                .collect()
        })
        .collect();
    let cell_where = |pi: usize, keep: &dyn Fn(&crossym::symmetry::compose::Condition) -> bool| {
        let scores: Vec<_> = p
            .test
            .trajectories
            .iter()
            .zip(&scored[pi])
            .filter(|(a, _)| keep(&a.condition))
            .map(|(_, (sc, _))| *sc)
            .collect();
        crossym::eval::Cell::from_scores(&scores)
    };
    for (pi, (label, _)) in loaded.iter().enumerate() {
        let cells: Vec<_> = SubGroup::ALL
            .iter()
            .map(|g| Some(cell_where(pi, &|c| g.contains(c))))
            .collect();
        add_row(label, &cells);
    }
    // References: each test trajectory against the training demos under its condition.
    let mut nearest = Vec::new();
    let mut mean = Vec::new();
    for g in SubGroup::ALL {
        let (mut sn, mut sm) = (Vec::new(), Vec::new());
        for t in p.test.subset(g) {
            let refs: Vec<_> = p
                .reference
                .trajectories
                .iter()
                .filter(|r| r.condition == t.condition)
                .map(|r| &r.traj)
                .collect();
            if let Some((n, a)) = crossym::eval::demo_reference(&t.traj, &refs) {
                let score = |rmse| crossym::eval::RolloutScore {
                    rmse,
                    diverged: false,
                };
                sn.push(score(n));
                sm.push(score(a));
            }
        }
        nearest.push(Some(crossym::eval::Cell::from_scores(&sn)));
        mean.push(Some(crossym::eval::Cell::from_scores(&sm)));
    }
    add_row("reference: nearest training demo", &nearest);
    add_row("reference: mean of training demos", &mean);
    for (pi, (label, policy)) in loaded.iter().enumerate() {
        // Per condition (over the test demonstrations).
        for cond in aug.test.conditions() {
            let c = cell_where(pi, &|c| *c == cond);
            if c.count == 0 {
                continue;
            }
            // Per-arm RMSE, mean over the condition's test trajectories.
            let mut arms = vec![0.0; kin.chains().len()];
            for (_, (_, per_arm)) in p
                .test
                .trajectories
                .iter()
                .zip(&scored[pi])
                .filter(|(a, _)| a.condition == cond)
            {
                for (a, r) in arms.iter_mut().zip(per_arm) {
                    *a += r / c.count as f64;
                }
            }
            let arms: Vec<String> = arms.iter().map(|a| a.to_string()).collect();
            let _ = writeln!(
                per_cond,
                "{label},{},{},{},{},{},{},{},{}",
                cond.theta.to_degrees(),
                cond.scale,
                cond.reflection,
                c.mean,
                c.std,
                c.count,
                c.diverged,
                arms.join(",")
            );
        }
        // Figure: one panel per test set, up to 6 conditions on the first test demo, taken
        // from what the set adds to the previous one (rotations, then scalings, then the
        // reflection).
        let panels: Vec<PathPanel> = SubGroup::ALL
            .iter()
            .enumerate()
            .map(|(gi, _)| {
                let (shown, label) = figure_conditions(&p.test, gi, first_demo, 6);
                PathPanel {
                    m: kin.task_dim(),
                    arm_dim,
                    view,
                    label,
                    paths: shown
                        .iter()
                        .map(|a| {
                            let exe =
                                crossym::eval::rollout_path(policy, kin, &a.traj, &a.condition);
                            (a.traj.x.clone(), exe)
                        })
                        .collect(),
                }
            })
            .filter(|panel| !panel.paths.is_empty())
            .collect();
        if !panels.is_empty() {
            std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
            let png = out.join(format!("trajectories_{label}.png"));
            let fig = PathFigure {
                executed_name: format!("rollout of {label}"),
                nominal_name: "nominal (test demonstration under the condition)".into(),
                ..PathFigure::for_robot(
                    format!(
                        "Table II test sets: {label} on {}, test demonstration {}",
                        kin.robot,
                        first_demo.map_or_else(|| "–".into(), |d| d.to_string())
                    ),
                    kin,
                    &cfg.eval,
                )
            };
            write_paths_grid(&png, &fig, &panels, panels.len(), 400).map_err(anyhow::Error::msg)?;
        }
    }
    let _ = write!(
        md,
        "\nRMSE per coordinate (task units) between the policy rollout and the nominal \
         trajectory from the same initial configuration, `√(mean over samples and the {m} \
         task coordinates of the squared error)`, mean ± std over the test trajectories \
         (diverged rollouts included and counted). The reference rows involve no policy: \
         each test trajectory against the training demonstrations transformed by the same \
         condition (the nearest one; their sample-wise mean).\n\n\
         The same in the Euclidean convention, `√(mean over samples of ‖x̂ − x‖²)` with all \
         arms stacked (= per coordinate × √{m}):\n\n{md_euclid}\n\
         Figures `trajectories_<policy>.png`: one \
         panel per test set (Original, G_R, G_RT, G_MRT), up to 6 of the conditions it adds \
         to the previous set (rotations, scalings, reflection) on the first test \
         demonstration; grey nominal, colour rollout (blue left arm, red right).\n",
    );
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))?;
    std::fs::write(out.join("table2.md"), &md)?;
    std::fs::write(out.join("table2.csv"), &csv)?;
    std::fs::write(out.join("conditions.csv"), &per_cond)?;
    println!(
        "wrote {}, {}, {} and trajectories_*.png",
        out.join("table2.md").display(),
        out.join("table2.csv").display(),
        out.join("conditions.csv").display()
    );
    Ok(ExitCode::SUCCESS)
}
