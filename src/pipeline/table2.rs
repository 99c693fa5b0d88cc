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
use crate::eval::plot::{write_paths_grid, PathFigure, PathPanel, XY_VIEW};
use crate::kinematics::Kinematics;
use crate::policy::SubGroup;
use crate::symmetry::compose::Condition;

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

/// The three tables as they fill: Table II per coordinate and in the Euclidean convention
/// (markdown), its CSV, the per-condition CSV.
struct Tables {
    md: String,
    md_euclid: String,
    csv: String,
    per_cond: String,
    /// Task coordinates `m`.
    m: usize,
}

impl Tables {
    fn new(kin: &Kinematics) -> Self {
        let header = "| Policy | Original | G_R | G_RT | G_MRT |\n|---|---|---|---|---|\n";
        let chain_cols: Vec<String> = kin
            .chains()
            .iter()
            .map(|c| format!("mean_rmse_{}", c.name))
            .collect();
        Self {
            md: String::from(header),
            md_euclid: String::from(header),
            csv: String::from(
                "policy,test_set,mean_rmse,std_rmse,count,diverged,mean_rmse_per_coordinate,std_rmse_per_coordinate\n",
            ),
            per_cond: format!(
                "policy,theta_deg,scale,reflection,mean_rmse,std_rmse,count,diverged,{}\n",
                chain_cols.join(",")
            ),
            m: kin.task_dim(),
        }
    }

    /// One table row per scorer (a policy, or a reference built from the training demos),
    /// its cells per sub-group; the per-coordinate markdown row goes to `on_row` too.
    fn add_row(
        &mut self,
        label: &str,
        cells: &[Option<crate::eval::Cell>],
        on_row: &mut impl FnMut(&str),
    ) {
        let (mut row, mut row_e) = (format!("| {label} |"), format!("| {label} |"));
        for (g, c) in SubGroup::ALL.iter().zip(cells) {
            let Some(c) = c.filter(|c| c.count > 0) else {
                row.push_str(" – |");
                row_e.push_str(" – |");
                let _ = writeln!(self.csv, "{label},{},,,0,0,,", g.label());
                continue;
            };
            let pc = c.per_coordinate(self.m);
            row.push_str(&cell_text(&pc));
            row_e.push_str(&cell_text(&c));
            let _ = writeln!(
                self.csv,
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
        for (table, r) in [(&mut self.md, row), (&mut self.md_euclid, row_e)] {
            table.push_str(&r);
            table.push('\n');
        }
    }

    /// The per-condition rows of policy `pi` (over the test demonstrations): RMSE and the
    /// per-arm RMSE, mean over the condition's test trajectories.
    fn add_condition_rows(
        &mut self,
        label: &str,
        scores: &Scores,
        pi: usize,
        conditions: &[Condition],
        arms_n: usize,
    ) {
        for &cond in conditions {
            let c = scores.cell_where(pi, &|c| *c == cond);
            if c.count == 0 {
                continue;
            }
            let mut arms = vec![0.0; arms_n];
            for (_, (_, per_arm)) in scores
                .test
                .trajectories
                .iter()
                .zip(&scores.scored[pi])
                .filter(|(a, _)| a.condition == cond)
            {
                for (a, r) in arms.iter_mut().zip(per_arm) {
                    *a += r / c.count as f64;
                }
            }
            let arms: Vec<String> = arms.iter().map(|a| a.to_string()).collect();
            let _ = writeln!(
                self.per_cond,
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
    }

    /// `table2.md`'s text: both tables and what they mean.
    fn markdown(mut self) -> (String, String, String) {
        let m = self.m;
        let _ = write!(
            self.md,
            "\nRMSE per coordinate (task units) between the policy rollout and the nominal \
             trajectory from the same initial configuration, `√(mean over samples and the {m} \
             task coordinates of the squared error)`, mean ± std over the test trajectories \
             (diverged rollouts included and counted). The reference rows involve no policy: \
             each test trajectory against the training demonstrations transformed by the same \
             condition (the nearest one; their sample-wise mean).\n\n\
             The same in the Euclidean convention, `√(mean over samples of ‖x̂ − x‖²)` with all \
             arms stacked (= per coordinate × √{m}):\n\n{}\n\
             Figures `trajectories_<policy>.png`: one \
             panel per test set (Original, G_R, G_RT, G_MRT), up to 6 of the conditions it adds \
             to the previous set (rotations, scalings, reflection) on the first test \
             demonstration; grey nominal, colour rollout (blue left arm, red right).\n",
            self.md_euclid
        );
        (self.md, self.csv, self.per_cond)
    }
}

/// A cell as the table shows it: `mean ± std`, and the diverged rollouts if any.
fn cell_text(c: &crate::eval::Cell) -> String {
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
}

/// Each test trajectory rolled out once per policy: its score and per-arm RMSE, from which
/// the sub-group cells and the per-condition rows are aggregated.
struct Scores<'a> {
    test: &'a crate::data::augmentation::AugmentedSet,
    scored: Vec<Vec<(crate::eval::RolloutScore, Vec<f64>)>>,
}

impl<'a> Scores<'a> {
    fn roll_out<P: crate::eval::ConditionedPolicy>(
        cfg: &Config,
        kin: &Kinematics,
        loaded: &[(String, P)],
        p: &'a Pipeline,
    ) -> Self {
        let scored = loaded
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
        Self {
            test: &p.test,
            scored,
        }
    }

    /// Policy `pi`'s cell over the test trajectories whose condition passes `keep`.
    fn cell_where(&self, pi: usize, keep: &dyn Fn(&Condition) -> bool) -> crate::eval::Cell {
        let scores: Vec<_> = self
            .test
            .trajectories
            .iter()
            .zip(&self.scored[pi])
            .filter(|(a, _)| keep(&a.condition))
            .map(|(_, (sc, _))| *sc)
            .collect();
        crate::eval::Cell::from_scores(&scores)
    }
}

/// The no-learning references per sub-group: each test trajectory against the training
/// demos under its condition (the nearest one; their sample-wise mean).
type ReferenceCells = (
    Vec<Option<crate::eval::Cell>>,
    Vec<Option<crate::eval::Cell>>,
);

fn reference_cells(p: &Pipeline) -> ReferenceCells {
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
    (nearest, mean)
}

/// Policy `label`'s figure into `out`: one panel per test set, up to 6 conditions on the
/// first test demo, taken from what the set adds to the previous one (rotations, then
/// scalings, then the reflection). `None` when no panel has a path.
fn policy_figure<P: crate::eval::ConditionedPolicy>(
    cfg: &Config,
    kin: &Kinematics,
    p: &Pipeline,
    (label, policy): (&str, &P),
    out: &Path,
) -> Result<Option<PathBuf>, PipelineError> {
    let arm_dim = kin.chains().first().map_or(2, |c| c.task.dim());
    let view = cfg.eval.view.unwrap_or(XY_VIEW);
    let first_demo = p.demos.test.first().copied();
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
    if panels.is_empty() {
        return Ok(None);
    }
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
    Ok(Some(png))
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
    let aug = super::augmentation(cfg)?;
    let mut tables = Tables::new(kin);
    let scores = Scores::roll_out(cfg, kin, loaded, p);
    for (pi, (label, _)) in loaded.iter().enumerate() {
        let cells: Vec<_> = SubGroup::ALL
            .iter()
            .map(|g| Some(scores.cell_where(pi, &|c| g.contains(c))))
            .collect();
        tables.add_row(label, &cells, &mut on_row);
    }
    let (nearest, mean) = reference_cells(p);
    tables.add_row("reference: nearest training demo", &nearest, &mut on_row);
    tables.add_row("reference: mean of training demos", &mean, &mut on_row);
    let conditions = aug.test.conditions();
    let mut figures = Vec::new();
    for (pi, (label, policy)) in loaded.iter().enumerate() {
        tables.add_condition_rows(label, &scores, pi, &conditions, kin.chains().len());
        if let Some(png) = policy_figure(cfg, kin, p, (label, policy), out)? {
            figures.push(png);
        }
    }
    let (md, csv, per_cond) = tables.markdown();
    let write = |name: &str, text: &str| super::write_text(out, name, text);
    Ok(Table2Files {
        markdown: write("table2.md", &md)?,
        csv: write("table2.csv", &csv)?,
        conditions: write("conditions.csv", &per_cond)?,
        figures,
    })
}
