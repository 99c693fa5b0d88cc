//! The conditions a policy was trained on: its *condition domain*.
//!
//! A policy `π(q, s)` learned from demonstrations augmented with a grid of group elements
//! `s = (θ, λ, σ)` (paper Sec. V, eq. 23) has seen the conditions of that grid only. Between
//! grid points it interpolates; outside their range it extrapolates, and a policy trained
//! without scalings or without the reflection has never seen `λ ≠ 1` or `σ = −1` at all
//! (Table II: such policies are an order of magnitude worse there and mostly diverge).
//!
//! The domain is the box spanned by the training grid restricted to the policy's sub-group:
//! `|wrap(θ)| ≤ θ_max` (the whole circle when the grid reaches ±180°), `λ ∈ [λ_min, λ_max]`,
//! and `σ = −1` only when the grid holds the reflection. It is read from the sidecar's
//! `symmetry` record (`{"group": …, "grid": …}`, written by `crossym train`); a policy
//! without that record (hand-made or synthetic) has no domain and accepts every valid
//! condition.

use std::f64::consts::PI;

use crate::grid::{GroupGrid, SubGroup};
use crossym_math::symmetry::compose::Condition;
use crossym_math::symmetry::transfer::lift::wrap_angle as wrap;

use crate::PolicyMeta;

/// Relative slack on the domain's bounds (floating-point round-off of grid values).
const SLACK: f64 = 1e-9;

/// The box of conditions a policy was trained on (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConditionDomain {
    /// Largest `|θ|` trained on (rad); `≥ π` means the whole circle.
    pub max_abs_theta: f64,
    /// Smallest scaling factor trained on.
    pub scale_min: f64,
    /// Largest scaling factor trained on.
    pub scale_max: f64,
    /// Whether the reflection `σ = −1` was trained on.
    pub reflection: bool,
}

/// Which part of a condition lies outside a [`ConditionDomain`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DomainViolation {
    /// `|θ|` beyond the trained range.
    Theta,
    /// `λ` outside the trained range.
    Scale,
    /// `σ = −1` for a policy trained without the reflection.
    Reflection,
}

impl std::fmt::Display for DomainViolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Theta => "θ",
            Self::Scale => "λ",
            Self::Reflection => "the reflection σ = −1",
        })
    }
}

impl ConditionDomain {
    /// The bounding box of `conditions` (non-empty, each valid).
    pub fn spanning(conditions: &[Condition]) -> Option<Self> {
        let first = conditions.first()?;
        let mut d = Self {
            max_abs_theta: wrap(first.theta).abs(),
            scale_min: first.scale,
            scale_max: first.scale,
            reflection: first.reflection == -1,
        };
        for c in &conditions[1..] {
            d.max_abs_theta = d.max_abs_theta.max(wrap(c.theta).abs());
            d.scale_min = d.scale_min.min(c.scale);
            d.scale_max = d.scale_max.max(c.scale);
            d.reflection |= c.reflection == -1;
        }
        Some(d)
    }

    /// The domain recorded in a policy's metadata: `Ok(None)` when the sidecar has no
    /// `symmetry.group`/`symmetry.grid` record; an error when the record is malformed.
    pub fn from_meta(meta: &PolicyMeta) -> Result<Option<Self>, String> {
        let sym = &meta.symmetry;
        let (Some(group), Some(grid)) = (sym.get("group"), sym.get("grid")) else {
            return Ok(None);
        };
        let label = group
            .as_str()
            .ok_or_else(|| format!("symmetry.group {group} is not a string"))?;
        let g = SubGroup::parse(label).ok_or_else(|| {
            format!("symmetry.group `{label}` is not Original, G_R, G_RT or G_MRT")
        })?;
        let grid = if grid.is_null() {
            GroupGrid::identity()
        } else {
            serde_json::from_value::<GroupGrid>(grid.clone())
                .map_err(|e| format!("symmetry.grid: {e}"))?
        };
        grid.validate().map_err(|e| format!("symmetry.grid: {e}"))?;
        let conditions = grid.restrict(g).conditions();
        Self::spanning(&conditions)
            .map(Some)
            .ok_or_else(|| format!("symmetry.grid holds no condition of {label}"))
    }

    /// Checks a valid condition against the domain; allocation-free.
    pub fn check(&self, s: &Condition) -> Result<(), DomainViolation> {
        if self.max_abs_theta < PI - SLACK && wrap(s.theta).abs() > self.max_abs_theta + SLACK {
            return Err(DomainViolation::Theta);
        }
        if s.scale < self.scale_min * (1.0 - SLACK) || s.scale > self.scale_max * (1.0 + SLACK) {
            return Err(DomainViolation::Scale);
        }
        if s.reflection == -1 && !self.reflection {
            return Err(DomainViolation::Reflection);
        }
        Ok(())
    }

    /// Human-readable box, e.g. `θ ∈ [−60°, 60°], λ ∈ [0.5, 1], σ ∈ {1, −1}` (degrees).
    pub fn describe(&self) -> String {
        let theta = if self.max_abs_theta >= PI - SLACK {
            "any θ".to_string()
        } else if self.max_abs_theta <= SLACK {
            "θ = 0°".to_string()
        } else {
            let d = format!("{:.3}", self.max_abs_theta.to_degrees());
            let d = d.trim_end_matches('0').trim_end_matches('.');
            format!("θ ∈ [−{d}°, {d}°]")
        };
        let scale = if self.scale_min == self.scale_max {
            format!("λ = {}", self.scale_min)
        } else {
            format!("λ ∈ [{}, {}]", self.scale_min, self.scale_max)
        };
        let sigma = if self.reflection {
            "σ ∈ {1, −1}"
        } else {
            "σ = 1"
        };
        format!("{theta}, {scale}, {sigma}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(group: &str, grid: serde_json::Value) -> PolicyMeta {
        PolicyMeta::new(
            "r",
            vec![],
            serde_json::json!({"group": group, "order": ["M", "R", "S"], "grid": grid}),
        )
    }

    fn c(theta_deg: f64, scale: f64, reflection: i8) -> Condition {
        Condition {
            theta: theta_deg.to_radians(),
            scale,
            reflection,
        }
    }

    #[test]
    fn sub_groups_of_the_letter_grid() {
        let grid = serde_json::json!({"rotation_step_deg": 30.0,
            "scales": [0.5, 0.6, 0.7, 0.8, 0.9, 1.0], "reflection": true});
        let mrt = ConditionDomain::from_meta(&meta("G_MRT", grid.clone()))
            .unwrap()
            .unwrap();
        assert_eq!(mrt.describe(), "any θ, λ ∈ [0.5, 1], σ ∈ {1, −1}");
        for ok in [
            c(0.0, 1.0, 1),
            c(179.0, 0.5, -1),
            c(-200.0, 0.75, -1),
            c(400.0, 1.0, 1),
        ] {
            assert_eq!(mrt.check(&ok), Ok(()), "{ok:?}");
        }
        assert_eq!(mrt.check(&c(0.0, 0.45, 1)), Err(DomainViolation::Scale));
        assert_eq!(mrt.check(&c(0.0, 1.2, -1)), Err(DomainViolation::Scale));
        assert_eq!(DomainViolation::Scale.to_string(), "λ");

        let r = ConditionDomain::from_meta(&meta("G_R", grid.clone()))
            .unwrap()
            .unwrap();
        assert_eq!(r.describe(), "any θ, λ = 1, σ = 1");
        assert_eq!(r.check(&c(90.0, 1.0, 1)), Ok(()));
        assert_eq!(r.check(&c(90.0, 0.7, 1)), Err(DomainViolation::Scale));
        assert_eq!(r.check(&c(90.0, 1.0, -1)), Err(DomainViolation::Reflection));

        let id = ConditionDomain::from_meta(&meta("Original", grid))
            .unwrap()
            .unwrap();
        assert_eq!(id.describe(), "θ = 0°, λ = 1, σ = 1");
        assert_eq!(id.check(&Condition::IDENTITY), Ok(()));
        assert_eq!(
            id.check(&c(360.0, 1.0, 1)),
            Ok(()),
            "a full turn is the identity"
        );
        assert_eq!(id.check(&c(15.0, 1.0, 1)), Err(DomainViolation::Theta));
    }

    #[test]
    fn limited_rotation_grid_and_explicit_lists() {
        let pan = serde_json::json!({"rotation_step_deg": 10.0, "max_rotation_deg": 60.0,
            "reflection": true});
        let d = ConditionDomain::from_meta(&meta("G_MRT", pan))
            .unwrap()
            .unwrap();
        assert_eq!(d.describe(), "θ ∈ [−60°, 60°], λ = 1, σ ∈ {1, −1}");
        assert_eq!(d.check(&c(-60.0, 1.0, -1)), Ok(()));
        assert_eq!(d.check(&c(61.0, 1.0, 1)), Err(DomainViolation::Theta));
        assert_eq!(d.check(&c(-300.0, 1.0, 1)), Ok(()), "−300° is +60°");

        let list = serde_json::json!({"conditions": [[0.0, 1.0, 1.0], [45.0, 0.8, -1.0]]});
        let d = ConditionDomain::from_meta(&meta("G_MRT", list))
            .unwrap()
            .unwrap();
        assert_eq!(d.check(&c(30.0, 0.9, -1)), Ok(()));
        assert_eq!(d.check(&c(50.0, 0.9, 1)), Err(DomainViolation::Theta));
    }

    #[test]
    fn missing_and_malformed_records() {
        let none = PolicyMeta::new("r", vec![], serde_json::Value::Null);
        assert_eq!(ConditionDomain::from_meta(&none), Ok(None));
        let e = ConditionDomain::from_meta(&meta("G_XYZ", serde_json::Value::Null)).unwrap_err();
        assert!(e.contains("G_XYZ"), "{e}");
        let e = ConditionDomain::from_meta(&meta("G_R", serde_json::json!({"scales": [-1.0]})))
            .unwrap_err();
        assert!(e.contains("symmetry.grid") && e.contains("scales"), "{e}");
        let e =
            ConditionDomain::from_meta(&meta("G_R", serde_json::json!({"bogus": 1}))).unwrap_err();
        assert!(e.contains("bogus"), "{e}");
        // No grid record (config without [augmentation]): the identity grid.
        let d = ConditionDomain::from_meta(&meta("G_MRT", serde_json::Value::Null))
            .unwrap()
            .unwrap();
        assert_eq!(d.describe(), "θ = 0°, λ = 1, σ = 1");
    }
}
