//! Slowing down near singular postures, as MoveIt Servo does: with `κ` the worst condition
//! number of the chains' task Jacobians ([`crossym_math::kinematics::conditioning`]), a
//! command that moves toward a singularity is scaled by
//!
//! `f(κ) = clamp((κ_stop − κ) / (κ_stop − κ_slowdown), 0, 1)`
//!
//! — 1 below `slowdown`, falling linearly to 0 at `stop` and beyond — so the command is a
//! continuous function of the posture across the band, with no jump from full speed to
//! zero. Per chain: "toward" is decided by a look-ahead, the chain's `κ` at `q + v Δt` (the
//! command over one period) above its `κ` at `q`; the whole command (every chain, so a
//! bimanual motion stays coordinated) is scaled by the smallest `f` of the chains moving
//! toward their singularity. A command that moves away is not scaled (Servo's rule), so a
//! robot halted at `stop` can leave when the policy points out of the band. Applied to every policy (a task-space head lifts through `J⁺`, whose gain
//! grows like `κ`; a joint-space policy gets the band from the same Jacobian of the
//! controlled chains). Statuses: `DECELERATE_FOR_APPROACHING_SINGULARITY` while scaled,
//! `HALT_FOR_SINGULARITY` at `f = 0`.

use serde::{Deserialize, Serialize};

use crossym_math::kinematics::conditioning::chain_condition_number;
use crossym_math::kinematics::{Kinematics, KinematicsWorkspace};

/// `[node.singularity]`: the band, in condition numbers (dimensionless: the same on any
/// robot).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SingularitySettings {
    /// Off: no scaling (the lift's own singularity check still refuses `κ = ∞`).
    pub enabled: bool,
    /// `κ` at which slowing down starts (MoveIt Servo: `lower_singularity_threshold`).
    pub slowdown: f64,
    /// `κ` at which a command toward the singularity is zero (Servo:
    /// `hard_stop_singularity_threshold`).
    pub stop: f64,
}

impl Default for SingularitySettings {
    fn default() -> Self {
        Self {
            enabled: true,
            slowdown: 17.0,
            stop: 30.0,
        }
    }
}

impl SingularitySettings {
    /// `1 ≤ slowdown < stop`, both finite.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.slowdown.is_finite() && self.stop.is_finite()) {
            return Err(format!(
                "slowdown {} and stop {} must be finite",
                self.slowdown, self.stop
            ));
        }
        if !(1.0 <= self.slowdown && self.slowdown < self.stop) {
            return Err(format!(
                "need 1 <= slowdown < stop (condition numbers), got slowdown {} and stop {}",
                self.slowdown, self.stop
            ));
        }
        Ok(())
    }

    /// `f(κ)` (module docs).
    pub fn factor(&self, kappa: f64) -> f64 {
        if !self.enabled {
            return 1.0;
        }
        if kappa.is_nan() {
            return 1.0;
        }
        ((self.stop - kappa) / (self.stop - self.slowdown)).clamp(0.0, 1.0)
    }
}

/// What the band did on a tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SingularityStatus {
    /// Below `slowdown`, moving away, or the band is off: unscaled.
    Clear,
    /// Scaled by `0 < f < 1`.
    Decelerate,
    /// `f = 0`: the command toward the singularity is zero.
    Halt,
}

/// The band's outcome on a tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SingularityReport {
    /// What it did.
    pub status: SingularityStatus,
    /// The factor applied (1 when clear).
    pub factor: f64,
    /// `κ` at the measured posture (the worst chain).
    pub condition: f64,
}

/// The band with its look-ahead workspace (allocated once).
pub struct SingularityBand {
    settings: SingularitySettings,
    ws: KinematicsWorkspace,
    q_next: Vec<f64>,
    kappa: Vec<f64>,
    last: SingularityReport,
}

impl SingularityBand {
    /// The band for `kin` (allocates the look-ahead's workspace).
    pub fn new(settings: SingularitySettings, kin: &Kinematics) -> Self {
        Self {
            settings,
            ws: kin.workspace(),
            q_next: vec![0.0; kin.dof()],
            kappa: vec![0.0; kin.chains().len()],
            last: SingularityReport {
                status: SingularityStatus::Clear,
                factor: 1.0,
                condition: f64::NAN,
            },
        }
    }

    /// The outcome of the last [`Self::tick`] (before any: clear, `κ` unknown: NaN).
    pub fn last(&self) -> SingularityReport {
        self.last
    }

    /// The band on a node's tick: [`Self::apply`], or, when the condition is `infeasible`
    /// (no policy velocity to scale), clear with `κ` reported as ∞; kept as
    /// [`Self::last`]. Allocation-free.
    pub fn tick(
        &mut self,
        kin: &Kinematics,
        at_q: &KinematicsWorkspace,
        q: &[f64],
        v: &mut [f64],
        dt: f64,
        infeasible: bool,
    ) -> SingularityReport {
        self.last = if infeasible {
            SingularityReport {
                status: SingularityStatus::Clear,
                factor: 1.0,
                condition: f64::INFINITY,
            }
        } else {
            self.apply(kin, at_q, q, v, dt)
        };
        self.last
    }

    /// The settings.
    pub fn settings(&self) -> &SingularitySettings {
        &self.settings
    }

    /// Scales `v` in place (module docs); `at_q` holds the Jacobian at `q` (after
    /// [`Kinematics::jacobian`]). Allocation-free.
    pub fn apply(
        &mut self,
        kin: &Kinematics,
        at_q: &KinematicsWorkspace,
        q: &[f64],
        v: &mut [f64],
        dt: f64,
    ) -> SingularityReport {
        let mut worst = 1.0f64;
        let mut inside = false;
        for (i, k) in self.kappa.iter_mut().enumerate() {
            *k = chain_condition_number(kin, at_q, i);
            if k.is_nan() {
                continue;
            }
            worst = worst.max(*k);
            // κ = ∞: the lift reports the singular posture itself (or the Jacobian is not
            // finite and the filter brakes).
            inside |= *k > self.settings.slowdown && k.is_finite();
        }
        let clear = SingularityReport {
            status: SingularityStatus::Clear,
            factor: 1.0,
            condition: worst,
        };
        if !self.settings.enabled || !inside || !v.iter().all(|x| x.is_finite()) {
            return clear;
        }
        for ((n, &qj), &vj) in self.q_next.iter_mut().zip(q).zip(v.iter()) {
            *n = qj + vj * dt;
        }
        kin.jacobian(&self.q_next, &mut self.ws);
        let mut f = 1.0f64;
        for (i, &k) in self.kappa.iter().enumerate() {
            if k > self.settings.slowdown
                && k.is_finite()
                && chain_condition_number(kin, &self.ws, i) > k
            {
                f = f.min(self.settings.factor(k));
            }
        }
        if f == 1.0 {
            return clear;
        }
        for x in v.iter_mut() {
            *x *= f;
        }
        SingularityReport {
            status: if f == 0.0 {
                SingularityStatus::Halt
            } else {
                SingularityStatus::Decelerate
            },
            factor: f,
            condition: worst,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::node::test_robot::planar;

    /// A two-link planar arm (links of 1), stretched out at `q₂ = 0`.
    fn arm() -> Kinematics {
        const URDF: &str = r#"<robot name="arm2">
  <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="tip"/>
  <joint name="j1" type="revolute"> <parent link="base"/> <child link="l1"/>
    <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
  <joint name="j2" type="revolute"> <parent link="l1"/> <child link="l2"/>
    <origin xyz="1 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
  <joint name="tool" type="fixed"> <parent link="l2"/> <child link="tip"/> <origin xyz="1 0 0"/> </joint>
</robot>"#;
        planar(URDF, &[("arm", "base", "tip")])
    }

    #[test]
    fn the_node_tick_scales_toward_the_stretched_arm_and_reports_an_infeasible_tick_as_clear() {
        let kin = arm();
        let mut band = SingularityBand::new(SingularitySettings::default(), &kin);
        assert!(band.last().condition.is_nan(), "no tick yet");
        let mut ws = kin.workspace();
        // Bent well away from the stretched arm: clear, nothing scaled.
        let q = [0.0, 1.5];
        kin.jacobian(&q, &mut ws);
        let mut v = [0.1, -0.3];
        let r = band.tick(&kin, &ws, &q, &mut v, 0.01, false);
        assert_eq!((r.status, r.factor), (SingularityStatus::Clear, 1.0));
        assert!(r.condition.is_finite() && r.condition < 17.0, "{r:?}");
        assert_eq!(v, [0.1, -0.3]);
        // Nearly stretched, straightening further: slowed down, every joint alike.
        let q = [0.0, 0.08];
        kin.jacobian(&q, &mut ws);
        let mut v = [0.2, -0.5];
        let r = band.tick(&kin, &ws, &q, &mut v, 0.01, false);
        assert_ne!(r.status, SingularityStatus::Clear, "{r:?}");
        assert!(r.factor < 1.0);
        assert_eq!(v, [0.2 * r.factor, -0.5 * r.factor]);
        assert_eq!(band.last(), r);
        // Bending away from it: not scaled (Servo's rule).
        let mut v = [0.2, 0.5];
        let r = band.tick(&kin, &ws, &q, &mut v, 0.01, false);
        assert_eq!(r.status, SingularityStatus::Clear);
        assert_eq!(v, [0.2, 0.5]);
        // Infeasible: no velocity to scale; clear with κ = ∞.
        let mut v = [f64::NAN; 2];
        let r = band.tick(&kin, &ws, &q, &mut v, 0.01, true);
        assert_eq!((r.status, r.factor), (SingularityStatus::Clear, 1.0));
        assert_eq!(r.condition, f64::INFINITY);
        assert_eq!(band.last(), r);
    }

    #[test]
    fn the_factor_falls_continuously_across_the_band() {
        let s = SingularitySettings::default();
        assert_eq!(s.factor(1.0), 1.0);
        assert_eq!(s.factor(17.0), 1.0);
        assert_eq!(s.factor(30.0), 0.0);
        assert_eq!(s.factor(1e9), 0.0);
        assert_eq!(s.factor(f64::INFINITY), 0.0);
        let mut prev = 1.0;
        for k in 0..=1300 {
            let f = s.factor(17.0 + k as f64 * 0.01);
            assert!(
                f <= prev && prev - f <= 0.01 / 13.0 + 1e-12,
                "{k}: {prev} → {f}"
            );
            prev = f;
        }
        assert!(SingularitySettings {
            slowdown: 30.0,
            ..s
        }
        .validate()
        .is_err());
        assert!(SingularitySettings { slowdown: 0.5, ..s }
            .validate()
            .is_err());
        assert!(SingularitySettings {
            stop: f64::INFINITY,
            ..s
        }
        .validate()
        .is_err());
        assert!(s.validate().is_ok());
    }
}
