//! Input encoding and normalisation of the symmetry-conditioned policy `π(q, s) → q̇`.
//!
//! With per-joint statistics of the training set (`μ` mean and `σ_q` std of `q`, `v` RMS
//! of `q̇`, each floored at [`STD_FLOOR`]) the network sees
//!
//! `u = [ (q − μ) ⊘ σ_q ,  cos θ,  sin θ,  ln λ,  σ ] ∈ ℝⁿ⁺⁴`
//!
//! and predicts the normalised velocity `y = q̇ ⊘ v ∈ ℝⁿ`, so `q̇ = v ⊙ y`.
//!
//! - `θ` enters through `(cos θ, sin θ)`: continuous across `±π`, where the rotation group
//!   wraps, so the conditions `θ = π` and `θ = −π` (the same group element) coincide.
//! - `λ` is log-encoded: `ln λ` is the scaling group's additive parameter (the lifted flow
//!   is `Φ_S(ln λ, ·)`, eq. 18), the identity maps to 0, and the paper's grid
//!   `λ ∈ [0.5, 1]` becomes `[−0.69, 0]`, evenly spaced in the group's own coordinate.
//! - `σ ∈ {1, −1}` is used as is.
//!
//! In normalised coordinates `z = (q − μ) ⊘ σ_q` the Euler step `q_{k+1} = q_k + Δt q̇_k`
//! reads `z_{k+1} = z_k + Δt g ⊙ y_k` with gain `g = v ⊘ σ_q` ([`Normalizer::gain`]):
//! training rolls out in `z`, and the rollout is exactly the physical one mapped affinely.

use serde::{Deserialize, Serialize};

use super::error::PolicyError;
use super::error::PolicyFitError;
use crate::trajectory::JointTrajectory;
use crossym_math::symmetry::compose::Condition;

/// Number of condition features appended to the normalised joint positions.
pub const CONDITION_FEATURES: usize = 4;

/// Floor on every std and RMS statistic (rad, rad/s): keeps a joint that never moves in
/// the data from dividing by zero.
pub const STD_FLOOR: f64 = 1e-3;

/// Writes the condition features `[cos θ, sin θ, ln λ, σ]` into `out[..4]` (dimensionless).
#[inline]
pub fn encode_condition(s: &Condition, out: &mut [f64]) {
    out[0] = s.theta.cos();
    out[1] = s.theta.sin();
    out[2] = s.scale.ln();
    out[3] = f64::from(s.reflection);
}

/// Per-joint affine normalisation of positions and velocities, fitted on training data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Normalizer {
    /// Mean joint position `μ` (rad).
    pub q_mean: Vec<f64>,
    /// Joint-position std `σ_q`, floored at [`STD_FLOOR`] (rad).
    pub q_std: Vec<f64>,
    /// Joint-velocity RMS `v`, floored at [`STD_FLOOR`] (rad/s).
    pub v_scale: Vec<f64>,
}

impl Normalizer {
    /// The identity normalisation for `n` joints (`μ = 0`, `σ_q = v = 1`).
    pub fn identity(n: usize) -> Self {
        Self {
            q_mean: vec![0.0; n],
            q_std: vec![1.0; n],
            v_scale: vec![1.0; n],
        }
    }

    /// Fits `μ`, `σ_q` and `v` over every sample of `trajs` (equal weight per sample;
    /// two passes, so a large mean does not cancel a small spread).
    pub fn fit<'a>(
        trajs: impl IntoIterator<Item = &'a JointTrajectory>,
    ) -> Result<Self, PolicyError> {
        let trajs: Vec<&JointTrajectory> = trajs.into_iter().collect();
        let n = trajs.first().map_or(0, |t| t.n);
        if let Some(t) = trajs.iter().find(|t| t.n != n) {
            return Err(PolicyError::Data {
                message: format!("demonstration {} has {} joints, expected {n}", t.demo, t.n),
            });
        }
        let count: usize = trajs.iter().map(|t| t.len()).sum();
        if n == 0 || count == 0 {
            return Err(PolicyError::Data {
                message: "no samples to fit the normaliser on".into(),
            });
        }
        let c = count as f64;
        let mut out = Self::identity(n);
        let mut var = vec![0.0; n];
        let mut v_sq = vec![0.0; n];
        for t in &trajs {
            for i in 0..t.len() {
                for (j, &q) in t.q(i).iter().enumerate() {
                    out.q_mean[j] += q / c;
                }
            }
        }
        for t in &trajs {
            for i in 0..t.len() {
                for (j, (&q, &v)) in t.q(i).iter().zip(t.qdot(i)).enumerate() {
                    var[j] += (q - out.q_mean[j]).powi(2);
                    v_sq[j] += v * v;
                }
            }
        }
        for j in 0..n {
            out.q_std[j] = (var[j] / c).sqrt().max(STD_FLOOR);
            out.v_scale[j] = (v_sq[j] / c).sqrt().max(STD_FLOOR);
        }
        if let Err(message) = out.validate() {
            return Err(PolicyError::Data {
                message: message.to_string(),
            });
        }
        Ok(out)
    }

    /// Joint-space dimension `n`.
    pub fn dim(&self) -> usize {
        self.q_mean.len()
    }

    /// Network input dimension `n + 4` without task features (see [`super::Policy::input_dim`]).
    pub fn input_dim(&self) -> usize {
        self.dim() + CONDITION_FEATURES
    }

    /// Checks equal lengths, finite means and positive finite scales; says what is wrong.
    pub fn validate(&self) -> Result<(), PolicyFitError> {
        self.validate_inner().map_err(PolicyFitError::features)
    }

    // The checks of [`Self::validate`], failing with a message.
    fn validate_inner(&self) -> Result<(), String> {
        let n = self.q_mean.len();
        if n == 0 {
            return Err("normaliser has zero joints".into());
        }
        if self.q_std.len() != n || self.v_scale.len() != n {
            return Err(format!(
                "lengths differ: q_mean {n}, q_std {}, v_scale {}",
                self.q_std.len(),
                self.v_scale.len()
            ));
        }
        if let Some(j) = self.q_mean.iter().position(|m| !m.is_finite()) {
            return Err(format!("q_mean[{j}] = {} is not finite", self.q_mean[j]));
        }
        for (name, v) in [("q_std", &self.q_std), ("v_scale", &self.v_scale)] {
            if let Some(j) = v.iter().position(|s| !(s.is_finite() && *s > 0.0)) {
                return Err(format!(
                    "{name}[{j}] = {} must be positive and finite",
                    v[j]
                ));
            }
        }
        Ok(())
    }

    /// `z = (q − μ) ⊘ σ_q` (dimensionless); `q`, `out` of length `n`.
    #[inline]
    pub fn normalize_q(&self, q: &[f64], out: &mut [f64]) {
        for j in 0..self.q_mean.len() {
            out[j] = (q[j] - self.q_mean[j]) / self.q_std[j];
        }
    }

    /// `q = μ + σ_q ⊙ z` (rad); `z`, `out` of length `n`.
    #[inline]
    pub fn denormalize_q(&self, z: &[f64], out: &mut [f64]) {
        for j in 0..self.q_mean.len() {
            out[j] = self.q_mean[j] + self.q_std[j] * z[j];
        }
    }

    /// `y = q̇ ⊘ v` (dimensionless); `qdot`, `out` of length `n`.
    #[inline]
    pub fn normalize_qdot(&self, qdot: &[f64], out: &mut [f64]) {
        for j in 0..self.v_scale.len() {
            out[j] = qdot[j] / self.v_scale[j];
        }
    }

    /// `q̇ = v ⊙ y` (rad/s); `y`, `out` of length `n`.
    #[inline]
    pub fn denormalize_qdot(&self, y: &[f64], out: &mut [f64]) {
        for j in 0..self.v_scale.len() {
            out[j] = self.v_scale[j] * y[j];
        }
    }

    /// Gain `g_j = v_j / σ_q,j` (1/s) with `ż = g ⊙ y` in normalised coordinates.
    #[inline]
    pub fn gain(&self, j: usize) -> f64 {
        self.v_scale[j] / self.q_std[j]
    }

    /// Network input `u = [z, cos θ, sin θ, ln λ, σ]` of a policy without task features;
    /// `out` of length `n + 4`.
    #[inline]
    pub fn encode(&self, q: &[f64], s: &Condition, out: &mut [f64]) {
        let n = self.q_mean.len();
        self.normalize_q(q, &mut out[..n]);
        encode_condition(s, &mut out[n..n + CONDITION_FEATURES]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn traj(q: Vec<f64>, qdot: Vec<f64>) -> JointTrajectory {
        JointTrajectory {
            demo: 1,
            n: 2,
            m: 2,
            dt: 0.01,
            x: q.clone(),
            q,
            qdot,
        }
    }

    #[test]
    fn fit_floors_constant_joints_and_encodes() {
        // Joint 0 sits at 1e3 ± 1 (a large mean over a small spread), joint 1 never moves.
        let t = traj(vec![999.0, 2.0, 1001.0, 2.0], vec![3.0, 0.0, -4.0, 0.0]);
        let nz = Normalizer::fit([&t]).unwrap();
        assert_eq!(nz.q_mean, vec![1000.0, 2.0]);
        assert!((nz.q_std[0] - 1.0).abs() < 1e-12);
        assert_eq!(nz.q_std[1], STD_FLOOR);
        assert!((nz.v_scale[0] - 12.5f64.sqrt()).abs() < 1e-12);
        assert_eq!(nz.v_scale[1], STD_FLOOR);
        let mut u = [0.0; 6];
        let s = Condition {
            theta: std::f64::consts::FRAC_PI_2,
            scale: 0.5,
            reflection: -1,
        };
        nz.encode(&[1001.0, 2.0], &s, &mut u);
        assert!((u[0] - 1.0).abs() < 1e-12 && u[1] == 0.0);
        assert!(u[2].abs() < 1e-15 && u[3] == 1.0);
        assert_eq!((u[4], u[5]), (0.5f64.ln(), -1.0));
        let mut y = [0.0; 2];
        nz.normalize_qdot(&[3.0, 0.0], &mut y);
        let mut v = [0.0; 2];
        nz.denormalize_qdot(&y, &mut v);
        assert!((v[0] - 3.0).abs() < 1e-12 && v[1] == 0.0);
    }

    #[test]
    fn fit_rejects_empty_and_mixed_dimensions() {
        assert!(Normalizer::fit(std::iter::empty()).is_err());
        let a = traj(vec![0.0, 0.0], vec![0.0, 0.0]);
        let mut b = a.clone();
        b.n = 1;
        assert!(Normalizer::fit([&a, &b]).is_err());
    }
}
