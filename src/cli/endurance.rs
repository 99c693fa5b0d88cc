//! `crossym endurance`: the node core of a config in a long closed loop with a kinematic
//! robot under a cyclic schedule of conditions ([`crossym::sim::endurance`]), faster than
//! real time: limit margins, ticks on a bound and the posture drift of a redundant arm.

use std::path::PathBuf;
use std::process::ExitCode;

use crossym::config::{Config, RedundancyConfig};
use crossym::sim::endurance;

/// Options of `crossym endurance`.
#[derive(Debug, clap::Args)]
pub struct EnduranceArgs {
    /// Config (TOML with [robot] and [node]); conditions from [augmentation] test, else
    /// the identity.
    #[arg(long, short)]
    pub config: PathBuf,
    /// Simulated time (s).
    #[arg(long, default_value_t = 600.0)]
    pub duration_s: f64,
    /// A new condition every this many seconds.
    #[arg(long, default_value_t = 10.0)]
    pub condition_period_s: f64,
    /// The policy to run instead of [node] policy.
    #[arg(long)]
    pub policy: Option<PathBuf>,
    /// `[redundancy] weight` instead of the config's (1/s; 0: the plain lift).
    #[arg(long)]
    pub null_space_weight: Option<f64>,
}

/// `crossym endurance`. Exits 1 when a joint left its limits.
pub fn run(a: &EnduranceArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.duration_s.is_finite() && a.duration_s > 0.0,
        "--duration-s must be positive"
    );
    anyhow::ensure!(
        a.condition_period_s.is_finite() && a.condition_period_s > 0.0,
        "--condition-period-s must be positive"
    );
    let mut cfg = Config::from_file(&a.config)?;
    if let Some(w) = a.null_space_weight {
        cfg.redundancy = Some(RedundancyConfig {
            weight: w,
            ..cfg.redundancy.clone().unwrap_or_default()
        });
    }
    let (mut core, start, settings) =
        crossym::setup::endurance(&cfg, a.policy.clone(), a.duration_s, a.condition_period_s)?;
    let report = endurance::run(&mut core, &start, &settings);
    let weight = cfg.redundancy.as_ref().map_or(0.0, |r| r.weight);
    println!(
        "endurance ({}, {:.0} s, null-space weight {weight}): {report}",
        a.config.display(),
        a.duration_s
    );
    Ok(if report.violation_ticks > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}
