//! Fit to the demonstrations (issue 17): every training and every test demonstration
//! rolled out from its own first configuration under the identity condition and scored
//! against itself, `RMSE = √(mean over samples and the m task coordinates of ‖x̂ − x‖²)`
//! (whole trajectory, by time, as Table II's held-out protocol scores).
//!
//! An imitation policy should reproduce the demonstrations it was trained on: a training
//! RMSE close to the test RMSE says it learned one mean flow rather than each
//! demonstration; a training RMSE far below it says it fits its data (and how much of the
//! test error is generalisation).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::PipelineError;
use crate::config::Config;
use crate::data::demonstrations::Demonstrations;
use crate::eval::ConditionedPolicy;
use crate::kinematics::Kinematics;
use crate::symmetry::compose::Condition;

/// Which set a demonstration belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitSplit {
    /// A training demonstration (`[demonstrations] train`).
    Train,
    /// A test demonstration (`[demonstrations] test`).
    Test,
}

impl FitSplit {
    /// `train` / `test`.
    pub fn label(self) -> &'static str {
        match self {
            Self::Train => "train",
            Self::Test => "test",
        }
    }
}

/// One policy on one demonstration.
#[derive(Debug, Clone, PartialEq)]
pub struct DemoFit {
    /// Training or test.
    pub split: FitSplit,
    /// Demonstration number (1-based, as `[demonstrations]` numbers them).
    pub demo: usize,
    /// RMSE per task coordinate (task units).
    pub rmse_per_coordinate: f64,
    /// The rollout diverged (non-finite, or beyond `[eval] divergence_threshold`).
    pub diverged: bool,
}

/// The training demonstrations, then the test ones (1-based numbers).
fn picks(demos: &Demonstrations) -> Vec<(FitSplit, usize)> {
    let train = demos.train.iter().map(|&d| (FitSplit::Train, d));
    train
        .chain(demos.test.iter().map(|&d| (FitSplit::Test, d)))
        .collect()
}

/// Rolls `policy` out on every training and test demonstration of `demos` (identity
/// condition, from each demonstration's first configuration), training first.
pub fn demo_fit<P: ConditionedPolicy + ?Sized>(
    cfg: &Config,
    kin: &Kinematics,
    demos: &Demonstrations,
    policy: &P,
) -> Vec<DemoFit> {
    use rayon::prelude::*;
    let m = kin.task_dim() as f64;
    picks(demos)
        .par_iter()
        .map(|&(split, demo)| {
            let traj = &demos.demos[demo - 1];
            let path = crate::eval::rollout_path(policy, kin, traj, &Condition::IDENTITY);
            let score = crate::eval::score_path(traj, &path, &cfg.eval);
            DemoFit {
                split,
                demo,
                rmse_per_coordinate: score.rmse / m.sqrt(),
                diverged: score.diverged,
            }
        })
        .collect()
}

/// The files [`write_fit`] wrote.
#[derive(Debug, Clone)]
pub struct FitFiles {
    /// `fit.md`: a row per policy, a column per demonstration, the mean per split.
    pub markdown: PathBuf,
    /// `fit.csv`: one row per (policy, demonstration).
    pub csv: PathBuf,
}

/// Mean of the RMSEs of `split` in `fits` (`None` without such demonstrations).
pub fn split_mean(fits: &[DemoFit], split: FitSplit) -> Option<f64> {
    let v: Vec<f64> = fits
        .iter()
        .filter(|f| f.split == split)
        .map(|f| f.rmse_per_coordinate)
        .collect();
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

/// Scores every `(label, policy)` with [`demo_fit`] and writes `fit.md` and `fit.csv`
/// into `out`, passing each markdown row to `on_row`.
pub fn write_fit<P: ConditionedPolicy>(
    cfg: &Config,
    kin: &Kinematics,
    demos: &Demonstrations,
    loaded: &[(String, P)],
    out: &Path,
    mut on_row: impl FnMut(&str),
) -> Result<FitFiles, PipelineError> {
    let mut csv = String::from("policy,split,demo,name,rmse_per_coordinate,diverged\n");
    let columns = picks(demos);
    let mut md = String::from("| Policy |");
    for split in [FitSplit::Train, FitSplit::Test] {
        for (_, d) in columns.iter().filter(|(s, _)| *s == split) {
            let _ = write!(md, " {} #{d} |", split.label());
        }
        let _ = write!(md, " **{} mean** |", split.label());
    }
    md.push_str("\n|---|");
    for _ in 0..columns.len() + 2 {
        md.push_str("---|");
    }
    md.push('\n');
    for (label, policy) in loaded {
        let fits = demo_fit(cfg, kin, demos, policy);
        let mut row = format!("| {label} |");
        for split in [FitSplit::Train, FitSplit::Test] {
            for f in fits.iter().filter(|f| f.split == split) {
                let _ = write!(
                    row,
                    " {:.3}{} |",
                    f.rmse_per_coordinate,
                    if f.diverged { " (div.)" } else { "" }
                );
                let _ = writeln!(
                    csv,
                    "{label},{},{},{},{},{}",
                    split.label(),
                    f.demo,
                    demos.names[f.demo - 1].replace(',', ";"),
                    f.rmse_per_coordinate,
                    f.diverged
                );
            }
            match split_mean(&fits, split) {
                Some(mean) => {
                    let _ = write!(row, " **{mean:.3}** |");
                }
                None => row.push_str(" – |"),
            }
        }
        on_row(&row);
        md.push_str(&row);
        md.push('\n');
    }
    let _ = write!(
        md,
        "\nFit to the demonstrations: each demonstration rolled out from its own first \
         configuration under the identity condition and scored against itself, RMSE per \
         coordinate (task units, whole trajectory, by time). A training mean close to the \
         test mean says the policy follows one mean flow rather than each demonstration.\n"
    );
    let write = |name: &str, text: &str| super::write_text(out, name, text);
    Ok(FitFiles {
        markdown: write("fit.md", &md)?,
        csv: write("fit.csv", &csv)?,
    })
}
