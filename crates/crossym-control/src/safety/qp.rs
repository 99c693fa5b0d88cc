//! The safety filter's QP for Clarabel, set up once: `min ½xᵀPx + qᵀx` s.t. `Ax + s = b`,
//! `s ≥ 0`, with `P = 2W` (dense upper triangle), `q = −2Wv`, `A = [I; −I; −g]`,
//! `b = [hi; −lo; γh]`. Each solve only updates `P`, `q`, `b` (and the barrier row of `A`)
//! in place, following Clarabel's data-updating API. Setup runs one solve, so that every
//! tick's solve allocates nothing (Clarabel's timers, vendor/README.md).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use nalgebra::DMatrix;

use super::settings::SafetyError;

/// Clarabel and the QP's data, allocated at setup.
pub(crate) struct ClarabelQp {
    solver: DefaultSolver<f64>,
    barrier_row: bool,
    p_vals: Vec<f64>,
    a_vals: Vec<f64>,
    q_vec: Vec<f64>,
    b_vec: Vec<f64>,
    iterations: u32,
}

impl ClarabelQp {
    /// The QP of `n` joints, with the barrier row if `barrier_row`, at most `max_iter`
    /// interior-point iterations (presolve off, no time limit: its clock counts setup time).
    pub(crate) fn new(n: usize, barrier_row: bool, max_iter: u32) -> Result<Self, SafetyError> {
        let br = usize::from(barrier_row);
        // P: dense upper triangle, column-major.
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        for j in 0..n {
            rowval.extend(0..=j);
            colptr.push(rowval.len());
        }
        let p_vals: Vec<f64> = (0..n)
            .flat_map(|j| (0..=j).map(move |i| if i == j { 2.0 } else { 0.0 }))
            .collect();
        let p = CscMatrix::new(n, n, colptr, rowval, p_vals.clone());
        // A = [I; −I; −g]: per column rows j, n + j, and 2n (barrier).
        let m = 2 * n + br;
        let mut colptr = vec![0];
        let mut rowval = Vec::new();
        let mut a_vals = Vec::new();
        for j in 0..n {
            rowval.extend([j, n + j]);
            a_vals.extend([1.0, -1.0]);
            if br == 1 {
                rowval.push(2 * n);
                a_vals.push(0.0);
            }
            colptr.push(rowval.len());
        }
        let a = CscMatrix::new(m, n, colptr, rowval, a_vals.clone());
        let q_vec = vec![0.0; n];
        let b_vec = vec![1.0; m];
        let settings_c = DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .input_sparse_dropzeros(false)
            .max_iter(max_iter)
            .build()
            .map_err(|e| SafetyError::Solver {
                message: format!("{e:?}"),
            })?;
        let cones = [NonnegativeConeT(m)];
        let mut solver =
            DefaultSolver::new(&p, &q_vec, &a, &b_vec, &cones, settings_c).map_err(|e| {
                SafetyError::Solver {
                    message: e.to_string(),
                }
            })?;
        // One solve at setup builds Clarabel's timer tree; the vendored Clarabel keeps it
        // across solves (vendor/README.md), so no tick's solve allocates. A solve depends
        // only on the data it is given, not on earlier solves (`tests::history_free`).
        solver.solve();
        Ok(Self {
            solver,
            barrier_row,
            p_vals,
            a_vals,
            q_vec,
            b_vec,
            iterations: 0,
        })
    }

    /// Solves `min (x − v)ᵀW(x − v)` s.t. `lo ≤ x ≤ hi` and the barrier row
    /// `g·x ≥ −γ h` for `barrier = (g, h)` (when the QP has the row; `None` makes it
    /// vacuous). True when solved with a finite
    /// solution ([`Self::solution`]). Allocation-free.
    pub(crate) fn solve(
        &mut self,
        w: &DMatrix<f64>,
        v: &[f64],
        lo: &[f64],
        hi: &[f64],
        barrier: Option<(&[f64], f64)>,
        gamma: f64,
    ) -> bool {
        let n = v.len();
        self.iterations = 0;
        let mut k = 0;
        for c in 0..n {
            for r in 0..=c {
                self.p_vals[k] = 2.0 * w[(r, c)];
                k += 1;
            }
        }
        for r in 0..n {
            self.q_vec[r] = -2.0 * (0..n).map(|c| w[(r, c)] * v[c]).sum::<f64>();
            self.b_vec[r] = hi[r];
            self.b_vec[n + r] = -lo[r];
        }
        if self.barrier_row {
            match barrier {
                Some((gradient, value)) => {
                    for c in 0..n {
                        self.a_vals[3 * c + 2] = -gradient[c];
                    }
                    self.b_vec[2 * n] = gamma * value;
                }
                None => {
                    for c in 0..n {
                        self.a_vals[3 * c + 2] = 0.0;
                    }
                    self.b_vec[2 * n] = 1.0;
                }
            }
        }
        let updated = self.solver.update_P(&self.p_vals).is_ok()
            && self.solver.update_q(&self.q_vec).is_ok()
            && self.solver.update_b(&self.b_vec).is_ok()
            && (!self.barrier_row || self.solver.update_A(&self.a_vals).is_ok());
        updated && {
            self.solver.solve();
            self.iterations = self.solver.info.iterations;
            matches!(
                self.solver.solution.status,
                SolverStatus::Solved | SolverStatus::AlmostSolved
            ) && self.solver.solution.x.iter().all(|x| x.is_finite())
        }
    }

    /// Interior-point iterations of the last solve (0 when it was not called).
    pub(crate) fn iterations(&self) -> u32 {
        self.iterations
    }

    /// The last solution (`n` entries).
    pub(crate) fn solution(&self) -> &[f64] {
        &self.solver.solution.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A QP: `W`, `v`, the box `lo`, `hi` and a row (gradient, value).
    struct Instance {
        w: DMatrix<f64>,
        v: Vec<f64>,
        lo: Vec<f64>,
        hi: Vec<f64>,
        gradient: Vec<f64>,
        value: f64,
    }

    /// A deterministic QP of `n` joints: `W = GᵀG + 0.1 I`, `v`, a box around 0 and a row.
    fn instance(k: u64, n: usize) -> Instance {
        let mut state = 0x9e37_79b9_7f4a_7c15u64 ^ k.wrapping_mul(0xbf58_476d_1ce4_e5b9);
        let mut r = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        let g = DMatrix::from_fn(n, n, |_, _| r());
        let w = g.transpose() * &g + DMatrix::identity(n, n) * 0.1;
        let v: Vec<f64> = (0..n).map(|_| 3.0 * r()).collect();
        let lo: Vec<f64> = (0..n).map(|_| -0.5 - r().abs()).collect();
        let hi: Vec<f64> = (0..n).map(|_| 0.5 + r().abs()).collect();
        let gradient: Vec<f64> = (0..n).map(|_| r()).collect();
        Instance {
            w,
            v,
            lo,
            hi,
            gradient,
            value: 0.3 * r(),
        }
    }

    /// A solve's result depends only on its data: one solver reused over 200 QPs (as the
    /// filter reuses it) gives, bit for bit, what a new solver gives on each — so the
    /// setup's solve changes no tick's result.
    #[test]
    fn history_free() {
        for (n, barrier) in [(8, true), (14, true), (7, false)] {
            let mut shared = ClarabelQp::new(n, barrier, 50).unwrap();
            let mut solved = 0;
            for k in 0..200 {
                let Instance {
                    w,
                    v,
                    lo,
                    hi,
                    gradient,
                    value,
                } = instance(k, n);
                let row = barrier.then_some((gradient.as_slice(), value));
                let a = shared.solve(&w, &v, &lo, &hi, row, 1.0);
                let mut fresh = ClarabelQp::new(n, barrier, 50).unwrap();
                let b = fresh.solve(&w, &v, &lo, &hi, row, 1.0);
                assert_eq!(a, b, "n = {n}, QP {k}: status");
                assert_eq!(shared.iterations(), fresh.iterations(), "n = {n}, QP {k}");
                let bits = |x: &[f64]| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(
                    bits(shared.solution()),
                    bits(fresh.solution()),
                    "n = {n}, QP {k}: solution"
                );
                solved += usize::from(a);
            }
            assert!(solved > 150, "n = {n}: {solved} of 200 solved");
        }
    }
}
