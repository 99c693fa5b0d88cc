//! Table II (paper Sec. VI-A): every test trajectory rolled out once per policy from its
//! initial configuration under its condition, scored against the nominal trajectory
//! (`RMSE = √(mean over samples and the m task coordinates of ‖x̂ − x‖²)`), aggregated per
//! sub-group (Original ⊂ G_R ⊂ G_RT ⊂ G_MRT) as mean ± std over trajectories, with two
//! no-learning references (the nearest training demonstration under the same condition,
//! and their sample-wise mean), per-condition rows and a figure per policy.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::{create_parent, Pipeline, PipelineError};
use crate::config::Config;
use crate::data::augmentation::SubGroup;
use crate::eval::plot::{write_paths_grid, PathFigure, PathPanel, XY_VIEW};
use crate::kinematics::Kinematics;

/// The files [`table2`] wrote.
#[derive(Debug, Clone)]
pub struct Table2Files {
    /// `table2.md`: the table per coordinate and in the Euclidean convention.
    pub markdown: PathBuf,
    /// `table2.csv`: one row per (policy or reference, test set).
    pub csv: PathBuf,
    /// `conditions.csv`: one row per (policy, test condition), per-arm RMSE.
    pub conditions: PathBuf,
    /// `trajectories_<policy>.png`.
    pub figures: Vec<PathBuf>,
}

/// Scores `policies` (label, policy) on `p.test` (built with `test` and `reference`),
/// writes `table2.md`, `table2.csv`, `conditions.csv` and a figure per policy into `out`,
/// and passes each table row (markdown) to `on_row` as it is ready.
pub fn table2<P: crate::eval::ConditionedPolicy>(
    cfg: &Config,
    kin: &Kinematics,
    loaded: &[(String, P)],
    p: &Pipeline,
    out: &Path,
    mut on_row: impl FnMut(&str),
) -> Result<Table2Files, PipelineError> {
    let mut figures = Vec::new();
    let aug = super::augmentation(cfg)?;
    let m = kin.task_dim();
    let header = "| Policy | Original | G_R | G_RT | G_MRT |\n|---|---|---|---|---|\n";
    // Per-coordinate rows (primary) and Euclidean rows, filled side by side.
    let (mut md, mut md_euclid) = (String::from(header), String::from(header));
    let mut csv = String::from(
        "policy,test_set,mean_rmse,std_rmse,count,diverged,mean_rmse_per_coordinate,std_rmse_per_coordinate\n",
    );
    let cell_text = |c: &crate::eval::Cell| {
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
    let mut add_row = |label: &str, cells: &[Option<crate::eval::Cell>]| {
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
        on_row(&row);
        for (table, r) in [(&mut md, row), (&mut md_euclid, row_e)] {
            table.push_str(&r);
            table.push('\n');
        }
    };
    // Each test trajectory rolled out once per policy: its score and per-arm RMSE, from
    // which the sub-group cells and the per-condition rows are aggregated.
    let scored: Vec<Vec<(crate::eval::RolloutScore, Vec<f64>)>> = loaded
        .iter()
        .map(|(_, policy)| {
            use rayon::prelude::*;
            p.test
                .trajectories
                .par_iter()
                .map(|a| {
                    let path = crate::eval::rollout_path(policy, kin, &a.traj, &a.condition);
                    (
                        crate::eval::score_path(&a.traj, &path, &cfg.eval),
                        crate::eval::chain_rmse(kin, &a.traj, &path),
                    )
                })
                .collect()
        })
        .collect();
    let cell_where = |pi: usize, keep: &dyn Fn(&crate::symmetry::compose::Condition) -> bool| {
        let scores: Vec<_> = p
            .test
            .trajectories
            .iter()
            .zip(&scored[pi])
            .filter(|(a, _)| keep(&a.condition))
            .map(|(_, (sc, _))| *sc)
            .collect();
        crate::eval::Cell::from_scores(&scores)
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
            if let Some((n, a)) = crate::eval::demo_reference(&t.traj, &refs) {
                let score = |rmse| crate::eval::RolloutScore {
                    rmse,
                    diverged: false,
                };
                sn.push(score(n));
                sm.push(score(a));
            }
        }
        nearest.push(Some(crate::eval::Cell::from_scores(&sn)));
        mean.push(Some(crate::eval::Cell::from_scores(&sm)));
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
                let (shown, label) = super::figures::figure_conditions(&p.test, gi, first_demo, 6);
                PathPanel {
                    m: kin.task_dim(),
                    arm_dim,
                    view,
                    label,
                    paths: shown
                        .iter()
                        .map(|a| {
                            let exe = crate::eval::rollout_path(policy, kin, &a.traj, &a.condition);
                            (a.traj.x.clone(), exe)
                        })
                        .collect(),
                }
            })
            .filter(|panel| !panel.paths.is_empty())
            .collect();
        if !panels.is_empty() {
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
            create_parent(&png)?;
            write_paths_grid(&png, &fig, &panels, panels.len(), 400).map_err(|message| {
                PipelineError::Write {
                    path: png.clone(),
                    message,
                }
            })?;
            figures.push(png);
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
    let write = |name: &str, text: &str| super::write_text(out, name, text);
    Ok(Table2Files {
        markdown: write("table2.md", &md)?,
        csv: write("table2.csv", &csv)?,
        conditions: write("conditions.csv", &per_cond)?,
        figures,
    })
}
