//! The adversarial policies an episode can draw instead of the real one, as overrides of
//! the node's policy output.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

use crossym_control::node::PolicyOverride;

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

    /// The override of the policy's output for this adversary (`None` for the real
    /// policy): `vmax` the episode's velocity limits, `signs` one drawn sign per joint, its
    /// own random stream from `seed`.
    pub(super) fn policy_override(
        self,
        vmax: Vec<f64>,
        signs: Vec<f64>,
        seed: u64,
    ) -> Option<PolicyOverride> {
        if self == Adversary::Real {
            return None;
        }
        let adversary = self;
        let mut arng = StdRng::seed_from_u64(seed ^ 0xAD5E);
        Some(Box::new(move |tick, _q, v| {
            for j in 0..v.len() {
                v[j] = match adversary {
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
        }))
    }
}
