//! Whether a policy fits the node: its joints, task features and the barrier's chains
//! against the robot, and the node's default condition against the conditions it was
//! trained on. Checked once, when a [`NodeCore`](super::NodeCore) is built.

use crossym_math::kinematics::Kinematics;
use crossym_policy::{AnyPolicy, ConditionDomain};

use super::config::NodeConfig;
use super::error::NodeError;
use crate::safety::SafetySettings;

/// The node's policy for `kin`: a canonicalised or task-head network wrapped as such, its
/// joints and task features checked against the robot, and the chains the end-effector
/// distance barrier of `safety` needs.
pub(super) fn checked_policy(
    policy: AnyPolicy,
    kin: &Kinematics,
    safety: &SafetySettings,
) -> Result<AnyPolicy, NodeError> {
    let policy = match policy {
        AnyPolicy::Plain(p) if p.meta.canonicalised.is_some() || p.meta.task_head.is_some() => {
            AnyPolicy::new(*p, kin).map_err(|message| NodeError::Policy {
                message: message.to_string(),
            })?
        }
        other => other,
    };
    let n = kin.dof();
    if policy.dim() != n {
        return Err(NodeError::Policy {
            message: format!("policy has {} joints, robot controls {n}", policy.dim()),
        });
    }
    let names = &policy.network().meta.joint_names;
    // A task head's network is named by task coordinates, checked when it was built.
    if policy.task_head().is_none() && !names.is_empty() && names.as_slice() != kin.joint_names() {
        return Err(NodeError::Policy {
            message: format!(
                "policy joints {:?} differ from the robot's {:?}",
                names,
                kin.joint_names()
            ),
        });
    }
    if let Some(t) = policy.network().task_features() {
        t.check_kinematics(kin)
            .map_err(|message| NodeError::Policy {
                message: message.to_string(),
            })?;
    }
    if safety.min_ee_distance.is_some() {
        let c = kin.chains();
        if c.len() != 2 || c[0].task.dim() != c[1].task.dim() {
            return Err(NodeError::Config {
                field: "safety.min_ee_distance",
                message: format!(
                    "needs exactly two chains of equal task dimension, robot has {}",
                    c.len()
                ),
            });
        }
    }
    Ok(policy)
}

/// The conditions the policy was trained on (its sidecar's record), unless `cfg` accepts
/// untrained ones; the default condition must lie inside.
pub(super) fn checked_domain(
    cfg: &NodeConfig,
    policy: &AnyPolicy,
) -> Result<Option<ConditionDomain>, NodeError> {
    let domain = cfg
        .condition_domain(policy)
        .map_err(|m| NodeError::Policy {
            message: format!("the sidecar's training record: {m}"),
        })?;
    if let Some(d) = &domain {
        if let Err(part) = d.check(&cfg.default_condition) {
            return Err(NodeError::Config {
                field: "default_condition",
                message: format!(
                    "{:?}: {part} lies outside the policy's trained conditions ({}); \
                     set accept_untrained_conditions = true to allow it",
                    cfg.default_condition,
                    d.describe()
                ),
            });
        }
    }
    Ok(domain)
}
