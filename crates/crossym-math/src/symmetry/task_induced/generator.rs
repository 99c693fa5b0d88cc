//! Affine generators `X(x) = A x + b` of a task-induced symmetry.

use super::cost::norm;
use super::cost::norm3;

use nalgebra::{DMatrix, DVector};

use crate::symmetry::field::VectorField;

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
