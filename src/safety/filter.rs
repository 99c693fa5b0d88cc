//! The joint-velocity safety filter: a small QP solved with Clarabel.
//!
//! Given the policy's joint velocity `v`, find
//!
//! `x* = argmin (x − v)ᵀ W (x − v)`  s.t.  `lo ≤ x ≤ hi`,  `g·x ≥ −γ h`  (optional)
//!
//! where `[lo, hi]` are the per-joint bounds of [`super::bounds`] (velocity, acceleration
//! relative to the last command, braking-aware position limits), `W = JᵀJ + εI` keeps the
//! end-effector motion the policy asked for as far as the limits allow (`J` the stacked task
//! Jacobian; `ε` relative to `tr(JᵀJ)/n`), and the optional row is a linearised barrier
//! `ḣ ≥ −γ h` on `h = ‖p_l − p_r‖ − d_min`, the distance between two end-effectors.
//!
//! Following Clarabel's data-updating API the solver is built once at setup (presolve off,
//! no time limit: its clock counts setup time) and each tick only updates `P`, `q` and `b`
//! (and the barrier row of `A`) in place. When the unconstrained optimum `v` already
//! satisfies every constraint it is returned as is, without calling the solver. With no
//! Jacobian (`W = I`) and no barrier the QP is separable and its solution is the clamp.
//! The solver's output is clamped to the bounds; any status other than solved falls back
//! to the clamp of `v`, which always satisfies the box.

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, NonnegativeConeT, SolverStatus,
};
use nalgebra::DMatrix;

use super::bounds::joint_bounds;
use crate::kinematics::JointLimits;

/// Settings of the safety filter, validated once.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySettings {
    /// Control period `Δt` (s).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// Distance kept from position limits (rad or m).
    #[serde(default = "d_margin")]
    pub margin: f64,
    /// Acceleration limit for joints whose URDF/config gives none (rad/s² or m/s²).
    #[serde(default = "d_accel")]
    pub default_acceleration: f64,
    /// Relative regularisation `ε` of `W = JᵀJ + ε·tr(JᵀJ)/n·I`.
    #[serde(default = "d_eps")]
    pub weight_epsilon: f64,
    /// Minimum end-effector distance for the barrier (task units); `None` disables it.
    #[serde(default)]
    pub min_ee_distance: Option<f64>,
    /// Barrier gain `γ` (1/s).
    #[serde(default = "d_gamma")]
    pub barrier_gain: f64,
    /// Iteration budget of the interior-point solver.
    #[serde(default = "d_iter")]
    pub max_iter: u32,
}

fn d_dt() -> f64 {
    0.01
}
fn d_margin() -> f64 {
    0.01
}
fn d_accel() -> f64 {
    10.0
}
fn d_eps() -> f64 {
    1e-3
}
fn d_gamma() -> f64 {
    5.0
}
fn d_iter() -> u32 {
    50
}

impl Default for SafetySettings {
    fn default() -> Self {
        Self {
            dt: d_dt(),
            margin: d_margin(),
            default_acceleration: d_accel(),
            weight_epsilon: d_eps(),
            min_ee_distance: None,
            barrier_gain: d_gamma(),
            max_iter: d_iter(),
        }
    }
}

/// Setup errors of the safety filter.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum SafetyError {
    /// A setting is out of its domain.
    #[error("invalid safety setting `{field}`: {message}")]
    Setting {
        /// Configuration key.
        field: &'static str,
        /// Why.
        message: String,
    },
    /// A joint has no finite velocity limit.
    #[error("joint {index} has no finite velocity limit: set [robot.limits.<joint>] velocity")]
    NoVelocityLimit {
        /// Index in the controlled joint order.
        index: usize,
    },
    /// Clarabel refused the problem at setup.
    #[error("QP solver setup failed: {message}")]
    Solver {
        /// Solver message.
        message: String,
    },
}

/// What the filter did this tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SafetyStatus {
    /// `v` satisfied every constraint and was returned unchanged.
    Passthrough,
    /// The QP was solved (or, with `W = I` and no barrier, clamped exactly).
    Filtered,
    /// The solver did not succeed; the clamp of `v` to the bounds was returned.
    Fallback,
    /// The measured state was not finite: a braking command was returned.
    InvalidState,
}

/// Per-tick report of the filter (no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyReport {
    /// What happened.
    pub status: SafetyStatus,
    /// Joints whose output sits on a bound.
    pub active: u32,
    /// Joints where braking overrode the acceleration limit.
    pub accel_overridden: u32,
    /// True when the policy output had non-finite entries (replaced by 0).
    pub policy_nonfinite: bool,
    /// Solver iterations (0 when not called).
    pub iterations: u32,
}

/// The barrier row of one tick: `gradient · x ≥ −γ · value`.
#[derive(Debug, Clone, Copy)]
pub struct Barrier<'a> {
    /// `∂h/∂q` (n entries).
    pub gradient: &'a [f64],
    /// `h(q) = ‖p_l − p_r‖ − d_min` (task units).
    pub value: f64,
}

/// Joint-velocity safety filter; setup allocates, [`SafetyFilter::filter`] reuses.
pub struct SafetyFilter {
    n: usize,
    limits: Vec<JointLimits>,
    settings: SafetySettings,
    solver: DefaultSolver<f64>,
    barrier_rows: usize,
    p_vals: Vec<f64>,
    a_vals: Vec<f64>,
    q_vec: Vec<f64>,
    b_vec: Vec<f64>,
    w: DMatrix<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    v: Vec<f64>,
    last: Vec<f64>,
}

impl SafetyFilter {
    /// Builds the filter for joints with `limits` (every velocity limit finite).
    pub fn new(limits: &[JointLimits], settings: SafetySettings) -> Result<Self, SafetyError> {
        let bad = |field: &'static str, message: String| SafetyError::Setting { field, message };
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(settings.dt) {
            return Err(bad("dt", format!("{} must be positive", settings.dt)));
        }
        if !(settings.margin.is_finite() && settings.margin >= 0.0) {
            return Err(bad(
                "margin",
                format!("{} must be non-negative", settings.margin),
            ));
        }
        if !pos(settings.default_acceleration) {
            return Err(bad(
                "default_acceleration",
                format!("{} must be positive", settings.default_acceleration),
            ));
        }
        if !pos(settings.weight_epsilon) {
            return Err(bad(
                "weight_epsilon",
                format!("{} must be positive", settings.weight_epsilon),
            ));
        }
        if !pos(settings.barrier_gain) {
            return Err(bad(
                "barrier_gain",
                format!("{} must be positive", settings.barrier_gain),
            ));
        }
        if let Some(d) = settings.min_ee_distance {
            if !pos(d) {
                return Err(bad("min_ee_distance", format!("{d} must be positive")));
            }
        }
        if settings.max_iter == 0 {
            return Err(bad("max_iter", "must be positive".into()));
        }
        if let Some(i) = limits
            .iter()
            .position(|l| !(l.velocity.is_finite() && l.velocity > 0.0))
        {
            return Err(SafetyError::NoVelocityLimit { index: i });
        }
        let n = limits.len();
        let br = usize::from(settings.min_ee_distance.is_some());
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
            .max_iter(settings.max_iter)
            .build()
            .map_err(|e| SafetyError::Solver {
                message: format!("{e:?}"),
            })?;
        let cones = [NonnegativeConeT(m)];
        let solver =
            DefaultSolver::new(&p, &q_vec, &a, &b_vec, &cones, settings_c).map_err(|e| {
                SafetyError::Solver {
                    message: e.to_string(),
                }
            })?;
        Ok(Self {
            n,
            limits: limits.to_vec(),
            settings,
            solver,
            barrier_rows: br,
            p_vals,
            a_vals,
            q_vec,
            b_vec,
            w: DMatrix::zeros(n, n),
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            v: vec![0.0; n],
            last: vec![0.0; n],
        })
    }

    /// The validated settings.
    pub fn settings(&self) -> &SafetySettings {
        &self.settings
    }

    /// The last command returned (rad/s or m/s), the reference of the acceleration limit.
    pub fn last_command(&self) -> &[f64] {
        &self.last
    }

    /// Sets the last command (e.g. to the measured velocity at start-up).
    pub fn reset(&mut self, last: &[f64]) {
        for (l, &v) in self.last.iter_mut().zip(last) {
            *l = if v.is_finite() { v } else { 0.0 };
        }
    }

    /// Bounds of the last tick (lower, upper), rad/s or m/s.
    pub fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lo, &self.hi)
    }

    /// Filters the policy velocity `v` at measured position `q` into `out`. Allocation-free.
    ///
    /// `jac` (m × n task Jacobian) shapes `W`; `barrier` adds the distance row when the
    /// filter was built with `min_ee_distance`. `out` is always finite and inside the
    /// velocity, acceleration (unless braking overrides it) and braking-position bounds.
    pub fn filter(
        &mut self,
        q: &[f64],
        v: &[f64],
        jac: Option<&DMatrix<f64>>,
        barrier: Option<Barrier<'_>>,
        out: &mut [f64],
    ) -> SafetyReport {
        let n = self.n;
        assert!(
            q.len() == n && v.len() == n && out.len() == n,
            "safety filter: wrong dimensions"
        );
        let dt = self.settings.dt;
        let mut report = SafetyReport {
            status: SafetyStatus::Filtered,
            active: 0,
            accel_overridden: 0,
            policy_nonfinite: false,
            iterations: 0,
        };
        if q.iter().any(|x| !x.is_finite()) {
            // No position information: brake every joint toward zero within its acceleration limit.
            for i in 0..n {
                let a = self.limits[i]
                    .acceleration
                    .unwrap_or(self.settings.default_acceleration);
                let u = self.last[i];
                out[i] = if u > 0.0 {
                    (u - a * dt).max(0.0)
                } else {
                    (u + a * dt).min(0.0)
                };
            }
            self.last.copy_from_slice(out);
            report.status = SafetyStatus::InvalidState;
            return report;
        }
        for i in 0..n {
            let b = joint_bounds(
                &self.limits[i],
                self.settings.default_acceleration,
                self.settings.margin,
                q[i],
                self.last[i],
                dt,
            );
            self.lo[i] = b.lo;
            self.hi[i] = b.hi;
            report.accel_overridden += u32::from(b.accel_overridden);
            self.v[i] = if v[i].is_finite() {
                v[i]
            } else {
                report.policy_nonfinite = true;
                0.0
            };
        }
        let barrier = barrier.filter(|b| {
            self.barrier_rows == 1
                && b.gradient.len() == n
                && b.value.is_finite()
                && b.gradient.iter().all(|g| g.is_finite())
        });
        let gamma = self.settings.barrier_gain;
        let barrier_ok = |x: &[f64]| match barrier {
            None => true,
            Some(b) => {
                b.gradient.iter().zip(x).map(|(g, x)| g * x).sum::<f64>() >= -gamma * b.value
            }
        };
        let inside = self
            .v
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .all(|(x, (l, h))| x >= l && x <= h);
        if inside && barrier_ok(&self.v) {
            out.copy_from_slice(&self.v);
            self.last.copy_from_slice(out);
            report.status = SafetyStatus::Passthrough;
            return report;
        }
        let separable = jac.is_none() && barrier.is_none();
        if separable {
            self.clamp_into(out);
        } else {
            // W = JᵀJ + ε tr(JᵀJ)/n I (or I without a Jacobian).
            match jac {
                Some(j) => {
                    // JᵀJ with explicit loops (gemm may allocate packing buffers).
                    let m = j.nrows();
                    for r in 0..n {
                        for c in r..n {
                            let mut acc = 0.0;
                            for k in 0..m {
                                acc += j[(k, r)] * j[(k, c)];
                            }
                            self.w[(r, c)] = acc;
                            self.w[(c, r)] = acc;
                        }
                    }
                    let tr = (0..n).map(|i| self.w[(i, i)]).sum::<f64>() / n as f64;
                    let eps = self.settings.weight_epsilon * tr.max(1e-12);
                    for i in 0..n {
                        self.w[(i, i)] += eps;
                    }
                }
                None => self.w.fill_with_identity(),
            }
            let mut k = 0;
            for c in 0..n {
                for r in 0..=c {
                    self.p_vals[k] = 2.0 * self.w[(r, c)];
                    k += 1;
                }
            }
            for r in 0..n {
                self.q_vec[r] = -2.0 * (0..n).map(|c| self.w[(r, c)] * self.v[c]).sum::<f64>();
                self.b_vec[r] = self.hi[r];
                self.b_vec[n + r] = -self.lo[r];
            }
            if self.barrier_rows == 1 {
                match barrier {
                    Some(b) => {
                        for c in 0..n {
                            self.a_vals[3 * c + 2] = -b.gradient[c];
                        }
                        self.b_vec[2 * n] = gamma * b.value;
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
                && (self.barrier_rows == 0 || self.solver.update_A(&self.a_vals).is_ok());
            let solved = updated && {
                self.solver.solve();
                report.iterations = self.solver.info.iterations;
                matches!(
                    self.solver.solution.status,
                    SolverStatus::Solved | SolverStatus::AlmostSolved
                ) && self.solver.solution.x.iter().all(|x| x.is_finite())
            };
            if solved {
                for i in 0..n {
                    out[i] = self.solver.solution.x[i].clamp(self.lo[i], self.hi[i]);
                }
            } else {
                self.clamp_into(out);
                report.status = SafetyStatus::Fallback;
            }
        }
        report.active = (0..n)
            .filter(|&i| {
                (out[i] - self.lo[i]).abs() <= 1e-12 || (out[i] - self.hi[i]).abs() <= 1e-12
            })
            .count() as u32;
        self.last.copy_from_slice(out);
        report
    }

    fn clamp_into(&self, out: &mut [f64]) {
        for i in 0..self.n {
            out[i] = self.v[i].clamp(self.lo[i], self.hi[i]);
        }
    }
}
