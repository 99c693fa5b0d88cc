//! The letter-drawing task of the paper's simulated experiment (Sec. VI-A): LASA letters
//! placed in the planar dual arm's workspace and tracked into joint-space demonstrations.
//!
//! Protocol (from the authors' public code, so that RMSE is in the paper's units):
//! 1. each letter's demonstrations are min/max-normalised per coordinate, jointly over all
//!    demonstrations, to `[−r, r]` (`r = 1.5`);
//! 2. shifted by `f_arm(q0) − o` (`o = (5, −1.5)` left, `(5, 1.5)` right; `q0` the rest
//!    posture: left `[π/4, −π/6, −π/8, −π/10]`, right `−q0_left`);
//! 3. the first 10 and last 2 samples are dropped;
//! 4. starting from `q0`, each remaining sample is tracked by one damped-least-squares step
//!    `Δq = Jᵀ(J Jᵀ + μ I)⁻¹ (x_target − f(q))` (`μ = 10⁻³`, full step, one sample = 0.01 s);
//! 5. the first 10 and the last sample of the joint trajectory are dropped and `q̇` is the
//!    forward difference over `dt`.
//!
//! Demonstration `k` of every arm's letter forms dual-arm demonstration `k`. Everything is
//! configuration (`[letters]`), so other letters, placements and robots use the same path:
//! on `xyz` chains (RB-Y1, Sec. VI-B) the letter is drawn in a plane `centre + a u + b v`,
//! and an arm may instead follow synthetic minimum-jerk reaches (the pan-grasping task) or
//! hold its rest posture.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::lasa::LetterSet;
use super::DataError;
use crossym_math::kinematics::{
    DampedPinv, Kinematics, KinematicsWorkspace, Metric, PinvWorkspace,
};
use crossym_policy::JointTrajectory;

/// One arm's demonstrations: a LASA letter placed in the task space, synthetic reaching
/// motions, or neither (the arm holds its rest posture).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmLetter {
    /// Chain name (from `[[robot.chains]]`).
    pub chain: String,
    /// LASA file (`.csv` or `.mat`), relative to the config file's directory.
    #[serde(default)]
    pub letter: Option<PathBuf>,
    /// Synthetic reaching demonstrations (one per entry), instead of a letter.
    #[serde(default)]
    pub reach: Vec<Reach>,
    /// Rest posture of this chain's joints (rad).
    pub rest: Vec<f64>,
    /// Offset `o`: the letter box's centre is placed at `f(q0) − o` (task units).
    #[serde(default)]
    pub offset: Option<Vec<f64>>,
    /// The letter box's centre in the chain's task frame (task units), instead of `offset`.
    #[serde(default)]
    pub center: Option<Vec<f64>>,
    /// In-plane unit axes `(u, v)` of the drawing plane for `xyz` chains (task frame): the
    /// letter point `(a, b)` goes to `centre + a u + b v`. Planar chains use `x, y`.
    #[serde(default)]
    pub plane: Option<[[f64; 3]; 2]>,
}

/// A synthetic reaching motion in the chain's task frame: minimum-jerk segments from
/// `f(q0)` through the `via` points to `goal`, timed in proportion to segment length.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Reach {
    /// Final position (task units, task frame).
    pub goal: Vec<f64>,
    /// Intermediate positions passed through at rest (task units).
    #[serde(default)]
    pub via: Vec<Vec<f64>>,
    /// Duration of the motion (s).
    pub duration_s: f64,
    /// Start posture of this chain's joints for this demonstration (rad); absent → the
    /// arm's `rest`. Demonstrations from one start must agree, or a policy `π(q, s)`
    /// cannot tell them apart.
    #[serde(default)]
    pub start: Option<Vec<f64>>,
}

impl Reach {
    /// The sampled path (`duration_s / dt + 1` points) starting at `start`.
    fn sample(&self, start: &[f64], dt: f64) -> Result<Vec<Vec<f64>>, String> {
        let d = start.len();
        let mut pts: Vec<&[f64]> = vec![start];
        pts.extend(self.via.iter().map(|v| v.as_slice()));
        pts.push(&self.goal);
        if pts
            .iter()
            .any(|p| p.len() != d || p.iter().any(|v| !v.is_finite()))
        {
            return Err(format!("reach points must be finite and {d}-dimensional"));
        }
        if !(self.duration_s.is_finite() && self.duration_s > 0.0) {
            return Err(format!(
                "reach duration_s {} must be positive",
                self.duration_s
            ));
        }
        let dist = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y) * (x - y))
                .sum::<f64>()
                .sqrt()
        };
        let lens: Vec<f64> = pts.windows(2).map(|w| dist(w[0], w[1])).collect();
        let total: f64 = lens.iter().sum();
        if total <= 0.0 {
            return Err("reach has zero length".into());
        }
        let samples = (self.duration_s / dt).round() as usize + 1;
        let mut out = Vec::with_capacity(samples);
        for i in 0..samples {
            // Arc length reached at time t, then the segment and its min-jerk phase.
            let t = i as f64 / (samples - 1) as f64 * total;
            let (mut k, mut acc) = (0, 0.0);
            while k + 1 < lens.len() && acc + lens[k] < t {
                acc += lens[k];
                k += 1;
            }
            let tau = if lens[k] > 0.0 {
                ((t - acc) / lens[k]).clamp(0.0, 1.0)
            } else {
                1.0
            };
            let s = tau * tau * tau * (10.0 - 15.0 * tau + 6.0 * tau * tau);
            out.push(
                (0..d)
                    .map(|c| pts[k][c] + s * (pts[k + 1][c] - pts[k][c]))
                    .collect(),
            );
        }
        Ok(out)
    }
}

fn d_range() -> f64 {
    1.5
}
fn d_mu() -> f64 {
    1e-3
}
fn d_dt() -> f64 {
    0.01
}
fn d_train() -> Vec<usize> {
    vec![1, 2, 3, 4, 5]
}
fn d_test() -> Vec<usize> {
    vec![6, 7]
}
fn d_drop() -> [usize; 4] {
    [10, 2, 10, 1]
}

/// `[letters]`: the letter task's placement and tracking protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LetterTaskConfig {
    /// One entry per chain, in the robot's chain order.
    pub arms: Vec<ArmLetter>,
    /// Half-width `r` of the normalised letter box (task units).
    #[serde(default = "d_range")]
    pub half_range: f64,
    /// Damping `μ` added to `J Jᵀ` in the tracking step.
    #[serde(default = "d_mu")]
    pub tracking_damping: f64,
    /// Sample period (s).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// Samples dropped: task start, task end, joint start, joint end.
    #[serde(default = "d_drop")]
    pub drop: [usize; 4],
    /// 1-based demonstration numbers used for training.
    #[serde(default = "d_train")]
    pub train: Vec<usize>,
    /// 1-based demonstration numbers used for testing.
    #[serde(default = "d_test")]
    pub test: Vec<usize>,
    /// Damped-least-squares iterations from the rest posture towards the first target
    /// before tracking starts (0 in the paper's protocol).
    #[serde(default)]
    pub settle_iterations: usize,
}

/// The tracked demonstrations of a letter task and how well they were tracked.
#[derive(Debug, Clone)]
pub struct LetterDemos {
    /// All demonstrations, in demo order.
    pub demos: Vec<JointTrajectory>,
    /// Max `‖f(q_i) − x_i‖` over the kept samples (task units).
    pub max_tracking_error: f64,
    /// Training demo numbers.
    pub train: Vec<usize>,
    /// Test demo numbers.
    pub test: Vec<usize>,
}

impl LetterDemos {
    /// The demonstrations with the given numbers.
    pub fn select(&self, which: &[usize]) -> Vec<&JointTrajectory> {
        self.demos
            .iter()
            .filter(|d| which.contains(&d.demo))
            .collect()
    }
}

/// Centre of the arm's letter box and its in-plane axes, checked finite and of dimension `p0.len()`.
fn letter_frame(arm: &ArmLetter, p0: &[f64]) -> Result<(Vec<f64>, [Vec<f64>; 2]), DataError> {
    let d = p0.len();
    let name = &arm.chain;
    // Centre of the letter box and in-plane axes.
    let centre: Vec<f64> = match (&arm.center, &arm.offset) {
        (Some(c), None) => c.clone(),
        (None, Some(o)) if o.len() == d => p0.iter().zip(o).map(|(p, o)| p - o).collect(),
        (None, Some(o)) => {
            return Err(invalid(format!(
                "[letters] arm `{name}`: offset has {} values, the task {d}",
                o.len()
            )))
        }
        _ => {
            return Err(invalid(format!(
                "[letters] arm `{name}`: give exactly one of `offset` and `center`"
            )))
        }
    };
    let axes: [Vec<f64>; 2] = match (d, &arm.plane) {
        (2, None) => [vec![1.0, 0.0], vec![0.0, 1.0]],
        (3, Some([u, v])) => [u.to_vec(), v.to_vec()],
        _ => {
            return Err(invalid(format!(
                "[letters] arm `{name}`: a letter needs an xy chain, or an xyz chain \
                 with `plane = [u, v]`"
            )))
        }
    };
    if centre.len() != d
        || centre
            .iter()
            .chain(&axes[0])
            .chain(&axes[1])
            .any(|v| !v.is_finite())
    {
        return Err(invalid(format!(
            "[letters] arm `{name}`: centre/offset/plane must be finite and {d}-dimensional"
        )));
    }
    Ok((centre, axes))
}

/// Joint min/max per coordinate over all demonstrations of the letter loaded from `path`.
fn letter_extent(set: &LetterSet, path: &Path) -> Result<([f64; 2], [f64; 2]), DataError> {
    // Joint min/max per coordinate over all demonstrations.
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for demo in &set.demos {
        for p in &demo.pos {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    }
    if (0..2).any(|k| hi[k] <= lo[k] || hi[k].is_nan() || lo[k].is_nan()) {
        return Err(invalid(format!("{}: letter has no extent", path.display())));
    }
    Ok((lo, hi))
}

fn invalid(what: impl Into<String>) -> DataError {
    DataError::Invalid {
        message: what.into(),
    }
}

impl LetterTaskConfig {
    /// One arm's task paths (one per demonstration, samples of `d` coordinates) before the
    /// sample drops: the placed letter, the sampled reaches, or none.
    fn arm_paths(
        &self,
        arm: &ArmLetter,
        chain: &crossym_math::kinematics::Chain,
        p0: &[f64],
        base_dir: &Path,
    ) -> Result<Vec<Vec<Vec<f64>>>, DataError> {
        let d = p0.len();
        if !arm.reach.is_empty() {
            return self.reach_paths(arm, chain, p0);
        }
        let Some(letter) = &arm.letter else {
            return Ok(Vec::new());
        };
        let (centre, axes) = letter_frame(arm, p0)?;
        let path = if letter.is_absolute() {
            letter.clone()
        } else {
            base_dir.join(letter)
        };
        let set = LetterSet::load(&path)?;
        let (lo, hi) = letter_extent(&set, &path)?;
        let r = self.half_range;
        Ok(set
            .demos
            .iter()
            .map(|demo| {
                demo.pos
                    .iter()
                    .map(|p| {
                        let a = -r + 2.0 * r * (p[0] - lo[0]) / (hi[0] - lo[0]);
                        let b = -r + 2.0 * r * (p[1] - lo[1]) / (hi[1] - lo[1]);
                        (0..d)
                            .map(|c| centre[c] + a * axes[0][c] + b * axes[1][c])
                            .collect()
                    })
                    .collect()
            })
            .collect())
    }

    /// The arm's sampled reaches, each from `p0` or from its own start configuration.
    fn reach_paths(
        &self,
        arm: &ArmLetter,
        chain: &crossym_math::kinematics::Chain,
        p0: &[f64],
    ) -> Result<Vec<Vec<Vec<f64>>>, DataError> {
        let d = p0.len();
        let name = &arm.chain;
        if arm.letter.is_some() {
            return Err(invalid(format!(
                "[letters] arm `{name}`: give either `letter` or `reach`, not both"
            )));
        }
        arm.reach
            .iter()
            .map(|r| match &r.start {
                None => r.sample(p0, self.dt),
                Some(q) if q.len() == chain.dof() && q.iter().all(|v| v.is_finite()) => {
                    let mut ws = chain.workspace();
                    let p = chain.position(q, &mut ws);
                    r.sample(&[p.x, p.y, p.z][..d], self.dt)
                }
                Some(q) => Err(format!(
                    "reach start needs {} finite joint values, got {:?}",
                    chain.dof(),
                    q
                )),
            })
            .collect::<Result<_, _>>()
            .map_err(|e| invalid(format!("[letters] arm `{name}`: {e}")))
    }

    /// Loads the letters (paths relative to `base_dir`) and tracks them with `kin`.
    pub fn build(&self, kin: &Kinematics, base_dir: &Path) -> Result<LetterDemos, DataError> {
        let chains = kin.chains();
        self.check_settings(chains.len())?;
        let (n, m) = (kin.dof(), kin.task_dim());
        let mut rest = vec![0.0; n];
        let mut targets: Vec<Vec<Vec<f64>>> = Vec::new(); // [demo][sample][m]
        let mut counts: Option<usize> = None;
        let mut rest_x: Vec<(usize, Vec<f64>)> = Vec::new();
        // Per-demonstration start postures: (demo index, first joint, joint values).
        let mut starts: Vec<(usize, usize, Vec<f64>)> = Vec::new();
        for (ci, (arm, chain)) in self.arms.iter().zip(chains).enumerate() {
            check_arm(ci, arm, chain)?;
            let d = chain.task.dim();
            rest[kin.q_offset(ci)..kin.q_offset(ci) + chain.dof()].copy_from_slice(&arm.rest);
            let mut ws = chain.workspace();
            let p0: Vec<f64> = {
                let p = chain.position(&arm.rest, &mut ws);
                [p.x, p.y, p.z][..d].to_vec()
            };
            let xo = kin.x_offset(ci);
            let arm_paths = self.arm_paths(arm, chain, &p0, base_dir)?;
            for (k, r) in arm.reach.iter().enumerate() {
                if let Some(q) = &r.start {
                    starts.push((k, kin.q_offset(ci), q.clone()));
                }
            }
            let columns = TaskColumns { xo, d, m };
            self.add_targets(arm, &arm_paths, columns, &mut targets, &mut counts)?;
            rest_x.push((xo, p0));
        }
        if targets.is_empty() {
            return Err(invalid("[letters] no arm has a letter or reach"));
        }
        // Arms without demonstrations hold their rest position.
        for t in &mut targets {
            for sample in t.iter_mut() {
                for (xo, p0) in &rest_x {
                    if sample[*xo].is_nan() {
                        sample[*xo..*xo + p0.len()].copy_from_slice(p0);
                    }
                }
            }
        }
        if !kin.within_limits(&rest) {
            return Err(invalid(
                "[letters] rest posture is outside the joint limits",
            ));
        }
        let [_, _, js, je] = self.drop;
        let tracking = Tracking {
            damping: self.tracking_damping,
            settle_iterations: self.settle_iterations,
            drop_joint: [js, je],
            dt: self.dt,
        };
        let (demos, max_err) = track(kin, &rest, &starts, &targets, &tracking)?;
        for &d in self.train.iter().chain(&self.test) {
            if d == 0 || d > demos.len() {
                return Err(invalid(format!(
                    "[letters] demo number {d} not in 1..={}",
                    demos.len()
                )));
            }
        }
        Ok(LetterDemos {
            demos,
            max_tracking_error: max_err,
            train: self.train.clone(),
            test: self.test.clone(),
        })
    }

    /// Checks the arm count against the robot's `chains` and the numeric settings.
    fn check_settings(&self, chains: usize) -> Result<(), DataError> {
        if self.arms.len() != chains {
            return Err(invalid(format!(
                "[letters] has {} arms, the robot has {} chains",
                self.arms.len(),
                chains
            )));
        }
        if !(self.half_range.is_finite()
            && self.half_range > 0.0
            && self.dt.is_finite()
            && self.dt > 0.0)
        {
            return Err(invalid("[letters] half_range and dt must be positive"));
        }
        if !(self.tracking_damping.is_finite() && self.tracking_damping >= 0.0) {
            return Err(invalid("[letters] tracking_damping must be non-negative"));
        }
        Ok(())
    }

    /// Writes the kept samples of `arm`'s task paths (after `drop`) into its `columns` of
    /// `targets` (`[demo][sample][m]`, NaN where unset); every arm with demonstrations must
    /// agree on their number (`counts`) and lengths.
    fn add_targets(
        &self,
        arm: &ArmLetter,
        arm_paths: &[Vec<Vec<f64>>],
        columns: TaskColumns,
        targets: &mut Vec<Vec<Vec<f64>>>,
        counts: &mut Option<usize>,
    ) -> Result<(), DataError> {
        let TaskColumns { xo, d, m } = columns;
        let [ds, de, _, _] = self.drop;
        // Every arm with demonstrations must agree on their number and lengths.
        if !arm_paths.is_empty() {
            if counts.is_some_and(|c| c != arm_paths.len()) {
                return Err(invalid(format!(
                    "[letters] arm `{}` has {} demonstrations, another arm {}",
                    arm.chain,
                    arm_paths.len(),
                    counts.unwrap_or(0)
                )));
            }
            *counts = Some(arm_paths.len());
        }
        for (k, path) in arm_paths.iter().enumerate() {
            if path.len() <= ds + de + 1 {
                return Err(invalid(format!(
                    "[letters] arm `{}`: demo {} too short",
                    arm.chain,
                    k + 1
                )));
            }
            if targets.len() <= k {
                targets.push(Vec::new());
            }
            let kept = &path[ds..path.len() - de];
            let t = &mut targets[k];
            if t.is_empty() {
                t.resize(kept.len(), vec![f64::NAN; m]);
            } else if t.len() != kept.len() {
                return Err(invalid(format!(
                    "demo {}: arms' demonstrations have different lengths",
                    k + 1
                )));
            }
            for (s, p) in kept.iter().enumerate() {
                t[s][xo..xo + d].copy_from_slice(p);
            }
        }
        Ok(())
    }
}

/// Where one arm's task point sits in the stacked task vector: offset `xo`, dimension `d`,
/// of `m` task coordinates in all.
#[derive(Clone, Copy)]
struct TaskColumns {
    xo: usize,
    d: usize,
    m: usize,
}

/// Checks that arm `ci` names `chain` and has a finite rest posture of the chain's size.
fn check_arm(
    ci: usize,
    arm: &ArmLetter,
    chain: &crossym_math::kinematics::Chain,
) -> Result<(), DataError> {
    if arm.chain != chain.name {
        return Err(invalid(format!(
            "[letters] arm {ci} names chain `{}`, expected `{}` (chain order)",
            arm.chain, chain.name
        )));
    }
    if arm.rest.len() != chain.dof() {
        return Err(invalid(format!(
            "[letters] arm `{}`: needs {} rest values, got {}",
            arm.chain,
            chain.dof(),
            arm.rest.len()
        )));
    }
    if arm.rest.iter().any(|v| !v.is_finite()) {
        return Err(invalid(format!(
            "[letters] arm `{}`: rest must be finite",
            arm.chain
        )));
    }
    Ok(())
}

/// How task-space targets are tracked into joint space (`[letters]` / task sources).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Tracking {
    /// Damping `μ` added to `J Jᵀ`.
    pub damping: f64,
    /// Damped-least-squares iterations towards the first target before tracking.
    pub settle_iterations: usize,
    /// Joint samples dropped at the start and at the end (the end ≥ 1: forward difference).
    pub drop_joint: [usize; 2],
    /// Sample period (s).
    pub dt: f64,
}

/// Tracks `targets[demo][sample]` (full task vectors, task units) by one damped
/// least-squares step per sample from `rest` (with per-demonstration `starts`: demo
/// index, first joint, values), drops `tr.drop_joint` samples and differentiates forward;
/// returns the demonstrations (numbered from 1) and the largest tracking error.
pub(crate) fn track(
    kin: &Kinematics,
    rest: &[f64],
    starts: &[(usize, usize, Vec<f64>)],
    targets: &[Vec<Vec<f64>>],
    tr: &Tracking,
) -> Result<(Vec<JointTrajectory>, f64), DataError> {
    let mut tracker = Tracker::new(kin, tr.damping)?;
    let [js, je] = tr.drop_joint;
    if je == 0 {
        return Err(invalid(
            "drop[3] (joint end) must be ≥ 1: q̇ is a forward difference",
        ));
    }
    let mut demos = Vec::new();
    let mut max_err: f64 = 0.0;
    for (k, t) in targets.iter().enumerate() {
        let mut q = rest.to_vec();
        for (_, qo, v) in starts.iter().filter(|s| s.0 == k) {
            q[*qo..*qo + v.len()].copy_from_slice(v);
        }
        if !kin.within_limits(&q) {
            return Err(invalid(format!(
                "demo {}: start posture is outside the joint limits",
                k + 1
            )));
        }
        for _ in 0..tr.settle_iterations {
            tracker.step(&mut q, &t[0]);
        }
        let (qs, errs) = tracker.follow(&mut q, t);
        let len = t.len();
        if len <= js + je + 1 {
            return Err(invalid(format!(
                "demo {}: too short after dropping samples",
                k + 1
            )));
        }
        let traj = tracker.trajectory(k, &qs, js..len - je, &errs, &mut max_err, tr.dt);
        if traj.q.iter().chain(&traj.qdot).any(|v| !v.is_finite()) {
            return Err(invalid(format!("demo {}: tracking diverged", k + 1)));
        }
        demos.push(traj);
    }
    Ok((demos, max_err))
}

/// Damped least-squares tracking of task targets (identity metric, μ on J Jᵀ) with its
/// workspaces.
struct Tracker<'a> {
    kin: &'a Kinematics,
    dls: DampedPinv,
    kws: KinematicsWorkspace,
    pws: PinvWorkspace,
    /// Task error (m).
    e: Vec<f64>,
    /// Joint step (n).
    dq: Vec<f64>,
}

impl<'a> Tracker<'a> {
    /// A tracker for `kin` with damping `μ`.
    fn new(kin: &'a Kinematics, damping: f64) -> Result<Self, DataError> {
        let (n, m) = (kin.dof(), kin.task_dim());
        let kws = kin.workspace();
        // Tracking with damped least squares (identity metric, μ on J Jᵀ).
        let dls = DampedPinv::new(Metric::identity(n), damping.sqrt(), 0.0)
            .map_err(|e| invalid(e.to_string()))?;
        let pws = dls.workspace(m);
        Ok(Self {
            kin,
            dls,
            kws,
            pws,
            e: vec![0.0; m],
            dq: vec![0.0; n],
        })
    }

    /// One damped least-squares step of `q` towards `target`.
    fn step(&mut self, q: &mut [f64], target: &[f64]) {
        self.kin.jacobian(q, &mut self.kws);
        for r in 0..self.e.len() {
            self.e[r] = target[r] - self.kws.x[r];
        }
        self.dls.factor(&self.kws.jac, &mut self.pws);
        self.dls.solve(&mut self.pws, &self.e, &mut self.dq);
        for (a, b) in q.iter_mut().zip(&self.dq) {
            *a += b;
        }
    }

    /// One step per target from `q`: the joint samples and each sample's tracking error.
    fn follow(&mut self, q: &mut [f64], t: &[Vec<f64>]) -> (Vec<f64>, Vec<f64>) {
        let mut qs: Vec<f64> = Vec::with_capacity(t.len() * q.len());
        let mut errs = Vec::with_capacity(t.len());
        for target in t {
            self.step(q, target);
            let x = self.kin.forward(q, &mut self.kws);
            errs.push(
                x.iter()
                    .zip(target)
                    .map(|(a, b)| (a - b) * (a - b))
                    .sum::<f64>()
                    .sqrt(),
            );
            qs.extend_from_slice(q);
        }
        (qs, errs)
    }

    /// Demonstration `k` from the joint samples `keep` of `qs` (forward-difference
    /// velocities); raises `max_err` to the kept samples' errors.
    fn trajectory(
        &mut self,
        k: usize,
        qs: &[f64],
        keep: std::ops::Range<usize>,
        errs: &[f64],
        max_err: &mut f64,
        dt: f64,
    ) -> JointTrajectory {
        let (n, m) = (self.kin.dof(), self.kin.task_dim());
        let mut traj = JointTrajectory {
            demo: k + 1,
            n,
            m,
            dt,
            q: Vec::new(),
            qdot: Vec::new(),
            x: Vec::new(),
        };
        for i in keep {
            let qi = &qs[i * n..(i + 1) * n];
            let qn = &qs[(i + 1) * n..(i + 2) * n];
            traj.q.extend_from_slice(qi);
            traj.qdot
                .extend(qi.iter().zip(qn).map(|(a, b)| (b - a) / dt));
            traj.x.extend(self.kin.forward(qi, &mut self.kws).iter());
            *max_err = max_err.max(errs[i]);
        }
        traj
    }
}
