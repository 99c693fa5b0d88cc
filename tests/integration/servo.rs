//! The operator's controls in the node core, as MoveIt Servo has them: the singularity
//! band on a scripted approach to a stretched arm (its condition number computed here by an
//! SVD of a finite-difference Jacobian, independent of crossym's Jacobian and eigenvalue
//! code), pause and resume braking within the limits, the velocity scale, refusals.
//! (Over DDS, with an independent peer calling the services: `operator_services`.)

use crossym::control::faults::OverrideOutput;
use crossym::control::{
    Command, NodeConfig, NodeCore, OperatorRefusal, OperatorRequest, OutputMode,
    SingularitySettings, StatusCode,
};
use crossym::kinematics::Kinematics;
use crossym::msg;
use crossym::policy::{MlpInference, MlpSpec, Normalizer, Policy, PolicyMeta};
use crossym::safety::{ExactBounds, SafetySettings};
use nalgebra::DMatrix;

use crate::common;

const DT: f64 = 0.01;
/// The planar arms' start: both bent.
const Q0: [f64; 8] = [0.5, 0.8, 0.6, 0.4, -0.5, -0.8, -0.6, -0.4];

/// A zero policy (its output is replaced by the test's override).
fn zero_policy(n: usize) -> Policy {
    let spec = MlpSpec {
        input: n + 4,
        hidden: vec![4],
        output: n,
        activation: Default::default(),
    };
    let mlp = MlpInference::new(
        spec,
        vec![vec![0.0; 4 * (n + 4)], vec![0.0; n * 4]],
        vec![vec![0.0; 4], vec![0.0; n]],
    )
    .unwrap();
    Policy::new(Normalizer::identity(n), mlp, PolicyMeta::default()).unwrap()
}

/// A velocity-mode node on the planar arms whose policy is `drive(q, v)`.
fn node(
    band: SingularitySettings,
    drive: impl FnMut(u64, &[f64], &mut [f64]) + Send + 'static,
) -> (NodeCore<OverrideOutput>, Kinematics) {
    let robot = common::planar();
    let n = robot.kinematics.dof();
    let cfg = NodeConfig {
        output: OutputMode::Velocity,
        singularity: band,
        ..NodeConfig::default()
    };
    let stage = OverrideOutput(Some(Box::new(drive)));
    let kin = robot.kinematics.clone();
    let core = NodeCore::with_stages(
        robot.kinematics,
        zero_policy(n),
        SafetySettings::default(),
        cfg,
        stage,
        ExactBounds,
    )
    .unwrap();
    (core, kin)
}

fn joint_state(names: &[String], q: &[f64], t: f64) -> msg::JointState {
    msg::JointState {
        header: msg::Header {
            stamp: msg::Time::from_secs_f64(t),
            frame_id: String::new(),
        },
        name: names.to_vec(),
        position: q.to_vec(),
        ..Default::default()
    }
}

/// κ of the left arm's 2 × 4 position Jacobian by central differences of the forward
/// kinematics and an SVD.
fn left_condition(kin: &Kinematics, q: &[f64]) -> f64 {
    let mut ws = kin.workspace();
    let h = 1e-6;
    let mut j = DMatrix::zeros(2, 4);
    for c in 0..4 {
        let mut qp = q.to_vec();
        let mut qm = q.to_vec();
        qp[c] += h;
        qm[c] -= h;
        let xp = kin.forward(&qp, &mut ws).clone();
        let xm = kin.forward(&qm, &mut ws).clone();
        for r in 0..2 {
            j[(r, c)] = (xp[r] - xm[r]) / (2.0 * h);
        }
    }
    let s = j.singular_values();
    s.max() / s.min()
}

/// One tick of a kinematic robot in velocity mode: the node sees `q`, the robot then moves
/// by the command.
fn step<O: crossym::control::node::OutputStage>(
    core: &mut NodeCore<O>,
    names: &[String],
    q: &mut [f64],
    k: usize,
    cmd: &mut Command,
) -> StatusCode {
    let t = k as f64 * DT;
    core.on_joint_state(&joint_state(names, q, t), t).unwrap();
    let report = core.tick(t, cmd);
    for (qj, v) in q.iter_mut().zip(&cmd.velocities) {
        *qj += v * DT;
    }
    report.code
}

/// Each joint's acceleration limit as the filter applies it.
fn accelerations<O: crossym::control::node::OutputStage>(core: &NodeCore<O>) -> Vec<f64> {
    let d = SafetySettings::default().default_acceleration;
    core.limits()
        .iter()
        .map(|l| l.acceleration.unwrap_or(d))
        .collect()
}

struct Approach {
    /// The joints' acceleration limits.
    accel: Vec<f64>,
    /// Per tick: κ of the left arm (independent), the command's speed, the status.
    trace: Vec<(f64, f64, StatusCode)>,
}

/// The left arm straightened at a constant joint speed (its elbow and wrist joints driven
/// toward 0, where the arm is singular) for 6 s.
fn approach(band: SingularitySettings) -> Approach {
    let (mut core, kin) = node(band, |_, q, v| {
        v.fill(0.0);
        let norm = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt().max(1e-9);
        for j in 1..4 {
            v[j] = -0.6 * q[j] / norm;
        }
    });
    let names = core.joint_names().to_vec();
    let mut q = Q0.to_vec();
    let mut cmd = core.command();
    let mut trace = Vec::new();
    let accel = accelerations(&core);
    for k in 0..600 {
        let code = step(&mut core, &names, &mut q, k, &mut cmd);
        assert!(
            cmd.velocities.iter().all(|v| v.is_finite()),
            "tick {k}: {:?}",
            cmd.velocities
        );
        let speed = cmd.velocities.iter().map(|v| v * v).sum::<f64>().sqrt();
        trace.push((left_condition(&kin, &q), speed, code));
    }
    Approach { accel, trace }
}

/// The scripted approach: the command slows down continuously and monotonically once the
/// arm's condition number passes `slowdown` (status DECELERATE…), then halts (speed → 0,
/// κ held below `stop` + what one tick can add, HALT or DECELERATE with a vanishing
/// factor), no NaN, no jump: |Δv| per tick within the acceleration limit. With the band
/// off, the same drive stretches the arm far past `stop` — the check sees the difference.
#[test]
fn the_singularity_band_slows_down_continuously_and_halts() {
    let band = SingularitySettings::default();
    let a = approach(band);
    let a_norm = a.accel.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut entered = None;
    for (k, w) in a.trace.windows(2).enumerate() {
        let ((_, s0, _), (kappa, s1, code)) = (w[0], w[1]);
        // No jump: the filter's acceleration limit holds per joint, so the speed (a norm of
        // the joint velocities) changes by at most |a| Δt.
        assert!(
            (s1 - s0).abs() <= a_norm * DT + 1e-9,
            "tick {}: speed {s0} → {s1}",
            k + 1
        );
        if entered.is_none() && kappa > band.slowdown {
            entered = Some(k + 1);
        }
        // Inside the band the speed only falls.
        if let Some(e) = entered {
            if k + 1 > e {
                assert!(
                    s1 <= s0 + 1e-9,
                    "tick {}: speed rose {s0} → {s1} at κ {kappa} ({code:?})",
                    k + 1
                );
            }
        }
    }
    let entered = entered.expect("the arm never entered the band");
    let codes: Vec<StatusCode> = a.trace.iter().map(|t| t.2).collect();
    assert!(
        codes[entered..].contains(&StatusCode::DecelerateForSingularity),
        "{:?}",
        &codes[entered..entered + 5]
    );
    let (kappa_end, speed_end, code_end) = *a.trace.last().unwrap();
    let speed_max = a.trace.iter().map(|t| t.1).fold(0.0, f64::max);
    let kappa_max = a.trace.iter().map(|t| t.0).fold(0.0, f64::max);
    eprintln!(
        "band: entered at tick {entered}; κ max {kappa_max:.2} (stop {}), end κ {kappa_end:.2}, speed {speed_end:.2e} of {speed_max:.3} rad/s, {code_end:?}",
        band.stop
    );
    assert!(
        speed_end < 1e-2 * speed_max,
        "not halted: {speed_end} rad/s"
    );
    assert!(
        matches!(
            code_end,
            StatusCode::HaltForSingularity | StatusCode::DecelerateForSingularity
        ),
        "{code_end:?}"
    );
    assert!(kappa_max <= band.stop * 1.02, "κ reached {kappa_max}");

    // The band off: the same drive goes on into the singularity.
    let off = approach(SingularitySettings {
        enabled: false,
        ..band
    });
    let kappa_off = off.trace.iter().map(|t| t.0).fold(0.0, f64::max);
    assert!(
        kappa_off > 3.0 * band.stop,
        "without the band κ only {kappa_off}"
    );
    assert!(off
        .trace
        .iter()
        .all(|t| t.2 != StatusCode::DecelerateForSingularity));
}

/// Halted at the band, a command pointing out of the singularity is not scaled: the arm
/// leaves (Servo's rule).
#[test]
fn a_halted_arm_can_leave_the_singularity() {
    let band = SingularitySettings::default();
    let (mut core, kin) = node(band, |tick, q, v| {
        v.fill(0.0);
        let norm = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt().max(1e-9);
        // 5 s toward the singularity, then away.
        let sign = if tick < 500 { -1.0 } else { 1.0 };
        for j in 1..4 {
            v[j] = sign * 0.6 * q[j] / norm;
        }
    });
    let names = core.joint_names().to_vec();
    let mut q = Q0.to_vec();
    let mut cmd = core.command();
    for k in 0..500 {
        step(&mut core, &names, &mut q, k, &mut cmd);
    }
    let stuck = left_condition(&kin, &q);
    assert!(stuck > band.slowdown, "κ {stuck}");
    let mut code = StatusCode::NoWarning;
    for k in 500..700 {
        code = step(&mut core, &names, &mut q, k, &mut cmd);
    }
    let left = left_condition(&kin, &q);
    assert!(left < band.slowdown, "κ {stuck} → {left}");
    assert_eq!(code, StatusCode::NoWarning);
}

/// A constant push on every joint, below the limits.
fn push(_: u64, _: &[f64], v: &mut [f64]) {
    for (j, x) in v.iter_mut().enumerate() {
        *x = 0.3 * if j % 2 == 0 { 1.0 } else { -1.0 };
    }
}

/// Paused while moving: the command falls to zero at the acceleration limit (within
/// `v / a_max` plus a tick), status PAUSED, held at zero; resumed: the policy again from
/// the measured state. The velocity scale 0.5 halves the settled command.
#[test]
fn pause_brakes_within_the_limits_and_resume_and_scale_follow() {
    let (mut core, _) = node(SingularitySettings::default(), push);
    let names = core.joint_names().to_vec();
    let accel = accelerations(&core);
    let a_min = accel.iter().copied().fold(f64::INFINITY, f64::min);
    // A frozen robot: the policy's output is constant, the command settles on it.
    let q = Q0.to_vec();
    let mut cmd = core.command();
    let tick = |core: &mut NodeCore<OverrideOutput>, k: usize, cmd: &mut Command| {
        let t = k as f64 * DT;
        core.on_joint_state(&joint_state(&names, &q, t), t).unwrap();
        core.tick(t, cmd).code
    };
    for k in 0..100 {
        tick(&mut core, k, &mut cmd);
    }
    let settled = cmd.velocities.clone();
    assert!((settled[0] - 0.3).abs() < 1e-12, "{settled:?}");
    core.apply(OperatorRequest::Pause(true)).unwrap();
    let bound = (0.3f64 / (a_min * DT)).ceil() as usize + 1;
    let mut zero_at = None;
    let mut prev = settled.clone();
    for k in 100..200 {
        let code = tick(&mut core, k, &mut cmd);
        assert_eq!(code, StatusCode::Paused);
        for (j, (v, p)) in cmd.velocities.iter().zip(&prev).enumerate() {
            assert!(
                (v - p).abs() <= accel[j] * DT + 1e-12,
                "tick {k} joint {j}: {p} → {v}"
            );
        }
        prev.clone_from(&cmd.velocities);
        if zero_at.is_none() && cmd.velocities.iter().all(|v| *v == 0.0) {
            zero_at = Some(k - 100 + 1);
        }
    }
    let zero_at = zero_at.expect("never reached zero while paused");
    assert!(
        zero_at <= bound,
        "zero after {zero_at} ticks (bound {bound})"
    );
    assert!(core.status().paused);
    core.apply(OperatorRequest::Pause(false)).unwrap();
    let mut code = StatusCode::Paused;
    for k in 200..300 {
        code = tick(&mut core, k, &mut cmd);
    }
    assert_eq!(code, StatusCode::NoWarning);
    assert_eq!(cmd.velocities, settled);
    core.apply(OperatorRequest::VelocityScale(0.5)).unwrap();
    for k in 300..400 {
        tick(&mut core, k, &mut cmd);
    }
    for (v, s) in cmd.velocities.iter().zip(&settled) {
        assert!((v - 0.5 * s).abs() < 1e-12, "{v} vs {s}");
    }
    assert_eq!(core.status().velocity_scale, 0.5);
}

/// Bad runtime values are refused by reason and change nothing.
#[test]
fn bad_runtime_values_are_refused_and_change_nothing() {
    let (mut core, _) = node(SingularitySettings::default(), push);
    let before = core.runtime();
    for r in [
        OperatorRequest::VelocityScale(f64::NAN),
        OperatorRequest::VelocityScale(-1.0),
        OperatorRequest::VelocityScale(1.5),
        OperatorRequest::StaleTimeout(10.0),
        OperatorRequest::StaleTimeout(0.0),
        OperatorRequest::Margin(-0.1),
        OperatorRequest::Margin(100.0),
        OperatorRequest::Margin(f64::NAN),
    ] {
        let e = core.apply(r).unwrap_err();
        assert!(!e.to_string().is_empty());
        assert_eq!(core.runtime(), before, "{r:?} changed something");
    }
    let e = core
        .apply(OperatorRequest::DefaultCondition(
            crossym::symmetry::compose::Condition {
                theta: 0.0,
                scale: 1.0,
                reflection: 0,
            },
        ))
        .unwrap_err();
    assert!(matches!(e, OperatorRefusal::Condition { .. }), "{e}");
    assert!(core.apply(OperatorRequest::Margin(0.05)).is_ok());
    assert_eq!(core.runtime().margin, 0.05);
}
