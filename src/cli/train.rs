//! `crossym train`: a symmetry-conditioned policy trained on the demonstrations augmented
//! with a sub-group, canonicalised (`--equivariant`) or as a task-space head
//! (`--task-head`); the weights, their sidecar and the loss log written.
// Without the `teach` feature only the options remain (`run` says how to get the command).
#![cfg_attr(not(feature = "teach"), allow(dead_code, unused_imports))]

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::ValueEnum;
use crossym::config::Config;
use crossym::pipeline::Splits;
use crossym::policy::SubGroup;

use super::common::{pipeline, Trimmed};

/// Options of `crossym train`.
#[derive(Debug, clap::Args)]
pub struct TrainArgs {
    /// Config file (TOML) with [demonstrations], [augmentation], [train].
    #[arg(long, short)]
    pub config: PathBuf,
    /// Sub-group of the config's composition to train for: identity, R, RT or MRT (the
    /// whole composition, whatever the config composes: M ⋊ R for a config without
    /// scaling; default MRT). With --task-head, a comma list (e.g. identity,R,RT,MRT)
    /// writes one file per sub-group from one training; --out then contains `{group}`,
    /// replaced by original, r, rt or mrt.
    #[arg(
        long,
        value_delimiter = ',',
        action = clap::ArgAction::Set,
        ignore_case = true,
        value_parser = Trimmed::<GroupArg>::new()
    )]
    pub group: Option<Vec<GroupArg>>,
    /// Train `π₀` on the original demonstrations only and save it canonicalised by
    /// the config's composition: exactly equivariant, any feasible condition (the
    /// sidecar records the composition; every command loads it like any policy).
    #[arg(long, conflicts_with = "group")]
    pub equivariant: bool,
    /// Train a task-space head `h` on the original demonstrations' task paths and save
    /// it canonicalised by `--group`'s action on X and lifted to Q by the horizontal
    /// lift: `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`, exactly equivariant in X under the
    /// group (the sidecar records the action; every command loads it like any policy).
    #[arg(long, conflicts_with = "equivariant")]
    pub task_head: bool,
    /// Output weights (`.safetensors`; a `.json` sidecar and the loss log `.loss.csv`
    /// are written beside it).
    #[arg(long)]
    pub out: PathBuf,
    /// Override `[train] iterations`.
    #[arg(long)]
    pub iterations: Option<usize>,
}

/// A sub-group of the composed group (`--group`), spelled as [`SubGroup::parse`] reads it:
/// `identity` (`original`, `none`), `R` (`G_R`), `RT` (`G_RT`), `MRT` (`G_MRT`), any case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum GroupArg {
    #[value(name = "identity", alias = "original", alias = "none")]
    Identity,
    #[value(name = "R", alias = "g_r")]
    R,
    #[value(name = "RT", alias = "g_rt")]
    Rt,
    #[value(name = "MRT", alias = "g_mrt")]
    Mrt,
}

impl From<GroupArg> for SubGroup {
    fn from(g: GroupArg) -> Self {
        match g {
            GroupArg::Identity => Self::Identity,
            GroupArg::R => Self::R,
            GroupArg::Rt => Self::RT,
            GroupArg::Mrt => Self::MRT,
        }
    }
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

/// Without the `teach` feature: an error saying how to build the command.
#[cfg(not(feature = "teach"))]
pub fn run(_: &TrainArgs) -> anyhow::Result<ExitCode> {
    super::common::needs_teach("train")
}

/// `crossym train`.
#[cfg(feature = "teach")]
pub fn run(a: &TrainArgs) -> anyhow::Result<ExitCode> {
    let kind = TrainKind::from_flags(a.equivariant, a.task_head);
    let cfg = Config::from_file(&a.config)?;
    let out = a.out.as_path();
    let groups = sub_groups(kind, a)?;
    let g = groups[0];
    let tc = train_config(kind, &cfg, a)?;
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
    announce(kind, &p, &groups, &tc);
    let total_iterations = tc.iterations * tc.ensemble;
    let bar = progress_bar(total_iterations);
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
    write_outputs(&cfg, kin, &policy, &groups, out, &log, &report)?;
    Ok(ExitCode::SUCCESS)
}

/// The sub-groups the policy is written for (a task head may be written for several at
/// once: one network).
#[cfg(feature = "teach")]
fn sub_groups(kind: TrainKind, a: &TrainArgs) -> anyhow::Result<Vec<SubGroup>> {
    let groups: Vec<SubGroup> = match (kind, &a.group) {
        (TrainKind::Equivariant, _) => vec![SubGroup::Identity],
        (_, Some(given)) => given.iter().map(|&g| g.into()).collect(),
        (_, None) => vec![SubGroup::MRT],
    };
    anyhow::ensure!(
        groups.len() == 1
            || (kind == TrainKind::TaskHead && a.out.to_string_lossy().contains("{group}")),
        "--group with several sub-groups needs --task-head and `{{group}}` in --out"
    );
    Ok(groups)
}

/// The training settings: `[train_task_head]` for a task head when present, else `[train]`;
/// `--iterations` applied.
#[cfg(feature = "teach")]
fn train_config(
    kind: TrainKind,
    cfg: &Config,
    a: &TrainArgs,
) -> anyhow::Result<crossym::policy::TrainConfig> {
    let section = match kind {
        TrainKind::TaskHead if cfg.train_task_head.is_some() => &cfg.train_task_head,
        _ => &cfg.train,
    };
    let mut tc = section
        .clone()
        .with_context(|| format!("{}: no [train] section", a.config.display()))?;
    if let Some(it) = a.iterations {
        tc.iterations = it;
    }
    Ok(tc)
}

/// The progress bar of `total_iterations` iterations.
#[cfg(feature = "teach")]
fn progress_bar(total_iterations: usize) -> indicatif::ProgressBar {
    let bar = indicatif::ProgressBar::new(total_iterations as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  [{bar:30}] {pos}/{len} it, loss {msg} {elapsed}/{duration}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    bar
}

/// Saves the policy (for each of `groups`) and its loss `log` (CSV) beside the first file,
/// and prints what was written and the loss of `report`.
#[cfg(feature = "teach")]
fn write_outputs(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    policy: &crossym::policy::Policy,
    groups: &[SubGroup],
    out: &Path,
    log: &str,
    report: &crossym::train::TrainReport,
) -> anyhow::Result<()> {
    let written = save(cfg, kin, policy, groups, out)?;
    let out = &written[0];
    if written.len() > 1 {
        let names: Vec<String> = written.iter().map(|f| f.display().to_string()).collect();
        println!(
            "one task head, written for each sub-group: {}",
            names.join(", ")
        );
    }
    let log_path = out.with_extension("loss.csv");
    std::fs::write(&log_path, log).with_context(|| format!("writing {}", log_path.display()))?;
    println!(
        "loss {:.4e} → {:.4e} in {} iterations, {:.1} s; saved {} (loss log {})",
        report.initial_loss,
        report.final_loss,
        report.iterations,
        report.seconds,
        out.display(),
        log_path.display()
    );
    Ok(())
}

/// The line announcing what is trained.
#[cfg(feature = "teach")]
fn announce(
    kind: TrainKind,
    p: &crossym::pipeline::Pipeline,
    groups: &[SubGroup],
    tc: &crossym::policy::TrainConfig,
) {
    let g = groups[0];
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
}

/// Saves the trained `policy` for each of `groups` (a task head canonicalised by each,
/// `{group}` in `out` replaced by its name); the files, in order.
#[cfg(feature = "teach")]
fn save(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    policy: &crossym::policy::Policy,
    groups: &[SubGroup],
    out: &Path,
) -> anyhow::Result<Vec<PathBuf>> {
    let g = groups[0];
    let mut written = Vec::new();
    for &gk in groups {
        let file = PathBuf::from(
            out.to_string_lossy()
                .replace("{group}", &gk.label().replace("G_", "").to_lowercase()),
        );
        let p = if gk == g {
            policy.clone()
        } else {
            crossym::pipeline::task_head_for(cfg, kin, policy, gk)?
        };
        crossym::pipeline::create_parent(&file)?;
        p.save(&file)?;
        written.push(file);
    }
    Ok(written)
}
