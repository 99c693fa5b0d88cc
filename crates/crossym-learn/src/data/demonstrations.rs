//! One demonstration schema for every source (`[demonstrations]`): LASA letters placed in
//! the workspace, synthetic reaches, rosbag2 joint-state recordings and CSV files, each
//! turned into joint-space demonstrations `(q_i, q̇_i, x_i = f(q_i))` sampled every `dt`,
//! numbered `1 … N` in source order and selected for training and testing by number or by
//! name.
//!
//! ```toml
//! [demonstrations]
//! dt = 0.01                          # s: sample period of every demonstration
//! train = ["pick_1", "pick_2"]       # names (a source: all its demonstrations) or numbers
//! test = ["pick_3"]
//! [[demonstrations.sources]]
//! name = "pick_1"
//! bag = "recordings/pick_1"          # rosbag2 directory (metadata.yaml + .mcap or .db3)
//! topic = "/joint_states"            # default
//! ```
//!
//! Source kinds (`kind`, inferred from the keys when absent):
//! - `lasa` (`arms` with a `letter`): the letter task's placement and damped-least-squares
//!   tracking protocol ([`super::letters`]); one demonstration per LASA demonstration.
//! - `reach` (`arms` with `reach`): minimum-jerk reaches tracked the same way.
//! - `bag` (`bag`): a `sensor_msgs/JointState` topic of a rosbag2 bag, MCAP or SQLite3,
//!   read by joint name ([`super::recording`]) and cleaned ([`super::clean`]).
//! - `csv` (`csv`): a header row, an optional `t` column (s) and either one column per
//!   configured joint (joint positions, cleaned like a recording) or `<chain>.x`,
//!   `<chain>.y`(, `<chain>.z`) task columns sampled every `dt` (tracked from `start` like a
//!   letter; chains without columns hold their `start`).
//!
//! A source that yields one demonstration names it after itself; one that yields several
//! (a LASA file, reaches, a recording split at idle periods) names them `name#1 … name#k`.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::clean::CleanConfig;
use super::letters::{track, ArmLetter, JointTrajectory, LetterTaskConfig, Tracking};
use super::recorded::{load_recording, Recorded};
use super::recording::{open_joint_states, JointRecording, StampSource};
use super::DataError;
use crossym_math::kinematics::Kinematics;

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
}

impl SourceKind {
    /// The name used in configs and reports.
    pub fn label(self) -> &'static str {
        match self {
            Self::Lasa => "lasa",
            Self::Reach => "reach",
            Self::Bag => "bag",
            Self::Csv => "csv",
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
    pub fn resolved_kind(&self) -> Result<SourceKind, String> {
        let inferred = if self.bag.is_some() {
            Some(SourceKind::Bag)
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
                return Err(format!(
                    "source `{}`: give `bag`, `csv`, or `arms` with a `letter` or `reach`",
                    self.name
                ))
            }
        };
        let has = |set: bool, key: &str, allowed: bool| -> Result<(), String> {
            if set && !allowed {
                return Err(format!(
                    "source `{}` ({}): `{key}` does not apply",
                    self.name,
                    kind.label()
                ));
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
            Lasa | Reach => self.arms.is_empty().then_some("arms"),
        };
        if let Some(key) = missing {
            return Err(format!(
                "source `{}` ({}): needs `{key}`",
                self.name,
                kind.label()
            ));
        }
        Ok(kind)
    }

    fn drop_or_default(&self, kind: SourceKind) -> [usize; 4] {
        self.drop.unwrap_or(if kind == SourceKind::Lasa {
            [10, 2, 10, 1]
        } else {
            [0, 0, 0, 1]
        })
    }

    /// The letter-task settings of a `lasa` / `reach` source, sampled every `dt` (s).
    fn letter_task(&self, kind: SourceKind, dt: f64) -> LetterTaskConfig {
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
    pub fn validate(&self) -> Result<(), String> {
        self.cleaning.validate(self.dt)?;
        let mut seen = std::collections::BTreeSet::new();
        for s in &self.sources {
            if s.name.is_empty() || s.name.contains('#') {
                return Err(format!("source name `{}`: empty or with `#`", s.name));
            }
            if !seen.insert(s.name.as_str()) {
                return Err(format!("source `{}` is defined twice", s.name));
            }
            s.resolved_kind()?;
        }
        for p in self.train.iter().chain(&self.test) {
            match p {
                Pick::Number(0) => return Err("demonstration numbers start at 1".into()),
                Pick::Number(_) => {}
                Pick::Name(n) => {
                    let base = n.split('#').next().unwrap_or(n);
                    if !seen.contains(base) {
                        return Err(format!(
                            "train/test name `{n}` is not a source (sources: {})",
                            seen.iter().copied().collect::<Vec<_>>().join(", ")
                        ));
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
            sources.push(r.map_err(invalid)?);
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
) -> Vec<(String, Result<SourceDemos, String>)> {
    cfg.sources
        .iter()
        .map(|s| {
            let r =
                load_source(cfg, s, &resolve, kin).map_err(|e| format!("source `{}`: {e}", s.name));
            (s.name.clone(), r)
        })
        .collect()
}

/// Names `name` (one demonstration) or `name#1 … name#k`.
fn named(name: &str, demos: Vec<JointTrajectory>) -> Vec<(String, JointTrajectory)> {
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
    let kind = s.resolved_kind()?;
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
                CsvTable::Task { t, targets } => csv_task(s, cfg.dt, &file, &t, targets, kin)?,
            }
        }
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

/// The columns of a CSV source.
enum CsvTable {
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
fn parse_csv(text: &str, file: &Path, kin: &Kinematics) -> Result<CsvTable, String> {
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
    let col = |name: &str| cols.iter().position(|c| *c == name);
    let t = col("t").map(|i| rows.iter().map(|r| r[i]).collect::<Vec<f64>>());
    let joints = kin.joint_names();
    let joint_cols: Vec<Option<usize>> = joints.iter().map(|j| col(j)).collect();
    // Task columns `<chain>.<axis>`.
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
                    "{f}: chain `{}` needs all of its {d} task columns {}",
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
    let any_joint = joint_cols.iter().any(Option::is_some);
    match (any_joint, task_cols.is_empty()) {
        (true, false) => Err(format!(
            "{f}: has both joint and task columns; give one kind"
        )),
        (true, true) => {
            if let Some(k) = joint_cols.iter().position(Option::is_none) {
                return Err(format!("{f}: no column for joint `{}`", joints[k]));
            }
            let n = joints.len();
            let mut q = Vec::with_capacity(rows.len() * n);
            for r in &rows {
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

/// A task CSV tracked into joint space from `start`.
fn csv_task(
    s: &SourceConfig,
    dt: f64,
    file: &Path,
    t: &Option<Vec<f64>>,
    mut targets: Vec<Vec<f64>>,
    kin: &Kinematics,
) -> Result<(Vec<JointTrajectory>, SourceDetail), String> {
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
    Ok((demos, SourceDetail::Tracked { max_tracking_error }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<DemonstrationsConfig, String> {
        let d: DemonstrationsConfig = toml::from_str(text).map_err(|e| e.to_string())?;
        d.validate()?;
        Ok(d)
    }

    #[test]
    fn kinds_are_inferred_from_keys_and_foreign_keys_are_refused() {
        let d = parse(
            "dt = 0.01\ntrain = [\"a\", 2]\n\
             [[sources]]\nname = \"a\"\nbag = \"rec/a\"\n\
             [[sources]]\nname = \"b\"\ncsv = \"b.csv\"\n\
             [[sources]]\nname = \"c\"\narms = [{ chain = \"left\", rest = [0.0], letter = \"x.mat\" }]\n\
             [[sources]]\nname = \"d\"\narms = [{ chain = \"left\", rest = [0.0], reach = [{ goal = [1.0, 0.0], duration_s = 1.0 }] }]\n",
        )
        .unwrap();
        let kinds: Vec<_> = d
            .sources
            .iter()
            .map(|s| s.resolved_kind().unwrap())
            .collect();
        use SourceKind::*;
        assert_eq!(kinds, [Bag, Csv, Lasa, Reach]);
        assert_eq!(d.train, [Pick::Name("a".into()), Pick::Number(2)]);
        for (text, needle) in [
            (
                "[[sources]]\nname = \"a\"\nbag = \"x\"\nhalf_range = 1.0\n",
                "`half_range` does not apply",
            ),
            (
                "[[sources]]\nname = \"a\"\ncsv = \"x\"\ntopic = \"/j\"\n",
                "`topic` does not apply",
            ),
            ("[[sources]]\nname = \"a\"\nkind = \"bag\"\n", "needs `bag`"),
            ("[[sources]]\nname = \"a\"\n", "give `bag`, `csv`"),
            ("[[sources]]\nname = \"a#1\"\nbag = \"x\"\n", "with `#`"),
            (
                "[[sources]]\nname = \"a\"\nbag = \"x\"\n[[sources]]\nname = \"a\"\nbag = \"y\"\n",
                "twice",
            ),
            (
                "train = [\"z\"]\n[[sources]]\nname = \"a\"\nbag = \"x\"\n",
                "`z` is not a source",
            ),
            (
                "train = [0]\n[[sources]]\nname = \"a\"\nbag = \"x\"\n",
                "start at 1",
            ),
        ] {
            let e = parse(&format!("dt = 0.01\n{text}")).unwrap_err();
            assert!(e.contains(needle), "{text}: {e}");
        }
    }

    fn traj(v: f64) -> JointTrajectory {
        JointTrajectory {
            demo: 0,
            n: 1,
            m: 1,
            dt: 0.01,
            q: vec![v; 3],
            qdot: vec![0.0; 3],
            x: vec![v; 3],
        }
    }

    fn source(name: &str, k: usize) -> SourceDemos {
        SourceDemos {
            name: name.into(),
            kind: SourceKind::Bag,
            demos: named(name, (0..k).map(|i| traj(i as f64)).collect()),
            detail: SourceDetail::Tracked {
                max_tracking_error: 0.0,
            },
        }
    }

    #[test]
    fn picks_resolve_by_number_demonstration_name_and_source_name() {
        let cfg = |train: Vec<Pick>, test: Vec<Pick>| DemonstrationsConfig {
            dt: 0.01,
            train,
            test,
            cleaning: CleanConfig::default(),
            sources: Vec::new(),
        };
        let sources = || vec![source("a", 1), source("b", 3), source("c", 1)];
        let name = |s: &str| Pick::Name(s.into());
        let d = Demonstrations::from_sources(
            &cfg(
                vec![name("b"), name("a"), Pick::Number(2)],
                vec![name("b#3"), Pick::Number(5)],
            ),
            sources(),
        )
        .unwrap();
        assert_eq!(d.names, ["a", "b#1", "b#2", "b#3", "c"]);
        assert_eq!(
            d.demos.iter().map(|t| t.demo).collect::<Vec<_>>(),
            [1, 2, 3, 4, 5]
        );
        // `b` = its three demonstrations; `a`; 2 again is not repeated.
        assert_eq!(d.train, [2, 3, 4, 1]);
        assert_eq!(d.test, [4, 5]);
        assert_eq!(d.name(4), "b#3");
        assert_eq!(d.name(9), "–");
        for bad in [Pick::Number(6), name("b#4"), name("d")] {
            let e = Demonstrations::from_sources(&cfg(vec![bad.clone()], vec![]), sources())
                .unwrap_err()
                .to_string();
            assert!(e.contains(&bad.to_string().replace('`', "")), "{bad}: {e}");
        }
    }
}
