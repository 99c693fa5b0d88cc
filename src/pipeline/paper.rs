//! Table II under the paper's own evaluation protocol (`crossym eval --protocol paper`,
//! [`crate::eval::paper`]): the pooled script for the simulated letters (training and test
//! trajectories together, warm-up dropped, a common horizon, pooled RMSE with the std of
//! the MSEs), the resampled real-robot script for the RB-Y1 tasks. Sets are nested by
//! condition as in Table II (Original ⊂ G_R ⊂ G_RT ⊂ G_MRT).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use rayon::prelude::*;

use super::{invalid, Pipeline, PipelineError, Splits};
use crate::config::Config;
use crate::data::augmentation::Augmented;
use crate::eval::paper::{
    pooled_cell, pooled_horizon, resample, resampled_cell, resampled_rmse, trajectory_mse, Columns,
    PaperCell, PaperProtocol, TrajectoryError,
};
use crate::eval::plot::XY_VIEW;
use crate::kinematics::Kinematics;
use crate::policy::SubGroup;

/// The files [`table2_paper`] wrote.
#[derive(Debug, Clone)]
pub struct PaperFiles {
    /// `table2_paper.md`: a row per policy, the four sets as columns, `value ± std` cells.
    pub markdown: PathBuf,
    /// `table2_paper.csv`: a row per (policy, set), as `table2.csv`.
    pub csv: PathBuf,
}

/// The augmented sets the protocol of `cfg` needs: training and test (pooled), or test
/// only (resampled).
pub fn splits(cfg: &Config) -> Splits {
    let pooled = matches!(cfg.eval.paper_protocol, PaperProtocol::Pooled { .. });
    Splits {
        train: pooled,
        test: true,
        reference: false,
    }
}

/// The trajectories the protocol scores: the training and test sets pooled, or the test
/// set (resampled).
fn pool<'a>(cfg: &Config, p: &'a Pipeline) -> Vec<&'a Augmented> {
    match cfg.eval.paper_protocol {
        PaperProtocol::Pooled { .. } => p
            .train
            .trajectories
            .iter()
            .chain(&p.test.trajectories)
            .collect(),
        _ => p.test.trajectories.iter().collect(),
    }
}

/// Scores `policies` under `[eval] paper_protocol` on the pool of `p` (built with
/// [`splits`]), writes `table2_paper.md` and `table2_paper.csv` into `out`, and passes each
/// markdown row to `on_row` as it is ready.
pub fn table2_paper<P: crate::eval::ConditionedPolicy>(
    cfg: &Config,
    kin: &Kinematics,
    loaded: &[(String, P)],
    p: &Pipeline,
    out: &Path,
    mut on_row: impl FnMut(&str),
) -> Result<PaperFiles, PipelineError> {
    let protocol = cfg.eval.paper_protocol;
    protocol
        .validate()
        .map_err(|e| invalid(cfg, format!("[eval] {e}")))?;
    let pool = pool(cfg, p);
    if pool.is_empty() {
        return Err(invalid(cfg, "no trajectory to evaluate"));
    }
    let counts: Vec<usize> = SubGroup::ALL
        .iter()
        .map(|g| pool.iter().filter(|a| g.contains(&a.condition)).count())
        .collect();
    let (describe, pooled) = describe_protocol(cfg, kin, p, &pool, protocol)?;
    let mut md = String::from("| Policy |");
    for (g, c) in SubGroup::ALL.iter().zip(&counts) {
        let _ = write!(md, " {} ({c}) |", g.label());
    }
    md.push_str("\n|---|---|---|---|---|\n");
    let mut csv = String::from("policy,test_set,value,std,std_of,count,diverged\n");
    let project = projection(cfg, kin, protocol);
    for (label, policy) in loaded {
        let errors: Vec<TrajectoryError> = pool
            .par_iter()
            .map(|a| match pooled {
                Some((warmup, horizon)) => pooled_error(policy, kin, a, warmup, horizon, cfg),
                None => resampled_error(policy, kin, a, &project, protocol, cfg),
            })
            .collect();
        let row = policy_row(label, &pool, &errors, pooled.is_some(), &mut csv);
        on_row(&row);
        md.push_str(&row);
        md.push('\n');
    }
    let _ = write!(md, "\n{describe}\n");
    let write = |name: &str, text: &str| super::write_text(out, name, text);
    Ok(PaperFiles {
        markdown: write("table2_paper.md", &md)?,
        csv: write("table2_paper.csv", &csv)?,
    })
}

/// The protocol's description under the table, and for the pooled protocol its warm-up and
/// horizon (samples; refused when a trajectory of `pool` is no longer than the warm-up).
fn describe_protocol(
    cfg: &Config,
    kin: &Kinematics,
    p: &Pipeline,
    pool: &[&Augmented],
    protocol: PaperProtocol,
) -> Result<(String, Option<(usize, usize)>), PipelineError> {
    Ok(match protocol {
        PaperProtocol::Pooled { warmup_samples } => {
            let horizon = pooled_horizon(pool.iter().map(|a| a.traj.len()), warmup_samples)
                .ok_or_else(|| {
                    invalid(
                        cfg,
                        format!(
                            "[eval] paper_protocol: a trajectory has no more than the \
                             {warmup_samples} warm-up samples"
                        ),
                    )
                })?;
            (
                format!(
                    "Paper protocol, pooled (the authors' Table II script): training and test \
                     trajectories together ({} + {}), the first {warmup_samples} samples of \
                     each dropped, the policy rolled out from the trimmed first state for \
                     {} Euler steps of the stored Δt and compared sample by sample over the \
                     {horizon} samples; per trajectory MSE = mean over samples and the {} task \
                     coordinates of (x̂ − x)²; value = √(mean of the MSEs), ± = population \
                     std of the MSEs (task units²); diverged rollouts included and counted.",
                    p.train.trajectories.len(),
                    p.test.trajectories.len(),
                    horizon - 1,
                    kin.task_dim()
                ),
                Some((warmup_samples, horizon)),
            )
        }
        PaperProtocol::Resampled { points, columns } => (
            format!(
                "Paper protocol, resampled (the authors' real-robot script): the {} test \
                 rollouts over each nominal's duration and the nominals, both resampled to \
                 {points} points over normalised time, compared on {}; RMSE = √(mean of the \
                 squared differences over all entries); mean ± std (ddof 1) over the set.",
                p.test.trajectories.len(),
                match columns {
                    Columns::View =>
                        "each arm's point projected on the `[eval] view` plane (2 columns per arm)",
                    _ => "every task coordinate",
                }
            ),
            None,
        ),
    })
}

/// The markdown row of policy `label` (a cell per sub-group, nested) from the `errors` of
/// its rollouts on `pool` (`pooled`: under the pooled protocol, else the resampled one);
/// its CSV lines appended to `csv`.
fn policy_row(
    label: &str,
    pool: &[&Augmented],
    errors: &[TrajectoryError],
    pooled: bool,
    csv: &mut String,
) -> String {
    let mut row = format!("| {label} |");
    for g in SubGroup::ALL {
        let set: Vec<TrajectoryError> = pool
            .iter()
            .zip(errors)
            .filter(|(a, _)| g.contains(&a.condition))
            .map(|(_, e)| *e)
            .collect();
        if set.is_empty() {
            row.push_str(" – |");
            let _ = writeln!(csv, "{label},{},,,,0,0", g.label());
            continue;
        }
        let c = if pooled {
            pooled_cell(&set)
        } else {
            resampled_cell(&set)
        };
        row.push_str(&cell_text(&c));
        let _ = writeln!(
            csv,
            "{label},{},{},{},{},{},{}",
            g.label(),
            c.value,
            c.std,
            c.spread.label(),
            c.count,
            c.diverged
        );
    }
    row
}

/// ` value ± std |` with the divergence count, both to three significant digits of the
/// value (metres and letter units alike); `–` for an undefined std.
fn cell_text(c: &PaperCell) -> String {
    let decimals = if c.value.is_finite() && c.value > 0.0 {
        (2 - c.value.log10().floor() as i32).clamp(3, 8) as usize
    } else {
        3
    };
    let std = if c.std.is_finite() {
        format!("{:.decimals$}", c.std)
    } else {
        "–".into()
    };
    let div = if c.diverged > 0 {
        format!(" ({} div.)", c.diverged)
    } else {
        String::new()
    };
    format!(" {:.decimals$} ± {std}{div} |", c.value)
}

/// The pooled protocol's `MSE_τ`: rolled out from sample `warmup` for `horizon` samples,
/// compared with samples `warmup … warmup + horizon − 1`.
fn pooled_error<P: crate::eval::ConditionedPolicy>(
    policy: &P,
    kin: &Kinematics,
    a: &Augmented,
    warmup: usize,
    horizon: usize,
    cfg: &Config,
) -> TrajectoryError {
    let t = &a.traj;
    let m = t.m;
    let r = crate::eval::rollout(policy, kin, t.q(warmup), &a.condition, t.dt, horizon);
    let nominal = &t.x[warmup * m..(warmup + horizon) * m];
    trajectory_mse(&r.traj.x, nominal, m, cfg.eval.divergence_threshold)
}

/// Reduces one task point (`m` values) to the compared columns.
type Projection = Box<dyn Fn(&[f64], &mut Vec<f64>) + Sync>;

/// The columns of [`Columns`]: all task coordinates, or each arm's `(u·x, v·x)` on the
/// `[eval] view` plane.
fn projection(cfg: &Config, kin: &Kinematics, protocol: PaperProtocol) -> Projection {
    match protocol {
        PaperProtocol::Resampled {
            columns: Columns::View,
            ..
        } => {
            let [u, v] = cfg.eval.view.unwrap_or(XY_VIEW);
            let arms: Vec<(usize, usize)> = (0..kin.chains().len())
                .map(|c| (kin.x_offset(c), kin.chains()[c].task.dim().min(3)))
                .collect();
            Box::new(move |x: &[f64], out: &mut Vec<f64>| {
                for &(o, d) in &arms {
                    let dot = |w: &[f64; 3]| (0..d).map(|i| w[i] * x[o + i]).sum::<f64>();
                    out.push(dot(&u));
                    out.push(dot(&v));
                }
            })
        }
        _ => Box::new(|x: &[f64], out: &mut Vec<f64>| out.extend_from_slice(x)),
    }
}

/// The resampled protocol's `RMSE_τ`: rolled out over the nominal's length, both paths
/// projected and resampled to `points`.
fn resampled_error<P: crate::eval::ConditionedPolicy>(
    policy: &P,
    kin: &Kinematics,
    a: &Augmented,
    project: &Projection,
    protocol: PaperProtocol,
    cfg: &Config,
) -> TrajectoryError {
    let PaperProtocol::Resampled { points, .. } = protocol else {
        unreachable!("resampled protocol");
    };
    let t = &a.traj;
    let executed = crate::eval::rollout_path(policy, kin, t, &a.condition);
    resampled_path_error(
        project,
        points,
        &executed,
        &t.x,
        t.m,
        cfg.eval.divergence_threshold,
    )
}

/// `RMSE_τ` of an executed task path against its nominal (both row-major, `m` task
/// coordinates per sample), projected and resampled to `points`.
fn resampled_path_error(
    project: &Projection,
    points: usize,
    executed: &[f64],
    nominal: &[f64],
    m: usize,
    threshold: f64,
) -> TrajectoryError {
    let reduce = |path: &[f64]| {
        let mut out = Vec::new();
        for x in path.chunks(m.max(1)) {
            project(x, &mut out);
        }
        out
    };
    let (exe, nom) = (reduce(executed), reduce(nominal));
    let len = nominal.len() / m.max(1);
    let c = nom.len() / len.max(1);
    resampled_rmse(
        &resample(&exe, c, points),
        &resample(&nom, c, points),
        c,
        threshold,
    )
}

/// The config's `[eval] paper_protocol` applied to an executed path (a closed loop's
/// measured task path, row-major `m` per sample) against its nominal: `Some(RMSE_τ)` when
/// the protocol is the resampled (real-robot) one, `None` for the pooled one, which scores
/// rollouts from their own start rather than recorded paths.
pub fn paper_path_error(
    cfg: &Config,
    kin: &Kinematics,
    executed: &[f64],
    nominal: &[f64],
    m: usize,
) -> Option<TrajectoryError> {
    let protocol = cfg.eval.paper_protocol;
    let PaperProtocol::Resampled { points, .. } = protocol else {
        return None;
    };
    let project = projection(cfg, kin, protocol);
    Some(resampled_path_error(
        &project,
        points,
        executed,
        nominal,
        m,
        cfg.eval.divergence_threshold,
    ))
}
