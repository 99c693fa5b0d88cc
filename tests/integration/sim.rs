//! The mock hardware's simulation without DDS: integration, latency, drops, noise, faults,
//! resets and the violation log.

use std::collections::BTreeMap;

use crossym::control::OutputMode;
use crossym::sim::{FaultKind, MockHardware, MockHwConfig};

use crate::common;

fn hw(mode: OutputMode, cfg: MockHwConfig) -> MockHardware {
    let robot = common::planar();
    let kin = &robot.kinematics;
    let q0 = vec![0.1; kin.dof()];
    MockHardware::new(
        &robot.model,
        kin.joint_names(),
        kin.limits(),
        &BTreeMap::new(),
        &q0,
        mode,
        cfg,
    )
    .unwrap()
}

#[test]
fn velocity_commands_integrate_and_are_held() {
    let mut h = hw(OutputMode::Velocity, MockHwConfig::default());
    assert_eq!(h.names.len(), 8);
    assert!(h.command(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -0.5]));
    for _ in 0..100 {
        h.step(0.01);
    }
    let q = h.positions();
    assert!((q[0] - 1.1).abs() < 1e-12, "{}", q[0]);
    assert!((q[7] - (0.1 - 0.5)).abs() < 1e-12);
    assert_eq!(q[1], 0.1);
    assert_eq!(h.summary().violation_count, 0);
}

#[test]
fn latency_delays_commands() {
    let mut h = hw(
        OutputMode::Velocity,
        MockHwConfig {
            latency_s: 0.05,
            ..Default::default()
        },
    );
    h.command(&[1.0; 8]);
    for _ in 0..4 {
        h.step(0.01);
    }
    assert_eq!(h.positions()[0], 0.1, "not applied before the latency");
    for _ in 0..6 {
        h.step(0.01);
    }
    // Applied at the step reaching t = 0.05, then integrated for 6 steps.
    assert!(
        (h.positions()[0] - 0.16).abs() < 1e-12,
        "{}",
        h.positions()[0]
    );
}

#[test]
fn invalid_and_dropped_commands_are_counted() {
    let mut h = hw(
        OutputMode::Velocity,
        MockHwConfig {
            drop_probability: 1.0,
            ..Default::default()
        },
    );
    assert!(!h.command(&[1.0; 3]), "wrong length");
    assert!(!h.command(&[f64::NAN; 8]), "non-finite");
    assert!(h.command(&[1.0; 8]));
    h.step(0.01);
    let s = h.summary();
    assert_eq!(
        (s.commands_received, s.commands_invalid, s.commands_dropped),
        (3, 2, 1)
    );
    assert_eq!(h.positions()[0], 0.1, "dropped command not applied");
}

#[test]
fn violations_are_logged_not_prevented() {
    // 2.9 rad/s is within the 3 rad/s limit but runs past the 2π position limit.
    let mut h = hw(OutputMode::Velocity, MockHwConfig::default());
    h.command(&[2.9, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    for _ in 0..300 {
        h.step(0.01);
    }
    let s = h.summary();
    assert!(h.positions()[0] > 2.0 * std::f64::consts::PI, "not clamped");
    assert!(s.violation_count > 0);
    assert!(s.violations.iter().all(|v| v.kind == "position"));
    assert_eq!(s.violations[0].joint, "left_joint1");
    assert!((s.violations[0].bound - 2.0 * std::f64::consts::PI).abs() < 1e-12);

    let mut h = hw(OutputMode::Velocity, MockHwConfig::default());
    h.command(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -5.0]);
    h.step(0.01);
    let s = h.summary();
    assert_eq!(s.violation_count, 1);
    assert_eq!(s.violations[0].kind, "velocity");
    assert_eq!(s.violations[0].joint, "right_joint4");
}

#[test]
fn position_mode_follows_and_reset_teleports() {
    let mut h = hw(OutputMode::Position, MockHwConfig::default());
    h.command(&[0.2; 8]);
    h.step(0.01);
    assert_eq!(h.positions()[3], 0.2);
    assert!(h.reset(&[0.5; 8]));
    assert!(!h.reset(&[0.5; 2]));
    h.step(0.01);
    assert_eq!(h.positions()[3], 0.5, "reset clears the held command");
    assert_eq!(h.summary().resets, 1);
    // Commands issued before the reset was seen (inside the settle window) are discarded.
    h.command(&[0.2; 8]);
    h.step(0.01);
    assert_eq!(h.positions()[3], 0.5);
    assert_eq!(h.summary().commands_discarded, 1);
    for _ in 0..10 {
        h.step(0.01);
    }
    h.command(&[0.3; 8]);
    h.step(0.01);
    assert_eq!(h.positions()[3], 0.3);
}

#[test]
fn faults_freeze_or_silence() {
    let mut frozen = hw(
        OutputMode::Velocity,
        MockHwConfig {
            fault: Some(FaultKind::Frozen),
            fault_after_s: 0.05,
            ..Default::default()
        },
    );
    frozen.command(&[1.0; 8]);
    for _ in 0..20 {
        frozen.step(0.01);
    }
    assert!((frozen.positions()[0] - 0.15).abs() < 1e-9);
    let mut out = Vec::new();
    assert!(frozen.measured(&mut out), "frozen still publishes");

    let mut silent = hw(
        OutputMode::Velocity,
        MockHwConfig {
            fault: Some(FaultKind::Silent),
            fault_after_s: 0.05,
            ..Default::default()
        },
    );
    assert!(silent.measured(&mut out));
    for _ in 0..10 {
        silent.step(0.01);
    }
    assert!(!silent.measured(&mut out), "silent publishes nothing");
}

/// `nan_position` and `missing_joint` corrupt the published state for a window while the
/// robot keeps integrating commands.
#[test]
fn sensor_faults_corrupt_a_window_and_keep_integrating() {
    for kind in [FaultKind::NanPosition, FaultKind::MissingJoint] {
        let mut h = hw(
            OutputMode::Velocity,
            MockHwConfig {
                fault: Some(kind),
                fault_after_s: 0.045,
                fault_duration_s: Some(0.1),
                fault_joint: Some("left_joint2".into()),
                ..Default::default()
            },
        );
        h.command(&[1.0; 8]);
        let (mut names, mut pos) = (Vec::new(), Vec::new());
        let mut faulty = Vec::new();
        for i in 0..30 {
            h.step(0.01);
            assert!(
                h.joint_state(&mut names, &mut pos),
                "{kind:?} still publishes"
            );
            assert_eq!(names.len(), pos.len());
            let bad = match kind {
                FaultKind::NanPosition => {
                    assert_eq!(names.len(), 8);
                    pos[1].is_nan()
                }
                _ => {
                    let missing = !names.iter().any(|n| n == "left_joint2");
                    assert_eq!(names.len(), if missing { 7 } else { 8 });
                    missing
                }
            };
            assert!(pos.iter().filter(|x| x.is_nan()).count() <= usize::from(bad));
            if bad {
                faulty.push(i);
            }
        }
        // Steps 5..=14 end at t = 0.05 … 0.14 s, inside [0.045, 0.145).
        assert_eq!(faulty, (4..14).collect::<Vec<_>>(), "{kind:?}");
        assert_eq!(h.summary().joint_states_faulted, 10);
        assert_eq!(h.summary().fault_started_s, Some(0.045));
        assert!(h.faulted().is_none(), "the window closed");
        assert!(
            (h.positions()[1] - 0.4).abs() < 1e-9,
            "integrated throughout"
        );
    }
}

/// With `fault_near_limit`, the fault begins when a joint moves toward a limit close to it
/// (at >= 25 % of its velocity limit), not before.
#[test]
fn fault_near_limit_waits_for_an_approach() {
    let cfg = MockHwConfig {
        fault: Some(FaultKind::NanPosition),
        fault_near_limit: Some(0.5),
        ..Default::default()
    };
    // Planar limits: ±2π rad, 3 rad/s. Joint 8 runs down at 1 rad/s from 0.1 rad; the NaN
    // goes to the first controlled joint (no `fault_joint`).
    let mut h = hw(OutputMode::Velocity, cfg.clone());
    h.command(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0]);
    let mut out = Vec::new();
    let mut started = None;
    for _ in 0..600 {
        h.step(0.01);
        h.measured(&mut out);
        if started.is_none() && out[0].is_nan() {
            started = Some(h.positions()[7]);
        }
    }
    let q = started.expect("fault started");
    let lower = -2.0 * std::f64::consts::PI;
    assert!(q - lower <= 0.5 && q - lower > 0.48, "started at q = {q}");
    assert_eq!(
        h.summary().fault_trigger_joint.as_deref(),
        Some("right_joint4")
    );
    // Too slow (0.5 rad/s < 0.75 rad/s): no fault even right at the limit.
    let mut h = hw(OutputMode::Velocity, cfg);
    h.command(&[0.5; 8]);
    for _ in 0..1200 {
        h.step(0.01);
    }
    assert!(h.summary().fault_started_s.is_none() && h.faulted().is_none());
}

#[test]
fn noise_has_the_configured_spread() {
    let mut h = hw(
        OutputMode::Velocity,
        MockHwConfig {
            noise_std: 0.01,
            seed: 3,
            ..Default::default()
        },
    );
    let mut out = Vec::new();
    let (mut sum, mut sum2, mut n) = (0.0, 0.0, 0.0);
    for _ in 0..2000 {
        h.measured(&mut out);
        for &x in &out {
            let e = x - 0.1;
            sum += e;
            sum2 += e * e;
            n += 1.0;
        }
    }
    let mean = sum / n;
    let std = (sum2 / n - mean * mean).sqrt();
    assert!(mean.abs() < 1e-3, "mean {mean}");
    assert!((std - 0.01).abs() < 5e-4, "std {std}");
    assert_eq!(h.positions()[0], 0.1, "noise is on the measurement only");
}

#[test]
fn bad_settings_are_refused() {
    let robot = common::planar();
    let kin = &robot.kinematics;
    for (cfg, what) in [
        (
            MockHwConfig {
                rate_hz: 0.0,
                ..Default::default()
            },
            "rate_hz",
        ),
        (
            MockHwConfig {
                drop_probability: 1.5,
                ..Default::default()
            },
            "drop_probability",
        ),
        (
            MockHwConfig {
                latency_s: f64::NAN,
                ..Default::default()
            },
            "latency_s",
        ),
        (
            MockHwConfig {
                fault_duration_s: Some(0.0),
                ..Default::default()
            },
            "fault_duration_s",
        ),
        (
            MockHwConfig {
                fault_near_limit: Some(-0.1),
                ..Default::default()
            },
            "fault_near_limit",
        ),
        (
            MockHwConfig {
                fault: Some(FaultKind::NanPosition),
                fault_joint: Some("torso_joint".into()),
                ..Default::default()
            },
            "fault_joint",
        ),
    ] {
        let e = MockHardware::new(
            &robot.model,
            kin.joint_names(),
            kin.limits(),
            &BTreeMap::new(),
            &vec![0.0; kin.dof()],
            OutputMode::Velocity,
            cfg,
        )
        .err()
        .unwrap()
        .to_string();
        assert!(e.contains(what), "{e}");
    }
}
