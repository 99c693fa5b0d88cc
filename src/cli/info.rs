//! `crossym info`: a robot config loaded, its chains, joints, limits and FK at a
//! configuration.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;

/// Options of `crossym info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// Config file (TOML).
    #[arg(long, short)]
    pub config: PathBuf,
    /// Joint values (rad or m), comma-separated, in the robot's joint order; zeros by default.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub q: Option<Vec<f64>>,
}

/// `crossym info`.
pub fn run(a: &InfoArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let q = a.q.clone().unwrap_or_else(|| vec![0.0; kin.dof()]);
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
