//! The four checks of fields on `R^d` for a cost: invariance, spanning of the level set,
//! closure under the bracket (structure constants) and completeness of the flows.

use super::cost::dot;
use super::cost::norm;
use super::cost::Cost;
use super::error::TaskInducedError;
use super::sampling::Region;
use super::sampling::Samples;
use super::settings::TaskInducedSettings;
use std::fmt;

use nalgebra::{DMatrix, DVector};

use crate::symmetry::field::{lie_bracket, VectorField};
use crate::symmetry::transfer::flow::{integrate, FlowStatus, FlowWorkspace};

/// Seed offset of the check samples, so that checks use points not seen by discovery.
const CHECK_SEED: u64 = 0x9E37_79B9_7F4A_7C15;

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

/// Fields evaluated on the sampled level-set points: the samples where every field is
/// defined and finite, their unit normals `∇c/|∇c|`, and the field values there.
struct FieldSamples {
    points: Vec<Vec<f64>>,
    normals: Vec<Vec<f64>>,
    /// `values[s][l]`: field `l` at point `s`.
    values: Vec<Vec<Vec<f64>>>,
    /// Largest field norm over all samples (the scale of the relative tolerances).
    scale: f64,
}

impl FieldSamples {
    /// Evaluates `fields` on `all`; samples where some field is undefined are dropped.
    fn evaluate(fields: &[&dyn VectorField], all: &Samples, d: usize) -> Self {
        let k = fields.len();
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
        let scale = values.iter().flatten().map(|v| norm(v)).fold(0.0, f64::max);
        Self {
            points,
            normals,
            values,
            scale,
        }
    }

    fn len(&self) -> usize {
        self.points.len()
    }
}

/// Invariance: the largest `|∇c·X| / (|∇c| |X|)` over samples and fields (∞ with fields
/// but no sample).
fn invariance_residual(samples: &FieldSamples, k: usize) -> f64 {
    let mut invariance: f64 = if samples.len() == 0 && k > 0 {
        f64::INFINITY
    } else {
        0.0
    };
    for (vs, n) in samples.values.iter().zip(&samples.normals) {
        for v in vs {
            let vn = norm(v);
            if vn > 1e-12 * samples.scale {
                invariance = invariance.max(dot(n, v).abs() / vn);
            }
        }
    }
    invariance
}

/// Spanning: the smallest rank of `(I − n nᵀ)[X_1 … X_k]` over the samples (at most
/// `m = d − 1`) and the smallest `σ_m / σ_1` (the margin).
fn spanning(
    samples: &FieldSamples,
    d: usize,
    k: usize,
    settings: &TaskInducedSettings,
) -> (usize, f64) {
    let m = d - 1;
    let s_count = samples.len();
    let field_scale = samples.scale;
    let mut spanning_rank = if s_count == 0 { 0 } else { usize::MAX };
    let mut spanning_margin: f64 = if s_count == 0 || k < m {
        0.0
    } else {
        f64::INFINITY
    };
    for (vs, n) in samples.values.iter().zip(&samples.normals) {
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
    (spanning_rank, spanning_margin)
}

/// Closure under the bracket.
struct Closure {
    /// `c_ij^l`, antisymmetric in `i, j`.
    structure: Vec<Vec<Vec<f64>>>,
    /// Worst relative residual of `[X_i, X_j] ≈ Σ_l c_ij^l X_l` (constant `c`).
    residual: f64,
    worst_pair: Option<(usize, usize)>,
}

/// Closure: `[X_i, X_j] ≈ Σ_l c_ij^l X_l` with constant `c` over all samples, fitted by
/// least squares; the residual relative to `|X_i| |X_j| / radius`.
fn closure(
    fields: &[&dyn VectorField],
    samples: &FieldSamples,
    d: usize,
    settings: &TaskInducedSettings,
    radius: f64,
) -> Closure {
    let k = fields.len();
    let s_count = samples.len();
    let mut structure = vec![vec![vec![0.0; k]; k]; k];
    let mut closure: f64 = 0.0;
    let mut worst_pair = None;
    if k >= 2 && s_count > 0 {
        let mut mat = DMatrix::zeros(s_count * d, k);
        let mut fmax = vec![0.0f64; k];
        for (s, vs) in samples.values.iter().enumerate() {
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
                for (s, x) in samples.points.iter().enumerate() {
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
                    let scale = fmax[i] * fmax[j] / radius;
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
    Closure {
        structure,
        residual: closure,
        worst_pair,
    }
}

/// Completeness: flows of every field from the first `flow_starts` samples to `t = ±T`;
/// the failures and the report's note (`affine` fields are complete in theory).
fn completeness(
    fields: &[&dyn VectorField],
    samples: &FieldSamples,
    d: usize,
    settings: &TaskInducedSettings,
    affine: bool,
) -> (Vec<FlowFailure>, String) {
    let mut failures = Vec::new();
    let mut flows = 0;
    let mut ws = FlowWorkspace::new(d);
    let mut out = vec![0.0; d];
    let starts = settings.flow_starts.min(samples.len());
    for (f, field) in fields.iter().enumerate() {
        for x in samples.points.iter().take(starts) {
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
    let note = if let Some(fl) = failures.first() {
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
    (failures, note)
}

/// The four checks of `fields` for `cost` ([`check_fields`]; `affine` fields are known to
/// be complete, which the completeness note says).
pub(super) fn check_impl(
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
    let samples = FieldSamples::evaluate(fields, &all, d);
    let s_count = samples.len();

    let invariance = invariance_residual(&samples, k);
    let (spanning_rank, spanning_margin) = spanning(&samples, d, k, settings);
    let closure = closure(fields, &samples, d, settings, region.radius);
    let (failures, completeness_note) = completeness(fields, &samples, d, settings, affine);

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
        closure_residual: closure.residual,
        closure_worst_pair: closure.worst_pair,
        closed: closure.residual <= settings.closure_tol,
        structure_constants: closure.structure,
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
