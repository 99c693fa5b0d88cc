//! A joint-space trajectory `q(t)` sampled at a fixed period, with its velocities and the
//! nominal task-space path `x = f(q)`: what demonstrations, rollouts and the node's
//! scenarios exchange, stored row-major (one sample per row).

/// A joint-space demonstration with its nominal task-space path.
#[derive(Debug, Clone, PartialEq)]
pub struct JointTrajectory {
    /// 1-based demonstration number it came from (0: none, e.g. a policy rollout).
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
