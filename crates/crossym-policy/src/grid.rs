//! Finite grids of symmetry conditions `s = (θ, λ, σ)` of the composed group
//! `G_MRT = (SO(2) × S) ⋊ C2` (paper Sec. VI-A) and the sub-groups compared in Table II:
//! what a policy was trained on (its [`ConditionDomain`](crate::ConditionDomain)) and what
//! the augmentation and evaluation iterate over.

use serde::{Deserialize, Serialize};

use crate::error::GridError;
use crossym_math::symmetry::compose::Condition;

/// A finite grid of conditions `s = (θ, λ, σ)`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroupGrid {
    /// Rotation step Δθ (degrees): θ = kΔθ ∈ [−180°, 180°]; absent → θ = 0 only.
    #[serde(default)]
    pub rotation_step_deg: Option<f64>,
    /// Scaling factors λ (> 0); absent → `[1.0]`.
    #[serde(default = "one")]
    pub scales: Vec<f64>,
    /// Include the reflection σ = −1.
    #[serde(default)]
    pub reflection: bool,
    /// Largest |θ| kept from the rotation grid (degrees); absent → 180°.
    #[serde(default)]
    pub max_rotation_deg: Option<f64>,
    /// An explicit list of conditions `[θ (degrees), λ, σ]` instead of a grid.
    #[serde(default)]
    pub conditions: Option<Vec<[f64; 3]>>,
}

fn one() -> Vec<f64> {
    vec![1.0]
}

impl GroupGrid {
    /// The identity-only grid (no augmentation).
    pub fn identity() -> Self {
        Self {
            rotation_step_deg: None,
            scales: one(),
            reflection: false,
            max_rotation_deg: None,
            conditions: None,
        }
    }

    /// Checks steps and scales; says what is wrong.
    pub fn validate(&self) -> Result<(), GridError> {
        if let Some(list) = &self.conditions {
            if self.rotation_step_deg.is_some()
                || self.reflection
                || self.max_rotation_deg.is_some()
                || self.scales != one()
            {
                return Err(GridError::ConditionsAndGrid);
            }
            if list.is_empty() {
                return Err(GridError::NoConditions);
            }
            for c in self.conditions() {
                c.validate().map_err(|e| GridError::Condition {
                    message: e.to_string(),
                })?;
            }
            return Ok(());
        }
        if let Some(m) = self.max_rotation_deg {
            if !(m.is_finite() && m >= 0.0) {
                return Err(GridError::MaxRotation {
                    max_rotation_deg: m,
                });
            }
        }
        if let Some(d) = self.rotation_step_deg {
            if !(d.is_finite() && d > 0.0 && d <= 180.0) {
                return Err(GridError::RotationStep {
                    rotation_step_deg: d,
                });
            }
        }
        if self.scales.is_empty() || self.scales.iter().any(|l| !(l.is_finite() && *l > 0.0)) {
            return Err(GridError::Scales {
                scales: self.scales.clone(),
            });
        }
        Ok(())
    }

    /// The rotation angles (rad), ascending, always containing 0.
    pub fn angles(&self) -> Vec<f64> {
        if self.conditions.is_some() {
            let mut a: Vec<f64> = self.conditions().iter().map(|c| c.theta).collect();
            a.push(0.0);
            a.sort_by(f64::total_cmp);
            a.dedup();
            return a;
        }
        match self.rotation_step_deg {
            None => vec![0.0],
            Some(d) => {
                let max = self.max_rotation_deg.unwrap_or(180.0).min(180.0);
                let k = (max / d + 1e-9).floor() as i64;
                (-k..=k).map(|i| (i as f64 * d).to_radians()).collect()
            }
        }
    }

    /// The scaling factors used by the grid (or the explicit list), ascending.
    pub fn scales_used(&self) -> Vec<f64> {
        if self.conditions.is_some() {
            let mut s: Vec<f64> = self.conditions().iter().map(|c| c.scale).collect();
            s.sort_by(f64::total_cmp);
            s.dedup();
            return s;
        }
        self.scales.clone()
    }

    /// All conditions of the grid, in (σ, λ, θ) order (or the explicit list, in its order).
    pub fn conditions(&self) -> Vec<Condition> {
        if let Some(list) = &self.conditions {
            return list
                .iter()
                .map(|[t, l, s]| Condition {
                    theta: t.to_radians(),
                    scale: *l,
                    reflection: if *s < 0.0 {
                        -1
                    } else if *s > 0.0 {
                        1
                    } else {
                        0
                    },
                })
                .collect();
        }
        let sigmas: &[i8] = if self.reflection { &[1, -1] } else { &[1] };
        let mut out = Vec::new();
        for &reflection in sigmas {
            for &scale in &self.scales {
                for theta in self.angles() {
                    out.push(Condition {
                        theta,
                        scale,
                        reflection,
                    });
                }
            }
        }
        out
    }
}

/// The sub-groups of `G_MRT` compared in Table II.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum SubGroup {
    /// No augmentation (`Original`).
    Identity,
    /// Rotations only (`G_R`).
    R,
    /// Rotations and scalings (`G_RT`).
    RT,
    /// The full composition (`G_MRT`).
    MRT,
}

impl SubGroup {
    /// All four, in Table II order.
    pub const ALL: [Self; 4] = [Self::Identity, Self::R, Self::RT, Self::MRT];

    /// Table label.
    pub fn label(self) -> &'static str {
        match self {
            Self::Identity => "Original",
            Self::R => "G_R",
            Self::RT => "G_RT",
            Self::MRT => "G_MRT",
        }
    }

    /// Parses `identity`/`original`, `R`, `RT`, `MRT` (case-insensitive).
    pub fn parse(s: &str) -> Option<Self> {
        match s.to_ascii_lowercase().as_str() {
            "identity" | "original" | "none" => Some(Self::Identity),
            "r" | "g_r" => Some(Self::R),
            "rt" | "g_rt" => Some(Self::RT),
            "mrt" | "g_mrt" => Some(Self::MRT),
            _ => None,
        }
    }
}

impl SubGroup {
    /// True when `c` belongs to this sub-group (given that it is on the full grid).
    pub fn contains(self, c: &Condition) -> bool {
        match self {
            Self::Identity => c.theta == 0.0 && c.scale == 1.0 && c.reflection == 1,
            Self::R => c.scale == 1.0 && c.reflection == 1,
            Self::RT => c.reflection == 1,
            Self::MRT => true,
        }
    }
}

impl GroupGrid {
    /// The grid restricted to a sub-group: `R` keeps rotations, `RT` adds scalings, `MRT` all.
    pub fn restrict(&self, g: SubGroup) -> Self {
        if let Some(list) = &self.conditions {
            let kept: Vec<[f64; 3]> = list
                .iter()
                .zip(self.conditions())
                .filter(|(_, c)| g.contains(c))
                .map(|(raw, _)| *raw)
                .collect();
            return Self {
                conditions: Some(kept),
                ..Self::identity()
            };
        }
        match g {
            SubGroup::Identity => Self::identity(),
            SubGroup::R => Self {
                rotation_step_deg: self.rotation_step_deg,
                max_rotation_deg: self.max_rotation_deg,
                ..Self::identity()
            },
            SubGroup::RT => Self {
                reflection: false,
                ..self.clone()
            },
            SubGroup::MRT => self.clone(),
        }
    }
}
