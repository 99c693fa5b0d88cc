//! What we ship, pinned: each shipped policy file scored on a fixed subset of its test
//! transformations (one test demonstration under a few conditions, the whole trajectory,
//! task-space RMSE per coordinate as `crossym eval` reports it), against the values these
//! files gave when they were shipped (measured 2026-12-03). A retrained, corrupted or
//! swapped policy file, or a change of the rollout, moves them; the tolerance (1e-6
//! relative) lets a change of floating-point order pass and nothing else.
//!
//! The set-level figures of docs/guide/paper.md (Table II of each protocol) cover whole test sets
//! and take minutes in release; these subsets take seconds in a test build. The paper's
//! resampled protocol is pinned on a hand-computed example below.

use crossym::eval::paper::{resample, resampled_rmse};
use crossym::eval::{score, EvalConfig};
use crossym::symmetry::compose::Condition;

use super::common;

/// `config`'s first test demonstration under each `theta_deg:scale:reflection` of
/// `conditions`, rolled out by `policy` (a file in `data/policies/`): the RMSE of each.
fn scores(config: &str, policy: &str, conditions: &[(f64, f64, i8)]) -> Vec<f64> {
    let (cfg, robot, demos) = common::task(config);
    let kin = &robot.kinematics;
    let file = common::path("data/policies").join(policy);
    let p = crossym::pipeline::load_any_policy(&cfg, kin, &file)
        .unwrap_or_else(|e| panic!("{policy}: {e}"));
    let demo = crossym::pipeline::pick_demo(&demos, None).unwrap();
    let conds: Vec<Condition> = conditions
        .iter()
        .map(|&(deg, scale, reflection)| Condition {
            theta: deg.to_radians(),
            scale,
            reflection,
        })
        .collect();
    let nominal = crossym::pipeline::nominal_trajectories(&cfg, kin, demo, &conds)
        .unwrap_or_else(|e| panic!("{config}: {e}"));
    nominal
        .iter()
        .map(|a| score(&p, kin, &a.traj, &a.condition, &EvalConfig::default()).rmse)
        .collect()
}

/// `got` equals the pinned `want` to 1e-6 relative, per entry.
fn assert_pinned(what: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= 1e-6 * w.abs(),
            "{what}, condition {i}: {g:.9} where the shipped policy gave {w:.9} (all: {got:?})"
        );
    }
}

const PLANAR: &[(f64, f64, i8)] = &[(0.0, 1.0, 1), (30.0, 0.8, 1), (90.0, 0.5, -1)];

#[test]
fn shipped_planar_policies_score_as_shipped() {
    for (policy, want) in [
        ("pi_mrt_head_planar.safetensors", PIN_HEAD),
        ("pi_mrt_planar.safetensors", PIN_JOINT),
        ("pi_eq_planar.safetensors", PIN_EQ),
    ] {
        assert_pinned(policy, &scores("letters.toml", policy, PLANAR), want);
    }
}

#[test]
fn shipped_rby1_policies_score_as_shipped() {
    if common::rby1_urdf().is_none() {
        return;
    }
    let letters = scores(
        "rby1-letters.toml",
        "pi_mrt_rby1_letters.safetensors",
        PLANAR,
    );
    assert_pinned("pi_mrt_rby1_letters", &letters, PIN_RBY1_LETTERS);
    let pan = scores(
        "rby1-pan.toml",
        "pi_mr_rby1_pan.safetensors",
        &[(15.0, 1.0, 1), (-30.0, 1.0, -1)],
    );
    assert_pinned("pi_mr_rby1_pan", &pan, PIN_RBY1_PAN);
    // The task-space heads, as every command loads them: with their configs'
    // `[redundancy]` null-space term in the lift.
    let head = scores(
        "rby1-letters.toml",
        "pi_mrt_head_rby1_letters.safetensors",
        PLANAR,
    );
    assert_pinned("pi_mrt_head_rby1_letters", &head, PIN_RBY1_LETTERS_HEAD);
    let pan_head = scores(
        "rby1-pan.toml",
        "pi_mr_head_rby1_pan.safetensors",
        &[(15.0, 1.0, 1), (-30.0, 1.0, -1)],
    );
    assert_pinned("pi_mr_head_rby1_pan", &pan_head, PIN_RBY1_PAN_HEAD);
}

// Measured 2026-12-03 with the shipped files (first test demonstration; conditions as
// above; the planar letters in the drawing's units, RB-Y1 in m). The planar values are this
// one demonstration's, above the set means of Table II (docs/guide/paper.md).
const PIN_HEAD: &[f64] = &[0.3690958861141967, 0.2950935888826398, 0.1841210756467762];
const PIN_JOINT: &[f64] = &[0.4370075015693828, 0.3158491804252665, 0.23260330907162316];
const PIN_EQ: &[f64] = &[0.25507247958168766, 0.20399886634311154, 0.1271577488179666];
const PIN_RBY1_LETTERS: &[f64] = &[
    0.019453426113392232,
    0.014065561396984018,
    0.011675511343040713,
];
const PIN_RBY1_PAN: &[f64] = &[0.011041646507939866, 0.021858430966004646];
// Measured 2026-12-04 with the heads shipped that day.
const PIN_RBY1_LETTERS_HEAD: &[f64] = &[
    0.015627473495893544,
    0.01248939286059583,
    0.007811563389513326,
];
const PIN_RBY1_PAN_HEAD: &[f64] = &[0.01148510624695452, 0.011475971362621865];

/// The resampled (real-robot) protocol on a tiny example computed by hand: a path of 3
/// samples × 1 column resampled to 5 points over normalised time, against a constant
/// nominal.
#[test]
fn resampled_protocol_matches_a_hand_computation() {
    // Executed [0, 2, 6] at u = 0, 0.5, 1 → at u = 0, .25, .5, .75, 1: 0, 1, 2, 4, 6.
    let exe = resample(&[0.0, 2.0, 6.0], 1, 5);
    assert_eq!(exe, vec![0.0, 1.0, 2.0, 4.0, 6.0]);
    // Nominal [1, 1] → five ones. Differences −1, 0, 1, 3, 5: squares 1, 0, 1, 9, 25 → mean
    // 36 / 5 = 7.2, RMSE √7.2.
    let nom = resample(&[1.0, 1.0], 1, 5);
    let e = resampled_rmse(&exe, &nom, 1, 100.0);
    assert!((e.error - 7.2f64.sqrt()).abs() < 1e-15, "{}", e.error);
    assert!(!e.diverged);
    // Two columns: the RMSE runs over all entries, not per column. Column 2 is 10× column
    // 1's error: squares (1 + 0 + 1 + 9 + 25)(1 + 100) / 10 = 363.6.
    let exe2: Vec<f64> = exe
        .iter()
        .flat_map(|&x| [x, 10.0 * (x - 1.0) + 1.0])
        .collect();
    let nom2 = vec![1.0; 10];
    let e2 = resampled_rmse(&exe2, &nom2, 2, 100.0);
    assert!((e2.error - 363.6f64.sqrt()).abs() < 1e-12, "{}", e2.error);
    // A sample beyond the divergence threshold marks the trajectory diverged.
    assert!(resampled_rmse(&exe, &nom, 1, 4.0).diverged);
}
