//! Endurance: the node core in a long closed loop with a kinematic robot, no DDS, faster
//! than real time — what a redundant arm does over minutes of work under changing
//! conditions (issue 37).
//!
//! Every period `Δt` the robot's joint state (stamped with simulated time) enters the core,
//! the core ticks, and the robot executes the command exactly (velocity mode
//! `q ← q + Δt·v`, position modes `q ← q_cmd`). Every `condition_period_s` the next
//! condition of a cyclic schedule is sent; the arms work on from where they are (no reset),
//! so whatever the joints drift through accumulates.
//!
//! Measured per tick: the smallest distance of any joint to a position limit as a fraction
//! of its range, whether a joint's command sat on a bound (the safety filter's
//! `active_constraints`), any joint outside its limits, the status code, and the
//! **posture drift** `‖N (q − r)‖` — the part of the distance to the rest posture `r` the
//! task cannot see, `N = I − J⁺J` (the null-space coordinates' distance from rest).

use crossym_control::{NodeCore, OutputMode, StatusCode, TickReport};
use crossym_io::msg;
use crossym_math::kinematics::{
    DampedPinv, JointLimits, Kinematics, KinematicsWorkspace, PinvStatus,
};
use crossym_math::symmetry::compose::Condition;
use nalgebra::DMatrix;

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct EnduranceSettings {
    /// Simulated time (s).
    pub duration_s: f64,
    /// A new condition every this many seconds (s).
    pub condition_period_s: f64,
    /// The conditions, sent in turn (cyclic).
    pub conditions: Vec<Condition>,
    /// The rest posture the drift is measured from (rad or m).
    pub rest: Vec<f64>,
}

/// What happened.
#[derive(Debug, Clone, PartialEq)]
pub struct EnduranceReport {
    /// Ticks run.
    pub ticks: u64,
    /// Ticks with at least one joint's command on a bound.
    pub bound_ticks: u64,
    /// Ticks whose status was not `NoWarning` / `JointBound` (stale, infeasible, …).
    pub other_status_ticks: u64,
    /// Those ticks by status code.
    pub other_status: std::collections::BTreeMap<String, u64>,
    /// Ticks with a joint outside its position limits.
    pub violation_ticks: u64,
    /// Conditions sent and accepted.
    pub conditions_accepted: u64,
    /// Conditions sent and rejected.
    pub conditions_rejected: u64,
    /// Why the last rejected condition was rejected.
    pub last_rejection: Option<String>,
    /// Smallest distance of any joint to a position limit over the run, as a fraction of its
    /// range (0.5: mid-range; 0: on the limit).
    pub min_margin: f64,
    /// The joint where it was (name).
    pub min_margin_joint: String,
    /// Largest posture drift `‖N (q − r)‖` over the run (rad).
    pub max_drift: f64,
    /// Posture drift at the end (rad).
    pub final_drift: f64,
    /// Posture drift averaged over each tenth of the run (rad): unbounded drift grows here.
    pub drift_by_tenth: Vec<f64>,
    /// Largest `|qⱼ − rⱼ|` over the run, per joint (rad or m).
    pub max_excursion: Vec<f64>,
    /// Largest condition number of a chain's task Jacobian over the run (the singularity
    /// band's measure).
    pub max_condition: f64,
}

impl EnduranceReport {
    /// Share of ticks with a joint on a bound.
    pub fn bound_share(&self) -> f64 {
        self.bound_ticks as f64 / self.ticks.max(1) as f64
    }
}

impl std::fmt::Display for EnduranceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} ticks: on a bound {:.2} %, other status {} {:?}, outside limits {}; conditions {} accepted, {} rejected{}; min limit margin {:.1} % of range ({}); posture drift max {:.3} rad, final {:.3} rad, by tenth [{}]; largest |q − rest| per joint [{}]; largest condition number {:.1}",
            self.ticks,
            100.0 * self.bound_share(),
            self.other_status_ticks,
            self.other_status,
            self.violation_ticks,
            self.conditions_accepted,
            self.conditions_rejected,
            self.last_rejection
                .as_ref()
                .map_or(String::new(), |e| format!(" (last: {e})")),
            100.0 * self.min_margin,
            self.min_margin_joint,
            self.max_drift,
            self.final_drift,
            self.drift_by_tenth
                .iter()
                .map(|d| format!("{d:.3}"))
                .collect::<Vec<_>>()
                .join(", "),
            self.max_excursion
                .iter()
                .map(|d| format!("{d:.2}"))
                .collect::<Vec<_>>()
                .join(", "),
            self.max_condition
        )
    }
}

/// Runs `core` from `start` (allocates; not a real-time path).
pub fn run(core: &mut NodeCore, start: &[f64], settings: &EnduranceSettings) -> EnduranceReport {
    let names = core.joint_names().to_vec();
    let limits = core.limits().to_vec();
    let (n, dt) = (core.kinematics().dof(), core.config().period_s);
    let mode = core.config().output;
    let mut probe = DriftProbe::new(core.kinematics().clone());
    let mut q = start.to_vec();
    let mut cmd = core.command();
    let ticks = (settings.duration_s / dt).round() as u64;
    let per_condition = ((settings.condition_period_s / dt).round() as u64).max(1);
    let mut r = EnduranceReport::empty(n);
    let mut tenth_count = [0u64; 10];
    for k in 0..ticks {
        let t = k as f64 * dt;
        if k % per_condition == 0 && !settings.conditions.is_empty() {
            let s = settings.conditions[(k / per_condition) as usize % settings.conditions.len()];
            r.send_condition(core, s);
        }
        // The robot's own state is always well-formed: a rejection would be a bug here.
        if core.on_joint_state(&joint_state(&names, &q, t), t).is_err() {
            r.other_status_ticks += 1;
        }
        let rep = core.tick(t, &mut cmd);
        r.count_tick(&rep, core.singularity().condition);
        if rep.publish {
            match mode {
                OutputMode::Velocity => {
                    for (x, v) in q.iter_mut().zip(&cmd.velocities) {
                        *x += dt * v;
                    }
                }
                _ => q.copy_from_slice(&cmd.positions),
            }
        }
        r.measure_posture(&q, &limits, &names, &settings.rest);
        let drift = probe.drift(&q, &settings.rest);
        if drift.is_finite() {
            r.max_drift = r.max_drift.max(drift);
            r.final_drift = drift;
            let tenth = ((10 * k) / ticks.max(1)) as usize;
            r.drift_by_tenth[tenth] += drift;
            tenth_count[tenth] += 1;
        }
    }
    for (d, c) in r.drift_by_tenth.iter_mut().zip(tenth_count) {
        *d /= c.max(1) as f64;
    }
    r
}

/// The robot's joint state `q` at simulated time `t`.
fn joint_state(names: &[String], q: &[f64], t: f64) -> msg::JointState {
    msg::JointState {
        header: msg::Header {
            stamp: msg::Time::from_secs_f64(t),
            frame_id: String::new(),
        },
        name: names.to_vec(),
        position: q.to_vec(),
        velocity: Vec::new(),
        effort: Vec::new(),
    }
}

impl EnduranceReport {
    /// The report of a run not started, for `n` joints.
    fn empty(n: usize) -> Self {
        Self {
            ticks: 0,
            bound_ticks: 0,
            other_status_ticks: 0,
            other_status: Default::default(),
            violation_ticks: 0,
            conditions_accepted: 0,
            conditions_rejected: 0,
            last_rejection: None,
            min_margin: f64::INFINITY,
            min_margin_joint: String::new(),
            max_drift: 0.0,
            final_drift: 0.0,
            drift_by_tenth: vec![0.0; 10],
            max_excursion: vec![0.0; n],
            max_condition: 1.0,
        }
    }

    /// Sends condition `s` to `core`, counting it accepted or rejected.
    fn send_condition(&mut self, core: &mut NodeCore, s: Condition) {
        let m = msg::SymmetryCondition {
            theta: s.theta,
            scale: s.scale,
            reflection: s.reflection,
            ..Default::default()
        };
        match core.on_condition(&m) {
            Ok(()) => self.conditions_accepted += 1,
            Err(e) => {
                self.conditions_rejected += 1;
                self.last_rejection = Some(format!("{e:?}"));
            }
        }
    }

    /// Counts a tick: its condition number `kappa`, its status, a joint on a bound.
    fn count_tick(&mut self, rep: &TickReport, kappa: f64) {
        self.ticks += 1;
        if kappa.is_finite() || kappa == f64::INFINITY {
            self.max_condition = self.max_condition.max(kappa);
        }
        match rep.code {
            StatusCode::NoWarning | StatusCode::JointBound => {}
            code => {
                self.other_status_ticks += 1;
                *self.other_status.entry(format!("{code:?}")).or_default() += 1;
            }
        }
        if rep.active_constraints > 0 {
            self.bound_ticks += 1;
        }
    }

    /// The posture `q` after the robot moved: margins to the limits, a joint outside them,
    /// the excursions from `rest`.
    fn measure_posture(
        &mut self,
        q: &[f64],
        limits: &[JointLimits],
        names: &[String],
        rest: &[f64],
    ) {
        let mut outside = false;
        for (j, (x, l)) in q.iter().zip(limits).enumerate() {
            if !(l.lower.is_finite() && l.upper.is_finite()) {
                continue;
            }
            let margin = (x - l.lower).min(l.upper - x) / (l.upper - l.lower);
            outside |= margin < 0.0;
            if margin < self.min_margin {
                self.min_margin = margin;
                self.min_margin_joint.clone_from(&names[j]);
            }
        }
        if outside {
            self.violation_ticks += 1;
        }
        for ((e, x), rest) in self.max_excursion.iter_mut().zip(q).zip(rest) {
            *e = e.max((x - rest).abs());
        }
    }
}

/// The posture drift `‖(I − J⁺J)(q − r)‖` with the robot's pseudo-inverse, and the
/// workspaces it is computed in.
struct DriftProbe {
    kin: Kinematics,
    kws: KinematicsWorkspace,
    jp: DMatrix<f64>,
    nq: DMatrix<f64>,
}

impl DriftProbe {
    fn new(kin: Kinematics) -> Self {
        let n = kin.dof();
        Self {
            kws: kin.workspace(),
            jp: DMatrix::<f64>::zeros(n, kin.task_dim()),
            nq: DMatrix::<f64>::zeros(n, n),
            kin,
        }
    }

    /// The drift of `q` from `rest` (NaN where the Jacobian is singular).
    fn drift(&mut self, q: &[f64], rest: &[f64]) -> f64 {
        let kin = &self.kin;
        kin.jacobian(q, &mut self.kws);
        if kin.factor(&mut self.kws).status == PinvStatus::Singular {
            f64::NAN
        } else {
            kin.pinv().matrix(&mut self.kws.pinv, &mut self.jp);
            DampedPinv::nullspace_projector(&self.kws.jac, &self.jp, &mut self.nq);
            let d =
                nalgebra::DVector::from_iterator(kin.dof(), q.iter().zip(rest).map(|(a, b)| a - b));
            (&self.nq * d).norm()
        }
    }
}
