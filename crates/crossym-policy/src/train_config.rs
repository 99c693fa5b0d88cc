//! `[train]`: the network architecture and optimisation settings of `crossym_learn::train::train`,
//! validated once; a trained policy records them ([`super::PolicyMeta::train_config`]).

use serde::{Deserialize, Serialize};

use super::activation::Activation;
use super::error::PolicyError;

/// Learning-rate schedule over the iterations.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LrSchedule {
    /// The learning rate stays at [`TrainConfig::learning_rate`].
    Constant,
    /// Cosine decay from [`TrainConfig::learning_rate`] to `final_learning_rate`.
    Cosine {
        /// Learning rate reached at the last iteration (dimensionless, > 0).
        final_learning_rate: f64,
    },
}

impl Default for LrSchedule {
    fn default() -> Self {
        LrSchedule::Cosine {
            final_learning_rate: 1e-5,
        }
    }
}

impl LrSchedule {
    /// Learning rate at 0-based iteration `k` of `total`, starting from `lr0`.
    pub fn at(&self, lr0: f64, k: usize, total: usize) -> f64 {
        match *self {
            LrSchedule::Constant => lr0,
            LrSchedule::Cosine {
                final_learning_rate: f,
            } => {
                let p = if total == 0 {
                    0.0
                } else {
                    k as f64 / total as f64
                };
                f + 0.5 * (lr0 - f) * (1.0 + (std::f64::consts::PI * p).cos())
            }
        }
    }
}

fn d_hidden() -> Vec<usize> {
    vec![256, 256, 256]
}
fn d_horizon() -> usize {
    10
}
fn d_velocity_weight() -> f64 {
    1.0
}
fn d_lr() -> f64 {
    1e-3
}
fn d_iterations() -> usize {
    2000
}
fn d_batch() -> usize {
    256
}
fn d_log_every() -> usize {
    10
}

/// `[train]`: network architecture and optimisation settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainConfig {
    /// Hidden-layer widths.
    #[serde(default = "d_hidden")]
    pub hidden: Vec<usize>,
    /// Hidden-layer nonlinearity.
    #[serde(default)]
    pub activation: Activation,
    /// Rollout horizon `H` (steps; each window spans `H + 1` samples).
    #[serde(default = "d_horizon")]
    pub horizon: usize,
    /// Weight `w_v` of the velocity term (dimensionless, ≥ 0).
    #[serde(default = "d_velocity_weight")]
    pub velocity_weight: f64,
    /// Initial Adam learning rate (> 0).
    #[serde(default = "d_lr")]
    pub learning_rate: f64,
    /// Learning-rate schedule.
    #[serde(default)]
    pub lr_schedule: LrSchedule,
    /// Number of optimiser steps (0 returns the initial network).
    #[serde(default = "d_iterations")]
    pub iterations: usize,
    /// Windows per batch `B` (> 0).
    #[serde(default = "d_batch")]
    pub batch_size: usize,
    /// Seed of the weight initialisation and the window sampler.
    #[serde(default)]
    pub seed: u64,
    /// Call the progress callback every this many iterations (> 0).
    #[serde(default = "d_log_every")]
    pub log_every: usize,
    /// Samples between consecutive window points (≥ 1): the rollout steps by
    /// `stride · Δt`, so a window spans `horizon · stride` samples.
    #[serde(default = "d_one")]
    pub stride: usize,
    /// Horizon at the first iteration (0: no curriculum); grows linearly to `horizon` over
    /// the first `curriculum_fraction` of the iterations.
    #[serde(default)]
    pub horizon_start: usize,
    /// Fraction of the iterations over which the horizon grows (in `[0, 1]`).
    #[serde(default)]
    pub curriculum_fraction: f64,
    /// Std of the Gaussian noise added to each window's start state (normalised units,
    /// ≥ 0): the rollout must return to the demonstration (DART-like).
    #[serde(default)]
    pub start_noise: f64,
    /// AdamW weight decay (≥ 0).
    #[serde(default)]
    pub weight_decay: f64,
    /// Let windows run past a trajectory's end, holding its last sample (CONDOR's
    /// padding): every sample starts a window and the policy learns to stop at the goal.
    #[serde(default)]
    pub pad_end: bool,
    /// Also feed the network the canonical task-space point `x̃ = g(s)⁻¹ f(q)`
    /// ([`super::canonical`]), differentiated through the FK in the rollout; needs
    /// `crossym_learn::train::train_with_features`.
    #[serde(default)]
    pub task_features: bool,
    /// Members of an averaged ensemble (≥ 1): trained from seeds `seed`, `seed + 1`, … on
    /// the same data and merged into one network computing their mean output
    /// ([`MlpInference::average`](super::MlpInference::average); hidden layers `ensemble ×` as wide).
    #[serde(default = "d_one")]
    pub ensemble: usize,
}

fn d_one() -> usize {
    1
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            hidden: d_hidden(),
            activation: Activation::default(),
            horizon: d_horizon(),
            velocity_weight: d_velocity_weight(),
            learning_rate: d_lr(),
            lr_schedule: LrSchedule::default(),
            iterations: d_iterations(),
            batch_size: d_batch(),
            seed: 0,
            log_every: d_log_every(),
            stride: 1,
            horizon_start: 0,
            curriculum_fraction: 0.0,
            start_noise: 0.0,
            weight_decay: 0.0,
            pad_end: false,
            task_features: false,
            ensemble: 1,
        }
    }
}

impl TrainConfig {
    /// Rollout horizon at 0-based iteration `k`: `horizon_start` growing linearly to
    /// `horizon` over the first `curriculum_fraction` of the iterations (no curriculum
    /// when `horizon_start` is 0).
    pub fn horizon_at(&self, k: usize) -> usize {
        let ramp = self.curriculum_fraction * self.iterations as f64;
        if self.horizon_start == 0 || ramp < 1.0 || k as f64 >= ramp {
            return self.horizon;
        }
        let p = k as f64 / ramp;
        let h0 = self.horizon_start as f64;
        (h0 + p * (self.horizon as f64 - h0)).round() as usize
    }

    /// Checks every field's domain.
    pub fn validate(&self) -> Result<(), PolicyError> {
        let bad = |field: &str, message: String| {
            Err(PolicyError::Config {
                field: field.into(),
                message,
            })
        };
        if let Some(l) = self.hidden.iter().position(|&h| h == 0) {
            return bad("hidden", format!("layer {l} has width 0"));
        }
        if self.horizon == 0 {
            return bad("horizon", "must be at least 1".into());
        }
        if !(self.velocity_weight.is_finite() && self.velocity_weight >= 0.0) {
            return bad(
                "velocity_weight",
                format!("{} must be finite and ≥ 0", self.velocity_weight),
            );
        }
        if !(self.learning_rate.is_finite() && self.learning_rate > 0.0) {
            return bad(
                "learning_rate",
                format!("{} must be positive", self.learning_rate),
            );
        }
        if let LrSchedule::Cosine {
            final_learning_rate: f,
        } = self.lr_schedule
        {
            if !(f.is_finite() && f > 0.0) {
                return bad(
                    "lr_schedule.final_learning_rate",
                    format!("{f} must be positive"),
                );
            }
        }
        if self.ensemble == 0 {
            return bad("ensemble", "must be at least 1".into());
        }
        if self.batch_size == 0 {
            return bad("batch_size", "must be at least 1".into());
        }
        if self.log_every == 0 {
            return bad("log_every", "must be at least 1".into());
        }
        if self.stride == 0 {
            return bad("stride", "must be at least 1".into());
        }
        if self.horizon_start > self.horizon {
            return bad(
                "horizon_start",
                format!("{} exceeds horizon {}", self.horizon_start, self.horizon),
            );
        }
        if !(0.0..=1.0).contains(&self.curriculum_fraction) {
            return bad(
                "curriculum_fraction",
                format!("{} must be in [0, 1]", self.curriculum_fraction),
            );
        }
        for (field, v) in [
            ("start_noise", self.start_noise),
            ("weight_decay", self.weight_decay),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return bad(field, format!("{v} must be finite and ≥ 0"));
            }
        }
        Ok(())
    }
}
