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
//! configuration (`[letters]`), so other letters, placements and robots use the same path.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::lasa::LetterSet;
use super::DataError;
use crate::kinematics::{DampedPinv, Kinematics, Metric};

/// One arm's letter: which chain draws which LASA file from which rest posture.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ArmLetter {
    /// Chain name (from `[[robot.chains]]`).
    pub chain: String,
    /// LASA file (`.csv` or `.mat`), relative to the config file's directory.
    pub letter: PathBuf,
    /// Rest posture of this chain's joints (rad).
    pub rest: Vec<f64>,
    /// Offset `o` subtracted from `f(q0)` to place the letter (task units).
    pub offset: Vec<f64>,
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
}

/// A joint-space demonstration with its nominal task-space path.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// 1-based demonstration number it came from.
    pub demo: usize,
    /// Joint-space dimension `n`.
    pub n: usize,
    /// Task-space dimension `m`.
    pub m: usize,
    /// Sample period (s).
    pub dt: f64,
    /// Positions, row-major `len × n` (rad).
    pub q: Vec<f64>,
    /// Velocities, row-major `len × n` (rad/s).
    pub qdot: Vec<f64>,
    /// Nominal task-space path `f(q)`, row-major `len × m` (task units).
    pub x: Vec<f64>,
}

impl JointTrajectory {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.q.len() / self.n.max(1)
    }
    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
    /// Position of sample `i`.
    pub fn q(&self, i: usize) -> &[f64] {
        &self.q[i * self.n..(i + 1) * self.n]
    }
    /// Velocity of sample `i`.
    pub fn qdot(&self, i: usize) -> &[f64] {
        &self.qdot[i * self.n..(i + 1) * self.n]
    }
    /// Task point of sample `i`.
    pub fn x(&self, i: usize) -> &[f64] {
        &self.x[i * self.m..(i + 1) * self.m]
    }
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

fn invalid(what: impl Into<String>) -> DataError {
    DataError::Invalid {
        message: what.into(),
    }
}

impl LetterTaskConfig {
    /// Loads the letters (paths relative to `base_dir`) and tracks them with `kin`.
    pub fn build(&self, kin: &Kinematics, base_dir: &Path) -> Result<LetterDemos, DataError> {
        let chains = kin.chains();
        if self.arms.len() != chains.len() {
            return Err(invalid(format!(
                "[letters] has {} arms, the robot has {} chains",
                self.arms.len(),
                chains.len()
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
        let (n, m) = (kin.dof(), kin.task_dim());
        let mut rest = vec![0.0; n];
        let mut targets: Vec<Vec<Vec<f64>>> = Vec::new(); // [demo][sample][m]
        let mut kws = kin.workspace();
        for (ci, (arm, chain)) in self.arms.iter().zip(chains).enumerate() {
            if arm.chain != chain.name {
                return Err(invalid(format!(
                    "[letters] arm {ci} names chain `{}`, expected `{}` (chain order)",
                    arm.chain, chain.name
                )));
            }
            let d = chain.task.dim();
            if d != 2 || arm.offset.len() != 2 || arm.rest.len() != chain.dof() {
                return Err(invalid(format!(
                    "[letters] arm `{}`: needs a planar (xy) chain, a 2-D offset and {} rest values",
                    arm.chain,
                    chain.dof()
                )));
            }
            if arm.rest.iter().chain(&arm.offset).any(|v| !v.is_finite()) {
                return Err(invalid(format!(
                    "[letters] arm `{}`: rest/offset must be finite",
                    arm.chain
                )));
            }
            rest[kin.q_offset(ci)..kin.q_offset(ci) + chain.dof()].copy_from_slice(&arm.rest);
            let path = if arm.letter.is_absolute() {
                arm.letter.clone()
            } else {
                base_dir.join(&arm.letter)
            };
            let set = LetterSet::load(&path)?;
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
            let q0 = &arm.rest;
            let mut ws = chain.workspace();
            let p0 = chain.position(q0, &mut ws);
            let shift = [p0.x - arm.offset[0], p0.y - arm.offset[1]];
            let [ds, de, _, _] = self.drop;
            for (k, demo) in set.demos.iter().enumerate() {
                if demo.pos.len() <= ds + de + 1 {
                    return Err(invalid(format!(
                        "{}: demo {} too short",
                        path.display(),
                        k + 1
                    )));
                }
                if targets.len() <= k {
                    targets.push(Vec::new());
                }
                let kept = &demo.pos[ds..demo.pos.len() - de];
                let t = &mut targets[k];
                if t.is_empty() {
                    t.resize(kept.len(), vec![0.0; m]);
                } else if t.len() != kept.len() {
                    return Err(invalid(format!(
                        "demo {}: arms' letters have different lengths",
                        k + 1
                    )));
                }
                let xo = kin.x_offset(ci);
                for (s, p) in kept.iter().enumerate() {
                    for c in 0..2 {
                        let r = self.half_range;
                        let v = -r + 2.0 * r * (p[c] - lo[c]) / (hi[c] - lo[c]);
                        t[s][xo + c] = v + shift[c];
                    }
                }
            }
        }
        if !kin.within_limits(&rest) {
            return Err(invalid(
                "[letters] rest posture is outside the joint limits",
            ));
        }
        // Tracking with damped least squares (identity metric, μ on J Jᵀ).
        let dls = DampedPinv::new(Metric::identity(n), self.tracking_damping.sqrt(), 0.0)
            .map_err(|e| invalid(e.to_string()))?;
        let mut pws = dls.workspace(m);
        let [_, _, js, je] = self.drop;
        if je == 0 {
            return Err(invalid(
                "[letters] drop[3] (joint end) must be ≥ 1: q̇ is a forward difference",
            ));
        }
        let mut demos = Vec::new();
        let mut max_err: f64 = 0.0;
        let mut e = vec![0.0; m];
        let mut dq = vec![0.0; n];
        for (k, t) in targets.iter().enumerate() {
            let mut q = rest.clone();
            let mut qs: Vec<f64> = Vec::with_capacity(t.len() * n);
            let mut errs = Vec::with_capacity(t.len());
            for target in t {
                kin.jacobian(&q, &mut kws);
                for r in 0..m {
                    e[r] = target[r] - kws.x[r];
                }
                dls.factor(&kws.jac, &mut pws);
                dls.solve(&mut pws, &e, &mut dq);
                for (a, b) in q.iter_mut().zip(&dq) {
                    *a += b;
                }
                let x = kin.forward(&q, &mut kws);
                errs.push(
                    x.iter()
                        .zip(target)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt(),
                );
                qs.extend_from_slice(&q);
            }
            let len = t.len();
            if len <= js + je + 1 {
                return Err(invalid(format!(
                    "demo {}: too short after dropping samples",
                    k + 1
                )));
            }
            let keep = js..len - je;
            let mut traj = JointTrajectory {
                demo: k + 1,
                n,
                m,
                dt: self.dt,
                q: Vec::new(),
                qdot: Vec::new(),
                x: Vec::new(),
            };
            for i in keep.clone() {
                let qi = &qs[i * n..(i + 1) * n];
                let qn = &qs[(i + 1) * n..(i + 2) * n];
                traj.q.extend_from_slice(qi);
                traj.qdot
                    .extend(qi.iter().zip(qn).map(|(a, b)| (b - a) / self.dt));
                traj.x.extend(kin.forward(qi, &mut kws).iter());
                max_err = max_err.max(errs[i]);
            }
            if traj.q.iter().chain(&traj.qdot).any(|v| !v.is_finite()) {
                return Err(invalid(format!("demo {}: tracking diverged", k + 1)));
            }
            demos.push(traj);
        }
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
}
