//! The simulated robot of an episode, independent of the node and of the mock hardware:
//! time in integer microseconds, velocity commands integrated exactly (piecewise constant
//! between events, so a position's extremes lie at event times) or position commands
//! reached at once (an ideal servo), the last command held, nothing enforced; its joint
//! states carry the episode's input faults.

use std::collections::VecDeque;

use rand::rngs::StdRng;
use rand::Rng;

use crossym_io::msg;
use crossym_math::kinematics::JointLimits;

use super::tally::Tally;

/// An input fault active over a time window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fault {
    /// One controlled joint's position is NaN.
    NanPosition(usize),
    /// One controlled joint is missing from the message.
    MissingJoint(usize),
    /// One controlled joint appears twice.
    DuplicateJoint(usize),
    /// One controlled joint carries another name.
    RenamedJoint(usize),
    /// The driver republishes its last message unchanged (stamp included).
    Frozen,
    /// No joint states.
    Silent,
    /// Stamps lie this far (s) in the future.
    FutureStamp(f64),
    /// Stamps lie this far (s) in the past.
    PastStamp(f64),
}

impl Fault {
    pub(super) fn name(&self) -> &'static str {
        match self {
            Fault::NanPosition(_) => "nan",
            Fault::MissingJoint(_) => "missing",
            Fault::DuplicateJoint(_) => "duplicate",
            Fault::RenamedJoint(_) => "renamed",
            Fault::Frozen => "frozen",
            Fault::Silent => "silent",
            Fault::FutureStamp(_) => "future stamp",
            Fault::PastStamp(_) => "past stamp",
        }
    }
}

/// A command on its way to the robot.
struct Pending {
    at_us: i64,
    data: Vec<f64>,
}

/// The robot's state and the commands in flight to it.
pub(super) struct SimRobot<'a> {
    /// True position (rad or m).
    pub q: Vec<f64>,
    /// The command in effect (velocity, or position for a position robot).
    cmd: Vec<f64>,
    /// Position (or trajectory) commands: the robot jumps to them.
    position: bool,
    pending: VecDeque<Pending>,
    last_arrival: i64,
    last_state: Option<msg::JointState>,
    names: Vec<String>,
    limits: &'a [JointLimits],
}

impl<'a> SimRobot<'a> {
    /// A robot at `start` with joints `names` and the episode's `limits`.
    pub fn new(
        start: Vec<f64>,
        names: Vec<String>,
        limits: &'a [JointLimits],
        position: bool,
    ) -> Self {
        let n = start.len();
        Self {
            q: start,
            cmd: vec![0.0; n],
            position,
            pending: VecDeque::new(),
            last_arrival: i64::MIN,
            last_state: None,
            names,
            limits,
        }
    }

    /// Counts every joint beyond its limit (by more than 1e-9).
    pub fn check_position(&self, tally: &mut Tally) {
        let q = &self.q;
        for j in 0..q.len() {
            let l = &self.limits[j];
            let e = (q[j] - l.upper).max(l.lower - q[j]);
            if e > 1e-9 {
                if std::env::var_os("CROSSYM_STRESS_TRACE").is_some() && tally.position < 3 {
                    eprintln!(
                        "position joint {j}: {:.5} outside [{:.4}, {:.4}] by {e:.2e}",
                        q[j], l.lower, l.upper
                    );
                }
                tally.position += 1;
                tally.position_worst = tally.position_worst.max(e);
            }
        }
    }

    /// When the next command in flight arrives (µs; `i64::MAX` with none).
    pub fn next_command_at(&self) -> i64 {
        self.pending.front().map_or(i64::MAX, |p| p.at_us)
    }

    /// Moves from `t` to `t_next` (µs) under the velocity command in effect.
    pub fn integrate(&mut self, t: i64, t_next: i64, tally: &mut Tally) {
        if !self.position && t_next > t {
            let h = (t_next - t) as f64 * 1e-6;
            for j in 0..self.q.len() {
                self.q[j] += self.cmd[j] * h;
            }
            self.check_position(tally);
        }
    }

    /// Applies the commands arriving by `t` (µs).
    pub fn receive(&mut self, t: i64, tally: &mut Tally) {
        while self.pending.front().is_some_and(|p| p.at_us <= t) {
            let p = self.pending.pop_front().expect("front");
            self.cmd.copy_from_slice(&p.data);
            if self.position {
                self.q.copy_from_slice(&p.data);
                self.check_position(tally);
            }
        }
    }

    /// Puts a command in flight, to arrive at `at_us` (in order: never before the previous).
    pub fn send(&mut self, at_us: i64, data: Vec<f64>) {
        let at = at_us.max(self.last_arrival);
        self.last_arrival = at;
        self.pending.push_back(Pending { at_us: at, data });
    }

    /// The joint state the robot publishes at `t` (µs) under `fault`, with Gaussian noise
    /// of standard deviation `noise` (drawn from `rng`); `None` when it is silent.
    pub fn publish(
        &mut self,
        t: i64,
        fault: Option<Fault>,
        noise: f64,
        rng: &mut StdRng,
    ) -> Option<msg::JointState> {
        let stamp_s = t as f64 * 1e-6;
        match fault {
            Some(Fault::Silent) => None,
            Some(Fault::Frozen) => self.last_state.clone(),
            _ => {
                let mut name = self.names.clone();
                let mut position: Vec<f64> = self
                    .q
                    .iter()
                    .map(|&x| {
                        if noise > 0.0 {
                            let u1: f64 = rng.random::<f64>().max(1e-300);
                            let u2: f64 = rng.random();
                            x + noise
                                * (-2.0 * u1.ln()).sqrt()
                                * (2.0 * std::f64::consts::PI * u2).cos()
                        } else {
                            x
                        }
                    })
                    .collect();
                let mut stamp = stamp_s;
                match fault {
                    Some(Fault::NanPosition(j)) => position[j] = f64::NAN,
                    Some(Fault::MissingJoint(j)) => {
                        name.remove(j);
                        position.remove(j);
                    }
                    Some(Fault::DuplicateJoint(j)) => {
                        name.push(name[j].clone());
                        position.push(position[j] + 0.1);
                    }
                    Some(Fault::RenamedJoint(j)) => name[j] = format!("{}_renamed", name[j]),
                    Some(Fault::FutureStamp(d)) => stamp += d,
                    Some(Fault::PastStamp(d)) => stamp -= d,
                    _ => {}
                }
                let m = msg::JointState {
                    header: msg::Header {
                        stamp: msg::Time::from_secs_f64(stamp.max(1e-6)),
                        frame_id: String::new(),
                    },
                    name,
                    position,
                    velocity: Vec::new(),
                    effort: Vec::new(),
                };
                self.last_state = Some(m.clone());
                Some(m)
            }
        }
    }
}
