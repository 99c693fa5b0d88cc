//! Step 4 of the demo: the per-condition table (Markdown and CSV), the failures (RMSE
//! ratio, abnormal status, limit violations, exit codes, the bag's offline replay), the
//! figure of the executed paths and the files.

use std::path::{Path, PathBuf};

use crate::eval::plot::{condition_label, write_paths_grid, PathFigure, PathPanel, XY_VIEW};
use crate::pipeline::figures::file_name;
use crate::pipeline::paper::paper_path_error;
use crate::setup::{build_core, NodeOverrides};
use crate::sim::scenario::StepResult;
use crate::sim::MockHwSummary;

use super::{chain, DemoError, DemoSettings, Prepared, Run};

/// Largest deviation of a replayed command from the recorded one (rad/s or rad).
const REPLAY_TOLERANCE: f64 = 1e-9;

const MD_HEADER: &str = "| # | condition | θ (rad) | λ | σ | RMSE closed loop | RMSE offline rollout | ratio | RMSE paper protocol | samples | status on a bound | tick median / max (µs) |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n";

const CSV_HEADER: &str = "step,label,theta,scale,reflection,rmse_closed_loop,rmse_offline,ratio,rmse_paper_protocol,samples,statuses_on_bound,statuses,tick_median_us,tick_max_us\n";

const FIGURE_CAPTION: &str = "\nFigure `demo.png`: one panel per step, in table order, captioned with its condition; grey = nominal paths (transformed demonstration), colour = end-effector paths executed over DDS (blue left arm, red right arm).\n";

/// The demo's outcome ([`report()`]).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Report {
    /// `demo.md`: the table, the mock hardware's summary, the replay and the figure's
    /// caption.
    pub markdown: String,
    /// `demo.csv`: one row per step.
    pub csv: String,
    /// Every failed check, one line each; the demo passed when empty.
    pub failures: Vec<String>,
}

/// The files [`write()`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// `demo.md`.
    pub markdown: PathBuf,
    /// `demo.csv`.
    pub csv: PathBuf,
    /// `demo.png`.
    pub figure: PathBuf,
}

/// Step 4: the table of the run's steps against their offline scores and every check: the
/// closed-loop RMSE within `max_ratio × offline + max_excess`, no abnormal status, no limit
/// violation, both children exiting 0, and the node's bag (`out/bag`) replaying within
/// 1e-9 through the node's logic ([`replay_bag`]).
pub fn report(s: &DemoSettings, p: &Prepared, run: &Run) -> Report {
    let mut r = Report {
        markdown: MD_HEADER.into(),
        csv: CSV_HEADER.into(),
        failures: Vec::new(),
    };
    for (i, (result, offline)) in run.results.iter().zip(&p.offline).enumerate() {
        step_row(&mut r, s.max_ratio, p, i, result, *offline);
    }
    let summary = &run.summary;
    if summary.violation_count > 0 {
        r.failures.push(format!(
            "mock hardware saw {} limit violations (first: {:?})",
            summary.violation_count,
            summary.violations.first()
        ));
    }
    if run.node_rc != 0 {
        r.failures.push(format!("node exited with {}", run.node_rc));
    }
    let bag_dir = s.bag_dir();
    let replay_line = match replay_bag(&bag_dir, &s.config, &s.overrides()) {
        Ok((commands, dev)) => {
            if dev > REPLAY_TOLERANCE {
                r.failures.push(format!(
                    "replay of {} deviates by {dev:e} from the recorded commands",
                    bag_dir.display()
                ));
            }
            format!(
                "\nBag `{}`: offline replay recomputed {commands} commands, max deviation {dev:.1e}.\n",
                bag_dir.display()
            )
        }
        Err(e) => {
            r.failures
                .push(format!("replay of {}: {}", bag_dir.display(), chain(&e)));
            String::new()
        }
    };
    if run.hw_rc != 0 {
        r.failures
            .push(format!("mock-hw exited with {}", run.hw_rc));
    }
    r.markdown.push_str(&hardware_paragraph(summary));
    r.markdown.push_str(&replay_line);
    r.markdown.push_str(FIGURE_CAPTION);
    r
}

/// Step `i`'s Markdown and CSV rows, and its failures (RMSE ratio, abnormal status codes).
fn step_row(r: &mut Report, max_ratio: f64, p: &Prepared, i: usize, result: &StepResult, off: f64) {
    let kin = &p.robot.kinematics;
    let ratio = result.rmse / off.max(1e-12);
    // `[eval] paper_protocol` on the measured path (the resampled, real-robot script).
    let nominal = &p.steps[i].nominal;
    let paper = paper_path_error(&p.cfg, kin, &result.path, &nominal.x, nominal.m);
    let paper_md = paper.map_or("–".to_string(), |e| format!("{:.4}", e.error));
    let paper_csv = paper.map_or(String::new(), |e| e.error.to_string());
    let StepResult {
        label,
        theta,
        scale,
        reflection,
        rmse,
        samples,
        statuses_on_bound,
        statuses,
        tick_median_us,
        tick_max_us,
        ..
    } = result;
    let n = i + 1;
    r.markdown.push_str(&format!(
        "| {n} | {label} | {theta:.4} | {scale} | {reflection} | {rmse:.4} | {off:.4} | {ratio:.2} | {paper_md} | {samples} | {statuses_on_bound}/{statuses} | {tick_median_us:.1} / {tick_max_us:.1} |\n",
    ));
    r.csv.push_str(&format!(
        "{n},{label},{theta},{scale},{reflection},{rmse},{off},{ratio},{paper_csv},{samples},{statuses_on_bound},{statuses},{tick_median_us},{tick_max_us}\n",
    ));
    if !(rmse.is_finite() && *rmse <= max_ratio * off + p.max_excess) {
        r.failures.push(format!(
            "step {n} ({label}): closed-loop RMSE {rmse:.4} is {ratio:.2}× the offline rollout's {off:.4} (limit {max_ratio}× + {})",
            p.max_excess
        ));
    }
    if !result.abnormal_codes.is_empty() {
        r.failures.push(format!(
            "step {n} ({label}): node status codes {:?} seen",
            result.abnormal_codes
        ));
    }
}

/// The mock hardware's paragraph of `demo.md` (and the physics robot's tracking line).
fn hardware_paragraph(summary: &MockHwSummary) -> String {
    let mut s = format!(
        "\nMock hardware: {} steps, {} commands received, {} invalid, {} limit violations; largest |q̇| per joint (rad/s): {:?}.\n",
        summary.steps,
        summary.commands_received,
        summary.commands_invalid,
        summary.violation_count,
        summary
            .max_abs_velocity
            .iter()
            .map(|v| (v * 1000.0).round() / 1000.0)
            .collect::<Vec<_>>()
    );
    if let Some(line) = summary.plant_line() {
        s.push_str(&format!("\n{line}\n"));
    }
    s
}

/// Replays the bag recorded in `dir` through the node's logic as built from `config` and
/// `overrides`; (commands compared, max deviation), an error when a command lacks its
/// input snapshot or none was compared.
pub fn replay_bag(
    dir: &Path,
    config: &Path,
    overrides: &NodeOverrides,
) -> Result<(usize, f64), DemoError> {
    use crate::ros::replay::{replay, ReplayTopics};
    let bag = crate::bag::Bag::open(dir)?;
    let (_, mut core) = build_core(config, overrides)?;
    let topics = ReplayTopics::for_node(core.config());
    let r = replay(&bag, &mut core, &topics)?;
    if r.unmatched != 0 || r.commands == 0 {
        return Err(DemoError::ReplayIncomplete {
            unmatched: r.unmatched,
            commands: r.commands,
        });
    }
    Ok((r.commands, r.max()))
}

/// Writes `demo.png` (one panel per step: nominal grey, executed in colour), `demo.md` and
/// `demo.csv` into the settings' output directory.
pub fn write(
    s: &DemoSettings,
    p: &Prepared,
    run: &Run,
    report: &Report,
) -> Result<Written, DemoError> {
    let figure = s.out.join("demo.png");
    write_figure(&figure, p, &run.results)?;
    let markdown = s.out.join("demo.md");
    std::fs::write(&markdown, &report.markdown).map_err(DemoError::io("writing", &markdown))?;
    let csv = s.out.join("demo.csv");
    std::fs::write(&csv, &report.csv).map_err(DemoError::io("writing", &csv))?;
    Ok(Written {
        markdown,
        csv,
        figure,
    })
}

/// The figure: one panel per step, in table order, captioned with its condition.
fn write_figure(png: &Path, p: &Prepared, results: &[StepResult]) -> Result<(), DemoError> {
    let kin = &p.robot.kinematics;
    let arm_dim = kin.chains().first().map_or(2, |c| c.task.dim());
    let view = p.cfg.eval.view.unwrap_or(XY_VIEW);
    let panels: Vec<PathPanel> = results
        .iter()
        .zip(&p.steps)
        .enumerate()
        .map(|(i, (r, s))| {
            PathPanel::single(
                s.nominal.m,
                arm_dim,
                view,
                s.nominal.x.clone(),
                r.path.clone(),
                format!("{}. {}", i + 1, condition_label(&s.condition)),
            )
        })
        .collect();
    let fig = PathFigure {
        executed_name: "executed over DDS".into(),
        ..PathFigure::for_robot(
            format!(
                "crossym demo: {} on {}, demonstration {}, closed loop through the node",
                file_name(&p.policy_path),
                kin.robot,
                p.demo
            ),
            kin,
            &p.cfg.eval,
        )
    };
    write_paths_grid(png, &fig, &panels, panels.len().min(5), 360).map_err(|message| {
        DemoError::Figure {
            path: png.to_path_buf(),
            message,
        }
    })
}
