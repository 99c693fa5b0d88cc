//! The motion supervisor (position modes): a robot **held** (rby1_hardware's collision hold:
//! every arm joint stops while commanded to move) and a **locked** joint (a brake, a jam:
//! one joint stops while the others go on), told from the measured motion against the
//! commanded motion.
//!
//! Joint `j` is *still* at a measurement time `t` when every measured position of the last
//! `window_s` lay within a band of one value: `±still` scaled to its command when it is
//! commanded to move, `±still_ratio·v·window_s` (`v` its slowest command since it became
//! fast: it moved slower than `still_ratio` of its command) kept within `[still, 2·still]`;
//! `±2·still` otherwise (it settles at its own pace: sag, coupling); one not commanded to
//! move whose measured speed is below `still / window_s` (less than half its band in a
//! window) *settles*: it counts as still for a hold (a hold's jolt throws coupled joints on,
//! and they slow down over a servo time constant). A joint commanded to
//! move whose measured speed (low-passed over `window_s / 3`) is below
//! `min(still_ratio·v, 2·still / window_s)` *creeps* (a held arm's servos settling,
//! compliance): leaving its band then moves the band along and keeps it still, and while
//! it creeps it counts as still for a hold and never as following (whenever it last left
//! its band: perhaps before its command was fast long enough to count). It is *commanded to
//! move* when every command since `t − window_s − delay` had `|q̇ⱼ| ≥ speed` with one sign,
//! `delay` being the servo's response (`response_s`) plus the filter's latency and state
//! delay: a servo that follows such commands moves at least `speed·window_s ≥ 2·still`
//! (checked) over the window after `delay`, farther than its band. A joint both still and
//! commanded to move is *stuck*. No band is wider than `2·still`: a held robot is restarted
//! at rest, which must not stop a joint moving faster than about `2·still / window_s`.
//!
//! - **Held**: every joint still, or commanded to move and thrown back against its command
//!   (its last exit from its band was against the command's sign: a hold's jolt, a push),
//!   and at least one stuck. Bound from the hold: the servos stopping (≈ their time
//!   constant, `response_s`, 0.1 s on RB-Y1, measured on the physics robot: every joint
//!   commanded to move inside its band 0.05–0.1 s after the hold, every other one slower
//!   than `still / window_s` by 0.15 s, which its window covers) + `window_s` + one
//!   joint-state period and one tick; with the defaults (0.15 s) 0.27 s, stated as 0.3 s.
//! - **Locked**: a joint stuck for `window_s + 2·response_s` while another joint commanded
//!   to move is not still and last left its band in the direction of its command, i.e.
//!   follows it (named; a joint thrown back against its command by a hold's jolt, settling or sagging
//!   without a command of its own is no evidence; a hold stops the joints one after the other as the servos settle, within
//!   about `2·response_s`: the wait keeps a hold from being taken for a lock). Bound from
//!   the lock while the command is fast: `window_s + 2·response_s` + one joint-state
//!   period and one tick; with the defaults 0.37 s, stated as 0.5 s. A joint commanded
//!   slower than `speed` is no evidence (it moves less than the `still` band in a window):
//!   its lock is left to the tracking envelope.
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
    /// A joint commanded faster than `speed` counts as not moving within the wider band
    /// `still_ratio · v · window_s` too, `v` its slowest command since it became fast: it
    /// moves slower than this fraction of its command (a held robot's joints settle and
    /// drift by coupling at a few mrad/s for a few tenths of a second).
    pub still_ratio: f64,
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
            still_ratio: 0.3,
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
        if !(self.still_ratio.is_finite() && self.still_ratio > 0.0 && self.still_ratio <= 0.5) {
            return Err(format!(
                "still_ratio = {} must lie in (0, 0.5] (a joint that follows at half its \
                 command must look moving)",
                self.still_ratio
            ));
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
    fast_min: Vec<f64>,
    /// The direction (±1) of the joint's last exit from its band (0: none yet).
    exit_sign: Vec<f64>,
    /// The previous measurement and the measured speed (rad/s, low-passed over
    /// `window_s / 3`; infinite when unknown: after a gap or at the start).
    q_prev: Vec<f64>,
    speed_est: Vec<f64>,
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
            fast_min: vec![f64::INFINITY; n],
            exit_sign: vec![0.0; n],
            q_prev: vec![f64::NAN; n],
            speed_est: vec![f64::INFINITY; n],
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
        self.fast_min.fill(f64::INFINITY);
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
                self.fast_min[j] = f64::INFINITY;
            }
            if sign != 0.0 {
                self.fast_min[j] = self.fast_min[j].min(vj.abs());
            }
            self.fast_sign[j] = sign;
        }
    }

    /// The measured speeds, low-passed over `window_s / 3`, from the step `dt` (s) to `q`;
    /// unknown (infinite) after a gap longer than the window.
    fn update_speeds(&mut self, dt: f64, q: &[f64]) {
        let gap = !(dt > 0.0 && dt <= self.s.window_s);
        let a = 1.0 - (-3.0 * dt / self.s.window_s).exp();
        for (j, &qj) in q.iter().enumerate() {
            let v = ((qj - self.q_prev[j]) / dt).abs();
            self.speed_est[j] = if gap || !v.is_finite() {
                f64::INFINITY
            } else if self.speed_est[j].is_finite() {
                self.speed_est[j] + a * (v - self.speed_est[j])
            } else {
                v
            };
            self.q_prev[j] = qj;
        }
    }

    /// Joint `j`'s band (module docs): a fraction of the commanded motion for a joint
    /// commanded to move (`fast_min` finite), `2 · still` otherwise.
    fn band(&self, j: usize) -> f64 {
        let wide = self.s.still_ratio * self.fast_min[j] * self.s.window_s;
        if wide.is_finite() {
            wide.clamp(self.s.still, 2.0 * self.s.still)
        } else {
            2.0 * self.s.still
        }
    }

    /// A new measurement `q` at `t_s`: what it shows.
    pub fn measure(&mut self, t_s: f64, q: &[f64]) -> Motion {
        if !self.s.enabled {
            return Motion::Normal;
        }
        // Not moving is shown by measurements throughout the window: after a gap in them
        // (a silent driver) the evidence starts again.
        let dt = t_s - self.last_t;
        if dt > self.s.window_s {
            self.still_since.fill(t_s);
        }
        self.update_speeds(dt, q);
        self.last_t = t_s;
        // A joint commanded to move but measured slower than this creeps (a held arm's
        // servos settling, compliance): it is still, however far it creeps in a window.
        let creep_cap = 2.0 * self.s.still / self.s.window_s;
        let settle_cap = self.s.still / self.s.window_s;
        let mut all_still = true;
        let mut stuck = None;
        let mut locked = None;
        // Another joint commanded to move that moves with its command: what a lock (one
        // joint stops, the others go on) shows and a hold (every joint stops; some settle
        // later, rebound against their command, or drift under gravity without being
        // commanded) does not.
        let mut following = false;
        let fast_before = t_s - self.s.window_s - self.delay_s;
        let lock_still = self.s.window_s + 2.0 * self.s.response_s;
        for (j, &qj) in q.iter().enumerate() {
            // A NaN anchor (no measurement yet) re-anchors.
            let within = (qj - self.anchor[j]).abs() <= self.band(j);
            let fast = self.fast_since[j] <= fast_before;
            let creeps =
                fast && self.speed_est[j] < (self.s.still_ratio * self.fast_min[j]).min(creep_cap);
            if !within {
                if self.anchor[j].is_finite() && !creeps {
                    self.moved = true;
                    self.exit_sign[j] = (qj - self.anchor[j]).signum();
                }
                self.anchor[j] = qj;
                if !creeps {
                    self.still_since[j] = t_s;
                }
            }
            let still = t_s - self.still_since[j] >= self.s.window_s;
            // A joint commanded to move that last left its band in the direction of its
            // command follows it: evidence of a lock elsewhere, and no held robot. One
            // that left it against its command was thrown back (a hold's jolt, a push):
            // it does not follow, which a hold allows.
            let with = self.exit_sign[j] == self.fast_sign[j];
            // Measured slower than its creep (whenever it left its band, e.g. before its
            // command was fast long enough to count): it does not follow now. Not commanded
            // to move and slower than `still / window_s` (less than half its band in a
            // window), it settles: it counts as still for a hold.
            let settles = !fast && self.speed_est[j] < settle_cap;
            all_still &= still || creeps || settles || (fast && !with && self.exit_sign[j] != 0.0);
            following |= !still && fast && with && !creeps;
            if still && fast {
                stuck.get_or_insert(j);
                // A hold stops the joints one after the other as the servos settle: a lock
                // is told only once its joint has been still for the settling time more
                // (`2 · response_s`).
                if locked.is_none() && t_s - self.still_since[j] >= lock_still {
                    locked = Some(j);
                }
            }
        }
        match stuck {
            None => Motion::Normal,
            Some(joint) if all_still => Motion::Held { joint },
            _ => match locked {
                Some(joint) if following => Motion::Locked { joint },
                _ => Motion::Normal,
            },
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
        assert!(matches!(m, Motion::Held { joint: 0 | 1 }), "{m:?}");
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

    /// Two joints commanded fast stop at 1 s; a third, commanded slower than `speed`,
    /// drifts on at `drift` rad/s (sag, coupling after the jolt): the first verdict.
    fn hold_with_a_drifting_joint(drift: f64) -> (Motion, f64) {
        let mut sup = MotionSupervisor::new(3, MotionSettings::default(), 0.02);
        let v = [0.08, -0.05, drift];
        let mut q = [0.3; 3];
        let mut t = 0.0;
        loop {
            sup.command(t, &v);
            for j in 0..3 {
                if t < 1.0 || j == 2 {
                    q[j] += v[j] * DT;
                }
            }
            t += DT;
            let m = sup.measure(t, &q);
            if m != Motion::Normal || t > 3.0 {
                return (m, t);
            }
        }
    }

    #[test]
    fn a_hold_is_told_while_a_slow_joint_settles_and_not_while_one_moves() {
        // 0.01 rad/s: inside the `2 · still` band of a joint not commanded to move.
        let (m, t) = hold_with_a_drifting_joint(0.01);
        assert_eq!(m, Motion::Held { joint: 0 });
        let s = MotionSettings::default();
        assert!(
            t - 1.0 <= s.window_s + 2.0 * DT,
            "held found {:.3} s late",
            t - 1.0
        );
        // 0.029 rad/s (below `speed`, beyond `2 · still / window_s`): a joint still moving
        // is never restarted at rest as held; nor is it evidence of a lock, being
        // commanded slower than `speed` (a hold's settling or sag looks the same): the
        // stopped joints are left to the tracking envelope.
        let (m, _) = hold_with_a_drifting_joint(0.029);
        assert_eq!(m, Motion::Normal);
    }

    /// Joints commanded at `v` follow until a hold at 1 s; after it joint `j` moves by
    /// `after(j, t)` per period. Every verdict until 2 s must be `Held`; returns the first's
    /// delay after the hold.
    fn hold_seen_as_held(v: &[f64], after: impl Fn(usize, f64) -> f64) -> f64 {
        hold_seen_as_held_with(
            |_| v.to_vec(),
            |j, t| if t < 1.0 { v[j] * DT } else { after(j, t) },
        )
    }

    /// As [`hold_seen_as_held`], the commands `v(t)` and every step `step(j, t)` given.
    fn hold_seen_as_held_with<V: AsRef<[f64]>>(
        v: impl Fn(f64) -> V,
        step: impl Fn(usize, f64) -> f64,
    ) -> f64 {
        let n = v(0.0).as_ref().len();
        let mut sup = MotionSupervisor::new(n, MotionSettings::default(), 0.02);
        let mut q = vec![0.3; n];
        let mut t = 0.0;
        let mut verdicts = Vec::new();
        while t < 2.0 {
            sup.command(t, v(t).as_ref());
            for (j, qj) in q.iter_mut().enumerate() {
                *qj += step(j, t);
            }
            t += DT;
            let m = sup.measure(t, &q);
            if m != Motion::Normal {
                verdicts.push((m, t));
            }
        }
        assert!(
            verdicts
                .iter()
                .all(|(m, _)| matches!(m, Motion::Held { .. })),
            "{verdicts:?}"
        );
        let first = verdicts.first().expect("held").1;
        assert!(first > 1.0, "a verdict before the hold: {verdicts:?}");
        first - 1.0
    }

    /// The hold's jolt throws joint 2 back against its command, 7 mrad in 0.05 s (out of
    /// its band wherever it was in it), then it creeps back 3 mrad more over 0.4 s (on the
    /// physics RB-Y1 left_arm_0, at 0.07 rad/s, came back 3.2 mrad over 0.35 s, at times
    /// leaving its band): held within the window and a period as if it stood still, and
    /// never a lock (it does not follow its command).
    #[test]
    fn a_hold_whose_jolt_throws_a_joint_back_is_held_at_once_and_no_lock() {
        let delay = hold_seen_as_held(&[0.04, -0.05, -0.07], |j, t| match j {
            2 if t < 1.05 => 0.007 / 5.0,
            2 if t < 1.45 => 0.003 / 40.0,
            _ => 0.0,
        });
        let s = MotionSettings::default();
        assert!(
            delay <= s.window_s + 2.0 * DT,
            "held found {delay:.3} s late"
        );
    }

    /// Joint 1 (commanded at −0.04 rad/s) creeps on in its command's direction at 6 mrad/s
    /// (15 % of it: on the physics RB-Y1 left_arm_1 crept 2.5 mrad over 0.4 s after a
    /// collision hold), out of its band now and then: held within the bound of the module
    /// docs, never a lock. Its measured speed takes a while to fall below the creep's (the
    /// servo stopping, `response_s` in that bound).
    #[test]
    fn a_held_joint_that_creeps_on_is_still() {
        let delay = hold_seen_as_held(
            &[0.05, -0.04],
            |j, _| if j == 1 { -0.006 * DT } else { 0.0 },
        );
        let s = MotionSettings::default();
        assert!(
            delay <= s.response_s + s.window_s + 2.0 * DT,
            "held found {delay:.3} s late"
        );
    }

    /// Joint 1's command turns fast only at the hold (0.02 → 0.035 rad/s); it creeps on at
    /// 8 mrad/s in its direction and left its band while its command was not yet fast
    /// long enough to count (on the physics RB-Y1 `right_arm_3`, CI 2026-12-05: a false
    /// lock of `left_arm_1` at 0.36 s): it does not follow; held, never a lock.
    #[test]
    fn a_joint_creeping_since_before_its_command_turned_fast_does_not_follow() {
        let delay = hold_seen_as_held_with(
            |t| [0.05, if t < 1.0 { 0.02 } else { 0.035 }],
            |j, t| match (j, t < 1.0) {
                (0, true) => 0.05 * DT,
                (1, true) => 0.02 * DT,
                (1, false) => 0.008 * DT,
                _ => 0.0,
            },
        );
        let s = MotionSettings::default();
        assert!(
            delay <= s.response_s + s.window_s + 2.0 * DT,
            "held found {delay:.3} s late"
        );
    }

    /// Joint 1, commanded slower than `speed` (0.028 rad/s) and following, is thrown on by
    /// the hold's jolt and settles: 0.06 rad/s decaying with a time constant of 0.1 s (6 mrad
    /// more; 16 mrad/s at 0.13 s), out of its band as late as 0.2 s after the hold
    /// depending on where in its band it was (on the physics RB-Y1 right_arm_0 left its
    /// band 0.13 s after a hold at 15 mrad/s and slowing: held at 0.30 s). Held within the
    /// bound of the module docs from every phase (without the settling rule: 0.32 s),
    /// never a lock.
    #[test]
    fn a_joint_not_commanded_to_move_that_settles_late_does_not_delay_a_hold() {
        let s = MotionSettings::default();
        let mut worst: f64 = 0.0;
        for k in 0..16 {
            // The joint starts moving at `t0`: its band's phase at the hold.
            let t0 = k as f64 * DT;
            let delay = hold_seen_as_held_with(
                |t| [0.05, if t < t0 { 0.0 } else { 0.028 }],
                |j, t| match (j, t < 1.0) {
                    (0, true) => 0.05 * DT,
                    (1, true) if t >= t0 => 0.028 * DT,
                    (1, false) => 0.06 * (-(t - 1.0) / 0.1).exp() * DT,
                    _ => 0.0,
                },
            );
            worst = worst.max(delay);
        }
        assert!(
            worst <= s.response_s + s.window_s + 2.0 * DT,
            "held found {worst:.3} s late"
        );
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
