//! The faults the mock hardware injects (`[mock_hw] fault`).

use serde::{Deserialize, Serialize};

/// A fault injected after `fault_after_s`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FaultKind {
    /// The state stops changing; joint states keep being published (stuck encoders).
    Frozen,
    /// No more joint states are published (driver crash, cable).
    Silent,
    /// The `fault_joint`'s published position is NaN (encoder fault); commands are still
    /// integrated.
    NanPosition,
    /// The `fault_joint` is left out of the published message (a driver dropping a
    /// joint); commands are still integrated.
    MissingJoint,
}
