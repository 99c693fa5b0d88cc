//! The node core's reactions to a robot that does not do what it is told (position modes):
//! a held robot, a locked joint, a silent driver, a controller switched off; and the status
//! period that makes a one-tick code visible. A two-joint arm commanded at a constant
//! velocity, and a robot that takes each commanded position at once unless a fault says
//! otherwise.

use std::collections::HashMap;

use crossym_io::msg::JointState;
use crossym_math::kinematics::{ChainSpec, Kinematics, KinematicsSettings, RobotModel, TaskSpace};
use crossym_policy::Policy;

use super::super::{Command, NodeConfig, NodeCore, OutputMode, OutputStage, StatusCode};
use crate::safety::{ExactBounds, SafetySettings};

const URDF: &str = r#"<robot name="arm2">
  <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="tip"/>
  <joint name="j1" type="revolute"> <parent link="base"/> <child link="l1"/>
    <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2" acceleration="1"/> </joint>
  <joint name="j2" type="revolute"> <parent link="l1"/> <child link="l2"/>
    <origin xyz="1 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2" acceleration="1"/> </joint>
  <joint name="tool" type="fixed"> <parent link="l2"/> <child link="tip"/> <origin xyz="1 0 0"/> </joint>
</robot>"#;

const DT: f64 = 0.01;
/// The URDF's acceleration limit (rad/s²).
const ACCEL: f64 = 1.0;

/// The policy's velocity, replaced by a constant one (rad/s).
struct Constant([f64; 2]);

impl OutputStage for Constant {
    fn apply(&mut self, _tick: u64, _q: &[f64], v: &mut [f64]) {
        v.copy_from_slice(&self.0);
    }
}

/// What the simulated robot does with the commands.
#[derive(Clone, Copy, PartialEq)]
enum Robot {
    /// Takes each commanded position at once.
    Follows,
    /// Does not move (held; or no joint states are published when `silent`).
    Held,
    /// Joint `0` does not move; the others follow.
    Locked(usize),
}

struct Sim {
    core: NodeCore<Constant, ExactBounds>,
    cmd: Command,
    names: Vec<String>,
    q: Vec<f64>,
    t: f64,
    silent: bool,
}

impl Sim {
    fn new() -> Self {
        let model = RobotModel::from_urdf_str(URDF, "arm2.urdf").unwrap();
        let chains = [ChainSpec::new("arm", "base", "tip", TaskSpace::Xy)];
        let kin = Kinematics::new(
            &model,
            &chains,
            &HashMap::new(),
            &KinematicsSettings::default(),
        )
        .unwrap();
        let names = kin.joint_names().to_vec();
        let policy = Policy::synthetic(2, names.clone(), &[8], 7);
        // RB-Y1's tracking envelope (config/rby1-letters.toml).
        let safety = SafetySettings {
            tracking_tolerance: 0.02,
            tracking_window_s: 0.6,
            max_restarts: 2,
            restart_window_s: 5.0,
            ..SafetySettings::default()
        };
        let cfg = NodeConfig {
            output: OutputMode::Trajectory,
            ..NodeConfig::default()
        };
        let core =
            NodeCore::with_stages(kin, policy, safety, cfg, Constant([0.3, -0.2]), ExactBounds)
                .unwrap();
        let cmd = core.command();
        Self {
            core,
            cmd,
            names,
            q: vec![0.4, 1.2],
            t: 0.0,
            silent: false,
        }
    }

    /// One period: the robot's joint state (unless silent), a tick, the robot's response.
    fn step(&mut self, robot: Robot) -> StatusCode {
        if !self.silent {
            let js = JointState {
                name: self.names.clone(),
                position: self.q.clone(),
                ..Default::default()
            };
            self.core.on_joint_state(&js, self.t).unwrap();
        }
        self.t += DT;
        let r = self.core.tick(self.t, &mut self.cmd);
        if r.publish {
            for j in 0..2 {
                let moves = match robot {
                    Robot::Follows => true,
                    Robot::Held => false,
                    Robot::Locked(k) => j != k,
                };
                if moves {
                    self.q[j] = self.cmd.positions[j];
                }
            }
        }
        r.code
    }

    /// Runs `steps` periods; the codes.
    fn run(&mut self, steps: usize, robot: Robot) -> Vec<StatusCode> {
        (0..steps).map(|_| self.step(robot)).collect()
    }
}

/// The time (s from the start of `codes`) of the first `code`.
fn first(codes: &[StatusCode], code: StatusCode) -> Option<f64> {
    codes
        .iter()
        .position(|c| *c == code)
        .map(|k| (k + 1) as f64 * DT)
}

#[test]
fn a_held_robot_is_reported_within_0_3_s_held_at_its_state_resumes_without_a_jump_and_latches_when_held_for_good(
) {
    let mut s = Sim::new();
    let codes = s.run(150, Robot::Follows);
    assert!(!codes.contains(&StatusCode::RobotHeld), "{codes:?}");
    // Every joint stops while commanded to move (a collision hold).
    let codes = s.run(30, Robot::Held);
    let t = first(&codes, StatusCode::RobotHeld).expect("ROBOT_HELD reported");
    assert!(t <= 0.3, "held reported {t:.2} s after the hold");
    // Held for 1 s more: held at the measured state, tried again now and then (each try
    // held again counts as a restart; fewer than the latch needs); the command never
    // strays farther than the tracking tolerance from where the robot is.
    let codes = held_steps(&mut s, 100);
    assert!(
        codes.iter().all(|c| *c == StatusCode::RobotHeld),
        "{codes:?}"
    );
    assert!(s.core.status().held_events >= 2);
    // Released while held at its state: the commands start from the measured state at
    // rest and speed up within the acceleration limit.
    while !(s.step(Robot::Held) == StatusCode::RobotHeld && s.cmd.positions == s.q) {}
    let mut v_prev = [0.0; 2];
    let mut from = s.q.clone();
    for _ in 0..60 {
        s.step(Robot::Follows);
        for j in 0..2 {
            let v = (s.cmd.positions[j] - from[j]) / DT;
            assert!(
                (v - v_prev[j]).abs() <= ACCEL * DT * 1.001 + 1e-9,
                "joint {j}: command speed jumped from {} to {v} rad/s",
                v_prev[j]
            );
            v_prev[j] = v;
            from[j] = s.cmd.positions[j];
        }
    }
    assert!(v_prev[0] > 0.1, "the policy did not resume: {v_prev:?}");
    let codes = s.run(50, Robot::Follows);
    assert!(
        !codes.contains(&StatusCode::RobotHeld),
        "still held: {codes:?}"
    );
    assert!(!codes.contains(&StatusCode::RobotNotFollowing), "{codes:?}");
    // Held for good: the tries held again latch not following (no trying for ever), and
    // the latch holds where the robot is.
    let mut codes = s.run(30, Robot::Held);
    assert!(codes.contains(&StatusCode::RobotHeld), "{codes:?}");
    codes.extend(held_steps(&mut s, 270));
    let t = first(&codes, StatusCode::RobotNotFollowing).expect("ROBOT_NOT_FOLLOWING");
    assert!(t <= 3.0, "latched {t:.2} s after the second hold");
    assert!(codes[codes.len() - 100..]
        .iter()
        .all(|c| *c == StatusCode::RobotNotFollowing));
}

/// `n` ticks of a held robot; asserts the command stays within the tracking tolerance of
/// it (and one period's creep).
fn held_steps(s: &mut Sim, n: usize) -> Vec<StatusCode> {
    let mut codes = Vec::new();
    for _ in 0..n {
        codes.push(s.step(Robot::Held));
        for j in 0..2 {
            let off = (s.cmd.positions[j] - s.q[j]).abs();
            assert!(
                off <= 0.02 + 0.3 * DT,
                "joint {j}: command {off} rad from the held robot"
            );
        }
    }
    codes
}

#[test]
fn a_locked_joint_is_named_within_0_5_s_and_repeated_locks_hold_the_robot() {
    let mut s = Sim::new();
    s.run(150, Robot::Follows);
    let codes = s.run(300, Robot::Locked(1));
    let t = first(&codes, StatusCode::JointLocked).expect("JOINT_LOCKED reported");
    assert!(t <= 0.5, "locked reported {t:.2} s after the lock");
    let st = s.core.status();
    assert_eq!(st.locked_joint, Some(1));
    assert!(st.locked_events >= 1);
    assert!(!codes.contains(&StatusCode::RobotHeld), "{codes:?}");
    // A joint that stays locked: counted like restarts, then the node holds.
    assert!(codes.contains(&StatusCode::RobotNotFollowing), "{codes:?}");
}

#[test]
fn a_restart_that_lasts_one_tick_shows_in_the_status_period() {
    let mut s = Sim::new();
    s.run(100, Robot::Follows);
    s.core.end_status_period();
    // The robot moved by something else: one restart from the measured state.
    s.q[0] += 0.1;
    s.run(1, Robot::Follows);
    let codes = s.run(9, Robot::Follows);
    assert!(!codes.contains(&StatusCode::RestartedFromMeasured));
    let st = s.core.status();
    assert_ne!(st.code, StatusCode::RestartedFromMeasured);
    assert_eq!(st.period_code, StatusCode::RestartedFromMeasured);
    assert_eq!(st.period.restarts, 1);
    assert_eq!(st.period_ticks, 10);
    s.core.end_status_period();
    s.run(10, Robot::Follows);
    let st = s.core.status();
    assert_eq!(st.period_code, st.code);
    assert_eq!(st.period.restarts, 0);
}

#[test]
fn a_silent_driver_brakes_and_restarts_from_the_measured_state_without_a_jump() {
    let mut s = Sim::new();
    s.run(150, Robot::Follows);
    // Joint states absent for 3 s; the arm moved by hand meanwhile.
    s.silent = true;
    let codes = s.run(300, Robot::Held);
    assert!(codes[20..]
        .iter()
        .all(|c| *c == StatusCode::StaleJointStates));
    let stale = codes
        .iter()
        .filter(|c| **c == StatusCode::StaleJointStates)
        .count();
    s.silent = false;
    s.q[0] -= 0.05;
    s.q[1] += 0.03;
    let measured = s.q.clone();
    let code = s.step(Robot::Follows);
    assert_eq!(code, StatusCode::RestartedFromMeasured);
    for j in 0..2 {
        assert!(
            (s.cmd.positions[j] - measured[j]).abs() <= ACCEL * DT * DT + 1e-12,
            "joint {j}: command {} vs measured {}",
            s.cmd.positions[j],
            measured[j]
        );
    }
    let codes = s.run(50, Robot::Follows);
    assert!(!codes.contains(&StatusCode::RobotNotFollowing), "{codes:?}");
    assert_eq!(s.core.status().period.stale_ticks as usize, stale);
}

#[test]
fn a_controller_switched_off_is_reported_and_held_then_resumed_from_the_measured_state() {
    let mut s = Sim::new();
    // Before any subscriber matched (discovery), nothing changes.
    s.core.set_command_subscribers(0);
    let codes = s.run(50, Robot::Follows);
    assert!(!codes.contains(&StatusCode::NoCommandSubscriber));
    s.core.set_command_subscribers(1);
    s.run(100, Robot::Follows);
    s.core.set_command_subscribers(0);
    let codes = s.run(100, Robot::Held);
    assert!(codes.iter().all(|c| *c == StatusCode::NoCommandSubscriber));
    assert_eq!(s.core.status().command_subscribers, Some(0));
    // Braked to a hold within the acceleration limit (0.3 rad/s at 1 rad/s²: 0.3 s).
    let hold = s.cmd.positions.clone();
    s.run(5, Robot::Held);
    assert_eq!(s.cmd.positions, hold);
    // The robot drifted while no one commanded it; a new controller: from the measured state.
    s.q[1] += 0.02;
    s.core.set_command_subscribers(1);
    let measured = s.q.clone();
    assert_eq!(s.step(Robot::Follows), StatusCode::RestartedFromMeasured);
    for j in 0..2 {
        assert!((s.cmd.positions[j] - measured[j]).abs() <= ACCEL * DT * DT + 1e-12);
    }
}
