//! Sampling the level sets of a cost inside the region of interest.

use super::cost::norm;
use super::cost::Cost;
use super::error::TaskInducedError;
use super::settings::TaskInducedSettings;

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// The sampling box actually used: centre `o`, half-width `ρ`, corners.
pub(super) struct Region {
    lower: Vec<f64>,
    upper: Vec<f64>,
    pub(super) center: Vec<f64>,
    pub(super) radius: f64,
}

/// Usable samples: points and unit normals `∇c/|∇c|`.
pub(super) struct Samples {
    pub(super) points: Vec<Vec<f64>>,
    pub(super) normals: Vec<Vec<f64>>,
}

impl Region {
    pub(super) fn new(cost: &Cost, settings: &TaskInducedSettings) -> Self {
        let d = cost.dim();
        match &settings.region {
            Some(r) => {
                let center: Vec<f64> = (0..d).map(|i| 0.5 * (r.lower[i] + r.upper[i])).collect();
                let radius = (0..d)
                    .map(|i| 0.5 * (r.upper[i] - r.lower[i]))
                    .fold(0.0, f64::max);
                Self {
                    lower: r.lower.clone(),
                    upper: r.upper.clone(),
                    center,
                    radius,
                }
            }
            None => {
                let anchors = cost.anchors();
                let mut center = vec![0.0; d];
                for a in &anchors {
                    for i in 0..d {
                        center[i] += a[i] / anchors.len() as f64;
                    }
                }
                let spread = anchors
                    .iter()
                    .map(|a| {
                        let r: Vec<f64> = (0..d).map(|i| a[i] - center[i]).collect();
                        norm(&r)
                    })
                    .fold(0.0, f64::max);
                let radius = (2.0 * spread).max(1.0);
                Self {
                    lower: center.iter().map(|c| c - radius).collect(),
                    upper: center.iter().map(|c| c + radius).collect(),
                    center,
                    radius,
                }
            }
        }
    }

    /// Draws up to `n` points with a usable gradient (`|∇c| > 1e-8 Σ|w|`), `4n` attempts.
    pub(super) fn sample(
        &self,
        cost: &Cost,
        n: usize,
        seed: u64,
    ) -> Result<Samples, TaskInducedError> {
        let d = cost.dim();
        let mut rng = StdRng::seed_from_u64(seed);
        let floor = 1e-8 * cost.gradient_bound();
        let mut points = Vec::with_capacity(n);
        let mut normals = Vec::with_capacity(n);
        let mut g = vec![0.0; d];
        let mut attempts = 0;
        while points.len() < n && attempts < 4 * n {
            attempts += 1;
            let x: Vec<f64> = (0..d)
                .map(|i| rng.random_range(self.lower[i]..self.upper[i]))
                .collect();
            if !cost.gradient(&x, &mut g) {
                continue;
            }
            let gn = norm(&g);
            if gn.is_nan() || gn <= floor {
                continue;
            }
            normals.push(g.iter().map(|v| v / gn).collect());
            points.push(x);
        }
        let needed = n / 2;
        if points.len() < needed {
            return Err(TaskInducedError::DegenerateCost {
                usable: points.len(),
                needed,
                rejected: attempts - points.len(),
                attempts,
            });
        }
        Ok(Samples { points, normals })
    }
}
