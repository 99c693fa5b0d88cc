//! Metric-weighted damped pseudo-inverse of the task Jacobian (paper eq. 13).
//!
//! For a task Jacobian `J ∈ R^{m×n}` (`m < n`, full row rank away from singularities,
//! assumption A3) and a constant Riemannian metric `M ∈ R^{n×n}` (A2, SPD), the
//! horizontal lift of a task velocity `ẋ` is the `M`-minimum-norm joint velocity
//!
//! `q̇_H = J⁺ ẋ`, `J⁺ = M⁻¹Jᵀ (J M⁻¹ Jᵀ + λ² I)⁻¹`   (eq. 13; eq. 17 for vector fields)
//!
//! with damping `λ ≥ 0` (`λ = 0` gives the exact horizontal lift, `λ > 0` the damped
//! least-squares inverse of Wampler 1986 / Nakamura 1986, which trades exactness for
//! bounded output near singularities). The nullspace projector is `N = I − J⁺J`; its
//! range is the vertical space `V_q = ker J` of the submersion (Sec. II-C) when `λ = 0`.
//! Manipulability is `w = √det(J M⁻¹ Jᵀ)` (Yoshikawa 1985 for `M = I`).
//!
//! Setup allocates; [`DampedPinv::factor`] and [`DampedPinv::solve`] reuse a
//! caller-owned [`PinvWorkspace`] and allocate nothing.

use std::ops::Range;

use nalgebra::{DMatrix, DVector};

use super::error::KinematicsError;

/// Constant joint-space metric `M` (SPD), stored as its inverse.
#[derive(Debug, Clone)]
pub struct Metric {
    inv: DMatrix<f64>,
    identity: bool,
}

impl Metric {
    /// The identity metric on `R^n` (the paper's choice, Sec. VI).
    pub fn identity(n: usize) -> Self {
        Self {
            inv: DMatrix::identity(n, n),
            identity: true,
        }
    }

    /// A diagonal metric with positive entries `d` (one per joint).
    pub fn diagonal(d: &[f64]) -> Result<Self, KinematicsError> {
        if let Some(v) = d.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
            return Err(KinematicsError::InvalidSetting {
                field: "kinematics.metric".into(),
                message: format!("diagonal entry {v} is not positive and finite"),
            });
        }
        let identity = d.iter().all(|&v| v == 1.0);
        Ok(Self {
            inv: DMatrix::from_diagonal(&DVector::from_iterator(
                d.len(),
                d.iter().map(|v| 1.0 / v),
            )),
            identity,
        })
    }

    /// A full symmetric positive-definite metric.
    pub fn full(m: DMatrix<f64>) -> Result<Self, KinematicsError> {
        let bad = |message: String| KinematicsError::InvalidSetting {
            field: "kinematics.metric".into(),
            message,
        };
        if !m.is_square() || m.iter().any(|v| !v.is_finite()) {
            return Err(bad("metric must be a finite square matrix".into()));
        }
        if (&m - m.transpose()).amax() > 1e-12 * m.amax().max(1.0) {
            return Err(bad("metric must be symmetric".into()));
        }
        let chol = m
            .clone()
            .cholesky()
            .ok_or_else(|| bad("metric is not positive definite".into()))?;
        Ok(Self {
            inv: chol.inverse(),
            identity: false,
        })
    }

    /// Dimension `n` of the joint space.
    pub fn dim(&self) -> usize {
        self.inv.nrows()
    }

    /// `M⁻¹`.
    pub fn inverse(&self) -> &DMatrix<f64> {
        &self.inv
    }
}

/// Numerical outcome of factoring `J M⁻¹ Jᵀ + λ²I`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PinvStatus {
    /// `J` has full row rank with manipulability above the threshold.
    Regular,
    /// Manipulability below the threshold: near a kinematic singularity (A3 violated).
    /// With `λ > 0` the damped solution is still returned; with `λ = 0` it may be huge.
    NearSingular,
    /// `J M⁻¹ Jᵀ + λ²I` is not positive definite: no solution was formed (output zeroed).
    Singular,
}

/// Result of [`DampedPinv::factor`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PinvReport {
    /// Regular / near-singular / singular.
    pub status: PinvStatus,
    /// `√det(J M⁻¹ Jᵀ)` (units of the task Jacobian to the power m).
    pub manipulability: f64,
}

/// Scratch for the pseudo-inverse of an `m × n` Jacobian.
#[derive(Debug, Clone)]
pub struct PinvWorkspace {
    /// `J M⁻¹` (m × n).
    jm: DMatrix<f64>,
    /// Cholesky factor of `J M⁻¹ Jᵀ + λ²I` (lower triangle, m × m).
    l: DMatrix<f64>,
    /// Cholesky factor of `J M⁻¹ Jᵀ`, for the manipulability.
    l0: DMatrix<f64>,
    y: DVector<f64>,
    ok: bool,
}

/// One diagonal block of a block-diagonal Jacobian (one chain): task rows `rows`, joint
/// columns `cols`; `J` is zero outside its blocks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct JacobianBlock {
    /// Task-space rows of the block.
    pub rows: Range<usize>,
    /// Joint-space columns of the block.
    pub cols: Range<usize>,
}

/// The configured pseudo-inverse: metric, damping and singularity threshold.
///
/// Undamped, `J⁺ = M⁻¹Jᵀ(J M⁻¹ Jᵀ)⁻¹` is a right inverse of `J` (paper eq. 13), and its
/// output is the `M`-minimum-norm solution: it lies in the range of `M⁻¹Jᵀ`.
///
/// ```
/// use crossym_math::kinematics::{DampedPinv, Metric, PinvStatus};
/// use nalgebra::DMatrix;
///
/// // J (2 × 3) and M = diag(1, 2, 4).
/// let j = DMatrix::from_row_slice(2, 3, &[1.0, 0.5, 0.0, 0.0, 1.0, 2.0]);
/// let pinv = DampedPinv::new(Metric::diagonal(&[1.0, 2.0, 4.0])?, 0.0, 1e-9)?;
/// let mut ws = pinv.workspace(2);
/// assert_eq!(pinv.factor(&j, &mut ws).status, PinvStatus::Regular);
/// let xdot = [0.3, -0.7];
/// let mut qdot = [0.0; 3];
/// pinv.solve(&mut ws, &xdot, &mut qdot);
/// // J J⁺ ẋ = ẋ.
/// let back = &j * nalgebra::DVector::from_column_slice(&qdot);
/// assert!((back[0] - 0.3).abs() < 1e-12 && (back[1] + 0.7).abs() < 1e-12);
/// // q̇ = M⁻¹ Jᵀ u for the multiplier u = (J M⁻¹ Jᵀ)⁻¹ ẋ.
/// let u = pinv.multiplier(&ws);
/// let w = [1.0, 0.5, 0.25];
/// for c in 0..3 {
///     let want = w[c] * (j[(0, c)] * u[0] + j[(1, c)] * u[1]);
///     assert!((qdot[c] - want).abs() < 1e-12);
/// }
/// # Ok::<(), crossym_math::kinematics::KinematicsError>(())
/// ```
#[derive(Debug, Clone)]
pub struct DampedPinv {
    metric: Metric,
    damping: f64,
    singular_manipulability: f64,
    /// Block structure of `J` (empty: dense).
    blocks: Vec<JacobianBlock>,
}

impl DampedPinv {
    /// Validates the settings once: `λ ≥ 0` (finite), threshold `≥ 0`.
    pub fn new(
        metric: Metric,
        damping: f64,
        singular_manipulability: f64,
    ) -> Result<Self, KinematicsError> {
        if !(damping.is_finite() && damping >= 0.0) {
            return Err(KinematicsError::InvalidSetting {
                field: "kinematics.damping".into(),
                message: format!("{damping} is not a finite non-negative number"),
            });
        }
        if !(singular_manipulability.is_finite() && singular_manipulability >= 0.0) {
            return Err(KinematicsError::InvalidSetting {
                field: "kinematics.singular_manipulability".into(),
                message: format!("{singular_manipulability} is not a finite non-negative number"),
            });
        }
        Ok(Self {
            metric,
            damping,
            singular_manipulability,
            blocks: Vec::new(),
        })
    }

    /// Declares `J` block diagonal (e.g. one block per chain of a robot whose chains share
    /// no joint): `J M⁻¹ Jᵀ + λ²I` is then block diagonal too, and [`DampedPinv::factor`]
    /// and [`DampedPinv::solve`] work block by block (the manipulability is the product of
    /// the blocks'). The blocks' rows must tile `0..m` and their columns `0..n` in order,
    /// and `M⁻¹` must not couple columns of different blocks.
    pub fn with_blocks(mut self, blocks: Vec<JacobianBlock>) -> Result<Self, KinematicsError> {
        let bad = |message: String| {
            Err(KinematicsError::InvalidSetting {
                field: "kinematics.blocks".into(),
                message,
            })
        };
        let n = self.metric.dim();
        let (mut r, mut c) = (0, 0);
        for b in &blocks {
            if b.rows.start != r || b.cols.start != c || b.rows.is_empty() || b.cols.is_empty() {
                return bad(format!(
                    "blocks {blocks:?} do not tile the rows and columns in order"
                ));
            }
            (r, c) = (b.rows.end, b.cols.end);
        }
        if c != n {
            return bad(format!("blocks cover {c} columns, the metric has {n}"));
        }
        for (i, a) in blocks.iter().enumerate() {
            for b in blocks.iter().skip(i + 1) {
                let coupled = a.cols.clone().any(|p| {
                    b.cols
                        .clone()
                        .any(|q| self.metric.inv[(p, q)] != 0.0 || self.metric.inv[(q, p)] != 0.0)
                });
                if coupled {
                    return bad(format!(
                        "the metric couples columns {:?} and {:?}",
                        a.cols, b.cols
                    ));
                }
            }
        }
        self.blocks = blocks;
        Ok(self)
    }

    /// The diagonal blocks of an `m × n` Jacobian: the declared ones, or one dense block.
    fn blocks_of(&self, m: usize, n: usize) -> impl Iterator<Item = JacobianBlock> + '_ {
        debug_assert!(self.blocks.last().is_none_or(|b| b.rows.end == m));
        let dense = self.blocks.is_empty().then_some(JacobianBlock {
            rows: 0..m,
            cols: 0..n,
        });
        dense.into_iter().chain(self.blocks.iter().cloned())
    }

    /// Damping `λ` of eq. 13.
    pub fn damping(&self) -> f64 {
        self.damping
    }

    /// The joint-space metric.
    pub fn metric(&self) -> &Metric {
        &self.metric
    }

    /// Manipulability below which [`PinvStatus::NearSingular`] is reported.
    pub fn singular_manipulability(&self) -> f64 {
        self.singular_manipulability
    }

    /// Scratch for `m` task rows (allocates; setup only).
    pub fn workspace(&self, m: usize) -> PinvWorkspace {
        let n = self.metric.dim();
        PinvWorkspace {
            jm: DMatrix::zeros(m, n),
            l: DMatrix::zeros(m, m),
            l0: DMatrix::zeros(m, m),
            y: DVector::zeros(m),
            ok: false,
        }
    }

    /// Factors `J M⁻¹ Jᵀ + λ²I` for `j` (m × n) into `ws`. Allocation-free.
    pub fn factor(&self, j: &DMatrix<f64>, ws: &mut PinvWorkspace) -> PinvReport {
        let (m, n) = j.shape();
        debug_assert_eq!(n, self.metric.dim());
        if self.metric.identity {
            ws.jm.copy_from(j);
        } else {
            // J M⁻¹ with explicit loops (gemm may allocate packing buffers).
            for r in 0..m {
                for c in 0..n {
                    let mut acc = 0.0;
                    for k in 0..n {
                        acc += j[(r, k)] * self.metric.inv[(k, c)];
                    }
                    ws.jm[(r, c)] = acc;
                }
            }
        }
        // S0 = (J M⁻¹) Jᵀ, symmetric and block diagonal: fill the lower triangle of each
        // block of l0 and l and factor it. Column-major slices (entry (r, c) at r + c·m):
        // no per-index bounds checks on the matrices.
        let (jm, jv) = (ws.jm.as_slice(), j.as_slice());
        let (l0, l) = (ws.l0.as_mut_slice(), ws.l.as_mut_slice());
        let (mut regular, mut ok, mut product) = (true, true, 1.0);
        for b in self.blocks_of(m, n) {
            for r in b.rows.clone() {
                for c in b.rows.start..=r {
                    let mut acc = 0.0;
                    for k in b.cols.clone() {
                        acc += jm[r + k * m] * jv[c + k * m];
                    }
                    l0[r + c * m] = acc;
                    l[r + c * m] = acc;
                }
                l[r + r * m] += self.damping * self.damping;
            }
            let reg = cholesky_block(l0, m, b.rows.clone());
            regular &= reg;
            if reg {
                product *= b.rows.clone().map(|i| l0[i + i * m]).product::<f64>();
            }
            if self.damping == 0.0 {
                // Undamped: the solve's factor is the one just computed.
                ok &= reg;
                for c in b.rows.clone() {
                    let col = c * m;
                    l[col + c..col + b.rows.end].copy_from_slice(&l0[col + c..col + b.rows.end]);
                }
            } else {
                ok &= cholesky_block(l, m, b.rows.clone());
            }
        }
        ws.ok = ok;
        let manipulability = if regular { product } else { 0.0 };
        let status = if !ws.ok || !manipulability.is_finite() {
            if ws.ok {
                PinvStatus::NearSingular
            } else {
                PinvStatus::Singular
            }
        } else if manipulability < self.singular_manipulability {
            PinvStatus::NearSingular
        } else {
            PinvStatus::Regular
        };
        PinvReport {
            status,
            manipulability,
        }
    }

    /// `out = J⁺ v` for the Jacobian last factored into `ws`. Allocation-free.
    ///
    /// Writes zeros when the factorisation failed ([`PinvStatus::Singular`]).
    pub fn solve(&self, ws: &mut PinvWorkspace, v: &[f64], out: &mut [f64]) {
        let (m, n) = ws.jm.shape();
        debug_assert!(v.len() == m && out.len() == n);
        if !ws.ok {
            out.fill(0.0);
            return;
        }
        // Per block: L Lᵀ y = v (column-major slices, entry (i, k) at i + k·m), then
        // out = M⁻¹ Jᵀ y = (J M⁻¹)ᵀ y on the block's columns.
        let (l, jm, y) = (ws.l.as_slice(), ws.jm.as_slice(), ws.y.as_mut_slice());
        for b in self.blocks_of(m, n) {
            let rows = b.rows.clone();
            for i in rows.clone() {
                let mut s = v[i];
                for k in rows.start..i {
                    s -= l[i + k * m] * y[k];
                }
                y[i] = s / l[i + i * m];
            }
            for i in rows.clone().rev() {
                let mut s = y[i];
                for k in i + 1..rows.end {
                    s -= l[k + i * m] * y[k];
                }
                y[i] = s / l[i + i * m];
            }
            for c in b.cols.clone() {
                let col = &jm[c * m + rows.start..c * m + rows.end];
                out[c] = col.iter().zip(&y[rows.clone()]).map(|(a, b)| a * b).sum();
            }
        }
    }

    /// The multiplier `u = (J M⁻¹ Jᵀ + λ²I)⁻¹ v` of the last [`DampedPinv::solve`]
    /// (so that its output is `M⁻¹ Jᵀ u`).
    pub fn multiplier<'w>(&self, ws: &'w PinvWorkspace) -> &'w [f64] {
        ws.y.as_slice()
    }

    /// `out = M⁻¹ v` (n). Allocation-free.
    pub fn apply_metric_inverse(&self, v: &[f64], out: &mut [f64]) {
        if self.metric.identity {
            out.copy_from_slice(v);
            return;
        }
        for (r, o) in out.iter_mut().enumerate() {
            *o = (0..v.len()).map(|c| self.metric.inv[(r, c)] * v[c]).sum();
        }
    }

    /// The full `J⁺` (n × m) into `out`, column by column. Allocation-free.
    pub fn matrix(&self, ws: &mut PinvWorkspace, out: &mut DMatrix<f64>) {
        let (m, n) = ws.jm.shape();
        debug_assert_eq!(out.shape(), (n, m));
        let mut e = [0.0; 64];
        let mut col = [0.0; 64];
        assert!(
            m <= 64 && n <= 64,
            "pseudo-inverse matrix limited to 64 rows/columns"
        );
        for j in 0..m {
            e[..m].fill(0.0);
            e[j] = 1.0;
            self.solve(ws, &e[..m], &mut col[..n]);
            out.column_mut(j).copy_from_slice(&col[..n]);
        }
    }

    /// Nullspace projector `N = I − J⁺J` (n × n) into `out`, given `j_pinv = J⁺`. Allocation-free.
    pub fn nullspace_projector(j: &DMatrix<f64>, j_pinv: &DMatrix<f64>, out: &mut DMatrix<f64>) {
        // Explicit loops: nalgebra's gemm hands larger products to matrixmultiply, which
        // allocates packing buffers.
        let (m, n) = j.shape();
        for r in 0..n {
            for c in 0..n {
                let mut acc = if r == c { 1.0 } else { 0.0 };
                for k in 0..m {
                    acc -= j_pinv[(r, k)] * j[(k, c)];
                }
                out[(r, c)] = acc;
            }
        }
    }
}

/// In-place Cholesky of the lower triangle of a symmetric matrix; false if not PD.
/// In-place Cholesky of the lower triangle of the diagonal block `rows × rows` of a
/// symmetric `m × m` matrix stored column-major in `a`; false if not PD.
fn cholesky_block(a: &mut [f64], m: usize, rows: Range<usize>) -> bool {
    for j in rows.clone() {
        let mut d = a[j + j * m];
        for k in rows.start..j {
            d -= a[j + k * m] * a[j + k * m];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[j + j * m] = d;
        for i in j + 1..rows.end {
            let mut s = a[i + j * m];
            for k in rows.start..j {
                s -= a[i + k * m] * a[j + k * m];
            }
            a[i + j * m] = s / d;
        }
    }
    true
}

/// Condition number `σ_max/σ_min` of `J` (allocates: for monitoring and reports, not the tick).
pub fn condition_number(j: &DMatrix<f64>) -> f64 {
    let sv = j.clone().singular_values();
    let max = sv.max();
    let min = sv.min();
    if min > 0.0 {
        max / min
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A block-diagonal 5 × 7 Jacobian (blocks 2 × 3 and 3 × 4) with a diagonal metric.
    fn blocked() -> (DMatrix<f64>, Vec<JacobianBlock>, Vec<f64>) {
        let mut j = DMatrix::zeros(5, 7);
        let mut v = 0.3;
        for (rows, cols) in [(0..2, 0..3), (2..5, 3..7)] {
            for r in rows.clone() {
                for c in cols.clone() {
                    v = (v * 7.3 + 0.11) % 2.0 - 1.0;
                    j[(r, c)] = v;
                }
            }
        }
        let blocks = vec![
            JacobianBlock {
                rows: 0..2,
                cols: 0..3,
            },
            JacobianBlock {
                rows: 2..5,
                cols: 3..7,
            },
        ];
        (j, blocks, vec![1.0, 2.0, 0.5, 1.5, 1.0, 3.0, 0.7])
    }

    #[test]
    fn blockwise_pinv_equals_the_dense_one() {
        let (j, blocks, metric) = blocked();
        let xdot = [0.4, -1.2, 0.3, 0.9, -0.5];
        for damping in [0.0, 0.05] {
            let dense = DampedPinv::new(Metric::diagonal(&metric).unwrap(), damping, 0.0).unwrap();
            let blockwise = dense.clone().with_blocks(blocks.clone()).unwrap();
            let (mut wd, mut wb) = (dense.workspace(5), blockwise.workspace(5));
            let (rd, rb) = (dense.factor(&j, &mut wd), blockwise.factor(&j, &mut wb));
            assert_eq!(rd.status, PinvStatus::Regular);
            assert_eq!(rb.status, rd.status);
            assert!((rd.manipulability - rb.manipulability).abs() < 1e-12 * rd.manipulability);
            let (mut od, mut ob) = ([0.0; 7], [0.0; 7]);
            dense.solve(&mut wd, &xdot, &mut od);
            blockwise.solve(&mut wb, &xdot, &mut ob);
            for (a, b) in od.iter().zip(&ob) {
                assert!((a - b).abs() < 1e-12, "{od:?} vs {ob:?}");
            }
            if damping == 0.0 {
                // Exact lift: J J⁺ ẋ = ẋ.
                let back = &j * DVector::from_column_slice(&ob);
                for (a, b) in back.iter().zip(&xdot) {
                    assert!((a - b).abs() < 1e-12);
                }
            }
        }
        // A rank-deficient block makes the whole Jacobian singular.
        let mut js = j.clone();
        for c in 3..7 {
            js[(4, c)] = js[(3, c)];
        }
        let p = DampedPinv::new(Metric::identity(7), 0.0, 0.0)
            .unwrap()
            .with_blocks(blocks)
            .unwrap();
        let mut ws = p.workspace(5);
        assert_eq!(p.factor(&js, &mut ws).status, PinvStatus::Singular);
    }

    #[test]
    fn bad_blocks_are_refused() {
        let (_, blocks, _) = blocked();
        let p = DampedPinv::new(Metric::identity(7), 0.0, 0.0).unwrap();
        let gap = vec![
            blocks[0].clone(),
            JacobianBlock {
                rows: 2..5,
                cols: 4..7,
            },
        ];
        assert!(p.clone().with_blocks(gap).is_err());
        assert!(p.clone().with_blocks(blocks[..1].to_vec()).is_err());
        let mut m = DMatrix::identity(7, 7);
        m[(0, 5)] = 0.1;
        m[(5, 0)] = 0.1;
        let coupled = DampedPinv::new(Metric::full(m).unwrap(), 0.0, 0.0).unwrap();
        assert!(coupled.with_blocks(blocks).is_err());
    }
}
