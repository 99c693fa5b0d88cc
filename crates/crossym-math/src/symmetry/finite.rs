//! Finite groups represented by signed permutations (paper eqs. 4–5, Example 1).
//!
//! A morphological symmetry of a robot with interchangeable chains of 1-DoF joints
//! acts on `Q` linearly, `Φ_M(g, q) = ρ_Q(g) q` (eq. 4), with `ρ_Q(g)` a signed
//! permutation matrix: it exchanges each joint with its counterpart and flips the
//! sign where the two joints have opposite conventions. For RB-Y1 (Example 1)
//! `ρ_Q(g_s) = [[0, P], [P, 0]]`, `P = diag(1, −1, −1, 1, −1, 1, −1)`.
//! Because `ρ` is linear, the differential is `ρ` itself: `q̇ ↦ ρ_Q(g) q̇`.
//!
//! [`FiniteGroup`] closes a set of generators under composition.

use nalgebra::{DMatrix, Isometry3};

/// Why a `(perm, signs)` pair is not a signed permutation ([`SignedPermutation::new`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum PermutationError {
    /// As many signs as coordinates are needed.
    #[error("{signs} signs for {coordinates} coordinates")]
    SignCount {
        /// Number of signs given.
        signs: usize,
        /// Number of coordinates (`perm.len()`).
        coordinates: usize,
    },
    /// `perm` is not a bijection of `0..n`.
    #[error("{perm:?} is not a permutation of 0..{n}")]
    NotAPermutation {
        /// The indices given.
        perm: Vec<usize>,
        /// Dimension.
        n: usize,
    },
    /// A sign is neither `+1` nor `−1`.
    #[error("sign {sign} is not ±1")]
    Sign {
        /// The offending sign.
        sign: f64,
    },
}

/// Why generators do not give a finite group ([`FiniteGroup::generate`], [`FiniteGroup::c2`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FiniteGroupError {
    /// The generator list is empty.
    #[error("no generators")]
    NoGenerators,
    /// The generators act on spaces of different dimensions.
    #[error("generators act on spaces of different dimension")]
    MixedDimensions,
    /// Closing the generators exceeds the order limit.
    #[error("group `{name}` has more than {max_order} elements")]
    TooLarge {
        /// Group name.
        name: String,
        /// The limit.
        max_order: usize,
    },
    /// The C2 generator is the identity or does not square to it.
    #[error("`{name}`: generator is not an involution")]
    NotAnInvolution {
        /// Group name.
        name: String,
    },
}

/// A signed permutation `ρ` of `R^n`: `(ρ p)_i = s_i · p_{π(i)}`.
#[derive(Debug, Clone, PartialEq)]
pub struct SignedPermutation {
    /// `π(i)`: which input coordinate lands in output slot `i`.
    pub perm: Vec<usize>,
    /// `s_i ∈ {+1, −1}`.
    pub signs: Vec<f64>,
}

impl SignedPermutation {
    /// The identity on `R^n`.
    pub fn identity(n: usize) -> Self {
        Self {
            perm: (0..n).collect(),
            signs: vec![1.0; n],
        }
    }

    /// Builds and validates a signed permutation (`perm` a bijection, signs ±1).
    pub fn new(perm: Vec<usize>, signs: Vec<f64>) -> Result<Self, PermutationError> {
        let n = perm.len();
        if signs.len() != n {
            return Err(PermutationError::SignCount {
                signs: signs.len(),
                coordinates: n,
            });
        }
        let mut seen = vec![false; n];
        for &p in &perm {
            if p >= n || seen[p] {
                return Err(PermutationError::NotAPermutation { perm, n });
            }
            seen[p] = true;
        }
        if let Some(&sign) = signs.iter().find(|s| **s != 1.0 && **s != -1.0) {
            return Err(PermutationError::Sign { sign });
        }
        Ok(Self { perm, signs })
    }

    /// The bilateral swap `[[0, P], [P, 0]]` of two blocks of size `k = p.len()`
    /// (Example 1): output block 0 is `P` times input block 1 and vice versa.
    pub fn block_swap(p: &[f64]) -> Self {
        let k = p.len();
        let perm = (0..2 * k)
            .map(|i| if i < k { i + k } else { i - k })
            .collect();
        let signs = p.iter().chain(p).copied().collect();
        Self { perm, signs }
    }

    /// Dimension `n`.
    pub fn dim(&self) -> usize {
        self.perm.len()
    }

    /// `out = ρ p`. Allocation-free.
    #[inline]
    pub fn apply(&self, p: &[f64], out: &mut [f64]) {
        for (i, (&j, &s)) in self.perm.iter().zip(&self.signs).enumerate() {
            out[i] = s * p[j];
        }
    }

    /// `self ∘ other` (apply `other` first).
    pub fn compose(&self, other: &Self) -> Self {
        let perm = self.perm.iter().map(|&j| other.perm[j]).collect();
        let signs = self
            .perm
            .iter()
            .zip(&self.signs)
            .map(|(&j, &s)| s * other.signs[j])
            .collect();
        Self { perm, signs }
    }

    /// `ρ⁻¹ = ρᵀ`.
    pub fn inverse(&self) -> Self {
        let n = self.dim();
        let mut perm = vec![0; n];
        let mut signs = vec![1.0; n];
        for (i, (&j, &s)) in self.perm.iter().zip(&self.signs).enumerate() {
            perm[j] = i;
            signs[j] = s;
        }
        Self { perm, signs }
    }

    /// True for the identity.
    pub fn is_identity(&self) -> bool {
        self.perm.iter().enumerate().all(|(i, &j)| i == j) && self.signs.iter().all(|&s| s == 1.0)
    }

    /// The `n × n` matrix of `ρ`.
    pub fn matrix(&self) -> DMatrix<f64> {
        let n = self.dim();
        let mut m = DMatrix::zeros(n, n);
        for (i, (&j, &s)) in self.perm.iter().zip(&self.signs).enumerate() {
            m[(i, j)] = s;
        }
        m
    }
}

/// A finite group given by signed-permutation generators, closed under composition.
#[derive(Debug, Clone)]
pub struct FiniteGroup {
    /// Name from configuration (e.g. `C2`).
    pub name: String,
    /// All elements; `elements[0]` is the identity.
    pub elements: Vec<SignedPermutation>,
}

impl FiniteGroup {
    /// Closes `generators` under composition; fails beyond `max_order` elements.
    pub fn generate(
        name: &str,
        generators: &[SignedPermutation],
        max_order: usize,
    ) -> Result<Self, FiniteGroupError> {
        let n = generators
            .first()
            .map(SignedPermutation::dim)
            .ok_or(FiniteGroupError::NoGenerators)?;
        if generators.iter().any(|g| g.dim() != n) {
            return Err(FiniteGroupError::MixedDimensions);
        }
        let mut elements = vec![SignedPermutation::identity(n)];
        let mut frontier = 0;
        while frontier < elements.len() {
            let e = elements[frontier].clone();
            for g in generators {
                let c = g.compose(&e);
                if !elements.contains(&c) {
                    if elements.len() >= max_order {
                        return Err(FiniteGroupError::TooLarge {
                            name: name.into(),
                            max_order,
                        });
                    }
                    elements.push(c);
                }
            }
            frontier += 1;
        }
        Ok(Self {
            name: name.into(),
            elements,
        })
    }

    /// The cyclic group of order 2 generated by `g` (the reflection of Example 1).
    pub fn c2(name: &str, g: SignedPermutation) -> Result<Self, FiniteGroupError> {
        let g2 = g.compose(&g);
        if !g2.is_identity() || g.is_identity() {
            return Err(FiniteGroupError::NotAnInvolution { name: name.into() });
        }
        Ok(Self {
            name: name.into(),
            elements: vec![SignedPermutation::identity(g.dim()), g],
        })
    }

    /// Group order `|G|`.
    pub fn order(&self) -> usize {
        self.elements.len()
    }
}

/// Floating-base symmetry composed with a joint permutation (eq. 5):
/// `(X, q) ↦ (X_g X X_g⁻¹, ρ_Q(g) q)` for a base pose `X ∈ SE(3)`.
#[derive(Debug, Clone)]
pub struct FloatingBaseAction {
    /// Rigid transform `X_g` of the floating-base symmetry.
    pub base: Isometry3<f64>,
    /// Joint permutation `ρ_Q(g)`.
    pub joints: SignedPermutation,
}

impl FloatingBaseAction {
    /// Applies eq. 5 to a base pose and joint vector; `q_out` receives `ρ_Q(g) q`.
    pub fn apply(
        &self,
        base_pose: &Isometry3<f64>,
        q: &[f64],
        q_out: &mut [f64],
    ) -> Isometry3<f64> {
        self.joints.apply(q, q_out);
        self.base * base_pose * self.base.inverse()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_swap_is_an_involution_and_c2() {
        let p = [1.0, -1.0, -1.0, 1.0, -1.0, 1.0, -1.0];
        let g = SignedPermutation::block_swap(&p);
        assert!(g.compose(&g).is_identity());
        let grp = FiniteGroup::generate("C2", std::slice::from_ref(&g), 8).unwrap();
        assert_eq!(grp.order(), 2);
        let q: Vec<f64> = (0..14).map(|i| i as f64 + 1.0).collect();
        let mut out = vec![0.0; 14];
        g.apply(&q, &mut out);
        assert_eq!(out[0], q[7]);
        assert_eq!(out[1], -q[8]);
        assert_eq!(out[7], q[0]);
        assert_eq!(out[13], -q[6]);
        assert_eq!(g.matrix() * g.matrix(), DMatrix::identity(14, 14));
        assert_eq!(g.inverse(), g);
    }

    #[test]
    fn generate_closes_a_dihedral_group() {
        // Rotation by 90° on R² as a signed permutation and a reflection: D4 has 8 elements.
        let r = SignedPermutation::new(vec![1, 0], vec![-1.0, 1.0]).unwrap();
        let s = SignedPermutation::new(vec![0, 1], vec![1.0, -1.0]).unwrap();
        let g = FiniteGroup::generate("D4", &[r, s], 16).unwrap();
        assert_eq!(g.order(), 8);
        for a in &g.elements {
            assert!(g.elements.contains(&a.inverse()));
            for b in &g.elements {
                assert!(g.elements.contains(&a.compose(b)));
            }
        }
    }

    #[test]
    fn floating_base_conjugation_is_a_group_action() {
        use nalgebra::{Translation3, UnitQuaternion, Vector3};
        // Reflection-like base symmetry as a rotation by π about x, composed with the arm swap.
        let xg = Isometry3::from_parts(
            Translation3::identity(),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
        );
        let act = FloatingBaseAction {
            base: xg,
            joints: SignedPermutation::block_swap(&[1.0, -1.0]),
        };
        let base = Isometry3::from_parts(
            Translation3::new(0.3, -0.2, 0.9),
            UnitQuaternion::from_euler_angles(0.1, 0.2, 0.3),
        );
        let q = [0.1, 0.2, 0.3, 0.4];
        let mut q1 = [0.0; 4];
        let mut q2 = [0.0; 4];
        let b1 = act.apply(&base, &q, &mut q1);
        let b2 = act.apply(&b1, &q1, &mut q2);
        // g² = e: applying twice returns the original base pose and joints (eq. 5 is an action).
        assert!((b2.translation.vector - base.translation.vector).norm() < 1e-12);
        assert!(b2.rotation.angle_to(&base.rotation) < 1e-12);
        assert_eq!(q2, q);
        // Conjugation keeps the base pose's rotation angle (an automorphism of SE(3)).
        assert!((b1.rotation.angle() - base.rotation.angle()).abs() < 1e-12);
    }

    #[test]
    fn invalid_permutations_are_rejected() {
        assert!(SignedPermutation::new(vec![0, 0], vec![1.0, 1.0]).is_err());
        assert!(SignedPermutation::new(vec![0, 1], vec![1.0, 0.5]).is_err());
        assert!(FiniteGroup::c2("x", SignedPermutation::identity(3)).is_err());
    }
}
