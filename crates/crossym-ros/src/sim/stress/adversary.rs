//! The adversarial policies an episode can draw instead of the real one, as the node
//! core's output stage (the node's own core has the identity stage there).

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crossym_control::node::OutputStage;

/// The adversarial policies an episode can draw instead of the real one.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Adversary {
    /// The trained policy.
    Real,
    /// 10 × the velocity limit toward one bound per joint.
    TowardLimit,
    /// NaN outputs on some ticks.
    Nan,
    /// ±1e9.
    Huge,
    /// ±∞.
    Infinite,
    /// Gaussian noise, 5 × the velocity limit.
    Noise,
    /// ±5 × the velocity limit, the sign flipping every tick.
    SignFlip,
}

pub(super) const ADVERSARIES: [Adversary; 7] = [
    Adversary::Real,
    Adversary::TowardLimit,
    Adversary::Nan,
    Adversary::Huge,
    Adversary::Infinite,
    Adversary::Noise,
    Adversary::SignFlip,
];

impl Adversary {
    /// The name in the report.
    pub fn name(self) -> &'static str {
        match self {
            Adversary::Real => "real policy",
            Adversary::TowardLimit => "toward limit",
            Adversary::Nan => "NaN",
            Adversary::Huge => "±1e9",
            Adversary::Infinite => "±∞",
            Adversary::Noise => "noise",
            Adversary::SignFlip => "sign flips",
        }
    }
}

/// The policy output of an episode: the policy's own, or the drawn adversary's instead.
pub(super) struct AdversaryOutput {
    adversary: Adversary,
    /// The episode's velocity limits.
    vmax: Vec<f64>,
    /// One drawn sign per joint (empty for the real policy).
    signs: Vec<f64>,
    /// The adversary's own random stream.
    rng: StdRng,
}

impl AdversaryOutput {
    /// `adversary` with the episode's velocity limits `vmax`, one drawn sign per joint and
    /// its own random stream from `seed`.
    pub fn new(adversary: Adversary, vmax: Vec<f64>, signs: Vec<f64>, seed: u64) -> Self {
        Self {
            adversary,
            vmax,
            signs,
            rng: StdRng::seed_from_u64(seed ^ 0xAD5E),
        }
    }
}

impl OutputStage for AdversaryOutput {
    fn apply(&mut self, tick: u64, _q: &[f64], v: &mut [f64]) {
        let (vmax, signs, arng) = (&self.vmax, &self.signs, &mut self.rng);
        if self.adversary == Adversary::Real {
            return;
        }
        for j in 0..v.len() {
            v[j] = match self.adversary {
                Adversary::Real => v[j],
                Adversary::TowardLimit => 10.0 * vmax[j] * signs[j],
                Adversary::Nan => {
                    if arng.random_bool(0.5) {
                        f64::NAN
                    } else {
                        10.0 * vmax[j] * signs[j]
                    }
                }
                Adversary::Huge => 1e9 * signs[j],
                Adversary::Infinite => f64::INFINITY * signs[j],
                Adversary::Noise => {
                    let u1: f64 = arng.random::<f64>().max(1e-300);
                    let u2: f64 = arng.random();
                    5.0 * vmax[j]
                        * (-2.0 * u1.ln()).sqrt()
                        * (2.0 * std::f64::consts::PI * u2).cos()
                }
                Adversary::SignFlip => {
                    let s = if tick % 2 == 0 { 1.0 } else { -1.0 };
                    5.0 * vmax[j] * signs[j] * s
                }
            };
        }
    }
}
