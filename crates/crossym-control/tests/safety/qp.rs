//! The filter's QP `min ½(x − v)ᵀW(x − v)` s.t. `lo ≤ x ≤ hi`, `aᵀx ≥ c`: the active-set
//! solver's answers are KKT points (verified here, multipliers included) and Clarabel's,
//! called directly; so is the filter's output when a Jacobian weights it (either solver);
//! a solver that fails leaves the clamp.

use std::cell::Cell;

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use crossym_control::safety::active_set::{solve, ActiveSetStatus, ActiveSetWorkspace};
use crossym_control::safety::{
    Anchor, Barrier, SafetyError, SafetyFilter, SafetySettings, SafetyStatus,
};
use crossym_math::kinematics::JointLimits;
use nalgebra::{DMatrix, DVector};
use proptest::prelude::*;
use proptest::test_runner::TestRunner;

use crate::support::{config, unit_range};

/// One QP: `W`, `v`, the box and the optional row `aᵀx ≥ c`.
#[derive(Debug, Clone)]
struct Qp {
    w: DMatrix<f64>,
    v: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    row: Option<(Vec<f64>, f64)>,
}

impl Qp {
    fn row(&self) -> Option<(&[f64], f64)> {
        self.row.as_ref().map(|(a, c)| (a.as_slice(), *c))
    }
}

/// `W = JᵀJ + ε·tr(JᵀJ)/n·I` (the filter's weight) from a random `m × n` Jacobian.
fn weight(j: &DMatrix<f64>, eps: f64) -> DMatrix<f64> {
    let n = j.ncols();
    let mut w = j.transpose() * j;
    let e = eps * (w.trace() / n as f64).max(1e-12);
    for i in 0..n {
        w[(i, i)] += e;
    }
    w
}

/// Random QPs of 1 to 14 joints whose clamp of `v` satisfies the row (the active-set
/// solver's feasible start), the row binding more often than not.
fn qp() -> impl Strategy<Value = Qp> {
    (1usize..15, 1usize..7).prop_flat_map(|(n, m)| {
        (
            prop::collection::vec(-1.0..1.0f64, m * n),
            prop_oneof![Just(1e-3), 1e-3..1.0f64],
            prop::collection::vec((-3.0..3.0f64, -2.0..0.5f64, 0.0..2.0f64), n),
            prop::option::of((prop::collection::vec(-1.0..1.0f64, n), 0.0..0.5f64)),
        )
            .prop_map(move |(j, eps, joints, row)| {
                let w = weight(&DMatrix::from_row_slice(m, n, &j), eps);
                let v: Vec<f64> = joints.iter().map(|t| t.0).collect();
                let lo: Vec<f64> = joints.iter().map(|t| t.1).collect();
                let hi: Vec<f64> = joints.iter().map(|t| t.1 + t.2).collect();
                let row = row.map(|(a, below)| {
                    let ax: f64 = (0..n).map(|i| a[i] * v[i].clamp(lo[i], hi[i])).sum();
                    (a, ax - below)
                });
                Qp { w, v, lo, hi, row }
            })
    })
}

/// The KKT conditions of `q` at `x`, to `tol` (relative to the data's scale): `x`
/// feasible, and multipliers `λ ≥ 0` of the bounds and `μ ≥ 0` of the row with
/// `W(x − v) = λ_lo − λ_hi + μa`, each zero unless its constraint is active. `μ` is the one
/// unknown left once the free joints and bound signs are read off `x`: the conditions are
/// linear in it, so an interval of `μ` that meets them all is searched for.
fn kkt(q: &Qp, x: &[f64], tol: f64) -> Result<(), String> {
    let n = x.len();
    let scale = q.v.iter().chain(x).fold(1.0f64, |m, a| m.max(a.abs()));
    let tol_x = tol * scale;
    for i in 0..n {
        if !(x[i] >= q.lo[i] - tol_x && x[i] <= q.hi[i] + tol_x) {
            return Err(format!(
                "x[{i}] = {} outside [{}, {}]",
                x[i], q.lo[i], q.hi[i]
            ));
        }
    }
    let d = DVector::from_iterator(n, (0..n).map(|i| x[i] - q.v[i]));
    let g = &q.w * d;
    // Relative to W's size: the same QP scaled has the same solution.
    let tol_g = tol * scale * q.w.abs().max();
    // Interval of μ meeting every condition; without an active row μ = 0.
    let (mut mu_lo, mut mu_hi) = (0.0f64, f64::INFINITY);
    let (a, row_active) = match q.row() {
        Some((a, c)) => {
            let ax: f64 = a.iter().zip(x).map(|(a, x)| a * x).sum();
            let a_scale = a.iter().fold(c.abs(), |m, a| m.max(a.abs())).max(1.0);
            if ax < c - tol_x * a_scale * n as f64 {
                return Err(format!("row: aᵀx = {ax} < c = {c}"));
            }
            (a.to_vec(), ax <= c + tol_x * a_scale * n as f64)
        }
        None => (vec![0.0; n], false),
    };
    if !row_active {
        mu_hi = 0.0;
    }
    // Each condition reads `lower ≤ g_i − μ a_i ≤ upper`.
    for i in 0..n {
        let at_lo = x[i] <= q.lo[i] + tol_x;
        let at_hi = x[i] >= q.hi[i] - tol_x;
        let (lower, upper) = match (at_lo, at_hi) {
            (true, true) => continue,
            (true, false) => (-tol_g, f64::INFINITY),
            (false, true) => (f64::NEG_INFINITY, tol_g),
            (false, false) => (-tol_g, tol_g),
        };
        // g − μa ≥ lower ⇔ μa ≤ g − lower; g − μa ≤ upper ⇔ μa ≥ g − upper.
        let (gi, ai) = (g[i], a[i]);
        if ai.abs() < 1e-300 {
            if gi < lower || gi > upper {
                return Err(format!("stationarity at joint {i}: gradient {gi}"));
            }
            continue;
        }
        let (p, r) = ((gi - lower) / ai, (gi - upper) / ai);
        if ai > 0.0 {
            mu_hi = mu_hi.min(p);
            mu_lo = mu_lo.max(r);
        } else {
            mu_lo = mu_lo.max(p);
            mu_hi = mu_hi.min(r);
        }
    }
    if mu_lo <= mu_hi {
        Ok(())
    } else {
        Err(format!(
            "no multiplier of the row fits: μ ∈ [{mu_lo}, {mu_hi}] (gradient {g:?})"
        ))
    }
}

/// Clarabel, called directly on `q` (tight tolerances, `W` scaled to unit size, which
/// leaves the solution as it is): its solution, if solved.
fn clarabel(q: &Qp) -> Option<Vec<f64>> {
    let n = q.v.len();
    let w = &q.w / q.w.abs().max();
    let (mut colptr, mut rowval, mut pv) = (vec![0], Vec::new(), Vec::new());
    for col in 0..n {
        for r in 0..=col {
            rowval.push(r);
            pv.push(w[(r, col)]);
        }
        colptr.push(rowval.len());
    }
    let p = CscMatrix::new(n, n, colptr, rowval, pv);
    let lin: Vec<f64> = (0..n)
        .map(|r| -(0..n).map(|k| w[(r, k)] * q.v[k]).sum::<f64>())
        .collect();
    // A = [I; −I; −aᵀ], b = [hi; −lo; −c].
    let rows = 2 * n + usize::from(q.row.is_some());
    let (mut colptr, mut rowval, mut av) = (vec![0], Vec::new(), Vec::new());
    for col in 0..n {
        rowval.extend([col, n + col]);
        av.extend([1.0, -1.0]);
        if let Some((a, _)) = &q.row {
            rowval.push(2 * n);
            av.push(-a[col]);
        }
        colptr.push(rowval.len());
    }
    let a = CscMatrix::new(rows, n, colptr, rowval, av);
    let mut b: Vec<f64> =
        q.hi.iter()
            .copied()
            .chain(q.lo.iter().map(|l| -l))
            .collect();
    if let Some((_, c)) = &q.row {
        b.push(-c);
    }
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-11)
        .tol_gap_rel(1e-11)
        .tol_feas(1e-11)
        .tol_ktratio(1e-9)
        .max_iter(200)
        .build()
        .unwrap();
    let cones = [NonnegativeConeT(rows)];
    let mut solver = DefaultSolver::new(&p, &lin, &a, &b, &cones, settings).unwrap();
    solver.solve();
    matches!(solver.solution.status, SolverStatus::Solved).then(|| solver.solution.x.clone())
}

fn max_diff(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).fold(0.0, |m, (a, b)| m.max((a - b).abs()))
}

proptest! {
    #![proptest_config(config(256))]

    /// From a feasible start the active-set solver solves every well-posed instance; its
    /// solution is a KKT point and Clarabel's (the optimum of a strictly convex QP is
    /// unique).
    #[test]
    fn the_active_set_solution_is_the_kkt_point_clarabel_finds(q in qp()) {
        let n = q.v.len();
        let mut ws = ActiveSetWorkspace::new(n);
        let mut x = vec![f64::NAN; n];
        let status = solve(q.w.as_slice(), &q.v, &q.lo, &q.hi, q.row(), &mut x, &mut ws);
        prop_assert!(matches!(status, ActiveSetStatus::Solved { .. }), "{:?}", status);
        if let Err(e) = kkt(&q, &x, 1e-9) {
            return Err(TestCaseError::fail(format!("active set: {e}; x = {x:?}")));
        }
        let xc = clarabel(&q).expect("Clarabel solves a feasible strictly convex QP");
        prop_assert!(max_diff(&x, &xc) <= 1e-6, "active set {:?}, Clarabel {:?}", x, xc);
    }
}

/// The filter's QP with a box known beforehand: joints far inside wide limits, an
/// acceleration limit too large to bind, so `lo = −v_max`, `hi = v_max`; the barrier row
/// `gᵀx ≥ −γh` with `h ≥ 0` (`x = 0` satisfies it).
#[derive(Debug, Clone)]
struct Weighted {
    vmax: Vec<f64>,
    jac: DMatrix<f64>,
    v: Vec<f64>,
    barrier: Option<(Vec<f64>, f64)>,
}

fn weighted() -> impl Strategy<Value = Weighted> {
    (1usize..10, 1usize..7).prop_flat_map(|(n, m)| {
        (
            prop::collection::vec(0.2..2.0f64, n),
            prop::collection::vec(-1.0..1.0f64, m * n),
            prop::collection::vec(-4.0..4.0f64, n),
            prop::option::of((prop::collection::vec(-1.0..1.0f64, n), 0.0..0.2f64)),
        )
            .prop_map(move |(vmax, j, v, barrier)| Weighted {
                vmax,
                jac: DMatrix::from_row_slice(m, n, &j),
                v,
                barrier,
            })
    })
}

const GAMMA: f64 = 5.0;
const EPSILON: f64 = 1e-2;

fn weighted_filter(vmax: &[f64], barrier: bool, max_iter: u32) -> SafetyFilter {
    let limits: Vec<JointLimits> = vmax
        .iter()
        .map(|&velocity| JointLimits {
            lower: -1e3,
            upper: 1e3,
            velocity,
            effort: 1.0,
            acceleration: Some(1e6),
        })
        .collect();
    let settings = SafetySettings {
        weight_epsilon: EPSILON,
        barrier_gain: GAMMA,
        min_ee_distance: barrier.then_some(0.1),
        max_iter,
        ..SafetySettings::default()
    };
    SafetyFilter::new(&limits, settings).unwrap()
}

/// Runs the filter on `c` from rest; its output and status.
fn filter_once(f: &mut SafetyFilter, c: &Weighted) -> (Vec<f64>, SafetyStatus) {
    let n = c.v.len();
    let mut out = vec![f64::NAN; n];
    let barrier = c.barrier.as_ref().map(|(g, h)| Barrier {
        gradient: g,
        value: *h,
    });
    let q = vec![0.0; n];
    let anchor = Anchor::Commanded { q: &q };
    let report = f.filter(0.0, anchor, &c.v, Some(&c.jac), barrier, &mut out);
    (out, report.status)
}

/// The filter's weighted QP (either solver: the active set, or Clarabel where it
/// declines) gives the KKT point of the QP written out here, which Clarabel, called
/// directly, also finds. Both paths must be taken.
#[test]
fn the_filter_solves_the_weighted_qp_through_either_solver() {
    let (active_set, clarabel_path) = (Cell::new(0u32), Cell::new(0u32));
    let mut runner = TestRunner::new(config(256));
    runner
        .run(&weighted(), |c| {
            let n = c.v.len();
            let mut f = weighted_filter(&c.vmax, c.barrier.is_some(), 50);
            let (out, status) = filter_once(&mut f, &c);
            let q = Qp {
                w: weight(&c.jac, EPSILON),
                v: c.v.clone(),
                lo: c.vmax.iter().map(|v| -v).collect(),
                hi: c.vmax.clone(),
                row: c.barrier.as_ref().map(|(g, h)| (g.clone(), -GAMMA * h)),
            };
            if status == SafetyStatus::Passthrough {
                prop_assert_eq!(&out, &c.v);
                return Ok(());
            }
            prop_assert_eq!(status, SafetyStatus::Filtered);
            let through_clarabel = f.clarabel_solves() == 1;
            let cell = if through_clarabel {
                &clarabel_path
            } else {
                &active_set
            };
            cell.set(cell.get() + 1);
            // An interior-point answer is a KKT point to its tolerance only.
            let tol = if through_clarabel { 1e-6 } else { 1e-9 };
            if let Err(e) = kkt(&q, &out, tol) {
                return Err(TestCaseError::fail(format!("{n} joints: {e}; x = {out:?}")));
            }
            let xc = clarabel(&q).expect("Clarabel solves a feasible strictly convex QP");
            prop_assert!(
                max_diff(&out, &xc) <= 1e-5,
                "filter {:?}, Clarabel {:?}",
                out,
                xc
            );
            Ok(())
        })
        .unwrap();
    let (fast, slow) = (active_set.get(), clarabel_path.get());
    assert!(
        fast >= 50 && slow >= 10,
        "active set {fast}, Clarabel {slow}"
    );
}

/// Clarabel held to one iteration cannot solve a QP whose barrier row binds from an
/// infeasible start: the command is then `v` clamped to the velocity and acceleration
/// box (computed here), whatever the barrier asked.
#[test]
fn a_failed_solve_falls_back_to_the_clamp() {
    let fallbacks = Cell::new(0u32);
    let mut runner = TestRunner::new(config(128));
    runner
        .run(&weighted(), |mut c| {
            let Some((g, _)) = c.barrier.as_mut() else {
                return Ok(());
            };
            // Push hard against the row so that the clamp of v violates it.
            for (v, g) in c.v.iter_mut().zip(g.iter()) {
                *v = -10.0 * g.signum() - g;
            }
            let mut f = weighted_filter(&c.vmax, true, 1);
            let (out, status) = filter_once(&mut f, &c);
            if status != SafetyStatus::Fallback {
                return Ok(());
            }
            fallbacks.set(fallbacks.get() + 1);
            let expected: Vec<f64> = (0..c.v.len())
                .map(|i| c.v[i].clamp(-c.vmax[i], c.vmax[i]))
                .collect();
            prop_assert_eq!(out, expected);
            Ok(())
        })
        .unwrap();
    assert!(fallbacks.get() >= 20, "{} fallbacks", fallbacks.get());
    // A non-finite policy velocity counts as 0 in the clamp.
    let c = Weighted {
        vmax: vec![1.0, 1.0],
        jac: DMatrix::from_row_slice(1, 2, &[1.0, 0.5]),
        v: vec![f64::NAN, 5.0],
        barrier: Some((vec![-1.0, -1.0], 0.0)),
    };
    let mut f = weighted_filter(&c.vmax, true, 1);
    assert_eq!(
        filter_once(&mut f, &c),
        (vec![0.0, 1.0], SafetyStatus::Fallback)
    );
}

#[test]
fn every_setting_out_of_its_domain_is_refused_by_name() {
    let limits = unit_range(2, 1.0, None);
    let d = SafetySettings::default;
    let cases: [(SafetySettings, &str); 11] = [
        (SafetySettings { dt: 0.0, ..d() }, "dt"),
        (
            SafetySettings {
                dt: f64::NAN,
                ..d()
            },
            "dt",
        ),
        (
            SafetySettings {
                margin: -1e-3,
                ..d()
            },
            "margin",
        ),
        (
            SafetySettings {
                default_acceleration: 0.0,
                ..d()
            },
            "default_acceleration",
        ),
        (
            SafetySettings {
                weight_epsilon: f64::INFINITY,
                ..d()
            },
            "weight_epsilon",
        ),
        (
            SafetySettings {
                barrier_gain: -1.0,
                ..d()
            },
            "barrier_gain",
        ),
        (
            SafetySettings {
                min_ee_distance: Some(0.0),
                ..d()
            },
            "min_ee_distance",
        ),
        (SafetySettings { max_iter: 0, ..d() }, "max_iter"),
        (
            SafetySettings {
                latency_s: Some(f64::NAN),
                ..d()
            },
            "latency_s",
        ),
        (
            SafetySettings {
                state_delay_s: -0.1,
                ..d()
            },
            "state_delay_s",
        ),
        (
            SafetySettings {
                max_state_age_s: f64::INFINITY,
                ..d()
            },
            "max_state_age_s",
        ),
    ];
    for (settings, key) in cases {
        match SafetyFilter::new(&limits, settings) {
            Err(SafetyError::Setting { field, .. }) => assert_eq!(field, key),
            other => panic!("{key}: {:?}", other.err()),
        }
    }
    for velocity in [f64::INFINITY, f64::NAN, 0.0, -1.0] {
        let mut bad = limits.clone();
        bad[1].velocity = velocity;
        assert!(matches!(
            SafetyFilter::new(&bad, d()),
            Err(SafetyError::NoVelocityLimit { index: 1 })
        ));
    }
}
