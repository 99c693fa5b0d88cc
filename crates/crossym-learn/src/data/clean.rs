//! From a joint-state recording to clean demonstrations: gap check, resampling onto a
//! uniform grid, velocities by a Savitzky–Golay differentiator, idle start and end
//! trimmed, optional split at idle periods, samples outside the joint limits flagged.
//!
//! - **Gaps.** Stamps `t_k` of a recording are irregular; a step `t_{k+1} − t_k` larger than
//!   `max_gap_s` is refused (no interpolation across a dropout).
//! - **Resampling.** `q(iΔt)` by linear interpolation between the two stamps around it, for
//!   `i = 0 … ⌊t_end/Δt⌋`.
//! - **Velocities.** A Savitzky–Golay differentiator: at sample `i` the least-squares
//!   polynomial of degree `p` through the `2h + 1` samples around it (shifted inside the
//!   record at its ends) is differentiated at `i`, `q̇ᵢ = Σ_m w_m q_{i+m}` with weights
//!   `w = e₁ᵀ (VᵀV)⁻¹ Vᵀ / Δt`, `V_{m,r} = (m − c)ʳ`. On encoder noise of standard deviation
//!   `σ` the central finite difference has error `≈ σ/(√2 Δt)`; the fit's is
//!   `≈ σ √(12 / (N(N²−1))) / Δt` for `p ≤ 2` with `N = 2h + 1` (see the tests for measured
//!   figures), at the price of a bias `O(Δt^{p+1} h^{p})` on curved motion.
//! - **Idle trimming.** A sample is idle when every joint moves slower than
//!   `idle_speed`. A first-order policy `q̇ = π(q, s)` cannot leave a state where its
//!   demonstration stood still: the idle start is cut so the demonstration starts at the
//!   last idle sample before motion (the start state, with its small onset velocity); the
//!   idle end is cut after the first idle sample at the end (the goal, where the policy
//!   should learn to stop).
//! - **Split** (optional): an idle run in the middle longer than `split_idle_s` ends one
//!   demonstration and the next motion starts another.

use crossym_math::kinematics::JointLimits;

use super::recording::JointRecording;

/// The velocity estimator.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum Differentiator {
    /// Savitzky–Golay: degree-`order` fit over `2 · half_window + 1` samples.
    SavitzkyGolay {
        /// `h`: samples on each side.
        half_window: usize,
        /// `p`: polynomial degree (1 … 4).
        order: usize,
    },
    /// Central finite difference (one-sided at the ends).
    FiniteDifference,
}

/// Cleaning settings (`[demonstrations.cleaning]`, validated by [`CleanConfig::validate`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CleanConfig {
    /// Largest accepted step between two stamps (s).
    #[serde(default = "d_gap")]
    pub max_gap_s: f64,
    /// Joint speed below which a sample is idle (rad/s or m/s, every joint).
    #[serde(default = "d_idle")]
    pub idle_speed: f64,
    /// Split at idle runs in the middle longer than this (s); `None` = one demonstration
    /// per recording.
    #[serde(default)]
    pub split_idle_s: Option<f64>,
    /// Velocity estimator.
    #[serde(default = "d_diff")]
    pub differentiator: Differentiator,
}

fn d_gap() -> f64 {
    0.1
}
fn d_idle() -> f64 {
    0.02
}
fn d_diff() -> Differentiator {
    Differentiator::SavitzkyGolay {
        half_window: 7,
        order: 2,
    }
}

impl Default for CleanConfig {
    fn default() -> Self {
        Self {
            max_gap_s: d_gap(),
            idle_speed: d_idle(),
            split_idle_s: None,
            differentiator: d_diff(),
        }
    }
}

impl CleanConfig {
    /// Checks every setting for a resampling step `dt` (s); the message names the bad one.
    pub fn validate(&self, dt: f64) -> Result<(), CleanConfigError> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(CleanConfigError::Dt { dt });
        }
        if !(self.max_gap_s.is_finite() && self.max_gap_s >= dt) {
            return Err(CleanConfigError::MaxGap {
                max_gap_s: self.max_gap_s,
            });
        }
        if !(self.idle_speed.is_finite() && self.idle_speed >= 0.0) {
            return Err(CleanConfigError::IdleSpeed {
                idle_speed: self.idle_speed,
            });
        }
        if let Some(s) = self.split_idle_s {
            if !(s.is_finite() && s > 0.0) {
                return Err(CleanConfigError::SplitIdle { split_idle_s: s });
            }
        }
        if let Differentiator::SavitzkyGolay { half_window, order } = self.differentiator {
            if !(1..=4).contains(&order) || half_window == 0 || 2 * half_window < order {
                return Err(CleanConfigError::SavitzkyGolay { half_window, order });
            }
        }
        Ok(())
    }
}

/// Why cleaning settings are refused; the message names the bad setting.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CleanConfigError {
    /// The resampling step is not positive.
    #[error("dt = {dt} must be positive")]
    Dt {
        /// The step (s).
        dt: f64,
    },
    /// The largest gap is shorter than one step.
    #[error("max_gap_s = {max_gap_s} must be ≥ dt")]
    MaxGap {
        /// The setting (s).
        max_gap_s: f64,
    },
    /// The idle speed is negative.
    #[error("idle_speed = {idle_speed} must be ≥ 0")]
    IdleSpeed {
        /// The setting (rad/s or m/s).
        idle_speed: f64,
    },
    /// The idle time that splits a recording is not positive.
    #[error("split_idle_s = {split_idle_s} must be positive")]
    SplitIdle {
        /// The setting (s).
        split_idle_s: f64,
    },
    /// The Savitzky–Golay window cannot fit a polynomial of the order asked for.
    #[error(
        "Savitzky–Golay half_window = {half_window}, order = {order}: need 1 ≤ order ≤ 4 and 2·half_window ≥ order"
    )]
    SavitzkyGolay {
        /// Half window (samples).
        half_window: usize,
        /// Polynomial order.
        order: usize,
    },
}

/// One clean demonstration on a uniform grid.
#[derive(Debug, Clone, PartialEq)]
pub struct CleanDemo {
    /// Grid step (s).
    pub dt: f64,
    /// Joints (columns).
    pub n: usize,
    /// Time of the first sample in the recording (s since its first stamp).
    pub start_s: f64,
    /// Positions, row-major `len × n` (rad or m).
    pub q: Vec<f64>,
    /// Velocities, row-major `len × n` (rad/s or m/s).
    pub qdot: Vec<f64>,
}

impl CleanDemo {
    /// Samples.
    pub fn len(&self) -> usize {
        self.q.len() / self.n.max(1)
    }

    /// True without samples.
    pub fn is_empty(&self) -> bool {
        self.q.is_empty()
    }
}

/// What cleaning did to one recording.
#[derive(Debug, Clone, PartialEq)]
pub struct CleanReport {
    /// Largest step between stamps (s).
    pub max_gap_s: f64,
    /// Samples on the uniform grid before trimming.
    pub resampled: usize,
    /// Idle time cut at the start and at the end (s).
    pub trimmed_s: (f64, f64),
    /// Demonstrations found (1 unless split).
    pub segments: usize,
    /// Largest joint speed (rad/s or m/s) and its joint index.
    pub peak_speed: (f64, usize),
    /// Smallest distance to a joint limit over the kept samples (negative: outside), and
    /// its joint index; `None` without limits.
    pub min_margin: Option<(f64, usize)>,
    /// Kept samples with some joint outside its limits.
    pub outside_limits: usize,
}

/// Why a recording could not be cleaned.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CleanError {
    /// Invalid settings.
    #[error("cleaning settings: {message}")]
    Settings {
        /// What is wrong.
        message: String,
    },
    /// A dropout longer than allowed.
    #[error("a gap of {gap_s:.3} s at t = {at_s:.3} s (more than max_gap_s = {max_s} s)")]
    Gap {
        /// Its length (s).
        gap_s: f64,
        /// Where it starts (s since the first stamp).
        at_s: f64,
        /// The limit (s).
        max_s: f64,
    },
    /// Nothing moves (every sample idle) or too few samples for the differentiator.
    #[error("{message}")]
    NoMotion {
        /// What was found.
        message: String,
    },
}

/// Linear resampling of `rec` onto `t = iΔt` (`dt` in s), refusing gaps over `cfg.max_gap_s`:
/// positions row-major `len × n` (rad or m) and the largest stamp step (s).
pub fn resample(
    rec: &JointRecording,
    dt: f64,
    cfg: &CleanConfig,
) -> Result<(Vec<f64>, f64), CleanError> {
    let n = rec.joints.len();
    let mut max_gap = 0.0f64;
    for (k, w) in rec.t.windows(2).enumerate() {
        let g = w[1] - w[0];
        if g > cfg.max_gap_s {
            return Err(CleanError::Gap {
                gap_s: g,
                at_s: rec.t[k],
                max_s: cfg.max_gap_s,
            });
        }
        max_gap = max_gap.max(g);
    }
    let len = (rec.duration() / dt + 1e-9).floor() as usize + 1;
    let mut q = Vec::with_capacity(len * n);
    let mut k = 0;
    for i in 0..len {
        let t = i as f64 * dt;
        while k + 2 < rec.len() && rec.t[k + 1] <= t {
            k += 1;
        }
        if rec.len() == 1 {
            q.extend_from_slice(rec.q(0));
            continue;
        }
        let (t0, t1) = (rec.t[k], rec.t[k + 1]);
        let a = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
        for (x0, x1) in rec.q(k).iter().zip(rec.q(k + 1)) {
            q.push(x0 + a * (x1 - x0));
        }
    }
    Ok((q, max_gap))
}

/// Savitzky–Golay derivative weights for a window of `w` samples evaluated at position
/// `c` (0-based within the window), degree `p`, step `dt`: `q̇ = Σ_m weights[m] q_m`.
pub fn savitzky_golay_weights(w: usize, c: usize, p: usize, dt: f64) -> Vec<f64> {
    // Abscissae scaled to |τ| ≤ 1 keep VᵀV well conditioned for any window length.
    let s = w as f64;
    let v = nalgebra::DMatrix::from_fn(w, p + 1, |m, r| ((m as f64 - c as f64) / s).powi(r as i32));
    let vtv = v.transpose() * &v;
    let inv = vtv
        .try_inverse()
        .expect("VᵀV of w > p distinct nodes in [−1, 1] is invertible");
    let rows = inv * v.transpose();
    (0..w).map(|m| rows[(1, m)] / (s * dt)).collect()
}

/// Velocities of a uniform series `q` (`len × n`, step `dt`).
pub fn differentiate(q: &[f64], n: usize, dt: f64, d: Differentiator) -> Vec<f64> {
    let len = q.len() / n.max(1);
    let mut out = vec![0.0; q.len()];
    if len < 2 {
        return out;
    }
    match d {
        Differentiator::FiniteDifference => {
            for i in 0..len {
                let (a, b) = if i == 0 {
                    (0, 1)
                } else if i == len - 1 {
                    (len - 2, len - 1)
                } else {
                    (i - 1, i + 1)
                };
                for j in 0..n {
                    out[i * n + j] = (q[b * n + j] - q[a * n + j]) / ((b - a) as f64 * dt);
                }
            }
        }
        Differentiator::SavitzkyGolay { half_window, order } => {
            let w = (2 * half_window + 1).min(len);
            let p = order.min(w - 1);
            // One weight vector per position in the window (ends use shifted windows).
            let weights: Vec<Vec<f64>> = (0..w)
                .map(|c| savitzky_golay_weights(w, c, p, dt))
                .collect();
            for i in 0..len {
                let start = i.saturating_sub(w / 2).min(len - w);
                let wt = &weights[i - start];
                for j in 0..n {
                    out[i * n + j] = wt
                        .iter()
                        .enumerate()
                        .map(|(m, c)| c * q[(start + m) * n + j])
                        .sum();
                }
            }
        }
    }
    out
}

/// Cleans a recording into demonstrations sampled every `dt` (s) (one, or one per motion
/// when split), with a report; `limits` (configured joint order) flags samples outside them.
pub fn clean(
    rec: &JointRecording,
    dt: f64,
    cfg: &CleanConfig,
    limits: Option<&[JointLimits]>,
) -> Result<(Vec<CleanDemo>, CleanReport), CleanError> {
    cfg.validate(dt).map_err(|e| CleanError::Settings {
        message: e.to_string(),
    })?;
    let n = rec.joints.len();
    let (q, max_gap) = resample(rec, dt, cfg)?;
    let len = q.len() / n.max(1);
    if len < 3 {
        return Err(CleanError::NoMotion {
            message: format!("{len} samples at Δt = {} s: too short to differentiate", dt),
        });
    }
    let qdot = differentiate(&q, n, dt, cfg.differentiator);
    let moving: Vec<bool> = (0..len)
        .map(|i| {
            qdot[i * n..(i + 1) * n]
                .iter()
                .any(|v| v.abs() >= cfg.idle_speed)
        })
        .collect();
    let Some(first) = moving.iter().position(|&m| m) else {
        return Err(CleanError::NoMotion {
            message: format!(
                "no joint moves faster than idle_speed = {} over {:.3} s",
                cfg.idle_speed,
                rec.duration()
            ),
        });
    };
    let last = moving.iter().rposition(|&m| m).expect("some sample moves");
    // Keep the last idle sample before motion and the first idle one after it.
    let (a, b) = (first.saturating_sub(1), (last + 1).min(len - 1));
    let ranges = motion_ranges(&moving, a, b, cfg.split_idle_s, dt);
    let mut demos = Vec::new();
    let mut seen = Extremes::default();
    for &(s, e) in &ranges {
        for i in s..=e {
            seen.observe(&q[i * n..(i + 1) * n], &qdot[i * n..(i + 1) * n], limits);
        }
        demos.push(CleanDemo {
            dt,
            n,
            start_s: s as f64 * dt,
            q: q[s * n..(e + 1) * n].to_vec(),
            qdot: qdot[s * n..(e + 1) * n].to_vec(),
        });
    }
    let report = CleanReport {
        max_gap_s: max_gap,
        resampled: len,
        trimmed_s: (a as f64 * dt, (len - 1 - b) as f64 * dt),
        segments: demos.len(),
        peak_speed: (seen.peak, seen.peak_j),
        min_margin: seen.margin,
        outside_limits: seen.outside,
    };
    Ok((demos, report))
}

/// The motion `a..=b` as one range, or split at idle runs of at least `split_idle_s` (s).
fn motion_ranges(
    moving: &[bool],
    a: usize,
    b: usize,
    split_idle_s: Option<f64>,
    dt: f64,
) -> Vec<(usize, usize)> {
    // Segments: split at idle runs longer than split_idle_s.
    let mut ranges = vec![(a, b)];
    if let Some(split) = split_idle_s {
        let min_run = (split / dt).ceil() as usize;
        ranges.clear();
        let (mut start, mut i) = (a, a + 1);
        while i <= b {
            if !moving[i] {
                let run_start = i;
                while i <= b && !moving[i] {
                    i += 1;
                }
                if i <= b && i - run_start >= min_run {
                    ranges.push((start, run_start));
                    start = i - 1;
                }
            } else {
                i += 1;
            }
        }
        ranges.push((start, b));
    }
    ranges
}

/// The peak speed and the limit margins seen over the kept samples.
#[derive(Default)]
struct Extremes {
    peak: f64,
    peak_j: usize,
    margin: Option<(f64, usize)>,
    outside: usize,
}

impl Extremes {
    /// Takes in one sample's positions `q` and velocities `qdot`.
    fn observe(&mut self, q: &[f64], qdot: &[f64], limits: Option<&[JointLimits]>) {
        let n = q.len();
        for j in 0..n {
            let v = qdot[j].abs();
            if v > self.peak {
                (self.peak, self.peak_j) = (v, j);
            }
        }
        if let Some(l) = limits {
            let mut out = false;
            for (j, lj) in l.iter().enumerate().take(n) {
                let x = q[j];
                let m = (x - lj.lower).min(lj.upper - x);
                out |= m < 0.0;
                if self.margin.is_none_or(|(best, _)| m < best) {
                    self.margin = Some((m, j));
                }
            }
            self.outside += usize::from(out);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn recording(t: Vec<f64>, q: Vec<f64>, n: usize) -> JointRecording {
        JointRecording {
            bag: "test.db3".into(),
            topic: "/joint_states".into(),
            joints: (0..n).map(|j| format!("j{j}")).collect(),
            t,
            start_ns: 0,
            q,
            ignored: vec![],
        }
    }

    /// Savitzky–Golay weights differentiate polynomials up to their degree exactly, at
    /// every window position (checked against the analytic derivative).
    #[test]
    fn savitzky_golay_is_exact_on_polynomials_of_its_degree() {
        let dt = 0.01;
        for c in 0..7 {
            let w = savitzky_golay_weights(7, c, 2, dt);
            let f = |m: usize| {
                let t = m as f64 * dt;
                1.0 + 2.0 * t - 3.0 * t * t
            };
            let d: f64 = w.iter().enumerate().map(|(m, wm)| wm * f(m)).sum();
            let exact = 2.0 - 6.0 * (c as f64 * dt);
            assert!((d - exact).abs() < 1e-9, "c = {c}: {d} vs {exact}");
        }
    }

    /// `differentiate` is exact on a quadratic at every sample, the first and last `h`
    /// included (where the window is shifted inside the record).
    #[test]
    fn savitzky_golay_series_is_exact_to_the_ends() {
        let dt = 0.02;
        let q: Vec<f64> = (0..40)
            .flat_map(|i| {
                let t = i as f64 * dt;
                [0.3 - t + 2.0 * t * t, 5.0 * t]
            })
            .collect();
        let d = differentiate(
            &q,
            2,
            dt,
            Differentiator::SavitzkyGolay {
                half_window: 3,
                order: 2,
            },
        );
        for i in 0..40 {
            let t = i as f64 * dt;
            assert!(
                (d[2 * i] - (-1.0 + 4.0 * t)).abs() < 1e-9,
                "sample {i}: {}",
                d[2 * i]
            );
            assert!((d[2 * i + 1] - 5.0).abs() < 1e-9, "sample {i}");
        }
    }

    /// On encoder-like noise (σ = 1 mrad at 500 Hz) the smoothing differentiator's error
    /// against the analytic velocity is several times smaller than the finite difference's.
    #[test]
    fn smoothing_beats_the_finite_difference_on_noisy_positions() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let dt = 0.002;
        let len = 2000;
        let truth = |t: f64| 0.5 * (1.3 * t).sin();
        let vel = |t: f64| 0.65 * (1.3 * t).cos();
        let q: Vec<f64> = (0..len)
            .map(|i| {
                // Box–Muller normal noise, σ = 1e-3.
                let (u1, u2): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random());
                let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                truth(i as f64 * dt) + 1e-3 * z
            })
            .collect();
        let rms = |v: &[f64]| {
            (v.iter()
                .enumerate()
                .map(|(i, x)| (x - vel(i as f64 * dt)).powi(2))
                .sum::<f64>()
                / v.len() as f64)
                .sqrt()
        };
        let fd = rms(&differentiate(&q, 1, dt, Differentiator::FiniteDifference));
        let sg = rms(&differentiate(
            &q,
            1,
            dt,
            Differentiator::SavitzkyGolay {
                half_window: 25,
                order: 2,
            },
        ));
        eprintln!("velocity RMS error, σ = 1 mrad at 500 Hz: finite difference {fd:.4} rad/s, Savitzky–Golay (h = 25, p = 2) {sg:.4} rad/s");
        // σ/(√2 Δt) = 0.354 rad/s for the finite difference (theory).
        assert!((fd - 0.354).abs() < 0.05, "finite difference {fd}");
        assert!(
            sg < fd / 5.0,
            "Savitzky–Golay {sg} vs finite difference {fd}"
        );
    }

    /// Idle start and end are cut (keeping the start state and the arrival), gaps refused,
    /// resampling lands on the recorded values at stamps on the grid.
    #[test]
    fn trimming_resampling_and_gaps() {
        // 1 s idle, 2 s motion (q = t − 1 on joint 0), 1 s idle; stamps every 4 ms.
        let t: Vec<f64> = (0..=1000).map(|k| k as f64 * 0.004).collect();
        let q: Vec<f64> = t
            .iter()
            .flat_map(|&t| [(t - 1.0).clamp(0.0, 2.0), 0.3])
            .collect();
        let rec = recording(t.clone(), q, 2);
        let cfg = CleanConfig {
            differentiator: Differentiator::FiniteDifference,
            ..Default::default()
        };
        let (demos, rep) = clean(&rec, 0.01, &cfg, None).unwrap();
        assert_eq!(demos.len(), 1);
        let d = &demos[0];
        // Starts at the last idle sample before motion (t = 1.00), ends at the first idle
        // one after it (t = 3.00 + 0.01).
        assert!((d.start_s - 1.0).abs() < 0.011, "{}", d.start_s);
        assert!((rep.trimmed_s.0 - 1.0).abs() < 0.011);
        assert!((rep.trimmed_s.1 - 1.0).abs() < 0.011);
        assert!((d.q[0] - 0.0).abs() < 1e-9);
        assert!((d.q[(d.len() - 1) * 2] - 2.0).abs() < 1e-9);
        assert!((rep.peak_speed.0 - 1.0).abs() < 1e-6 && rep.peak_speed.1 == 0);
        // A 0.2 s dropout is refused.
        let mut t2 = t.clone();
        for v in &mut t2[500..] {
            *v += 0.2;
        }
        let rec2 = recording(t2, rec.q.clone(), 2);
        assert!(matches!(
            clean(&rec2, 0.01, &cfg, None),
            Err(CleanError::Gap { .. })
        ));
        // Nothing moves.
        let still = recording(t, vec![0.1; 2002], 2);
        assert!(matches!(
            clean(&still, 0.01, &cfg, None),
            Err(CleanError::NoMotion { .. })
        ));
    }

    /// Two motions separated by 1 s of stillness become two demonstrations when asked.
    #[test]
    fn splitting_at_idle_periods() {
        let t: Vec<f64> = (0..=500).map(|k| k as f64 * 0.01).collect();
        let q: Vec<f64> = t
            .iter()
            .map(|&t| (t - 0.5).clamp(0.0, 1.0) + (t - 2.5).clamp(0.0, 1.0))
            .collect();
        let rec = recording(t, q, 1);
        let mut cfg = CleanConfig {
            differentiator: Differentiator::FiniteDifference,
            ..Default::default()
        };
        assert_eq!(clean(&rec, 0.01, &cfg, None).unwrap().0.len(), 1);
        cfg.split_idle_s = Some(0.5);
        let (demos, rep) = clean(&rec, 0.01, &cfg, None).unwrap();
        assert_eq!(rep.segments, 2);
        assert!((demos[0].start_s - 0.5).abs() < 0.011);
        assert!(
            (demos[1].start_s - 2.5).abs() < 0.021,
            "{}",
            demos[1].start_s
        );
        let end0 = demos[0].q[demos[0].len() - 1];
        assert!((end0 - 1.0).abs() < 1e-9);
    }
}
