//! The robot-follows supervisor (position and trajectory modes): whether the next command
//! continues the last commanded position, restarts from the measured state, or brakes to a
//! hold; and the hold itself — the last commanded position `q_hold` (the anchor of the
//! next command), the last command's velocities and the history of commanded positions.
//!
//! It decides, [`NodeCore`](super::NodeCore) acts: a [`Verdict`] says go on (with the
//! code of a restart, and whether the tracking warning holds) or brake as a code; a
//! restart at rest also resets the safety filter's command history (the core's, told by
//! [`Supervisor::follow`]). The rules, in the order a tick applies them:
//!
//! - **Not-following latch** ([`Supervisor::admit`]): more than `safety.max_restarts`
//!   restarts within `safety.restart_window_s` mean the robot does not follow: the node
//!   brakes to a hold (`ROBOT_NOT_FOLLOWING`, every tick counted) until a new condition is
//!   accepted (or an operator's reset), then starts from the measured state with a clean
//!   restart count. A robot that does not follow would otherwise be restarted for ever.
//! - **Held dwell**: a robot found held ([`MotionSupervisor`]) is restarted at rest at its
//!   measured state and held there (`ROBOT_HELD`) for `[node.motion] held_dwell_s`, then
//!   tried again from the measured state: the policy runs, reported `ROBOT_HELD` until a
//!   joint moves; still held with the commands farther than `tracking_tolerance` from the
//!   robot, it is held again (a release then finds the commands close to its state), and
//!   that try counts as a restart: a robot held through more than `safety.max_restarts`
//!   tries within the window (a 3 s hold latched after 2.6 s on the physics robot) latches
//!   not following.
//! - **Resume**: a controller back (the command topic matched again) restarts from the
//!   measured state, counted as a restart.
//! - **Locked joint**: a joint found locked restarts from the measured state
//!   (`JOINT_LOCKED`, the joint named), counted as a restart.
//! - **Tracking envelope**: the measured `q` must lie within `safety.tracking_tolerance`
//!   of the hull of the commands issued since `safety.tracking_window_s` before its
//!   measurement (a servo whose step response does not overshoot stays inside the hull of
//!   its recent commands, so lag and sag pass) and, with a window, must not have jumped: a
//!   joint that moved farther than 1.5 × its commands' top speed × (the time between the
//!   two measurements + one period + the latency), plus half the tolerance, was moved by
//!   something else (a reset, another controller). Otherwise the commands restart from
//!   the measured state at rest (`RESTARTED_FROM_MEASURED`).
//! - **Tracking warning**: the distance to the command in effect at the measurement above
//!   `safety.tracking_warning` for longer than the window (at least one period):
//!   `TRACKING_ERROR`, counted.
//!
//! Counts go to the node's [`Counters`]. Allocation-free after construction.

use crossym_math::kinematics::JointLimits;

use super::code::StatusCode;
use super::command::{clamp_to, Command};
use super::counters::{bump, Counters};
use super::gate::Inputs;
use super::motion::{Motion, MotionSettings, MotionSupervisor};
use crate::safety::history::{CommandHistory, CommandWindow};

/// The supervisor's settings, fixed at start (from `[safety]`, `[node.motion]`, the
/// period and the filter's delays).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FollowSettings {
    /// `safety.tracking_tolerance` (rad or m).
    pub tolerance: f64,
    /// `safety.tracking_window_s`.
    pub window_s: f64,
    /// `safety.tracking_warning` (rad or m), if any.
    pub warning: Option<f64>,
    /// `safety.max_restarts`.
    pub max_restarts: u32,
    /// `safety.restart_window_s`.
    pub restart_window_s: f64,
    /// `[node.motion] held_dwell_s`.
    pub held_dwell_s: f64,
    /// The tick period (s).
    pub period_s: f64,
    /// The filter's state delay (s).
    pub state_delay_s: f64,
    /// The filter's latency (s).
    pub latency_s: f64,
}

/// What the supervisor decides before the policy runs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Verdict {
    /// Command on: the code of a restart from the measured state (or a locked joint), if
    /// any, and whether the tracking warning holds.
    Go {
        /// The restart's code.
        restart: Option<StatusCode>,
        /// The tracking warning holds.
        lagging: bool,
    },
    /// Brake to a hold, reported as this code.
    Brake(StatusCode),
}

/// A held robot's handling.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Held {
    /// Not held.
    Clear,
    /// Found held: holding at the measured state until the time (s).
    Dwell(f64),
    /// Trying the policy again; reported held until a joint moves.
    Probe,
}

/// The times of the last `max_restarts + 1` restarts (a ring).
#[derive(Debug, Clone, PartialEq)]
struct RestartWindow {
    times: Vec<f64>,
    head: usize,
    window_s: f64,
}

impl RestartWindow {
    fn new(max_restarts: u32, window_s: f64) -> Self {
        Self {
            times: vec![f64::NEG_INFINITY; max_restarts as usize + 1],
            head: 0,
            window_s,
        }
    }

    /// Records a restart at `now_s`; true when it makes more than `max_restarts` within
    /// the window (the robot does not follow).
    fn record(&mut self, now_s: f64) -> bool {
        let k = self.times.len();
        self.head = (self.head + 1) % k;
        self.times[self.head] = now_s;
        // The oldest of the last `max_restarts + 1` restarts.
        let oldest = self.times[(self.head + 1) % k];
        now_s - oldest <= self.window_s
    }

    /// Forgets every restart (a clean count).
    fn clear(&mut self) {
        self.times.fill(f64::NEG_INFINITY);
    }
}

/// The joint state the last envelope test saw (jump detection).
#[derive(Debug, Clone, PartialEq)]
struct JumpWatch {
    prev_q: Vec<f64>,
    prev_time_s: f64,
    prev_seq: u64,
    cmd_speed: Vec<f64>,
}

impl JumpWatch {
    fn new(n: usize) -> Self {
        Self {
            prev_q: vec![0.0; n],
            prev_time_s: f64::NEG_INFINITY,
            prev_seq: 0,
            cmd_speed: vec![0.0; n],
        }
    }

    /// Whether the measured state jumped since the previous joint state seen (module docs:
    /// a servo that does not overshoot moves no faster than its commands did over the
    /// window). Remembers the measurement for the next call.
    fn jumped(&mut self, i: &Inputs, history: &CommandHistory, s: &FollowSettings) -> bool {
        if i.joint_state_seq == self.prev_seq {
            return false;
        }
        let dt = i.measured_time_s - self.prev_time_s;
        let slack = 0.5 * s.tolerance;
        let since = i.measured_time_s - s.state_delay_s - s.latency_s - s.window_s - dt.max(0.0);
        // After a gap longer than the history (a silent robot) the commands' speed is not
        // known: no evidence of a jump; the hull test still applies.
        let known = history.max_speed(since, &mut self.cmd_speed);
        // A robot that takes each position command at once moves a whole period's step
        // between two measurements however close they are, and commands held up by the
        // latency envelope arrive together: one period and the latency more.
        let reach = dt + s.period_s + s.latency_s;
        let jumped = self.prev_seq != 0
            && known
            && dt >= 0.0
            && (0..self.prev_q.len())
                .any(|j| (i.q[j] - self.prev_q[j]).abs() > 1.5 * self.cmd_speed[j] * reach + slack);
        self.prev_q.copy_from_slice(&i.q);
        self.prev_time_s = i.measured_time_s;
        self.prev_seq = i.joint_state_seq;
        jumped
    }
}

/// The tracking error and how long it has been above the warning.
#[derive(Debug, Clone, Copy, PartialEq)]
struct TrackingWatch {
    high_since: Option<f64>,
    error: f64,
}

impl TrackingWatch {
    /// Whether the error has stayed above the warning for longer than the window (at least
    /// one period) at `now_s`; counts such ticks in `count`.
    fn watch(&mut self, now_s: f64, s: &FollowSettings, count: &mut u64) -> bool {
        let Some(limit) = s.warning else {
            return false;
        };
        if self.error <= limit {
            self.high_since = None;
            return false;
        }
        let since = *self.high_since.get_or_insert(now_s);
        let lagging = now_s - since >= s.window_s.max(s.period_s);
        if lagging {
            bump(count);
        }
        lagging
    }
}

/// The robot-follows supervisor and the hold it keeps (see the module docs).
pub(crate) struct Supervisor {
    s: FollowSettings,
    // The last commanded position (the anchor of the next command), whether there is one,
    // and the last command's velocities (the start of the next trajectory segment).
    q_hold: Vec<f64>,
    has_hold: bool,
    v_last: Vec<f64>,
    // Zero velocities: the filter's history at a restart at rest.
    zeros: Vec<f64>,
    // Commanded positions with their times, and the hull of those the robot may follow.
    history: CommandHistory,
    window: CommandWindow,
    unbounded: Vec<f64>,
    restarts: RestartWindow,
    jump: JumpWatch,
    tracking: TrackingWatch,
    // The condition under which the robot was found not following (the latch), if any.
    not_following: Option<u64>,
    // Held-robot and locked-joint detection, the reaction to a held robot, the last locked
    // joint, the joint state the motion supervisor last saw.
    motion: MotionSupervisor,
    held: Held,
    locked_joint: Option<usize>,
    motion_seq: u64,
}

impl Supervisor {
    /// A supervisor for `n` joints with no hold yet; the history holds `capacity` commands.
    pub fn new(n: usize, s: FollowSettings, motion: MotionSettings, capacity: usize) -> Self {
        Self {
            s,
            q_hold: vec![0.0; n],
            has_hold: false,
            v_last: vec![0.0; n],
            zeros: vec![0.0; n],
            history: CommandHistory::new(n, capacity),
            window: CommandWindow::new(n),
            unbounded: vec![f64::INFINITY; n],
            restarts: RestartWindow::new(s.max_restarts, s.restart_window_s),
            jump: JumpWatch::new(n),
            tracking: TrackingWatch {
                high_since: None,
                error: 0.0,
            },
            not_following: None,
            motion: MotionSupervisor::new(n, motion, s.latency_s + s.state_delay_s),
            held: Held::Clear,
            locked_joint: None,
            motion_seq: 0,
        }
    }

    /// The last commanded position (rad or m; the anchor of the next command).
    pub fn q_hold(&self) -> &[f64] {
        &self.q_hold
    }

    /// Whether there is a commanded position to hold (position modes).
    pub fn has_hold(&self) -> bool {
        self.has_hold
    }

    /// The last command's velocities.
    pub fn v_last(&self) -> &[f64] {
        &self.v_last
    }

    /// Zero velocities (the filter's history after a restart at rest).
    pub fn zeros(&self) -> &[f64] {
        &self.zeros
    }

    /// The measured state against the command in effect when it was measured (rad or m).
    pub fn tracking_error(&self) -> f64 {
        self.tracking.error
    }

    /// The last joint found locked, if any.
    pub fn locked_joint(&self) -> Option<usize> {
        self.locked_joint
    }

    /// Whether a held robot is being tried again (reported `ROBOT_HELD`).
    pub fn probing(&self) -> bool {
        self.held == Held::Probe
    }

    /// Forgets the hold: the next command starts from the measured state (a resume, an
    /// activation).
    pub fn drop_hold(&mut self) {
        self.has_hold = false;
    }

    /// An operator's reset: clears the latch, a held robot's dwell and the restart count;
    /// the next command starts from the measured state.
    pub fn reset(&mut self) {
        self.held = Held::Clear;
        self.not_following = None;
        self.has_hold = false;
        self.restarts.clear();
        self.tracking.high_since = None;
    }

    /// Before anything else of a fresh tick: the not-following latch (held until a
    /// condition other than `condition_seq`'s is accepted) and a held robot's dwell. `Some`:
    /// brake as that code.
    pub fn admit(
        &mut self,
        now_s: f64,
        condition_seq: u64,
        c: &mut Counters,
    ) -> Option<StatusCode> {
        if let Some(seq) = self.not_following {
            if condition_seq == seq {
                bump(&mut c.not_following_ticks);
                return Some(StatusCode::RobotNotFollowing);
            }
            // A new condition: start again from the measured state, with a clean count.
            self.not_following = None;
            self.has_hold = false;
            self.restarts.clear();
        }
        // A held robot is held at its measured state for a while, then tried again.
        if let Held::Dwell(until) = self.held {
            if now_s < until {
                return Some(StatusCode::RobotHeld);
            }
            self.held = Held::Probe;
            self.has_hold = false;
        }
        None
    }

    /// Position modes, after [`Self::admit`], before the policy runs: the verdict on the
    /// inputs `i` (`resume`: a controller came back), and whether the commands restarted
    /// at rest (the caller then resets the filter's history to [`Self::zeros`]).
    pub fn follow(
        &mut self,
        now_s: f64,
        i: &Inputs,
        limits: &[JointLimits],
        resume: bool,
        c: &mut Counters,
    ) -> (Verdict, bool) {
        let resumed = resume && self.has_hold;
        if resumed {
            self.has_hold = false;
            bump(&mut c.restarts);
        }
        let mut at_rest = false;
        match self.envelope(now_s, i, limits, c, &mut at_rest) {
            Verdict::Go { lagging, .. } if resumed => (
                Verdict::Go {
                    restart: Some(StatusCode::RestartedFromMeasured),
                    lagging,
                },
                at_rest,
            ),
            v => (v, at_rest),
        }
    }

    /// The held robot, the locked joint, the envelope and the restart count (module docs).
    fn envelope(
        &mut self,
        now_s: f64,
        i: &Inputs,
        limits: &[JointLimits],
        c: &mut Counters,
        at_rest: &mut bool,
    ) -> Verdict {
        let motion = self.watch_motion(i);
        if let Motion::Held { .. } = motion {
            // Hold where the robot is (no command away from it while it cannot move), then
            // try again: a release finds the commands on the measured state.
            bump(&mut c.held_events);
            self.restart_at_rest(now_s, &i.q, limits);
            *at_rest = true;
            // Tried again and held again: a restart the robot did not follow, counted (a
            // robot held for good, e.g. one joint frozen while only it is commanded to
            // move, latches instead of being tried for ever).
            if self.held == Held::Probe && self.count_restart(now_s, i.condition_seq, c) {
                self.held = Held::Clear;
                return Verdict::Brake(StatusCode::RobotNotFollowing);
            }
            self.held = Held::Dwell(now_s + self.s.held_dwell_s);
            return Verdict::Brake(StatusCode::RobotHeld);
        }
        let locked = if let Motion::Locked { joint } = motion {
            bump(&mut c.locked_events);
            self.locked_joint = Some(joint);
            true
        } else {
            false
        };
        // With a lag window, a measured jump restarts even when it lands inside the
        // envelope of the window's commands. Without one the envelope is the commands
        // since the measurement: a jump leaves it anyway.
        let jumped = self.s.window_s > 0.0 && self.jump.jumped(i, &self.history, &self.s);
        let tracks = !self.has_hold || (!locked && !jumped && self.tracks_commands(i));
        if !tracks && self.count_restart(now_s, i.condition_seq, c) {
            // Repeated restarts: the robot does not follow. Hold where the commands are.
            return Verdict::Brake(StatusCode::RobotNotFollowing);
        }
        let mut restart = None;
        if !self.has_hold || !tracks {
            if self.has_hold {
                restart = Some(if locked {
                    StatusCode::JointLocked
                } else {
                    StatusCode::RestartedFromMeasured
                });
            }
            self.restart_at_rest(now_s, &i.q, limits);
            *at_rest = true;
        }
        let lagging = self
            .tracking
            .watch(now_s, &self.s, &mut c.tracking_warning_ticks);
        Verdict::Go { restart, lagging }
    }

    /// Counts a restart at `now_s`; true when it makes more than `max_restarts` within the
    /// window: the not-following latch is set under `condition_seq`.
    fn count_restart(&mut self, now_s: f64, condition_seq: u64, c: &mut Counters) -> bool {
        bump(&mut c.restarts);
        if !self.restarts.record(now_s) {
            return false;
        }
        self.not_following = Some(condition_seq);
        bump(&mut c.not_following_ticks);
        self.tracking.high_since = None;
        true
    }

    /// The motion supervisor on a new joint state (while commands are continued): held,
    /// locked or nothing.
    fn watch_motion(&mut self, i: &Inputs) -> Motion {
        if !self.has_hold || i.joint_state_seq == self.motion_seq {
            return Motion::Normal;
        }
        self.motion_seq = i.joint_state_seq;
        let t = i.state_time_s.unwrap_or(i.measured_time_s);
        let m = self.motion.measure(t, &i.q);
        if self.held == Held::Probe {
            if self.motion.moved() {
                self.held = Held::Clear;
            } else if let Some(joint) =
                (0..self.q_hold.len()).find(|&j| (self.q_hold[j] - i.q[j]).abs() > self.s.tolerance)
            {
                // Tried again and still held: no farther than the tracking tolerance from
                // the robot (a release then finds the command close to its state).
                return Motion::Held { joint };
            }
        }
        m
    }

    /// True when the measured `q` lies within the tolerance of the hull of the positions
    /// the robot may be following: the commands from the window before the measurement
    /// until now. Also sets the tracking error.
    fn tracks_commands(&mut self, i: &Inputs) -> bool {
        let s = i.measured_time_s - self.s.state_delay_s;
        let t = i.state_time_s.unwrap_or(s);
        self.history.window(
            s.min(t) - self.s.window_s,
            t,
            self.s.latency_s,
            &self.unbounded,
            &mut self.window,
        );
        let n = self.q_hold.len();
        self.tracking.error = match self.history.at(s) {
            Some(c) => (0..n).fold(0.0, |e: f64, j| e.max((i.q[j] - c[j]).abs())),
            None => 0.0,
        };
        let tol = self.s.tolerance;
        (0..n).all(|j| {
            i.q[j] >= self.window.past_min[j] - tol && i.q[j] <= self.window.past_max[j] + tol
        })
    }

    /// The commands restart from the measured `q` at rest.
    fn restart_at_rest(&mut self, now_s: f64, q: &[f64], limits: &[JointLimits]) {
        for (j, h) in self.q_hold.iter_mut().enumerate() {
            *h = clamp_to(&limits[j], q[j]);
        }
        if self.has_hold {
            // Commands still in flight may yet move the robot: keep them in the hull.
            self.history.push(now_s, &self.q_hold);
        } else {
            self.history.reset_to(&self.q_hold);
        }
        self.has_hold = true;
        self.tracking.high_since = None;
        self.tracking.error = 0.0;
        self.v_last.fill(0.0);
        self.motion.reset();
    }

    /// The command `out` was issued at `now_s`: in position modes its positions are the
    /// new hold and join the history; its velocities start the next segment.
    pub fn commanded(&mut self, now_s: f64, position: bool, out: &Command) {
        if position {
            self.q_hold.copy_from_slice(&out.positions);
            self.history.push(now_s, &out.positions);
        }
        self.v_last.copy_from_slice(&out.velocities);
    }

    /// After every tick (position modes): the motion supervisor learns the command.
    pub fn after_tick(&mut self, now_s: f64) {
        self.motion.command(now_s, &self.v_last);
    }
}

#[cfg(test)]
#[path = "supervisor_tests.rs"]
mod tests;
