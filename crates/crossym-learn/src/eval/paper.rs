//! The paper's own evaluation protocol, as its authors' public evaluation code computes
//! Table II and the real-robot figures (`crossym eval --protocol paper`).
//!
//! **Pooled** (simulated letters, [`PaperProtocol::Pooled`]): the pool is every trajectory
//! of the training *and* test sets; the first `w` samples of each are dropped (warm-up);
//! the policy is rolled out from the trimmed trajectory's first state with its condition,
//! one explicit Euler step per stored sample, for `L − 1` steps with
//! `L = min over the pool of (len − w)`, and compared sample by sample (no time alignment,
//! no run to convergence, diverging rollouts included). Per trajectory
//! `MSE_τ = 1/(L m) Σ_k ‖x̂_k − x_k‖²` (`m` task coordinates, no normalisation); per set
//! `value = √(mean_τ MSE_τ)` (the *pooled* RMSE, not the mean of RMSEs) and the `±` is the
//! population standard deviation of the `MSE_τ` (not of RMSEs).
//!
//! **Resampled** (the real-robot script, [`PaperProtocol::Resampled`]): executed and nominal
//! paths are both resampled to `P` points over normalised time (linear interpolation),
//! reduced to the chosen columns, `RMSE_τ = √(mean of the squared differences over all
//! entries)`, and a set reports mean ± standard deviation (`ddof = 1`) of the `RMSE_τ`.
//!
//! Both are per coordinate (means over task coordinates), in task units.

use serde::{Deserialize, Serialize};

/// `[eval] paper_protocol`: which of the authors' two evaluation scripts
/// `crossym eval --protocol paper` follows.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum PaperProtocol {
    /// Table II's script: training and test trajectories pooled, warm-up dropped, a common
    /// horizon, pooled RMSE with the std of the per-trajectory MSEs.
    Pooled {
        /// Samples dropped at the start of every trajectory (the authors' 60).
        #[serde(default = "d_warmup")]
        warmup_samples: usize,
    },
    /// The real-robot script: test rollouts and nominals resampled over normalised time,
    /// RMSE per trajectory on `columns`, mean ± std (ddof 1).
    Resampled {
        /// Points over normalised time (the authors' 200, ≥ 2).
        #[serde(default = "d_points")]
        points: usize,
        /// Which task-space columns are compared.
        #[serde(default)]
        columns: Columns,
    },
}

fn d_warmup() -> usize {
    60
}

fn d_points() -> usize {
    200
}

impl Default for PaperProtocol {
    fn default() -> Self {
        PaperProtocol::Pooled {
            warmup_samples: d_warmup(),
        }
    }
}

/// Task-space columns compared by [`PaperProtocol::Resampled`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Columns {
    /// Every task coordinate of every arm (positions for `xyz` / `xy` arms).
    #[default]
    Task,
    /// Each arm's point projected on the `[eval] view` plane `(u, v)`: the two coordinates
    /// of a drawing plane per arm (the letter task on RB-Y1).
    View,
}

impl PaperProtocol {
    /// Checks the settings' domains.
    pub fn validate(&self) -> Result<(), PaperProtocolError> {
        match *self {
            PaperProtocol::Resampled { points, .. } if points < 2 => {
                Err(PaperProtocolError::TooFewPoints { points })
            }
            _ => Ok(()),
        }
    }
}

/// Why `[eval] paper_protocol` settings are refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PaperProtocolError {
    /// Fewer than 2 resampling points.
    #[error("paper_protocol.points = {points}: need at least 2 points")]
    TooFewPoints {
        /// The setting.
        points: usize,
    },
}

/// A Table II cell in the paper's protocol.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PaperCell {
    /// The reported value: pooled `√(mean MSE)` or mean RMSE (task units, per coordinate).
    pub value: f64,
    /// The `±`: population std of the MSEs (pooled; task units²) or sample std (ddof 1) of
    /// the RMSEs (resampled; task units); NaN with fewer than 2 trajectories (resampled).
    pub std: f64,
    /// What [`PaperCell::std`] is the spread of.
    pub spread: Spread,
    /// Trajectories in the set.
    pub count: usize,
    /// Rollouts whose task error exceeded the divergence threshold or turned non-finite.
    pub diverged: usize,
}

/// What a [`PaperCell`]'s `±` measures.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Spread {
    /// Population standard deviation of the per-trajectory MSEs (task units²).
    MsePopulation,
    /// Sample standard deviation (ddof 1) of the per-trajectory RMSEs (task units).
    RmseSample,
}

impl Spread {
    /// Short label for tables and CSV (`std_mse`, `std_rmse_ddof1`).
    pub fn label(self) -> &'static str {
        match self {
            Spread::MsePopulation => "std_mse",
            Spread::RmseSample => "std_rmse_ddof1",
        }
    }
}

/// One trajectory's error: the pooled protocol's `MSE_τ` or the resampled one's `RMSE_τ`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrajectoryError {
    /// `MSE_τ` (task units², pooled) or `RMSE_τ` (task units, resampled).
    pub error: f64,
    /// Whether the rollout diverged.
    pub diverged: bool,
}

/// The pooled protocol's common horizon: `L = min over the pool of (len − warmup)`
/// samples (`None` for an empty pool or when a trajectory is not longer than the warm-up).
///
/// ```
/// assert_eq!(crossym_learn::eval::paper::pooled_horizon([100, 80, 90], 60), Some(20));
/// assert_eq!(crossym_learn::eval::paper::pooled_horizon([100, 60], 60), None);
/// ```
pub fn pooled_horizon(lengths: impl IntoIterator<Item = usize>, warmup: usize) -> Option<usize> {
    lengths
        .into_iter()
        .map(|len| len.checked_sub(warmup).filter(|&l| l > 0))
        .try_fold(usize::MAX, |acc, l| l.map(|l| acc.min(l)))
        .filter(|&l| l != usize::MAX)
}

/// `MSE_τ = 1/(L m) Σ_k Σ_i (x̂_{k,i} − x_{k,i})²` over the first `L` samples of both
/// row-major paths (`m` coordinates per sample, `L` = the shorter one's length); a
/// non-finite sample counts with the last finite sample's squared error. Diverged: a
/// non-finite sample, or a Euclidean error above `threshold` (task units).
///
/// ```
/// use crossym_learn::eval::paper::trajectory_mse;
/// // Two samples of a 2-D path, errors (1, 0) and (1, 2): (1 + 0 + 1 + 4) / 4 = 1.5.
/// let e = trajectory_mse(&[1.0, 0.0, 1.0, 2.0], &[0.0; 4], 2, 10.0);
/// assert_eq!(e.error, 1.5);
/// ```
pub fn trajectory_mse(
    executed: &[f64],
    nominal: &[f64],
    m: usize,
    threshold: f64,
) -> TrajectoryError {
    let m = m.max(1);
    let len = executed.len().min(nominal.len()) / m;
    let (mut sum, mut last, mut diverged) = (0.0, 0.0, false);
    for k in 0..len {
        let e2: f64 = executed[k * m..(k + 1) * m]
            .iter()
            .zip(&nominal[k * m..(k + 1) * m])
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        if e2.is_finite() {
            last = e2;
            diverged |= e2.sqrt() > threshold;
        } else {
            diverged = true;
        }
        sum += last;
    }
    TrajectoryError {
        error: if len == 0 {
            f64::NAN
        } else {
            sum / (len * m) as f64
        },
        diverged,
    }
}

/// A set's cell under the pooled protocol: `value = √(mean MSE_τ)`, `std` = population std
/// of the `MSE_τ`.
///
/// ```
/// use crossym_learn::eval::paper::{pooled_cell, TrajectoryError};
/// let e = |error| TrajectoryError { error, diverged: false };
/// let c = pooled_cell(&[e(1.0), e(9.0)]);
/// assert_eq!(c.value, 5f64.sqrt()); // not the mean of the RMSEs, (1 + 3) / 2 = 2
/// assert_eq!(c.std, 4.0); // of the MSEs 1 and 9
/// ```
pub fn pooled_cell(errors: &[TrajectoryError]) -> PaperCell {
    let count = errors.len();
    let (mean, std) = super::stats::mean_std(&values(errors), 0);
    PaperCell {
        value: mean.sqrt(),
        std,
        spread: Spread::MsePopulation,
        count,
        diverged: errors.iter().filter(|e| e.diverged).count(),
    }
}

/// A set's cell under the resampled protocol: mean ± sample std (ddof 1) of the `RMSE_τ`
/// (std NaN with fewer than 2).
///
/// ```
/// use crossym_learn::eval::paper::{resampled_cell, TrajectoryError};
/// let e = |error| TrajectoryError { error, diverged: false };
/// let c = resampled_cell(&[e(1.0), e(3.0)]);
/// assert_eq!((c.value, c.std), (2.0, 2f64.sqrt())); // ddof 1: √((1 + 1) / 1)
/// ```
pub fn resampled_cell(errors: &[TrajectoryError]) -> PaperCell {
    let count = errors.len();
    let (mean, std) = super::stats::mean_std(&values(errors), 1);
    PaperCell {
        value: mean,
        std,
        spread: Spread::RmseSample,
        count,
        diverged: errors.iter().filter(|e| e.diverged).count(),
    }
}

/// The per-trajectory errors as plain values.
fn values(errors: &[TrajectoryError]) -> Vec<f64> {
    errors.iter().map(|e| e.error).collect()
}

/// A row-major path of `len` samples × `c` columns resampled to `points` samples over
/// normalised time `u ∈ [0, 1]` (sample `i` of the input at `u = i / (len − 1)`), linear
/// interpolation (numpy's `interp` per column). A single sample is repeated.
///
/// ```
/// let r = crossym_learn::eval::paper::resample(&[0.0, 10.0, 20.0], 1, 5);
/// assert_eq!(r, vec![0.0, 5.0, 10.0, 15.0, 20.0]);
/// ```
pub fn resample(path: &[f64], c: usize, points: usize) -> Vec<f64> {
    let c = c.max(1);
    let len = path.len() / c;
    let mut out = Vec::with_capacity(points * c);
    if len == 0 {
        out.resize(points * c, f64::NAN);
        return out;
    }
    for p in 0..points {
        let u = if points > 1 {
            p as f64 / (points - 1) as f64
        } else {
            0.0
        };
        let s = u * (len - 1) as f64;
        let k = (s.floor() as usize).min(len - 1);
        let w = s - k as f64;
        let k1 = (k + 1).min(len - 1);
        for i in 0..c {
            let (a, b) = (path[k * c + i], path[k1 * c + i]);
            out.push(if w == 0.0 { a } else { a + w * (b - a) });
        }
    }
    out
}

/// `RMSE_τ = √(mean over all entries of (a − b)²)` of two equally long resampled paths; a
/// non-finite entry makes the rollout diverged and counts with the largest finite squared
/// difference seen.
pub fn resampled_rmse(
    executed: &[f64],
    nominal: &[f64],
    c: usize,
    threshold: f64,
) -> TrajectoryError {
    let c = c.max(1);
    let (mut sum, mut worst, mut diverged, mut count) = (0.0, 0.0f64, false, 0usize);
    for (a, b) in executed.chunks(c).zip(nominal.chunks(c)) {
        let mut e2 = 0.0;
        for (a, b) in a.iter().zip(b) {
            let d = (a - b) * (a - b);
            if d.is_finite() {
                worst = worst.max(d);
                sum += d;
            } else {
                diverged = true;
                sum += worst;
            }
            e2 += d;
            count += 1;
        }
        diverged |= e2.is_nan() || e2.sqrt() > threshold;
    }
    TrajectoryError {
        error: (sum / count.max(1) as f64).sqrt(),
        diverged,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn e(error: f64) -> TrajectoryError {
        TrajectoryError {
            error,
            diverged: false,
        }
    }

    /// The pooled value is √(mean MSE), which differs from the mean of the per-trajectory
    /// RMSEs; the ± is the population std of the MSEs, not of the RMSEs.
    #[test]
    fn pooled_rmse_is_not_the_mean_of_rmses_and_its_spread_is_of_mses() {
        // Two trajectories of one coordinate, constant errors 1 and 3 over 4 samples.
        let nominal = vec![0.0; 4];
        let a = trajectory_mse(&[1.0; 4], &nominal, 1, 10.0);
        let b = trajectory_mse(&[3.0; 4], &nominal, 1, 10.0);
        assert_eq!((a.error, b.error), (1.0, 9.0));
        let c = pooled_cell(&[a, b]);
        // Computed here independently: mean MSE 5, RMSEs 1 and 3.
        assert!((c.value - 5f64.sqrt()).abs() < 1e-15);
        assert!((c.value - 2.0).abs() > 0.2, "the mean of the RMSEs is 2");
        assert_eq!(c.std, 4.0, "population std of {{1, 9}}");
        assert_ne!(c.std, 1.0, "the population std of the RMSEs {{1, 3}} is 1");
        assert_eq!(c.spread, Spread::MsePopulation);
    }

    /// The MSE averages over samples *and* coordinates (no Euclidean sum), and stops at
    /// the shorter path (the common horizon).
    #[test]
    fn trajectory_mse_averages_over_coordinates_and_common_samples() {
        // 3 samples of 4 coordinates; the executed path has one extra sample that must
        // not count.
        let nominal = vec![0.0; 12];
        let mut executed = vec![0.0; 16];
        executed[0] = 2.0; // sample 0, one coordinate: squared error 4
        executed[12..16].copy_from_slice(&[100.0; 4]); // beyond the nominal's length
        let t = trajectory_mse(&executed, &nominal, 4, 10.0);
        assert_eq!(t.error, 4.0 / 12.0);
        assert!(!t.diverged);
        // A 12.0 error beyond the threshold of 10 makes it diverged and is kept in full.
        executed[5] = 12.0;
        let t = trajectory_mse(&executed, &nominal, 4, 10.0);
        assert!(t.diverged);
        assert_eq!(t.error, (4.0 + 144.0) / 12.0);
    }

    /// The horizon is the shortest trimmed length; a trajectory not longer than the
    /// warm-up leaves no horizon.
    #[test]
    fn horizon_is_the_shortest_trimmed_length() {
        assert_eq!(pooled_horizon([977, 1000, 700], 60), Some(640));
        assert_eq!(pooled_horizon([977], 0), Some(977));
        assert_eq!(pooled_horizon(Vec::<usize>::new(), 60), None);
        assert_eq!(pooled_horizon([977, 50], 60), None);
    }

    /// Resampling over normalised time maps both ends onto each other whatever the
    /// lengths, so a path and its 3× denser copy compare to zero error.
    #[test]
    fn resampled_paths_of_different_density_agree() {
        let coarse: Vec<f64> = (0..11).flat_map(|k| [k as f64, (k * k) as f64]).collect();
        // A denser sampling of the same piecewise-linear path.
        let dense: Vec<f64> = (0..31)
            .flat_map(|k| {
                let s = k as f64 / 3.0;
                let (i, w) = (s.floor() as usize, s - s.floor());
                let i1 = (i + 1).min(10);
                let y = (i * i) as f64 + w * ((i1 * i1) as f64 - (i * i) as f64);
                [s, y]
            })
            .collect();
        let (a, b) = (resample(&coarse, 2, 200), resample(&dense, 2, 200));
        assert_eq!(a.len(), 400);
        let r = resampled_rmse(&a, &b, 2, 1.0);
        assert!(r.error < 1e-12, "{}", r.error);
        assert!(!r.diverged);
        // Index by index, without resampling, the same two paths differ badly.
        assert!(trajectory_mse(&coarse, &dense, 2, 1e9).error > 1.0);
    }

    /// The resampled cell's ± is the sample std (ddof 1) of the RMSEs.
    #[test]
    fn resampled_cell_uses_the_sample_std_of_rmses() {
        let c = resampled_cell(&[e(0.01), e(0.02), e(0.03)]);
        assert!((c.value - 0.02).abs() < 1e-15);
        assert!((c.std - 0.01).abs() < 1e-15, "{}", c.std);
        assert!(resampled_cell(&[e(0.01)]).std.is_nan());
    }
}
