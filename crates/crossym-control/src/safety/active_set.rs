//! A dense primal active-set solver for the safety filter's small QP (Nocedal & Wright,
//! *Numerical Optimization*, Alg. 16.3, specialised to bounds and one general row):
//!
//! `x* = argmin ½ (x − v)ᵀ W (x − v)`  s.t.  `lo ≤ x ≤ hi`,  `aᵀx ≥ c`  (row optional),
//!
//! `W` symmetric positive definite (`n × n`, `n` a robot's joints). From a feasible start
//! (the clamp of `v`, which must satisfy the row) each iteration solves the equality-
//! constrained problem on the free joints — the working set fixes the others at their
//! bounds and, when active, the row at equality — by a Cholesky factor of `W_FF`:
//! `x_F = W_FF⁻¹ r + μ W_FF⁻¹ a_F` with `r = W_FF v_F − W_FA (x_A − v_A)` and the row's
//! multiplier `μ = (c' − a_Fᵀ W_FF⁻¹ r) / (a_Fᵀ W_FF⁻¹ a_F)`. A step that would leave the
//! feasible set stops at the first blocking constraint, which joins the working set; at a
//! stationary point the constraint with the most negative multiplier leaves it
//! (`λ_i = g_i − μ a_i` at a lower bound, its negative at an upper bound, `μ` for the row,
//! `g = W(x − v)`); all multipliers non-negative is the KKT point, the global optimum of
//! the convex QP. Allocation-free with a caller-owned [`ActiveSetWorkspace`].
//!
//! Anything the method does not cover — a start that violates the row, a degenerate row on
//! the free joints, a factor that fails, or no convergence within the iteration cap — is a
//! status, not an answer: the filter then solves the QP with Clarabel as before.

/// How one solve ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum ActiveSetStatus {
    /// KKT point reached after this many iterations.
    Solved {
        /// Iterations (equality-constrained solves).
        iterations: u32,
    },
    /// The clamp of `v` violates the row: no feasible start without a phase-1 problem.
    InfeasibleStart,
    /// `W_FF` not positive definite, the row vanishes on the free joints, or a value
    /// overflowed.
    Degenerate,
    /// No KKT point within the iteration cap.
    MaxIterations,
}

/// Where a joint sits in the working set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Bound {
    Free,
    Lo,
    Hi,
}

/// Scratch for [`solve`] (allocates once, for `n` joints).
#[derive(Debug, Clone)]
pub struct ActiveSetWorkspace {
    n: usize,
    state: Vec<Bound>,
    free: Vec<usize>,
    /// Cholesky factor of `W_FF` (row-major, `n × n` capacity).
    l: Vec<f64>,
    rhs: Vec<f64>,
    x_f: Vec<f64>,
    y_f: Vec<f64>,
    target: Vec<f64>,
    g: Vec<f64>,
}

impl ActiveSetWorkspace {
    /// Scratch for `n` joints.
    pub fn new(n: usize) -> Self {
        Self {
            n,
            state: vec![Bound::Free; n],
            free: Vec::with_capacity(n),
            l: vec![0.0; n * n],
            rhs: vec![0.0; n],
            x_f: vec![0.0; n],
            y_f: vec![0.0; n],
            target: vec![0.0; n],
            g: vec![0.0; n],
        }
    }
}

/// In-place Cholesky `L Lᵀ = M` of the `k × k` row-major matrix in `l[..k*k]` (lower
/// triangle used); false when not positive definite.
fn cholesky(l: &mut [f64], k: usize) -> bool {
    for j in 0..k {
        let mut d = l[j * k + j];
        for p in 0..j {
            d -= l[j * k + p] * l[j * k + p];
        }
        if !(d > 0.0 && d.is_finite()) {
            return false;
        }
        let d = d.sqrt();
        l[j * k + j] = d;
        for i in j + 1..k {
            let mut s = l[i * k + j];
            for p in 0..j {
                s -= l[i * k + p] * l[j * k + p];
            }
            l[i * k + j] = s / d;
        }
    }
    true
}

/// `b ← (L Lᵀ)⁻¹ b` for the factor in `l[..k*k]`.
fn cholesky_solve(l: &[f64], k: usize, b: &mut [f64]) {
    for i in 0..k {
        let mut s = b[i];
        for p in 0..i {
            s -= l[i * k + p] * b[p];
        }
        b[i] = s / l[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = b[i];
        for p in i + 1..k {
            s -= l[p * k + i] * b[p];
        }
        b[i] = s / l[i * k + i];
    }
}

/// `a_Fᵀ y` for `y` indexed like the free joints `free`.
fn free_dot(free: &[usize], a: &[f64], y: &[f64]) -> f64 {
    free.iter().zip(y).map(|(&i, y)| a[i] * y).sum()
}

// Long (≈175 lines) on purpose: one primal active-set loop — the equality-constrained
// step on the free joints, the blocking bound, the multipliers that release a joint —
// whose state lives in the caller's workspace. Split into functions, each piece would take
// the same dozen slices and the loop would lose the textbook shape it is checked against
// (Nocedal & Wright, Alg. 16.3).
/// Solves the QP above into `x` (rad/s or m/s per joint); `w` column-major `n × n`
/// (nalgebra's layout), `row = (a, c)` for `aᵀx ≥ c`. Allocation-free.
///
/// ```
/// use crossym_control::safety::active_set::{solve, ActiveSetStatus, ActiveSetWorkspace};
///
/// // W = diag(1, 4): the joints decouple, the optimum is the clamp of v.
/// let w = [1.0, 0.0, 0.0, 4.0];
/// let mut ws = ActiveSetWorkspace::new(2);
/// let mut x = [0.0; 2];
/// let st = solve(&w, &[2.0, -0.5], &[-1.0, -1.0], &[1.0, 1.0], None, &mut x, &mut ws);
/// assert!(matches!(st, ActiveSetStatus::Solved { .. }));
/// assert_eq!(x, [1.0, -0.5]);
/// // Coupled: W = [[2, 1], [1, 2]], v = (2, 0): x₁ = 1 on its bound, then x₂ minimises
/// // 2x₂² + 2x₂(x₁ − 2) → x₂ = (2 − x₁)/2 = 0.5.
/// let w = [2.0, 1.0, 1.0, 2.0];
/// solve(&w, &[2.0, 0.0], &[-1.0, -1.0], &[1.0, 1.0], None, &mut x, &mut ws);
/// assert!((x[0] - 1.0).abs() < 1e-12 && (x[1] - 0.5).abs() < 1e-12);
/// ```
pub fn solve(
    w: &[f64],
    v: &[f64],
    lo: &[f64],
    hi: &[f64],
    row: Option<(&[f64], f64)>,
    x: &mut [f64],
    ws: &mut ActiveSetWorkspace,
) -> ActiveSetStatus {
    let n = ws.n;
    debug_assert!(w.len() == n * n && v.len() == n && x.len() == n);
    let wij = |i: usize, j: usize| w[i + j * n];
    // Feasible start: the clamp of v (joints clamped start in the working set).
    for i in 0..n {
        x[i] = v[i].clamp(lo[i], hi[i]);
        ws.state[i] = if x[i] == lo[i] && v[i] < lo[i] {
            Bound::Lo
        } else if x[i] == hi[i] && v[i] > hi[i] {
            Bound::Hi
        } else {
            Bound::Free
        };
    }
    let row_scale = row.map_or(1.0, |(a, c)| {
        a.iter().fold(c.abs(), |m, ai| m.max(ai.abs())).max(1e-300)
    });
    let row_value = |x: &[f64]| row.map(|(a, _)| a.iter().zip(x).map(|(a, x)| a * x).sum::<f64>());
    if let (Some((_, c)), Some(ax)) = (row, row_value(x)) {
        if ax < c - 1e-12 * row_scale {
            return ActiveSetStatus::InfeasibleStart;
        }
    }
    let mut row_active = false;
    let tol = 1e-12 * (1.0 + v.iter().fold(0.0f64, |m, a| m.max(a.abs())));
    for iteration in 1..=(4 * n as u32 + 8) {
        // Equality-constrained optimum on the free joints.
        ws.free.clear();
        ws.free
            .extend((0..n).filter(|&i| ws.state[i] == Bound::Free));
        let k = ws.free.len();
        let mut mu = 0.0;
        ws.target.copy_from_slice(x);
        if k > 0 {
            for (r, &i) in ws.free.iter().enumerate() {
                for (c, &j) in ws.free.iter().enumerate() {
                    ws.l[r * k + c] = wij(i, j);
                }
                // r = W_FF v_F − W_FA (x_A − v_A): free terms W_ij v_j, fixed W_ij (v_j − x_j).
                let mut s = 0.0;
                for j in 0..n {
                    s += wij(i, j)
                        * if ws.state[j] == Bound::Free {
                            v[j]
                        } else {
                            v[j] - x[j]
                        };
                }
                ws.rhs[r] = s;
            }
            if !cholesky(&mut ws.l[..k * k], k) {
                return ActiveSetStatus::Degenerate;
            }
            ws.x_f[..k].copy_from_slice(&ws.rhs[..k]);
            cholesky_solve(&ws.l[..k * k], k, &mut ws.x_f[..k]);
            if let (true, Some((a, c))) = (row_active, row) {
                for (r, &i) in ws.free.iter().enumerate() {
                    ws.y_f[r] = a[i];
                }
                let a_fixed: f64 = (0..n)
                    .filter(|&j| ws.state[j] != Bound::Free)
                    .map(|j| a[j] * x[j])
                    .sum();
                cholesky_solve(&ws.l[..k * k], k, &mut ws.y_f[..k]);
                let ay_w = free_dot(&ws.free, a, &ws.y_f);
                if ay_w.is_nan() || ay_w <= 1e-14 * row_scale * row_scale {
                    return ActiveSetStatus::Degenerate;
                }
                mu = (c - a_fixed - free_dot(&ws.free, a, &ws.x_f)) / ay_w;
                for r in 0..k {
                    ws.x_f[r] += mu * ws.y_f[r];
                }
            }
            for (r, &i) in ws.free.iter().enumerate() {
                ws.target[i] = ws.x_f[r];
            }
            if !(mu.is_finite() && ws.x_f[..k].iter().all(|t| t.is_finite())) {
                // Overflow (e.g. a policy output near f64::MAX): not this method's job.
                return ActiveSetStatus::Degenerate;
            }
        } else if row_active {
            // Every joint fixed: the row is satisfied at equality by the fixed point; its
            // multiplier is undetermined — leave the row and re-check.
            row_active = false;
            continue;
        }
        let step_norm = (0..n).fold(0.0f64, |m, i| m.max((ws.target[i] - x[i]).abs()));
        if step_norm <= tol {
            // Stationary on the working set: multipliers.
            for i in 0..n {
                ws.g[i] = (0..n).map(|j| wij(i, j) * (x[j] - v[j])).sum::<f64>();
            }
            if !ws.g.iter().all(|g| g.is_finite()) {
                return ActiveSetStatus::Degenerate;
            }
            let a_of = |i: usize| row.map_or(0.0, |(a, _)| a[i]);
            let mut worst = (-tol, None::<usize>, false);
            for i in 0..n {
                let lambda = match ws.state[i] {
                    Bound::Free => continue,
                    Bound::Lo => ws.g[i] - mu * a_of(i),
                    Bound::Hi => -(ws.g[i] - mu * a_of(i)),
                };
                if lambda < worst.0 {
                    worst = (lambda, Some(i), false);
                }
            }
            if row_active && mu < worst.0 {
                worst = (mu, None, true);
            }
            match worst {
                (_, Some(i), _) => ws.state[i] = Bound::Free,
                (_, None, true) => row_active = false,
                _ => {
                    return ActiveSetStatus::Solved {
                        iterations: iteration,
                    }
                }
            }
            continue;
        }
        // Step toward the target, stopped by the first blocking constraint.
        let mut alpha = 1.0;
        let mut block: Option<(usize, Bound)> = None;
        let mut block_row = false;
        for i in 0..n {
            if ws.state[i] != Bound::Free {
                continue;
            }
            let p = ws.target[i] - x[i];
            if p < 0.0 && ws.target[i] < lo[i] {
                let t = (lo[i] - x[i]) / p;
                if t < alpha {
                    (alpha, block, block_row) = (t, Some((i, Bound::Lo)), false);
                }
            } else if p > 0.0 && ws.target[i] > hi[i] {
                let t = (hi[i] - x[i]) / p;
                if t < alpha {
                    (alpha, block, block_row) = (t, Some((i, Bound::Hi)), false);
                }
            }
        }
        if let (false, Some((a, c)), Some(ax)) = (row_active, row, row_value(x)) {
            let ap: f64 = (0..n).map(|i| a[i] * (ws.target[i] - x[i])).sum();
            if ap < 0.0 && ax + ap < c {
                let t = ((c - ax) / ap).max(0.0);
                if t < alpha {
                    (alpha, block, block_row) = (t, None, true);
                }
            }
        }
        let alpha = alpha.clamp(0.0, 1.0);
        for i in 0..n {
            if ws.state[i] == Bound::Free {
                x[i] += alpha * (ws.target[i] - x[i]);
            }
        }
        if let Some((i, b)) = block {
            ws.state[i] = b;
            x[i] = if b == Bound::Lo { lo[i] } else { hi[i] };
        } else if block_row {
            row_active = true;
        }
    }
    ActiveSetStatus::MaxIterations
}
