//! Discovery: the cost-preserving affine fields among the Killing fields and the dilation.

use super::cost::dot;
use super::cost::norm;
use super::cost::Cost;
use super::error::TaskInducedError;
use super::generator::AffineGenerator;
use super::sampling::Region;
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

/// Result of the nullspace computation: tidy generators and the relative singular values.
pub(super) fn discover_generators(
    cost: &Cost,
    settings: &TaskInducedSettings,
) -> Result<(Vec<AffineGenerator>, Vec<f64>), TaskInducedError> {
    let d = cost.dim();
    let region = Region::new(cost, settings);
    let samples = region.sample(cost, settings.samples, settings.seed)?;
    let rots = rotation_basis(d);
    let nr = rots.len();
    let nl = nr + 1; // rotations + dilation
    let kc = nl + d;
    let (o, rho) = (&region.center, region.radius);
    let cand = |c: usize, u: &[f64], out: &mut [f64]| {
        for r in 0..d {
            out[r] = if c < nr {
                (0..d).map(|j| rots[c][r][j] * u[j]).sum()
            } else if c == nr {
                u[r]
            } else {
                f64::from(u8::from(r == c - nl))
            };
        }
    };
    let s_count = samples.points.len();
    let mut g = DMatrix::zeros(s_count, kc);
    let mut u = vec![0.0; d];
    let mut v = vec![0.0; d];
    for (s, (x, n)) in samples.points.iter().zip(&samples.normals).enumerate() {
        for i in 0..d {
            u[i] = (x[i] - o[i]) / rho;
        }
        for c in 0..kc {
            cand(c, &u, &mut v);
            g[(s, c)] = dot(n, &v);
        }
    }
    let svd = g.svd(false, true);
    let vt = svd.v_t.expect("SVD with V requested");
    let sv = svd.singular_values;
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let null: Vec<usize> = (0..sv.len())
        .filter(|&i| sv[i] <= settings.nullspace_tol * smax)
        .collect();
    let mut rel: Vec<f64> = sv.iter().map(|s| s / smax).collect();
    rel.sort_by(|a, b| b.total_cmp(a));

    let mut basis = DMatrix::zeros(null.len(), kc);
    for (r, &i) in null.iter().enumerate() {
        basis.row_mut(r).copy_from(&vt.row(i));
    }
    let pivots = rref(&mut basis, 1e-9);
    let round = |x: f64| if x.abs() < 1e-11 { 0.0 } else { x };
    basis.apply(|x| *x = round(*x));

    // Pure translations: rows whose pivot is a translation column; orthonormalise them.
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
                trans.push(t.iter().map(|x| round(x / tn)).collect());
            }
        }
    }
    let mut gens = Vec::new();
    for (r, &p) in pivots.iter().enumerate() {
        if p >= nl {
            continue;
        }
        // Linear part l (rotation + dilation coordinates) and translation part τ ⊥ translations.
        let l: Vec<f64> = (0..nl).map(|c| basis[(r, c)]).collect();
        let mut tau: Vec<f64> = (0..d).map(|i| basis[(r, nl + i)]).collect();
        for q in &trans {
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
                            rots[c][i][j]
                        } else {
                            f64::from(u8::from(i == j))
                        };
                }
            }
        }
        let tau = DVector::from_iterator(d, tau.iter().map(|t| round(*t) * f));
        let b = tau - &a * DVector::from_column_slice(o);
        gens.push(AffineGenerator::new(a, b));
    }
    for t in trans {
        gens.push(AffineGenerator::translation(&t));
    }
    Ok((gens, rel))
}
