//! The `[demonstrations]` schema: its sources (`[[demonstrations.sources]]`), their kinds
//! and the train / test picks, with the checks that run when a config is read.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::data::clean::{CleanConfig, CleanConfigError};
use crate::data::letters::{ArmLetter, LetterTaskConfig};
use crate::data::recording::StampSource;

/// What a source is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SourceKind {
    /// LASA letters placed in the workspace and tracked into joint space.
    Lasa,
    /// Synthetic minimum-jerk reaches tracked into joint space.
    Reach,
    /// A rosbag2 joint-state recording (MCAP or SQLite3).
    Bag,
    /// A CSV file of joint positions or task positions.
    Csv,
    /// A LeRobot dataset (`LeRobotDataset` v3.0 or v2.1): one demonstration per episode.
    Lerobot,
}

/// The unit of a LeRobot dataset's revolute joint positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AngleUnit {
    /// Radians (the default; what ROS and crossym use).
    #[default]
    Rad,
    /// Degrees (converted to radians on reading; prismatic joints stay in m).
    Deg,
}

impl SourceKind {
    /// The name used in configs and reports.
    pub fn label(self) -> &'static str {
        match self {
            Self::Lasa => "lasa",
            Self::Reach => "reach",
            Self::Bag => "bag",
            Self::Csv => "csv",
            Self::Lerobot => "lerobot",
        }
    }
}

/// A demonstration picked for training or testing: its 1-based number, or a name (a
/// demonstration's, or a source's for all of its demonstrations).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Pick {
    /// Demonstration number (1-based, over all sources in order).
    Number(usize),
    /// A demonstration name (`name` or `name#k`) or a source name.
    Name(String),
}

impl std::fmt::Display for Pick {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Number(n) => write!(f, "{n}"),
            Self::Name(s) => write!(f, "`{s}`"),
        }
    }
}

/// One `[[demonstrations.sources]]` entry (the keys of its kind only).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SourceConfig {
    /// Name used by `train` / `test` and in reports.
    pub name: String,
    /// The kind; inferred from the keys when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kind: Option<SourceKind>,
    /// `bag`: rosbag2 directory, `.mcap` or `.db3` (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bag: Option<PathBuf>,
    /// `bag`: the `sensor_msgs/msg/JointState` topic (default `/joint_states`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub topic: Option<String>,
    /// `bag`: sample times from the header stamp (default) or the receive time.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stamps: Option<StampSource>,
    /// `csv`: the file (relative to the config file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub csv: Option<PathBuf>,
    /// `csv` with task columns: the joint posture tracking starts from (rad, every joint).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub start: Option<Vec<f64>>,
    /// `lerobot`: the dataset directory (holding `meta/info.json`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub dataset: Option<PathBuf>,
    /// `lerobot`: the state feature, a list whose `names` are joints (default
    /// `observation.state`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state: Option<String>,
    /// `lerobot`: one scalar feature per joint instead of a list (e.g. `right_arm_0.pos`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub features: Option<Vec<String>>,
    /// `lerobot`: the episodes to read (`episode_index`); default all.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub episodes: Option<Vec<i64>>,
    /// `lerobot`: only the episodes of this task (the task string of `meta/tasks`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task: Option<String>,
    /// `lerobot`: the unit of revolute joint positions (default `rad`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub units: Option<AngleUnit>,
    /// `lasa` / `reach`: one entry per chain, in the robot's chain order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub arms: Vec<ArmLetter>,
    /// `lasa`: half-width `r` of the normalised letter box (task units; default 1.5).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub half_range: Option<f64>,
    /// Tracked sources: damping `μ` added to `J Jᵀ` (default 1e-3).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tracking_damping: Option<f64>,
    /// Tracked sources: samples dropped at task start, task end, joint start, joint end
    /// (default `[10, 2, 10, 1]` for `lasa`, `[0, 0, 0, 1]` otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drop: Option<[usize; 4]>,
    /// Tracked sources: damped-least-squares iterations towards the first target before
    /// tracking (default 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settle_iterations: Option<usize>,
}

impl SourceConfig {
    /// The source's kind: `kind`, or inferred from its keys; an error when the keys do
    /// not fit the kind.
    pub fn resolved_kind(&self) -> Result<SourceKind, DemonstrationsConfigError> {
        let inferred = if self.bag.is_some() {
            Some(SourceKind::Bag)
        } else if self.dataset.is_some() {
            Some(SourceKind::Lerobot)
        } else if self.csv.is_some() {
            Some(SourceKind::Csv)
        } else if self.arms.iter().any(|a| a.letter.is_some()) {
            Some(SourceKind::Lasa)
        } else if self.arms.iter().any(|a| !a.reach.is_empty()) {
            Some(SourceKind::Reach)
        } else {
            None
        };
        let kind = match (self.kind, inferred) {
            (Some(k), _) => k,
            (None, Some(k)) => k,
            (None, None) => {
                return Err(DemonstrationsConfigError::NoKind {
                    name: self.name.clone(),
                })
            }
        };
        let has = |set: bool,
                   key: &'static str,
                   allowed: bool|
         -> Result<(), DemonstrationsConfigError> {
            if set && !allowed {
                return Err(DemonstrationsConfigError::KeyDoesNotApply {
                    name: self.name.clone(),
                    kind,
                    key,
                });
            }
            Ok(())
        };
        use SourceKind::*;
        let tracked = matches!(kind, Lasa | Reach | Csv);
        has(self.bag.is_some(), "bag", kind == Bag)?;
        has(self.topic.is_some(), "topic", kind == Bag)?;
        has(self.stamps.is_some(), "stamps", kind == Bag)?;
        has(self.csv.is_some(), "csv", kind == Csv)?;
        has(self.start.is_some(), "start", kind == Csv)?;
        has(self.dataset.is_some(), "dataset", kind == Lerobot)?;
        has(self.state.is_some(), "state", kind == Lerobot)?;
        has(self.features.is_some(), "features", kind == Lerobot)?;
        has(self.episodes.is_some(), "episodes", kind == Lerobot)?;
        has(self.units.is_some(), "units", kind == Lerobot)?;
        has(self.task.is_some(), "task", kind == Lerobot)?;
        has(!self.arms.is_empty(), "arms", matches!(kind, Lasa | Reach))?;
        has(self.half_range.is_some(), "half_range", kind == Lasa)?;
        has(self.tracking_damping.is_some(), "tracking_damping", tracked)?;
        has(self.drop.is_some(), "drop", tracked)?;
        has(
            self.settle_iterations.is_some(),
            "settle_iterations",
            tracked,
        )?;
        let missing = match kind {
            Bag => self.bag.is_none().then_some("bag"),
            Csv => self.csv.is_none().then_some("csv"),
            Lerobot => self.dataset.is_none().then_some("dataset"),
            Lasa | Reach => self.arms.is_empty().then_some("arms"),
        };
        if let Some(key) = missing {
            return Err(DemonstrationsConfigError::MissingKey {
                name: self.name.clone(),
                kind,
                key,
            });
        }
        Ok(kind)
    }

    pub(super) fn drop_or_default(&self, kind: SourceKind) -> [usize; 4] {
        self.drop.unwrap_or(if kind == SourceKind::Lasa {
            [10, 2, 10, 1]
        } else {
            [0, 0, 0, 1]
        })
    }

    /// The letter-task settings of a `lasa` / `reach` source, sampled every `dt` (s).
    pub(super) fn letter_task(&self, kind: SourceKind, dt: f64) -> LetterTaskConfig {
        LetterTaskConfig {
            arms: self.arms.clone(),
            half_range: self.half_range.unwrap_or(1.5),
            tracking_damping: self.tracking_damping.unwrap_or(1e-3),
            dt,
            drop: self.drop_or_default(kind),
            train: Vec::new(),
            test: Vec::new(),
            settle_iterations: self.settle_iterations.unwrap_or(0),
        }
    }
}

/// `[demonstrations]`: where demonstrations come from and which train and test.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemonstrationsConfig {
    /// Sample period Δt of every demonstration (s): the resampling step of recordings,
    /// the sample period of letters, reaches and task CSV files.
    pub dt: f64,
    /// Training demonstrations.
    #[serde(default)]
    pub train: Vec<Pick>,
    /// Test demonstrations.
    #[serde(default)]
    pub test: Vec<Pick>,
    /// How recordings and joint CSV files are cleaned (`[demonstrations.cleaning]`).
    #[serde(default)]
    pub cleaning: CleanConfig,
    /// The sources, in demonstration-number order.
    #[serde(default)]
    pub sources: Vec<SourceConfig>,
}

impl DemonstrationsConfig {
    /// Checks settings, source kinds, unique source names, and that `train` / `test` name
    /// sources (or their demonstrations `name#k`) or positive numbers.
    pub fn validate(&self) -> Result<(), DemonstrationsConfigError> {
        self.cleaning.validate(self.dt)?;
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.sources {
            if s.name.is_empty() || s.name.contains('#') {
                return Err(DemonstrationsConfigError::BadName {
                    name: s.name.clone(),
                });
            }
            if !seen.insert(s.name.as_str()) {
                return Err(DemonstrationsConfigError::DuplicateName {
                    name: s.name.clone(),
                });
            }
            s.resolved_kind()?;
        }
        for p in self.train.iter().chain(&self.test) {
            match p {
                Pick::Number(0) => return Err(DemonstrationsConfigError::NumberZero),
                Pick::Number(_) => {}
                Pick::Name(n) => {
                    let base = n.split('#').next().unwrap_or(n);
                    if !seen.contains(base) {
                        return Err(DemonstrationsConfigError::UnknownName {
                            name: n.clone(),
                            sources: seen.iter().map(|s| s.to_string()).collect(),
                        });
                    }
                }
            }
        }
        Ok(())
    }

    /// The `[demonstrations]` equivalent of a legacy `[letters]` section: one source named
    /// `letters`, demonstrations picked by the same numbers.
    pub fn from_letters(l: &LetterTaskConfig) -> Self {
        let is_lasa = l.arms.iter().any(|a| a.letter.is_some());
        Self {
            dt: l.dt,
            train: l.train.iter().map(|&n| Pick::Number(n)).collect(),
            test: l.test.iter().map(|&n| Pick::Number(n)).collect(),
            cleaning: CleanConfig::default(),
            sources: vec![SourceConfig {
                name: "letters".into(),
                arms: l.arms.clone(),
                half_range: is_lasa.then_some(l.half_range),
                tracking_damping: Some(l.tracking_damping),
                drop: Some(l.drop),
                settle_iterations: Some(l.settle_iterations),
                ..SourceConfig::default()
            }],
        }
    }
}

/// Why a `[demonstrations]` section is refused ([`DemonstrationsConfig::validate`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum DemonstrationsConfigError {
    /// A `[demonstrations.cleaning]` setting is out of its domain.
    #[error(transparent)]
    Cleaning {
        /// What is wrong with it.
        #[from]
        source: CleanConfigError,
    },
    /// A source has no `kind` and no key to infer one from.
    #[error("source `{name}`: give `bag`, `csv`, or `arms` with a `letter` or `reach`")]
    NoKind {
        /// The source.
        name: String,
    },
    /// A source has a key of another kind.
    #[error("source `{name}` ({}): `{key}` does not apply", .kind.label())]
    KeyDoesNotApply {
        /// The source.
        name: String,
        /// Its kind.
        kind: SourceKind,
        /// The foreign key.
        key: &'static str,
    },
    /// A source lacks the key its kind needs.
    #[error("source `{name}` ({}): needs `{key}`", .kind.label())]
    MissingKey {
        /// The source.
        name: String,
        /// Its kind.
        kind: SourceKind,
        /// The missing key.
        key: &'static str,
    },
    /// A source name is empty or contains `#`.
    #[error("source name `{name}`: empty or with `#`")]
    BadName {
        /// The name.
        name: String,
    },
    /// Two sources share a name.
    #[error("source `{name}` is defined twice")]
    DuplicateName {
        /// The name.
        name: String,
    },
    /// A train / test pick is the number 0.
    #[error("demonstration numbers start at 1")]
    NumberZero,
    /// A train / test pick names no source.
    #[error("train/test name `{name}` is not a source (sources: {})", .sources.join(", "))]
    UnknownName {
        /// The pick.
        name: String,
        /// The sources' names.
        sources: Vec<String>,
    },
}
