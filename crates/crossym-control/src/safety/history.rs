//! The commands published so far and which of them the robot may still be executing.
//!
//! Latency model (velocity commands, the `[node] safety.latency_s` envelope `L`): a command
//! issued at `t_k` reaches the robot at some time in `[t_k, t_k + L]`, in order, and the
//! robot executes the latest one it has received (ros2_control's ForwardCommandController
//! holds it). `L` covers transport, dropped commands (a run of `m` drops adds `m` periods)
//! and late ticks. Then at any time `τ` the robot runs one of the commands
//!
//! `S(τ) = { k : t_k ≥ t_{j(τ)}, t_k ≤ τ }`,  `j(τ)` = the last command issued at or before `τ − L`,
//!
//! because command `j(τ)` has surely arrived by `τ`. `j` never decreases with `τ`, so every
//! command possibly in effect during `[s, t)` belongs to `{ k ≥ j(s) }`. Before the first
//! command the robot is taken to be at rest: the history starts with a zero command at
//! `t = −∞`. [`CommandHistory::window`] returns, per joint, the largest and smallest command
//! of `{ k ≥ j(s) }` and of `{ k ≥ j(t) }`; when `j(s)` is older than the oldest retained
//! command the joint's velocity limit stands in for it (sound, conservative).

/// Ring buffer of the last commands (rad/s or m/s) with their issue times (s). Setup
/// allocates; [`CommandHistory::push`] and [`CommandHistory::window`] do not.
#[derive(Debug, Clone)]
pub struct CommandHistory {
    n: usize,
    cap: usize,
    times: Vec<f64>,
    values: Vec<f64>,
    len: usize,
    head: usize,
    evicted: bool,
}

/// Per-joint extremes of the commands the robot may execute over a window (rad/s or m/s).
#[derive(Debug, Clone, PartialEq)]
pub struct CommandWindow {
    /// Largest command of `{ k ≥ j(s) }`: any command possibly in effect since the measurement.
    pub past_max: Vec<f64>,
    /// Smallest command of `{ k ≥ j(s) }`.
    pub past_min: Vec<f64>,
    /// Largest command of `{ k ≥ j(t) }`: any command possibly in effect from now until the new one arrives.
    pub recent_max: Vec<f64>,
    /// Smallest command of `{ k ≥ j(t) }`.
    pub recent_min: Vec<f64>,
}

impl CommandWindow {
    /// A window for `n` joints (all zero).
    pub fn new(n: usize) -> Self {
        Self {
            past_max: vec![0.0; n],
            past_min: vec![0.0; n],
            recent_max: vec![0.0; n],
            recent_min: vec![0.0; n],
        }
    }
}

impl CommandHistory {
    /// A history of `n` joints keeping the last `capacity` commands (at least 2), starting
    /// with the robot at rest (a zero command at `t = −∞`).
    pub fn new(n: usize, capacity: usize) -> Self {
        let cap = capacity.max(2);
        let mut h = Self {
            n,
            cap,
            times: vec![0.0; cap],
            values: vec![0.0; cap * n],
            len: 0,
            head: 0,
            evicted: false,
        };
        h.clear();
        h
    }

    /// Forgets every command: the robot is at rest again (zero command at `t = −∞`).
    pub fn clear(&mut self) {
        self.len = 1;
        self.head = 0;
        self.evicted = false;
        self.times[0] = f64::NEG_INFINITY;
        self.values[..self.n].fill(0.0);
    }

    /// Forgets every command: the robot is taken to have run `u` since `t = −∞`.
    pub fn reset_to(&mut self, u: &[f64]) {
        self.clear();
        self.values[..self.n].copy_from_slice(u);
    }

    /// Commands retained (count, including the initial rest command until it is evicted).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always false: the history holds at least the initial rest command.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Issue time (s) of the newest command (`−∞` before the first).
    pub fn last_time(&self) -> f64 {
        self.times[self.head]
    }

    /// The newest command (rad/s or m/s).
    pub fn last(&self) -> &[f64] {
        &self.values[self.head * self.n..(self.head + 1) * self.n]
    }

    /// Records the command `u` issued at `t_s` (s). Times must not decrease; an earlier time
    /// is stored as the newest one's.
    pub fn push(&mut self, t_s: f64, u: &[f64]) {
        debug_assert_eq!(u.len(), self.n);
        let t = if t_s >= self.last_time() {
            t_s
        } else {
            self.last_time()
        };
        self.head = (self.head + 1) % self.cap;
        if self.len == self.cap {
            self.evicted = true;
        } else {
            self.len += 1;
        }
        self.times[self.head] = t;
        self.values[self.head * self.n..(self.head + 1) * self.n].copy_from_slice(u);
    }

    /// Fills `w` with the extremes of `{ k ≥ j(s_s) }` and `{ k ≥ j(t_s) }` for latency
    /// `latency_s` (see the module docs); `vmax[i]` stands in for commands older than the
    /// history. `s_s ≤ t_s` (s). Allocation-free.
    pub fn window(&self, s_s: f64, t_s: f64, latency_s: f64, vmax: &[f64], w: &mut CommandWindow) {
        let n = self.n;
        w.past_max.fill(f64::NEG_INFINITY);
        w.past_min.fill(f64::INFINITY);
        let (cut_s, cut_t) = (s_s - latency_s, t_s - latency_s);
        let mut recent_done = false;
        let mut past_done = false;
        for age in 0..self.len {
            let k = (self.head + self.cap - age) % self.cap;
            let row = &self.values[k * n..(k + 1) * n];
            for i in 0..n {
                w.past_max[i] = w.past_max[i].max(row[i]);
                w.past_min[i] = w.past_min[i].min(row[i]);
            }
            let tk = self.times[k];
            if !recent_done && tk <= cut_t {
                w.recent_max.copy_from_slice(&w.past_max);
                w.recent_min.copy_from_slice(&w.past_min);
                recent_done = true;
            }
            if tk <= cut_s {
                past_done = true;
                break;
            }
        }
        if !past_done {
            // j(s) is older than anything retained: it may be any admissible velocity.
            for i in 0..n {
                w.past_max[i] = w.past_max[i].max(vmax[i]);
                w.past_min[i] = w.past_min[i].min(-vmax[i]);
            }
        }
        if !recent_done {
            w.recent_max.copy_from_slice(&w.past_max);
            w.recent_min.copy_from_slice(&w.past_min);
        }
    }

    /// The newest command issued at or before `t_s` (s); `None` when every retained
    /// command is newer (the rest command at `t = −∞` counts until it is evicted).
    /// Allocation-free.
    pub fn at(&self, t_s: f64) -> Option<&[f64]> {
        let n = self.n;
        (0..self.len)
            .map(|age| (self.head + self.cap - age) % self.cap)
            .find(|&k| self.times[k] <= t_s)
            .map(|k| &self.values[k * n..(k + 1) * n])
    }

    /// Per joint, the largest speed `|u_k − u_{k−1}| / (t_k − t_{k−1})` between consecutive
    /// commands issued at or after `s_s` (s) into `out` (0 when fewer than two; a pair at the
    /// same time counts as infinitely fast). For position commands: how fast the commands
    /// moved. Returns whether the history reaches back to `s_s`: false when commands issued
    /// after `s_s` were evicted, so `out` may miss faster ones. Allocation-free.
    pub fn max_speed(&self, s_s: f64, out: &mut [f64]) -> bool {
        let n = self.n;
        out.fill(0.0);
        for age in 1..self.len {
            let k = (self.head + self.cap - age + 1) % self.cap;
            let p = (self.head + self.cap - age) % self.cap;
            if self.times[p] < s_s {
                return true;
            }
            let dt = self.times[k] - self.times[p];
            for (i, o) in out.iter_mut().enumerate() {
                let du = (self.values[k * n + i] - self.values[p * n + i]).abs();
                let v = if dt > 0.0 {
                    du / dt
                } else if du > 0.0 {
                    f64::INFINITY
                } else {
                    0.0
                };
                *o = o.max(v);
            }
        }
        // Every retained command is at or after `s_s`: complete unless older ones (the
        // oldest retained one's predecessor) were evicted.
        !self.evicted
    }

    /// Capacity (commands).
    pub fn capacity(&self) -> usize {
        self.cap
    }

    /// True once the initial rest command or later ones have been evicted.
    pub fn evicted(&self) -> bool {
        self.evicted
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_covers_the_commands_possibly_in_effect() {
        let mut h = CommandHistory::new(1, 8);
        let vmax = [9.0];
        let mut w = CommandWindow::new(1);
        // Before any command: the rest command only.
        h.window(0.0, 0.0, 0.01, &vmax, &mut w);
        assert_eq!((w.past_max[0], w.recent_max[0]), (0.0, 0.0));
        for (k, u) in [1.0, 2.0, 3.0, -1.0].into_iter().enumerate() {
            h.push(0.01 * k as f64, &[u]);
        }
        // t = 0.04, L = 0.01: j(t) is the command of 0.03 (−1), so recent = {−1}. The state of
        // s = 0.015: j(s) is the command of 0.0 (1.0): past = {1, 2, 3, −1}.
        h.window(0.015, 0.04, 0.01, &vmax, &mut w);
        assert_eq!((w.recent_max[0], w.recent_min[0]), (-1.0, -1.0));
        assert_eq!((w.past_max[0], w.past_min[0]), (3.0, -1.0));
        // A state older than the history: the velocity limit stands in.
        let mut h = CommandHistory::new(1, 2);
        for k in 0..5 {
            h.push(0.01 * k as f64, &[0.5]);
        }
        h.window(0.0, 0.04, 0.01, &vmax, &mut w);
        assert_eq!((w.past_max[0], w.past_min[0]), (9.0, -9.0));
    }

    #[test]
    fn at_is_the_newest_command_issued_by_then() {
        let mut h = CommandHistory::new(1, 3);
        assert_eq!(h.at(-1e9), Some(&[0.0][..]), "the rest command of t = −∞");
        for (k, u) in [1.0, 2.0, 3.0].into_iter().enumerate() {
            h.push(0.01 * k as f64, &[u]);
        }
        assert_eq!(h.at(0.015), Some(&[2.0][..]));
        assert_eq!(h.at(0.02), Some(&[3.0][..]));
        assert_eq!(h.at(1.0), Some(&[3.0][..]));
        // Capacity 3: the rest command and nothing older than 0.0 is retained.
        assert_eq!(h.at(-0.5), None);
    }

    #[test]
    fn max_speed_is_the_fastest_step_since_then() {
        let mut h = CommandHistory::new(1, 8);
        let mut v = [0.0];
        h.max_speed(0.0, &mut v);
        assert_eq!(v, [0.0], "one command: no speed");
        for (t, u) in [(0.0, 0.0), (0.01, 0.01), (0.02, 0.04), (0.03, 0.05)] {
            h.push(t, &[u]);
        }
        h.max_speed(0.0, &mut v);
        assert!((v[0] - 3.0).abs() < 1e-9, "{v:?}");
        // Only the pair issued at or after 0.02.
        h.max_speed(0.02, &mut v);
        assert!((v[0] - 1.0).abs() < 1e-9, "{v:?}");
        h.push(0.03, &[0.06]);
        h.max_speed(0.025, &mut v);
        assert_eq!(v, [f64::INFINITY], "a step at one time");
    }

    #[test]
    fn max_speed_says_when_the_history_does_not_reach_back() {
        let mut h = CommandHistory::new(1, 3);
        let mut v = [0.0];
        assert!(
            h.max_speed(-1.0, &mut v),
            "the rest command covers all time"
        );
        // A fast step, then slow ones that evict it.
        for (t, u) in [(0.0, 0.0), (0.01, 1.0), (0.02, 1.0), (0.03, 1.0)] {
            h.push(t, &[u]);
        }
        // Retained: 0.01, 0.02, 0.03. Since 0.015 the history is complete (both pairs).
        assert!(h.max_speed(0.015, &mut v));
        assert_eq!(v, [0.0]);
        // Since 0.0 the step 0.0 -> 0.01 was evicted: speed 0 seen, but incomplete.
        assert!(!h.max_speed(0.0, &mut v), "{v:?}");
        assert_eq!(v, [0.0]);
    }
}
