//! One command of the node: velocities and positions of the controlled joints, with
//! the inputs that produced it.

use crossym_io::msg;
use crossym_math::kinematics::JointLimits;

use super::config::OutputMode;

/// One command, sized for the controlled joints (reused every tick).
#[derive(Debug, Clone, PartialEq)]
pub struct Command {
    /// What the command carries.
    pub mode: OutputMode,
    /// Joint velocities (rad/s or m/s); zero when stale.
    pub velocities: Vec<f64>,
    /// Joint positions (rad or m): `q + v·Δt` clamped to the limits, or the hold position.
    pub positions: Vec<f64>,
    /// Position modes: where this command starts (rad or m): the previous command, or the
    /// measured state on a (re)start.
    pub start_positions: Vec<f64>,
    /// Position modes: the velocities at the start (rad/s or m/s): the previous command's,
    /// zero on a (re)start.
    pub start_velocities: Vec<f64>,
}

impl Command {
    /// The Float64MultiArray payload: velocities (velocity mode) or positions (rad/s or rad).
    pub fn data(&self) -> &[f64] {
        match self.mode {
            OutputMode::Velocity => &self.velocities,
            OutputMode::Position | OutputMode::Trajectory => &self.positions,
        }
    }

    /// As a Float64MultiArray for ForwardCommandController (allocates).
    pub fn to_float64_multi_array(&self) -> msg::Float64MultiArray {
        msg::Float64MultiArray {
            layout: msg::MultiArrayLayout::default(),
            data: self.data().to_vec(),
        }
    }

    /// As a JointTrajectory whose last point, the command, is reached after `dt` (s)
    /// (allocates). With `start_point`, a first point at `time_from_start = 0` holds where
    /// the command starts (the previous command): a JointTrajectoryController then
    /// interpolates from there, not from the measured state — its default for the start of
    /// every new trajectory (`open_loop_control = false`), which would restart a lagging
    /// robot's reference from where the robot is, 100 times a second.
    pub fn to_joint_trajectory(
        &self,
        joint_names: &[String],
        dt: f64,
        start_point: bool,
    ) -> msg::JointTrajectory {
        let point = |positions: &[f64], velocities: &[f64], t: f64| msg::JointTrajectoryPoint {
            positions: positions.to_vec(),
            velocities: velocities.to_vec(),
            accelerations: Vec::new(),
            effort: Vec::new(),
            time_from_start: msg::Duration::from_secs_f64(t),
        };
        let mut points = Vec::with_capacity(2);
        if start_point {
            points.push(point(&self.start_positions, &self.start_velocities, 0.0));
        }
        points.push(point(&self.positions, &self.velocities, dt));
        msg::JointTrajectory {
            header: msg::Header::default(),
            joint_names: joint_names.to_vec(),
            points,
        }
    }
}

/// Clamps `x` into `[lower, upper]` (infinite limits bound nothing; NaN stays NaN).
pub(crate) fn clamp_to(l: &JointLimits, x: f64) -> f64 {
    let mut y = x;
    if y > l.upper {
        y = l.upper;
    }
    if y < l.lower {
        y = l.lower;
    }
    y
}
