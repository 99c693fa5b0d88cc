//! Why the mock hardware cannot start.

/// Why the mock hardware cannot start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum MockHwError {
    /// A `[mock_hw]` setting is out of its domain.
    #[error("{message}")]
    Setting {
        /// What is wrong (names the key and its value).
        message: String,
    },
    /// The robot does not fit: joint counts, a controlled joint the URDF does not move, a
    /// non-finite start.
    #[error("{message}")]
    Robot {
        /// What is wrong (names the joint).
        message: String,
    },
}

impl MockHwError {
    pub(super) fn setting(message: String) -> Self {
        Self::Setting { message }
    }
    pub(super) fn robot(message: String) -> Self {
        Self::Robot { message }
    }
}
