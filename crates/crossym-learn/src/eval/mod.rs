//! Evaluation of learned policies (paper Sec. VI-A, Table II).
//!
//! For a test trajectory `(q_0 … q_T, x_0 … x_T)` with condition `s`, the policy is rolled
//! out from the same initial configuration, `q̂_{k+1} = q̂_k + Δt π(q̂_k, s)`, and compared
//! in task space: `RMSE = √(1/(T+1) Σ_k ‖f(q̂_k) − x_k‖²)` (both arms stacked, task units).
//! A rollout *diverges* when it becomes non-finite or its task error exceeds a threshold
//! (default 3.0, the width of the normalised letter box); diverging rollouts are scored on
//! their whole path (not capped at the threshold), stay in the mean ± std, as in the paper,
//! and are counted. A rollout at another step than the trajectory's is compared with the
//! nominal at the same *times* ([`nominal_at`], [`score_path_timed`]), never index by index.
//! [`paper`] holds the authors' own protocol (pooled training and test trajectories, or the
//! resampled real-robot script); [`ConditionedPolicy`] lets a canonicalised policy be
//! rolled out like a plain one.
//!
//! Units. The paper does not define its RMSE; Table II is reported in two conventions that
//! differ by the constant `√m` (`m` task coordinates, 4 for the planar dual arm):
//! the Euclidean one above (both arms stacked) and the per-coordinate one
//! `√(1/((T+1)·m) Σ_k ‖f(q̂_k) − x_k‖²)` (numpy's `sqrt(mean((a − b)**2))` over a `T × m`
//! array), see [`Cell::per_coordinate`].
//!
//! Reference without learning ([`demo_reference`]): the test trajectory scored against the
//! *training* demonstrations transformed by the same condition, the nearest one and their
//! sample-wise mean. A policy that memorised the closest demonstration would score the
//! former; it calibrates what the test demonstrations' own variability allows.

pub mod paper;
pub mod plot;
mod stats;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crossym_math::kinematics::Kinematics;
use crossym_math::symmetry::compose::Condition;
use crossym_policy::JointTrajectory;
use crossym_policy::Policy;
pub use stats::mean_std;

/// A symmetry-conditioned policy `π(q, s) → q̇` that evaluation can roll out: a plain
/// [`Policy`] or a canonicalised [`crossym_policy::EquivariantPolicy`].
pub trait ConditionedPolicy: Sync {
    /// Caller-owned scratch.
    type Workspace;
    /// Scratch sized for this policy.
    fn rollout_workspace(&self) -> Self::Workspace;
    /// `out = π(q, s)` (rad/s or m/s); `false` where the policy is undefined (a flow of a
    /// canonicalised policy reached a singularity): the rollout stops there.
    fn velocity_into(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut Self::Workspace,
    ) -> bool;
}

impl ConditionedPolicy for Policy {
    type Workspace = crossym_policy::PolicyWorkspace;
    fn rollout_workspace(&self) -> Self::Workspace {
        self.workspace()
    }
    fn velocity_into(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut Self::Workspace,
    ) -> bool {
        self.velocity(q, s, out, ws);
        true
    }
}

impl ConditionedPolicy for crossym_policy::EquivariantPolicy {
    type Workspace = crossym_policy::EquivariantWorkspace;
    fn rollout_workspace(&self) -> Self::Workspace {
        self.workspace()
    }
    fn velocity_into(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut Self::Workspace,
    ) -> bool {
        self.velocity(q, s, out, ws).is_ok()
    }
}

use crossym_policy::{AnyPolicy, AnyWorkspace};

impl ConditionedPolicy for AnyPolicy {
    type Workspace = AnyWorkspace;
    fn rollout_workspace(&self) -> AnyWorkspace {
        self.workspace()
    }
    fn velocity_into(
        &self,
        q: &[f64],
        s: &Condition,
        out: &mut [f64],
        ws: &mut AnyWorkspace,
    ) -> bool {
        self.velocity(q, s, out, ws).is_ok()
    }
}

/// `[eval]` settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EvalConfig {
    /// Task error above which a rollout counts as diverged (task units).
    #[serde(default = "d_div")]
    pub divergence_threshold: f64,
    /// Plot projection: the unit vectors `(u, v)` of the figure's horizontal and vertical
    /// axes in each arm's task frame (`xy` arms use the first two components); absent →
    /// `x` right, `y` up.
    #[serde(default)]
    pub view: Option<[[f64; 3]; 2]>,
    /// Name of the task-space unit on figure axes (`m` for a URDF robot's metres; default
    /// `task units`).
    #[serde(default = "d_units")]
    pub units: String,
    /// Policies evaluated when `crossym eval` gets no `--policy`: label → weights file
    /// (relative to the config file's directory).
    #[serde(default)]
    pub policies: std::collections::BTreeMap<String, std::path::PathBuf>,
    /// How `crossym eval --protocol paper` scores (default: Table II's pooled script).
    #[serde(default)]
    pub paper_protocol: paper::PaperProtocol,
}

fn d_div() -> f64 {
    3.0
}

fn d_units() -> String {
    "task units".into()
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            divergence_threshold: d_div(),
            view: None,
            units: d_units(),
            policies: Default::default(),
            paper_protocol: Default::default(),
        }
    }
}

/// Score of one rollout.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RolloutScore {
    /// Task-space RMSE against the nominal trajectory (task units).
    pub rmse: f64,
    /// True when the rollout diverged (non-finite or beyond the threshold).
    pub diverged: bool,
}

/// Rolls `policy` out from the trajectory's first configuration and scores it
/// ([`rollout_path`], then [`score_path`]).
///
/// The rollout runs for the whole trajectory even after it diverged, so a diverged
/// rollout's RMSE is its real error; only once it turns non-finite does integration stop,
/// its last finite error standing for the remaining samples.
pub fn score<P: ConditionedPolicy + ?Sized>(
    policy: &P,
    kin: &Kinematics,
    traj: &JointTrajectory,
    s: &Condition,
    cfg: &EvalConfig,
) -> RolloutScore {
    score_path(traj, &rollout_path(policy, kin, traj, s), cfg)
}

/// Scores an executed task-space path (row-major `len × m`, NaN from where it turned
/// non-finite, as [`rollout_path`] returns it) sampled at the trajectory's own step:
/// [`score_path_timed`] with `dt = traj.dt`.
pub fn score_path(traj: &JointTrajectory, executed: &[f64], cfg: &EvalConfig) -> RolloutScore {
    score_path_timed(traj, executed, traj.dt, cfg)
}

/// The nominal trajectory's task point at time `t` (s after its first sample) into `out`
/// (`m` values, task units): linear interpolation between the samples at `k Δt`; before
/// the start its first sample, past its end its last one (the goal).
///
/// ```
/// # use crossym_policy::JointTrajectory;
/// let traj = JointTrajectory { demo: 1, n: 1, m: 1, dt: 0.5, q: vec![0.0; 3], qdot: vec![0.0; 3], x: vec![0.0, 1.0, 3.0] };
/// let mut x = [0.0];
/// crossym_learn::eval::nominal_at(&traj, 0.75, &mut x);
/// assert_eq!(x[0], 2.0); // halfway between 1 (t = 0.5 s) and 3 (t = 1 s)
/// crossym_learn::eval::nominal_at(&traj, 9.0, &mut x);
/// assert_eq!(x[0], 3.0); // the goal past the end
/// ```
pub fn nominal_at(traj: &JointTrajectory, t: f64, out: &mut [f64]) {
    let len = traj.len();
    if len == 0 {
        out.fill(f64::NAN);
        return;
    }
    let u = (t / traj.dt).max(0.0);
    // A time within 1e-9 samples of a sample's is that sample, exactly (`k Δt / Δt` need
    // not be `k` in floating point).
    let u = if (u - u.round()).abs() < 1e-9 {
        u.round()
    } else {
        u
    };
    let k = (u.floor() as usize).min(len - 1);
    let w = if k + 1 < len { u - k as f64 } else { 0.0 };
    let (a, b) = (traj.x(k), traj.x((k + 1).min(len - 1)));
    for ((o, &a), &b) in out.iter_mut().zip(a).zip(b) {
        *o = if w == 0.0 { a } else { a + w * (b - a) };
    }
}

/// Scores an executed task-space path sampled every `dt` s (row-major `len × m`, NaN from
/// where it turned non-finite) against the nominal trajectory **at the same times**
/// ([`nominal_at`]: interpolated when `dt` differs from the nominal's step, its goal past
/// its end): the Euclidean RMSE over the executed samples, a non-finite sample counting
/// with the last finite error, and whether it diverged (non-finite, or an error above the
/// threshold).
pub fn score_path_timed(
    traj: &JointTrajectory,
    executed: &[f64],
    dt: f64,
    cfg: &EvalConfig,
) -> RolloutScore {
    let m = traj.m;
    let len = executed.len() / m.max(1);
    let same_step = dt == traj.dt;
    let mut nominal = vec![0.0; m];
    let (mut sum, mut last_err, mut diverged) = (0.0, 0.0, false);
    for k in 0..len {
        let x: &[f64] = if same_step && k < traj.len() {
            traj.x(k)
        } else {
            nominal_at(traj, k as f64 * dt, &mut nominal);
            &nominal
        };
        let e = executed[k * m..(k + 1) * m]
            .iter()
            .zip(x)
            .map(|(a, b)| (a - b) * (a - b))
            .sum::<f64>()
            .sqrt();
        if e.is_finite() {
            last_err = e;
            diverged |= e > cfg.divergence_threshold;
        } else {
            diverged = true;
        }
        sum += last_err * last_err;
    }
    RolloutScore {
        rmse: (sum / len.max(1) as f64).sqrt(),
        diverged,
    }
}

/// Number of samples a rollout at step `dt` needs to span the nominal trajectory's time
/// length `(len − 1) Δt_nominal` (at least 1).
pub fn samples_spanning(traj: &JointTrajectory, dt: f64) -> usize {
    let duration = traj.len().saturating_sub(1) as f64 * traj.dt;
    (duration / dt).round() as usize + 1
}

/// A policy rolled out open loop from a start configuration ([`rollout`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Rollout {
    /// The executed states `q̂_k` at times `k Δt`, the policy's velocities `π(q̂_k, s)`
    /// (zero at the last sample) and the task path `f(q̂_k)`; `demo` is 0.
    pub traj: JointTrajectory,
    /// Whether the rollout stayed finite over all requested samples.
    pub status: RolloutStatus,
}

/// How a [`rollout`] ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum RolloutStatus {
    /// Every sample is finite.
    Finite,
    /// The state turned non-finite at this sample; it and the samples after it are NaN.
    NonFinite {
        /// First non-finite sample.
        sample: usize,
    },
}

/// Integrates `q̂_{k+1} = q̂_k + Δt π(q̂_k, s)` (explicit Euler, as the node's velocity
/// commands are held for a period) from `q0` for `len` samples, recording `q̂`, `π` and
/// `f(q̂)`. Stops at the first non-finite state, filling the rest with NaN.
pub fn rollout<P: ConditionedPolicy + ?Sized>(
    policy: &P,
    kin: &Kinematics,
    q0: &[f64],
    s: &Condition,
    dt: f64,
    len: usize,
) -> Rollout {
    let (n, m) = (q0.len(), kin.task_dim());
    let mut ws = policy.rollout_workspace();
    let mut kws = kin.workspace();
    let mut q = q0.to_vec();
    let mut v = vec![0.0; n];
    let mut t = JointTrajectory {
        demo: 0,
        n,
        m,
        dt,
        q: Vec::with_capacity(len * n),
        qdot: Vec::with_capacity(len * n),
        x: Vec::with_capacity(len * m),
    };
    let mut status = RolloutStatus::Finite;
    for k in 0..len {
        let x = kin.forward(&q, &mut kws);
        if q.iter().chain(x.iter()).any(|c| !c.is_finite()) {
            status = RolloutStatus::NonFinite { sample: k };
            t.q.resize(len * n, f64::NAN);
            t.qdot.resize(len * n, f64::NAN);
            t.x.resize(len * m, f64::NAN);
            break;
        }
        t.x.extend(x.iter());
        t.q.extend_from_slice(&q);
        if k + 1 < len {
            if !policy.velocity_into(&q, s, &mut v, &mut ws) {
                // Undefined here: the next state is not finite.
                v.fill(f64::NAN);
            }
            for j in 0..n {
                q[j] += dt * v[j];
            }
        } else {
            v.fill(0.0);
        }
        t.qdot.extend_from_slice(&v);
    }
    Rollout { traj: t, status }
}

/// The task-space path `f(q̂_k)` of the policy rolled out from the trajectory's first
/// configuration for as many steps as the trajectory has (row-major `len × m`, see
/// [`rollout`]); a rollout that becomes non-finite stops there (the rest is NaN).
pub fn rollout_path<P: ConditionedPolicy + ?Sized>(
    policy: &P,
    kin: &Kinematics,
    traj: &JointTrajectory,
    s: &Condition,
) -> Vec<f64> {
    rollout(policy, kin, traj.q(0), s, traj.dt, traj.len())
        .traj
        .x
}

/// Per-chain task-space RMSE of an executed path against the trajectory's nominal one
/// (`√(mean_k ‖x̂_k,c − x_k,c‖²)` for each chain `c`, task units); non-finite samples
/// count with the last finite error.
pub fn chain_rmse(kin: &Kinematics, traj: &JointTrajectory, executed: &[f64]) -> Vec<f64> {
    let m = traj.m;
    kin.chains()
        .iter()
        .enumerate()
        .map(|(ci, c)| {
            let (o, d) = (kin.x_offset(ci), c.task.dim());
            let (mut sum, mut last) = (0.0, 0.0);
            for k in 0..traj.len() {
                let e = (o..o + d)
                    .map(|i| (executed[k * m + i] - traj.x[k * m + i]).powi(2))
                    .sum::<f64>();
                if e.is_finite() {
                    last = e;
                }
                sum += last;
            }
            (sum / traj.len().max(1) as f64).sqrt()
        })
        .collect()
}

/// Mean ± std of RMSE over a test set, with the divergence count.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Cell {
    /// Mean RMSE (task units).
    pub mean: f64,
    /// Standard deviation of the RMSE.
    pub std: f64,
    /// Test trajectories.
    pub count: usize,
    /// Diverged rollouts.
    pub diverged: usize,
}

/// Scores every trajectory of a test set (in parallel).
pub fn evaluate<P: ConditionedPolicy + ?Sized>(
    policy: &P,
    kin: &Kinematics,
    set: &[(&JointTrajectory, Condition)],
    cfg: &EvalConfig,
) -> Cell {
    let scores: Vec<RolloutScore> = set
        .par_iter()
        .map(|(t, s)| score(policy, kin, t, s, cfg))
        .collect();
    Cell::from_scores(&scores)
}

/// Task-space RMSE of a nominal path `x` against a reference path `r` (row-major, `m`
/// coordinates per sample), over their common length (task units, Euclidean as above).
pub fn path_rmse(x: &[f64], r: &[f64], m: usize) -> f64 {
    let len = x.len().min(r.len()) / m.max(1);
    if len == 0 {
        return f64::NAN;
    }
    let sum: f64 = x[..len * m]
        .iter()
        .zip(&r[..len * m])
        .map(|(a, b)| (a - b) * (a - b))
        .sum();
    (sum / len as f64).sqrt()
}

/// Scores of a test trajectory against reference trajectories with the same condition
/// (task units): `(nearest, mean)`, the RMSE to the closest reference and to the
/// sample-wise mean of all references (over their common length). `None` without
/// references.
pub fn demo_reference(test: &JointTrajectory, refs: &[&JointTrajectory]) -> Option<(f64, f64)> {
    let m = test.m;
    let len = refs.iter().map(|r| r.len()).min()?.min(test.len());
    let nearest = refs
        .iter()
        .map(|r| path_rmse(&test.x, &r.x, m))
        .fold(f64::INFINITY, f64::min);
    let mut mean = vec![0.0; len * m];
    for r in refs {
        for (acc, v) in mean.iter_mut().zip(&r.x) {
            *acc += v / refs.len() as f64;
        }
    }
    Some((nearest, path_rmse(&test.x, &mean, m)))
}

impl Cell {
    /// The cell in the per-coordinate convention: every RMSE divided by `√m` (`m` task
    /// coordinates), which is exact because `m` is the same for every trajectory.
    pub fn per_coordinate(self, m: usize) -> Self {
        let k = (m.max(1) as f64).sqrt();
        Cell {
            mean: self.mean / k,
            std: self.std / k,
            ..self
        }
    }

    /// Mean ± std (population) of the scores' RMSE, with the divergence count.
    pub fn from_scores(scores: &[RolloutScore]) -> Self {
        let count = scores.len();
        let rmse: Vec<f64> = scores.iter().map(|s| s.rmse).collect();
        let (mean, std) = mean_std(&rmse, 0);
        Cell {
            mean,
            std,
            count,
            diverged: scores.iter().filter(|s| s.diverged).count(),
        }
    }
}
