//! Task-induced symmetries: groups found from a task cost `c: X → R` (paper Sec. III-C, eq. 7).
//!
//! Two task states are symmetric when they have the same cost, `c(x_1) = c(x_2)`. Locally the
//! symmetry directions at `x` are the level-set directions `{v ∈ T_x X : ∇c(x)·v = 0}`, of
//! dimension `d − 1` on one task block `X = R^d` (d = 2 or 3). Fields `X_1 … X_k` with
//! `∇c·X_k = 0` generate a Lie group `G_T` acting on `X` only if they are
//! **complete** (flows exist for all `t`, Lee Thm. 20.16) and **closed under the Lie bracket**
//! (`[X_i, X_j] = Σ_l c_ij^l X_l` with constant structure constants); the action is then the
//! flow (eq. 7)
//!
//! `Φ_T(exp(tξ), x) = γ(t, x)`,  `dγ/dt = X_ξ(γ) = Σ_k ξ_k X_k(γ)`,  `γ(0, x) = x`,
//!
//! which preserves `c` by construction. Here:
//!
//! - **Costs** ([`CostSpec`], [`Cost`]): Euclidean distance to a point `|x − p|`, distance to a
//!   line `|(I − u uᵀ)(x − p)|`, signed height above a plane `n·(x − p)/|n|`, and weighted sums
//!   of these. Distances are *not* squared: a sum of squared distances to two points is a
//!   squared distance to their midpoint (plus a constant) and would hide the loss of symmetry
//!   that sums are meant to express. Gradients are analytic and undefined only on the point /
//!   the line itself.
//! - **Discovery** ([`TaskInducedSymmetry::discover`]): the candidates are the affine Killing
//!   fields of `R^d` plus the dilation — rotations `R_k (x − o)/ρ`, the Euler field
//!   `(x − o)/ρ` and translations `e_i`, with `o, ρ` the centre and half-width of the sampling
//!   box. On `N` sampled points the matrix `G[s, k] = ∇c(x_s)·X_k(x_s) / |∇c(x_s)|` is formed;
//!   the cost-preserving fields are its numerical nullspace (singular values below
//!   `nullspace_tol · σ_max`). The candidates span a Lie algebra (the similitudes), and the
//!   fields annihilating `c` form a subalgebra (`[X, Y]c = X(Yc) − Y(Xc) = 0`), so the result
//!   is closed up to sampling — which is checked, not assumed. The basis is tidied (reduced row
//!   echelon form, translations orthonormalised, rotation rates normalised to 1 rad per unit
//!   `ξ`), so a distance to a point in 3-D gives so(3) about the point, a distance to a line the
//!   rotation about and translation along the line, a plane se(2).
//! - **Checks** ([`TaskInducedReport`], [`check_fields`]): invariance, spanning of the level set
//!   at every sample, closure (least-squares fit of the numerical brackets with constant
//!   coefficients, giving the structure constants) and completeness (affine fields are complete
//!   in theory; flows to `t = ±flow_time` are integrated to confirm). [`TaskInducedReport::verdict`]
//!   says in words which condition fails.
//! - **Action** ([`TaskInducedSymmetry::act`]): eq. 7 integrated with the DOPRI5 flow of
//!   [`crate::symmetry::transfer::flow`], the differential by the variational equation, and on
//!   `B` blocks (one per arm) the same field on every block. For affine generators the flow has
//!   the closed form `exp` of the augmented matrix ([`TaskInducedSymmetry::act_closed_form`]),
//!   used as a reference.
//!
//!
//! Thresholds (defaults of [`TaskInducedSettings`]): exact symmetries give null singular values
//! of `G` at rounding level (~1e-16 of `σ_max`), while the other candidates stay above ~1e-2
//! for the costs here, so `nullspace_tol = 1e-9` sits in a wide gap; discovered fields are
//! invariant to ~1e-15 (`invariance_tol = 1e-8`); brackets of affine fields by central
//! differences are exact up to rounding amplified by `1/h ≈ 1e5`, ~1e-11 relative
//! (`closure_tol = 1e-6` leaves room for the `O(h²)` truncation of nonlinear user fields);
//! `rank_tol = 1e-6` counts a direction unless it is a million times weaker than the strongest.
//!
//! [`TaskInducedSymmetry::act`] is allocation-free; everything else is analysis (setup time)
//! and may allocate.

mod check;
mod cost;
mod discover;
mod error;
mod generator;
mod group;
mod sampling;
mod settings;
#[cfg(test)]
mod tests;

pub use self::check::{check_fields, FlowFailure, TaskInducedFailure, TaskInducedReport};
pub use self::cost::{Cost, CostSpec, WeightedCost};
pub use self::error::TaskInducedError;
pub use self::generator::AffineGenerator;
pub use self::group::{TaskInducedField, TaskInducedSymmetry, TaskInducedWorkspace};
pub use self::settings::{SampleRegion, TaskInducedSettings};
