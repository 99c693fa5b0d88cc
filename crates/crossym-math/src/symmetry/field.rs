//! Vector fields on coordinate spaces `R^d` and their Lie bracket (paper Sec. II-B).
//!
//! A vector field `X: M → TM` is evaluated in coordinates as `X(p) ∈ R^d`. The Lie
//! bracket in local coordinates is
//!
//! `[X, Y](p) = dX|_p Y(p) − dY|_p X(p)`   (paper, Sec. II-B, "Lie bracket")
//!
//! and measures the non-commutativity of the flows of `X` and `Y`. Here the
//! differentials are directional central differences
//! `dX|_p v ≈ (X(p + h v) − X(p − h v)) / 2h`, exact for affine fields up to rounding.
//! Infinitesimal generators (eq. 2) of the actions in [`crate::symmetry::lie`] are
//! vector fields, and so are horizontally lifted generators (eq. 17).

/// A smooth vector field on `R^d`, evaluated into a caller buffer.
pub trait VectorField {
    /// Dimension `d` of the space the field lives on.
    fn dim(&self) -> usize;
    /// Writes `X(p)` into `out` (`p.len() == out.len() == dim`).
    ///
    /// Returns `false` when the field is undefined at `p` (e.g. a lifted field at a
    /// kinematic singularity); `out` is then unspecified.
    fn eval(&self, p: &[f64], out: &mut [f64]) -> bool;
    /// `X(p)` into `out` and its directional derivative `dX|_p δ` into `out_d`, when the
    /// field knows it in closed form (`None`: it does not; callers difference [`eval`]).
    /// `Some(false)` where the field is undefined.
    ///
    /// [`eval`]: VectorField::eval
    fn eval_derivative(
        &self,
        _p: &[f64],
        _delta: &[f64],
        _out: &mut [f64],
        _out_d: &mut [f64],
    ) -> Option<bool> {
        None
    }
}

/// Forwards [`VectorField`] through a pointer type.
macro_rules! forward_vector_field {
    ($($ptr:ty),*) => {$(
        impl<F: VectorField + ?Sized> VectorField for $ptr {
            fn dim(&self) -> usize {
                (**self).dim()
            }
            fn eval(&self, p: &[f64], out: &mut [f64]) -> bool {
                (**self).eval(p, out)
            }
            fn eval_derivative(
                &self,
                p: &[f64],
                delta: &[f64],
                out: &mut [f64],
                out_d: &mut [f64],
            ) -> Option<bool> {
                (**self).eval_derivative(p, delta, out, out_d)
            }
        }
    )*};
}
forward_vector_field!(&F, Box<F>);

/// A vector field given by a closure (setup, tests, examples).
pub struct FnField<F> {
    dim: usize,
    f: F,
}

impl<F: Fn(&[f64], &mut [f64])> FnField<F> {
    /// Wraps `f(p, out)` as a field on `R^dim`.
    pub fn new(dim: usize, f: F) -> Self {
        Self { dim, f }
    }
}

impl<F: Fn(&[f64], &mut [f64])> VectorField for FnField<F> {
    fn dim(&self) -> usize {
        self.dim
    }
    fn eval(&self, p: &[f64], out: &mut [f64]) -> bool {
        (self.f)(p, out);
        true
    }
}

/// Directional derivative `dX|_p v` by central differences with relative step `h`.
///
/// Returns `false` when the field is undefined at one of the probe points.
pub fn directional_derivative(
    x: &dyn VectorField,
    p: &[f64],
    v: &[f64],
    h: f64,
    out: &mut [f64],
) -> bool {
    let d = x.dim();
    let vn = v.iter().map(|a| a * a).sum::<f64>().sqrt();
    if vn == 0.0 {
        out.fill(0.0);
        return true;
    }
    let pn = p.iter().map(|a| a * a).sum::<f64>().sqrt();
    let step = h * pn.max(1.0) / vn;
    let mut pp = vec![0.0; d];
    let mut pm = vec![0.0; d];
    let mut fp = vec![0.0; d];
    let mut fm = vec![0.0; d];
    for i in 0..d {
        pp[i] = p[i] + step * v[i];
        pm[i] = p[i] - step * v[i];
    }
    if !(x.eval(&pp, &mut fp) && x.eval(&pm, &mut fm)) {
        return false;
    }
    for i in 0..d {
        out[i] = (fp[i] - fm[i]) / (2.0 * step);
    }
    true
}

/// Lie bracket `[X, Y](p) = dX|_p Y(p) − dY|_p X(p)` by central differences (step `h`).
///
/// Allocates small scratch vectors: this is an analysis tool, not a control-tick function.
/// Returns `false` when either field is undefined near `p`.
pub fn lie_bracket(
    x: &dyn VectorField,
    y: &dyn VectorField,
    p: &[f64],
    h: f64,
    out: &mut [f64],
) -> bool {
    let d = x.dim();
    assert_eq!(d, y.dim(), "Lie bracket of fields on different spaces");
    let mut xv = vec![0.0; d];
    let mut yv = vec![0.0; d];
    let mut a = vec![0.0; d];
    let mut b = vec![0.0; d];
    if !(x.eval(p, &mut xv) && y.eval(p, &mut yv)) {
        return false;
    }
    if !(directional_derivative(x, p, &yv, h, &mut a)
        && directional_derivative(y, p, &xv, h, &mut b))
    {
        return false;
    }
    for i in 0..d {
        out[i] = a[i] - b[i];
    }
    true
}

/// Default finite-difference step for brackets of fields with unit-scale coordinates.
pub const DEFAULT_FD_STEP: f64 = 1e-5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bracket_of_rotation_and_scaling_vanishes_example3() {
        // Paper Example 3: X1 = (-x2, x1), X2 = (x1, x2), [X1, X2] = 0.
        let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
            o[0] = -p[1];
            o[1] = p[0];
        });
        let sc = FnField::new(2, |p: &[f64], o: &mut [f64]| o.copy_from_slice(p));
        let mut out = [0.0; 2];
        assert!(lie_bracket(
            &rot,
            &sc,
            &[0.3, -1.7],
            DEFAULT_FD_STEP,
            &mut out
        ));
        assert!(out.iter().all(|v| v.abs() < 1e-9), "{out:?}");
    }

    #[test]
    fn bracket_of_translations_and_rotation_is_translation() {
        // [∂x, Ω·] with Ω = rotation about z: d(Ωp)·e_x − 0 = Ω e_x = e_y.
        let tx = FnField::new(2, |_: &[f64], o: &mut [f64]| {
            o[0] = 1.0;
            o[1] = 0.0;
        });
        let rot = FnField::new(2, |p: &[f64], o: &mut [f64]| {
            o[0] = -p[1];
            o[1] = p[0];
        });
        let mut out = [0.0; 2];
        assert!(lie_bracket(
            &rot,
            &tx,
            &[2.0, 5.0],
            DEFAULT_FD_STEP,
            &mut out
        ));
        assert!(
            (out[0] - 0.0).abs() < 1e-8 && (out[1] - 1.0).abs() < 1e-8,
            "{out:?}"
        );
    }
}
