//! Lie groups acting affinely on task space: SO(2) in any plane, SO(3), uniform
//! scaling S, translations (paper Sec. III-B, Examples 2–4).
//!
//! Each group is given by a basis `ξ_1 … ξ_k` of its Lie algebra, represented on one
//! task block `R^d` (d = 2 or 3) by an affine generator `x ↦ A_k (x − c) + b_k`
//! around a center `c` (the origin by default, as in the paper). On a product task
//! space `X = X_1 × … × X_B` (one block per arm) the same action applies to every block.
//!
//! - infinitesimal generator (eq. 2): `X_ξ(x) = Σ_k ξ_k (A_k (x − c) + b_k)`;
//!   for SO(2) this is `X_Ω(x) = Ω x` of Sec. III-B and Example 2;
//! - action of `g = exp(ξ)`: `Φ(g, x) = c + E (x − c) + e` with `[[E, e], [0, 1]] =
//!   exp([[Σ ξ_k A_k, Σ ξ_k b_k], [0, 0]])` (closed form for each kind below);
//! - differential (Sec. II-B): `dΦ_g|_x v = E v`.
//!
//! Elements are parametrised by exponential coordinates `ξ ∈ R^k`: the angle `θ` for
//! SO(2), the rotation vector for SO(3), `ln λ` for scaling (`λ = e^s`), the offset for
//! translations.

use nalgebra::{DMatrix, DVector, Matrix3, Vector3};
use serde::{Deserialize, Serialize};

use super::field::VectorField;

/// A Lie group acting on task space, seen through its exponential coordinates: what the
/// lift (eqs. 17–18) and the composition checks (eqs. 19–22) need from any continuous
/// task-space symmetry (affine isometries and scalings here, task-induced ones from costs).
pub trait TaskGroupAction: Send + Sync {
    /// Name from configuration.
    fn name(&self) -> &str;
    /// Dimension of the task space acted on.
    fn dim(&self) -> usize;
    /// Dimension of the Lie algebra (exponential coordinates).
    fn algebra_dim(&self) -> usize;
    /// The infinitesimal generator `X_ξ` (eq. 2) as a vector field on task space.
    fn generator_field(&self, xi: &[f64]) -> Box<dyn VectorField + '_>;
    /// `out = Φ(exp(ξ), x)`; `false` where the action cannot be evaluated.
    fn act_on(&self, xi: &[f64], x: &[f64], out: &mut [f64]) -> bool;
    /// `out = dΦ_{exp ξ}|_x v`; `false` where it cannot be evaluated.
    fn differential_on(&self, xi: &[f64], x: &[f64], v: &[f64], out: &mut [f64]) -> bool;
}

impl TaskGroupAction for AffineAction {
    fn name(&self) -> &str {
        &self.name
    }
    fn dim(&self) -> usize {
        AffineAction::dim(self)
    }
    fn algebra_dim(&self) -> usize {
        AffineAction::algebra_dim(self)
    }
    fn generator_field(&self, xi: &[f64]) -> Box<dyn VectorField + '_> {
        Box::new(self.generator(xi))
    }
    fn act_on(&self, xi: &[f64], x: &[f64], out: &mut [f64]) -> bool {
        self.act(xi, x, out);
        true
    }
    fn differential_on(&self, xi: &[f64], _x: &[f64], v: &[f64], out: &mut [f64]) -> bool {
        self.differential(xi, v, out);
        true
    }
}

/// Which Lie group, with its parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum LieGroupSpec {
    /// SO(2): rotations in a plane. On 2-D blocks the plane is the block itself; on 3-D
    /// blocks give the plane's unit normal `axis` (right-hand rule sets the sign of θ).
    So2 {
        /// Rotation axis for 3-D blocks; ignored (must be absent or `[0,0,1]`) for 2-D blocks.
        #[serde(default)]
        axis: Option<[f64; 3]>,
    },
    /// SO(3): all rotations of a 3-D block about the center.
    So3,
    /// S: uniform scaling about the center, element `λ = e^s > 0`.
    Scaling,
    /// Translations along the given directions (block coordinates); all axes when empty.
    Translation {
        /// Directions spanning the translations.
        #[serde(default)]
        directions: Vec<Vec<f64>>,
    },
}

/// An affine Lie group action on `R^{B·d}` acting identically on `B` blocks of size `d`.
#[derive(Debug, Clone)]
pub struct AffineAction {
    /// Name from configuration (e.g. `R`, `S`).
    pub name: String,
    /// The group.
    pub spec: LieGroupSpec,
    /// Block size `d` (2 or 3).
    pub block_dim: usize,
    /// Number of blocks `B`.
    pub blocks: usize,
    /// Center `c` (block coordinates).
    pub center: DVector<f64>,
    /// Linear parts `A_k` (d × d), one per algebra basis element.
    pub linear: Vec<DMatrix<f64>>,
    /// Translation parts `b_k` (d), one per algebra basis element.
    pub offset: Vec<DVector<f64>>,
}

/// Why an affine group action cannot be built ([`AffineAction::new`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum AffineActionError {
    /// Task blocks must be 2-D or 3-D.
    #[error("`{name}`: task blocks must be 2-D or 3-D, got {block_dim}")]
    BlockDim {
        /// Symmetry name.
        name: String,
        /// The block dimension given.
        block_dim: usize,
    },
    /// No task block to act on.
    #[error("`{name}`: no task blocks")]
    NoBlocks {
        /// Symmetry name.
        name: String,
    },
    /// The centre has the wrong length or a non-finite coordinate.
    #[error("`{name}`: center {center:?} must have {block_dim} finite coordinates")]
    Center {
        /// Symmetry name.
        name: String,
        /// The centre given.
        center: Vec<f64>,
        /// The block dimension.
        block_dim: usize,
    },
    /// SO(2) on planar blocks has an axis other than z.
    #[error("`{name}`: SO(2) on planar blocks rotates about z only")]
    PlanarAxis {
        /// Symmetry name.
        name: String,
    },
    /// SO(2) on 3-D blocks without an axis.
    #[error("`{name}`: SO(2) on 3-D blocks needs `axis`")]
    MissingAxis {
        /// Symmetry name.
        name: String,
    },
    /// The SO(2) axis is zero or not finite.
    #[error("`{name}`: SO(2) axis {axis:?} is not a non-zero vector")]
    Axis {
        /// Symmetry name.
        name: String,
        /// The axis given.
        axis: Vector3<f64>,
    },
    /// SO(3) on blocks that are not 3-D.
    #[error("`{name}`: SO(3) needs 3-D task blocks")]
    So3Blocks {
        /// Symmetry name.
        name: String,
    },
    /// A translation direction has the wrong length or a non-finite coordinate.
    #[error("`{name}`: translation direction {direction:?} must have {dim} finite coordinates")]
    Direction {
        /// Symmetry name.
        name: String,
        /// The direction given.
        direction: Vec<f64>,
        /// The block dimension.
        dim: usize,
    },
}

fn skew(u: &Vector3<f64>) -> DMatrix<f64> {
    DMatrix::from_column_slice(
        3,
        3,
        Matrix3::new(0.0, -u.z, u.y, u.z, 0.0, -u.x, -u.y, u.x, 0.0).as_slice(),
    )
}

/// The action's centre: zero when not given, else a finite point of dimension `block_dim`.
fn checked_center(
    name: &str,
    block_dim: usize,
    center: Option<&[f64]>,
) -> Result<DVector<f64>, AffineActionError> {
    match center {
        None => Ok(DVector::zeros(block_dim)),
        Some(c) if c.len() == block_dim && c.iter().all(|v| v.is_finite()) => {
            Ok(DVector::from_column_slice(c))
        }
        Some(c) => Err(AffineActionError::Center {
            name: name.into(),
            center: c.to_vec(),
            block_dim,
        }),
    }
}

/// The Lie algebra's generators `(A_i, b_i)` of `spec` on blocks of dimension `d`.
type Generators = (Vec<DMatrix<f64>>, Vec<DVector<f64>>);

/// The generators of `spec` acting on blocks of dimension `d`, checked.
fn generators(name: &str, spec: &LieGroupSpec, d: usize) -> Result<Generators, AffineActionError> {
    let zero_b = || DVector::zeros(d);
    Ok(match spec {
        LieGroupSpec::So2 { axis } => so2_generator(name, *axis, d)?,
        LieGroupSpec::So3 => {
            if d != 3 {
                return Err(AffineActionError::So3Blocks { name: name.into() });
            }
            (
                vec![
                    skew(&Vector3::x()),
                    skew(&Vector3::y()),
                    skew(&Vector3::z()),
                ],
                vec![zero_b(), zero_b(), zero_b()],
            )
        }
        LieGroupSpec::Scaling => (vec![DMatrix::identity(d, d)], vec![zero_b()]),
        LieGroupSpec::Translation { directions } => translation_generators(name, directions, d)?,
    })
}

/// The rotation generator of SO(2): the plane's, or about `axis` in 3-D blocks.
fn so2_generator(
    name: &str,
    axis: Option<[f64; 3]>,
    d: usize,
) -> Result<Generators, AffineActionError> {
    let zero_b = || DVector::zeros(d);
    if d == 2 {
        if axis.is_some_and(|a| a != [0.0, 0.0, 1.0]) {
            return Err(AffineActionError::PlanarAxis { name: name.into() });
        }
        Ok((
            vec![DMatrix::from_row_slice(2, 2, &[0.0, -1.0, 1.0, 0.0])],
            vec![zero_b()],
        ))
    } else {
        let a = Vector3::from(
            axis.ok_or_else(|| AffineActionError::MissingAxis { name: name.into() })?,
        );
        if a.norm() <= 1e-12 || a.iter().any(|v| !v.is_finite()) {
            return Err(AffineActionError::Axis {
                name: name.into(),
                axis: a,
            });
        }
        Ok((vec![skew(&a.normalize())], vec![zero_b()]))
    }
}

/// The translation generators along `directions` (all axes when empty), each checked.
fn translation_generators(
    name: &str,
    directions: &[Vec<f64>],
    d: usize,
) -> Result<Generators, AffineActionError> {
    let dirs: Vec<Vec<f64>> = if directions.is_empty() {
        (0..d)
            .map(|i| (0..d).map(|j| f64::from(u8::from(i == j))).collect())
            .collect()
    } else {
        directions.to_vec()
    };
    let mut offs = Vec::new();
    for v in dirs {
        if v.len() != d || v.iter().any(|x| !x.is_finite()) {
            return Err(AffineActionError::Direction {
                name: name.into(),
                direction: v,
                dim: d,
            });
        }
        offs.push(DVector::from_vec(v));
    }
    Ok((offs.iter().map(|_| DMatrix::zeros(d, d)).collect(), offs))
}

impl AffineAction {
    /// Builds the action of `spec` on `blocks` blocks of dimension `block_dim` about `center`.
    pub fn new(
        name: &str,
        spec: LieGroupSpec,
        block_dim: usize,
        blocks: usize,
        center: Option<&[f64]>,
    ) -> Result<Self, AffineActionError> {
        if !(block_dim == 2 || block_dim == 3) {
            return Err(AffineActionError::BlockDim {
                name: name.into(),
                block_dim,
            });
        }
        if blocks == 0 {
            return Err(AffineActionError::NoBlocks { name: name.into() });
        }
        let center = checked_center(name, block_dim, center)?;
        let (linear, offset) = generators(name, &spec, block_dim)?;
        Ok(Self {
            name: name.into(),
            spec,
            block_dim,
            blocks,
            center,
            linear,
            offset,
        })
    }

    /// Dimension `k` of the Lie algebra (number of exponential coordinates).
    pub fn algebra_dim(&self) -> usize {
        self.linear.len()
    }

    /// Dimension `B·d` of the space acted on.
    pub fn dim(&self) -> usize {
        self.block_dim * self.blocks
    }

    /// The identity element's exponential coordinates (all zero).
    pub fn identity(&self) -> Vec<f64> {
        vec![0.0; self.algebra_dim()]
    }

    /// `(E, e)` of `exp(ξ)`: the linear part and translation of the block action.
    pub fn block_transform(&self, xi: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
        let d = self.block_dim;
        let mut aug = DMatrix::zeros(d + 1, d + 1);
        for (k, &t) in xi.iter().enumerate() {
            for r in 0..d {
                for c in 0..d {
                    aug[(r, c)] += t * self.linear[k][(r, c)];
                }
                aug[(r, d)] += t * self.offset[k][r];
            }
        }
        let ex = aug.exp();
        (
            ex.view((0, 0), (d, d)).into_owned(),
            ex.view((0, d), (d, 1)).column(0).into_owned(),
        )
    }

    /// `out = Φ(exp(ξ), x)` on every block.
    pub fn act(&self, xi: &[f64], x: &[f64], out: &mut [f64]) {
        let (e, t) = self.block_transform(xi);
        self.apply_transform(&e, &t, x, out);
    }

    /// Applies a precomputed `(E, e)` from [`AffineAction::block_transform`]: `c + E(x − c) + e`.
    pub fn apply_transform(&self, e: &DMatrix<f64>, t: &DVector<f64>, x: &[f64], out: &mut [f64]) {
        let d = self.block_dim;
        for b in 0..self.blocks {
            for r in 0..d {
                let mut s = self.center[r] + t[r];
                for c in 0..d {
                    s += e[(r, c)] * (x[b * d + c] - self.center[c]);
                }
                out[b * d + r] = s;
            }
        }
    }

    /// Differential `out = dΦ_g|_x v = E v` on every block.
    pub fn differential(&self, xi: &[f64], v: &[f64], out: &mut [f64]) {
        let (e, _) = self.block_transform(xi);
        let d = self.block_dim;
        for b in 0..self.blocks {
            for r in 0..d {
                out[b * d + r] = (0..d).map(|c| e[(r, c)] * v[b * d + c]).sum();
            }
        }
    }

    /// The infinitesimal generator `X_ξ` (eq. 2) of the algebra element `ξ` as a vector field.
    pub fn generator(&self, xi: &[f64]) -> Generator<'_> {
        Generator {
            action: self,
            xi: xi.to_vec(),
        }
    }

    /// Generator of the `k`-th basis element.
    pub fn basis_generator(&self, k: usize) -> Generator<'_> {
        let mut xi = vec![0.0; self.algebra_dim()];
        xi[k] = 1.0;
        self.generator(&xi)
    }
}

/// Infinitesimal generator `X_ξ(x) = Σ_k ξ_k (A_k (x − c) + b_k)` of an [`AffineAction`].
#[derive(Debug, Clone)]
pub struct Generator<'a> {
    action: &'a AffineAction,
    /// Algebra coordinates `ξ`.
    pub xi: Vec<f64>,
}

impl Generator<'_> {
    /// `out = Σ_k ξ_k (o_k + L_k (p − c))` per block when `affine`, else `Σ_k ξ_k L_k p`
    /// (the linear part, the field's derivative along `p`).
    fn apply(&self, p: &[f64], affine: bool, out: &mut [f64]) {
        let a = self.action;
        let d = a.block_dim;
        out.fill(0.0);
        for (k, &t) in self.xi.iter().enumerate() {
            if t == 0.0 {
                continue;
            }
            for b in 0..a.blocks {
                for r in 0..d {
                    let mut s = if affine { a.offset[k][r] } else { 0.0 };
                    for c in 0..d {
                        let shift = if affine { a.center[c] } else { 0.0 };
                        s += a.linear[k][(r, c)] * (p[b * d + c] - shift);
                    }
                    out[b * d + r] += t * s;
                }
            }
        }
    }
}

impl VectorField for Generator<'_> {
    fn dim(&self) -> usize {
        self.action.dim()
    }
    fn eval(&self, x: &[f64], out: &mut [f64]) -> bool {
        self.apply(x, true, out);
        true
    }

    /// Affine field: `dX|_x δ = Σ_k ξ_k L_k δ` per block, exactly.
    fn eval_derivative(
        &self,
        x: &[f64],
        delta: &[f64],
        out: &mut [f64],
        out_d: &mut [f64],
    ) -> Option<bool> {
        self.apply(x, true, out);
        self.apply(delta, false, out_d);
        Some(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::symmetry::field::{lie_bracket, DEFAULT_FD_STEP};

    #[test]
    fn so2_rotates_both_blocks_and_differential_matches() {
        let r = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 2, None).unwrap();
        let x = [1.0, 0.0, 0.0, 2.0];
        let mut out = [0.0; 4];
        r.act(&[std::f64::consts::FRAC_PI_2], &x, &mut out);
        let want = [0.0, 1.0, -2.0, 0.0];
        for (o, w) in out.iter().zip(want) {
            assert!((o - w).abs() < 1e-12, "{out:?}");
        }
        // Differential of a linear action equals the action on vectors.
        let mut dv = [0.0; 4];
        r.differential(&[std::f64::consts::FRAC_PI_2], &x, &mut dv);
        assert_eq!(
            dv.map(|v| (v * 1e9).round()),
            out.map(|v| (v * 1e9).round())
        );
    }

    #[test]
    fn scaling_uses_log_coordinates_about_center() {
        let s = AffineAction::new("S", LieGroupSpec::Scaling, 2, 1, Some(&[1.0, 1.0])).unwrap();
        let mut out = [0.0; 2];
        s.act(&[0.5f64.ln()], &[3.0, 1.0], &mut out);
        assert!(
            (out[0] - 2.0).abs() < 1e-12 && (out[1] - 1.0).abs() < 1e-12,
            "{out:?}"
        );
    }

    #[test]
    fn so3_brackets_close_with_structure_constants() {
        let r = AffineAction::new("R3", LieGroupSpec::So3, 3, 1, None).unwrap();
        let (x, y, z) = (
            r.basis_generator(0),
            r.basis_generator(1),
            r.basis_generator(2),
        );
        let p = [0.3, -0.8, 1.1];
        let mut b = [0.0; 3];
        let mut zv = [0.0; 3];
        assert!(lie_bracket(&x, &y, &p, DEFAULT_FD_STEP, &mut b));
        z.eval(&p, &mut zv);
        // With [X, Y] = dX·Y − dY·X and linear fields X_A = A x: [X_A, X_B] = X_[A,B],
        // and [ê_x, ê_y] = ê_z for the skew matrices of so(3).
        for i in 0..3 {
            assert!((b[i] - zv[i]).abs() < 1e-8, "{b:?} vs {zv:?}");
        }
    }

    #[test]
    fn so2_about_an_axis_in_3d() {
        let r = AffineAction::new(
            "R",
            LieGroupSpec::So2 {
                axis: Some([0.0, 0.0, 2.0]),
            },
            3,
            1,
            None,
        )
        .unwrap();
        let mut out = [0.0; 3];
        r.act(&[std::f64::consts::PI], &[1.0, 2.0, 3.0], &mut out);
        assert!(
            (out[0] + 1.0).abs() < 1e-12
                && (out[1] + 2.0).abs() < 1e-12
                && (out[2] - 3.0).abs() < 1e-12
        );
        assert!(AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 3, 1, None).is_err());
    }
}
