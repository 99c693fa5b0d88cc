//! Errors of the policy module: training setup, saving and loading a policy.
//!
//! These are setup errors; the control-loop entry point [`super::Policy::velocity`] never
//! returns one.

use std::path::PathBuf;

/// What can go wrong while training, saving or loading a policy.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PolicyError {
    /// A file could not be read or written.
    #[error("cannot access policy file {path}: {source}")]
    Io {
        /// File that was being read or written.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The JSON sidecar is not valid JSON or does not have the expected fields.
    #[error("malformed policy sidecar {path}: {message}")]
    Sidecar {
        /// Sidecar file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// The sidecar was written by an unsupported format version.
    #[error(
        "policy sidecar {path} has format version {found}, this build reads version {supported}"
    )]
    Version {
        /// Sidecar file.
        path: PathBuf,
        /// Version found in the file.
        found: u32,
        /// Version this build reads.
        supported: u32,
    },
    /// The safetensors file is truncated or its header is malformed.
    #[error("malformed safetensors file {path}: {message}")]
    Weights {
        /// Weights file.
        path: PathBuf,
        /// Parser message.
        message: String,
    },
    /// A tensor named by the layer sizes is absent from the weights file.
    #[error("weights file {path} has no tensor `{tensor}`")]
    MissingTensor {
        /// Weights file.
        path: PathBuf,
        /// Expected tensor name.
        tensor: String,
    },
    /// A tensor's dtype or shape disagrees with the sidecar's layer sizes.
    #[error("weights file {path}: tensor `{tensor}`: expected {expected}, found {found}")]
    Shape {
        /// Weights file.
        path: PathBuf,
        /// Tensor name.
        tensor: String,
        /// Expected dtype and shape.
        expected: String,
        /// Dtype and shape in the file.
        found: String,
    },
    /// A weight is NaN or infinite.
    #[error("weights file {path}: tensor `{tensor}` has a non-finite value at flat index {index}")]
    NonFinite {
        /// Weights file.
        path: PathBuf,
        /// Tensor name.
        tensor: String,
        /// Flat (row-major) index of the first bad value.
        index: usize,
    },
    /// A sidecar field is out of its domain or inconsistent with another one.
    #[error("policy sidecar {path}: `{field}`: {message}")]
    Invalid {
        /// Sidecar file, or `<memory>` for an in-memory policy.
        path: PathBuf,
        /// Offending field.
        field: String,
        /// What is wrong.
        message: String,
    },
    /// A training configuration value is out of its domain.
    #[error("invalid training setting `{field}`: {message}")]
    Config {
        /// Configuration key.
        field: String,
        /// Why it is invalid.
        message: String,
    },
    /// The training data are empty, inconsistent or too short for the horizon.
    #[error("invalid training data: {message}")]
    Data {
        /// What is wrong.
        message: String,
    },
    /// The training loss became NaN or infinite (learning rate too high, bad data scale).
    #[error("training diverged at iteration {iteration}: loss {loss}")]
    Diverged {
        /// Iteration (0-based) whose loss was not finite.
        iteration: usize,
        /// The loss value.
        loss: f64,
    },
    /// The tensor backend failed (out of memory, internal shape error).
    #[error("tensor backend error: {message}")]
    Backend {
        /// candle's message.
        message: String,
    },
}

/// Training's tensor errors (`crossym-learn` trains with candle; this crate runs without
/// it, the conversion only exists when the `candle` feature is on).
#[cfg(feature = "candle")]
impl From<candle_core::Error> for PolicyError {
    fn from(e: candle_core::Error) -> Self {
        PolicyError::Backend {
            message: e.to_string(),
        }
    }
}

/// Why a policy cannot be built or used as given (in memory, whatever file it came from):
/// its network, its input features, its fit to a robot, or its composition. The message
/// says what is wrong; the variant says where.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PolicyFitError {
    /// The network's architecture or weights are inconsistent (widths, shapes, non-finite
    /// values, ensemble members that differ).
    #[error("{message}")]
    Network {
        /// What is wrong.
        message: String,
    },
    /// The input features are inconsistent (normaliser, canonical task features).
    #[error("{message}")]
    Features {
        /// What is wrong.
        message: String,
    },
    /// The policy does not fit the robot's kinematics (joints, chains, FK, task space).
    #[error("{message}")]
    Robot {
        /// What is wrong.
        message: String,
    },
    /// The policy's composition is not the one required.
    #[error("{message}")]
    Composition {
        /// What differs.
        message: String,
    },
}

impl PolicyFitError {
    pub(crate) fn network(message: String) -> Self {
        Self::Network { message }
    }
    pub(crate) fn features(message: String) -> Self {
        Self::Features { message }
    }
    pub(crate) fn robot(message: String) -> Self {
        Self::Robot { message }
    }
    pub(crate) fn composition(message: String) -> Self {
        Self::Composition { message }
    }
}

/// Inside the policy module's own checks, which build messages.
impl From<PolicyFitError> for String {
    fn from(e: PolicyFitError) -> Self {
        e.to_string()
    }
}

/// Why a grid of conditions ([`GroupGrid`](crate::GroupGrid)) is refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GridError {
    /// An explicit list of conditions together with grid settings.
    #[error(
        "`conditions` replaces rotation_step_deg, scales, reflection and \
         max_rotation_deg: give one or the other"
    )]
    ConditionsAndGrid,
    /// An explicit, empty list of conditions.
    #[error("`conditions` is empty")]
    NoConditions,
    /// A condition of the explicit list is out of its domain.
    #[error("{message}")]
    Condition {
        /// What is wrong with it.
        message: String,
    },
    /// The largest rotation is negative or not finite.
    #[error("max_rotation_deg {max_rotation_deg} must be non-negative")]
    MaxRotation {
        /// The setting (degrees).
        max_rotation_deg: f64,
    },
    /// The rotation step is outside `(0, 180]`.
    #[error("rotation_step_deg {rotation_step_deg} must be in (0, 180]")]
    RotationStep {
        /// The setting (degrees).
        rotation_step_deg: f64,
    },
    /// No scale, or a scale that is not positive.
    #[error("scales {scales:?} must be non-empty and positive")]
    Scales {
        /// The setting.
        scales: Vec<f64>,
    },
}
