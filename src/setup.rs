//! The floors' objects built from a config file: the node's settings with the command
//! line's overrides ([`node_config`]), the node core ([`node_core`], [`build_core`]), a
//! symmetry condition from its text ([`parse_condition`]) and the stress campaign's robot
//! ([`stress_geometry`]). The floors below take plain values; only this crate reads config
//! files.

use std::path::{Path, PathBuf};

use crossym_control::{NodeConfig, NodeCore, NodeError, OutputMode, Severity, Trigger};
use crossym_math::symmetry::compose::Condition;
use crossym_policy::{Policy, PolicyError};
use crossym_ros::sim::stress::Geometry;

use crate::config::{Config, ConfigError};
use crate::pipeline::{load_any_policy, PipelineError};

/// Why a node could not be built from a config file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeSetupError {
    /// The config file or its robot is broken.
    #[error(transparent)]
    Config {
        /// Config error (names the file).
        #[from]
        source: ConfigError,
    },
    /// Neither `[node] policy` nor an override names a policy.
    #[error("{path}: no policy: set [node] policy or pass --policy")]
    NoPolicy {
        /// The config file.
        path: PathBuf,
    },
    /// The policy file could not be loaded.
    #[error(transparent)]
    Policy {
        /// Policy error (names the file).
        #[from]
        source: PolicyError,
    },
    /// The policy does not fit the config's robot (joints, FK of its task features) or,
    /// canonicalised, its composition.
    #[error(transparent)]
    PolicyFit {
        /// What does not fit (names the file).
        source: PipelineError,
    },
    /// The node settings or the policy do not fit the robot.
    #[error(transparent)]
    Node {
        /// Node error.
        #[from]
        source: NodeError,
    },
    /// The rest posture (`[mock_hw] initial_q` or `[check] reference_q`) does not fit the
    /// robot.
    #[error("{}: rest posture has {values} values for {joints} joints", path.display())]
    RestPosture {
        /// The config file.
        path: PathBuf,
        /// Values given.
        values: usize,
        /// Controlled joints.
        joints: usize,
    },
    /// `[redundancy]` cannot be used with this robot.
    #[error("{}: {source}", path.display())]
    Redundancy {
        /// The config file.
        path: PathBuf,
        /// What is wrong.
        source: crate::kinematics::NullSpaceError,
    },
}

/// Overrides of `[node]` (the command line's `--policy`, `--name`, …); `None` keeps the
/// config's value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeOverrides {
    /// Policy file (`.safetensors`, `.json` sidecar beside it); overrides `[node] policy`.
    pub policy: Option<PathBuf>,
    /// Node name.
    pub name: Option<String>,
    /// Node namespace (starts with `/`).
    pub namespace: Option<String>,
    /// Command output.
    pub output: Option<OutputMode>,
    /// Tick trigger.
    pub trigger: Option<Trigger>,
    /// Control period (s).
    pub period_s: Option<f64>,
    /// Command topic.
    pub command_topic: Option<String>,
    /// Stale timeout for joint states (s).
    pub stale_timeout_s: Option<f64>,
    /// Console and /rosout log level (default: a `crossym=LEVEL` or bare level in
    /// `RUST_LOG`, else `[node] log_level`).
    pub log_level: Option<Severity>,
}

/// `[node]` of `cfg` ([`Config::node_config`], policy path resolved) with the overrides `o`
/// applied and validated. The log level falls back to `RUST_LOG` (a `crossym=LEVEL` or bare
/// level) before `[node] log_level`.
pub fn node_config(cfg: &Config, o: &NodeOverrides) -> Result<NodeConfig, NodeError> {
    let mut n = cfg.node_config();
    if let Some(p) = &o.policy {
        n.policy = Some(p.clone());
    }
    if let Some(v) = &o.name {
        n.name = v.clone();
    }
    if let Some(v) = &o.namespace {
        n.namespace = v.clone();
    }
    if let Some(v) = o.output {
        n.output = v;
    }
    if let Some(v) = o.trigger {
        n.trigger = v;
    }
    if let Some(v) = o.period_s {
        n.period_s = v;
    }
    if let Some(v) = &o.command_topic {
        n.topics.command = v.clone();
    }
    if let Some(v) = o.stale_timeout_s {
        n.stale_timeout_s = v;
    }
    if let Some(l) = o.log_level.or_else(|| {
        std::env::var("RUST_LOG")
            .ok()
            .and_then(|v| Severity::from_rust_log(&v))
    }) {
        n.log_level = l;
    }
    n.validate()?;
    Ok(n)
}

/// The config file at `path` and the node core it builds with the overrides `o`
/// ([`node_config`], then [`node_core`]).
pub fn build_core(path: &Path, o: &NodeOverrides) -> Result<(Config, NodeCore), NodeSetupError> {
    let cfg = Config::from_file(path)?;
    let n = node_config(&cfg, o)?;
    let core = node_core(&cfg, n)?;
    Ok((cfg, core))
}

/// Why the text of a symmetry condition (`theta_rad:scale:reflection`) was refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConditionError {
    /// Not three `:`-separated fields.
    #[error("--condition `{text}`: expected theta_rad:scale:reflection")]
    Format {
        /// The text given.
        text: String,
    },
    /// A field is not a number.
    #[error("{field} in `{text}`: {message}")]
    Number {
        /// `theta`, `scale` or `reflection`.
        field: &'static str,
        /// The text given.
        text: String,
        /// The parser's message.
        message: String,
    },
    /// The numbers do not form a valid condition ([`Condition::validate`]).
    #[error("--condition `{text}`: {message}")]
    Invalid {
        /// The text given.
        text: String,
        /// What is wrong.
        message: String,
    },
}

/// Parses `theta_rad:scale:reflection` (e.g. `0.5236:0.8:-1`) into a validated condition.
pub fn parse_condition(text: &str) -> Result<Condition, ConditionError> {
    let parts: Vec<&str> = text.split(':').collect();
    let [theta, scale, reflection] = parts[..] else {
        return Err(ConditionError::Format { text: text.into() });
    };
    let number = |field: &'static str, e: &dyn std::fmt::Display| ConditionError::Number {
        field,
        text: text.into(),
        message: e.to_string(),
    };
    let c = Condition {
        theta: theta.parse().map_err(|e| number("theta", &e))?,
        scale: scale.parse().map_err(|e| number("scale", &e))?,
        reflection: reflection.parse().map_err(|e| number("reflection", &e))?,
    };
    c.validate().map_err(|e| ConditionError::Invalid {
        text: text.into(),
        message: e.to_string(),
    })?;
    Ok(c)
}

/// Builds the node of a config file: `cfg`'s robot, the policy `node.policy` (already
/// resolved, see [`Config::node_config`]) and `node`'s settings.
pub fn node_core(cfg: &Config, node: NodeConfig) -> Result<NodeCore, NodeSetupError> {
    let policy_path = node
        .policy
        .clone()
        .ok_or_else(|| NodeSetupError::NoPolicy {
            path: cfg.path.clone(),
        })?;
    let robot = cfg.load_robot()?;
    let policy = load_any_policy(cfg, &robot.kinematics, &policy_path).map_err(|e| match e {
        PipelineError::Policy(source) => NodeSetupError::Policy { source },
        source => NodeSetupError::PolicyFit { source },
    })?;
    let safety = node.safety;
    Ok(NodeCore::new(robot.kinematics, policy, safety, node)?)
}

/// The stress campaign's robot `name` from a config file: robot (`[robot]`), node settings
/// and policy (`[node]` with a policy); rest posture from `[mock_hw] initial_q`, else
/// `[check] reference_q`, else zeros.
pub fn stress_geometry(cfg: &Config, name: &str) -> Result<Geometry, NodeSetupError> {
    let robot = cfg.load_robot()?;
    let node = cfg.node_config();
    let path = node
        .policy
        .clone()
        .ok_or_else(|| NodeSetupError::NoPolicy {
            path: cfg.path.clone(),
        })?;
    let policy = Policy::load(&path)?;
    let n = robot.kinematics.dof();
    let rest = cfg
        .mock_hw
        .as_ref()
        .and_then(|m| m.initial_q.clone())
        .or_else(|| cfg.check.reference_q.clone())
        .unwrap_or_else(|| vec![0.0; n]);
    if rest.len() != n {
        return Err(NodeSetupError::RestPosture {
            path: cfg.path.clone(),
            values: rest.len(),
            joints: n,
        });
    }
    // A task head's `[redundancy]` term (rest checked against the robot's limits here; each
    // episode builds it against its own).
    let null_space = cfg
        .null_space_term(&robot.kinematics)
        .map_err(|source| NodeSetupError::Redundancy {
            path: cfg.path.clone(),
            source,
        })?
        .filter(|_| policy.meta.task_head.is_some())
        .map(|t| (*t.settings(), t.rest().to_vec()));
    Ok(Geometry {
        name: name.to_string(),
        kinematics: robot.kinematics,
        policy,
        node,
        rest,
        null_space,
    })
}

/// The endurance run of `cfg` ([`crate::sim::endurance`]): its node core (the config's
/// `[node]`, with `policy` instead of `[node] policy` when given), the start posture
/// (`[mock_hw] initial_q` or `[check] reference_q`), and the settings: the `[augmentation]`
/// test conditions (else the identity) in turn every `condition_period_s`, the drift
/// measured from the `[redundancy]` rest posture (else the start).
pub fn endurance(
    cfg: &Config,
    policy: Option<PathBuf>,
    duration_s: f64,
    condition_period_s: f64,
) -> Result<(NodeCore, Vec<f64>, crate::sim::endurance::EnduranceSettings), NodeSetupError> {
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let start = cfg
        .start_q()
        .filter(|q| q.len() == kin.dof())
        .ok_or_else(|| NodeSetupError::RestPosture {
            path: cfg.path.clone(),
            values: cfg.start_q().map_or(0, |q| q.len()),
            joints: kin.dof(),
        })?;
    let rest = cfg
        .null_space_term(kin)
        .map_err(|source| NodeSetupError::Redundancy {
            path: cfg.path.clone(),
            source,
        })?
        .map_or_else(|| start.clone(), |t| t.rest().to_vec());
    let conditions = cfg
        .augmentation
        .as_ref()
        .map(|g| g.test.conditions())
        .filter(|c| !c.is_empty())
        .unwrap_or_else(|| vec![crate::symmetry::compose::Condition::IDENTITY]);
    let mut node = cfg.node_config();
    if policy.is_some() {
        node.policy = policy;
    }
    let core = node_core(cfg, node)?;
    let settings = crate::sim::endurance::EnduranceSettings {
        duration_s,
        condition_period_s,
        conditions,
        rest,
    };
    Ok((core, start, settings))
}
