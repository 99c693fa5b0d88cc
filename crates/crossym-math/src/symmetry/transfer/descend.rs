//! Descending configuration-space symmetries to task space (paper Sec. IV-A, eqs. 8–10).
//!
//! A group action `Φ_Q` on `Q` descends through the forward kinematics `f: Q → X` when
//! `f` is equivariant (eq. 8):
//!
//! `f(Φ_Q(g, q)) = Φ_X(g, f(q))  ∀ q ∈ Q`,
//!
//! and then the task action is determined by `Φ_Q` and `f` (eq. 10),
//! `Φ_X(g, x) = f(Φ_Q(g, q))` for any `q` with `f(q) = x`. For a morphological symmetry
//! `Φ_Q(g, q) = ρ_Q(g) q` (eq. 4) the descended action is linear, `Φ_X(g, x) = ρ_X(g) x`,
//! with `ρ_X` a permutation of the end-effector coordinates (eq. 9; Example 1:
//! `ρ_X = [[0, P_X], [P_X, 0]]`, `P_X = diag(1, −1, 1)` for RB-Y1).
//!
//! The check here is numerical, on `N` seeded configurations `q_s` inside the joint limits:
//! 1. fit the linear map `L` (m × m) minimising `Σ_s |f(Φ_Q(g, q_s)) − L f(q_s)|²` (least
//!    squares through an SVD), and the affine map `[L | b]` as well;
//! 2. report the worst residual `max_s |f(Φ_Q(g, q_s)) − L f(q_s) (− b)|`, absolute (task
//!    units) and relative to the workspace size `max_s |f(q_s)|`;
//! 3. if `L` is within a tolerance of a signed permutation, return it as one (eq. 9);
//! 4. independently of any fit, walk along fibres `f⁻¹(f(q_s))` (the vertical directions
//!    `ker J`, Sec. II-C) of redundant robots and check that `f(Φ_Q(g, ·))` stays constant
//!    there — the necessary condition for *some* `Φ_X` to exist, linear or not (eq. 8).
//!
//! When the fit fails but the fibre test passes, eq. 8 holds on the samples with a
//! nonlinear `Φ_X` ([`DescendStatus::NonlinearAction`]); it is then only available
//! pointwise through eq. 10. A failing fibre test proves (up to the tolerance) that the
//! symmetry does not descend ([`DescendStatus::NotEquivariant`]).

use nalgebra::{DMatrix, DVector};

use crate::kinematics::{JointLimits, Kinematics, KinematicsWorkspace};
use crate::symmetry::finite::SignedPermutation;

/// Settings of the numerical descent check.
#[derive(Debug, Clone, PartialEq)]
pub struct DescendSettings {
    /// Number of sampled configurations `N` (must exceed `dim X + 1`).
    pub samples: usize,
    /// Seed of the sampler (runs are deterministic).
    pub seed: u64,
    /// Largest residual relative to the workspace size `max_s |f(q_s)|` counted as equivariant.
    pub relative_tolerance: f64,
    /// Largest entry-wise distance of `L` from a signed permutation for it to be returned as one.
    pub permutation_tolerance: f64,
    /// Number of samples whose fibre is walked for the fit-free test (0 disables it).
    pub fibre_samples: usize,
    /// Length of the walk along each fibre (rad or m, Euclidean in `Q`).
    pub fibre_length: f64,
}

impl Default for DescendSettings {
    fn default() -> Self {
        Self {
            samples: 256,
            seed: 0x5eed_de5c,
            relative_tolerance: 1e-6,
            permutation_tolerance: 1e-6,
            fibre_samples: 16,
            fibre_length: 0.5,
        }
    }
}

/// Outcome of the descent check.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum DescendStatus {
    /// `f` is equivariant and the descended task action is linear or affine (eqs. 8–10).
    Equivariant,
    /// No linear/affine task action fits, but `f(Φ_Q(g, ·))` is constant on the walked fibres:
    /// eq. 8 holds on the samples with a nonlinear `Φ_X`, available pointwise via eq. 10.
    NonlinearAction,
    /// `f` is not equivariant: the symmetry does not descend to task space.
    NotEquivariant,
}

/// The descended task-space action `x ↦ Φ_X(g, x)` (eqs. 9–10).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum DescendedAction {
    /// `x ↦ ρ_X x` with `ρ_X` a signed permutation of task coordinates (eq. 9).
    SignedPermutation(SignedPermutation),
    /// `x ↦ L x` with a general `m × m` matrix `L`.
    Linear(DMatrix<f64>),
    /// `x ↦ L x + b` (task units for `b`); needed when the action does not fix the origin.
    Affine {
        /// Linear part `L` (m × m).
        linear: DMatrix<f64>,
        /// Offset `b` (task units).
        offset: DVector<f64>,
    },
}

impl DescendedAction {
    /// `out = Φ_X(g, x)` (task units). Allocation-free.
    pub fn apply(&self, x: &[f64], out: &mut [f64]) {
        match self {
            Self::SignedPermutation(p) => p.apply(x, out),
            Self::Linear(l) => mat_vec(l, x, out),
            Self::Affine { linear, offset } => {
                mat_vec(linear, x, out);
                for (o, b) in out.iter_mut().zip(offset.iter()) {
                    *o += b;
                }
            }
        }
    }

    /// The linear part `L` as a matrix (the signed-permutation matrix for eq. 9).
    pub fn linear_part(&self) -> DMatrix<f64> {
        match self {
            Self::SignedPermutation(p) => p.matrix(),
            Self::Linear(l) => l.clone(),
            Self::Affine { linear, .. } => linear.clone(),
        }
    }

    /// The signed permutation `ρ_X` when the action is one (eq. 9).
    pub fn as_signed_permutation(&self) -> Option<&SignedPermutation> {
        match self {
            Self::SignedPermutation(p) => Some(p),
            _ => None,
        }
    }
}

fn mat_vec(l: &DMatrix<f64>, x: &[f64], out: &mut [f64]) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = (0..l.ncols()).map(|j| l[(i, j)] * x[j]).sum();
    }
}

/// Result of [`descend`] / [`descend_with`]: status, descended action and residuals.
#[derive(Debug, Clone, PartialEq)]
pub struct DescendReport {
    /// Name of the symmetry that was checked.
    pub symmetry: String,
    /// Whether the symmetry descends, and how.
    pub status: DescendStatus,
    /// The descended task action when [`DescendStatus::Equivariant`].
    pub task_action: Option<DescendedAction>,
    /// Worst residual of the retained fit (linear if it passes, else affine), task units.
    pub max_residual: f64,
    /// `max_residual` divided by the workspace size.
    pub relative_residual: f64,
    /// Worst residual of the linear fit `x ↦ L x` (task units).
    pub linear_residual: f64,
    /// Worst residual of the affine fit `x ↦ L x + b` (task units).
    pub affine_residual: f64,
    /// True when only the affine fit passes (the action moves the origin of `X`).
    pub affine_needed: bool,
    /// Worst `|f(Φ_Q(g, q')) − f(Φ_Q(g, q))|` over walked fibre pairs `f(q') = f(q)` (task
    /// units); `None` when not redundant (`dim Q ≤ dim X`), disabled, or no walk converged.
    pub fibre_residual: Option<f64>,
    /// Number of fibre pairs behind `fibre_residual`.
    pub fibre_pairs: usize,
    /// Workspace size `max_s |f(q_s)|` (task units) used to make residuals relative.
    pub workspace_size: f64,
    /// Rank of the sampled task points `[f(q_s)]` (`< dim X` means `L` is not unique).
    pub sample_rank: usize,
    /// Number of sampled configurations.
    pub samples: usize,
}

impl DescendReport {
    /// True for [`DescendStatus::Equivariant`].
    pub fn descends(&self) -> bool {
        self.status == DescendStatus::Equivariant
    }

    /// The report itself when the symmetry descends with a linear/affine action, otherwise a
    /// refusal naming the symmetry and the residual (for the CLI).
    pub fn require(self) -> Result<Self, DescendError> {
        match self.status {
            DescendStatus::Equivariant => Ok(self),
            DescendStatus::NonlinearAction => Err(DescendError::NonlinearAction {
                symmetry: self.symmetry,
                linear_residual: self.linear_residual,
                affine_residual: self.affine_residual,
                fibre_residual: self.fibre_residual.unwrap_or(f64::NAN),
                samples: self.samples,
            }),
            DescendStatus::NotEquivariant => Err(DescendError::NotEquivariant {
                symmetry: self.symmetry,
                max_residual: self.max_residual,
                relative_residual: self.relative_residual,
                fibre_residual: self.fibre_residual,
                samples: self.samples,
            }),
        }
    }
}

/// Invalid inputs to the descent check, and its refusal where the symmetry does not descend.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum DescendError {
    /// The action's dimension differs from `dim Q`.
    #[error(
        "descending `{symmetry}`: the action acts on R^{action_dim} but the robot has {dof} joints"
    )]
    DimensionMismatch {
        /// Symmetry name.
        symmetry: String,
        /// Dimension the action acts on.
        action_dim: usize,
        /// `dim Q` of the robot.
        dof: usize,
    },
    /// Too few samples to fit an affine map on `X`.
    #[error("descending `{symmetry}`: {samples} samples are too few for a {task_dim}-dimensional task space (need at least {needed})")]
    TooFewSamples {
        /// Symmetry name.
        symmetry: String,
        /// Requested samples.
        samples: usize,
        /// `dim X`.
        task_dim: usize,
        /// Minimum number of samples.
        needed: usize,
    },
    /// `f` is not equivariant under the symmetry (eq. 8 fails).
    #[error("symmetry `{symmetry}` does not descend to task space: f(Φ_Q(g, q)) ≠ L f(q) (+ b), max residual {max_residual:.3e} ({relative_residual:.3e} of the workspace size) over {samples} samples; fibre residual {}", fmt_fibre(*.fibre_residual))]
    NotEquivariant {
        /// Symmetry name.
        symmetry: String,
        /// Worst fit residual (task units).
        max_residual: f64,
        /// Worst fit residual relative to the workspace size.
        relative_residual: f64,
        /// Worst fibre residual (task units), if measured.
        fibre_residual: Option<f64>,
        /// Number of samples.
        samples: usize,
    },
    /// Eq. 8 holds on the samples, but no linear or affine task action fits.
    #[error("symmetry `{symmetry}` descends only with a nonlinear task action (linear-fit residual {linear_residual:.3e}, affine {affine_residual:.3e}, fibre residual {fibre_residual:.3e}, {samples} samples); use eq. 10 pointwise")]
    NonlinearAction {
        /// Symmetry name.
        symmetry: String,
        /// Worst linear-fit residual (task units).
        linear_residual: f64,
        /// Worst affine-fit residual (task units).
        affine_residual: f64,
        /// Worst fibre residual (task units).
        fibre_residual: f64,
        /// Number of samples.
        samples: usize,
    },
}

fn fmt_fibre(r: Option<f64>) -> String {
    r.map_or_else(|| "not measured".into(), |r| format!("{r:.3e}"))
}

/// Checks whether the morphological action `q ↦ ρ_Q q` (eq. 4) descends through `kin`'s
/// forward kinematics (eq. 8) and fits the task action (eqs. 9–10).
pub fn descend(
    symmetry: &str,
    kin: &Kinematics,
    rho_q: &SignedPermutation,
    settings: &DescendSettings,
) -> Result<DescendReport, DescendError> {
    if rho_q.dim() != kin.dof() {
        return Err(DescendError::DimensionMismatch {
            symmetry: symmetry.into(),
            action_dim: rho_q.dim(),
            dof: kin.dof(),
        });
    }
    descend_with(symmetry, kin, |q, out| rho_q.apply(q, out), settings)
}

/// Like [`descend`], refusing with [`DescendError::NotEquivariant`] (or
/// [`DescendError::NonlinearAction`]) where the symmetry does not descend linearly (CLI use).
pub fn require_descent(
    symmetry: &str,
    kin: &Kinematics,
    rho_q: &SignedPermutation,
    settings: &DescendSettings,
) -> Result<DescendReport, DescendError> {
    descend(symmetry, kin, rho_q, settings)?.require()
}

/// Checks eq. 8 for a general action `q ↦ Φ_Q(g, q)` on `Q` (`action(q, out)`, both of
/// length `dim Q`; e.g. a lifted or floating-base action) and fits the task action.
pub fn descend_with<A>(
    symmetry: &str,
    kin: &Kinematics,
    action: A,
    settings: &DescendSettings,
) -> Result<DescendReport, DescendError>
where
    A: Fn(&[f64], &mut [f64]),
{
    let (n, m) = (kin.dof(), kin.task_dim());
    let needed = m + 2;
    if settings.samples < needed {
        return Err(DescendError::TooFewSamples {
            symmetry: symmetry.into(),
            samples: settings.samples,
            task_dim: m,
            needed,
        });
    }
    let big_n = settings.samples;
    let mut rng = SplitMix64::new(settings.seed);
    let mut ws = kin.workspace();
    let SamplePairs {
        qs,
        x,
        y,
        size,
        finite,
    } = sample_pairs(kin, &action, big_n, &mut rng, &mut ws);
    let scale = if size > 0.0 { size } else { 1.0 };
    let (linear, affine, rank) = fit_task_maps(&x, &y, finite);
    let (linear_residual, affine_residual) = (linear.1, affine.1);
    let tol = settings.relative_tolerance * scale;
    let (task_action, max_residual, affine_needed) =
        choose_task_action(linear, affine, tol, settings.permutation_tolerance);
    let (fibre_residual, fibre_pairs) = if n > m && finite {
        fibre_test(kin, &action, &qs, settings, scale, &mut rng, &mut ws)
    } else {
        (None, 0)
    };
    let status = if task_action.is_some() {
        DescendStatus::Equivariant
    } else if fibre_residual.is_some_and(|r| r <= tol) {
        DescendStatus::NonlinearAction
    } else {
        DescendStatus::NotEquivariant
    };
    Ok(DescendReport {
        symmetry: symmetry.into(),
        status,
        task_action,
        max_residual,
        relative_residual: max_residual / scale,
        linear_residual,
        affine_residual,
        affine_needed,
        fibre_residual,
        fibre_pairs,
        workspace_size: size,
        sample_rank: rank,
        samples: big_n,
    })
}

/// Sampled configurations `q_s` with their images `x_s = f(q_s)` and `y_s = f(Φ_Q(g, q_s))`.
struct SamplePairs {
    qs: Vec<Vec<f64>>,
    x: DMatrix<f64>,
    y: DMatrix<f64>,
    /// Largest `|x_s|` (the workspace size).
    size: f64,
    /// Every `y_s` is finite.
    finite: bool,
}

/// Samples `big_n` configurations within the joint limits and maps them and their images through `f`.
fn sample_pairs<A>(
    kin: &Kinematics,
    action: &A,
    big_n: usize,
    rng: &mut SplitMix64,
    ws: &mut KinematicsWorkspace,
) -> SamplePairs
where
    A: Fn(&[f64], &mut [f64]),
{
    let (n, m) = (kin.dof(), kin.task_dim());
    let mut qs: Vec<Vec<f64>> = Vec::with_capacity(big_n);
    let mut x = DMatrix::zeros(big_n, m);
    let mut y = DMatrix::zeros(big_n, m);
    let mut gq = vec![0.0; n];
    let mut size: f64 = 0.0;
    let mut finite = true;
    for s in 0..big_n {
        let mut q = vec![0.0; n];
        sample_within_limits(kin.limits(), rng, &mut q);
        let fx = kin.forward(&q, ws);
        size = size.max(fx.norm());
        x.row_mut(s).copy_from(&fx.transpose());
        action(&q, &mut gq);
        let fy = kin.forward(&gq, ws);
        finite &= fy.iter().all(|v| v.is_finite());
        y.row_mut(s).copy_from(&fy.transpose());
        qs.push(q);
    }
    SamplePairs {
        qs,
        x,
        y,
        size,
        finite,
    }
}

/// The linear and affine least-squares fits of `y` on `x` (none unless `finite`), each
/// with its worst residual (infinite without a fit), and the rank of the samples `x`.
fn fit_task_maps(
    x: &DMatrix<f64>,
    y: &DMatrix<f64>,
    finite: bool,
) -> (Fitted<DMatrix<f64>>, Fitted<AffineFit>, usize) {
    let (linear, affine, rank) = if finite {
        let (l, rank) = fit_linear(x, y);
        (Some(l), fit_affine(x, y), rank)
    } else {
        (None, None, matrix_rank(x))
    };
    let linear_residual = linear
        .as_ref()
        .map_or(f64::INFINITY, |l| residual(x, y, l, None));
    let affine_residual = affine
        .as_ref()
        .map_or(f64::INFINITY, |(l, b)| residual(x, y, l, Some(b)));
    ((linear, linear_residual), (affine, affine_residual), rank)
}

/// An affine fit `x ↦ L x + b`.
type AffineFit = (DMatrix<f64>, DVector<f64>);

/// A fit, if there is one, and its worst residual.
type Fitted<T> = (Option<T>, f64);

/// The task action that fits within `tol` — linear (a signed permutation where one is
/// near), else affine, else none — with its residual and whether the offset was needed.
fn choose_task_action(
    (linear, linear_residual): Fitted<DMatrix<f64>>,
    (affine, affine_residual): Fitted<AffineFit>,
    tol: f64,
    permutation_tolerance: f64,
) -> (Option<DescendedAction>, f64, bool) {
    if linear_residual <= tol {
        let l = linear.expect("finite fit");
        let action = match nearest_signed_permutation(&l, permutation_tolerance) {
            Some(p) => DescendedAction::SignedPermutation(p),
            None => DescendedAction::Linear(l),
        };
        (Some(action), linear_residual, false)
    } else if affine_residual <= tol {
        let (l, b) = affine.expect("finite fit");
        (
            Some(DescendedAction::Affine {
                linear: l,
                offset: b,
            }),
            affine_residual,
            true,
        )
    } else {
        (None, linear_residual.min(affine_residual), false)
    }
}

/// Relative singular-value cutoff of the least-squares fits.
const RANK_EPS: f64 = 1e-10;

fn svd_cutoff(s: &DVector<f64>) -> f64 {
    s.max() * RANK_EPS
}

fn matrix_rank(a: &DMatrix<f64>) -> usize {
    let s = a.singular_values();
    let cut = svd_cutoff(&s);
    s.iter().filter(|&&v| v > cut).count()
}

/// Least-squares `L` with `Y ≈ X Lᵀ` (rows are samples), minimum-norm when rank-deficient.
fn fit_linear(x: &DMatrix<f64>, y: &DMatrix<f64>) -> (DMatrix<f64>, usize) {
    let svd = x.clone().svd(true, true);
    let cut = svd_cutoff(&svd.singular_values);
    let rank = svd.singular_values.iter().filter(|&&v| v > cut).count();
    let lt = svd
        .solve(y, cut)
        .unwrap_or_else(|_| DMatrix::zeros(x.ncols(), y.ncols()));
    (lt.transpose(), rank)
}

/// Least-squares `[L | b]` with `Y ≈ X Lᵀ + 1 bᵀ`.
fn fit_affine(x: &DMatrix<f64>, y: &DMatrix<f64>) -> Option<(DMatrix<f64>, DVector<f64>)> {
    let (rows, m) = (x.nrows(), x.ncols());
    let mut xa = DMatrix::from_element(rows, m + 1, 1.0);
    xa.columns_mut(0, m).copy_from(x);
    let svd = xa.svd(true, true);
    let cut = svd_cutoff(&svd.singular_values);
    let w = svd.solve(y, cut).ok()?;
    let l = w.rows(0, m).transpose();
    let b = w.row(m).transpose();
    Some((l, b))
}

fn residual(x: &DMatrix<f64>, y: &DMatrix<f64>, l: &DMatrix<f64>, b: Option<&DVector<f64>>) -> f64 {
    let mut pred = x * l.transpose();
    if let Some(b) = b {
        for mut row in pred.row_iter_mut() {
            row += b.transpose();
        }
    }
    (y - pred).row_iter().map(|r| r.norm()).fold(0.0, f64::max)
}

/// The signed permutation within `tol` (entry-wise) of `l`, if any.
fn nearest_signed_permutation(l: &DMatrix<f64>, tol: f64) -> Option<SignedPermutation> {
    let n = l.nrows();
    if l.ncols() != n {
        return None;
    }
    let mut perm = Vec::with_capacity(n);
    let mut signs = Vec::with_capacity(n);
    for i in 0..n {
        let row = l.row(i).transpose();
        let j = row.iamax();
        let s = if row[j] < 0.0 { -1.0 } else { 1.0 };
        let close = (0..n).all(|k| {
            let target = if k == j { s } else { 0.0 };
            (row[k] - target).abs() <= tol
        });
        if !close {
            return None;
        }
        perm.push(j);
        signs.push(s);
    }
    SignedPermutation::new(perm, signs).ok()
}

/// Walks fibres `f⁻¹(f(q_s))` of a redundant robot along `ker J` (Newton-corrected) and
/// returns the worst `|f(Φ(q')) − f(Φ(q_s))|` and the number of converged walks.
fn fibre_test<A>(
    kin: &Kinematics,
    action: &A,
    qs: &[Vec<f64>],
    settings: &DescendSettings,
    scale: f64,
    rng: &mut SplitMix64,
    ws: &mut KinematicsWorkspace,
) -> (Option<f64>, usize)
where
    A: Fn(&[f64], &mut [f64]),
{
    const STEPS: usize = 10;
    const NEWTON: usize = 30;
    let n = kin.dof();
    let target_tol = 1e-12 * scale;
    let mut worst: Option<f64> = None;
    let mut pairs = 0;
    let mut gq = vec![0.0; n];
    for q0 in qs.iter().take(settings.fibre_samples) {
        let x0 = kin.forward(q0, ws).clone();
        let d = DVector::from_fn(n, |_, _| rng.range(-1.0, 1.0));
        let mut q = DVector::from_column_slice(q0);
        let mut converged = true;
        for _ in 0..STEPS {
            kin.jacobian(q.as_slice(), ws);
            let Ok(jp) = ws.jac.clone().pseudo_inverse(RANK_EPS) else {
                converged = false;
                break;
            };
            let v = &d - &jp * (&ws.jac * &d);
            let norm = v.norm();
            if norm < 1e-9 {
                converged = false;
                break;
            }
            q += v * (settings.fibre_length / STEPS as f64 / norm);
            converged = false;
            for _ in 0..NEWTON {
                kin.jacobian(q.as_slice(), ws);
                let e = &ws.x - &x0;
                if e.norm() <= target_tol {
                    converged = true;
                    break;
                }
                let Ok(jp) = ws.jac.clone().pseudo_inverse(RANK_EPS) else {
                    break;
                };
                q -= jp * e;
            }
            if !converged {
                break;
            }
        }
        if !converged || !q.iter().all(|v| v.is_finite()) {
            continue;
        }
        action(q0, &mut gq);
        let a = kin.forward(&gq, ws).clone();
        action(q.as_slice(), &mut gq);
        let r = (kin.forward(&gq, ws) - a).norm();
        let r = if r.is_finite() { r } else { f64::INFINITY };
        worst = Some(worst.map_or(r, |w| w.max(r)));
        pairs += 1;
    }
    (worst, pairs)
}

/// SplitMix64 (Steele, Lea & Flood 2014): a small seeded generator for reproducible sampling.
#[derive(Debug, Clone)]
pub(crate) struct SplitMix64(u64);

impl SplitMix64 {
    /// A generator seeded with `seed`.
    pub(crate) fn new(seed: u64) -> Self {
        Self(seed)
    }

    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[lo, hi]`.
    pub(crate) fn range(&mut self, lo: f64, hi: f64) -> f64 {
        let u = (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        lo + (hi - lo) * u
    }
}

/// Fills `out` with a uniform sample inside `limits` (unbounded joints in `[−π, π]`).
pub(crate) fn sample_within_limits(limits: &[JointLimits], rng: &mut SplitMix64, out: &mut [f64]) {
    use std::f64::consts::PI;
    for (o, l) in out.iter_mut().zip(limits) {
        let lo = if l.lower.is_finite() { l.lower } else { -PI };
        let hi = if l.upper.is_finite() { l.upper } else { PI };
        *o = rng.range(lo, hi);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn signed_permutation_is_recognised_only_within_tolerance() {
        let p = SignedPermutation::new(vec![2, 0, 1], vec![1.0, -1.0, 1.0]).unwrap();
        let mut l = p.matrix();
        assert_eq!(nearest_signed_permutation(&l, 1e-6), Some(p));
        l[(0, 1)] = 1e-3;
        assert_eq!(nearest_signed_permutation(&l, 1e-6), None);
    }

    #[test]
    fn fits_recover_linear_and_affine_maps() {
        let mut rng = SplitMix64::new(7);
        let x = DMatrix::from_fn(40, 3, |_, _| rng.range(-1.0, 1.0));
        let l = DMatrix::from_row_slice(3, 3, &[0.0, 1.0, 0.0, 2.0, 0.0, 0.5, 0.0, 0.0, -1.0]);
        let b = DVector::from_column_slice(&[0.1, -0.2, 0.3]);
        let y_lin = &x * l.transpose();
        let (fit, rank) = fit_linear(&x, &y_lin);
        assert_eq!(rank, 3);
        assert!((fit - &l).amax() < 1e-12);
        let mut y_aff = y_lin.clone();
        for mut r in y_aff.row_iter_mut() {
            r += b.transpose();
        }
        let (fit, _) = fit_linear(&x, &y_aff);
        assert!(residual(&x, &y_aff, &fit, None) > 0.05);
        let (la, ba) = fit_affine(&x, &y_aff).unwrap();
        assert!((la - &l).amax() < 1e-12 && (ba - &b).amax() < 1e-12);
    }

    #[test]
    fn sampler_is_seeded_and_inside_limits() {
        let lim = JointLimits {
            lower: -0.5,
            upper: 0.25,
            ..JointLimits::UNBOUNDED
        };
        let (mut a, mut b) = (SplitMix64::new(3), SplitMix64::new(3));
        let (mut qa, mut qb) = ([0.0; 2], [0.0; 2]);
        for _ in 0..100 {
            sample_within_limits(&[lim, JointLimits::UNBOUNDED], &mut a, &mut qa);
            sample_within_limits(&[lim, JointLimits::UNBOUNDED], &mut b, &mut qb);
            assert_eq!(qa, qb);
            assert!(lim.contains(qa[0]) && qa[1].abs() <= std::f64::consts::PI);
        }
    }
}
