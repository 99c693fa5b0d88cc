//! Demonstrations recorded as rosbag2 bags (`[demonstrations]` with `bag` sources): each
//! source read by joint name ([`super::recording`]) and cleaned ([`super::clean`]) into
//! uniformly sampled `(q, q̇)` demonstrations, with a per-source report.
//!
//! ```toml
//! [demonstrations]
//! dt = 0.01                         # s, the resampling step
//! train = ["pick_1", "pick_2"]
//! test = ["pick_3"]
//! [[demonstrations.sources]]
//! name = "pick_1"
//! bag = "recordings/pick_1"         # rosbag2 directory (metadata.yaml + .mcap or .db3)
//! topic = "/joint_states"           # default
//! stamps = "header"                 # or "receive"
//! [demonstrations.cleaning]          # optional, defaults shown
//! max_gap_s = 0.1
//! idle_speed = 0.02
//! differentiator = { kind = "savitzky_golay", half_window = 7, order = 2 }
//! ```
//!
//! A source split at idle periods (`split_idle_s`) yields `name`, `name#2`, `name#3`, …;
//! `train` / `test` may name either the source (all its segments) or one segment.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::clean::{clean, CleanConfig, CleanDemo, CleanReport};
use super::recording::{open_joint_states, JointRecording, StampSource};
use crate::kinematics::Kinematics;

/// One `[[demonstrations.sources]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceConfig {
    /// Name used by `train` / `test`.
    pub name: String,
    /// rosbag2 directory, `.mcap` or `.db3` (relative to the config file).
    pub bag: PathBuf,
    /// `sensor_msgs/msg/JointState` topic.
    #[serde(default = "d_topic")]
    pub topic: String,
    /// Sample times from the header stamp or the receive time.
    #[serde(default)]
    pub stamps: StampSource,
}

fn d_topic() -> String {
    "/joint_states".into()
}

/// `[demonstrations]`: recorded demonstrations and how they are cleaned.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DemonstrationsConfig {
    /// Resampling step Δt (s).
    pub dt: f64,
    /// Training demonstrations (source or segment names).
    #[serde(default)]
    pub train: Vec<String>,
    /// Test demonstrations (source or segment names).
    #[serde(default)]
    pub test: Vec<String>,
    /// How recordings are cleaned (`[demonstrations.cleaning]`; defaults when absent).
    #[serde(default)]
    pub cleaning: CleanConfig,
    /// The sources.
    #[serde(default)]
    pub sources: Vec<SourceConfig>,
}

impl DemonstrationsConfig {
    /// Checks settings, unique source names, and that `train` / `test` name sources (or
    /// segments `name#k` of one).
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
        }
        for n in self.train.iter().chain(&self.test) {
            let base = n.split('#').next().unwrap_or(n);
            if !seen.contains(base) {
                return Err(format!(
                    "train/test name `{n}` is not a source (sources: {})",
                    seen.iter().copied().collect::<Vec<_>>().join(", ")
                ));
            }
        }
        Ok(())
    }
}

/// One source after reading and cleaning.
#[derive(Debug, Clone)]
pub struct LoadedSource {
    /// The source's name.
    pub name: String,
    /// The storage file read.
    pub file: PathBuf,
    /// Raw samples and duration (s) of the recording.
    pub raw: (usize, f64),
    /// Joints in the messages that are not configured (ignored).
    pub ignored: Vec<String>,
    /// The clean demonstrations, named `name` or `name#k`.
    pub demos: Vec<(String, CleanDemo)>,
    /// What cleaning did.
    pub report: CleanReport,
}

/// Reads and cleans every source of `cfg` for `kin`'s joints, bag paths mapped by
/// `resolve` (relative to the config file: [`crate::config::Config::resolve`]). A source
/// that fails does not stop the others: each gets its `Result`, the error text naming the
/// bag and the problem.
pub fn load_sources(
    cfg: &DemonstrationsConfig,
    resolve: impl Fn(&Path) -> PathBuf,
    kin: &Kinematics,
) -> Vec<(String, Result<LoadedSource, String>)> {
    let joints = kin.joint_names();
    cfg.sources
        .iter()
        .map(|s| {
            let r = open_joint_states(&resolve(&s.bag), &s.topic, joints, s.stamps)
                .map_err(|e| e.to_string())
                .and_then(|rec: JointRecording| {
                    let (demos, report) = clean(&rec, cfg.dt, &cfg.cleaning, Some(kin.limits()))
                        .map_err(|e| format!("{}: {e}", rec.bag.display()))?;
                    let names = (0..demos.len()).map(|k| {
                        if k == 0 {
                            s.name.clone()
                        } else {
                            format!("{}#{}", s.name, k + 1)
                        }
                    });
                    Ok(LoadedSource {
                        name: s.name.clone(),
                        file: rec.bag.clone(),
                        raw: (rec.len(), rec.duration()),
                        ignored: rec.ignored.clone(),
                        demos: names.zip(demos).collect(),
                        report,
                    })
                });
            (s.name.clone(), r)
        })
        .collect()
}
