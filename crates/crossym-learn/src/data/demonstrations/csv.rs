//! CSV sources: a header row, an optional `t` column and either joint columns (a recording,
//! cleaned) or `<chain>.<axis>` task columns (tracked into joint space from `start`).

use std::path::Path;

use super::config::{SourceConfig, SourceKind};
use crate::data::letters::{track, Tracking};
use crate::data::recording::JointRecording;
use crossym_math::kinematics::Kinematics;
use crossym_policy::JointTrajectory;

/// The columns of a CSV source.
pub(super) enum CsvTable {
    /// Joint positions (cleaned like a recording).
    Joints(JointRecording),
    /// Task targets per sample (`m` values; NaN for chains without columns) and the `t`
    /// column if any.
    Task {
        t: Option<Vec<f64>>,
        targets: Vec<Vec<f64>>,
    },
}

/// Parses a CSV source: header, optional `t`, joint columns or `<chain>.<axis>` columns.
pub(super) fn parse_csv(text: &str, file: &Path, kin: &Kinematics) -> Result<CsvTable, String> {
    let f = file.display();
    let (cols, rows) = parse_rows(text, file)?;
    let col = |name: &str| cols.iter().position(|c| *c == name);
    let t = col("t").map(|i| rows.iter().map(|r| r[i]).collect::<Vec<f64>>());
    let joints = kin.joint_names();
    let joint_cols: Vec<Option<usize>> = joints.iter().map(|j| col(j)).collect();
    let task_cols = task_columns(kin, &cols, file)?;
    let any_joint = joint_cols.iter().any(Option::is_some);
    match (any_joint, task_cols.is_empty()) {
        (true, false) => Err(format!(
            "{f}: has both joint and task columns; give one kind"
        )),
        (true, true) => joint_table(file, joints, &joint_cols, &cols, &rows, t),
        (false, false) => {
            let m = kin.task_dim();
            let targets = rows
                .iter()
                .map(|r| {
                    let mut x = vec![f64::NAN; m];
                    for &(c, k) in &task_cols {
                        x[k] = r[c];
                    }
                    x
                })
                .collect();
            Ok(CsvTable::Task { t, targets })
        }
        (false, true) => Err(format!(
            "{f}: no joint columns ({}) and no task columns (`<chain>.x`, …)",
            joints.join(", ")
        )),
    }
}

/// The header's column names and the rows of finite numbers (blank and `#` lines skipped).
fn parse_rows<'a>(text: &'a str, file: &Path) -> Result<(Vec<&'a str>, Vec<Vec<f64>>), String> {
    let f = file.display();
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, l)| (i + 1, l.trim()))
        .filter(|(_, l)| !l.is_empty() && !l.starts_with('#'));
    let (_, header) = lines.next().ok_or_else(|| format!("{f}: empty file"))?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let mut rows: Vec<Vec<f64>> = Vec::new();
    for (ln, l) in lines {
        let vals: Vec<&str> = l.split(',').map(str::trim).collect();
        if vals.len() != cols.len() {
            return Err(format!(
                "{f}:{ln}: {} values, the header has {}",
                vals.len(),
                cols.len()
            ));
        }
        let row = vals
            .iter()
            .zip(&cols)
            .map(|(v, c)| {
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("{f}:{ln}: column `{c}`: `{v}` is not a finite number"))
            })
            .collect::<Result<Vec<f64>, String>>()?;
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(format!("{f}: no samples"));
    }
    Ok((cols, rows))
}

/// Task columns `<chain>.<axis>`: `(csv column, task coordinate)`, all of a chain's or none.
fn task_columns(
    kin: &Kinematics,
    cols: &[&str],
    file: &Path,
) -> Result<Vec<(usize, usize)>, String> {
    let col = |name: &str| cols.iter().position(|c| *c == name);
    let mut task_cols: Vec<(usize, usize)> = Vec::new(); // (csv column, task coordinate)
    for (ci, c) in kin.chains().iter().enumerate() {
        let d = c.task.dim();
        let found: Vec<Option<usize>> = ["x", "y", "z"][..d]
            .iter()
            .map(|a| col(&format!("{}.{a}", c.name)))
            .collect();
        match found.iter().filter(|c| c.is_some()).count() {
            0 => {}
            k if k == d => task_cols.extend(
                found
                    .iter()
                    .enumerate()
                    .map(|(a, i)| (i.expect("all found"), kin.x_offset(ci) + a)),
            ),
            _ => {
                return Err(format!(
                    "{}: chain `{}` needs all of its {d} task columns {}",
                    file.display(),
                    c.name,
                    ["x", "y", "z"][..d]
                        .iter()
                        .map(|a| format!("{}.{a}", c.name))
                        .collect::<Vec<_>>()
                        .join(", ")
                ))
            }
        }
    }
    Ok(task_cols)
}

/// A joint recording from the joint columns (every joint needs one, and `t` is needed).
fn joint_table(
    file: &Path,
    joints: &[String],
    joint_cols: &[Option<usize>],
    cols: &[&str],
    rows: &[Vec<f64>],
    t: Option<Vec<f64>>,
) -> Result<CsvTable, String> {
    let f = file.display();
    if let Some(k) = joint_cols.iter().position(Option::is_none) {
        return Err(format!("{f}: no column for joint `{}`", joints[k]));
    }
    let n = joints.len();
    let mut q = Vec::with_capacity(rows.len() * n);
    for r in rows {
        q.extend(joint_cols.iter().map(|c| r[c.expect("checked")]));
    }
    let used: Vec<usize> = joint_cols.iter().flatten().copied().collect();
    let ignored: Vec<String> = cols
        .iter()
        .enumerate()
        .filter(|(i, c)| !used.contains(i) && **c != "t")
        .map(|(_, c)| c.to_string())
        .collect();
    Ok(CsvTable::Joints(JointRecording {
        bag: file.to_path_buf(),
        topic: "csv".into(),
        joints: joints.to_vec(),
        t: t.ok_or_else(|| format!("{f}: joint columns need a `t` column (s)"))?,
        start_ns: 0,
        q,
        ignored,
    }))
}

/// A task CSV tracked into joint space from `start`; the demonstrations and their largest
/// tracking error (task units).
pub(super) fn csv_task(
    s: &SourceConfig,
    dt: f64,
    file: &Path,
    t: &Option<Vec<f64>>,
    mut targets: Vec<Vec<f64>>,
    kin: &Kinematics,
) -> Result<(Vec<JointTrajectory>, f64), String> {
    let f = file.display();
    if let Some(t) = t {
        if let Some(k) = t
            .windows(2)
            .position(|w| ((w[1] - w[0]) - dt).abs() > 1e-6 * dt.max(1.0))
        {
            return Err(format!(
                "{f}: task columns must be sampled every dt = {dt} s; rows {} and {} are {} s apart",
                k + 1,
                k + 2,
                t[k + 1] - t[k]
            ));
        }
    }
    let start = s
        .start
        .as_ref()
        .ok_or_else(|| format!("{f}: task columns need `start` (a joint posture to track from)"))?;
    if start.len() != kin.dof() || start.iter().any(|v| !v.is_finite()) {
        return Err(format!(
            "`start` needs {} finite joint values, got {}",
            kin.dof(),
            start.len()
        ));
    }
    if !kin.within_limits(start) {
        return Err("`start` is outside the joint limits".into());
    }
    // Chains without columns hold their start position.
    let mut ws = kin.workspace();
    let x0 = kin.forward(start, &mut ws).as_slice().to_vec();
    for x in &mut targets {
        for (v, v0) in x.iter_mut().zip(&x0) {
            if v.is_nan() {
                *v = *v0;
            }
        }
    }
    let [ds, de, js, je] = s.drop_or_default(SourceKind::Csv);
    if targets.len() <= ds + de + 1 {
        return Err(format!("{f}: too few samples after dropping {ds} + {de}"));
    }
    let kept = targets[ds..targets.len() - de].to_vec();
    let tracking = Tracking {
        damping: s.tracking_damping.unwrap_or(1e-3),
        settle_iterations: s.settle_iterations.unwrap_or(0),
        drop_joint: [js, je],
        dt,
    };
    let (demos, max_tracking_error) =
        track(kin, start, &[], &[kept], &tracking).map_err(|e| e.to_string())?;
    Ok((demos, max_tracking_error))
}
