//! The tick's own timing, as the caller measures it around [`NodeCore::tick`]: how long it
//! ran, and how late it started — what a loaded computer (perception, logging, a build)
//! does to the node before anything else shows it.
//!
//! A tick is *late* when it starts more than half a period after its time: a timer tick
//! after the instant it was due, a joint-state tick after its joint state was sent (the
//! state's source stamp where the driver's clock agrees with ours, else its DDS receive
//! stamp). Ticks are *missed* when they never run: timer ticks skipped
//! (`⌊lateness / period⌋`: the next tick is scheduled one period after the late one, so a
//! late tick does not bunch up), or joint states read together and ticked once, on the
//! latest (all but one). `~/status` carries the totals and the counts of its period; the
//! log warns once a period has late or missed ticks. Allocation-free.
//!
//! [`NodeCore::tick`]: super::NodeCore::tick

/// The tick's duration and lateness, totals since start.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TickTiming {
    period_s: f64,
    /// Duration of the last tick (µs).
    pub last_us: f64,
    /// Longest tick (µs).
    pub max_us: f64,
    /// Ticks started more than half a period late (count).
    pub late: u64,
    /// Ticks never run (count).
    pub missed: u64,
    /// Largest lateness of a tick's start (µs).
    pub late_max_us: f64,
}

impl TickTiming {
    /// No tick yet, at `period_s` (s).
    pub fn new(period_s: f64) -> Self {
        Self {
            period_s,
            last_us: 0.0,
            max_us: 0.0,
            late: 0,
            missed: 0,
            late_max_us: 0.0,
        }
    }

    /// The duration of the tick that just ran (µs); a non-finite value is ignored.
    pub fn record_duration(&mut self, us: f64) {
        if us.is_finite() {
            self.last_us = us;
            self.max_us = self.max_us.max(us);
        }
    }

    /// A tick starts `late_s` (s) after its time, `missed` ticks having never run before
    /// it; a non-finite or negative lateness counts as on time.
    pub fn record_start(&mut self, late_s: f64, missed: u32) {
        self.missed = self.missed.saturating_add(u64::from(missed));
        if late_s.is_finite() && late_s > 0.0 {
            self.late_max_us = self.late_max_us.max(late_s * 1e6);
            if late_s > 0.5 * self.period_s {
                self.late = self.late.saturating_add(1);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tick_is_late_past_half_a_period_and_missed_ticks_add_up() {
        let mut t = TickTiming::new(0.01);
        t.record_start(0.004, 0);
        assert_eq!((t.late, t.missed), (0, 0), "4 ms of 10: on time");
        t.record_start(0.006, 0);
        assert_eq!(t.late, 1);
        t.record_start(0.035, 3);
        assert_eq!((t.late, t.missed), (2, 3));
        assert!((t.late_max_us - 35_000.0).abs() < 1e-6);
        for bad in [f64::NAN, f64::INFINITY, -1.0] {
            t.record_start(bad, 0);
        }
        assert_eq!((t.late, t.missed), (2, 3));
        assert!((t.late_max_us - 35_000.0).abs() < 1e-6);
    }

    #[test]
    fn durations_keep_the_last_and_the_longest() {
        let mut t = TickTiming::new(0.01);
        t.record_duration(12.0);
        t.record_duration(30.0);
        t.record_duration(f64::NAN);
        t.record_duration(8.0);
        assert_eq!((t.last_us, t.max_us), (8.0, 30.0));
    }
}
