//! The safety filter's settings (`[node] safety` in a config file) and its setup errors.

/// Settings of the safety filter, validated once.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SafetySettings {
    /// Control period `Δt` (s).
    #[serde(default = "d_dt")]
    pub dt: f64,
    /// Distance kept from position limits (rad or m).
    #[serde(default = "d_margin")]
    pub margin: f64,
    /// Acceleration limit for joints whose URDF/config gives none (rad/s² or m/s²).
    #[serde(default = "d_accel")]
    pub default_acceleration: f64,
    /// Relative regularisation `ε` of `W = JᵀJ + ε·tr(JᵀJ)/n·I`.
    #[serde(default = "d_eps")]
    pub weight_epsilon: f64,
    /// Minimum end-effector distance for the barrier (task units); `None` disables it.
    #[serde(default)]
    pub min_ee_distance: Option<f64>,
    /// Barrier gain `γ` (1/s).
    #[serde(default = "d_gamma")]
    pub barrier_gain: f64,
    /// Iteration budget of the interior-point solver.
    #[serde(default = "d_iter")]
    pub max_iter: u32,
    /// Worst-case time (s) from publishing a velocity command until the robot runs it and
    /// until a newer one replaces it: transport, dropped commands (each adds a period) and
    /// late ticks. `None`: one control period.
    #[serde(default)]
    pub latency_s: Option<f64>,
    /// How old a joint state's positions may already be when it arrives (s): sensing and
    /// transport delay before its header stamp or receipt time.
    #[serde(default)]
    pub state_delay_s: f64,
    /// Longest joint-state age (s) the position bound covers with the command history; older
    /// states use the velocity limit for the unknown commands (the node sets it to its
    /// stale timeout).
    #[serde(default = "d_max_age")]
    pub max_state_age_s: f64,
    /// Position modes: how far (rad or m) a measured position may lie from every position
    /// the robot may be following before the node restarts its commands from the measured
    /// state (a reset, a robot that does not follow).
    #[serde(default = "d_track")]
    pub tracking_tolerance: f64,
    /// Position modes: how long (s) a position command keeps pulling the robot. A servo
    /// whose step response does not overshoot (a first-order lag, an overdamped or
    /// critically damped loop) stays inside the hull of the commands of its last few time
    /// constants; the node checks the measured position against the commands of this window
    /// before the measurement (about five time constants of the robot's position loop, plus
    /// its trajectory interpolation). 0: the commands since the measurement only (a robot
    /// that executes each command at once).
    #[serde(default)]
    pub tracking_window_s: f64,
    /// Position modes: a measured position farther than this (rad or m) from the command in
    /// effect when it was measured, on any joint, for longer than `tracking_window_s`, is
    /// reported (status `TRACKING_ERROR`, a warning on the terminal). `None`: not reported.
    #[serde(default)]
    pub tracking_warning: Option<f64>,
    /// Position modes: after this many restarts from the measured state within
    /// `restart_window_s`, the node decides the robot does not follow, holds the measured
    /// position and reports `ROBOT_NOT_FOLLOWING` until a new condition is accepted.
    #[serde(default = "d_max_restarts")]
    pub max_restarts: u32,
    /// The window (s) of `max_restarts`.
    #[serde(default = "d_restart_window")]
    pub restart_window_s: f64,
}

fn d_dt() -> f64 {
    0.01
}
fn d_margin() -> f64 {
    0.01
}
fn d_accel() -> f64 {
    10.0
}
fn d_eps() -> f64 {
    1e-3
}
fn d_gamma() -> f64 {
    5.0
}
fn d_iter() -> u32 {
    50
}
fn d_max_age() -> f64 {
    0.1
}
fn d_track() -> f64 {
    2e-3
}
fn d_max_restarts() -> u32 {
    // With no lag window a robot that stops restarts nearly every tick: 64 within 2 s
    // (0.64 s of a frozen robot at 100 Hz) tells it from a reset's few restarts.
    64
}
fn d_restart_window() -> f64 {
    2.0
}

impl SafetySettings {
    /// The actuation latency `L` (s): `latency_s`, or one period.
    pub fn latency(&self) -> f64 {
        self.latency_s.unwrap_or(self.dt)
    }

    /// Checks every setting's domain (done once, when a filter is built).
    pub fn validate(&self) -> Result<(), SafetyError> {
        let bad = |field: &'static str, message: String| SafetyError::Setting { field, message };
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !pos(self.dt) {
            return Err(bad("dt", format!("{} must be positive", self.dt)));
        }
        if !(self.margin.is_finite() && self.margin >= 0.0) {
            return Err(bad(
                "margin",
                format!("{} must be non-negative", self.margin),
            ));
        }
        if !pos(self.default_acceleration) {
            return Err(bad(
                "default_acceleration",
                format!("{} must be positive", self.default_acceleration),
            ));
        }
        if !pos(self.weight_epsilon) {
            return Err(bad(
                "weight_epsilon",
                format!("{} must be positive", self.weight_epsilon),
            ));
        }
        if !pos(self.barrier_gain) {
            return Err(bad(
                "barrier_gain",
                format!("{} must be positive", self.barrier_gain),
            ));
        }
        if let Some(d) = self.min_ee_distance {
            if !pos(d) {
                return Err(bad("min_ee_distance", format!("{d} must be positive")));
            }
        }
        if self.max_iter == 0 {
            return Err(bad("max_iter", "must be positive".into()));
        }
        if let Some(l) = self.latency_s {
            if !(l.is_finite() && l >= 0.0) {
                return Err(bad("latency_s", format!("{l} must be finite and >= 0")));
            }
        }
        if !(self.state_delay_s.is_finite() && self.state_delay_s >= 0.0) {
            return Err(bad(
                "state_delay_s",
                format!("{} must be finite and >= 0", self.state_delay_s),
            ));
        }
        if !(self.max_state_age_s.is_finite() && self.max_state_age_s >= 0.0) {
            return Err(bad(
                "max_state_age_s",
                format!("{} must be finite and >= 0", self.max_state_age_s),
            ));
        }
        Ok(())
    }
}

impl Default for SafetySettings {
    fn default() -> Self {
        Self {
            dt: d_dt(),
            margin: d_margin(),
            default_acceleration: d_accel(),
            weight_epsilon: d_eps(),
            min_ee_distance: None,
            barrier_gain: d_gamma(),
            max_iter: d_iter(),
            latency_s: None,
            state_delay_s: 0.0,
            max_state_age_s: d_max_age(),
            tracking_tolerance: d_track(),
            tracking_window_s: 0.0,
            tracking_warning: None,
            max_restarts: d_max_restarts(),
            restart_window_s: d_restart_window(),
        }
    }
}

/// Setup errors of the safety filter.
#[derive(Debug, Clone, thiserror::Error)]
#[non_exhaustive]
pub enum SafetyError {
    /// A setting is out of its domain.
    #[error("invalid safety setting `{field}`: {message}")]
    Setting {
        /// Configuration key.
        field: &'static str,
        /// Why.
        message: String,
    },
    /// A joint has no finite velocity limit.
    #[error("joint {index} has no finite velocity limit: set [robot.limits.<joint>] velocity")]
    NoVelocityLimit {
        /// Index in the controlled joint order.
        index: usize,
    },
    /// Clarabel refused the problem at setup.
    #[error("QP solver setup failed: {message}")]
    Solver {
        /// Solver message.
        message: String,
    },
}
