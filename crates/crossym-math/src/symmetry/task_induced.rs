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

use std::fmt;

use nalgebra::{DMatrix, DVector};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::symmetry::field::{lie_bracket, VectorField, DEFAULT_FD_STEP};
use crate::symmetry::lie::TaskGroupAction;
use crate::symmetry::transfer::flow::{
    integrate, FlowSettings, FlowStatus, FlowWorkspace, VariationalField,
};

/// A task cost `c: R^d → R` as written in configuration (length units of the task space).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum CostSpec {
    /// Euclidean distance `|x − p|` to a point (length units).
    DistanceToPoint {
        /// The point `p` (block coordinates, length units).
        point: Vec<f64>,
    },
    /// Euclidean distance `|(I − u uᵀ)(x − p)|` to the line through `p` along `u` (length units).
    DistanceToLine {
        /// A point `p` on the line (block coordinates).
        point: Vec<f64>,
        /// Direction of the line (any non-zero length; normalised internally).
        direction: Vec<f64>,
    },
    /// Signed height `n·(x − p)/|n|` above the plane (a line in 2-D) through `p` with normal `n`.
    HeightAbovePlane {
        /// A point `p` on the plane (block coordinates).
        point: Vec<f64>,
        /// Normal `n` (any non-zero length; normalised internally), pointing to positive height.
        normal: Vec<f64>,
    },
    /// Weighted sum `Σ_i w_i c_i(x)` of costs.
    Sum {
        /// The terms (at least one).
        terms: Vec<WeightedCost>,
    },
}

fn unit_weight() -> f64 {
    1.0
}

/// One term `w · c(x)` of a [`CostSpec::Sum`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WeightedCost {
    /// Weight `w` (finite, non-zero; dimensionless; default 1).
    #[serde(default = "unit_weight")]
    pub weight: f64,
    /// The cost `c`.
    pub cost: CostSpec,
}

impl CostSpec {
    /// Validates the spec for `d`-dimensional task blocks and compiles it into a [`Cost`].
    pub fn build(&self, dim: usize) -> Result<Cost, TaskInducedError> {
        Cost::new(self, dim)
    }
}

/// Invalid cost specifications and settings, and costs that admit no analysis.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum TaskInducedError {
    /// Task blocks must be 2-D or 3-D.
    #[error("task-induced symmetries need 2-D or 3-D task blocks, got {dim}-D")]
    UnsupportedDim {
        /// Requested block dimension.
        dim: usize,
    },
    /// A point or vector has the wrong number of coordinates.
    #[error("cost `{path}`: {what} has {got} coordinates, but the task block is {expected}-D")]
    WrongDimension {
        /// Location in the spec, e.g. `cost.terms[1].cost`.
        path: String,
        /// Which parameter (`point`, `direction`, `normal`).
        what: &'static str,
        /// Block dimension `d`.
        expected: usize,
        /// Coordinates given.
        got: usize,
    },
    /// A point or vector has a NaN or infinite coordinate.
    #[error("cost `{path}`: {what} {values:?} has a non-finite coordinate")]
    NonFinite {
        /// Location in the spec.
        path: String,
        /// Which parameter.
        what: &'static str,
        /// The values given.
        values: Vec<f64>,
    },
    /// A line direction or plane normal is (numerically) zero.
    #[error("cost `{path}`: {what} {values:?} is a zero vector; it must have non-zero length")]
    ZeroVector {
        /// Location in the spec.
        path: String,
        /// Which parameter (`direction` or `normal`).
        what: &'static str,
        /// The values given.
        values: Vec<f64>,
    },
    /// A sum weight is zero or not finite.
    #[error("cost `{path}`: weight {weight} must be finite and non-zero (remove the term instead of weighting it by 0)")]
    BadWeight {
        /// Location of the term.
        path: String,
        /// The weight given.
        weight: f64,
    },
    /// A sum without terms.
    #[error("cost `{path}`: a sum needs at least one term")]
    EmptySum {
        /// Location of the sum.
        path: String,
    },
    /// A setting is out of its domain.
    #[error("invalid task-induced setting `{field}`: {message}")]
    InvalidSetting {
        /// Setting name.
        field: String,
        /// Why it is invalid.
        message: String,
    },
    /// The cost gradient vanishes (or is undefined) on too much of the sampled region.
    #[error("the cost gradient vanishes or is undefined at {rejected} of {attempts} sampled points (only {usable} usable, need {needed}): the cost is (nearly) constant on the region, e.g. its terms cancel, so its level sets are not hypersurfaces")]
    DegenerateCost {
        /// Points with a usable gradient.
        usable: usize,
        /// Points needed.
        needed: usize,
        /// Points rejected.
        rejected: usize,
        /// Points drawn.
        attempts: usize,
    },
    /// A field handed to [`check_fields`] lives on another space than the cost.
    #[error("field {index} acts on R^{got}, but the cost is defined on R^{expected}")]
    FieldDimension {
        /// Index of the field.
        index: usize,
        /// Cost dimension `d`.
        expected: usize,
        /// Field dimension.
        got: usize,
    },
    /// A symmetry needs at least one task block.
    #[error("a task-induced symmetry needs at least one task block")]
    NoBlocks,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Term {
    /// `|x − p|`.
    Point { p: [f64; 3] },
    /// `|(I − u uᵀ)(x − p)|`, `|u| = 1`.
    Line { p: [f64; 3], u: [f64; 3] },
    /// `n·(x − p)`, `|n| = 1`.
    Plane { p: [f64; 3], n: [f64; 3] },
}

/// A validated task cost `c(x) = Σ_i w_i c_i(x)` on one task block `R^d` (length units).
#[derive(Debug, Clone, PartialEq)]
pub struct Cost {
    dim: usize,
    spec: CostSpec,
    terms: Vec<(f64, Term)>,
}

fn check_vec(
    path: &str,
    what: &'static str,
    v: &[f64],
    d: usize,
    nonzero: bool,
) -> Result<[f64; 3], TaskInducedError> {
    if v.len() != d {
        return Err(TaskInducedError::WrongDimension {
            path: path.into(),
            what,
            expected: d,
            got: v.len(),
        });
    }
    if v.iter().any(|a| !a.is_finite()) {
        return Err(TaskInducedError::NonFinite {
            path: path.into(),
            what,
            values: v.to_vec(),
        });
    }
    let mut out = [0.0; 3];
    out[..d].copy_from_slice(v);
    if nonzero {
        let n = norm3(&out);
        if n <= 1e-12 {
            return Err(TaskInducedError::ZeroVector {
                path: path.into(),
                what,
                values: v.to_vec(),
            });
        }
        for a in &mut out {
            *a /= n;
        }
    }
    Ok(out)
}

fn compile(
    spec: &CostSpec,
    d: usize,
    path: &str,
    weight: f64,
    out: &mut Vec<(f64, Term)>,
) -> Result<(), TaskInducedError> {
    match spec {
        CostSpec::DistanceToPoint { point } => {
            let p = check_vec(path, "point", point, d, false)?;
            out.push((weight, Term::Point { p }));
        }
        CostSpec::DistanceToLine { point, direction } => {
            let p = check_vec(path, "point", point, d, false)?;
            let u = check_vec(path, "direction", direction, d, true)?;
            out.push((weight, Term::Line { p, u }));
        }
        CostSpec::HeightAbovePlane { point, normal } => {
            let p = check_vec(path, "point", point, d, false)?;
            let n = check_vec(path, "normal", normal, d, true)?;
            out.push((weight, Term::Plane { p, n }));
        }
        CostSpec::Sum { terms } => {
            if terms.is_empty() {
                return Err(TaskInducedError::EmptySum { path: path.into() });
            }
            for (i, t) in terms.iter().enumerate() {
                let sub = format!("{path}.terms[{i}]");
                if !(t.weight.is_finite() && t.weight != 0.0) {
                    return Err(TaskInducedError::BadWeight {
                        path: sub,
                        weight: t.weight,
                    });
                }
                compile(&t.cost, d, &format!("{sub}.cost"), weight * t.weight, out)?;
            }
        }
    }
    Ok(())
}

fn norm3(v: &[f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

impl Cost {
    /// Validates `spec` for `d`-dimensional blocks (`d` = 2 or 3) and compiles it.
    pub fn new(spec: &CostSpec, dim: usize) -> Result<Self, TaskInducedError> {
        if !(dim == 2 || dim == 3) {
            return Err(TaskInducedError::UnsupportedDim { dim });
        }
        let mut terms = Vec::new();
        compile(spec, dim, "cost", 1.0, &mut terms)?;
        Ok(Self {
            dim,
            spec: spec.clone(),
            terms,
        })
    }

    /// Dimension `d` of the task block the cost lives on.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The spec the cost was built from.
    pub fn spec(&self) -> &CostSpec {
        &self.spec
    }

    /// Number of elementary terms after flattening nested sums.
    pub fn terms(&self) -> usize {
        self.terms.len()
    }

    /// Sum of the absolute weights `Σ|w_i|`, an upper bound of `|∇c|` (dimensionless).
    pub fn gradient_bound(&self) -> f64 {
        self.terms.iter().map(|(w, _)| w.abs()).sum()
    }

    /// The anchor points `p` of the terms (block coordinates), used to place the sampling box.
    pub fn anchors(&self) -> Vec<Vec<f64>> {
        self.terms
            .iter()
            .map(|(_, t)| match t {
                Term::Point { p } | Term::Line { p, .. } | Term::Plane { p, .. } => {
                    p[..self.dim].to_vec()
                }
            })
            .collect()
    }

    /// The cost `c(x)` at a block point `x` (`x.len() == d`; length units).
    pub fn value(&self, x: &[f64]) -> f64 {
        debug_assert_eq!(x.len(), self.dim);
        let d = self.dim;
        let mut r = [0.0; 3];
        let mut c = 0.0;
        for (w, t) in &self.terms {
            let v = match t {
                Term::Point { p } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    norm3(&r)
                }
                Term::Line { p, u } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    let a = dot(&r, u);
                    for i in 0..d {
                        r[i] -= a * u[i];
                    }
                    norm3(&r)
                }
                Term::Plane { p, n } => (0..d).map(|i| (x[i] - p[i]) * n[i]).sum(),
            };
            c += w * v;
        }
        c
    }

    /// Writes the analytic gradient `∇c(x)` (dimensionless) into `out`.
    ///
    /// Returns `false` where `c` is not differentiable: exactly on a term's point (distance to
    /// a point) or line (distance to a line); `out` is then unspecified.
    pub fn gradient(&self, x: &[f64], out: &mut [f64]) -> bool {
        debug_assert_eq!(x.len(), self.dim);
        let d = self.dim;
        out[..d].fill(0.0);
        let mut r = [0.0; 3];
        for (w, t) in &self.terms {
            match t {
                Term::Point { p } | Term::Line { p, .. } => {
                    for i in 0..d {
                        r[i] = x[i] - p[i];
                    }
                    if let Term::Line { u, .. } = t {
                        let a = dot(&r, u);
                        for i in 0..d {
                            r[i] -= a * u[i];
                        }
                    }
                    let n = norm3(&r);
                    if n <= 0.0 || !n.is_finite() {
                        return false;
                    }
                    for i in 0..d {
                        out[i] += w * r[i] / n;
                    }
                }
                Term::Plane { n, .. } => {
                    for i in 0..d {
                        out[i] += w * n[i];
                    }
                }
            }
        }
        true
    }
}

/// An axis-aligned sampling box in block coordinates (length units).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SampleRegion {
    /// Lower corner.
    pub lower: Vec<f64>,
    /// Upper corner (strictly above `lower` in every coordinate).
    pub upper: Vec<f64>,
}

/// Sample counts, tolerances and flow settings of discovery and checks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskInducedSettings {
    /// Points sampled for discovery and, separately, for the checks (at least 16).
    #[serde(default = "default_samples")]
    pub samples: usize,
    /// RNG seed: results are deterministic given the seed.
    #[serde(default)]
    pub seed: u64,
    /// Sampling box; by default centred on the mean of the cost's anchor points with
    /// half-width `max(1, 2 × their largest distance from that mean)` (length units).
    #[serde(default)]
    pub region: Option<SampleRegion>,
    /// Nullspace threshold: singular values of `G` below `nullspace_tol · σ_max` are null.
    #[serde(default = "default_nullspace_tol")]
    pub nullspace_tol: f64,
    /// Rank threshold: singular values of the projected fields below `rank_tol · σ_1` do not count.
    #[serde(default = "default_rank_tol")]
    pub rank_tol: f64,
    /// Max relative invariance residual `|∇c·X| / (|∇c||X|)` accepted.
    #[serde(default = "default_invariance_tol")]
    pub invariance_tol: f64,
    /// Max relative closure residual accepted (see [`TaskInducedReport::closure_residual`]).
    #[serde(default = "default_closure_tol")]
    pub closure_tol: f64,
    /// Flow time `T` of the completeness check (flows to `±T`; units of `ξ`).
    #[serde(default = "default_flow_time")]
    pub flow_time: f64,
    /// Number of sampled start points per field in the completeness check.
    #[serde(default = "default_flow_starts")]
    pub flow_starts: usize,
    /// Relative finite-difference step of the Lie bracket.
    #[serde(default = "default_fd_step")]
    pub fd_step: f64,
    /// Integrator settings for the completeness check and the action.
    #[serde(default)]
    pub flow: FlowSettings,
}

fn default_samples() -> usize {
    256
}
fn default_nullspace_tol() -> f64 {
    1e-9
}
fn default_rank_tol() -> f64 {
    1e-6
}
fn default_invariance_tol() -> f64 {
    1e-8
}
fn default_closure_tol() -> f64 {
    1e-6
}
fn default_flow_time() -> f64 {
    10.0
}
fn default_flow_starts() -> usize {
    4
}
fn default_fd_step() -> f64 {
    DEFAULT_FD_STEP
}

impl Default for TaskInducedSettings {
    fn default() -> Self {
        Self {
            samples: default_samples(),
            seed: 0,
            region: None,
            nullspace_tol: default_nullspace_tol(),
            rank_tol: default_rank_tol(),
            invariance_tol: default_invariance_tol(),
            closure_tol: default_closure_tol(),
            flow_time: default_flow_time(),
            flow_starts: default_flow_starts(),
            fd_step: default_fd_step(),
            flow: FlowSettings::default(),
        }
    }
}

fn bad_setting(field: &str, message: String) -> TaskInducedError {
    TaskInducedError::InvalidSetting {
        field: field.into(),
        message,
    }
}

impl TaskInducedSettings {
    /// Checks the settings for `d`-dimensional blocks.
    pub fn validate(&self, dim: usize) -> Result<(), TaskInducedError> {
        if self.samples < 16 {
            return Err(bad_setting(
                "samples",
                format!("{} samples are too few (at least 16)", self.samples),
            ));
        }
        for (name, v) in [
            ("nullspace_tol", self.nullspace_tol),
            ("rank_tol", self.rank_tol),
            ("invariance_tol", self.invariance_tol),
            ("closure_tol", self.closure_tol),
            ("fd_step", self.fd_step),
        ] {
            if !(v > 0.0 && v < 1.0) {
                return Err(bad_setting(name, format!("{v} must be in (0, 1)")));
            }
        }
        if !(self.flow_time > 0.0 && self.flow_time.is_finite()) {
            return Err(bad_setting(
                "flow_time",
                format!("{} must be positive and finite", self.flow_time),
            ));
        }
        self.flow.validate().map_err(|m| bad_setting("flow", m))?;
        if let Some(r) = &self.region {
            if r.lower.len() != dim || r.upper.len() != dim {
                return Err(bad_setting(
                    "region",
                    format!(
                        "corners {:?}, {:?} must have {dim} coordinates",
                        r.lower, r.upper
                    ),
                ));
            }
            if r.lower
                .iter()
                .zip(&r.upper)
                .any(|(l, u)| !(l.is_finite() && u.is_finite() && u > l))
            {
                return Err(bad_setting(
                    "region",
                    format!(
                        "corners {:?}, {:?} must be finite with upper > lower",
                        r.lower, r.upper
                    ),
                ));
            }
        }
        Ok(())
    }
}

/// The sampling box actually used: centre `o`, half-width `ρ`, corners.
struct Region {
    lower: Vec<f64>,
    upper: Vec<f64>,
    center: Vec<f64>,
    radius: f64,
}

/// Usable samples: points and unit normals `∇c/|∇c|`.
struct Samples {
    points: Vec<Vec<f64>>,
    normals: Vec<Vec<f64>>,
}

impl Region {
    fn new(cost: &Cost, settings: &TaskInducedSettings) -> Self {
        let d = cost.dim();
        match &settings.region {
            Some(r) => {
                let center: Vec<f64> = (0..d).map(|i| 0.5 * (r.lower[i] + r.upper[i])).collect();
                let radius = (0..d)
                    .map(|i| 0.5 * (r.upper[i] - r.lower[i]))
                    .fold(0.0, f64::max);
                Self {
                    lower: r.lower.clone(),
                    upper: r.upper.clone(),
                    center,
                    radius,
                }
            }
            None => {
                let anchors = cost.anchors();
                let mut center = vec![0.0; d];
                for a in &anchors {
                    for i in 0..d {
                        center[i] += a[i] / anchors.len() as f64;
                    }
                }
                let spread = anchors
                    .iter()
                    .map(|a| {
                        let r: Vec<f64> = (0..d).map(|i| a[i] - center[i]).collect();
                        norm(&r)
                    })
                    .fold(0.0, f64::max);
                let radius = (2.0 * spread).max(1.0);
                Self {
                    lower: center.iter().map(|c| c - radius).collect(),
                    upper: center.iter().map(|c| c + radius).collect(),
                    center,
                    radius,
                }
            }
        }
    }

    /// Draws up to `n` points with a usable gradient (`|∇c| > 1e-8 Σ|w|`), `4n` attempts.
    fn sample(&self, cost: &Cost, n: usize, seed: u64) -> Result<Samples, TaskInducedError> {
        let d = cost.dim();
        let mut rng = StdRng::seed_from_u64(seed);
        let floor = 1e-8 * cost.gradient_bound();
        let mut points = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(n);
        let mut g = vec![0.0; d];
        let mut attempts = 0;
        while points.len() < n && attempts < 4 * n {
            attempts += 1;
            let x: Vec<f64> = (0..d)
                .map(|i| rng.random_range(self.lower[i]..self.upper[i]))
                .collect();
            if !cost.gradient(&x, &mut g) {
                continue;
            }
            let gn = norm(&g);
            if gn.is_nan() || gn <= floor {
                continue;
            }
            normals.push(g.iter().map(|v| v / gn).collect());
            points.push(x);
        }
        let needed = n / 2;
        if points.len() < needed {
            return Err(TaskInducedError::DegenerateCost {
                usable: points.len(),
                needed,
                rejected: attempts - points.len(),
                attempts,
            });
        }
        Ok(Samples { points, normals })
    }
}

/// Seed offset of the check samples, so that checks use points not seen by discovery.
const CHECK_SEED: u64 = 0x9E37_79B9_7F4A_7C15;

/// An affine vector field `X(x) = A x + b` on one task block `R^d` (block coordinates).
#[derive(Debug, Clone, PartialEq)]
pub struct AffineGenerator {
    /// Linear part `A` (d × d; rates per unit `ξ`, e.g. rad for rotations).
    pub linear: DMatrix<f64>,
    /// Offset `b` (d; length units per unit `ξ`).
    pub offset: DVector<f64>,
}

impl AffineGenerator {
    /// The field `x ↦ A x + b` (`A` square, `b` of matching length).
    pub fn new(linear: DMatrix<f64>, offset: DVector<f64>) -> Self {
        assert!(
            linear.is_square() && linear.nrows() == offset.len(),
            "affine generator: A is {}×{}, b has {} entries",
            linear.nrows(),
            linear.ncols(),
            offset.len()
        );
        Self { linear, offset }
    }

    /// Rotation `x ↦ Ω (x − p)` about `p` with the skew matrix `Ω` (rad per unit `ξ`).
    pub fn rotation_about(omega: DMatrix<f64>, point: &[f64]) -> Self {
        let p = DVector::from_column_slice(point);
        let b = -(&omega * p);
        Self::new(omega, b)
    }

    /// Translation `x ↦ v` (length units per unit `ξ`).
    pub fn translation(v: &[f64]) -> Self {
        Self::new(
            DMatrix::zeros(v.len(), v.len()),
            DVector::from_column_slice(v),
        )
    }

    /// Block dimension `d`.
    pub fn block_dim(&self) -> usize {
        self.offset.len()
    }

    /// The exact Lie bracket `[X, Y](x) = dX·Y − dY·X = [A, B] x + (A b_Y − B b_X)`.
    pub fn bracket(&self, other: &Self) -> Self {
        let a = &self.linear;
        let b = &other.linear;
        Self::new(a * b - b * a, a * &other.offset - b * &self.offset)
    }

    /// A description in words: rotation axis/centre and rate, translation, dilation.
    pub fn describe(&self) -> String {
        let d = self.block_dim();
        let tidy = |v: f64| if v.abs() < 1e-12 { 0.0 } else { v };
        let a = &self.linear.map(tidy);
        let offset = self.offset.map(tidy);
        let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if scale <= 1e-12 {
            return format!("translation along {:.4?}", offset.as_slice());
        }
        let s = a.trace() / d as f64;
        let w = a - DMatrix::identity(d, d) * s;
        let sym = (&w + w.transpose())
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        if sym > 1e-9 * scale {
            return format!(
                "affine field A x + b with A = {:.4?}, b = {:.4?}",
                a.as_slice(),
                offset.as_slice()
            );
        }
        let rotating = w.iter().any(|v| v.abs() > 1e-12 * scale);
        let scaling = s.abs() > 1e-12 * scale;
        if d == 3 && rotating && !scaling {
            let omega = [w[(2, 1)], w[(0, 2)], w[(1, 0)]];
            let on = norm3(&omega);
            let b = &offset;
            // b = −ω × p + h ω̂ with p ⊥ ω: p = ω × b / |ω|², h = b·ω̂.
            let p = [
                tidy((omega[1] * b[2] - omega[2] * b[1]) / (on * on)),
                tidy((omega[2] * b[0] - omega[0] * b[2]) / (on * on)),
                tidy((omega[0] * b[1] - omega[1] * b[0]) / (on * on)),
            ];
            let axis = [omega[0] / on, omega[1] / on, omega[2] / on].map(tidy);
            let h = (0..3).map(|i| b[i] * axis[i]).sum::<f64>();
            let mut text =
                format!("rotation at {on:.4} rad/unit about axis {axis:.4?} through {p:.4?}");
            if h.abs() > 1e-12 * (1.0 + norm(b.as_slice())) {
                text.push_str(&format!(" with translation {h:.4} along the axis (screw)"));
            }
            return text;
        }
        let center = a
            .clone()
            .try_inverse()
            .map(|inv| -(inv * &offset))
            .map(|c| format!("{:.4?}", c.map(tidy).as_slice()))
            .unwrap_or_else(|| "(none)".into());
        match (rotating, scaling) {
            (true, false) => format!("rotation at {:.4} rad/unit about {center}", w[(1, 0)]),
            (false, true) => format!("dilation at rate {s:.4} about {center}"),
            _ => format!(
                "spiral similarity (rotation {:.4?}, dilation rate {s:.4}) about {center}",
                w.as_slice()
            ),
        }
    }
}

impl VectorField for AffineGenerator {
    fn dim(&self) -> usize {
        self.block_dim()
    }
    fn eval(&self, x: &[f64], out: &mut [f64]) -> bool {
        let d = self.block_dim();
        for r in 0..d {
            out[r] = self.offset[r] + (0..d).map(|c| self.linear[(r, c)] * x[c]).sum::<f64>();
        }
        true
    }
}

/// A condition that fails in a [`TaskInducedReport`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TaskInducedFailure {
    /// Some field changes the cost.
    NotInvariant,
    /// The fields do not span the level-set directions at every sample.
    NotSpanning,
    /// Some bracket `[X_i, X_j]` is not a constant combination of the fields.
    NotClosed,
    /// Some flow did not exist up to the tested time.
    NotComplete,
}

impl fmt::Display for TaskInducedFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::NotInvariant => "not invariant",
            Self::NotSpanning => "not spanning",
            Self::NotClosed => "not closed",
            Self::NotComplete => "not complete",
        })
    }
}

/// A flow of the completeness check that did not reach its final time.
#[derive(Debug, Clone, PartialEq)]
pub struct FlowFailure {
    /// Index of the field.
    pub field: usize,
    /// Start point (block coordinates).
    pub start: Vec<f64>,
    /// Requested flow time (units of `ξ`).
    pub time: f64,
    /// What the integrator reported.
    pub status: FlowStatus,
}

/// Numerical evidence that fields generate a task-induced symmetry group (Sec. III-C).
#[derive(Debug, Clone, PartialEq)]
pub struct TaskInducedReport {
    /// Block dimension `d`.
    pub dim: usize,
    /// Number of fields `k`.
    pub fields: usize,
    /// Dimension `d − 1` of the level sets of `c`.
    pub level_set_dim: usize,
    /// Check samples used (fresh points, not those of discovery).
    pub samples: usize,
    /// Max over samples and fields of `|∇c·X| / (|∇c||X|)` (dimensionless).
    pub invariance_residual: f64,
    /// `invariance_residual ≤ invariance_tol`.
    pub invariant: bool,
    /// Min over samples of the rank of the fields projected on the level-set tangent space.
    pub spanning_rank: usize,
    /// Min over samples of `σ_{d−1}/σ_1` of the projected fields (0 when fewer than `d − 1` fields).
    pub spanning_margin: f64,
    /// `spanning_rank == level_set_dim`: the fields span the level set at every sample.
    pub spanning: bool,
    /// Max over pairs `i < j` of `max_s |[X_i,X_j](x_s) − Σ_l c_ij^l X_l(x_s)|`, with `c_ij`
    /// fitted by least squares over all samples, divided by `max_s|X_i| · max_s|X_j| / ρ`
    /// (`ρ` = sampling half-width), so that it does not depend on units.
    pub closure_residual: f64,
    /// The pair `(i, j)` with the largest closure residual, if any pair exists.
    pub closure_worst_pair: Option<(usize, usize)>,
    /// `closure_residual ≤ closure_tol`.
    pub closed: bool,
    /// Fitted structure constants `c_ij^l` as `structure_constants[i][j][l]` (antisymmetric in `i, j`).
    pub structure_constants: Vec<Vec<Vec<f64>>>,
    /// Every tested flow reached `t = ±flow_time` with finite values.
    pub complete: bool,
    /// How completeness was established (theory for affine fields, plus the numerical check).
    pub completeness_note: String,
    /// Flows that failed in the completeness check.
    pub flow_failures: Vec<FlowFailure>,
    /// Tolerances used: `(invariance_tol, rank_tol, closure_tol)`.
    pub tolerances: (f64, f64, f64),
}

impl TaskInducedReport {
    /// The failing conditions, in the order invariance, spanning, closure, completeness.
    pub fn failures(&self) -> Vec<TaskInducedFailure> {
        let mut f = Vec::new();
        if !self.invariant {
            f.push(TaskInducedFailure::NotInvariant);
        }
        if !self.spanning {
            f.push(TaskInducedFailure::NotSpanning);
        }
        if !self.closed {
            f.push(TaskInducedFailure::NotClosed);
        }
        if !self.complete {
            f.push(TaskInducedFailure::NotComplete);
        }
        f
    }

    /// Closed and complete: the fields generate a Lie group acting by their flows (eq. 7).
    pub fn is_group(&self) -> bool {
        self.closed && self.complete
    }

    /// All four conditions hold.
    pub fn is_ok(&self) -> bool {
        self.failures().is_empty()
    }

    /// Which condition fails, in words (or `ok: …`).
    pub fn verdict(&self) -> String {
        let (k, m) = (self.fields, self.level_set_dim);
        let (inv_tol, _rank_tol, clo_tol) = self.tolerances;
        let fails = self.failures();
        if fails.is_empty() {
            return format!(
                "ok: {k} field(s) preserve the cost, span the {m}-dimensional level sets, are closed under the Lie bracket and complete: they generate a {k}-dimensional Lie group acting by their flows (eq. 7)"
            );
        }
        if k == 0 && self.invariant && self.closed && self.complete {
            return format!(
                "not spanning: the cost has no continuous symmetry among the candidate fields (0 of the {m} level-set directions are generated); only the trivial group acts"
            );
        }
        let mut parts = Vec::new();
        for f in &fails {
            parts.push(match f {
                TaskInducedFailure::NotInvariant => format!(
                    "not invariant: a field changes the cost (max |∇c·X|/(|∇c||X|) = {:.2e} > {inv_tol:.0e})",
                    self.invariance_residual
                ),
                TaskInducedFailure::NotSpanning => format!(
                    "not spanning: the {k} field(s) span only {} of the {m} level-set directions at some samples",
                    self.spanning_rank
                ),
                TaskInducedFailure::NotClosed => {
                    let (i, j) = self.closure_worst_pair.unwrap_or((0, 0));
                    format!(
                        "not closed: the bracket [X_{i}, X_{j}] is not a constant combination of the fields (relative residual {:.2e} > {clo_tol:.0e})",
                        self.closure_residual
                    )
                }
                TaskInducedFailure::NotComplete => {
                    format!("not complete: {}", self.completeness_note)
                }
            });
        }
        let tail = if self.is_group() {
            if !self.invariant {
                "; the fields still generate a Lie group acting by their flows (eq. 7), but it does not preserve the cost"
            } else {
                "; the fields still generate a Lie group acting by their flows (eq. 7), but it does not move along every cost-preserving direction"
            }
        } else {
            "; no group action by flows follows (eq. 7 needs closure and completeness)"
        };
        format!("{}{tail}", parts.join("; "))
    }
}

/// Checks invariance, spanning, closure and completeness of arbitrary fields on `R^d` for `cost`.
///
/// Completeness of general fields can only be tested, not proven: flows from
/// `settings.flow_starts` samples to `t = ±settings.flow_time` must finish.
pub fn check_fields(
    cost: &Cost,
    fields: &[&dyn VectorField],
    settings: &TaskInducedSettings,
) -> Result<TaskInducedReport, TaskInducedError> {
    check_impl(cost, fields, settings, false)
}

fn check_impl(
    cost: &Cost,
    fields: &[&dyn VectorField],
    settings: &TaskInducedSettings,
    affine: bool,
) -> Result<TaskInducedReport, TaskInducedError> {
    let d = cost.dim();
    settings.validate(d)?;
    for (index, f) in fields.iter().enumerate() {
        if f.dim() != d {
            return Err(TaskInducedError::FieldDimension {
                index,
                expected: d,
                got: f.dim(),
            });
        }
    }
    let k = fields.len();
    let m = d - 1;
    let region = Region::new(cost, settings);
    let all = region.sample(cost, settings.samples, settings.seed ^ CHECK_SEED)?;

    // Field values; samples where some field is undefined are dropped.
    let mut points = Vec::new();
    let mut normals = Vec::new();
    let mut values: Vec<Vec<Vec<f64>>> = Vec::new();
    for (x, n) in all.points.iter().zip(&all.normals) {
        let mut vs = Vec::with_capacity(k);
        let mut ok = true;
        for f in fields {
            let mut v = vec![0.0; d];
            if !f.eval(x, &mut v) || v.iter().any(|a| !a.is_finite()) {
                ok = false;
                break;
            }
            vs.push(v);
        }
        if ok {
            points.push(x.clone());
            normals.push(n.clone());
            values.push(vs);
        }
    }
    let s_count = points.len();
    let field_scale = values.iter().flatten().map(|v| norm(v)).fold(0.0, f64::max);

    // Invariance.
    let mut invariance: f64 = if s_count == 0 && k > 0 {
        f64::INFINITY
    } else {
        0.0
    };
    for (vs, n) in values.iter().zip(&normals) {
        for v in vs {
            let vn = norm(v);
            if vn > 1e-12 * field_scale {
                invariance = invariance.max(dot(n, v).abs() / vn);
            }
        }
    }

    // Spanning: rank of (I − n nᵀ)[X_1 … X_k] at every sample.
    let mut spanning_rank = if s_count == 0 { 0 } else { usize::MAX };
    let mut spanning_margin: f64 = if s_count == 0 || k < m {
        0.0
    } else {
        f64::INFINITY
    };
    for (vs, n) in values.iter().zip(&normals) {
        let (rank, margin) = if k == 0 {
            (0, 0.0)
        } else {
            let mut p = DMatrix::zeros(d, k);
            for (c, v) in vs.iter().enumerate() {
                let a = dot(n, v);
                for r in 0..d {
                    p[(r, c)] = v[r] - a * n[r];
                }
            }
            let mut sv: Vec<f64> = p.singular_values().iter().copied().collect();
            sv.sort_by(|a, b| b.total_cmp(a));
            let s1 = sv[0];
            if s1.is_nan() || s1 <= settings.rank_tol * field_scale {
                (0, 0.0)
            } else {
                let rank = sv.iter().filter(|s| **s > settings.rank_tol * s1).count();
                let margin = if m >= 1 && sv.len() >= m {
                    sv[m - 1] / s1
                } else {
                    0.0
                };
                (rank, margin)
            }
        };
        spanning_rank = spanning_rank.min(rank);
        spanning_margin = spanning_margin.min(margin);
    }
    let spanning_rank = spanning_rank.min(m);
    if !spanning_margin.is_finite() {
        spanning_margin = 0.0;
    }

    // Closure: [X_i, X_j] ≈ Σ_l c_ij^l X_l with constant c over all samples.
    let mut structure = vec![vec![vec![0.0; k]; k]; k];
    let mut closure: f64 = 0.0;
    let mut worst_pair = None;
    if k >= 2 && s_count > 0 {
        let mut mat = DMatrix::zeros(s_count * d, k);
        let mut fmax = vec![0.0f64; k];
        for (s, vs) in values.iter().enumerate() {
            for (l, v) in vs.iter().enumerate() {
                fmax[l] = fmax[l].max(norm(v));
                for r in 0..d {
                    mat[(s * d + r, l)] = v[r];
                }
            }
        }
        let svd = mat.clone().svd(true, true);
        let smax = svd.singular_values.iter().copied().fold(0.0, f64::max);
        let pinv = svd
            .pseudo_inverse(1e-12 * smax.max(f64::MIN_POSITIVE))
            .unwrap_or_else(|_| DMatrix::zeros(k, s_count * d));
        let mut rhs = DVector::zeros(s_count * d);
        let mut b = vec![0.0; d];
        for i in 0..k {
            for j in (i + 1)..k {
                let mut defined = true;
                for (s, x) in points.iter().enumerate() {
                    if !lie_bracket(fields[i], fields[j], x, settings.fd_step, &mut b) {
                        defined = false;
                        break;
                    }
                    for r in 0..d {
                        rhs[s * d + r] = b[r];
                    }
                }
                let resid = if defined {
                    let c = &pinv * &rhs;
                    let fit = &mat * &c;
                    let mut worst: f64 = 0.0;
                    for s in 0..s_count {
                        let e: f64 = (0..d)
                            .map(|r| (rhs[s * d + r] - fit[s * d + r]).powi(2))
                            .sum::<f64>()
                            .sqrt();
                        worst = worst.max(e);
                    }
                    for l in 0..k {
                        structure[i][j][l] = c[l];
                        structure[j][i][l] = -c[l];
                    }
                    let scale = fmax[i] * fmax[j] / region.radius;
                    if scale > 0.0 {
                        worst / scale
                    } else {
                        0.0
                    }
                } else {
                    f64::INFINITY
                };
                let resid = if resid.is_nan() { f64::INFINITY } else { resid };
                if worst_pair.is_none() || resid > closure {
                    closure = resid;
                    worst_pair = Some((i, j));
                }
            }
        }
    }

    // Completeness: flows to ±T from a few samples.
    let mut failures = Vec::new();
    let mut flows = 0;
    let mut ws = FlowWorkspace::new(d);
    let mut out = vec![0.0; d];
    let starts = settings.flow_starts.min(s_count);
    for (f, field) in fields.iter().enumerate() {
        for x in points.iter().take(starts) {
            for time in [settings.flow_time, -settings.flow_time] {
                flows += 1;
                let st = integrate(*field, time, x, &mut out, &settings.flow, &mut ws);
                if !st.is_done() || out.iter().any(|v| !v.is_finite()) {
                    failures.push(FlowFailure {
                        field: f,
                        start: x.clone(),
                        time,
                        status: st,
                    });
                }
            }
        }
    }
    let t = settings.flow_time;
    let completeness_note = if let Some(fl) = failures.first() {
        format!(
            "{} of {flows} flows did not reach t = ±{t}: e.g. field {} from {:.4?} towards t = {}: {:?}",
            failures.len(),
            fl.field,
            fl.start,
            fl.time,
            fl.status
        )
    } else if affine {
        format!("affine fields are complete (the flow x ↦ e^(tA) x + ∫ e^(sA) b ds exists for all t); confirmed numerically: {flows} flows to t = ±{t} finished")
    } else {
        format!("{flows} flows from {starts} samples to t = ±{t} finished (a numerical test, not a proof of completeness)")
    };

    Ok(TaskInducedReport {
        dim: d,
        fields: k,
        level_set_dim: m,
        samples: s_count,
        invariance_residual: invariance,
        invariant: invariance <= settings.invariance_tol,
        spanning_rank,
        spanning_margin,
        spanning: s_count > 0 && spanning_rank == m,
        closure_residual: closure,
        closure_worst_pair: worst_pair,
        closed: closure <= settings.closure_tol,
        structure_constants: structure,
        complete: failures.is_empty(),
        completeness_note,
        flow_failures: failures,
        tolerances: (
            settings.invariance_tol,
            settings.rank_tol,
            settings.closure_tol,
        ),
    })
}

/// Rotation basis of so(d) (about the origin): `J` for d = 2, `[e_x]×, [e_y]×, [e_z]×` for d = 3.
fn rotation_basis(d: usize) -> Vec<[[f64; 3]; 3]> {
    let ez = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    if d == 2 {
        vec![ez]
    } else {
        vec![
            [[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]],
            ez,
        ]
    }
}

/// Reduced row echelon form in place (partial pivoting); returns the pivot columns.
fn rref(m: &mut DMatrix<f64>, tol: f64) -> Vec<usize> {
    let (rows, cols) = m.shape();
    let mut pivots = Vec::new();
    let mut r = 0;
    for c in 0..cols {
        if r == rows {
            break;
        }
        let mut best = r;
        for i in (r + 1)..rows {
            if m[(i, c)].abs() > m[(best, c)].abs() {
                best = i;
            }
        }
        if m[(best, c)].abs() <= tol {
            for i in r..rows {
                m[(i, c)] = 0.0;
            }
            continue;
        }
        m.swap_rows(r, best);
        let p = m[(r, c)];
        for j in 0..cols {
            m[(r, j)] /= p;
        }
        for i in 0..rows {
            if i != r {
                let f = m[(i, c)];
                if f != 0.0 {
                    for j in 0..cols {
                        let v = m[(r, j)];
                        m[(i, j)] -= f * v;
                    }
                }
            }
        }
        pivots.push(c);
        r += 1;
    }
    pivots
}

/// Result of the nullspace computation: tidy generators and the relative singular values.
fn discover_generators(
    cost: &Cost,
    settings: &TaskInducedSettings,
) -> Result<(Vec<AffineGenerator>, Vec<f64>), TaskInducedError> {
    let d = cost.dim();
    let region = Region::new(cost, settings);
    let samples = region.sample(cost, settings.samples, settings.seed)?;
    let rots = rotation_basis(d);
    let nr = rots.len();
    let nl = nr + 1; // rotations + dilation
    let kc = nl + d;
    let (o, rho) = (&region.center, region.radius);
    let cand = |c: usize, u: &[f64], out: &mut [f64]| {
        for r in 0..d {
            out[r] = if c < nr {
                (0..d).map(|j| rots[c][r][j] * u[j]).sum()
            } else if c == nr {
                u[r]
            } else {
                f64::from(u8::from(r == c - nl))
            };
        }
    };
    let s_count = samples.points.len();
    let mut g = DMatrix::zeros(s_count, kc);
    let mut u = vec![0.0; d];
    let mut v = vec![0.0; d];
    for (s, (x, n)) in samples.points.iter().zip(&samples.normals).enumerate() {
        for i in 0..d {
            u[i] = (x[i] - o[i]) / rho;
        }
        for c in 0..kc {
            cand(c, &u, &mut v);
            g[(s, c)] = dot(n, &v);
        }
    }
    let svd = g.svd(false, true);
    let vt = svd.v_t.expect("SVD with V requested");
    let sv = svd.singular_values;
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let null: Vec<usize> = (0..sv.len())
        .filter(|&i| sv[i] <= settings.nullspace_tol * smax)
        .collect();
    let mut rel: Vec<f64> = sv.iter().map(|s| s / smax).collect();
    rel.sort_by(|a, b| b.total_cmp(a));

    let mut basis = DMatrix::zeros(null.len(), kc);
    for (r, &i) in null.iter().enumerate() {
        basis.row_mut(r).copy_from(&vt.row(i));
    }
    let pivots = rref(&mut basis, 1e-9);
    let round = |x: f64| if x.abs() < 1e-11 { 0.0 } else { x };
    basis.apply(|x| *x = round(*x));

    // Pure translations: rows whose pivot is a translation column; orthonormalise them.
    let mut trans: Vec<Vec<f64>> = Vec::new();
    for (r, &p) in pivots.iter().enumerate() {
        if p >= nl {
            let mut t: Vec<f64> = (0..d).map(|i| basis[(r, nl + i)]).collect();
            for q in &trans {
                let a = dot(&t, q);
                for i in 0..d {
                    t[i] -= a * q[i];
                }
            }
            let tn = norm(&t);
            if tn > 1e-9 {
                trans.push(t.iter().map(|x| round(x / tn)).collect());
            }
        }
    }
    let mut gens = Vec::new();
    for (r, &p) in pivots.iter().enumerate() {
        if p >= nl {
            continue;
        }
        // Linear part l (rotation + dilation coordinates) and translation part τ ⊥ translations.
        let l: Vec<f64> = (0..nl).map(|c| basis[(r, c)]).collect();
        let mut tau: Vec<f64> = (0..d).map(|i| basis[(r, nl + i)]).collect();
        for q in &trans {
            let a = dot(&tau, q);
            for i in 0..d {
                tau[i] -= a * q[i];
            }
        }
        // Unit rate: the row is scaled by f = ρ/|l| (|l| ≥ 1: the pivot entry is 1), so that
        // A = f Σ_c l_c B_c / ρ = Σ_c (l_c/|l|) B_c and b = f τ − A o.
        let ln = norm(&l);
        let f = rho / ln;
        let mut a = DMatrix::zeros(d, d);
        for (c, lc) in l.iter().enumerate() {
            let coef = lc / ln;
            for i in 0..d {
                for j in 0..d {
                    a[(i, j)] += coef
                        * if c < nr {
                            rots[c][i][j]
                        } else {
                            f64::from(u8::from(i == j))
                        };
                }
            }
        }
        let tau = DVector::from_iterator(d, tau.iter().map(|t| round(*t) * f));
        let b = tau - &a * DVector::from_column_slice(o);
        gens.push(AffineGenerator::new(a, b));
    }
    for t in trans {
        gens.push(AffineGenerator::translation(&t));
    }
    Ok((gens, rel))
}

/// A task-induced symmetry: affine generators preserving a cost, acting on `B` task blocks by
/// their flows (eq. 7), with the evidence that they form a group.
#[derive(Debug, Clone)]
pub struct TaskInducedSymmetry {
    name: String,
    cost: Cost,
    blocks: usize,
    generators: Vec<AffineGenerator>,
    singular_values: Vec<f64>,
    report: TaskInducedReport,
    flow: FlowSettings,
}

impl TaskInducedSymmetry {
    /// Discovers the cost-preserving affine fields of `cost` (nullspace of `G`) and checks them.
    pub fn discover(
        name: &str,
        cost: &Cost,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        if blocks == 0 {
            return Err(TaskInducedError::NoBlocks);
        }
        settings.validate(cost.dim())?;
        let (generators, singular_values) = discover_generators(cost, settings)?;
        let refs: Vec<&dyn VectorField> =
            generators.iter().map(|g| g as &dyn VectorField).collect();
        let report = check_impl(cost, &refs, settings, true)?;
        Ok(Self {
            name: name.into(),
            cost: cost.clone(),
            blocks,
            generators,
            singular_values,
            report,
            flow: settings.flow,
        })
    }

    /// Builds the cost from `spec` on `block_dim`-dimensional blocks, then [`Self::discover`].
    pub fn from_spec(
        name: &str,
        spec: &CostSpec,
        block_dim: usize,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        Self::discover(name, &Cost::new(spec, block_dim)?, blocks, settings)
    }

    /// Uses the given affine generators (e.g. from a user) and checks them against `cost`.
    pub fn from_generators(
        name: &str,
        cost: &Cost,
        generators: Vec<AffineGenerator>,
        blocks: usize,
        settings: &TaskInducedSettings,
    ) -> Result<Self, TaskInducedError> {
        if blocks == 0 {
            return Err(TaskInducedError::NoBlocks);
        }
        let refs: Vec<&dyn VectorField> =
            generators.iter().map(|g| g as &dyn VectorField).collect();
        let report = check_impl(cost, &refs, settings, true)?;
        Ok(Self {
            name: name.into(),
            cost: cost.clone(),
            blocks,
            generators,
            singular_values: Vec::new(),
            report,
            flow: settings.flow,
        })
    }

    /// Name from configuration.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The cost whose level sets the group preserves (one block).
    pub fn cost(&self) -> &Cost {
        &self.cost
    }

    /// Block dimension `d`.
    pub fn block_dim(&self) -> usize {
        self.cost.dim()
    }

    /// Number of blocks `B`.
    pub fn blocks(&self) -> usize {
        self.blocks
    }

    /// Dimension `B·d` of the space acted on.
    pub fn dim(&self) -> usize {
        self.blocks * self.cost.dim()
    }

    /// Dimension `k` of the Lie algebra (number of generators).
    pub fn algebra_dim(&self) -> usize {
        self.generators.len()
    }

    /// The identity element's exponential coordinates (all zero).
    pub fn identity(&self) -> Vec<f64> {
        vec![0.0; self.algebra_dim()]
    }

    /// The affine generators `X_k(x) = A_k x + b_k` on one block.
    pub fn generators(&self) -> &[AffineGenerator] {
        &self.generators
    }

    /// Singular values of `G` relative to the largest, descending (empty if not discovered).
    pub fn singular_values(&self) -> &[f64] {
        &self.singular_values
    }

    /// Invariance, spanning, closure and completeness evidence.
    pub fn report(&self) -> &TaskInducedReport {
        &self.report
    }

    /// Integrator settings used by the [`TaskGroupAction`] implementation.
    pub fn flow_settings(&self) -> &FlowSettings {
        &self.flow
    }

    /// The infinitesimal generator `X_ξ = Σ_k ξ_k X_k` on all blocks (allocation-free).
    pub fn field(&self, xi: &[f64]) -> TaskInducedField {
        assert_eq!(
            xi.len(),
            self.algebra_dim(),
            "`{}`: ξ has {} coordinates, the algebra has dimension {}",
            self.name,
            xi.len(),
            self.algebra_dim()
        );
        let d = self.block_dim();
        let mut a = [[0.0; 3]; 3];
        let mut b = [0.0; 3];
        for (g, &t) in self.generators.iter().zip(xi) {
            for r in 0..d {
                b[r] += t * g.offset[r];
                for c in 0..d {
                    a[r][c] += t * g.linear[(r, c)];
                }
            }
        }
        TaskInducedField {
            block_dim: d,
            blocks: self.blocks,
            a,
            b,
        }
    }

    /// The `k`-th basis generator `X_k` on all blocks.
    pub fn generator(&self, k: usize) -> TaskInducedField {
        let mut xi = vec![0.0; self.algebra_dim()];
        xi[k] = 1.0;
        self.field(&xi)
    }

    /// Scratch for [`Self::differential`] (allocates; setup only).
    pub fn workspace(&self) -> TaskInducedWorkspace {
        let n = self.dim();
        TaskInducedWorkspace {
            var: FlowWorkspace::new(2 * n),
            y0: vec![0.0; 2 * n],
            y1: vec![0.0; 2 * n],
        }
    }

    /// `out = Φ_T(exp(ξ), x)`: the flow of `X_ξ` for unit time (eq. 7); allocation-free.
    ///
    /// `ws` must have dimension [`Self::dim`].
    pub fn act(
        &self,
        xi: &[f64],
        x: &[f64],
        out: &mut [f64],
        settings: &FlowSettings,
        ws: &mut FlowWorkspace,
    ) -> FlowStatus {
        let field = self.field(xi);
        integrate(&field, 1.0, x, out, settings, ws)
    }

    /// `v_out = dΦ_{exp ξ}|_x v` by the variational equation; the moved point is
    /// [`TaskInducedWorkspace::point`] afterwards. Allocates the variational field's scratch.
    pub fn differential(
        &self,
        xi: &[f64],
        x: &[f64],
        v: &[f64],
        v_out: &mut [f64],
        settings: &FlowSettings,
        ws: &mut TaskInducedWorkspace,
    ) -> FlowStatus {
        let n = self.dim();
        let field = self.field(xi);
        let var = VariationalField::new(&field, DEFAULT_FD_STEP);
        ws.y0[..n].copy_from_slice(x);
        ws.y0[n..].copy_from_slice(v);
        let st = integrate(&var, 1.0, &ws.y0, &mut ws.y1, settings, &mut ws.var);
        v_out.copy_from_slice(&ws.y1[n..]);
        st
    }

    /// `(E, e)` with `[[E, e], [0, 1]] = exp([[A_ξ, b_ξ], [0, 0]])`: the exact block transform.
    pub fn block_transform(&self, xi: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
        let d = self.block_dim();
        let f = self.field(xi);
        let mut aug = DMatrix::zeros(d + 1, d + 1);
        for r in 0..d {
            for c in 0..d {
                aug[(r, c)] = f.a[r][c];
            }
            aug[(r, d)] = f.b[r];
        }
        let ex = aug.exp();
        (
            ex.view((0, 0), (d, d)).into_owned(),
            ex.view((0, d), (d, 1)).column(0).into_owned(),
        )
    }

    /// `out = E x_b + e` on every block: the closed-form flow of affine generators (reference).
    pub fn act_closed_form(&self, xi: &[f64], x: &[f64], out: &mut [f64]) {
        let (e, t) = self.block_transform(xi);
        let d = self.block_dim();
        for b in 0..self.blocks {
            for r in 0..d {
                out[b * d + r] = t[r] + (0..d).map(|c| e[(r, c)] * x[b * d + c]).sum::<f64>();
            }
        }
    }
}

impl TaskGroupAction for TaskInducedSymmetry {
    fn name(&self) -> &str {
        &self.name
    }
    fn dim(&self) -> usize {
        TaskInducedSymmetry::dim(self)
    }
    fn algebra_dim(&self) -> usize {
        TaskInducedSymmetry::algebra_dim(self)
    }
    fn generator_field(&self, xi: &[f64]) -> Box<dyn VectorField + '_> {
        Box::new(self.field(xi))
    }
    fn act_on(&self, xi: &[f64], x: &[f64], out: &mut [f64]) -> bool {
        let mut ws = FlowWorkspace::new(self.dim());
        self.act(xi, x, out, &self.flow, &mut ws).is_done()
    }
    fn differential_on(&self, xi: &[f64], x: &[f64], v: &[f64], out: &mut [f64]) -> bool {
        let mut ws = self.workspace();
        self.differential(xi, x, v, out, &self.flow, &mut ws)
            .is_done()
    }
}

/// Scratch for [`TaskInducedSymmetry::differential`].
#[derive(Debug, Clone)]
pub struct TaskInducedWorkspace {
    var: FlowWorkspace,
    y0: Vec<f64>,
    y1: Vec<f64>,
}

impl TaskInducedWorkspace {
    /// The point `Φ_T(exp ξ, x)` reached by the last [`TaskInducedSymmetry::differential`].
    pub fn point(&self) -> &[f64] {
        &self.y1[..self.y1.len() / 2]
    }
}

/// The field `X_ξ(x) = A_ξ x_b + b_ξ` on every block `b` of `R^{B·d}` (stack only).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskInducedField {
    block_dim: usize,
    blocks: usize,
    a: [[f64; 3]; 3],
    b: [f64; 3],
}

impl VectorField for TaskInducedField {
    fn dim(&self) -> usize {
        self.block_dim * self.blocks
    }
    fn eval(&self, x: &[f64], out: &mut [f64]) -> bool {
        let d = self.block_dim;
        for blk in 0..self.blocks {
            let xb = &x[blk * d..(blk + 1) * d];
            for r in 0..d {
                out[blk * d + r] = self.b[r] + (0..d).map(|c| self.a[r][c] * xb[c]).sum::<f64>();
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fd_gradient(c: &Cost, x: &[f64]) -> Vec<f64> {
        let h = 1e-6;
        (0..x.len())
            .map(|i| {
                let mut p = x.to_vec();
                let mut m = x.to_vec();
                p[i] += h;
                m[i] -= h;
                (c.value(&p) - c.value(&m)) / (2.0 * h)
            })
            .collect()
    }

    #[test]
    fn analytic_gradients_match_finite_differences() {
        let spec = CostSpec::Sum {
            terms: vec![
                WeightedCost {
                    weight: 2.0,
                    cost: CostSpec::DistanceToPoint {
                        point: vec![0.1, -0.2, 0.3],
                    },
                },
                WeightedCost {
                    weight: -0.5,
                    cost: CostSpec::DistanceToLine {
                        point: vec![1.0, 0.0, 0.0],
                        direction: vec![0.0, 2.0, 1.0],
                    },
                },
                WeightedCost {
                    weight: 1.5,
                    cost: CostSpec::HeightAbovePlane {
                        point: vec![0.0, 0.0, 1.0],
                        normal: vec![1.0, 1.0, 1.0],
                    },
                },
            ],
        };
        let c = spec.build(3).unwrap();
        assert_eq!(c.terms(), 3);
        let x = [0.7, 0.4, -1.1];
        let mut g = [0.0; 3];
        assert!(c.gradient(&x, &mut g));
        let fd = fd_gradient(&c, &x);
        for i in 0..3 {
            assert!((g[i] - fd[i]).abs() < 1e-7, "{g:?} vs {fd:?}");
        }
        // Height is signed and uses the unit normal.
        let h = CostSpec::HeightAbovePlane {
            point: vec![0.0, 0.0],
            normal: vec![0.0, -3.0],
        }
        .build(2)
        .unwrap();
        assert!((h.value(&[5.0, 2.0]) + 2.0).abs() < 1e-15);
        // Undefined exactly at the point.
        let p = CostSpec::DistanceToPoint {
            point: vec![1.0, 2.0],
        }
        .build(2)
        .unwrap();
        assert!(!p.gradient(&[1.0, 2.0], &mut g[..2]));
    }

    #[test]
    fn rref_reduces_and_reports_pivots() {
        let mut m = DMatrix::from_row_slice(2, 3, &[0.0, 2.0, 4.0, 1.0, 1.0, 1.0]);
        let p = rref(&mut m, 1e-12);
        assert_eq!(p, vec![0, 1]);
        let want = [1.0, 0.0, -1.0, 0.0, 1.0, 2.0];
        for (i, w) in want.iter().enumerate() {
            assert!((m[(i / 3, i % 3)] - w).abs() < 1e-15, "{m}");
        }
    }

    #[test]
    fn numerical_structure_constants_match_exact_brackets() {
        let spec = CostSpec::HeightAbovePlane {
            point: vec![0.0, 0.0, 0.5],
            normal: vec![0.0, 0.0, 1.0],
        };
        let sym = TaskInducedSymmetry::from_spec("T", &spec, 3, 1, &TaskInducedSettings::default())
            .unwrap();
        let g = sym.generators();
        let c = &sym.report().structure_constants;
        for i in 0..g.len() {
            for j in 0..g.len() {
                if i == j {
                    continue;
                }
                let exact = g[i].bracket(&g[j]);
                let mut fit = AffineGenerator::new(DMatrix::zeros(3, 3), DVector::zeros(3));
                for (l, gl) in g.iter().enumerate() {
                    fit.linear += &gl.linear * c[i][j][l];
                    fit.offset += &gl.offset * c[i][j][l];
                }
                assert!((exact.linear - fit.linear).norm() < 1e-8);
                assert!((exact.offset - fit.offset).norm() < 1e-8);
            }
        }
    }

    #[test]
    fn settings_round_trip_and_reject_bad_values() {
        let s: TaskInducedSettings =
            toml::from_str("samples = 64\nseed = 3\n[region]\nlower = [0, 0]\nupper = [1, 2]\n")
                .unwrap();
        assert_eq!(s.samples, 64);
        assert!(s.validate(2).is_ok());
        assert!(s.validate(3).is_err());
        let bad = TaskInducedSettings {
            closure_tol: 0.0,
            ..TaskInducedSettings::default()
        };
        let e = bad.validate(3).unwrap_err().to_string();
        assert!(e.contains("closure_tol"), "{e}");
    }
}
