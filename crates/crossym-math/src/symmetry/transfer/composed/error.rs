//! The composed lift's errors: setup (a spec that does not fit), per condition (a flow
//! that fails), and two compositions that differ.

use crate::symmetry::affine::{CanonicalMapError, OneParamKind, StoredPermutation};
use crate::symmetry::compose::Condition;
use crate::symmetry::finite::PermutationError;
use crate::symmetry::parts::PartsError;
use crate::symmetry::transfer::flow::{FlowSettingsError, FlowStatus};

/// One continuous factor of the composition.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Factor {
    /// `Φ_R`, flow time `θ` (rad).
    Rotation,
    /// `Φ_S`, flow time `ln λ`.
    Scaling,
}

impl std::fmt::Display for Factor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Rotation => "rotation",
            Self::Scaling => "scaling",
        })
    }
}

/// What is wrong with a condition (fixed size).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConditionProblem {
    /// `θ` or `λ` is not finite.
    NonFinite,
    /// `λ ≤ 0`.
    NonPositiveScale,
    /// `σ ∉ {1, −1}`.
    Reflection,
}

impl ConditionProblem {
    /// What is wrong with `s`, if anything (allocation-free).
    pub fn of(s: &Condition) -> Option<Self> {
        if !(s.theta.is_finite() && s.scale.is_finite()) {
            Some(Self::NonFinite)
        } else if s.scale <= 0.0 {
            Some(Self::NonPositiveScale)
        } else if !(s.reflection == 1 || s.reflection == -1) {
            Some(Self::Reflection)
        } else {
            None
        }
    }
}

impl std::fmt::Display for ConditionProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::NonFinite => "θ or λ is not finite",
            Self::NonPositiveScale => "λ must be positive",
            Self::Reflection => "σ must be 1 or −1",
        })
    }
}

/// Why a condition's composed action could not be evaluated (fixed size, no allocation).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ComposedError {
    /// The lifted field is undefined at the flow's start (a singular configuration).
    #[error("the lifted {factor} field is undefined at the start (singular configuration)")]
    BadStart {
        /// Which flow.
        factor: Factor,
    },
    /// The flow reached a kinematic singularity at flow time `t` of `total`.
    #[error("the lifted {factor} flow reaches a singularity at flow time {t:.4} of {total:.4}")]
    Singular {
        /// Which flow.
        factor: Factor,
        /// Flow time reached (rad for the rotation, ln λ for the scaling).
        t: f64,
        /// Flow time asked for.
        total: f64,
    },
    /// The integration failed otherwise (non-finite state, too many steps).
    #[error("the lifted {factor} flow failed: {status:?}")]
    Integration {
        /// Which flow.
        factor: Factor,
        /// The integrator's outcome.
        status: FlowStatus,
    },
    /// The inverse misses its task-space image: `|f(Φ_g⁻¹ q) − g⁻¹ f(q)|∞ > tolerance` (a
    /// flow crossed a singularity between integrator steps, or the integrator is too
    /// coarse for this condition).
    #[error(
        "the inverse flow misses g⁻¹·f(q) by {residual:.2e} (tolerance {tolerance:.1e}): \
         a singularity lies on the way"
    )]
    Residual {
        /// `|f(Φ_g⁻¹ q) − g⁻¹ f(q)|∞` (task units).
        residual: f64,
        /// The tolerance it exceeds (task units).
        tolerance: f64,
    },
    /// `λ ≠ 1` asked of a composition without a scaling symmetry.
    #[error("scale λ = {scale} asked, but the composition has no scaling symmetry")]
    NoScaling {
        /// The scale asked for.
        scale: f64,
    },
    /// The horizontal lift `J⁺(q)` is undefined at `q` (`J M⁻¹ Jᵀ` singular or below the
    /// manipulability threshold): a task-space head cannot be lifted there.
    #[error("the horizontal lift is undefined at q (manipulability {manipulability:.2e})")]
    SingularLift {
        /// `√det(J M⁻¹ Jᵀ)` at `q`.
        manipulability: f64,
    },
    /// The condition is not finite, `λ ≤ 0` or `σ ∉ {±1}`.
    #[error("invalid condition: {problem}")]
    Condition {
        /// What is wrong.
        problem: ConditionProblem,
    },
}

/// What is wrong with a [`LiftIntegrator`](super::LiftIntegrator).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum IntegratorError {
    /// The adaptive integrator's settings are invalid.
    #[error(transparent)]
    Flow {
        /// Why.
        #[from]
        source: FlowSettingsError,
    },
    /// The RK4 step is not positive and finite.
    #[error("rk4 max_step {max_step} must be positive and finite")]
    Rk4Step {
        /// The step given.
        max_step: f64,
    },
}

/// Why a [`ComposedSpec`](super::ComposedSpec) (or the [`ComposedLift`](super::ComposedLift) of one) cannot be built or does not fit
/// the robot.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ComposedSpecError {
    /// The composition order's parts cannot be picked.
    #[error(transparent)]
    Parts {
        /// Why.
        #[from]
        source: PartsError,
    },
    /// The task-space action cannot be built or is inconsistent.
    #[error(transparent)]
    Task {
        /// Why.
        #[from]
        source: CanonicalMapError,
    },
    /// The stored reflection on `Q` is not a signed permutation.
    #[error("reflection: {source}")]
    Reflection {
        /// Why.
        source: PermutationError,
    },
    /// A signed permutation is invalid.
    #[error(transparent)]
    Permutation {
        /// Why.
        #[from]
        source: PermutationError,
    },
    /// The reflection acts on another space than `Q`.
    #[error("the reflection acts on R^{acts_on}, the robot has {n} joints")]
    ReflectionDim {
        /// Dimension it acts on.
        acts_on: usize,
        /// The robot's joints.
        n: usize,
    },
    /// The task-space action acts on another space than `X`.
    #[error("the task-space action is on R^{acts_on}, the robot's task space is R^{m}")]
    TaskDim {
        /// Dimension it acts on.
        acts_on: usize,
        /// The robot's task-space dimension.
        m: usize,
    },
    /// The task-space action has no `ρ_X`.
    #[error("the task-space action has no reflection ρ_X")]
    NoTaskReflection,
    /// A factor is of the wrong kind.
    #[error("`{name}`: a {want:?} is needed, not a {got:?}")]
    WrongKind {
        /// Symmetry name.
        name: String,
        /// The kind needed.
        want: OneParamKind,
        /// The kind stored.
        got: OneParamKind,
    },
    /// The composition has no rotation.
    #[error("the composition has no rotation")]
    NoRotation,
    /// The residual tolerance is not positive and finite.
    #[error("residual_tolerance {tolerance} must be positive")]
    ResidualTolerance {
        /// The tolerance given.
        tolerance: f64,
    },
    /// The integrator's settings are invalid.
    #[error(transparent)]
    Integrator {
        /// Why.
        #[from]
        source: IntegratorError,
    },
}

/// How two compositions differ
/// ([`ComposedSpec::same_composition`](super::ComposedSpec::same_composition)).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CompositionMismatch {
    /// The orders differ.
    #[error("composition order {ours:?} differs from {theirs:?}")]
    Order {
        /// This composition's order.
        ours: Vec<String>,
        /// The other's.
        theirs: Vec<String>,
    },
    /// The reflections on `Q` differ.
    #[error("the reflection on Q differs ({ours:?} vs {theirs:?})")]
    Reflection {
        /// This composition's reflection.
        ours: StoredPermutation,
        /// The other's.
        theirs: StoredPermutation,
    },
    /// The reflections on `X` differ.
    #[error("the reflection on X differs")]
    TaskReflection,
    /// The rotations' generators differ.
    #[error(
        "the rotation `{name}` differs (generator A = {linear:?}, b = {offset:?} vs A = {other_linear:?}, b = {other_offset:?})"
    )]
    Rotation {
        /// Name of this composition's rotation.
        name: String,
        /// Its `A` (row-major).
        linear: Vec<f64>,
        /// Its `b`.
        offset: Vec<f64>,
        /// The other's `A`.
        other_linear: Vec<f64>,
        /// The other's `b`.
        other_offset: Vec<f64>,
    },
    /// A composition has no rotation.
    #[error("a composition lacks its rotation")]
    MissingRotation,
    /// The scalings' generators differ.
    #[error("the scaling `{name}` differs (its centre or generator moved)")]
    Scaling {
        /// Name of this composition's scaling.
        name: String,
    },
    /// One composition has a scaling, the other not.
    #[error("one composition has a scaling, the other not")]
    ScalingPresence,
}
