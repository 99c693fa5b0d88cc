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

/// The configured pseudo-inverse: metric, damping and singularity threshold.
#[derive(Debug, Clone)]
pub struct DampedPinv {
    metric: Metric,
    damping: f64,
    singular_manipulability: f64,
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
        })
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
        // S0 = (J M⁻¹) Jᵀ, symmetric: fill the lower triangle of l0 and l.
        for r in 0..m {
            for c in 0..=r {
                let mut s = 0.0;
                for k in 0..n {
                    s += ws.jm[(r, k)] * j[(c, k)];
                }
                ws.l0[(r, c)] = s;
                ws.l[(r, c)] = s;
            }
            ws.l[(r, r)] += self.damping * self.damping;
        }
        let manipulability = if cholesky_in_place(&mut ws.l0) {
            (0..m).map(|i| ws.l0[(i, i)]).product::<f64>()
        } else {
            0.0
        };
        ws.ok = cholesky_in_place(&mut ws.l);
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
        // L Lᵀ y = v.
        for i in 0..m {
            let mut s = v[i];
            for k in 0..i {
                s -= ws.l[(i, k)] * ws.y[k];
            }
            ws.y[i] = s / ws.l[(i, i)];
        }
        for i in (0..m).rev() {
            let mut s = ws.y[i];
            for k in i + 1..m {
                s -= ws.l[(k, i)] * ws.y[k];
            }
            ws.y[i] = s / ws.l[(i, i)];
        }
        // out = M⁻¹ Jᵀ y = (J M⁻¹)ᵀ y.
        for (c, o) in out.iter_mut().enumerate() {
            let mut s = 0.0;
            for r in 0..m {
                s += ws.jm[(r, c)] * ws.y[r];
            }
            *o = s;
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
fn cholesky_in_place(a: &mut DMatrix<f64>) -> bool {
    let m = a.nrows();
    for j in 0..m {
        let mut d = a[(j, j)];
        for k in 0..j {
            d -= a[(j, k)] * a[(j, k)];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        a[(j, j)] = d;
        for i in j + 1..m {
            let mut s = a[(i, j)];
            for k in 0..j {
                s -= a[(i, k)] * a[(j, k)];
            }
            a[(i, j)] = s / d;
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
