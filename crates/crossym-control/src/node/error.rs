//! Why a node could not be built from its settings and policy.

use crate::safety::SafetyError;

/// Setup errors of the node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeError {
    /// A `[node]` setting is out of its domain.
    #[error("invalid node setting `{field}`: {message}")]
    Config {
        /// Configuration key.
        field: &'static str,
        /// Why.
        message: String,
    },
    /// The policy does not fit the robot's controlled joints.
    #[error("policy does not fit the robot: {message}")]
    Policy {
        /// What differs.
        message: String,
    },
    /// The safety filter could not be built.
    #[error(transparent)]
    Safety {
        /// Filter error.
        #[from]
        source: SafetyError,
    },
}
