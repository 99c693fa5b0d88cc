//! `crossym stress`: the fault campaign of [`crossym::sim::stress`] — randomized closed-loop
//! episodes of the node core and a simulated robot, with a table of limit violations.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::ValueEnum;
use crossym::config::Config;
use crossym::safety::{BoundRules, ExactBounds};
use crossym::setup::NodeSetupError;
use crossym::sim::stress::{report_table, run_campaign, Geometry, StressSettings};

use super::common::OutputArg;

/// Options of `crossym stress`.
#[derive(Debug, clap::Args)]
pub struct StressArgs {
    /// Config files (TOML with [robot] and [node] policy), repeatable; each is a geometry the
    /// episodes draw from. Default: config/letters.toml, plus config/rby1-letters.toml when
    /// its RB-Y1 URDF is found.
    #[arg(long, short)]
    pub config: Vec<PathBuf>,
    /// Episodes per output mode.
    #[arg(long, default_value_t = 1000)]
    pub episodes: usize,
    /// Campaign seed (every episode is reproducible from it).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output modes, comma-separated (velocity, position, trajectory).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "velocity,position,trajectory",
        value_enum
    )]
    pub modes: Vec<OutputArg>,
    /// Simulated time per episode (s).
    #[arg(long, default_value_t = 3.0)]
    pub duration_s: f64,
    /// Break the safety filter on purpose to see the campaign catch it: no-horizon,
    /// no-position-bound or no-acceleration-bound.
    #[arg(long = "break", value_enum)]
    pub defect: Option<DefectArg>,
    /// Re-run only the episode of this seed (as listed under "episodes with a violation")
    /// in the first of --modes, printing each violation.
    #[arg(long)]
    pub episode: Option<u64>,
    /// Also write the table (Markdown) here.
    #[arg(long)]
    pub out: Option<PathBuf>,
}

/// A deliberately broken safety filter (`--break`); runnable only in a build with the
/// `fault-injection` feature (`crossym_control::faults::FilterDefect`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
#[allow(clippy::enum_variant_names)] // named as `FilterDefect`'s variants and the flag's values
pub enum DefectArg {
    NoHorizon,
    NoPositionBound,
    NoAccelerationBound,
}

/// `crossym stress`. Exits 1 when any episode violated a limit or published a non-finite value.
pub fn run(a: &StressArgs) -> anyhow::Result<ExitCode> {
    let mut geometries = Vec::new();
    if a.config.is_empty() {
        let planar = Config::from_file("config/letters.toml")?;
        geometries.push(crossym::setup::stress_geometry(&planar, "planar")?);
        match Config::from_file("config/rby1-letters.toml")
            .map_err(NodeSetupError::from)
            .and_then(|c| crossym::setup::stress_geometry(&c, "rby1"))
        {
            Ok(g) => geometries.push(g),
            Err(e) => eprintln!("stress: RB-Y1 geometry left out ({e})"),
        }
    } else {
        for p in &a.config {
            let cfg = Config::from_file(p)?;
            let name = p
                .file_stem()
                .map_or("robot".into(), |s| s.to_string_lossy().into_owned());
            geometries.push(
                crossym::setup::stress_geometry(&cfg, &name)
                    .with_context(|| format!("{}", p.display()))?,
            );
        }
    }
    let modes = a.modes.iter().map(|&m| m.into()).collect();
    if !(a.duration_s.is_finite() && a.duration_s > 0.0) {
        anyhow::bail!("--duration-s must be positive");
    }
    let settings = StressSettings {
        episodes: a.episodes,
        seed: a.seed,
        modes,
        duration_s: a.duration_s,
    };
    match a.defect {
        None => campaign(a, &geometries, &settings, ExactBounds, None),
        Some(defect) => broken(a, &geometries, &settings, defect),
    }
}

/// `--break`: the campaign with a deliberately broken filter (feature `fault-injection`).
#[cfg(feature = "fault-injection")]
fn broken(
    a: &StressArgs,
    geometries: &[Geometry],
    settings: &StressSettings,
    defect: DefectArg,
) -> anyhow::Result<ExitCode> {
    use crossym::control::faults::FilterDefect;
    let defect = match defect {
        DefectArg::NoHorizon => FilterDefect::NoHorizon,
        DefectArg::NoPositionBound => FilterDefect::NoPositionBound,
        DefectArg::NoAccelerationBound => FilterDefect::NoAccelerationBound,
    };
    let label = format!(", DELIBERATELY BROKEN FILTER ({defect:?})");
    campaign(a, geometries, settings, defect, Some(label))
}

/// `--break` in a build without the `fault-injection` feature (e.g. the Docker image).
#[cfg(not(feature = "fault-injection"))]
fn broken(
    _: &StressArgs,
    _: &[Geometry],
    _: &StressSettings,
    defect: DefectArg,
) -> anyhow::Result<ExitCode> {
    let name = defect
        .to_possible_value()
        .map_or_else(String::new, |v| v.get_name().to_string());
    anyhow::bail!(
        "--break {name}: this crossym was built without the `fault-injection` feature (on by \
         default; the Docker image leaves it out), so it has no broken filter to run"
    )
}

/// The campaign (or one episode, `--episode`) with the filter's bound rules `rules`.
fn campaign<R: BoundRules + Clone + Send + Sync>(
    a: &StressArgs,
    geometries: &[Geometry],
    settings: &StressSettings,
    rules: R,
    broken: Option<String>,
) -> anyhow::Result<ExitCode> {
    if let Some(seed) = a.episode {
        std::env::set_var("CROSSYM_STRESS_TRACE", "1");
        let t = crossym::sim::stress::run_episode(
            geometries,
            settings.modes[0],
            seed,
            a.duration_s,
            rules,
        )
        .map_err(anyhow::Error::msg)?;
        println!("{t:?}");
        return Ok(if t.clean() {
            ExitCode::SUCCESS
        } else {
            ExitCode::from(1)
        });
    }
    let names: Vec<&str> = geometries.iter().map(|g| g.name.as_str()).collect();
    println!(
        "stress: {} episodes per mode, seed {}, {} s each, geometries {}{}",
        a.episodes,
        a.seed,
        a.duration_s,
        names.join(", "),
        broken.unwrap_or_default()
    );
    let t0 = Instant::now();
    let report = run_campaign(geometries, settings, rules).map_err(anyhow::Error::msg)?;
    let table = report_table(&report);
    println!("{table}");
    println!("run time {:.1} s", t0.elapsed().as_secs_f64());
    if let Some(out) = &a.out {
        if let Some(d) = out.parent() {
            std::fs::create_dir_all(d).ok();
        }
        std::fs::write(out, &table).with_context(|| format!("writing {}", out.display()))?;
    }
    Ok(if report.clean() {
        ExitCode::SUCCESS
    } else {
        println!("stress: VIOLATIONS found");
        ExitCode::from(1)
    })
}
