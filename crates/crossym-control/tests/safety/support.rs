//! What the safety tests share: proptest's settings and a robot's joints.

use crossym_math::kinematics::JointLimits;
use proptest::prelude::*;
use proptest::test_runner::{Config as ProptestConfig, RngSeed};

/// Fixed seed, fixed case count, no persistence files in the tree.
pub fn config(cases: u32) -> ProptestConfig {
    ProptestConfig {
        cases,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(54),
        ..ProptestConfig::default()
    }
}

/// A joint with a position range of `width` from `lower` (rad), a velocity limit and,
/// or not, an acceleration limit.
pub fn joint(width: std::ops::Range<f64>) -> impl Strategy<Value = JointLimits> {
    (
        -2.0..-0.05f64,
        width,
        0.1..3.0f64,
        prop_oneof![Just(None), (0.5..50.0f64).prop_map(Some)],
    )
        .prop_map(|(lower, width, velocity, acceleration)| JointLimits {
            lower,
            upper: lower + width,
            velocity,
            effort: 1.0,
            acceleration,
        })
}

/// The acceleration limit the filter must keep for `l`: its own, else the default.
pub fn accel(l: &JointLimits, default: f64) -> f64 {
    l.acceleration.unwrap_or(default)
}

/// `n` joints of range ±1 rad with `velocity` (rad/s) and `acceleration` (rad/s²) limits.
pub fn unit_range(n: usize, velocity: f64, acceleration: Option<f64>) -> Vec<JointLimits> {
    let l = JointLimits {
        lower: -1.0,
        upper: 1.0,
        velocity,
        effort: 1.0,
        acceleration,
    };
    vec![l; n]
}
