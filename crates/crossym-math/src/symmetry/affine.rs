//! One-parameter affine groups on task space in closed form, and stored signed
//! permutations: the serialisable forms of the letter group's factors (paper eqs. 2, 23).
//!
//! A one-parameter group `Φ(t, x) = exp(t H) x` with generator `H x = A x + b` is
//! evaluated from `H`'s minimal polynomial (`H = [[A, b], [0, 0]]`):
//!
//! - rotations, `H³ = −H`: `exp(tH) = I + sin t H + (1 − cos t) H²` (Rodrigues);
//! - scalings, `H² = H`: `exp(tH) = I + (eᵗ − 1) H`;
//! - translations, `H² = 0`: `exp(tH) = I + t H`.
//!
//! The generator itself is a [`VectorField`] with its closed-form derivative `dH|_x δ = A δ`,
//! which the horizontal lift (eq. 17) of [`crate::symmetry::transfer::composed`] flows.

use serde::{Deserialize, Serialize};

use crate::kinematics::Kinematics;
use crate::symmetry::built::BuiltSymmetry;
use crate::symmetry::compose::Condition;
use crate::symmetry::field::VectorField;
use crate::symmetry::finite::{PermutationError, SignedPermutation};
use crate::symmetry::lie::TaskGroupAction;
use crate::symmetry::parts::PartsError;

/// Tolerance on the generator identities (`H³ = −H`, `H² = H`, `H² = 0`) and on affinity.
const GENERATOR_TOL: f64 = 1e-9;

/// Closed form of a one-parameter affine group, from its generator's minimal polynomial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OneParamKind {
    /// `H³ = −H`: rotations, `t` an angle (rad).
    Rotation,
    /// `H² = H`: scalings about a point, `t = ln λ`.
    Scaling,
    /// `H² = 0`: translations, `t` a length (m).
    Translation,
}

/// Why a generator has no closed form here ([`OneParamAction::from_generator`],
/// [`OneParamAction::classify`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeneratorError {
    /// The generator is undefined at a probe point.
    #[error("`{name}`: generator undefined at {point}")]
    Undefined {
        /// Symmetry name.
        name: String,
        /// The point (`0`, `e_j` or the coordinates).
        point: String,
    },
    /// The generator is not affine.
    #[error(
        "`{name}` is not an affine action on X (residual {residual:.1e}): canonical \
         task features need rotations, scalings or translations"
    )]
    NotAffine {
        /// Symmetry name.
        name: String,
        /// Largest deviation from `A x + b` at the probes.
        residual: f64,
    },
    /// The generator is zero.
    #[error("`{name}`: the generator is zero")]
    Zero {
        /// Symmetry name.
        name: String,
    },
    /// `H` satisfies none of the three identities.
    #[error(
        "`{name}`: the generator satisfies none of H³ = −H, H² = H, H² = 0, so its \
         group has no closed form here"
    )]
    NoClosedForm {
        /// Symmetry name.
        name: String,
    },
}

/// `Φ(t, x) = exp(t H) x` with `H x = A x + b` on `X = ℝᵐ`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OneParamAction {
    /// Name of the symmetry (from configuration).
    pub name: String,
    /// Which closed form applies.
    pub kind: OneParamKind,
    /// Linear part `A` of the generator (`m × m`, row-major; 1/unit of `t`).
    pub linear: Vec<f64>,
    /// Offset `b` of the generator (m per unit of `t`).
    pub offset: Vec<f64>,
}

impl OneParamAction {
    /// Reads `A`, `b` off a generator `h(x) = A x + b` on `ℝᵐ` (at `0` and the unit
    /// vectors), checks it is affine at two more points and classifies `H`; says what is
    /// wrong otherwise.
    pub fn from_generator(
        name: &str,
        m: usize,
        h: &dyn Fn(&[f64], &mut [f64]) -> bool,
    ) -> Result<Self, GeneratorError> {
        let undefined = |point: String| GeneratorError::Undefined {
            name: name.into(),
            point,
        };
        let mut offset = vec![0.0; m];
        if !h(&vec![0.0; m], &mut offset) {
            return Err(undefined("0".into()));
        }
        let mut linear = vec![0.0; m * m];
        let mut col = vec![0.0; m];
        for j in 0..m {
            let mut e = vec![0.0; m];
            e[j] = 1.0;
            if !h(&e, &mut col) {
                return Err(undefined(format!("e_{j}")));
            }
            for i in 0..m {
                linear[i * m + j] = col[i] - offset[i];
            }
        }
        let out = Self {
            name: name.into(),
            kind: OneParamKind::Translation,
            linear,
            offset,
        };
        for probe in [0.37, -1.9] {
            let p: Vec<f64> = (0..m).map(|i| probe * (i as f64 + 1.3)).collect();
            let mut want = vec![0.0; m];
            if !h(&p, &mut want) {
                return Err(undefined(format!("{p:?}")));
            }
            let mut got = vec![0.0; m];
            out.generator(&p, &mut got);
            let err = max_diff(&got, &want);
            if err > GENERATOR_TOL * (1.0 + max_abs(&want)) {
                return Err(GeneratorError::NotAffine {
                    name: name.into(),
                    residual: err,
                });
            }
        }
        let kind = out.classify()?;
        Ok(Self { kind, ..out })
    }

    /// Which closed form the generator admits, from the powers of `H = [[A, b], [0, 0]]`
    /// (tolerance 1e-9 relative); an error for a zero generator or none of the three.
    pub fn classify(&self) -> Result<OneParamKind, GeneratorError> {
        let (m, name) = (self.offset.len(), &self.name);
        let k = m + 1;
        let mut hm = vec![0.0; k * k];
        for i in 0..m {
            hm[i * k..i * k + m].copy_from_slice(&self.linear[i * m..(i + 1) * m]);
            hm[i * k + m] = self.offset[i];
        }
        let h2 = matmul(&hm, &hm, k);
        let h3 = matmul(&h2, &hm, k);
        let scale = 1.0 + max_abs(&hm);
        let close = |a: &[f64], b: &[f64]| max_diff(a, b) <= GENERATOR_TOL * scale;
        let neg_h: Vec<f64> = hm.iter().map(|v| -v).collect();
        let zero = vec![0.0; k * k];
        if max_abs(&hm) == 0.0 {
            Err(GeneratorError::Zero { name: name.clone() })
        } else if close(&h2, &zero) {
            Ok(OneParamKind::Translation)
        } else if close(&h2, &hm) {
            Ok(OneParamKind::Scaling)
        } else if close(&h3, &neg_h) {
            Ok(OneParamKind::Rotation)
        } else {
            Err(GeneratorError::NoClosedForm { name: name.clone() })
        }
    }

    /// Task-space dimension `m`.
    pub fn dim(&self) -> usize {
        self.offset.len()
    }

    /// `out = A x + b` (the generator at `x`).
    #[inline]
    fn generator(&self, x: &[f64], out: &mut [f64]) {
        self.linear_part(x, out);
        for (o, b) in out.iter_mut().zip(&self.offset) {
            *o += b;
        }
    }

    /// `out = A u` (the generator's linear part: its differential, on a task velocity).
    #[inline]
    fn linear_part(&self, u: &[f64], out: &mut [f64]) {
        let m = self.offset.len();
        for (i, o) in out.iter_mut().enumerate().take(m) {
            let row = &self.linear[i * m..(i + 1) * m];
            *o = row.iter().zip(u).map(|(a, v)| a * v).sum::<f64>();
        }
    }

    /// `u ← exp(t A) u` in place: the differential of `x ↦ exp(t H) x` (the same for
    /// every `x`, the action being affine) on a task velocity `u`; scratch as [`Self::apply`].
    ///
    /// ```
    /// use crossym_math::symmetry::affine::{OneParamAction, OneParamKind};
    ///
    /// // Rotation about (1, 0): H x = (−(y − 0), x − 1).
    /// let rot = OneParamAction {
    ///     name: "R".into(),
    ///     kind: OneParamKind::Rotation,
    ///     linear: vec![0.0, -1.0, 1.0, 0.0],
    ///     offset: vec![0.0, -1.0],
    /// };
    /// let (mut h, mut h2) = ([0.0; 2], [0.0; 2]);
    /// // exp(tA) u = exp(tH)(x + u) − exp(tH) x.
    /// let (x, u, t) = ([0.3, -0.2], [0.5, 0.25], 0.7);
    /// let mut a = [x[0] + u[0], x[1] + u[1]];
    /// let mut b = x;
    /// rot.apply(t, &mut a, &mut h, &mut h2);
    /// rot.apply(t, &mut b, &mut h, &mut h2);
    /// let mut v = u;
    /// rot.apply_linear(t, &mut v, &mut h, &mut h2);
    /// assert!((v[0] - (a[0] - b[0])).abs() < 1e-15 && (v[1] - (a[1] - b[1])).abs() < 1e-15);
    /// ```
    #[inline]
    pub fn apply_linear(&self, t: f64, u: &mut [f64], h: &mut [f64], h2: &mut [f64]) {
        self.linear_part(u, h);
        match self.kind {
            // A = 0 for a translation: exp(tA) = I.
            OneParamKind::Translation => {}
            OneParamKind::Scaling => {
                let c = t.exp_m1();
                for (ui, hi) in u.iter_mut().zip(h.iter()) {
                    *ui += c * hi;
                }
            }
            OneParamKind::Rotation => {
                self.linear_part(h, h2);
                let (s, c) = t.sin_cos();
                let c1 = 1.0 - c;
                for i in 0..u.len() {
                    u[i] += s * h[i] + c1 * h2[i];
                }
            }
        }
    }

    /// `x ← exp(t H) x` in place, with two scratch vectors of length `m`.
    #[inline]
    pub fn apply(&self, t: f64, x: &mut [f64], h: &mut [f64], h2: &mut [f64]) {
        self.generator(x, h);
        match self.kind {
            OneParamKind::Translation => {
                for (xi, hi) in x.iter_mut().zip(h.iter()) {
                    *xi += t * hi;
                }
            }
            OneParamKind::Scaling => {
                let c = t.exp_m1();
                for (xi, hi) in x.iter_mut().zip(h.iter()) {
                    *xi += c * hi;
                }
            }
            OneParamKind::Rotation => {
                // H² [x; 1] = [A h(x); 0].
                self.linear_part(h, h2);
                let (s, c) = t.sin_cos();
                let c1 = 1.0 - c;
                for i in 0..self.offset.len() {
                    x[i] += s * h[i] + c1 * h2[i];
                }
            }
        }
    }
}

fn matmul(a: &[f64], b: &[f64], k: usize) -> Vec<f64> {
    let mut c = vec![0.0; k * k];
    for i in 0..k {
        for l in 0..k {
            let ail = a[i * k + l];
            for j in 0..k {
                c[i * k + j] += ail * b[l * k + j];
            }
        }
    }
    c
}

fn max_abs(a: &[f64]) -> f64 {
    a.iter().fold(0.0, |m, v| m.max(v.abs()))
}

/// `max_i |a_i − b_i|` over the common length of `a` and `b`.
pub fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

/// A signed permutation of `X` as stored: `(ρ x)_i = signs_i · x_{perm_i}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StoredPermutation {
    /// `perm[i]`: which input coordinate lands in output slot `i`.
    pub perm: Vec<usize>,
    /// `±1` per output slot.
    pub signs: Vec<f64>,
}

impl VectorField for OneParamAction {
    fn dim(&self) -> usize {
        self.offset.len()
    }
    fn eval(&self, x: &[f64], out: &mut [f64]) -> bool {
        self.generator(x, out);
        true
    }
    fn eval_derivative(
        &self,
        x: &[f64],
        delta: &[f64],
        out: &mut [f64],
        out_d: &mut [f64],
    ) -> Option<bool> {
        self.generator(x, out);
        self.linear_part(delta, out_d);
        Some(true)
    }
}

/// Why a [`CanonicalMap`] cannot be built or is inconsistent
/// ([`CanonicalMap::from_symmetries`], [`CanonicalMap::validate`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CanonicalMapError {
    /// The composition order's parts cannot be picked.
    #[error(transparent)]
    Parts {
        /// Why.
        #[from]
        source: PartsError,
    },
    /// `M` does not descend to a signed permutation of `X`.
    #[error(
        "`{name}` does not descend to a signed permutation of X, which canonical \
         task features need"
    )]
    NotDescended {
        /// Name of `M`.
        name: String,
    },
    /// `R` or `S` is not a one-parameter group on `X`.
    #[error("`{name}` must be a one-parameter group on X = R^{m}")]
    NotOneParameter {
        /// Symmetry name.
        name: String,
        /// Task-space dimension.
        m: usize,
    },
    /// A generator has no closed form.
    #[error(transparent)]
    Generator {
        /// Why.
        #[from]
        source: GeneratorError,
    },
    /// The task dimension is 0.
    #[error("task dimension is 0")]
    ZeroDim,
    /// The stored reflection is not a signed permutation.
    #[error("reflection: {source}")]
    Reflection {
        /// Why.
        source: PermutationError,
    },
    /// The stored reflection acts on another space.
    #[error("reflection acts on R^{acts_on}, not R^{m}")]
    ReflectionDim {
        /// Dimension it acts on.
        acts_on: usize,
        /// Task-space dimension.
        m: usize,
    },
    /// A stored generator is not `m × m + m`.
    #[error("`{name}`: generator is not {m}×{m} + {m}")]
    GeneratorShape {
        /// Symmetry name.
        name: String,
        /// Task-space dimension.
        m: usize,
    },
    /// A stored generator has a non-finite entry.
    #[error("`{name}`: generator is not finite")]
    NonFinite {
        /// Symmetry name.
        name: String,
    },
    /// A stored generator is not of its stored kind.
    #[error("`{name}`: stored as {stored:?} but its generator is a {actual:?}")]
    KindMismatch {
        /// Symmetry name.
        name: String,
        /// The kind stored.
        stored: OneParamKind,
        /// The kind of the generator.
        actual: OneParamKind,
    },
}

/// A condition the canonical map cannot undo ([`CanonicalMap::supports`]).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UnsupportedCondition {
    /// `σ = −1` without a reflection.
    #[error("the policy's group has no reflection (σ = −1)")]
    Reflection,
    /// `λ ≠ 1` without a scaling.
    #[error("the policy's group has no scaling (λ = {scale})")]
    Scaling {
        /// The scale asked for.
        scale: f64,
    },
    /// `θ ≠ 0` without a rotation.
    #[error("the policy's group has no rotation (θ = {theta})")]
    Rotation {
        /// The angle asked for (rad).
        theta: f64,
    },
}

/// The inverse action `x ↦ g(s)⁻¹ x` of the letter group `(SO(2) × S) ⋊ C2` (or a
/// sub-group) on `X`, in the composition order `ρ_X(σ) ∘ Φ_R(θ) ∘ Φ_S(ln λ)` (eq. 23).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CanonicalMap {
    /// Task-space dimension `m`.
    pub dim: usize,
    /// `ρ_X(−1)`, the reflection descended to `X` (absent: σ = −1 is not available).
    pub reflection: Option<StoredPermutation>,
    /// `Φ_R`, parameter `θ` (rad).
    pub rotation: Option<OneParamAction>,
    /// `Φ_S`, parameter `ln λ`.
    pub scaling: Option<OneParamAction>,
}

impl CanonicalMap {
    /// The map of the composition `order = [M, R, S]` (or `[M, R]`) of `built`: `M` must
    /// descend to a signed permutation of `X`, `R` and `S` must be affine (closed forms above).
    pub fn from_symmetries(
        kin: &Kinematics,
        built: &[BuiltSymmetry],
        order: &[String],
    ) -> Result<Self, CanonicalMapError> {
        let m = kin.task_dim();
        let super::parts::CompositionParts {
            rotation: rot,
            scaling: sc,
            ..
        } = super::parts::composition_parts(built, order)?;
        let mn = &order[0];
        let reflection = match built.iter().find(|b| b.name() == mn) {
            Some(BuiltSymmetry::Finite {
                rho_x: Some(rho), ..
            }) => StoredPermutation {
                perm: rho.perm.clone(),
                signs: rho.signs.clone(),
            },
            _ => return Err(CanonicalMapError::NotDescended { name: mn.clone() }),
        };
        let one = |a: &dyn TaskGroupAction| -> Result<OneParamAction, CanonicalMapError> {
            if a.dim() != m || a.algebra_dim() != 1 {
                return Err(CanonicalMapError::NotOneParameter {
                    name: a.name().into(),
                    m,
                });
            }
            let field = a.generator_field(&[1.0]);
            Ok(OneParamAction::from_generator(a.name(), m, &|x, out| {
                field.eval(x, out)
            })?)
        };
        Ok(Self {
            dim: m,
            reflection: Some(reflection),
            rotation: Some(one(rot)?),
            scaling: sc.map(one).transpose()?,
        })
    }

    /// Checks dimensions, the permutation, the generators' shapes and that each generator
    /// is of its stored kind; says what is wrong.
    pub fn validate(&self) -> Result<(), CanonicalMapError> {
        let m = self.dim;
        if m == 0 {
            return Err(CanonicalMapError::ZeroDim);
        }
        if let Some(r) = &self.reflection {
            SignedPermutation::new(r.perm.clone(), r.signs.clone())
                .map_err(|source| CanonicalMapError::Reflection { source })?;
            if r.perm.len() != m {
                return Err(CanonicalMapError::ReflectionDim {
                    acts_on: r.perm.len(),
                    m,
                });
            }
        }
        for a in [&self.rotation, &self.scaling].into_iter().flatten() {
            if a.linear.len() != m * m || a.offset.len() != m {
                return Err(CanonicalMapError::GeneratorShape {
                    name: a.name.clone(),
                    m,
                });
            }
            if a.linear.iter().chain(&a.offset).any(|v| !v.is_finite()) {
                return Err(CanonicalMapError::NonFinite {
                    name: a.name.clone(),
                });
            }
            let kind = a.classify()?;
            if kind != a.kind {
                return Err(CanonicalMapError::KindMismatch {
                    name: a.name.clone(),
                    stored: a.kind,
                    actual: kind,
                });
            }
        }
        Ok(())
    }

    /// Checks that the map can undo `s`: a reflection needs `ρ_X`, a scaling other than 1
    /// needs `Φ_S`, a rotation other than 0 needs `Φ_R`.
    pub fn supports(&self, s: &Condition) -> Result<(), UnsupportedCondition> {
        if s.reflection == -1 && self.reflection.is_none() {
            return Err(UnsupportedCondition::Reflection);
        }
        if s.scale != 1.0 && self.scaling.is_none() {
            return Err(UnsupportedCondition::Scaling { scale: s.scale });
        }
        if s.theta != 0.0 && self.rotation.is_none() {
            return Err(UnsupportedCondition::Rotation { theta: s.theta });
        }
        Ok(())
    }

    /// `out = Dg(s) u = ρ_X(σ) exp(θ A_R) exp(ln λ A_S) u`: the differential of `g(s)` (eq. 23's
    /// order; the same at every point, `g` being affine) on a task velocity `u` (m/s);
    /// `h`, `h2` are scratch vectors of length `m`.
    #[inline]
    pub fn apply_linear(
        &self,
        s: &Condition,
        u: &[f64],
        out: &mut [f64],
        h: &mut [f64],
        h2: &mut [f64],
    ) {
        out.copy_from_slice(u);
        if let Some(sc) = &self.scaling {
            sc.apply_linear(s.scale.ln(), out, h, h2);
        }
        if let Some(r) = &self.rotation {
            r.apply_linear(s.theta, out, h, h2);
        }
        if let (Some(r), true) = (&self.reflection, s.reflection == -1) {
            // (ρ y)_i = s_i y_{π(i)}, through `h`.
            h.copy_from_slice(out);
            for i in 0..self.dim {
                out[i] = r.signs[i] * h[r.perm[i]];
            }
        }
    }

    /// `out = g(s)⁻¹ x` (m); `h`, `h2` are scratch vectors of length `m`.
    #[inline]
    pub fn apply_inverse(
        &self,
        s: &Condition,
        x: &[f64],
        out: &mut [f64],
        h: &mut [f64],
        h2: &mut [f64],
    ) {
        match (&self.reflection, s.reflection == -1) {
            // ρ⁻¹: (ρ y)_i = s_i y_{π(i)}  ⇒  (ρ⁻¹ x)_{π(i)} = s_i x_i.
            (Some(r), true) => {
                for i in 0..self.dim {
                    out[r.perm[i]] = r.signs[i] * x[i];
                }
            }
            _ => out.copy_from_slice(x),
        }
        if let Some(r) = &self.rotation {
            r.apply(-s.theta, out, h, h2);
        }
        if let Some(sc) = &self.scaling {
            sc.apply(-s.scale.ln(), out, h, h2);
        }
    }
}

#[cfg(test)]
mod one_param_tests {
    use super::*;

    fn action(h: &dyn Fn(&[f64], &mut [f64]) -> bool) -> Result<OneParamAction, String> {
        OneParamAction::from_generator("g", 2, h).map_err(|e| e.to_string())
    }

    fn apply(a: &OneParamAction, t: f64, x: [f64; 2]) -> [f64; 2] {
        let (mut x, mut h, mut h2) = (x, [0.0; 2], [0.0; 2]);
        a.apply(t, &mut x, &mut h, &mut h2);
        x
    }

    #[test]
    fn closed_forms_match_the_groups() {
        let c = [0.3, -1.2];
        // Rotation about c: h(x) = J (x − c).
        let rot = action(&|x, o| {
            o[0] = -(x[1] - c[1]);
            o[1] = x[0] - c[0];
            true
        })
        .unwrap();
        assert_eq!(rot.kind, OneParamKind::Rotation);
        let (t, p) = (0.7f64, [2.0, 0.5]);
        let (dx, dy) = (p[0] - c[0], p[1] - c[1]);
        let want = [
            c[0] + t.cos() * dx - t.sin() * dy,
            c[1] + t.sin() * dx + t.cos() * dy,
        ];
        let got = apply(&rot, t, p);
        assert!((got[0] - want[0]).abs() < 1e-14 && (got[1] - want[1]).abs() < 1e-14);
        // Scaling about c: h(x) = x − c, so Φ(ln λ, x) = c + λ (x − c).
        let sc = action(&|x, o| {
            o[0] = x[0] - c[0];
            o[1] = x[1] - c[1];
            true
        })
        .unwrap();
        assert_eq!(sc.kind, OneParamKind::Scaling);
        let got = apply(&sc, 0.6f64.ln(), p);
        assert!((got[0] - (c[0] + 0.6 * dx)).abs() < 1e-14);
        assert!((got[1] - (c[1] + 0.6 * dy)).abs() < 1e-14);
        // A translation and a shear (both H² = 0): exp(tH) = I + tH exactly.
        let tr = action(&|_, o| {
            o[0] = 1.0;
            o[1] = -2.0;
            true
        })
        .unwrap();
        assert_eq!(tr.kind, OneParamKind::Translation);
        assert_eq!(apply(&tr, 0.5, p), [2.5, -0.5]);
        let shear = action(&|x, o| {
            o[0] = x[1];
            o[1] = 0.0;
            true
        })
        .unwrap();
        assert_eq!(shear.kind, OneParamKind::Translation);
        assert_eq!(apply(&shear, 2.0, p), [3.0, 0.5]);
    }

    #[test]
    fn generators_without_a_closed_form_are_refused() {
        let e = action(&|x, o| {
            o[0] = x[0] * x[0];
            o[1] = 0.0;
            true
        })
        .unwrap_err();
        assert!(e.contains("not an affine action"), "{e}");
        let e = action(&|x, o| {
            o[0] = x[0];
            o[1] = 2.0 * x[1];
            true
        })
        .unwrap_err();
        assert!(e.contains("none of"), "{e}");
        let e = action(&|_, o| {
            o.fill(0.0);
            true
        })
        .unwrap_err();
        assert!(e.contains("zero"), "{e}");
        let e = action(&|_, _| false).unwrap_err();
        assert!(e.contains("undefined"), "{e}");
    }
}
