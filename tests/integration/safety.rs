//! Safety filter properties over random and adversarial inputs: outputs are finite and
//! inside every limit, the fast path returns `v` exactly, and a closed loop driven by a
//! hostile policy never leaves the joint range.

use crossym::kinematics::JointLimits;
use crossym::safety::{Barrier, SafetyFilter, SafetySettings, SafetyStatus};
use nalgebra::DMatrix;
use rand::Rng;

use crate::common;

fn check_output(
    filter: &SafetyFilter,
    limits: &[JointLimits],
    q: &[f64],
    prev: &[f64],
    out: &[f64],
    dt: f64,
    settings: &SafetySettings,
) {
    let (lo, hi) = filter.bounds();
    for i in 0..out.len() {
        assert!(out[i].is_finite(), "non-finite output {out:?}");
        assert!(
            out[i].abs() <= limits[i].velocity + 1e-12,
            "velocity limit joint {i}: {}",
            out[i]
        );
        assert!(
            out[i] >= lo[i] - 1e-12 && out[i] <= hi[i] + 1e-12,
            "outside bounds joint {i}"
        );
        let a = limits[i]
            .acceleration
            .unwrap_or(settings.default_acceleration);
        // Inside the range: one period then full braking stops before the (margin-shrunk) limit.
        if q[i] <= limits[i].upper - settings.margin && out[i] > 0.0 {
            assert!(
                q[i] + out[i] * dt + out[i] * out[i] / (2.0 * a)
                    <= limits[i].upper - settings.margin + 1e-9,
                "braking upper joint {i}"
            );
        }
        if q[i] >= limits[i].lower + settings.margin && out[i] < 0.0 {
            assert!(
                q[i] + out[i] * dt - out[i] * out[i] / (2.0 * a)
                    >= limits[i].lower + settings.margin - 1e-9,
                "braking lower joint {i}"
            );
        }
        let _ = prev;
    }
}

fn rby1_like_limits(n: usize) -> Vec<JointLimits> {
    (0..n)
        .map(|i| JointLimits {
            lower: -1.0 - 0.2 * i as f64,
            upper: 0.5 + 0.3 * i as f64,
            velocity: 1.0 + 0.5 * (i % 3) as f64,
            effort: 10.0,
            acceleration: if i % 4 == 0 { None } else { Some(10.0) },
        })
        .collect()
}

#[test]
fn random_and_adversarial_inputs_give_safe_finite_commands() {
    let mut rng = common::rng(30);
    for &(n, with_jac) in &[(8usize, false), (8, true), (14, true)] {
        let limits = rby1_like_limits(n);
        let settings = SafetySettings::default();
        let mut filter = SafetyFilter::new(&limits, settings).unwrap();
        let mut out = vec![0.0; n];
        for trial in 0..400 {
            let q: Vec<f64> = limits
                .iter()
                .map(|l| rng.random_range(l.lower..l.upper))
                .collect();
            let v: Vec<f64> = (0..n)
                .map(|i| match (trial + i) % 7 {
                    0 => f64::NAN,
                    1 => 1e9,
                    2 => -1e9,
                    3 => f64::INFINITY,
                    _ => rng.random_range(-5.0..5.0),
                })
                .collect();
            let jac = DMatrix::from_fn(4, n, |_, _| rng.random_range(-3.0..3.0));
            let prev = filter.last_command().to_vec();
            let rep = filter.filter(&q, &v, with_jac.then_some(&jac), None, &mut out);
            assert!(rep.policy_nonfinite || v.iter().all(|x| x.is_finite()));
            assert_ne!(rep.status, SafetyStatus::InvalidState);
            check_output(&filter, &limits, &q, &prev, &out, settings.dt, &settings);
        }
        // Non-finite state: a braking command, still finite and within velocity limits.
        let q = vec![f64::NAN; n];
        let rep = filter.filter(&q, &vec![1.0; n], None, None, &mut out);
        assert_eq!(rep.status, SafetyStatus::InvalidState);
        assert!(out
            .iter()
            .zip(&limits)
            .all(|(x, l)| x.is_finite() && x.abs() <= l.velocity));
    }
}

#[test]
fn fast_path_returns_the_policy_output_exactly() {
    let limits = rby1_like_limits(8);
    let mut filter = SafetyFilter::new(&limits, SafetySettings::default()).unwrap();
    let q = vec![0.0; 8];
    let v = [0.05, -0.03, 0.01, 0.0, -0.07, 0.02, 0.09, -0.01];
    let mut out = vec![0.0; 8];
    let jac = DMatrix::from_fn(4, 8, |r, c| (r + c) as f64 * 0.1);
    let rep = filter.filter(&q, &v, Some(&jac), None, &mut out);
    assert_eq!(rep.status, SafetyStatus::Passthrough);
    assert_eq!(out, v, "bit-exact pass-through");
    assert_eq!(rep.iterations, 0);
}

#[test]
fn hostile_policy_never_drives_a_joint_out_of_range() {
    let limits = rby1_like_limits(14);
    let settings = SafetySettings::default();
    let mut filter = SafetyFilter::new(&limits, settings).unwrap();
    let mut rng = common::rng(31);
    let mut q: Vec<f64> = limits.iter().map(|l| 0.5 * (l.lower + l.upper)).collect();
    let mut out = vec![0.0; 14];
    let jac = DMatrix::from_fn(6, 14, |_, _| rng.random_range(-1.0..1.0));
    for tick in 0..3000 {
        // Push every joint toward a limit at absurd speed, switching sides now and then.
        let side = if (tick / 500) % 2 == 0 { 1e9 } else { -1e9 };
        let v: Vec<f64> = (0..14)
            .map(|i| if i % 2 == 0 { side } else { -side })
            .collect();
        let prev = filter.last_command().to_vec();
        let rep = filter.filter(&q, &v, Some(&jac), None, &mut out);
        assert_ne!(rep.status, SafetyStatus::InvalidState);
        check_output(&filter, &limits, &q, &prev, &out, settings.dt, &settings);
        for i in 0..14 {
            let a = limits[i]
                .acceleration
                .unwrap_or(settings.default_acceleration);
            // Acceleration is respected unless braking had to override it.
            if rep.accel_overridden == 0 {
                assert!(
                    (out[i] - prev[i]).abs() <= a * settings.dt + 1e-9,
                    "acceleration joint {i}"
                );
            }
            q[i] += out[i] * settings.dt;
            assert!(
                q[i] <= limits[i].upper && q[i] >= limits[i].lower,
                "tick {tick}: joint {i} at {} outside [{}, {}]",
                q[i],
                limits[i].lower,
                limits[i].upper
            );
        }
    }
}

#[test]
fn jacobian_weighting_keeps_the_end_effector_direction() {
    // Two joints, task = sum of both: when joint 0 saturates, W = JᵀJ makes joint 1 make up
    // the task velocity, where a plain clamp would lose it.
    let limits = vec![
        JointLimits {
            lower: -3.0,
            upper: 3.0,
            velocity: 0.5,
            effort: 1.0,
            acceleration: Some(1e3),
        },
        JointLimits {
            lower: -3.0,
            upper: 3.0,
            velocity: 2.0,
            effort: 1.0,
            acceleration: Some(1e3),
        },
    ];
    let mut filter = SafetyFilter::new(
        &limits,
        SafetySettings {
            weight_epsilon: 1e-6,
            ..Default::default()
        },
    )
    .unwrap();
    let jac = DMatrix::from_row_slice(1, 2, &[1.0, 1.0]);
    let mut out = vec![0.0; 2];
    let rep = filter.filter(&[0.0, 0.0], &[1.0, 0.2], Some(&jac), None, &mut out);
    assert_eq!(rep.status, SafetyStatus::Filtered);
    // W = JᵀJ + εI is nearly singular along (1, −1): the interior-point optimum sits
    // within solver tolerance of the bound.
    assert!(out[0] <= 0.5 && out[0] > 0.49, "{out:?}");
    assert!(
        (out[0] + out[1] - 1.2).abs() < 1e-4,
        "task velocity kept: {out:?}"
    );
    assert!(rep.iterations > 0);
}

#[test]
fn distance_barrier_slows_approach() {
    let limits = vec![
        JointLimits {
            lower: -3.0,
            upper: 3.0,
            velocity: 2.0,
            effort: 1.0,
            acceleration: Some(1e3)
        };
        2
    ];
    let settings = SafetySettings {
        min_ee_distance: Some(0.1),
        barrier_gain: 5.0,
        ..Default::default()
    };
    let mut filter = SafetyFilter::new(&limits, settings).unwrap();
    // h = 0.02 above the minimum distance, and the policy closes it at 1.0/s: ḣ = −(x0 + x1).
    let grad = [-1.0, -1.0];
    let mut out = vec![0.0; 2];
    let rep = filter.filter(
        &[0.0, 0.0],
        &[0.5, 0.5],
        None,
        Some(Barrier {
            gradient: &grad,
            value: 0.02,
        }),
        &mut out,
    );
    assert_eq!(rep.status, SafetyStatus::Filtered);
    let hdot: f64 = grad.iter().zip(&out).map(|(g, x)| g * x).sum();
    assert!(hdot >= -5.0 * 0.02 - 1e-6, "barrier violated: ḣ = {hdot}");
    // Moving apart is untouched.
    let rep = filter.filter(
        &[0.0, 0.0],
        &[-0.5, -0.5],
        None,
        Some(Barrier {
            gradient: &grad,
            value: 0.02,
        }),
        &mut out,
    );
    assert_eq!(rep.status, SafetyStatus::Passthrough);
}

#[test]
fn bad_settings_are_rejected_with_the_key() {
    let limits = rby1_like_limits(2);
    for (s, key) in [
        (
            SafetySettings {
                dt: 0.0,
                ..Default::default()
            },
            "dt",
        ),
        (
            SafetySettings {
                margin: f64::NAN,
                ..Default::default()
            },
            "margin",
        ),
        (
            SafetySettings {
                min_ee_distance: Some(-1.0),
                ..Default::default()
            },
            "min_ee_distance",
        ),
    ] {
        let e = SafetyFilter::new(&limits, s).err().expect("rejected");
        assert!(e.to_string().contains(key), "{e}");
    }
    let mut unbounded = limits.clone();
    unbounded[1].velocity = f64::INFINITY;
    assert!(SafetyFilter::new(&unbounded, SafetySettings::default())
        .err()
        .unwrap()
        .to_string()
        .contains("velocity"));
}
