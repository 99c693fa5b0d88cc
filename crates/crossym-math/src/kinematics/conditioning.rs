//! How far a posture is from a singularity: the condition number of each chain's task
//! Jacobian, `κ(J) = σ_max(J) / σ_min(J)` (1 for a perfectly conditioned chain, ∞ at a
//! singularity), the measure MoveIt Servo's singularity thresholds are stated in.
//!
//! With `J_c` the chain's `d × n` block of the stacked task Jacobian (`d` its task
//! dimension, `d ≤ n`), the singular values are the square roots of the eigenvalues of the
//! `d × d` symmetric `J_c J_cᵀ`, found by cyclic Jacobi rotations on a stack array: no
//! allocation, `d ≤` [`MAX_TASK_DIM`]. `κ` is dimensionless, so one threshold serves robots
//! of any size (unlike `√det(J Jᵀ)`, which scales with the links' lengths to the power `d`).

use super::robot::{Kinematics, KinematicsWorkspace};

/// Largest task dimension a chain's condition number is computed for.
pub const MAX_TASK_DIM: usize = 6;

/// Sweeps of cyclic Jacobi rotations at most (converges quadratically; 6 × 6 needs < 10).
const MAX_SWEEPS: usize = 30;

/// Eigenvalues of the symmetric `d × d` matrix `a` (row-major, `a[r * d + c]`), in
/// `out[..d]`, by cyclic Jacobi rotations; `a` is overwritten.
pub fn symmetric_eigenvalues(a: &mut [f64], d: usize, out: &mut [f64]) {
    for _ in 0..MAX_SWEEPS {
        let mut off = 0.0;
        let mut diag = 0.0;
        for r in 0..d {
            diag += a[r * d + r] * a[r * d + r];
            for c in r + 1..d {
                off += a[r * d + c] * a[r * d + c];
            }
        }
        if off <= 1e-30 * diag.max(f64::MIN_POSITIVE) {
            break;
        }
        for p in 0..d {
            for q in p + 1..d {
                let apq = a[p * d + q];
                if apq == 0.0 {
                    continue;
                }
                let (app, aqq) = (a[p * d + p], a[q * d + q]);
                // The rotation that zeroes a[p][q] (Golub & Van Loan, Alg. 8.5.1).
                let tau = (aqq - app) / (2.0 * apq);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                for k in 0..d {
                    let (akp, akq) = (a[k * d + p], a[k * d + q]);
                    a[k * d + p] = c * akp - s * akq;
                    a[k * d + q] = s * akp + c * akq;
                }
                for k in 0..d {
                    let (apk, aqk) = (a[p * d + k], a[q * d + k]);
                    a[p * d + k] = c * apk - s * aqk;
                    a[q * d + k] = s * apk + c * aqk;
                }
            }
        }
    }
    for (r, o) in out.iter_mut().enumerate().take(d) {
        *o = a[r * d + r];
    }
}

/// The condition number of chain `i`'s task Jacobian in `ws` (after
/// [`Kinematics::jacobian`]); `∞` at a singularity or for a non-finite Jacobian, `NaN`
/// when the task dimension exceeds [`MAX_TASK_DIM`] or the chain's joints. Allocation-free.
pub fn chain_condition_number(kin: &Kinematics, ws: &KinematicsWorkspace, i: usize) -> f64 {
    let d = kin.chains()[i].task.dim();
    // The stacked Jacobian is block-diagonal: the chain's rows are zero outside its joints.
    let (q0, n) = (kin.q_offset(i), kin.chains()[i].dof());
    if d > MAX_TASK_DIM || d > n {
        return f64::NAN;
    }
    let x0 = kin.x_offset(i);
    let mut a = [0.0; MAX_TASK_DIM * MAX_TASK_DIM];
    for r in 0..d {
        for c in r..d {
            let mut acc = 0.0;
            for k in q0..q0 + n {
                acc += ws.jac[(x0 + r, k)] * ws.jac[(x0 + c, k)];
            }
            a[r * d + c] = acc;
            a[c * d + r] = acc;
        }
    }
    if !a[..d * d].iter().all(|x| x.is_finite()) {
        return f64::INFINITY;
    }
    let mut eig = [0.0; MAX_TASK_DIM];
    symmetric_eigenvalues(&mut a[..d * d], d, &mut eig);
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &e in &eig[..d] {
        lo = lo.min(e);
        hi = hi.max(e);
    }
    // Eigenvalues of J Jᵀ below round-off of the largest are zero singular values.
    if hi.is_nan() || hi <= 0.0 || lo <= hi * 1e-15 {
        return f64::INFINITY;
    }
    (hi / lo).sqrt()
}

/// The largest condition number over the chains (the worst-conditioned chain) and its index.
pub fn worst_condition_number(kin: &Kinematics, ws: &KinematicsWorkspace) -> (f64, usize) {
    let mut worst = (1.0, 0);
    for i in 0..kin.chains().len() {
        let k = chain_condition_number(kin, ws, i);
        if k.is_nan() {
            continue;
        }
        if k > worst.0 {
            worst = (k, i);
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Jacobi's eigenvalues of random symmetric matrices agree with nalgebra's
    /// `SymmetricEigen` (an independent algorithm).
    #[test]
    fn jacobi_eigenvalues_agree_with_nalgebra() {
        let mut seed = 7u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
        };
        for d in 1..=MAX_TASK_DIM {
            for _ in 0..20 {
                let m = nalgebra::DMatrix::from_fn(d, d + 2, |_, _| rnd());
                let s = &m * m.transpose();
                let mut a: Vec<f64> = (0..d * d).map(|k| s[(k / d, k % d)]).collect();
                let mut got = vec![0.0; d];
                symmetric_eigenvalues(&mut a, d, &mut got);
                got.sort_by(f64::total_cmp);
                let mut want: Vec<f64> = s.symmetric_eigen().eigenvalues.iter().copied().collect();
                want.sort_by(f64::total_cmp);
                for (g, w) in got.iter().zip(&want) {
                    assert!(
                        (g - w).abs() < 1e-10 * (1.0 + w.abs()),
                        "{d}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }
}
