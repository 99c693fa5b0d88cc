//! Redundancy resolution: a secondary joint motion in the null space of the task Jacobian,
//! added to the horizontal lift without changing the task velocity.
//!
//! The lift `q̇ = J⁺ v` (eq. 13, `J⁺ = M⁻¹Jᵀ(J M⁻¹Jᵀ)⁻¹`) is the minimum-norm joint velocity
//! realising the task velocity `v`; on a redundant arm (RB-Y1: 7 joints for a 3-D point) it
//! leaves the remaining `n − m` directions to drift. The gradient-projection method
//! (Liégeois 1977) adds a secondary velocity `v₀(q)` projected into the null space:
//!
//!   q̇ = J⁺ v + (I − J⁺J) v₀(q) = J⁺ (v − J v₀) + v₀.
//!
//! Where `J` has full row rank, `J J⁺ = I`, so `J q̇ = v` exactly: the task-space velocity,
//! and with it the exact task-space equivariance of a task head, is untouched
//! (`J (I − J⁺J) = 0`). The second form costs one extra `m × n` product and no second
//! solve.
//!
//! **The secondary velocity** is the descent direction `v₀ = −k ∇H` of a posture cost (a
//! gradient rather than a weighted pseudo-inverse or a QP: it keeps the lift's closed form
//! and its cost per tick, works with any metric `M`, and is smooth, so the closed loop stays
//! an ODE the integrators and the safety filter already handle):
//!
//!   H(q) = ½ Σᵢ (qᵢ − rᵢ)² + ½ γ Σᵢ (max(0, lᵢ + bᵢ − qᵢ)² + max(0, qᵢ − uᵢ + bᵢ)²),
//!
//! `r` the rest posture, `[lᵢ, uᵢ]` the position limits, `bᵢ = β (uᵢ − lᵢ)` a band at each
//! limit (β the `limit_band` fraction) inside which the limit term pushes back with relative
//! gain `γ` (`limit_gain`), and `k` the `weight` (1/s). So
//!
//!   v₀ᵢ = k ((rᵢ − qᵢ) + γ (max(0, lᵢ + bᵢ − qᵢ) − max(0, qᵢ − uᵢ + bᵢ))).
//!
//! `H` is C¹ and the push grows linearly with the depth into the band. Joints without
//! finite limits have no limit term. `k = 0` is the plain lift exactly.
//!
//! **Symmetries.** Let `ρ` be a signed permutation of `Q` (`(ρq)ᵢ = sᵢ q_{πᵢ}`, a
//! morphological reflection). If `ρ r = r` and `ρ` maps every joint's limit interval onto its
//! image's (`[l, u]` of joint `πᵢ` times `sᵢ` is `[lᵢ, uᵢ]`), then `H(ρq) = H(q)` and, `ρ`
//! being orthogonal, `v₀(ρq) = ρ v₀(q)`: the term is equivariant under `ρ`
//! ([`NullSpaceTerm::respects`]). It is not equivariant under the continuous task-space
//! symmetries (a rotation of the drawing does not rotate the rest posture); it needs not be
//! for task-space equivariance, which holds for any `v₀` through the projection.

use super::model::JointLimits;
use super::robot::{Kinematics, KinematicsWorkspace};
use serde::{Deserialize, Serialize};

/// Settings of the null-space term (config `[redundancy]`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct NullSpaceSettings {
    /// `k`: gain of the pull toward the rest posture (1/s); 0 turns the term off.
    pub weight: f64,
    /// `β`: width of the band at each limit where the limit term acts, as a fraction of
    /// the joint's range (0 ≤ β < 0.5).
    pub limit_band: f64,
    /// `γ`: gain of the limit term relative to the rest term (≥ 0).
    pub limit_gain: f64,
}

impl Default for NullSpaceSettings {
    fn default() -> Self {
        Self {
            weight: 0.0,
            limit_band: 0.1,
            limit_gain: 10.0,
        }
    }
}

/// A setting or input of the null-space term that cannot be used.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NullSpaceError {
    /// A setting outside its range.
    #[error("[redundancy] {key} = {value}: {why}")]
    Setting {
        /// The setting.
        key: &'static str,
        /// Its value.
        value: f64,
        /// The range it must be in.
        why: &'static str,
    },
    /// The rest posture has the wrong length.
    #[error("the rest posture has {got} joints, the robot {want}")]
    RestLength {
        /// Joints given.
        got: usize,
        /// Joints of the robot.
        want: usize,
    },
    /// A rest joint value is not finite or outside its limits.
    #[error("rest posture joint {joint}: {value} is outside its limits [{lower}, {upper}]")]
    RestOutside {
        /// Index of the joint.
        joint: usize,
        /// Its rest value.
        value: f64,
        /// Lower limit.
        lower: f64,
        /// Upper limit.
        upper: f64,
    },
}

impl NullSpaceSettings {
    /// Checks every setting's range.
    pub fn validate(&self) -> Result<(), NullSpaceError> {
        let bad = |key, value, why| Err(NullSpaceError::Setting { key, value, why });
        if !(self.weight.is_finite() && self.weight >= 0.0) {
            return bad("weight", self.weight, "must be finite and ≥ 0 (1/s)");
        }
        if !(self.limit_band.is_finite() && (0.0..0.5).contains(&self.limit_band)) {
            return bad("limit_band", self.limit_band, "must be in [0, 0.5)");
        }
        if !(self.limit_gain.is_finite() && self.limit_gain >= 0.0) {
            return bad("limit_gain", self.limit_gain, "must be finite and ≥ 0");
        }
        Ok(())
    }

    /// True when the term does something (`weight > 0`).
    pub fn enabled(&self) -> bool {
        self.weight > 0.0
    }
}

/// `v₀ = −k ∇H` toward a rest posture and away from the limits (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct NullSpaceTerm {
    settings: NullSpaceSettings,
    rest: Vec<f64>,
    lower: Vec<f64>,
    upper: Vec<f64>,
    /// `lᵢ + bᵢ` and `uᵢ − bᵢ` (±∞ without finite limits).
    band_lower: Vec<f64>,
    band_upper: Vec<f64>,
}

impl NullSpaceTerm {
    /// The term of `settings` toward `rest` (inside `limits`, one per joint).
    pub fn new(
        settings: NullSpaceSettings,
        rest: &[f64],
        limits: &[JointLimits],
    ) -> Result<Self, NullSpaceError> {
        settings.validate()?;
        if rest.len() != limits.len() {
            return Err(NullSpaceError::RestLength {
                got: rest.len(),
                want: limits.len(),
            });
        }
        let mut t = Self {
            settings,
            rest: rest.to_vec(),
            lower: limits.iter().map(|l| l.lower).collect(),
            upper: limits.iter().map(|l| l.upper).collect(),
            band_lower: Vec::with_capacity(rest.len()),
            band_upper: Vec::with_capacity(rest.len()),
        };
        for (j, (&r, l)) in rest.iter().zip(limits).enumerate() {
            if !(r.is_finite() && l.lower <= r && r <= l.upper) {
                return Err(NullSpaceError::RestOutside {
                    joint: j,
                    value: r,
                    lower: l.lower,
                    upper: l.upper,
                });
            }
            let finite = l.lower.is_finite() && l.upper.is_finite();
            let b = if finite {
                settings.limit_band * (l.upper - l.lower)
            } else {
                0.0
            };
            t.band_lower.push(if finite {
                l.lower + b
            } else {
                f64::NEG_INFINITY
            });
            t.band_upper
                .push(if finite { l.upper - b } else { f64::INFINITY });
        }
        Ok(t)
    }

    /// Its settings.
    pub fn settings(&self) -> &NullSpaceSettings {
        &self.settings
    }

    /// The rest posture `r`.
    pub fn rest(&self) -> &[f64] {
        &self.rest
    }

    /// Number of joints.
    pub fn dim(&self) -> usize {
        self.rest.len()
    }

    /// The posture cost `H(q)` (rad²).
    pub fn cost(&self, q: &[f64]) -> f64 {
        let mut h = 0.0;
        for (i, &x) in q.iter().enumerate() {
            let d = x - self.rest[i];
            let lo = (self.band_lower[i] - x).max(0.0);
            let hi = (x - self.band_upper[i]).max(0.0);
            h += 0.5 * (d * d + self.settings.limit_gain * (lo * lo + hi * hi));
        }
        h
    }

    /// `out = v₀(q) = −k ∇H(q)` (rad/s). Allocation-free.
    pub fn secondary(&self, q: &[f64], out: &mut [f64]) {
        debug_assert!(q.len() == self.dim() && out.len() == self.dim());
        let (k, g) = (self.settings.weight, self.settings.limit_gain);
        for (i, (o, &x)) in out.iter_mut().zip(q).enumerate() {
            let lo = (self.band_lower[i] - x).max(0.0);
            let hi = (x - self.band_upper[i]).max(0.0);
            *o = k * ((self.rest[i] - x) + g * (lo - hi));
        }
    }

    /// True when `H` is invariant under the signed permutation `(ρq)ᵢ = signs[i] q[perm[i]]`
    /// (to `tol`): the rest posture is `ρ`-fixed and `ρ` maps the limits onto themselves, so
    /// `v₀(ρq) = ρ v₀(q)`.
    pub fn respects(&self, perm: &[usize], signs: &[f64], tol: f64) -> bool {
        let n = self.dim();
        if perm.len() != n || signs.len() != n {
            return false;
        }
        let close = |a: f64, b: f64| a == b || (a - b).abs() <= tol;
        (0..n).all(|i| {
            let (j, s) = (perm[i], signs[i]);
            let (lo, hi) = if s > 0.0 {
                (self.lower[j], self.upper[j])
            } else {
                (-self.upper[j], -self.lower[j])
            };
            close(self.rest[i], s * self.rest[j])
                && close(self.lower[i], lo)
                && close(self.upper[i], hi)
        })
    }
}

/// Scratch of [`lift_with_secondary`]: `J v₀` (m) and the corrected task velocity (m).
#[derive(Debug, Clone)]
pub struct SecondaryWorkspace {
    jv0: Vec<f64>,
    v: Vec<f64>,
}

impl SecondaryWorkspace {
    /// Sized for a task space of dimension `m` (allocates; setup only).
    pub fn new(m: usize) -> Self {
        Self {
            jv0: vec![0.0; m],
            v: vec![0.0; m],
        }
    }
}

/// `out = J⁺ (v − J v₀) + v₀ = J⁺ v + (I − J⁺J) v₀` for the Jacobian in `kws.jac`, already
/// factored ([`Kinematics::factor`]). Allocation-free.
pub fn lift_with_secondary(
    kin: &Kinematics,
    kws: &mut KinematicsWorkspace,
    v: &[f64],
    v0: &[f64],
    out: &mut [f64],
    ws: &mut SecondaryWorkspace,
) {
    let (m, n) = kws.jac.shape();
    debug_assert!(v.len() == m && v0.len() == n && out.len() == n);
    // J v₀, column by column (the Jacobian is column-major).
    ws.jv0.fill(0.0);
    for (c, &x) in v0.iter().enumerate() {
        for (r, jv) in ws.jv0.iter_mut().enumerate() {
            *jv += kws.jac[(r, c)] * x;
        }
    }
    for ((w, &vi), &jv) in ws.v.iter_mut().zip(v).zip(&ws.jv0) {
        *w = vi - jv;
    }
    kin.solve(kws, &ws.v, out);
    for (o, &x) in out.iter_mut().zip(v0) {
        *o += x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits(b: &[(f64, f64)]) -> Vec<JointLimits> {
        b.iter()
            .map(|&(lower, upper)| JointLimits {
                lower,
                upper,
                velocity: f64::INFINITY,
                effort: f64::INFINITY,
                acceleration: None,
            })
            .collect()
    }

    fn term(weight: f64) -> NullSpaceTerm {
        NullSpaceTerm::new(
            NullSpaceSettings {
                weight,
                limit_band: 0.1,
                limit_gain: 10.0,
            },
            &[0.0, 0.5, -0.5],
            &limits(&[(-1.0, 1.0), (-2.0, 2.0), (-2.0, 2.0)]),
        )
        .unwrap()
    }

    /// `v₀` is `−k ∇H`: against central differences of [`NullSpaceTerm::cost`], inside the
    /// bands and out of them.
    #[test]
    fn secondary_is_the_negative_gradient_of_the_cost() {
        let t = term(2.0);
        for q in [[0.3, 0.1, -0.2], [0.95, -1.9, 1.75], [-0.85, 1.7, 0.0]] {
            let mut v0 = [0.0; 3];
            t.secondary(&q, &mut v0);
            for i in 0..3 {
                let h = 1e-6;
                let (mut a, mut b) = (q, q);
                a[i] += h;
                b[i] -= h;
                let g = (t.cost(&a) - t.cost(&b)) / (2.0 * h);
                assert!(
                    (v0[i] + 2.0 * g).abs() < 1e-6,
                    "{q:?} joint {i}: {} vs {}",
                    v0[i],
                    -2.0 * g
                );
            }
        }
        // In the upper band of joint 0 (band = 0.2 wide): pushed down harder than the rest
        // pull alone.
        let mut v0 = [0.0; 3];
        t.secondary(&[0.95, 0.5, -0.5], &mut v0);
        assert!(
            (v0[0] - 2.0 * (-0.95 - 10.0 * 0.15)).abs() < 1e-12,
            "{v0:?}"
        );
        assert_eq!(&v0[1..], &[0.0, 0.0]);
    }

    #[test]
    fn bad_settings_and_rest_postures_are_refused() {
        let l = limits(&[(-1.0, 1.0)]);
        let s = |weight, limit_band, limit_gain| NullSpaceSettings {
            weight,
            limit_band,
            limit_gain,
        };
        for bad in [
            s(-1.0, 0.1, 1.0),
            s(f64::NAN, 0.1, 1.0),
            s(1.0, 0.5, 1.0),
            s(1.0, 0.1, -1.0),
        ] {
            let e = NullSpaceTerm::new(bad, &[0.0], &l).unwrap_err();
            assert!(matches!(e, NullSpaceError::Setting { .. }), "{e}");
        }
        let e = NullSpaceTerm::new(s(1.0, 0.1, 1.0), &[1.5], &l).unwrap_err();
        assert!(e.to_string().contains("outside its limits"), "{e}");
        let e = NullSpaceTerm::new(s(1.0, 0.1, 1.0), &[0.0, 0.0], &l).unwrap_err();
        assert!(
            matches!(e, NullSpaceError::RestLength { got: 2, want: 1 }),
            "{e}"
        );
    }

    /// A swap of two joints with a sign flip (a mirror): respected when rest and limits are
    /// mirrored, and then `v₀(ρq) = ρ v₀(q)`; not respected when the rest is not.
    #[test]
    fn a_mirrored_rest_and_limits_make_the_term_equivariant() {
        let l = limits(&[(-1.0, 2.0), (-2.0, 1.0)]);
        let set = NullSpaceSettings {
            weight: 1.5,
            ..NullSpaceSettings::default()
        };
        let (perm, signs) = ([1, 0], [-1.0, -1.0]);
        let t = NullSpaceTerm::new(set, &[0.4, -0.4], &l).unwrap();
        assert!(t.respects(&perm, &signs, 1e-12));
        let rho = |q: &[f64]| [signs[0] * q[perm[0]], signs[1] * q[perm[1]]];
        for q in [[0.3, 0.9], [1.9, -1.95], [-0.95, 0.2]] {
            let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
            t.secondary(&rho(&q), &mut a);
            t.secondary(&q, &mut b);
            let rb = rho(&b);
            assert!((a[0] - rb[0]).abs() < 1e-12 && (a[1] - rb[1]).abs() < 1e-12);
        }
        let off = NullSpaceTerm::new(set, &[0.4, 0.0], &l).unwrap();
        assert!(!off.respects(&perm, &signs, 1e-12));
    }
}
