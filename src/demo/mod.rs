//! `crossym demo` as library calls: mock hardware and the node as child processes, this
//! process as the user publishing symmetry conditions, a per-condition table, a figure of
//! the executed paths and an exact offline replay of the node's recorded bag.
//!
//! The closed loop runs the nominal trajectories `Φ_g(ξ)` of one demonstration `ξ` under
//! each condition `s = (θ, λ, σ)` of the composed group (eq. 23) and compares the task-space
//! RMSE measured over DDS with the RMSE of the same policy rolled out offline
//! ([`crate::eval::score`]): the loop passes when
//! `RMSE_closed ≤ max_ratio · RMSE_offline + max_excess` for every step, the mock hardware
//! saw no limit violation, the node reported no abnormal status and the recorded bag
//! replays bit for bit.
//!
//! The steps, in order (the CLI prints between them):
//!
//! 1. [`prepare`]: settings checked, config, node settings, policy, the conditions (given
//!    ones refused outside a plain policy's trained box, default ones left out), the
//!    scenario steps and their offline scores — no process, no DDS;
//! 2. [`start`]: `mock-hw` and `node` started as children of a `crossym` executable;
//! 3. [`Started::finish`]: the scenario over DDS, the children stopped, the mock
//!    hardware's summary read;
//! 4. [`report()`]: the Markdown table, the CSV, the list of failures (the bag replay check
//!    included), and [`write()`]: the figure and the files.

use std::path::{Path, PathBuf};

use crate::config::ConfigError;
use crate::control::NodeError;
use crate::pipeline::PipelineError;
use crate::policy::DomainViolation;
use crate::setup::{ConditionError, NodeOverrides, NodeSetupError};
use crate::sim::physics::Plant;

mod prepare;
mod processes;
mod report;

pub use prepare::{
    default_conditions, off_grid_conditions, offline_scores, prepare, select_conditions, steps,
    truncated_len, Conditions, Prepared,
};
pub use processes::{start, Run, Started};
pub use report::{replay_bag, report, write, Report, Written};

/// What `crossym demo` runs: the command line's options without the CLI's own
/// (`--no-isolation`).
#[derive(Debug, Clone, PartialEq)]
pub struct DemoSettings {
    /// Config file (TOML) with `[robot]`, `[demonstrations]`, `[[symmetries]]`,
    /// `[composition]`, `[node]`.
    pub config: PathBuf,
    /// Test demonstration to draw (1-based; `None`: the first of `[demonstrations] test`).
    pub demo: Option<usize>,
    /// Conditions `theta_rad:scale:reflection` (empty: [`default_conditions`], and
    /// [`off_grid_conditions`] for a canonicalised policy).
    pub conditions: Vec<String>,
    /// Policy file instead of `[node] policy`.
    pub policy: Option<PathBuf>,
    /// Only the first seconds of each letter (`None`: the whole letter).
    pub duration_s: Option<f64>,
    /// Output directory (`demo.md`, `demo.csv`, `demo.png`, the process logs, the bag).
    pub out: PathBuf,
    /// Largest accepted ratio closed-loop RMSE / offline-rollout RMSE.
    pub max_ratio: f64,
    /// Absolute allowance on top of `max_ratio × offline` (task units); `None`: 0 on the
    /// kinematic mock, 0.01 on the physics robot.
    pub max_excess: Option<f64>,
    /// The robot (`None`: `[mock_hw] plant`).
    pub plant: Option<Plant>,
}

impl DemoSettings {
    /// The command line's defaults for the config file `config`: every condition default,
    /// output `results/demo`, `max_ratio` 1.5.
    pub fn new(config: impl Into<PathBuf>) -> Self {
        Self {
            config: config.into(),
            demo: None,
            conditions: Vec::new(),
            policy: None,
            duration_s: None,
            out: PathBuf::from("results/demo"),
            max_ratio: 1.5,
            max_excess: None,
            plant: None,
        }
    }

    /// Checks the numbers: `max_ratio` finite and positive, `max_excess` finite and `≥ 0`,
    /// `duration_s` positive (where given).
    pub fn validate(&self) -> Result<(), DemoError> {
        let bad = |flag, requirement| Err(DemoError::InvalidSetting { flag, requirement });
        if !(self.max_ratio.is_finite() && self.max_ratio > 0.0) {
            return bad("--max-ratio", "positive");
        }
        if self
            .max_excess
            .is_some_and(|e| !(e.is_finite() && e >= 0.0))
        {
            return bad("--max-excess", "finite and ≥ 0");
        }
        if self.duration_s.is_some_and(|d| d.is_nan() || d <= 0.0) {
            return bad("--duration-s", "positive");
        }
        Ok(())
    }

    /// The node's overrides: the policy, when one is given.
    pub fn overrides(&self) -> NodeOverrides {
        NodeOverrides {
            policy: self.policy.clone(),
            ..NodeOverrides::default()
        }
    }

    /// The node's recording: `out/bag`.
    pub fn bag_dir(&self) -> PathBuf {
        self.out.join("bag")
    }

    /// The mock hardware's summary: `out/mock_hw_summary.json`.
    pub fn summary_path(&self) -> PathBuf {
        self.out.join("mock_hw_summary.json")
    }
}

/// The allowance on top of `max_ratio × offline` when none is given: 0 on the kinematic
/// mock (commands executed exactly), 0.01 on the physics robot (a servo lags a ramp by
/// ≈ 0.1 s, ≈ 1 cm at the hand speeds of the shipped tasks).
pub fn default_max_excess(plant: Plant) -> f64 {
    match plant {
        Plant::Kinematic => 0.0,
        Plant::Mujoco => 0.01,
    }
}

/// Why the demo could not run (a failed check is not an error: see [`Report::failures`]).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DemoError {
    /// A setting is out of range.
    #[error("{flag} must be {requirement}")]
    InvalidSetting {
        /// The command-line flag.
        flag: &'static str,
        /// What it must be.
        requirement: &'static str,
    },
    /// The config file or its robot is broken.
    #[error(transparent)]
    Config {
        /// Config error (names the file).
        #[from]
        source: ConfigError,
    },
    /// The node settings are invalid.
    #[error(transparent)]
    Node {
        /// Node error.
        #[from]
        source: NodeError,
    },
    /// The node's logic could not be rebuilt (bag replay).
    #[error(transparent)]
    Setup {
        /// Setup error.
        #[from]
        source: NodeSetupError,
    },
    /// The demonstrations could not be loaded.
    #[error(transparent)]
    Data {
        /// Data error.
        #[from]
        source: crate::data::DataError,
    },
    /// The policy or the demonstration asked for could not be loaded.
    #[error(transparent)]
    Pipeline {
        /// Pipeline error.
        #[from]
        source: PipelineError,
    },
    /// Neither `[node] policy` nor the settings name a policy.
    #[error("{}: [node] policy is not set", config.display())]
    NoPolicy {
        /// The config file.
        config: PathBuf,
    },
    /// The policy's sidecar records a malformed training grid.
    #[error("policy {}: {message}", policy.display())]
    PolicyDomain {
        /// The policy file.
        policy: PathBuf,
        /// What is malformed.
        message: String,
    },
    /// A condition's text is malformed or invalid.
    #[error(transparent)]
    Condition {
        /// Condition error (names the text).
        #[from]
        source: ConditionError,
    },
    /// A given condition lies outside the plain policy's trained box.
    #[error(
        "--condition `{condition}`: {part} lies outside the conditions the policy was trained \
         on ({domain}); set [node] accept_untrained_conditions = true to let it extrapolate"
    )]
    OutsideDomain {
        /// The condition's text.
        condition: String,
        /// Which part of it lies outside.
        part: DomainViolation,
        /// The trained box ([`crate::policy::ConditionDomain::describe`]).
        domain: String,
    },
    /// Every default condition lies outside the plain policy's trained box.
    #[error("no default condition lies in the policy's trained box ({domain}); give --condition")]
    NoDefaultCondition {
        /// The trained box.
        domain: String,
    },
    /// The nominal trajectories could not be built (symmetries, flows).
    #[error("{message}")]
    Nominal {
        /// What failed.
        message: String,
    },
    /// A file or directory could not be created, read or written.
    #[error("{action} {}", path.display())]
    Io {
        /// `creating`, `reading`, `writing`, `removing`.
        action: &'static str,
        /// The path.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A child process could not be started.
    #[error("starting {name}")]
    Spawn {
        /// `mock-hw` or `node`.
        name: &'static str,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// A child process ended early or would not stop.
    #[error("{name} {message}")]
    Process {
        /// `mock-hw` or `node`.
        name: &'static str,
        /// What happened.
        message: String,
    },
    /// The ROS environment is unusable.
    #[error(transparent)]
    Dds {
        /// DDS error.
        #[from]
        source: crate::ros::dds::DdsError,
    },
    /// The scenario over DDS failed.
    #[error(transparent)]
    Scenario {
        /// Scenario error.
        #[from]
        source: crate::sim::scenario::ScenarioError,
    },
    /// The mock hardware's summary is unreadable.
    #[error("mock-hw summary {}: {message}", path.display())]
    Summary {
        /// The summary file.
        path: PathBuf,
        /// The parser's message.
        message: String,
    },
    /// The recorded bag could not be read or replayed.
    #[error(transparent)]
    Bag {
        /// Bag error.
        #[from]
        source: crate::bag::BagError,
    },
    /// The replay compared no command, or commands without their inputs.
    #[error("{unmatched} commands without their input snapshot, {commands} compared")]
    ReplayIncomplete {
        /// Commands without their input snapshot.
        unmatched: usize,
        /// Commands compared.
        commands: usize,
    },
    /// The figure could not be drawn.
    #[error("{}: {message}", path.display())]
    Figure {
        /// The PNG file.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

impl DemoError {
    /// `Io` for `action` on `path`, as a `map_err` argument.
    fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> Self {
        let path = path.to_path_buf();
        move |source| Self::Io {
            action,
            path,
            source,
        }
    }
}

/// An error with its sources, `outer: inner: …` (as a report line).
fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        s.push_str(&format!(": {inner}"));
        source = inner.source();
    }
    s
}
