//! Composition of symmetries acting on a common space (paper Sec. V, eqs. 19–23).
//!
//! - **Direct product** `G = G_1 × G_2` when the actions commute (eq. 19):
//!   `Φ_1(g_1, Φ_2(g_2, p)) = Φ_2(g_2, Φ_1(g_1, p))`. For Lie groups this is decided by the
//!   Lie bracket of generators (eq. 20): `[X_ξ, X_ζ] = 0` for all basis pairs; for finite
//!   groups (and mixed pairs) by commutation of the actions on samples. The composed
//!   action is `Φ(g, p) = Φ_1(g_1, Φ_2(g_2, p))` (eq. 21).
//! - **Semi-direct product** `G = G_2 ⋊ G_1` when `G_1` acts on `G_2` by automorphisms
//!   (eq. 22): here `G_1` is finite with a linear action `ρ(g_1)` and `G_2` a Lie group with
//!   generators `X_k`; conjugation pushes generators forward, `(ρ_* X_k)(p) = ρ X_k(ρ⁻¹ p)`,
//!   and lands in `G_2` iff `ρ_* X_k = Σ_l C_lk X_l` for a matrix `C` (the automorphism on
//!   the Lie algebra, `φ(g_1)(exp ξ) = exp(C ξ)`). Example 4: `ρ = diag(1, −1)` on SO(2)
//!   gives `C = −1`, i.e. `R(θ) ↦ R(−θ)`, and `SO(2) ⋊ C2 = O(2)`.
//! - Otherwise the pair is incompatible and the residuals say by how much.
//!
//! Everything here is analysis (setup time) and may allocate.

use nalgebra::{DMatrix, DVector};

use super::field::{lie_bracket, VectorField};
use super::finite::SignedPermutation;

/// A group action by exponential coordinates: `act(ξ, p, out)`, `false` where undefined.
pub type ActionFn<'a> = &'a dyn Fn(&[f64], &[f64], &mut [f64]) -> bool;

/// A one-parameter action: `act(t, p, out)`, `false` where undefined.
pub type OneParamFn<'a> = &'a dyn Fn(f64, &[f64], &mut [f64]) -> bool;

/// How a pair of symmetries composes, with the numerical evidence.
#[derive(Debug, Clone, PartialEq)]
pub enum Composition {
    /// The actions commute: direct product (eqs. 19–21).
    Direct {
        /// Max commutation (or Lie-bracket) residual over samples.
        residual: f64,
    },
    /// The finite factor acts on the Lie factor by the algebra automorphism `C` (eq. 22).
    SemiDirect {
        /// Automorphism matrix `C` on the Lie factor's exponential coordinates.
        automorphism: DMatrix<f64>,
        /// Max relative residual of `ρ_* X_k − Σ_l C_lk X_l` over samples.
        residual: f64,
        /// Commutation residual (non-zero: why a direct product was refused).
        commutation: f64,
    },
    /// Neither: the named residuals are above tolerance.
    Incompatible {
        /// Commutation residual.
        commutation: f64,
        /// Residual of the best automorphism fit (∞ when not applicable).
        automorphism: f64,
    },
}

impl Composition {
    /// Short name for tables: `direct`, `semi-direct`, `incompatible`.
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Direct { .. } => "direct",
            Self::SemiDirect { .. } => "semi-direct",
            Self::Incompatible { .. } => "incompatible",
        }
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|a| a * a).sum::<f64>().sqrt()
}

/// Max over samples and basis pairs of `‖[X_i, Y_j](p)‖ / (‖X_i(p)‖‖Y_j(p)‖ + ε)` (eq. 20),
/// made relative so that it does not depend on units; samples where a field is undefined are skipped.
pub fn bracket_residual(
    xs: &[&dyn VectorField],
    ys: &[&dyn VectorField],
    samples: &[Vec<f64>],
    h: f64,
) -> f64 {
    let mut worst: f64 = 0.0;
    let mut evaluated = 0;
    for p in samples {
        let d = p.len();
        let (mut b, mut xv, mut yv) = (vec![0.0; d], vec![0.0; d], vec![0.0; d]);
        for x in xs {
            for y in ys {
                if !(lie_bracket(*x, *y, p, h, &mut b) && x.eval(p, &mut xv) && y.eval(p, &mut yv))
                {
                    continue;
                }
                // Brackets of fields scale like |X||Y|/|p|: normalise by that.
                let scale = norm(&xv) * norm(&yv) / norm(p).max(1e-12) + 1e-300;
                evaluated += 1;
                worst = worst.max(norm(&b) / scale);
            }
        }
    }
    if evaluated == 0 {
        f64::INFINITY
    } else {
        worst
    }
}

/// Max relative commutation residual `‖Φ_1(Φ_2(p)) − Φ_2(Φ_1(p))‖ / ‖p‖` of two maps over samples (eq. 19).
/// Maps return `false` where undefined; such samples are skipped, and when every sample is
/// skipped the residual is `∞` (nothing was shown to commute).
pub fn commutation_residual(
    a: &dyn Fn(&[f64], &mut [f64]) -> bool,
    b: &dyn Fn(&[f64], &mut [f64]) -> bool,
    samples: &[Vec<f64>],
) -> f64 {
    let mut worst: f64 = 0.0;
    let mut evaluated = 0;
    for p in samples {
        let d = p.len();
        let (mut t, mut ab, mut ba) = (vec![0.0; d], vec![0.0; d], vec![0.0; d]);
        if !(b(p, &mut t) && a(&t, &mut ab) && a(p, &mut t) && b(&t, &mut ba)) {
            continue;
        }
        evaluated += 1;
        let diff: Vec<f64> = ab.iter().zip(&ba).map(|(x, y)| x - y).collect();
        worst = worst.max(norm(&diff) / norm(p).max(1.0));
    }
    if evaluated == 0 {
        f64::INFINITY
    } else {
        worst
    }
}

/// Fits the automorphism `C` with `ρ X_k(ρ⁻¹ p) = Σ_l C_lk X_l(p)` over samples (eq. 22);
/// returns `(C, max relative residual)`. `C` is `k × k`.
pub fn fit_automorphism(
    rho: &SignedPermutation,
    fields: &[&dyn VectorField],
    samples: &[Vec<f64>],
) -> (DMatrix<f64>, f64) {
    let k = fields.len();
    let d = rho.dim();
    let inv = rho.inverse();
    // Stack rows over samples: A (S·d × k) with A[:, l] = X_l(p); B (S·d × k) with B[:, k] = ρ X_k(ρ⁻¹p).
    let mut a_rows: Vec<f64> = Vec::new();
    let mut b_rows: Vec<f64> = Vec::new();
    let mut rows = 0;
    let (mut pinv_p, mut xv, mut rx) = (vec![0.0; d], vec![0.0; d], vec![0.0; d]);
    for p in samples {
        inv.apply(p, &mut pinv_p);
        let mut ok = true;
        let mut block_a = vec![0.0; d * k];
        let mut block_b = vec![0.0; d * k];
        for (l, f) in fields.iter().enumerate() {
            if !f.eval(p, &mut xv) {
                ok = false;
                break;
            }
            for r in 0..d {
                block_a[r * k + l] = xv[r];
            }
            if !f.eval(&pinv_p, &mut rx) {
                ok = false;
                break;
            }
            rho.apply(&rx, &mut xv);
            for r in 0..d {
                block_b[r * k + l] = xv[r];
            }
        }
        if ok {
            a_rows.extend(block_a);
            b_rows.extend(block_b);
            rows += d;
        }
    }
    if rows == 0 {
        return (DMatrix::zeros(k, k), f64::INFINITY);
    }
    let a = DMatrix::from_row_slice(rows, k, &a_rows);
    let b = DMatrix::from_row_slice(rows, k, &b_rows);
    let svd = a.clone().svd(true, true);
    let c = svd
        .solve(&b, 1e-12)
        .unwrap_or_else(|_| DMatrix::zeros(k, k));
    let resid = &a * &c - &b;
    // Relative residual per sample block.
    let mut worst: f64 = 0.0;
    for s in 0..rows / d {
        let r = resid.rows(s * d, d);
        let bb = b.rows(s * d, d);
        worst = worst.max(r.norm() / bb.norm().max(1e-300));
    }
    (c, worst)
}

/// Tolerances for deciding compositions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ComposeTolerance {
    /// Max relative commutation / bracket residual for a direct product.
    pub commute: f64,
    /// Max relative residual of the automorphism fit for a semi-direct product.
    pub automorphism: f64,
}

impl Default for ComposeTolerance {
    fn default() -> Self {
        Self {
            commute: 1e-6,
            automorphism: 1e-6,
        }
    }
}

/// Decides how a finite group generated by `rho` (outer) composes with a Lie group with
/// generators `fields` acting by `act(ξ, p, out)` (inner), on the common space.
pub fn classify_finite_lie(
    rho: &SignedPermutation,
    fields: &[&dyn VectorField],
    act: ActionFn<'_>,
    test_elements: &[Vec<f64>],
    samples: &[Vec<f64>],
    tol: ComposeTolerance,
) -> Composition {
    let mut commutation: f64 = 0.0;
    let apply_rho = |p: &[f64], o: &mut [f64]| {
        rho.apply(p, o);
        true
    };
    for xi in test_elements {
        let g = |p: &[f64], o: &mut [f64]| act(xi, p, o);
        commutation = commutation.max(commutation_residual(&apply_rho, &g, samples));
    }
    if commutation <= tol.commute {
        return Composition::Direct {
            residual: commutation,
        };
    }
    let (c, resid) = fit_automorphism(rho, fields, samples);
    if resid <= tol.automorphism {
        Composition::SemiDirect {
            automorphism: c,
            residual: resid,
            commutation,
        }
    } else {
        Composition::Incompatible {
            commutation,
            automorphism: resid,
        }
    }
}

/// Decides how two Lie groups compose from the brackets of their generators (eq. 20).
pub fn classify_lie_lie(
    xs: &[&dyn VectorField],
    ys: &[&dyn VectorField],
    samples: &[Vec<f64>],
    h: f64,
    tol: ComposeTolerance,
) -> Composition {
    let r = bracket_residual(xs, ys, samples, h);
    if r <= tol.commute {
        return Composition::Direct { residual: r };
    }
    // Semi-direct (eq. 22) between Lie groups: the inner algebra is an ideal, i.e. every
    // bracket [X_i, Y_j] stays in span{Y} (so exp(ad) maps G_Y to itself, e.g.
    // SE(2) = T(2) ⋊ SO(2)). The automorphism's generator is ad restricted to g_Y.
    let (c, resid) = fit_ideal(xs, ys, samples, h);
    if resid <= tol.automorphism {
        Composition::SemiDirect {
            automorphism: c,
            residual: resid,
            commutation: r,
        }
    } else {
        Composition::Incompatible {
            commutation: r,
            automorphism: resid,
        }
    }
}

/// Fits `[X_i, Y_j] = Σ_l C^{(i)}_{lj} Y_l` over samples; returns the stacked `C^{(i)}`
/// (`k_x·k_y × k_y`, block `i` is `ad_{X_i}` on `span{Y}`) and the worst relative residual.
fn fit_ideal(
    xs: &[&dyn VectorField],
    ys: &[&dyn VectorField],
    samples: &[Vec<f64>],
    h: f64,
) -> (DMatrix<f64>, f64) {
    let ky = ys.len();
    let mut blocks = DMatrix::zeros(xs.len() * ky, ky);
    let mut worst: f64 = 0.0;
    for (i, x) in xs.iter().enumerate() {
        let mut a_rows: Vec<f64> = Vec::new();
        let mut b_rows: Vec<f64> = Vec::new();
        let mut rows = 0;
        for p in samples {
            let d = p.len();
            let mut yv = vec![vec![0.0; d]; ky];
            let mut br = vec![vec![0.0; d]; ky];
            let ok = ys
                .iter()
                .enumerate()
                .all(|(l, y)| y.eval(p, &mut yv[l]) && lie_bracket(*x, *y, p, h, &mut br[l]));
            if !ok {
                continue;
            }
            for r in 0..d {
                a_rows.extend((0..ky).map(|l| yv[l][r]));
                b_rows.extend((0..ky).map(|l| br[l][r]));
            }
            rows += d;
        }
        if rows == 0 {
            return (blocks, f64::INFINITY);
        }
        let a = DMatrix::from_row_slice(rows, ky, &a_rows);
        let b = DMatrix::from_row_slice(rows, ky, &b_rows);
        let c = a
            .clone()
            .svd(true, true)
            .solve(&b, 1e-12)
            .unwrap_or_else(|_| DMatrix::zeros(ky, ky));
        let resid = &a * &c - &b;
        let scale = b.norm().max(a.norm() * 1e-300).max(1e-300);
        worst = worst.max(resid.norm() / scale);
        blocks.view_mut((i * ky, 0), (ky, ky)).copy_from(&c);
    }
    (blocks, worst)
}

/// Decides how two finite groups compose: direct iff their generators commute.
pub fn classify_finite_finite(a: &SignedPermutation, b: &SignedPermutation) -> Composition {
    let r = (a.compose(b).matrix() - b.compose(a).matrix()).amax();
    if r == 0.0 {
        Composition::Direct { residual: 0.0 }
    } else {
        // Semi-direct between finite groups: b's conjugates by a stay in ⟨b⟩.
        let conj = a.compose(b).compose(&a.inverse());
        if conj == *b || conj == b.inverse() {
            let s = if conj == *b { 1.0 } else { -1.0 };
            Composition::SemiDirect {
                automorphism: DMatrix::from_element(1, 1, s),
                residual: 0.0,
                commutation: r,
            }
        } else {
            Composition::Incompatible {
                commutation: r,
                automorphism: f64::INFINITY,
            }
        }
    }
}

/// Element `s = (θ, λ, σ)` of the letter-task group `(SO(2) × S) ⋊ C2` (Sec. VI-A):
/// rotation angle (rad), scaling factor (> 0), reflection index (±1).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Condition {
    /// Rotation angle `θ ∈ [−π, π]` (rad).
    pub theta: f64,
    /// Scaling factor `λ > 0`.
    pub scale: f64,
    /// Reflection index `σ ∈ {1, −1}`.
    pub reflection: i8,
}

impl Condition {
    /// The identity element `(0, 1, 1)`.
    pub const IDENTITY: Self = Self {
        theta: 0.0,
        scale: 1.0,
        reflection: 1,
    };

    /// Checks `θ` finite, `λ > 0` finite, `σ = ±1`; says what is wrong otherwise.
    pub fn validate(&self) -> Result<(), InvalidCondition> {
        if !self.theta.is_finite() {
            return Err(InvalidCondition::Theta { theta: self.theta });
        }
        if !(self.scale.is_finite() && self.scale > 0.0) {
            return Err(InvalidCondition::Scale { scale: self.scale });
        }
        if !(self.reflection == 1 || self.reflection == -1) {
            return Err(InvalidCondition::Reflection {
                reflection: self.reflection,
            });
        }
        Ok(())
    }
}

/// What is wrong with a [`Condition`] ([`Condition::validate`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum InvalidCondition {
    /// `θ` is not finite.
    #[error("theta {theta} is not finite")]
    Theta {
        /// The angle given (rad).
        theta: f64,
    },
    /// `λ` is not positive and finite.
    #[error("scale {scale} must be positive and finite")]
    Scale {
        /// The scale given.
        scale: f64,
    },
    /// `σ ∉ {1, −1}`.
    #[error("reflection {reflection} must be 1 or -1")]
    Reflection {
        /// The reflection index given.
        reflection: i8,
    },
}

/// Composed action of eq. 23 for `s = (θ, λ, σ)`: `p ↦ ρ(σ) · Φ_R(θ, Φ_S(ln λ, p))`,
/// with rotation and scaling given as maps on the common space.
pub fn apply_condition(
    s: &Condition,
    rho: &SignedPermutation,
    rotate: OneParamFn<'_>,
    scale: OneParamFn<'_>,
    p: &[f64],
    out: &mut [f64],
) -> bool {
    let d = p.len();
    let mut a = vec![0.0; d];
    let mut b = vec![0.0; d];
    if !(scale(s.scale.ln(), p, &mut a) && rotate(s.theta, &a, &mut b)) {
        return false;
    }
    if s.reflection == -1 {
        rho.apply(&b, out);
    } else {
        out.copy_from_slice(&b);
    }
    true
}

/// Least-squares coordinates of `v` in the span of `basis` (columns), and the residual norm.
pub fn span_coordinates(basis: &DMatrix<f64>, v: &DVector<f64>) -> (DVector<f64>, f64) {
    let svd = basis.clone().svd(true, true);
    let c = svd
        .solve(v, 1e-12)
        .unwrap_or_else(|_| DVector::zeros(basis.ncols()));
    let r = (basis * &c - v).norm();
    (c, r)
}
