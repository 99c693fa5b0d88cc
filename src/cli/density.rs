//! `crossym density`: the augmentation-density experiment of the paper's Sec. VI-A figure.
//!
//! For each rotation step Δθ, `π_R` is trained on the training letters augmented with
//! `θ = kΔθ` (λ = 1, σ = 1) and evaluated on the test letters rotated by every `θ` of a fine
//! grid: RMSE (task units) against θ, one curve per Δθ. `--equivariant P` adds the curve
//! of a canonicalised policy (issue 18: trained on the originals only, no rotation grid at
//! all), flat by construction.
// Without the `teach` feature only the options remain (`run` says how to get the command).
#![cfg_attr(not(feature = "teach"), allow(dead_code, unused_imports))]

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use crossym::config::Config;
use crossym::data::augmentation::letter_augmenter;
use crossym::eval::plot::{curve_colour, write_curves_png, CurveFigure};
use crossym::policy::GroupGrid;
use crossym::policy::JointTrajectory;
use crossym::symmetry::compose::Condition;

/// Scores a policy on a set of (demonstration, condition) pairs.
type EvalSet<'a> = dyn for<'t> Fn(&[(&'t JointTrajectory, Condition)]) -> crossym::eval::Cell + 'a;

/// Arguments of `crossym density`.
#[derive(Debug, Args)]
pub struct DensityArgs {
    /// Config file (TOML) with [demonstrations], [[symmetries]], [composition], [train].
    #[arg(long, short)]
    pub config: PathBuf,
    /// Training rotation steps Δθ (degrees).
    #[arg(long, value_delimiter = ',', default_value = "5,10,15,30,45,60,75,90")]
    pub steps: Vec<f64>,
    /// Evaluation grid step (degrees).
    #[arg(long, default_value_t = 5.0)]
    pub eval_step: f64,
    /// Override `[train] iterations` (each Δθ trains one policy).
    #[arg(long)]
    pub iterations: Option<usize>,
    /// A canonicalised policy (`crossym train --equivariant`) evaluated on the same test
    /// letters and drawn as one more curve (`train_step_deg` = `eq` in the CSV).
    #[arg(long)]
    pub equivariant: Option<PathBuf>,
    /// Output directory for `density.csv`, `density.md` and `density.png`.
    #[arg(long, default_value = "results/density")]
    pub out: PathBuf,
}

/// Without the `teach` feature: an error saying how to build the command.
#[cfg(not(feature = "teach"))]
pub fn run(_: &DensityArgs) -> anyhow::Result<ExitCode> {
    super::common::needs_teach("density")
}

/// `crossym density`.
#[cfg(feature = "teach")]
pub fn run(a: &DensityArgs) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(&a.config)?;
    let mut tc = cfg
        .train
        .clone()
        .with_context(|| format!("{}: no [train] section", a.config.display()))?;
    if let Some(it) = a.iterations {
        tc.iterations = it;
    }
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let demos = cfg.load_demonstrations(kin)?;
    let (built, _) = crossym::symmetry::check::build(kin, &cfg.symmetries)?;
    let augmenter =
        letter_augmenter(kin, &built, &cfg.composition.order).map_err(anyhow::Error::msg)?;
    let grid = |step: f64| GroupGrid {
        rotation_step_deg: Some(step),
        ..GroupGrid::identity()
    };
    let test_grid = grid(a.eval_step);
    test_grid
        .validate()
        .map_err(anyhow::Error::msg)
        .context("--eval-step")?;
    let test = augmenter.augment(&demos.select(&demos.test), &test_grid, &|| {});
    anyhow::ensure!(!test.trajectories.is_empty(), "no feasible test trajectory");
    let angles = test_grid.angles();
    let mut out = Tables::new(a);
    let equivariant = match &a.equivariant {
        Some(p) => Some(load_equivariant(&cfg, kin, p)?),
        None => None,
    };
    for (si, &step) in a.steps.iter().enumerate() {
        let g = grid(step);
        g.validate()
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("--steps {step}"))?;
        let train = augmenter.augment(&demos.select(&demos.train), &g, &|| {});
        let data: Vec<_> = train
            .trajectories
            .iter()
            .map(|t| (&t.traj, t.condition))
            .collect();
        println!(
            "Δθ = {step}°: training π_R on {} trajectories ({} iterations)",
            data.len(),
            tc.iterations
        );
        let (policy, report) = train_rotations(&cfg, kin, &built, &tc, step, &data)?;
        let rows = per_angle(&test, &angles, &|set| {
            crossym::eval::evaluate(&policy, kin, set, &cfg.eval)
        });
        let c = curve_colour(si, a.steps.len());
        out.add_step(step, (c.0, c.1, c.2), data.len(), &report, &rows);
    }
    if let Some(policy) = &equivariant {
        let rows = per_angle(&test, &angles, &|set| {
            crossym::eval::evaluate(policy, kin, set, &cfg.eval)
        });
        out.add_equivariant(&rows, demos.train.len());
    }
    out.write(a, &cfg, kin, tc.iterations)?;
    Ok(ExitCode::SUCCESS)
}

/// RMSE per test angle of `policy` on the `test` trajectories: (θ°, mean, count, diverged).
#[cfg(feature = "teach")]
fn per_angle(
    test: &crossym::data::augmentation::AugmentedSet,
    angles: &[f64],
    policy: &EvalSet<'_>,
) -> Vec<(f64, f64, usize, usize)> {
    angles
        .iter()
        .filter_map(|&theta| {
            let set: Vec<_> = test
                .trajectories
                .iter()
                .filter(|t| (t.condition.theta - theta).abs() < 1e-9)
                .map(|t| (&t.traj, t.condition))
                .collect();
            (!set.is_empty()).then(|| {
                let c = policy(&set);
                (theta.to_degrees(), c.mean, c.count, c.diverged)
            })
        })
        .collect::<Vec<_>>()
}

/// `π_R` trained on `data`, the training letters augmented with rotation step `step`.
#[cfg(feature = "teach")]
fn train_rotations(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    built: &[crossym::symmetry::built::BuiltSymmetry],
    tc: &crossym::policy::train_config::TrainConfig,
    step: f64,
    data: &[(&JointTrajectory, Condition)],
) -> anyhow::Result<(crossym::policy::Policy, crossym::train::TrainReport)> {
    let meta = crossym::policy::PolicyMeta::new(
        &kin.robot,
        kin.joint_names().to_vec(),
        serde_json::json!({ "group": "G_R", "rotation_step_deg": step }),
    );
    let features =
        crossym::pipeline::task_features_for(cfg, kin, built, tc, crossym::policy::SubGroup::R)?;
    Ok(crossym::train::train_with_features(
        data,
        tc,
        meta,
        features,
        |_, _| {},
    )?)
}

/// `--equivariant P`: the canonicalised policy `P` (refused when plain).
#[cfg(feature = "teach")]
fn load_equivariant(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    p: &Path,
) -> anyhow::Result<crossym::policy::AnyPolicy> {
    let policy = crossym::pipeline::load_any_policy(cfg, kin, p)?;
    anyhow::ensure!(
        policy.composition().is_some(),
        "--equivariant {}: not a canonicalised policy (train it with `crossym train --equivariant`)",
        p.display()
    );
    Ok(policy)
}

/// What `crossym density` writes: `density.csv`, `density.md`, and the curves of
/// `density.png` with their names.
struct Tables {
    csv: String,
    md: String,
    curves: Vec<Vec<(f64, f64)>>,
    names: Vec<String>,
}

impl Tables {
    /// The headers, and one curve name per training step of `a`.
    fn new(a: &DensityArgs) -> Self {
        Self {
            csv: String::from(
                "train_step_deg,theta_deg,mean_rmse,count,diverged,train_trajectories,final_loss\n",
            ),
            md: String::from(
                "| Δθ train (°) | trajectories | mean RMSE over θ | max RMSE over θ | diverged |\n|---|---|---|---|---|\n",
            ),
            curves: Vec::new(),
            names: a.steps.iter().map(|s| format!("Δθ = {s}°")).collect(),
        }
    }

    /// One training step Δθ = `step` (its curve colour, the trajectories trained on, the
    /// training report) and its rows `(θ°, mean, count, diverged)`.
    #[cfg(feature = "teach")]
    fn add_step(
        &mut self,
        step: f64,
        colour: (u8, u8, u8),
        trajectories: usize,
        report: &crossym::train::TrainReport,
        rows: &[(f64, f64, usize, usize)],
    ) {
        let mut curve = Vec::new();
        let (mut sum, mut max, mut div) = (0.0, 0.0f64, 0);
        for &(theta, mean, count, diverged) in rows {
            self.csv.push_str(&format!(
                "{step},{theta},{mean},{count},{diverged},{},{}\n",
                trajectories, report.final_loss
            ));
            curve.push((theta, mean));
            sum += mean;
            max = max.max(mean);
            div += diverged;
        }
        let c = colour;
        self.md.push_str(&format!(
            "| {step} (rgb {},{},{}) | {} | {:.3} | {:.3} | {div} |\n",
            c.0,
            c.1,
            c.2,
            trajectories,
            sum / curve.len().max(1) as f64,
            max
        ));
        println!(
            "  loss {:.3e} → {:.3e} in {:.0} s; mean RMSE over θ {:.3}",
            report.initial_loss,
            report.final_loss,
            report.seconds,
            sum / curve.len().max(1) as f64
        );
        self.curves.push(curve);
    }

    /// The canonicalised policy's rows `(θ°, mean, count, diverged)`, trained on `n_train`
    /// originals: CSV rows, a table row, a black curve.
    fn add_equivariant(&mut self, rows: &[(f64, f64, usize, usize)], n_train: usize) {
        for (theta, mean, count, diverged) in rows {
            self.csv.push_str(&format!(
                "eq,{theta},{mean},{count},{diverged},{n_train},\n"
            ));
        }
        let mean = rows.iter().map(|r| r.1).sum::<f64>() / rows.len().max(1) as f64;
        let max = rows.iter().fold(0.0f64, |m, r| m.max(r.1));
        let div: usize = rows.iter().map(|r| r.3).sum();
        self.md.push_str(&format!(
            "| π_eq, canonicalised, originals only (black) | {n_train} | {mean:.3} | {max:.3} | {div} |\n"
        ));
        println!("π_eq (canonicalised): mean RMSE over θ {mean:.3}, max {max:.3}");
        self.curves.push(rows.iter().map(|r| (r.0, r.1)).collect());
        self.names.push("π_eq (originals only)".into());
    }

    /// The figure's caption into the table, then the files into `--out`.
    fn write(
        self,
        a: &DensityArgs,
        cfg: &Config,
        kin: &crossym::kinematics::Kinematics,
        iterations: usize,
    ) -> anyhow::Result<()> {
        let Self {
            csv,
            mut md,
            curves,
            names,
        } = self;
        md.push_str(&format!(
            "\nFigure `density.png`: RMSE (task units, mean over the test letters; Euclidean with \
             the arms stacked, per coordinate it is this ÷ √{}) against the test \
             rotation θ ∈ [−180°, 180°] in steps of {}°, one curve per training step Δθ (colours as \
             in the table, dark blue = densest); faint vertical lines at the evaluated θ. {} \
             iterations per policy.\n",
            kin.task_dim(),
            a.eval_step,
            iterations
        ));
        std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
        std::fs::write(a.out.join("density.csv"), &csv)?;
        std::fs::write(a.out.join("density.md"), &md)?;
        let fig = CurveFigure {
            title: format!(
                "Augmentation density: π_R on {} trained at rotation steps Δθ, tested every {}°",
                kin.robot, a.eval_step
            ),
            x_desc: "test rotation θ (°)".into(),
            y_desc: format!("RMSE, Euclidean, arms stacked ({})", cfg.eval.units),
            names,
            categorical: false,
            ramp: Some(a.steps.len()),
        };
        write_curves_png(&a.out.join("density.png"), &fig, &curves, 900, 460)
            .map_err(anyhow::Error::msg)?;
        println!("{md}");
        println!("wrote {}", a.out.display());
        Ok(())
    }
}
