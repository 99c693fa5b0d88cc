//! `lerobot` sources: a LeRobot dataset ([`crossym_io::lerobot`]), one demonstration per
//! episode named `<source>#<episode_index>` (`#<episode_index>.<k>` when cleaning splits
//! it at idle periods). The state's `names` are matched to the robot's joints by name —
//! exactly, or with LeRobot's `.pos` suffix (`right_arm_0.pos`) —; names of joints the
//! config does not control (grippers, torso, head) are ignored and listed; a controlled
//! joint without a name is refused. Each episode is then cleaned as a recording
//! ([`crate::data::clean`]: gap refusal, resampling to `dt`, velocities, idle trimming,
//! limit margins), its time the frames' `timestamp`. `episodes` and `task` (a task string of
//! `meta/tasks`) select episodes.

use std::path::{Path, PathBuf};

use super::config::{AngleUnit, DemonstrationsConfig, SourceConfig};
use crate::data::recorded::{load_recording, Recorded};
use crate::data::recording::JointRecording;
use crossym_io::lerobot::{read_states, read_tasks, LeRobotStates};
use crossym_math::kinematics::{JointKind, Kinematics};
use crossym_policy::JointTrajectory;

/// The named demonstrations of a source and what cleaning did to each episode.
pub(super) type Episodes = (Vec<(String, JointTrajectory)>, Vec<(i64, Recorded)>);

/// Reads and cleans the episodes of source `s`.
pub(super) fn load(
    cfg: &DemonstrationsConfig,
    s: &SourceConfig,
    resolve: &impl Fn(&Path) -> PathBuf,
    kin: &Kinematics,
) -> Result<Episodes, String> {
    let dir = resolve(s.dataset.as_deref().expect("checked by resolved_kind"));
    let state = s.state.as_deref().unwrap_or("observation.state");
    let scalars = s.features.clone().unwrap_or_default();
    let data = read_states(&dir, state, &scalars).map_err(|e| e.to_string())?;
    let (cols, ignored) = joint_columns(&data, kin, &dir, state)?;
    let scale = unit_scale(kin, s.units.unwrap_or_default());
    if let Some(want) = &s.episodes {
        check_episodes(want, &data, &dir)?;
    }
    let task_index = task_index(s, &dir)?;
    let width = data.names.len();
    let mut demos = Vec::new();
    let mut reports = Vec::new();
    for ep in &data.episodes {
        if s.episodes.as_ref().is_some_and(|w| !w.contains(&ep.index))
            || task_index.is_some_and(|t| t != ep.task_index)
        {
            continue;
        }
        let t0 = ep.t[0];
        let rec = JointRecording {
            bag: ep.file.clone(),
            topic: format!("episode {}", ep.index),
            joints: kin.joint_names().to_vec(),
            t: ep.t.iter().map(|t| t - t0).collect(),
            start_ns: (t0 * 1e9).round() as i128,
            q: ep
                .state
                .chunks(width)
                .flat_map(|row| cols.iter().zip(&scale).map(|(&c, k)| row[c] * k))
                .collect(),
            ignored: ignored.clone(),
        };
        let (report, d) = load_recording(&rec, cfg.dt, &cfg.cleaning, kin)
            .map_err(|e| format!("episode {}: {e}", ep.index))?;
        let k = d.len();
        for (i, traj) in d.into_iter().enumerate() {
            let name = if k == 1 {
                format!("{}#{}", s.name, ep.index)
            } else {
                format!("{}#{}.{}", s.name, ep.index, i + 1)
            };
            demos.push((name, traj));
        }
        reports.push((ep.index, report));
    }
    if demos.is_empty() {
        return Err(format!("{}: no episode selected", dir.display()));
    }
    Ok((demos, reports))
}

/// The state column of each controlled joint, and the state's other names (sorted).
fn joint_columns(
    data: &LeRobotStates,
    kin: &Kinematics,
    dir: &Path,
    state: &str,
) -> Result<(Vec<usize>, Vec<String>), String> {
    // Column of each controlled joint in the state.
    let column = |joint: &str| {
        data.names
            .iter()
            .position(|n| n == joint || n.strip_suffix(".pos") == Some(joint))
    };
    let mut cols = Vec::with_capacity(kin.dof());
    for j in kin.joint_names() {
        cols.push(column(j).ok_or_else(|| {
            format!(
                "{}: the state `{state}` names no joint `{j}` (names: {})",
                dir.display(),
                data.names.join(", ")
            )
        })?);
    }
    let mut ignored: Vec<String> = data
        .names
        .iter()
        .enumerate()
        .filter(|(i, _)| !cols.contains(i))
        .map(|(_, n)| n.clone())
        .collect();
    ignored.sort();
    Ok((cols, ignored))
}

/// Per controlled joint, the factor to radians (or metres) of the dataset's `units`.
fn unit_scale(kin: &Kinematics, units: AngleUnit) -> Vec<f64> {
    kin.joint_names()
        .iter()
        .map(|j| {
            let revolute = kin
                .model()
                .joint(j)
                .is_ok_and(|m| matches!(m.kind, JointKind::Revolute | JointKind::Continuous));
            match units {
                AngleUnit::Deg if revolute => std::f64::consts::PI / 180.0,
                _ => 1.0,
            }
        })
        .collect()
}

/// Refuses an asked-for episode the dataset does not have.
fn check_episodes(want: &[i64], data: &LeRobotStates, dir: &Path) -> Result<(), String> {
    if let Some(e) = want
        .iter()
        .find(|e| !data.episodes.iter().any(|x| x.index == **e))
    {
        return Err(format!(
            "{}: no episode {e} (episodes: {})",
            dir.display(),
            data.episodes
                .iter()
                .map(|x| x.index.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(())
}

/// `task`: the index of the task whose episodes (by their first frame) are selected.
fn task_index(s: &SourceConfig, dir: &Path) -> Result<Option<i64>, String> {
    match &s.task {
        None => Ok(None),
        Some(want) => {
            let tasks = read_tasks(dir).map_err(|e| e.to_string())?;
            let found = tasks.iter().find(|(_, t)| t == want).map(|(i, _)| *i);
            Ok(Some(found.ok_or_else(|| {
                format!(
                    "{}: no task `{want}` (tasks: {})",
                    dir.display(),
                    tasks
                        .iter()
                        .map(|(_, t)| format!("`{t}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            })?))
        }
    }
}
