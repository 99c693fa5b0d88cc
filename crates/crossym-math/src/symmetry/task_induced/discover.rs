//! Discovery: the cost-preserving affine fields among the Killing fields and the dilation.

use super::cost::dot;
use super::cost::norm;
use super::cost::Cost;
use super::error::TaskInducedError;
use super::generator::AffineGenerator;
use super::sampling::{Region, Samples};
use super::settings::TaskInducedSettings;

use nalgebra::{DMatrix, DVector};

/// Rotation basis of so(d) (about the origin): `J` for d = 2, `[e_x]×, [e_y]×, [e_z]×` for d = 3.
fn rotation_basis(d: usize) -> Vec<[[f64; 3]; 3]> {
    let ez = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0]];
    if d == 2 {
        vec![ez]
    } else {
        vec![
            [[0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]],
            [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]],
            ez,
        ]
    }
}

/// Reduced row echelon form in place (partial pivoting); returns the pivot columns.
pub(super) fn rref(m: &mut DMatrix<f64>, tol: f64) -> Vec<usize> {
    let (rows, cols) = m.shape();
    let mut pivots = Vec::new();
    let mut r = 0;
    for c in 0..cols {
        if r == rows {
            break;
        }
        let mut best = r;
        for i in (r + 1)..rows {
            if m[(i, c)].abs() > m[(best, c)].abs() {
                best = i;
            }
        }
        if m[(best, c)].abs() <= tol {
            for i in r..rows {
                m[(i, c)] = 0.0;
            }
            continue;
        }
        m.swap_rows(r, best);
        let p = m[(r, c)];
        for j in 0..cols {
            m[(r, j)] /= p;
        }
        for i in 0..rows {
            if i != r {
                let f = m[(i, c)];
                if f != 0.0 {
                    for j in 0..cols {
                        let v = m[(r, j)];
                        m[(i, j)] -= f * v;
                    }
                }
            }
        }
        pivots.push(c);
        r += 1;
    }
    pivots
}

/// The candidate fields: rotations about the region's centre, the dilation, the translations.
struct Candidates {
    d: usize,
    rots: Vec<[[f64; 3]; 3]>,
    /// Number of rotations.
    nr: usize,
    /// Number of linear candidates (rotations + dilation).
    nl: usize,
    /// Number of all candidates.
    kc: usize,
}

impl Candidates {
    /// The candidates in dimension `d`.
    fn new(d: usize) -> Self {
        let rots = rotation_basis(d);
        let nr = rots.len();
        let nl = nr + 1; // rotations + dilation
        let kc = nl + d;
        Self {
            d,
            rots,
            nr,
            nl,
            kc,
        }
    }

    /// Candidate `c`'s field at the normalised point `u`, into `out`.
    fn eval(&self, c: usize, u: &[f64], out: &mut [f64]) {
        let (d, nr, nl) = (self.d, self.nr, self.nl);
        for r in 0..d {
            out[r] = if c < nr {
                (0..d).map(|j| self.rots[c][r][j] * u[j]).sum()
            } else if c == nr {
                u[r]
            } else {
                f64::from(u8::from(r == c - nl))
            };
        }
    }

    /// `G[s, c] = n_s · v_c(u_s)`: each candidate's normal component at each sample.
    fn normal_components(&self, samples: &Samples, o: &[f64], rho: f64) -> DMatrix<f64> {
        let d = self.d;
        let s_count = samples.points.len();
        let mut g = DMatrix::zeros(s_count, self.kc);
        let mut u = vec![0.0; d];
        let mut v = vec![0.0; d];
        for (s, (x, n)) in samples.points.iter().zip(&samples.normals).enumerate() {
            for i in 0..d {
                u[i] = (x[i] - o[i]) / rho;
            }
            for c in 0..self.kc {
                self.eval(c, &u, &mut v);
                g[(s, c)] = dot(n, &v);
            }
        }
        g
    }

    /// Pure translations: rows whose pivot is a translation column, orthonormalised.
    fn pure_translations(&self, basis: &DMatrix<f64>, pivots: &[usize]) -> Vec<Vec<f64>> {
        let (d, nl) = (self.d, self.nl);
        let mut trans: Vec<Vec<f64>> = Vec::new();
        for (r, &p) in pivots.iter().enumerate() {
            if p >= nl {
                let mut t: Vec<f64> = (0..d).map(|i| basis[(r, nl + i)]).collect();
                for q in &trans {
                    let a = dot(&t, q);
                    for i in 0..d {
                        t[i] -= a * q[i];
                    }
                }
                let tn = norm(&t);
                if tn > 1e-9 {
                    trans.push(t.iter().map(|x| round_tiny(x / tn)).collect());
                }
            }
        }
        trans
    }

    /// The unit-rate generator of basis row `r` (a linear pivot), its translation ⊥ `trans`.
    fn linear_generator(
        &self,
        basis: &DMatrix<f64>,
        r: usize,
        trans: &[Vec<f64>],
        o: &[f64],
        rho: f64,
    ) -> AffineGenerator {
        let (d, nr, nl) = (self.d, self.nr, self.nl);
        // Linear part l (rotation + dilation coordinates) and translation part τ ⊥ translations.
        let l: Vec<f64> = (0..nl).map(|c| basis[(r, c)]).collect();
        let mut tau: Vec<f64> = (0..d).map(|i| basis[(r, nl + i)]).collect();
        for q in trans {
            let a = dot(&tau, q);
            for i in 0..d {
                tau[i] -= a * q[i];
            }
        }
        // Unit rate: the row is scaled by f = ρ/|l| (|l| ≥ 1: the pivot entry is 1), so that
        // A = f Σ_c l_c B_c / ρ = Σ_c (l_c/|l|) B_c and b = f τ − A o.
        let ln = norm(&l);
        let f = rho / ln;
        let mut a = DMatrix::zeros(d, d);
        for (c, lc) in l.iter().enumerate() {
            let coef = lc / ln;
            for i in 0..d {
                for j in 0..d {
                    a[(i, j)] += coef
                        * if c < nr {
                            self.rots[c][i][j]
                        } else {
                            f64::from(u8::from(i == j))
                        };
                }
            }
        }
        let tau = DVector::from_iterator(d, tau.iter().map(|t| round_tiny(*t) * f));
        let b = tau - &a * DVector::from_column_slice(o);
        AffineGenerator::new(a, b)
    }
}

/// Zero for entries below 1e-11 in magnitude.
fn round_tiny(x: f64) -> f64 {
    if x.abs() < 1e-11 {
        0.0
    } else {
        x
    }
}

/// The rows of `Vᵀ` spanning `g`'s numerical nullspace (in rref), their pivots and all
/// relative singular values, largest first.
fn nullspace_rref(g: DMatrix<f64>, tol: f64) -> (DMatrix<f64>, Vec<usize>, Vec<f64>) {
    let kc = g.ncols();
    let svd = g.svd(false, true);
    let vt = svd.v_t.expect("SVD with V requested");
    let sv = svd.singular_values;
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let null: Vec<usize> = (0..sv.len()).filter(|&i| sv[i] <= tol * smax).collect();
    let mut rel: Vec<f64> = sv.iter().map(|s| s / smax).collect();
    rel.sort_by(|a, b| b.total_cmp(a));

    let mut basis = DMatrix::zeros(null.len(), kc);
    for (r, &i) in null.iter().enumerate() {
        basis.row_mut(r).copy_from(&vt.row(i));
    }
    let pivots = rref(&mut basis, 1e-9);
    basis.apply(|x| *x = round_tiny(*x));
    (basis, pivots, rel)
}

/// Result of the nullspace computation: tidy generators and the relative singular values.
pub(super) fn discover_generators(
    cost: &Cost,
    settings: &TaskInducedSettings,
) -> Result<(Vec<AffineGenerator>, Vec<f64>), TaskInducedError> {
    let d = cost.dim();
    let region = Region::new(cost, settings);
    let samples = region.sample(cost, settings.samples, settings.seed)?;
    let cands = Candidates::new(d);
    let (o, rho) = (&region.center, region.radius);
    let g = cands.normal_components(&samples, o, rho);
    let (basis, pivots, rel) = nullspace_rref(g, settings.nullspace_tol);
    let trans = cands.pure_translations(&basis, &pivots);
    let mut gens = Vec::new();
    for (r, &p) in pivots.iter().enumerate() {
        if p >= cands.nl {
            continue;
        }
        gens.push(cands.linear_generator(&basis, r, &trans, o, rho));
    }
    for t in trans {
        gens.push(AffineGenerator::translation(&t));
    }
    Ok((gens, rel))
}
