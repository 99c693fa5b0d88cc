//! Settings of discovery and checks ([`TaskInducedSettings`]), validated once.

use super::error::TaskInducedError;

use serde::{Deserialize, Serialize};

use crate::symmetry::field::DEFAULT_FD_STEP;
use crate::symmetry::transfer::flow::FlowSettings;

/// An axis-aligned sampling box in block coordinates (length units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleRegion {
    /// Lower corner.
    pub lower: Vec<f64>,
    /// Upper corner (strictly above `lower` in every coordinate).
    pub upper: Vec<f64>,
}

/// Sample counts, tolerances and flow settings of discovery and checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskInducedSettings {
    /// Points sampled for discovery and, separately, for the checks (at least 16).
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// RNG seed: results are deterministic given the seed.
    #[serde(default)]
    pub seed: u64,
    /// Sampling box; by default centred on the mean of the cost's anchor points with
    /// half-width `max(1, 2 × their largest distance from that mean)` (length units).
    #[serde(default)]
    pub region: Option<SampleRegion>,
    /// Nullspace threshold: singular values of `G` below `nullspace_tol · σ_max` are null.
    #[serde(default = "default_nullspace_tol")]
    pub nullspace_tol: f64,
    /// Rank threshold: singular values of the projected fields below `rank_tol · σ_1` do not count.
    #[serde(default = "default_rank_tol")]
    pub rank_tol: f64,
    /// Max relative invariance residual `|∇c·X| / (|∇c||X|)` accepted.
    #[serde(default = "default_invariance_tol")]
    pub invariance_tol: f64,
    /// Max relative closure residual accepted (see [`TaskInducedReport::closure_residual`](super::TaskInducedReport::closure_residual)).
    #[serde(default = "default_closure_tol")]
    pub closure_tol: f64,
    /// Flow time `T` of the completeness check (flows to `±T`; units of `ξ`).
    #[serde(default = "default_flow_time")]
    pub flow_time: f64,
    /// Number of sampled start points per field in the completeness check.
    #[serde(default = "default_flow_starts")]
    pub flow_starts: usize,
    /// Relative finite-difference step of the Lie bracket.
    #[serde(default = "default_fd_step")]
    pub fd_step: f64,
    /// Integrator settings for the completeness check and the action.
    #[serde(default)]
    pub flow: FlowSettings,
}

fn default_samples() -> usize {
    256
}

fn default_nullspace_tol() -> f64 {
    1e-9
}

fn default_rank_tol() -> f64 {
    1e-6
}

fn default_invariance_tol() -> f64 {
    1e-8
}

fn default_closure_tol() -> f64 {
    1e-6
}

fn default_flow_time() -> f64 {
    10.0
}

fn default_flow_starts() -> usize {
    4
}

fn default_fd_step() -> f64 {
    DEFAULT_FD_STEP
}

impl Default for TaskInducedSettings {
    fn default() -> Self {
        Self {
            samples: default_samples(),
            seed: 0,
            region: None,
            nullspace_tol: default_nullspace_tol(),
            rank_tol: default_rank_tol(),
            invariance_tol: default_invariance_tol(),
            closure_tol: default_closure_tol(),
            flow_time: default_flow_time(),
            flow_starts: default_flow_starts(),
            fd_step: default_fd_step(),
            flow: FlowSettings::default(),
        }
    }
}

fn bad_setting(field: &str, message: String) -> TaskInducedError {
    TaskInducedError::InvalidSetting {
        field: field.into(),
        message,
    }
}

impl TaskInducedSettings {
    /// Checks the settings for `d`-dimensional blocks.
    pub fn validate(&self, dim: usize) -> Result<(), TaskInducedError> {
        if self.samples < 16 {
            return Err(bad_setting(
                "samples",
                format!("{} samples are too few (at least 16)", self.samples),
            ));
        }
        for (name, v) in [
            ("nullspace_tol", self.nullspace_tol),
            ("rank_tol", self.rank_tol),
            ("invariance_tol", self.invariance_tol),
            ("closure_tol", self.closure_tol),
            ("fd_step", self.fd_step),
        ] {
            if !(v > 0.0 && v < 1.0) {
                return Err(bad_setting(name, format!("{v} must be in (0, 1)")));
            }
        }
        if !(self.flow_time > 0.0 && self.flow_time.is_finite()) {
            return Err(bad_setting(
                "flow_time",
                format!("{} must be positive and finite", self.flow_time),
            ));
        }
        self.flow
            .validate()
            .map_err(|m| bad_setting("flow", m.to_string()))?;
        if let Some(r) = &self.region {
            if r.lower.len() != dim || r.upper.len() != dim {
                return Err(bad_setting(
                    "region",
                    format!(
                        "corners {:?}, {:?} must have {dim} coordinates",
                        r.lower, r.upper
                    ),
                ));
            }
            if r.lower
                .iter()
                .zip(&r.upper)
                .any(|(l, u)| !(l.is_finite() && u.is_finite() && u > l))
            {
                return Err(bad_setting(
                    "region",
                    format!(
                        "corners {:?}, {:?} must be finite with upper > lower",
                        r.lower, r.upper
                    ),
                ));
            }
        }
        Ok(())
    }
}
