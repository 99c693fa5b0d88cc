//! The joint-velocity safety filter: a small QP, solved by a dense active-set method
//! ([`super::active_set`]) with Clarabel as the fallback.
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
//! The active-set solver runs first: an exact KKT point of this dense QP (`n` joints, `2n`
//! bounds, one row) in a few µs, checked (finite, the row held) before it is used. When it
//! declines (a clamp of `v` that violates the row, a degenerate row, overflow, no
//! convergence) Clarabel solves the QP as before.
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

use super::active_set::{self, ActiveSetStatus, ActiveSetWorkspace};
use super::bounds::{joint_bounds, Horizon};
use super::history::{CommandHistory, CommandWindow};
use super::rules::{BoundRules, ExactBounds};
use crossym_math::kinematics::JointLimits;

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
    /// Worst-case time (s) from publishing a velocity command until the robot runs it and
    /// until a newer one replaces it: transport, dropped commands (each adds a period) and
    /// late ticks. `None`: one control period.
    #[serde(default)]
    pub latency_s: Option<f64>,
    /// How old a joint state's positions may already be when it arrives (s): sensing and
    /// transport delay before its header stamp or receipt time.
    #[serde(default)]
    pub state_delay_s: f64,
    /// Longest joint-state age (s) the position bound covers with the command history; older
    /// states use the velocity limit for the unknown commands (the node sets it to its
    /// stale timeout).
    #[serde(default = "d_max_age")]
    pub max_state_age_s: f64,
    /// Position modes: how far (rad or m) a measured position may lie from every position
    /// the robot may be following before the node restarts its commands from the measured
    /// state (a reset, a robot that does not follow).
    #[serde(default = "d_track")]
    pub tracking_tolerance: f64,
    /// Position modes: how long (s) a position command keeps pulling the robot. A servo
    /// whose step response does not overshoot (a first-order lag, an overdamped or
    /// critically damped loop) stays inside the hull of the commands of its last few time
    /// constants; the node checks the measured position against the commands of this window
    /// before the measurement (about five time constants of the robot's position loop, plus
    /// its trajectory interpolation). 0: the commands since the measurement only (a robot
    /// that executes each command at once).
    #[serde(default)]
    pub tracking_window_s: f64,
    /// Position modes: a measured position farther than this (rad or m) from the command in
    /// effect when it was measured, on any joint, for longer than `tracking_window_s`, is
    /// reported (status `TRACKING_ERROR`, a warning on the terminal). `None`: not reported.
    #[serde(default)]
    pub tracking_warning: Option<f64>,
    /// Position modes: after this many restarts from the measured state within
    /// `restart_window_s`, the node decides the robot does not follow, holds the measured
    /// position and reports `ROBOT_NOT_FOLLOWING` until a new condition is accepted.
    #[serde(default = "d_max_restarts")]
    pub max_restarts: u32,
    /// The window (s) of `max_restarts`.
    #[serde(default = "d_restart_window")]
    pub restart_window_s: f64,
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
fn d_max_age() -> f64 {
    0.1
}
fn d_track() -> f64 {
    2e-3
}
fn d_max_restarts() -> u32 {
    // With no lag window a robot that stops restarts nearly every tick: 64 within 2 s
    // (0.64 s of a frozen robot at 100 Hz) tells it from a reset's few restarts.
    64
}
fn d_restart_window() -> f64 {
    2.0
}

impl SafetySettings {
    /// The actuation latency `L` (s): `latency_s`, or one period.
    pub fn latency(&self) -> f64 {
        self.latency_s.unwrap_or(self.dt)
    }
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
            latency_s: None,
            state_delay_s: 0.0,
            max_state_age_s: d_max_age(),
            tracking_tolerance: d_track(),
            tracking_window_s: 0.0,
            tracking_warning: None,
            max_restarts: d_max_restarts(),
            restart_window_s: d_restart_window(),
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
    /// No usable state (stale, missing): [`SafetyFilter::brake`] decelerated toward zero.
    Braking,
}

/// Where the position bounds of a tick start from.
#[derive(Debug, Clone, Copy)]
pub enum Anchor<'a> {
    /// The robot integrates velocity commands; `q` (rad or m) was measured at `time_s` (s,
    /// the clock of the tick). The bound covers the time since then, the latency, the
    /// commands still in flight and one period (module docs of [`super::bounds`]).
    Measured {
        /// Measured positions.
        q: &'a [f64],
        /// When they were measured (header stamp or receipt time) (s).
        time_s: f64,
    },
    /// The robot follows position commands and `q` (rad or m) is the last commanded
    /// position: no latency term, the command `q + x·Δt` itself stays inside.
    Commanded {
        /// Last commanded positions.
        q: &'a [f64],
    },
}

/// Per-tick report of the filter (no allocation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SafetyReport {
    /// What happened.
    pub status: SafetyStatus,
    /// Joints whose output sits on a bound.
    pub active: u32,
    /// Joints whose position bound lay outside the acceleration box: they brake at `a_max`.
    pub braking_saturated: u32,
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
///
/// `R` is how each joint's bounds are computed: [`ExactBounds`], the rules in the module
/// docs, unless a test breaks them on purpose (with the `fault-injection` feature,
/// `crate::faults::FilterDefect`).
pub struct SafetyFilter<R: BoundRules = ExactBounds> {
    n: usize,
    limits: Vec<JointLimits>,
    settings: SafetySettings,
    solver: DefaultSolver<f64>,
    /// The dense active-set solver tried first ([`super::active_set`]).
    active_set: ActiveSetWorkspace,
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
    history: CommandHistory,
    window: CommandWindow,
    vmax: Vec<f64>,
    rules: R,
}

impl SafetyFilter {
    /// Builds the filter for joints with `limits` (every velocity limit finite).
    pub fn new(limits: &[JointLimits], settings: SafetySettings) -> Result<Self, SafetyError> {
        Self::with_rules(limits, settings, ExactBounds)
    }
}

impl<R: BoundRules> SafetyFilter<R> {
    /// Builds the filter with the bound rules `rules` ([`SafetyFilter::new`]: the exact
    /// ones).
    pub fn with_rules(
        limits: &[JointLimits],
        settings: SafetySettings,
        rules: R,
    ) -> Result<Self, SafetyError> {
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
        if let Some(l) = settings.latency_s {
            if !(l.is_finite() && l >= 0.0) {
                return Err(bad("latency_s", format!("{l} must be finite and >= 0")));
            }
        }
        if !(settings.state_delay_s.is_finite() && settings.state_delay_s >= 0.0) {
            return Err(bad(
                "state_delay_s",
                format!("{} must be finite and >= 0", settings.state_delay_s),
            ));
        }
        if !(settings.max_state_age_s.is_finite() && settings.max_state_age_s >= 0.0) {
            return Err(bad(
                "max_state_age_s",
                format!("{} must be finite and >= 0", settings.max_state_age_s),
            ));
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
        // Commands that can matter: those issued since the oldest state the bound covers,
        // minus the latency, plus the one then in effect.
        let span =
            2.0 * settings.max_state_age_s + settings.state_delay_s + 2.0 * settings.latency();
        let capacity = (span / settings.dt).ceil().min(1e5) as usize + 4;
        Ok(Self {
            n,
            history: CommandHistory::new(n, capacity),
            window: CommandWindow::new(n),
            vmax: limits.iter().map(|l| l.velocity).collect(),
            rules,
            limits: limits.to_vec(),
            settings,
            solver,
            active_set: ActiveSetWorkspace::new(n),
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

    /// Forgets the command history: the robot is taken to have run `last` (rad/s or m/s,
    /// non-finite entries read as 0) for ever, e.g. its measured velocity at start-up.
    pub fn reset(&mut self, last: &[f64]) {
        for (l, &v) in self.last.iter_mut().zip(last) {
            *l = if v.is_finite() { v } else { 0.0 };
        }
        self.history.reset_to(&self.last);
    }

    /// Bounds of the last tick (lower, upper), rad/s or m/s.
    pub fn bounds(&self) -> (&[f64], &[f64]) {
        (&self.lo, &self.hi)
    }

    /// The acceleration step: one period (ticks are taken to be one period apart; a late
    /// tick counts in `latency_s`).
    fn since_last(&self, _now_s: f64) -> f64 {
        self.settings.dt
    }

    /// Records `out` as the command issued at `now_s` (s).
    fn commit(&mut self, now_s: f64, out: &[f64]) {
        self.last.copy_from_slice(out);
        self.history.push(now_s, out);
    }

    /// The braking command at `now_s` (s) into `out`: every joint's last command moved toward
    /// zero by at most `a_max` times the time since it (never past zero). For ticks without a
    /// usable state; the previous ticks' position bounds assumed exactly this plan.
    /// Allocation-free.
    pub fn brake(&mut self, now_s: f64, out: &mut [f64]) -> SafetyReport {
        let since = self.since_last(now_s);
        for (i, o) in out.iter_mut().enumerate().take(self.n) {
            let a = self.limits[i]
                .acceleration
                .unwrap_or(self.settings.default_acceleration);
            let u = self.last[i];
            *o = if u > 0.0 {
                (u - a * since).max(0.0)
            } else {
                (u + a * since).min(0.0)
            };
        }
        self.commit(now_s, out);
        SafetyReport {
            status: SafetyStatus::Braking,
            active: 0,
            braking_saturated: 0,
            policy_nonfinite: false,
            iterations: 0,
        }
    }

    /// Filters the policy velocity `v` at tick time `now_s` (s) into `out`, the position
    /// bounds starting from `anchor`. Allocation-free.
    ///
    /// `jac` (m × n task Jacobian) shapes `W`; `barrier` adds the distance row when the
    /// filter was built with `min_ee_distance`. `out` is always finite and inside the
    /// velocity and acceleration bounds, and inside the position bounds whenever they are
    /// reachable within the acceleration limit (else the joint brakes at `a_max`).
    pub fn filter(
        &mut self,
        now_s: f64,
        anchor: Anchor<'_>,
        v: &[f64],
        jac: Option<&DMatrix<f64>>,
        barrier: Option<Barrier<'_>>,
        out: &mut [f64],
    ) -> SafetyReport {
        let n = self.n;
        let (q, measured_at) = match anchor {
            Anchor::Measured { q, time_s } => (q, Some(time_s)),
            Anchor::Commanded { q } => (q, None),
        };
        assert!(
            q.len() == n && v.len() == n && out.len() == n,
            "safety filter: wrong dimensions"
        );
        let dt = self.settings.dt;
        let latency = self.settings.latency();
        if q.iter().any(|x| !x.is_finite()) || !now_s.is_finite() {
            // No position information: brake every joint toward zero within its acceleration limit.
            let mut report = self.brake(now_s, out);
            report.status = SafetyStatus::InvalidState;
            return report;
        }
        let mut report = SafetyReport {
            status: SafetyStatus::Filtered,
            active: 0,
            braking_saturated: 0,
            policy_nonfinite: false,
            iterations: 0,
        };
        // The horizon of this tick: since the measurement (minus its own delay), the latency.
        let (age, lat) = match measured_at {
            Some(t) => {
                let s = if t.is_finite() { t.min(now_s) } else { now_s };
                let s = s - self.settings.state_delay_s;
                self.history
                    .window(s, now_s, latency, &self.vmax, &mut self.window);
                (now_s - s, latency)
            }
            None => (0.0, 0.0),
        };
        let since = self.rules.since(self.since_last(now_s), dt);
        for i in 0..n {
            let h = match measured_at {
                Some(_) if self.rules.horizon_applies() => Horizon {
                    age,
                    latency: lat,
                    past_max: self.window.past_max[i],
                    past_min: self.window.past_min[i],
                    recent_max: self.window.recent_max[i],
                    recent_min: self.window.recent_min[i],
                },
                _ => Horizon::NOW,
            };
            let mut lim = self.limits[i];
            if !self.rules.position_bound() {
                (lim.lower, lim.upper) = (f64::NEG_INFINITY, f64::INFINITY);
            }
            let b = joint_bounds(
                &lim,
                self.settings.default_acceleration,
                self.settings.margin,
                q[i],
                self.last[i],
                dt,
                since,
                &h,
            );
            self.lo[i] = b.lo;
            self.hi[i] = b.hi;
            report.braking_saturated += u32::from(b.braking_saturated);
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
            self.commit(now_s, out);
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
            // The active-set solver first: an exact KKT point of this small dense QP in a
            // few µs; anything it does not cover goes to Clarabel below.
            let row = barrier.map(|b| (b.gradient, -gamma * b.value));
            let fast = active_set::solve(
                self.w.as_slice(),
                &self.v,
                &self.lo,
                &self.hi,
                row,
                out,
                &mut self.active_set,
            );
            if let ActiveSetStatus::Solved { iterations } = fast {
                for i in 0..n {
                    out[i] = out[i].clamp(self.lo[i], self.hi[i]);
                }
                // Checked, not trusted: finite, and the barrier row held (the box holds by
                // the clamp); otherwise Clarabel decides.
                let finite = out.iter().all(|x| x.is_finite());
                let row_ok = barrier.is_none_or(|b| {
                    let ax: f64 = b.gradient.iter().zip(out.iter()).map(|(g, x)| g * x).sum();
                    let scale = b.gradient.iter().fold(1.0f64, |m, g| m.max(g.abs()));
                    ax >= -gamma * b.value - 1e-9 * scale
                });
                if finite && row_ok {
                    report.iterations = iterations;
                    return self.finish(now_s, out, report);
                }
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
        self.finish(now_s, out, report)
    }

    /// Counts the joints on a bound, records the command and returns the report.
    fn finish(&mut self, now_s: f64, out: &[f64], mut report: SafetyReport) -> SafetyReport {
        let n = self.n;
        report.active = (0..n)
            .filter(|&i| {
                (out[i] - self.lo[i]).abs() <= 1e-12 || (out[i] - self.hi[i]).abs() <= 1e-12
            })
            .count() as u32;
        self.commit(now_s, out);
        report
    }

    fn clamp_into(&self, out: &mut [f64]) {
        for i in 0..self.n {
            out[i] = self.v[i].clamp(self.lo[i], self.hi[i]);
        }
    }
}
