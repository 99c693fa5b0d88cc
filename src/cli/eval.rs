//! `crossym eval`: policies evaluated on the test sets of every sub-group (Table II, in
//! either protocol) and their fit to the demonstrations.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::pipeline::Splits;
use crossym::policy::AnyPolicy;

use super::common::pipeline;

/// Options of `crossym eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Config file (TOML).
    #[arg(long, short)]
    pub config: PathBuf,
    /// `label=path.safetensors`, repeatable (e.g. `pi_MRT=policies/pi_mrt.safetensors`).
    /// Without it, `[eval] policies` of the config.
    #[arg(long = "policy")]
    pub policies: Vec<String>,
    /// Directory for `table2.md` and `table2.csv` (`table2_paper.*` with `--protocol
    /// paper`), and `fit.md` / `fit.csv` (held-out protocol: every training and test
    /// demonstration rolled out from its own start, identity condition).
    #[arg(long, default_value = "results")]
    pub out: PathBuf,
    /// `heldout`: the test demonstrations under the test grid, whole trajectories
    /// (ours, stricter); `paper`: the authors' evaluation code (`[eval] paper_protocol`:
    /// training and test pooled with warm-up and common horizon, or resampled for the
    /// real-robot tasks).
    #[arg(long, value_enum, default_value_t = Protocol::Heldout)]
    pub protocol: Protocol,
    /// Evaluate the policy of this label canonicalised (repeatable): `π(q, s) =
    /// dΦ_g π₀(Φ_g⁻¹ q)` with `π₀` the policy at the identity condition and `Φ_g` the
    /// composed lifted action of `[composition]` — exactly equivariant for any
    /// feasible condition.
    #[arg(long = "canonicalise")]
    pub canonicalise: Vec<String>,
    /// Evaluate the task head of this label with the plain lift `J⁺ v` (repeatable),
    /// without the config's `[redundancy]` null-space term — to compare both on one file.
    #[arg(long = "plain-lift")]
    pub plain_lift: Vec<String>,
}

/// Evaluation protocol of `crossym eval`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Protocol {
    /// Held-out test trajectories, whole length (`table2.*`).
    Heldout,
    /// The authors' evaluation code (`table2_paper.*`).
    Paper,
}

/// `crossym eval`.
pub fn run(a: &EvalArgs) -> anyhow::Result<ExitCode> {
    let (path, policies, out, protocol) = (&a.config, &a.policies, a.out.as_path(), a.protocol);
    let cfg = Config::from_file(path)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let specs = policy_specs(&cfg, path, policies)?;
    let loaded = load_policies(a, &cfg, kin, specs)?;
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

/// The policies to evaluate, `(label, file)`: `--policy label=path` (relative to the
/// working directory), else `[eval] policies` (relative to the config file at `path`).
fn policy_specs(
    cfg: &Config,
    path: &Path,
    policies: &[String],
) -> anyhow::Result<Vec<(String, PathBuf)>> {
    Ok(if policies.is_empty() {
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
    })
}

/// The policies of `specs` loaded, `--canonicalise`d and with `--plain-lift` as asked (a
/// label of either flag must name one of them).
fn load_policies(
    a: &EvalArgs,
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    specs: Vec<(String, PathBuf)>,
) -> anyhow::Result<Vec<(String, AnyPolicy)>> {
    for (flag, labels) in [
        ("--canonicalise", &a.canonicalise),
        ("--plain-lift", &a.plain_lift),
    ] {
        if let Some(l) = labels
            .iter()
            .find(|l| !specs.iter().any(|(label, _)| label == *l))
        {
            anyhow::bail!("{flag} {l}: no policy labelled `{l}`");
        }
    }
    let mut loaded = Vec::new();
    for (label, file) in specs {
        let policy = crossym::pipeline::load_any_policy(cfg, kin, &file)?;
        let policy = match policy {
            AnyPolicy::Plain(p) if a.canonicalise.contains(&label) => {
                crossym::pipeline::canonicalise(cfg, kin, *p)
                    .with_context(|| format!("--canonicalise {label}"))?
            }
            other => other,
        };
        let policy = if a.plain_lift.contains(&label) {
            let (p, had) = policy.with_plain_lift();
            anyhow::ensure!(
                had,
                "--plain-lift {label}: not a task head with a `[redundancy]` null-space term"
            );
            p
        } else {
            policy
        };
        loaded.push((label, policy));
    }
    Ok(loaded)
}
