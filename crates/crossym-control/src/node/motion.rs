//! The motion supervisor (position modes): a robot **held** (rby1_hardware's collision hold:
//! every arm joint stops while commanded to move) and a **locked** joint (a brake, a jam:
//! one joint stops while the others go on), told from the measured motion against the
//! commanded motion.
//!
//! Joint `j` is *still* at a measurement time `t` when every measured position of the last
//! `window_s` lay within `±still` of one value. It is *commanded to move* when every command
//! since `t − window_s − delay` had `|q̇ⱼ| ≥ speed` with one sign, `delay` being the
//! servo's response (`response_s`) plus the filter's latency and state delay: a servo that
//! follows such commands moves at least `speed` over the window after `delay`, i.e.
//! `speed·window_s ≥ 2·still` (checked) — farther than `still` in half the window. A joint
//! both still and commanded to move is *stuck*.
//!
//! - **Held**: every joint still and at least one stuck. Bound from the hold: the servo
//!   stopping (≈ its time constant, 0.1 s on RB-Y1) + `window_s` + one joint-state period
//!   and one tick; with the defaults (0.15 s) 0.3 s.
//! - **Locked**: a joint stuck for `window_s + 2·response_s` while another joint still
//!   moves (named; a hold stops the joints one after the other as the servos settle, within
//!   about `2·response_s`: the wait keeps a hold from being taken for a lock). Bound from the
//!   lock while the command is fast: `window_s + 2·response_s` + one joint-state period and
//!   one tick; with the defaults 0.36 s, stated as 0.5 s.
//!
//! The supervisor only tells; [`NodeCore`](super::NodeCore) reacts (restart from the
//! measured state; a held robot is held there, then tried again). After a restart
//! ([`MotionSupervisor::reset`]) the commands must be fast for `window_s + delay` again
//! before a joint can be found stuck. Allocation-free after construction.

use serde::{Deserialize, Serialize};

/// `[node] motion`: the thresholds of held / locked detection (position modes).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionSettings {
    /// Detect held robots and locked joints at all.
    pub enabled: bool,
    /// Commanded speed (rad/s or m/s) above which a joint must move.
    pub speed: f64,
    /// Band (rad or m) within which a joint counts as not moving (sag, noise).
    pub still: f64,
    /// How long (s) a joint must stay within `still` while commanded to move.
    pub window_s: f64,
    /// The servo's response time (s) from a command to its motion, beyond the filter's
    /// latency and state delay.
    pub response_s: f64,
    /// A held robot is held at its measured state this long (s) before the policy is tried
    /// again.
    pub held_dwell_s: f64,
}

impl Default for MotionSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            speed: 0.03,
            still: 0.002,
            window_s: 0.15,
            response_s: 0.1,
            held_dwell_s: 0.3,
        }
    }
}

impl MotionSettings {
    /// Checks the thresholds (a joint moving at `speed` must leave the `still` band in half
    /// the window).
    pub fn validate(&self) -> Result<(), String> {
        for (name, v) in [
            ("speed", self.speed),
            ("still", self.still),
            ("window_s", self.window_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(format!("{name} = {v} must be positive"));
            }
        }
        for (name, v) in [
            ("response_s", self.response_s),
            ("held_dwell_s", self.held_dwell_s),
        ] {
            if !(v.is_finite() && (0.0..=10.0).contains(&v)) {
                return Err(format!("{name} = {v} must lie in [0, 10] s"));
            }
        }
        if self.speed * self.window_s < 2.0 * self.still {
            return Err(format!(
                "speed · window_s = {:.4} must be at least 2 · still = {:.4} (a joint moving at \
                 `speed` would look still)",
                self.speed * self.window_s,
                2.0 * self.still
            ));
        }
        Ok(())
    }
}

/// What one measurement showed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Motion {
    /// Nothing stuck (or not enough evidence).
    Normal,
    /// Every joint still, `joint` (the first) stuck: the robot is held.
    Held {
        /// The first stuck joint.
        joint: usize,
    },
    /// `joint` stuck while another joint moved.
    Locked {
        /// The stuck joint.
        joint: usize,
    },
}

/// Per-joint state of held / locked detection; see the module docs.
#[derive(Debug, Clone)]
pub struct MotionSupervisor {
    s: MotionSettings,
    delay_s: f64,
    anchor: Vec<f64>,
    still_since: Vec<f64>,
    fast_since: Vec<f64>,
    fast_sign: Vec<f64>,
    moved: bool,
    last_t: f64,
}

impl MotionSupervisor {
    /// The supervisor of `n` joints; `delay_s` is the filter's latency and state delay
    /// (`response_s` is added).
    pub fn new(n: usize, s: MotionSettings, delay_s: f64) -> Self {
        Self {
            s,
            delay_s: delay_s + s.response_s,
            anchor: vec![f64::NAN; n],
            still_since: vec![f64::INFINITY; n],
            fast_since: vec![f64::INFINITY; n],
            fast_sign: vec![0.0; n],
            moved: false,
            last_t: f64::NEG_INFINITY,
        }
    }

    /// The settings.
    pub fn settings(&self) -> &MotionSettings {
        &self.s
    }

    /// Forgets the commanded motion (the commands restarted at rest) and whether a joint
    /// moved since.
    pub fn reset(&mut self) {
        self.fast_since.fill(f64::INFINITY);
        self.fast_sign.fill(0.0);
        self.moved = false;
    }

    /// Whether a joint left its `still` band since the last [`Self::reset`].
    pub fn moved(&self) -> bool {
        self.moved
    }

    /// The velocities `v` commanded at `now_s`.
    pub fn command(&mut self, now_s: f64, v: &[f64]) {
        for (j, &vj) in v.iter().enumerate() {
            let sign = if vj >= self.s.speed {
                1.0
            } else if vj <= -self.s.speed {
                -1.0
            } else {
                0.0
            };
            if sign == 0.0 || sign != self.fast_sign[j] {
                self.fast_since[j] = if sign == 0.0 { f64::INFINITY } else { now_s };
            }
            self.fast_sign[j] = sign;
        }
    }

    /// A new measurement `q` at `t_s`: what it shows.
    pub fn measure(&mut self, t_s: f64, q: &[f64]) -> Motion {
        if !self.s.enabled {
            return Motion::Normal;
        }
        // Not moving is shown by measurements throughout the window: after a gap in them
        // (a silent driver) the evidence starts again.
        if t_s - self.last_t > 0.5 * self.s.window_s {
            self.still_since.fill(t_s);
        }
        self.last_t = t_s;
        let mut all_still = true;
        let mut stuck = None;
        for (j, &qj) in q.iter().enumerate() {
            // A NaN anchor (no measurement yet) re-anchors too.
            let within = (qj - self.anchor[j]).abs() <= self.s.still;
            if !within {
                if self.anchor[j].is_finite() {
                    self.moved = true;
                }
                self.anchor[j] = qj;
                self.still_since[j] = t_s;
            }
            let still = t_s - self.still_since[j] >= self.s.window_s;
            all_still &= still;
            if still
                && self.fast_since[j] <= t_s - self.s.window_s - self.delay_s
                && stuck.is_none()
            {
                stuck = Some(j);
            }
        }
        match stuck {
            None => Motion::Normal,
            Some(joint) if all_still => Motion::Held { joint },
            // A hold stops the joints one after the other as the servos settle: a lock
            // is told only once its joint has been still for the settling time more
            // (`2 · response_s`) while another joint still moves.
            Some(joint)
                if t_s - self.still_since[joint] >= self.s.window_s + 2.0 * self.s.response_s =>
            {
                Motion::Locked { joint }
            }
            Some(_) => Motion::Normal,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f64 = 0.01;

    /// Drives `n` joints commanded at `v` (rad/s) each; `follows[j]` says whether joint j
    /// moves with its command (a servo with no lag) from `t_fault` on; returns the first
    /// detection and its time.
    fn drive(v: &[f64], follows: &[bool], t_fault: f64, until: f64) -> Option<(Motion, f64)> {
        let n = v.len();
        let mut sup = MotionSupervisor::new(n, MotionSettings::default(), 0.02);
        let mut q = vec![0.3; n];
        let mut t = 0.0;
        while t < until {
            sup.command(t, v);
            for j in 0..n {
                if t < t_fault || follows[j] {
                    q[j] += v[j] * DT;
                }
            }
            t += DT;
            let m = sup.measure(t, &q);
            if m != Motion::Normal {
                return Some((m, t));
            }
        }
        None
    }

    #[test]
    fn a_robot_that_follows_is_never_stuck() {
        assert_eq!(drive(&[0.05, -0.2, 0.0], &[true; 3], 1e9, 5.0), None);
        // Exactly at the threshold speed: still leaves the band in half the window.
        assert_eq!(drive(&[0.03, 0.03], &[true; 2], 1e9, 5.0), None);
    }

    #[test]
    fn a_held_robot_is_found_within_the_window_and_a_period() {
        let (m, t) = drive(&[0.1, -0.05, 0.0], &[false; 3], 1.0, 5.0).unwrap();
        assert_eq!(m, Motion::Held { joint: 0 });
        let s = MotionSettings::default();
        assert!(
            t - 1.0 <= s.window_s + 2.0 * DT,
            "held found {:.3} s late",
            t - 1.0
        );
    }

    #[test]
    fn a_locked_joint_is_named_while_the_others_move() {
        let (m, t) = drive(&[0.1, 0.05, -0.3], &[true, false, true], 2.0, 5.0).unwrap();
        assert_eq!(m, Motion::Locked { joint: 1 });
        assert!(t - 2.0 <= 0.5, "locked found {:.3} s late", t - 2.0);
    }

    #[test]
    fn a_slow_command_is_no_evidence() {
        // 0.02 rad/s < speed: a joint that does not move is not stuck.
        assert_eq!(drive(&[0.02, 0.0], &[false, false], 0.5, 5.0), None);
    }

    #[test]
    fn a_restart_needs_fast_commands_again_and_motion_is_seen() {
        let mut sup = MotionSupervisor::new(1, MotionSettings::default(), 0.0);
        let mut t = 0.0;
        for _ in 0..50 {
            sup.command(t, &[0.2]);
            t += DT;
            let _ = sup.measure(t, &[0.0]);
        }
        sup.reset();
        assert!(!sup.moved());
        // Right after the restart no joint is stuck however still.
        sup.command(t, &[0.2]);
        t += DT;
        assert_eq!(sup.measure(t, &[0.0]), Motion::Normal);
        assert_eq!(sup.measure(t + DT, &[0.01]), Motion::Normal);
        assert!(sup.moved());
    }

    #[test]
    fn a_gap_in_the_measurements_is_no_evidence_of_standing_still() {
        let mut sup = MotionSupervisor::new(1, MotionSettings::default(), 0.0);
        for k in 0..50 {
            let t = k as f64 * DT;
            sup.command(t, &[0.2]);
            assert_eq!(sup.measure(t, &[0.2 * t]), Motion::Normal);
        }
        // 1 s later, where the robot was: no measurement in between.
        sup.command(1.5, &[0.2]);
        assert_eq!(sup.measure(1.5, &[0.2 * 0.49]), Motion::Normal);
    }

    #[test]
    fn settings_are_checked() {
        assert!(MotionSettings::default().validate().is_ok());
        let s = MotionSettings {
            speed: 0.01,
            ..MotionSettings::default()
        };
        assert!(s.validate().unwrap_err().contains("look still"));
        let s = MotionSettings {
            window_s: -1.0,
            ..MotionSettings::default()
        };
        assert!(s.validate().is_err());
    }
}
