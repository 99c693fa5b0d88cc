//! The floors' objects built from a config file: the node core ([`node_core`]) and the
//! stress campaign's robot ([`stress_geometry`]). The floors below take plain values; only
//! this crate reads config files.

use std::path::PathBuf;

use crossym_control::{NodeConfig, NodeCore, NodeError};
use crossym_learn::policy::{Policy, PolicyError};
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
pub fn stress_geometry(cfg: &Config, name: &str) -> Result<Geometry, String> {
    let robot = cfg.load_robot().map_err(|e| e.to_string())?;
    let node = cfg.node_config();
    let path = node
        .policy
        .clone()
        .ok_or_else(|| format!("{}: [node] policy is not set", cfg.path.display()))?;
    let policy = Policy::load(&path).map_err(|e| e.to_string())?;
    let n = robot.kinematics.dof();
    let rest = cfg
        .mock_hw
        .as_ref()
        .and_then(|m| m.initial_q.clone())
        .or_else(|| cfg.check.reference_q.clone())
        .unwrap_or_else(|| vec![0.0; n]);
    if rest.len() != n {
        return Err(format!(
            "{}: rest posture has {} values for {n} joints",
            cfg.path.display(),
            rest.len()
        ));
    }
    Ok(Geometry {
        name: name.to_string(),
        kinematics: robot.kinematics,
        policy,
        node,
        rest,
    })
}
