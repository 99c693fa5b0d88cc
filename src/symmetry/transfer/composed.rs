//! The composed lifted action of one condition, its inverse and its push-forward (eq. 23):
//!
//!   Φ_g(q) = ρ(σ) · Φ_R(θ, Φ_S(ln λ, q)),   g = g(s), s = (θ, λ, σ),
//!   Φ_g⁻¹(q) = Φ_S(−ln λ, Φ_R(−θ, ρ(σ)⁻¹ q)),
//!   dΦ_g|_q v = ρ(σ) · dΦ_R(θ)|_{Φ_S(q)} · dΦ_S(ln λ)|_q v,
//!
//! with `Φ_R`, `Φ_S` the flows of the horizontally lifted rotation and scaling generators
//! (eq. 18) and `ρ(σ)` the morphological reflection acting linearly on `Q`. The inverse
//! flows each field backwards in the reverse order, so it inverts *this fixed composite
//! map* exactly (up to the integrator's tolerance) whether or not the lifted action is a
//! group action (with `M = I` it is not: the vertical bracket and the 2π drift). The
//! push-forward transports the tangent `v` along the forward flows (variational equation,
//! [`super::lift::LiftedAction::act_with_differential`]), no `n × n` matrix.
//!
//! Canonicalisation (issue 18) uses exactly these three maps: a policy `π₀` for the
//! identity condition becomes `π(q, s) = dΦ_g|_{q₀} π₀(q₀)` with `q₀ = Φ_g⁻¹(q)`, whose
//! closed loop under `s` is conjugate to `π₀`'s, `q_s(t) = Φ_g(q_e(t))`.

use crate::kinematics::Kinematics;
use crate::symmetry::check::BuiltSymmetry;
use crate::symmetry::compose::Condition;
use crate::symmetry::finite::SignedPermutation;
use crate::symmetry::transfer::flow::FlowSettings;
use crate::symmetry::transfer::lift::{LiftError, LiftWorkspace, LiftedAction};

/// Why a condition's composed action could not be evaluated.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum ComposedError {
    /// A lifted flow failed (singularity at flow time `t`, integration failure, bad start).
    #[error(transparent)]
    Lift(#[from] LiftError),
    /// `λ ≠ 1` asked of a composition without a scaling symmetry.
    #[error("scale λ = {scale} asked, but the composition has no scaling symmetry")]
    NoScaling {
        /// The scale asked for.
        scale: f64,
    },
    /// The condition is not finite, `λ ≤ 0` or `σ ∉ {±1}`.
    #[error("invalid condition: {message}")]
    Condition {
        /// What is wrong.
        message: String,
    },
}

/// `Φ_g`, `Φ_g⁻¹` and `dΦ_g` of eq. 23 for the letter-style composition `(M, R[, S])`.
pub struct ComposedLift<'a> {
    kin: &'a Kinematics,
    reflection: SignedPermutation,
    reflection_inv: SignedPermutation,
    rotation: LiftedAction<'a>,
    scaling: Option<LiftedAction<'a>>,
}

/// Scratch for [`ComposedLift`] (allocates once, in [`ComposedLift::workspace`]).
#[derive(Debug, Clone)]
pub struct ComposedWorkspace {
    rotation: LiftWorkspace,
    scaling: LiftWorkspace,
    a: Vec<f64>,
    b: Vec<f64>,
    va: Vec<f64>,
    vb: Vec<f64>,
}

impl<'a> ComposedLift<'a> {
    /// The composition `order` (outer → inner: `[M, R, S]` or `[M, R]`) of the built
    /// symmetries, the lifted flows integrated with `settings`.
    pub fn new(
        kin: &'a Kinematics,
        built: &'a [BuiltSymmetry],
        order: &[String],
        settings: FlowSettings,
    ) -> Result<Self, String> {
        let (reflection, rot, sc) = crate::data::augmentation::letter_group(built, order)?;
        if reflection.dim() != kin.dof() {
            return Err(format!(
                "reflection acts on R^{}, dim Q = {}",
                reflection.dim(),
                kin.dof()
            ));
        }
        Ok(Self {
            kin,
            reflection_inv: reflection.inverse(),
            reflection,
            rotation: LiftedAction::new(kin, rot, settings)?,
            scaling: sc
                .map(|sc| LiftedAction::new(kin, sc, settings))
                .transpose()?,
        })
    }

    /// The robot.
    pub fn kinematics(&self) -> &Kinematics {
        self.kin
    }

    /// Scratch sized for this robot.
    pub fn workspace(&self) -> ComposedWorkspace {
        let n = self.kin.dof();
        ComposedWorkspace {
            rotation: self.rotation.workspace(),
            // One per field, so each warm-starts from its own last step size.
            scaling: self
                .scaling
                .as_ref()
                .map_or_else(|| self.rotation.workspace(), LiftedAction::workspace),
            a: vec![0.0; n],
            b: vec![0.0; n],
            va: vec![0.0; n],
            vb: vec![0.0; n],
        }
    }

    fn check(&self, s: &Condition) -> Result<(), ComposedError> {
        s.validate()
            .map_err(|message| ComposedError::Condition { message })?;
        if s.scale != 1.0 && self.scaling.is_none() {
            return Err(ComposedError::NoScaling { scale: s.scale });
        }
        Ok(())
    }

    /// `q_out = Φ_g⁻¹(q) = Φ_S(−ln λ, Φ_R(−θ, ρ(σ)⁻¹ q))` (rad or m).
    pub fn inverse(
        &self,
        s: &Condition,
        q: &[f64],
        q_out: &mut [f64],
        ws: &mut ComposedWorkspace,
    ) -> Result<(), ComposedError> {
        self.check(s)?;
        if s.reflection == -1 {
            self.reflection_inv.apply(q, &mut ws.a);
        } else {
            ws.a.copy_from_slice(q);
        }
        if s.theta != 0.0 {
            self.rotation
                .act(&[-s.theta], &ws.a, &mut ws.b, &mut ws.rotation)?;
        } else {
            ws.b.copy_from_slice(&ws.a);
        }
        match &self.scaling {
            Some(sc) if s.scale != 1.0 => {
                sc.act(&[-s.scale.ln()], &ws.b, q_out, &mut ws.scaling)?;
            }
            _ => q_out.copy_from_slice(&ws.b),
        }
        Ok(())
    }

    /// `q_out = Φ_g(q)` and `v_out = dΦ_g|_q v` (rad or m, and per second).
    pub fn act_with_differential(
        &self,
        s: &Condition,
        q: &[f64],
        v: &[f64],
        q_out: &mut [f64],
        v_out: &mut [f64],
        ws: &mut ComposedWorkspace,
    ) -> Result<(), ComposedError> {
        self.check(s)?;
        match &self.scaling {
            Some(sc) if s.scale != 1.0 => {
                sc.act_with_differential(
                    &[s.scale.ln()],
                    q,
                    v,
                    &mut ws.a,
                    &mut ws.va,
                    &mut ws.scaling,
                )?;
            }
            _ => {
                ws.a.copy_from_slice(q);
                ws.va.copy_from_slice(v);
            }
        }
        if s.theta != 0.0 {
            self.rotation.act_with_differential(
                &[s.theta],
                &ws.a,
                &ws.va,
                &mut ws.b,
                &mut ws.vb,
                &mut ws.rotation,
            )?;
        } else {
            ws.b.copy_from_slice(&ws.a);
            ws.vb.copy_from_slice(&ws.va);
        }
        if s.reflection == -1 {
            self.reflection.apply(&ws.b, q_out);
            self.reflection.apply(&ws.vb, v_out);
        } else {
            q_out.copy_from_slice(&ws.b);
            v_out.copy_from_slice(&ws.vb);
        }
        Ok(())
    }
}
