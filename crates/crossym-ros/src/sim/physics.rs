//! `[mock_hw.mujoco]`: a physics robot in place of the kinematic mock.
//!
//! The kinematic mock ([`super::MockHardware`]) executes every command exactly. A real arm
//! is a position servo with lag, gravity sag and torque limits behind a vendor stack that
//! interpolates and rate-limits its targets. `crossym mock-hw --plant mujoco` runs
//! `physics/rby1_mujoco.py` instead: the vendor SDK's RB-Y1 MuJoCo model (position actuators
//! kp 4000 / kv 400, joint armature and damping, the URDF's effort limits, gravity on, base
//! fixed) behind an emulation of the vendor's ROS 2 stack — `/joint_states` at 100 Hz, a
//! JointTrajectoryController on `/both_arms_controller/joint_trajectory` (Humble's rule for
//! the start of a new trajectory), `rby1_hardware`'s streaming limits and the firmware's
//! 15 Hz target filter. It is a separate process on Cyclone DDS (PyPI `mujoco` and
//! `cyclonedds`, `physics/install.sh`): MuJoCo's official binding, and a DDS implementation
//! other than the node's, as on the real robot. See `physics/README.md`.
//!
//! This module only turns the configuration into that program's command line.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

/// Which robot `crossym mock-hw` simulates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Plant {
    /// Commands executed exactly (velocity integrated, positions taken as they come).
    #[default]
    Kinematic,
    /// The MuJoCo RB-Y1 behind the vendor stack's emulation (`[mock_hw.mujoco]`).
    Mujoco,
}

impl std::str::FromStr for Plant {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "kinematic" => Ok(Self::Kinematic),
            "mujoco" => Ok(Self::Mujoco),
            other => Err(format!("unknown plant `{other}` (kinematic, mujoco)")),
        }
    }
}

/// `[mock_hw.mujoco]`: the physics robot's settings (paths relative to the config file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MujocoConfig {
    /// The vendor SDK's `mujoco/` folder (`model_act.xml`, `rby1_v<version>.xml`, `assets/`).
    pub model_dir: Option<PathBuf>,
    /// Robot version of the model (`1.0`, `1.1`, `1.2`): must match the URDF's.
    pub version: String,
    /// MuJoCo's gravity compensation on every body (as the vendor's controller may do).
    pub gravity_compensation: bool,
    /// Actuator forces limited to the URDF's `<limit effort>`.
    pub force_limits: bool,
    /// The JointTrajectoryController's `open_loop_control` (false: each new trajectory
    /// starts from the measured state, the controller's default).
    pub open_loop_control: bool,
    /// Streaming velocity limit of the hardware (rad/s).
    pub hw_velocity: f64,
    /// Streaming acceleration limit of the hardware (rad/s²); 0 disables the limiter.
    pub hw_acceleration: f64,
    /// Minimum time of each streamed target (s).
    pub hw_min_time_s: f64,
    /// The firmware's low-pass filter on position targets (Hz); 0 disables it.
    pub target_filter_hz: f64,
    /// Fault: this joint is locked from `freeze_after_s` (the robot stops following).
    pub freeze_joint: Option<String>,
    /// When the frozen joint locks (s after start).
    pub freeze_after_s: Option<f64>,
    /// Fault: the hardware's collision hold from this time (s after start): it holds its
    /// position and ignores commands.
    pub hold_after_s: Option<f64>,
    /// The lock of `freeze_joint` releases after this long (s); `None`: never.
    pub freeze_s: Option<f64>,
    /// The collision hold releases after this long (s); `None`: never.
    pub hold_s: Option<f64>,
    /// Fault: the vendor driver restarts at this time (s after start): no joint states and
    /// commands dropped for `driver_restart_s`, the controller's state reset.
    pub driver_restart_after_s: Option<f64>,
    /// How long the driver is down (s).
    pub driver_restart_s: f64,
    /// Where the arm is found when the driver is back: this far (rad) from where it stopped
    /// on every controlled joint (moved by hand).
    pub driver_restart_step: f64,
    /// Fault: the trajectory controller is switched off at this time (s after start): its
    /// command subscription is deleted (the node's publisher loses its match), the hardware
    /// holds; on again after `controller_off_s`.
    pub controller_off_after_s: Option<f64>,
    /// How long the controller is off (s).
    pub controller_off_s: f64,
    /// The program to run (`physics/rby1_mujoco.py`); default: `$CROSSYM_PHYSICS_DIR` or
    /// the `physics/` folder of the source tree crossym was built from.
    pub program: Option<PathBuf>,
}

impl Default for MujocoConfig {
    fn default() -> Self {
        Self {
            model_dir: None,
            version: "1.0".into(),
            gravity_compensation: false,
            force_limits: true,
            open_loop_control: false,
            hw_velocity: 4.712,
            hw_acceleration: 1.0,
            hw_min_time_s: 0.01,
            target_filter_hz: 15.0,
            freeze_joint: None,
            freeze_after_s: None,
            hold_after_s: None,
            freeze_s: None,
            hold_s: None,
            driver_restart_after_s: None,
            driver_restart_s: 3.0,
            driver_restart_step: 0.0,
            controller_off_after_s: None,
            controller_off_s: 2.0,
            program: None,
        }
    }
}

/// What the physics robot is given besides its own settings.
#[derive(Debug, Clone)]
pub struct PhysicsRun<'a> {
    /// The config file's directory (relative paths resolve against it).
    pub base_dir: &'a Path,
    /// The robot's URDF (effort limits and the limit checks).
    pub urdf: &'a Path,
    /// Controlled joints, in command order.
    pub joints: &'a [String],
    /// Their start positions (rad).
    pub initial_q: &'a [f64],
    /// Their position limits as the node knows them (`[robot] limits` applied, rad): the
    /// robot checks these where they are tighter than its URDF's (a user who narrows a
    /// joint's range expects the node to keep within it).
    pub position_limits: &'a [(f64, f64)],
    /// joint_states rate (Hz).
    pub rate_hz: f64,
    /// Where to write the JSON summary on exit.
    pub summary: Option<&'a Path>,
    /// `[mock_hw] fault`: the published joint states fail while the robot keeps moving.
    pub fault: Option<super::fault::FaultKind>,
    /// `[mock_hw] fault_joint` (NaN or missing); `None`: the first controlled joint.
    pub fault_joint: Option<&'a str>,
    /// `[mock_hw] fault_after_s` (s after start).
    pub fault_after_s: f64,
    /// `[mock_hw] fault_duration_s`; `None`: to the end.
    pub fault_duration_s: Option<f64>,
}

impl MujocoConfig {
    /// Checks values; says which is wrong.
    pub fn validate(&self) -> Result<(), super::error::MockHwError> {
        if !["1.0", "1.1", "1.2"].contains(&self.version.as_str()) {
            return Err(super::error::MockHwError::setting(format!(
                "version = `{}`: the vendor's models are 1.0, 1.1 and 1.2",
                self.version
            )));
        }
        for (k, v, zero_ok) in [
            ("hw_velocity", self.hw_velocity, false),
            ("hw_acceleration", self.hw_acceleration, true),
            ("hw_min_time_s", self.hw_min_time_s, true),
            ("target_filter_hz", self.target_filter_hz, true),
        ] {
            if !(v.is_finite() && (v > 0.0 || (zero_ok && v == 0.0))) {
                return Err(super::error::MockHwError::setting(format!(
                    "{k} = {v} must be finite and positive"
                )));
            }
        }
        if self.freeze_joint.is_some() != self.freeze_after_s.is_some() {
            return Err(super::error::MockHwError::setting(
                "freeze_joint and freeze_after_s go together".into(),
            ));
        }
        Ok(())
    }

    /// The program's path.
    pub fn program(&self, base_dir: &Path) -> PathBuf {
        match &self.program {
            Some(p) => base_dir.join(p),
            None => std::env::var_os("CROSSYM_PHYSICS_DIR")
                .map(PathBuf::from)
                .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../physics"))
                .join("rby1_mujoco.py"),
        }
    }

    /// The program's arguments (after the script's path).
    pub fn args(&self, run: &PhysicsRun<'_>) -> Result<Vec<String>, String> {
        let model_dir = self
            .model_dir
            .as_ref()
            .ok_or("model_dir is not set: point it at your RB-Y1 SDK's models/rby1a/mujoco")?;
        let mut a = self.robot_args(run, model_dir);
        self.push_behaviour_args(&mut a);
        push_run_args(run, &mut a);
        Ok(a)
    }

    /// The model, the robot, its start and limits, the hardware's motion settings.
    fn robot_args(&self, run: &PhysicsRun<'_>, model_dir: &Path) -> Vec<String> {
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| format!("{x:?}"))
                .collect::<Vec<_>>()
                .join(",")
        };
        vec![
            "--model-dir".to_string(),
            run.base_dir.join(model_dir).display().to_string(),
            "--version".into(),
            self.version.clone(),
            "--urdf".into(),
            run.urdf.display().to_string(),
            "--joints".into(),
            run.joints.join(","),
            format!("--initial-q={}", list(run.initial_q)),
            format!(
                "--position-limits={}",
                run.position_limits
                    .iter()
                    .map(|(lo, hi)| format!("{lo:?}:{hi:?}"))
                    .collect::<Vec<_>>()
                    .join(",")
            ),
            "--rate-hz".into(),
            format!("{:?}", run.rate_hz),
            "--hw-velocity".into(),
            format!("{:?}", self.hw_velocity),
            "--hw-acceleration".into(),
            format!("{:?}", self.hw_acceleration),
            "--hw-min-time".into(),
            format!("{:?}", self.hw_min_time_s),
            "--target-filter-hz".into(),
            format!("{:?}", self.target_filter_hz),
        ]
    }

    /// The simulated robot's behaviour: gravity compensation, force limits, open-loop
    /// control, and the planted joint freezes, holds, driver restarts and controller
    /// switch-offs.
    fn push_behaviour_args(&self, a: &mut Vec<String>) {
        if self.gravity_compensation {
            a.push("--gravity-compensation".into());
        }
        if !self.force_limits {
            a.push("--no-force-limits".into());
        }
        if self.open_loop_control {
            a.push("--open-loop-control".into());
        }
        if let (Some(j), Some(t)) = (&self.freeze_joint, self.freeze_after_s) {
            a.extend(["--freeze-joint".into(), j.clone()]);
            a.extend(["--freeze-after-s".into(), format!("{t:?}")]);
        }
        if let Some(t) = self.hold_after_s {
            a.extend(["--hold-after-s".into(), format!("{t:?}")]);
        }
        for (flag, v) in [("--freeze-s", self.freeze_s), ("--hold-s", self.hold_s)] {
            if let Some(v) = v {
                a.extend([flag.into(), format!("{v:?}")]);
            }
        }
        if let Some(t) = self.driver_restart_after_s {
            a.extend([
                "--driver-restart-after-s".into(),
                format!("{t:?}"),
                "--driver-restart-s".into(),
                format!("{:?}", self.driver_restart_s),
                "--driver-restart-step".into(),
                format!("{:?}", self.driver_restart_step),
            ]);
        }
        if let Some(t) = self.controller_off_after_s {
            a.extend([
                "--controller-off-after-s".into(),
                format!("{t:?}"),
                "--controller-off-s".into(),
                format!("{:?}", self.controller_off_s),
            ]);
        }
    }
}

/// This run's summary file and sensor fault.
fn push_run_args(run: &PhysicsRun<'_>, a: &mut Vec<String>) {
    if let Some(s) = run.summary {
        a.extend(["--summary".into(), s.display().to_string()]);
    }
    if let Some(kind) = run.fault {
        use super::fault::FaultKind;
        let k = match kind {
            FaultKind::Frozen => "frozen",
            FaultKind::Silent => "silent",
            FaultKind::NanPosition => "nan",
            FaultKind::MissingJoint => "missing",
        };
        a.extend(["--sensor-fault".into(), k.into()]);
        a.extend([
            "--sensor-fault-after-s".into(),
            format!("{:?}", run.fault_after_s),
        ]);
        if let Some(d) = run.fault_duration_s {
            a.extend(["--sensor-fault-s".into(), format!("{d:?}")]);
        }
        if let (Some(j), FaultKind::NanPosition | FaultKind::MissingJoint) = (run.fault_joint, kind)
        {
            a.extend(["--sensor-fault-joint".into(), j.into()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn arguments_carry_every_setting() {
        let c = MujocoConfig {
            model_dir: Some("sdk/mujoco".into()),
            gravity_compensation: true,
            freeze_joint: Some("left_arm_1".into()),
            freeze_after_s: Some(2.5),
            ..MujocoConfig::default()
        };
        c.validate().unwrap();
        let joints = ["a".to_string(), "b".to_string()];
        let a = c
            .args(&PhysicsRun {
                base_dir: Path::new("/cfg"),
                urdf: Path::new("/u.urdf"),
                joints: &joints,
                initial_q: &[-0.5, 1.0],
                position_limits: &[(-1.0, 1.0), (-0.25, 2.0)],
                rate_hz: 100.0,
                summary: Some(Path::new("/s.json")),
                fault: Some(super::super::fault::FaultKind::NanPosition),
                fault_joint: Some("b"),
                fault_after_s: 2.0,
                fault_duration_s: Some(0.5),
            })
            .unwrap();
        let s = a.join(" ");
        for want in [
            "--model-dir /cfg/sdk/mujoco",
            "--version 1.0",
            "--joints a,b",
            "--initial-q=-0.5,1.0",
            "--position-limits=-1.0:1.0,-0.25:2.0",
            "--hw-acceleration 1.0",
            "--target-filter-hz 15.0",
            "--gravity-compensation",
            "--freeze-joint left_arm_1 --freeze-after-s 2.5",
            "--summary /s.json",
            "--sensor-fault nan --sensor-fault-after-s 2.0 --sensor-fault-s 0.5 --sensor-fault-joint b",
        ] {
            assert!(s.contains(want), "`{want}` missing from {s}");
        }
        assert!(!s.contains("--open-loop-control"));
        let bad = MujocoConfig {
            version: "2.0".into(),
            ..MujocoConfig::default()
        };
        assert!(bad
            .validate()
            .unwrap_err()
            .to_string()
            .contains("1.0, 1.1 and 1.2"));
        assert!(MujocoConfig::default()
            .args(&PhysicsRun {
                base_dir: Path::new("/"),
                urdf: Path::new("/u"),
                joints: &joints,
                initial_q: &[0.0, 0.0],
                position_limits: &[],
                rate_hz: 100.0,
                summary: None,
                fault: None,
                fault_joint: None,
                fault_after_s: 0.0,
                fault_duration_s: None,
            })
            .unwrap_err()
            .contains("model_dir"));
    }
}
