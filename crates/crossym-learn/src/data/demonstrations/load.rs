//! Loading `[demonstrations]`: every source read on its own ([`load_each`]), then numbered
//! `1 … N` in source order with the train / test picks resolved ([`Demonstrations`]).

use std::path::{Path, PathBuf};

use super::config::{DemonstrationsConfig, Pick, SourceConfig, SourceKind};
use super::csv::{csv_task, parse_csv, CsvTable};
use crate::data::recorded::{load_recording, Recorded};
use crate::data::recording::{open_joint_states, JointRecording};
use crate::data::DataError;
use crossym_math::kinematics::Kinematics;
use crossym_policy::JointTrajectory;

/// What loading did to one source.
#[derive(Debug, Clone)]
pub enum SourceDetail {
    /// Task-space targets tracked into joint space: the largest tracking error (task units).
    Tracked {
        /// Max `‖f(q_i) − x_i‖` over the kept samples (task units).
        max_tracking_error: f64,
    },
    /// A recording (or joint CSV) read and cleaned.
    Recorded(Recorded),
    /// A LeRobot dataset: each episode read and cleaned (`episode_index`, what cleaning did).
    Episodes(Vec<(i64, Recorded)>),
}

/// One source after loading.
#[derive(Debug, Clone)]
pub struct SourceDemos {
    /// The source's name.
    pub name: String,
    /// Its kind.
    pub kind: SourceKind,
    /// Its demonstrations, named `name` or `name#k`, numbered from 1 within the source.
    pub demos: Vec<(String, JointTrajectory)>,
    /// What loading did.
    pub detail: SourceDetail,
}

/// Every demonstration of `[demonstrations]`, numbered, with the train / test selection.
#[derive(Debug, Clone)]
pub struct Demonstrations {
    /// All demonstrations; `demos[k].demo == k + 1`.
    pub demos: Vec<JointTrajectory>,
    /// Their names (`names[k]` for `demos[k]`).
    pub names: Vec<String>,
    /// The sources, in order, with their reports.
    pub sources: Vec<SourceDemos>,
    /// Max tracking error over tracked sources (task units; 0 without).
    pub max_tracking_error: f64,
    /// Training demonstration numbers.
    pub train: Vec<usize>,
    /// Test demonstration numbers.
    pub test: Vec<usize>,
}

fn invalid(message: impl Into<String>) -> DataError {
    DataError::Invalid {
        message: message.into(),
    }
}

impl Demonstrations {
    /// Loads every source of `cfg` for `kin` (paths mapped by `resolve`, e.g. relative
    /// to the config file); the first source that fails is the error,
    /// naming the source.
    pub fn load(
        cfg: &DemonstrationsConfig,
        resolve: impl Fn(&Path) -> PathBuf,
        kin: &Kinematics,
    ) -> Result<Self, DataError> {
        let mut sources = Vec::new();
        for (_, r) in load_each(cfg, resolve, kin) {
            sources.push(r.map_err(|e| invalid(e.to_string()))?);
        }
        Self::from_sources(cfg, sources)
    }

    /// Numbers the demonstrations of loaded `sources` and resolves `cfg`'s picks.
    pub fn from_sources(
        cfg: &DemonstrationsConfig,
        sources: Vec<SourceDemos>,
    ) -> Result<Self, DataError> {
        let (mut demos, mut names) = (Vec::new(), Vec::new());
        let mut max_err: f64 = 0.0;
        for s in &sources {
            if let SourceDetail::Tracked { max_tracking_error } = s.detail {
                max_err = max_err.max(max_tracking_error);
            }
            for (name, d) in &s.demos {
                let mut d = d.clone();
                d.demo = demos.len() + 1;
                demos.push(d);
                names.push(name.clone());
            }
        }
        let (train, test) = (
            resolve_picks(&cfg.train, &sources, &names)?,
            resolve_picks(&cfg.test, &sources, &names)?,
        );
        Ok(Self {
            demos,
            names,
            sources,
            max_tracking_error: max_err,
            train,
            test,
        })
    }

    /// The demonstrations with the given numbers.
    pub fn select(&self, which: &[usize]) -> Vec<&JointTrajectory> {
        self.demos
            .iter()
            .filter(|d| which.contains(&d.demo))
            .collect()
    }

    /// The name of demonstration number `demo` (1-based; `"–"` when out of range).
    pub fn name(&self, demo: usize) -> &str {
        demo.checked_sub(1)
            .and_then(|k| self.names.get(k))
            .map_or("–", String::as_str)
    }
}

/// Demonstration numbers of `picks`, in order, without repeats.
fn resolve_picks(
    picks: &[Pick],
    sources: &[SourceDemos],
    names: &[String],
) -> Result<Vec<usize>, DataError> {
    let mut out: Vec<usize> = Vec::new();
    for p in picks {
        let found: Vec<usize> = match p {
            Pick::Number(k) if (1..=names.len()).contains(k) => vec![*k],
            Pick::Number(k) => {
                return Err(invalid(format!(
                    "demonstration number {k} not in 1..={}",
                    names.len()
                )))
            }
            Pick::Name(n) => {
                let mut first = 1;
                let mut hits = Vec::new();
                for s in sources {
                    for (k, (dn, _)) in s.demos.iter().enumerate() {
                        if dn == n || &s.name == n {
                            hits.push(first + k);
                        }
                    }
                    first += s.demos.len();
                }
                if hits.is_empty() {
                    return Err(invalid(format!(
                        "no demonstration named `{n}` (have {})",
                        names.join(", ")
                    )));
                }
                hits
            }
        };
        for k in found {
            if !out.contains(&k) {
                out.push(k);
            }
        }
    }
    Ok(out)
}

/// Loads every source of `cfg` on its own: a failing source does not stop the others, its
/// error text names the source, the file and the problem.
pub fn load_each(
    cfg: &DemonstrationsConfig,
    resolve: impl Fn(&Path) -> PathBuf,
    kin: &Kinematics,
) -> Vec<(String, Result<SourceDemos, SourceError>)> {
    cfg.sources
        .iter()
        .map(|s| {
            let r = load_source(cfg, s, &resolve, kin).map_err(|message| SourceError {
                name: s.name.clone(),
                message,
            });
            (s.name.clone(), r)
        })
        .collect()
}

/// Names `name` (one demonstration) or `name#1 … name#k`.
pub(super) fn named(name: &str, demos: Vec<JointTrajectory>) -> Vec<(String, JointTrajectory)> {
    let k = demos.len();
    demos
        .into_iter()
        .enumerate()
        .map(|(i, d)| {
            let n = if k == 1 {
                name.to_string()
            } else {
                format!("{name}#{}", i + 1)
            };
            (n, d)
        })
        .collect()
}

fn load_source(
    cfg: &DemonstrationsConfig,
    s: &SourceConfig,
    resolve: &impl Fn(&Path) -> PathBuf,
    kin: &Kinematics,
) -> Result<SourceDemos, String> {
    let kind = s.resolved_kind().map_err(|e| e.to_string())?;
    #[cfg(not(feature = "lerobot"))]
    if kind == SourceKind::Lerobot {
        return Err(format!(
            "source {:?}: LeRobot datasets are read only by a build with crossym-learn's \
             `lerobot` feature (the crossym binary: `cargo build --release --features teach`)",
            s.name
        ));
    }
    #[cfg(feature = "lerobot")]
    if kind == SourceKind::Lerobot {
        let (demos, episodes) = super::lerobot::load(cfg, s, resolve, kin)?;
        return Ok(SourceDemos {
            name: s.name.clone(),
            kind,
            demos,
            detail: SourceDetail::Episodes(episodes),
        });
    }
    let (demos, detail) = match kind {
        SourceKind::Lasa | SourceKind::Reach => {
            let task = s.letter_task(kind, cfg.dt);
            // Letter paths resolve against the config's directory, as `resolve` does.
            let d = task
                .build(kin, &resolve(Path::new("")))
                .map_err(|e| e.to_string())?;
            (
                d.demos,
                SourceDetail::Tracked {
                    max_tracking_error: d.max_tracking_error,
                },
            )
        }
        SourceKind::Bag => {
            let bag = resolve(s.bag.as_deref().expect("checked by resolved_kind"));
            let topic = s.topic.as_deref().unwrap_or("/joint_states");
            let rec =
                open_joint_states(&bag, topic, kin.joint_names(), s.stamps.unwrap_or_default())
                    .map_err(|e| e.to_string())?;
            recorded(&rec, cfg, kin)?
        }
        SourceKind::Csv => {
            let file = resolve(s.csv.as_deref().expect("checked by resolved_kind"));
            let text = std::fs::read_to_string(&file)
                .map_err(|e| format!("cannot read {}: {e}", file.display()))?;
            match parse_csv(&text, &file, kin)? {
                CsvTable::Joints(rec) => {
                    if s.start.is_some() {
                        return Err(format!(
                            "{}: joint columns: `start` applies to task columns only",
                            file.display()
                        ));
                    }
                    recorded(&rec, cfg, kin)?
                }
                CsvTable::Task { t, targets } => {
                    let (demos, max_tracking_error) = csv_task(s, cfg.dt, &file, &t, targets, kin)?;
                    (demos, SourceDetail::Tracked { max_tracking_error })
                }
            }
        }
        SourceKind::Lerobot => unreachable!("read above"),
    };
    Ok(SourceDemos {
        name: s.name.clone(),
        kind,
        demos: named(&s.name, demos),
        detail,
    })
}

/// A recording cleaned into demonstrations with their task paths.
fn recorded(
    rec: &JointRecording,
    cfg: &DemonstrationsConfig,
    kin: &Kinematics,
) -> Result<(Vec<JointTrajectory>, SourceDetail), String> {
    let (rep, demos) = load_recording(rec, cfg.dt, &cfg.cleaning, kin)?;
    Ok((demos, SourceDetail::Recorded(rep)))
}

/// Why one source could not be loaded ([`load_each`]): the message names the file
/// and the problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("source `{name}`: {message}")]
pub struct SourceError {
    /// The source.
    pub name: String,
    /// What went wrong.
    pub message: String,
}
