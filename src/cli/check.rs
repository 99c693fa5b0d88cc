//! `crossym check`: the configured symmetries transferred and composed, with the
//! numerical checks.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::symmetry::check::CheckReport;
use crossym::symmetry::compose::Composition;

/// Options of `crossym check`.
#[derive(Debug, clap::Args)]
pub struct CheckArgs {
    /// Config file (TOML) with [[symmetries]] and [composition].
    #[arg(long, short)]
    pub config: PathBuf,
}

/// A residual in scientific notation, `0` for zero.
fn sci(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else {
        format!("{v:.1e}")
    }
}

/// `crossym check`. Exits 1 when a requested composition is impossible or a transfer fails.
pub fn run(a: &CheckArgs) -> anyhow::Result<ExitCode> {
    let path = &a.config;
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
    print_symmetries(&report);
    println!();
    print_pairs(&report, &cfg.composition.order);
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

/// The table of symmetries: group, transfer, the numerical checks and the verdict of each.
fn print_symmetries(report: &CheckReport) {
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
}

/// The table of pairs: composition, residuals and details (`order`: the requested
/// composition order; a pair outside it is marked).
fn print_pairs(report: &CheckReport, order: &[String]) {
    println!(
        "{:<8} {:<5} {:<13} {:>12} {:>12}  details",
        "pair", "space", "composition", "residual", "lifted ⊥"
    );
    for p in &report.pairs {
        let (residual, details) = composition_details(&p.composition);
        println!(
            "{:<8} {:<5} {:<13} {:>12} {:>12}  {}{}",
            format!("{}·{}", p.a, p.b),
            p.space,
            p.composition.kind(),
            sci(residual),
            p.lifted_vertical.map_or("-".into(), sci),
            details,
            if p.requested || order.is_empty() {
                ""
            } else {
                " (not requested)"
            }
        );
    }
}

/// A pair's residual and what its composition says (automorphism or why none).
fn composition_details(composition: &Composition) -> (f64, String) {
    match composition {
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
    }
}
