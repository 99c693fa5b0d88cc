//! Symmetry specifications in configuration (`[[symmetries]]`, `[composition]`, `[check]`).
//!
//! ```toml
//! [[symmetries]]
//! name = "M"                       # morphological C2, derived from the URDF (Example 1)
//! group = { kind = "morphological", chains = ["left", "right"], plane_normal = [0.0, 1.0, 0.0] }
//! # or, from the whole tree below the chains' base (joints on the plane map to themselves):
//! # group = { kind = "morphological", whole_body = true, plane_normal = [0.0, 1.0, 0.0] }
//!
//! [[symmetries]]
//! name = "R"                       # SO(2) on task space, lifted to Q (Example 2)
//! group = { kind = "so2" }
//!
//! [[symmetries]]
//! name = "S"                       # uniform scaling about the origin
//! group = { kind = "scaling" }
//!
//! [composition]
//! order = ["M", "R", "S"]          # outer → inner, eq. 23: ρ(σ) Φ_R(θ, Φ_S(λ, q))
//! ```

use serde::{Deserialize, Serialize};

use super::lie::LieGroupSpec;
use super::task_induced::CostSpec;

/// Which group a symmetry is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum GroupSpec {
    /// C2 acting on `Q` by swapping two chains (eq. 4). With `signs` the per-joint `P` is
    /// given by hand; otherwise it is derived from the URDF across the reflection plane
    /// through the base origin with unit normal `plane_normal` (default `[0, 1, 0]`).
    Morphological {
        /// The two chains exchanged (default: the robot's first two).
        #[serde(default)]
        chains: Option<[String; 2]>,
        /// Reflection plane normal in the base frame.
        #[serde(default)]
        plane_normal: Option<[f64; 3]>,
        /// Hand-written `P` (one ±1 per joint of a chain).
        #[serde(default)]
        signs: Option<Vec<f64>>,
        /// Derive `ρ_Q` on all controlled joints from the whole kinematic tree below the
        /// chains' common base (joints paired across the plane or mapped onto themselves,
        /// every link pose checked), instead of the swap of two chains.
        #[serde(default)]
        whole_body: bool,
    },
    /// SO(2) in a plane of the task space (`axis` for 3-D task blocks).
    So2 {
        /// Rotation axis (3-D task blocks only).
        #[serde(default)]
        axis: Option<[f64; 3]>,
    },
    /// SO(3) on 3-D task blocks.
    So3,
    /// Uniform scaling.
    Scaling,
    /// Translations along `directions` (all axes when empty).
    Translation {
        /// Directions in block coordinates.
        #[serde(default)]
        directions: Vec<Vec<f64>>,
    },
    /// Task-induced symmetry (eq. 7) of a cost on one task block, applied to every block.
    TaskInduced {
        /// The task cost `c: X → R`.
        cost: CostSpec,
    },
}

impl GroupSpec {
    /// The task-space Lie group, for the continuous kinds.
    pub fn lie(&self) -> Option<LieGroupSpec> {
        match self {
            Self::So2 { axis } => Some(LieGroupSpec::So2 { axis: *axis }),
            Self::So3 => Some(LieGroupSpec::So3),
            Self::Scaling => Some(LieGroupSpec::Scaling),
            Self::Translation { directions } => Some(LieGroupSpec::Translation {
                directions: directions.clone(),
            }),
            Self::Morphological { .. } | Self::TaskInduced { .. } => None,
        }
    }

    /// Human-readable group name (`C2`, `SO(2)`, …).
    pub fn label(&self) -> &'static str {
        match self {
            Self::Morphological { .. } => "C2",
            Self::So2 { .. } => "SO(2)",
            Self::So3 => "SO(3)",
            Self::Scaling => "S",
            Self::Translation { .. } => "T(n)",
            Self::TaskInduced { .. } => "G_T",
        }
    }
}

/// One `[[symmetries]]` entry.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SymmetryConfig {
    /// Short name used in `[composition]` and reports.
    pub name: String,
    /// The group.
    pub group: GroupSpec,
    /// Center of rotations/scalings in task-block coordinates (default: the origin).
    #[serde(default)]
    pub center: Option<Vec<f64>>,
}

/// `[composition]`: which symmetries to compose, outer first (eq. 23).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct CompositionConfig {
    /// Symmetry names, outer → inner.
    #[serde(default)]
    pub order: Vec<String>,
}

fn d_samples() -> usize {
    24
}
fn d_spread() -> f64 {
    0.3
}
fn d_seed() -> u64 {
    7
}

/// `[check]`: where and how densely conditions are tested numerically.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckConfig {
    /// Reference configuration (rad); samples are drawn uniformly within `±spread` of it.
    /// Default: the middle of the joint limits (bounded joints) or 0.
    #[serde(default)]
    pub reference_q: Option<Vec<f64>>,
    /// Number of sampled configurations.
    #[serde(default = "d_samples")]
    pub samples: usize,
    /// Half-width of the sampling box around the reference (rad).
    #[serde(default = "d_spread")]
    pub spread: f64,
    /// RNG seed.
    #[serde(default = "d_seed")]
    pub seed: u64,
    /// Rotation angles (rad) at which lifted SO(2) actions are tested.
    #[serde(default = "d_rot")]
    pub rotation_test: Vec<f64>,
    /// Scaling factors at which lifted scalings are tested.
    #[serde(default = "d_scale")]
    pub scaling_test: Vec<f64>,
    /// Size of the exponential coordinates used for other groups (translations in task
    /// units, SO(3) and task-induced algebra coordinates).
    #[serde(default = "d_step")]
    pub generic_test: f64,
}

fn d_rot() -> Vec<f64> {
    vec![std::f64::consts::FRAC_PI_6, -0.8]
}
fn d_scale() -> Vec<f64> {
    vec![0.7, 0.9]
}
fn d_step() -> f64 {
    0.1
}

impl Default for CheckConfig {
    fn default() -> Self {
        Self {
            reference_q: None,
            samples: d_samples(),
            spread: d_spread(),
            seed: d_seed(),
            rotation_test: d_rot(),
            scaling_test: d_scale(),
            generic_test: d_step(),
        }
    }
}
