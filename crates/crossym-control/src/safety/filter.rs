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

use nalgebra::DMatrix;

use super::active_set::{self, ActiveSetStatus, ActiveSetWorkspace};
use super::bounds::{joint_bounds, Horizon};
use super::history::{CommandHistory, CommandWindow};
use super::qp::ClarabelQp;
use super::rules::{BoundRules, ExactBounds};
pub use super::settings::{SafetyError, SafetySettings};
use crossym_math::kinematics::JointLimits;

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
    /// Clarabel, set up once: where the active-set solver declines.
    qp: ClarabelQp,
    /// QPs handed to Clarabel since setup.
    clarabel_solves: u64,
    /// The dense active-set solver tried first ([`super::active_set`]).
    active_set: ActiveSetWorkspace,
    barrier_rows: usize,
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
        settings.validate()?;
        if let Some(i) = limits
            .iter()
            .position(|l| !(l.velocity.is_finite() && l.velocity > 0.0))
        {
            return Err(SafetyError::NoVelocityLimit { index: i });
        }
        let n = limits.len();
        let br = usize::from(settings.min_ee_distance.is_some());
        let qp = ClarabelQp::new(n, br == 1, settings.max_iter)?;
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
            qp,
            clarabel_solves: 0,
            active_set: ActiveSetWorkspace::new(n),
            barrier_rows: br,
            w: DMatrix::zeros(n, n),
            lo: vec![0.0; n],
            hi: vec![0.0; n],
            v: vec![0.0; n],
            last: vec![0.0; n],
        })
    }

    /// QPs the active-set solver declined and Clarabel solved since setup (count): how often
    /// a tick takes the slower path.
    pub fn clarabel_solves(&self) -> u64 {
        self.clarabel_solves
    }

    /// Sets the margin kept inside the position limits from the next tick on (the caller
    /// checks it: [`crate::node::RuntimeBounds`]); allocation-free.
    pub fn set_margin(&mut self, margin: f64) {
        self.settings.margin = margin;
    }

    /// Sets the largest joint-state age the bounds cover, at most the one the filter was
    /// built with (its history is sized for that); a larger value is capped.
    pub fn set_max_state_age(&mut self, s: f64, built_with: f64) {
        self.settings.max_state_age_s = s.min(built_with);
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
        self.tick_bounds(now_s, q, measured_at, v, &mut report);
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
            self.solve_weighted(jac, barrier, out, &mut report);
        }
        self.finish(now_s, out, report)
    }

    /// The weighted QP (`W` from the task Jacobian `jac`, the distance row `barrier`) into
    /// `out`: the active-set solver first (an exact KKT point of this small dense QP in a
    /// few µs), Clarabel for what it does not cover, the clamp if Clarabel fails.
    fn solve_weighted(
        &mut self,
        jac: Option<&DMatrix<f64>>,
        barrier: Option<Barrier<'_>>,
        out: &mut [f64],
        report: &mut SafetyReport,
    ) {
        self.weight(jac);
        if let Some(iterations) = self.try_active_set(barrier, out) {
            report.iterations = iterations;
            return;
        }
        let row = barrier.map(|b| (b.gradient, b.value));
        self.clarabel_solves += 1;
        let gamma = self.settings.barrier_gain;
        let solved = self
            .qp
            .solve(&self.w, &self.v, &self.lo, &self.hi, row, gamma);
        report.iterations = self.qp.iterations();
        if solved {
            let x = self.qp.solution();
            for i in 0..self.n {
                out[i] = x[i].clamp(self.lo[i], self.hi[i]);
            }
        } else {
            self.clamp_into(out);
            report.status = SafetyStatus::Fallback;
        }
    }

    /// This tick's bounds `lo`, `hi` per joint (the horizon since the measurement at
    /// `measured_at`, minus its own delay, and the latency; none for a commanded anchor)
    /// and the policy velocity `v` with non-finite entries replaced by 0 (into `self.v`).
    fn tick_bounds(
        &mut self,
        now_s: f64,
        q: &[f64],
        measured_at: Option<f64>,
        v: &[f64],
        report: &mut SafetyReport,
    ) {
        let n = self.n;
        let dt = self.settings.dt;
        let latency = self.settings.latency();
        // The horizon of this tick.
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
    }

    /// `W = JᵀJ + ε tr(JᵀJ)/n I` from the task Jacobian `jac`, or `I` without one, into
    /// `self.w`.
    fn weight(&mut self, jac: Option<&DMatrix<f64>>) {
        let n = self.n;
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
    }

    /// The active-set solution into `out`, clamped to the bounds, when it solved and the
    /// check passed (finite, the barrier row held: the box holds by the clamp); its
    /// iterations. `None`: Clarabel decides.
    fn try_active_set(&mut self, barrier: Option<Barrier<'_>>, out: &mut [f64]) -> Option<u32> {
        let gamma = self.settings.barrier_gain;
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
        let ActiveSetStatus::Solved { iterations } = fast else {
            return None;
        };
        for i in 0..self.n {
            out[i] = out[i].clamp(self.lo[i], self.hi[i]);
        }
        let finite = out.iter().all(|x| x.is_finite());
        let row_ok = barrier.is_none_or(|b| {
            let ax: f64 = b.gradient.iter().zip(out.iter()).map(|(g, x)| g * x).sum();
            let scale = b.gradient.iter().fold(1.0f64, |m, g| m.max(g.abs()));
            ax >= -gamma * b.value - 1e-9 * scale
        });
        (finite && row_ok).then_some(iterations)
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
