//! The errors that stop the node process.

use crate::dds::DdsError;

/// Errors that stop the node process.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeRunError {
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The async runtime or a thread could not start.
    #[error("runtime: {message}")]
    Runtime {
        /// What failed.
        message: String,
    },
}
