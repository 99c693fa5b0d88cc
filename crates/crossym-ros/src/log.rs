//! The node's own log: one line per event on the console (stderr) and on `/rosout`, like an
//! rclcpp node.
//!
//! Console lines follow rcutils' default format
//! `[{severity}] [{time}] [{name}]: {message}` with the wall time in seconds and
//! nanoseconds. Repeated events of one kind (a rejected joint state at 500 Hz) are rate
//! limited: the first is printed immediately, later ones at most once per interval with the
//! count of those suppressed since. Logging happens on the I/O side of the node, never on
//! the control tick: the tick only exports a [`StatusSnapshot`]
//! (a `Copy` value) from which [`StatusWatch`] derives transitions (stale ↔ fresh, safety
//! fallback episodes, policy faults); condition changes are logged where they are accepted.

use std::io::Write;
use std::time::{Duration, Instant};

use ros2_client::log::LogLevel;
use ros2_client::{NodeLoggingHandle, RosoutRaw};

use crossym_control::Severity;
use crossym_control::{StatusCode, StatusSnapshot};

/// The `/rosout` level of a severity.
fn ros_level(severity: Severity) -> LogLevel {
    match severity {
        Severity::Debug => LogLevel::Debug,
        Severity::Info => LogLevel::Info,
        Severity::Warn => LogLevel::Warn,
        Severity::Error => LogLevel::Error,
    }
}

/// One console line in rcutils' default format (wall time in s).
pub fn format_line(severity: Severity, wall_s: f64, node: &str, text: &str) -> String {
    let secs = wall_s.floor();
    let nanos = ((wall_s - secs) * 1e9).round().min(999_999_999.0);
    format!(
        "[{}] [{}.{:09}] [{}]: {}",
        severity.label(),
        secs as i64,
        nanos as u64,
        node,
        text
    )
}

/// Rate-limit state of one kind of event.
#[derive(Debug, Clone)]
struct Limit {
    kind: &'static str,
    severity: Severity,
    last: Option<Instant>,
    suppressed: u64,
}

/// The node's logger: console and `/rosout`, with per-kind rate limits.
pub struct NodeLog {
    node: String,
    rosout: Option<NodeLoggingHandle>,
    min: Severity,
    interval: Duration,
    limits: Vec<Limit>,
    sink: Box<dyn FnMut(&str) + Send>,
}

impl NodeLog {
    /// A logger for node `node` printing at `min` and above to stderr (and `/rosout` when
    /// given); repeated kinds at most once per `interval`.
    pub fn new(
        node: &str,
        rosout: Option<NodeLoggingHandle>,
        min: Severity,
        interval: Duration,
    ) -> Self {
        Self::with_sink(node, rosout, min, interval, |line| {
            let mut e = std::io::stderr().lock();
            let _ = writeln!(e, "{line}");
        })
    }

    /// As [`NodeLog::new`] with console lines handed to `sink` (tests).
    pub fn with_sink(
        node: &str,
        rosout: Option<NodeLoggingHandle>,
        min: Severity,
        interval: Duration,
        sink: impl FnMut(&str) + Send + 'static,
    ) -> Self {
        Self {
            node: node.into(),
            rosout,
            min,
            interval,
            limits: Vec::new(),
            sink: Box::new(sink),
        }
    }

    /// Sets the filter (runtime parameter `log_level`).
    pub fn set_min(&mut self, min: Severity) {
        self.min = min;
    }

    /// Logs one line (console and `/rosout`) when `severity` passes the filter.
    pub fn log(&mut self, severity: Severity, text: &str) {
        if severity < self.min {
            return;
        }
        let line = format_line(severity, crate::dds::wall_time_s(), &self.node, text);
        (self.sink)(&line);
        if let Some(r) = &self.rosout {
            r.rosout_raw(
                ros2_client::builtin_interfaces::Time::now(),
                ros_level(severity),
                &self.node,
                text,
                file!(),
                "crossym",
                line!(),
            );
        }
    }

    /// Logs an event of `kind`: the first immediately, then at most once per interval with
    /// the number suppressed since the last line of that kind.
    pub fn limited(&mut self, kind: &'static str, severity: Severity, text: &str) {
        self.limited_at(kind, severity, text, Instant::now());
    }

    /// [`NodeLog::limited`] at a given instant (the rate limit's clock; tests drive it).
    pub fn limited_at(&mut self, kind: &'static str, severity: Severity, text: &str, now: Instant) {
        let i = match self.limits.iter().position(|l| l.kind == kind) {
            Some(i) => i,
            None => {
                self.limits.push(Limit {
                    kind,
                    severity,
                    last: None,
                    suppressed: 0,
                });
                self.limits.len() - 1
            }
        };
        let l = &mut self.limits[i];
        if l.last
            .is_some_and(|t| now.duration_since(t) < self.interval)
        {
            l.suppressed += 1;
            return;
        }
        let suppressed = std::mem::take(&mut l.suppressed);
        l.last = Some(now);
        if suppressed > 0 {
            let text = format!("{text} ({suppressed} more since the last report)");
            self.log(severity, &text);
        } else {
            self.log(severity, text);
        }
    }

    /// Reports, for each kind whose interval has passed since its last line, how many events
    /// the rate limit held back meanwhile (called every few ms by the I/O loop): an event is
    /// never hidden longer than one interval, and the first of a kind is printed at once.
    pub fn flush_due(&mut self) {
        self.flush_due_at(Instant::now());
    }

    /// [`NodeLog::flush_due`] at a given instant (tests drive the clock).
    pub fn flush_due_at(&mut self, now: Instant) {
        let interval = self.interval;
        let due: Vec<(&'static str, Severity, u64)> = self
            .limits
            .iter_mut()
            .filter(|l| {
                l.suppressed > 0 && l.last.is_some_and(|t| now.duration_since(t) >= interval)
            })
            // The window is not restarted: the next event of the kind is printed in full at
            // once (restarting it here hid a second's events of another reason, e.g. a pose
            // rejected for its frame after one rejected for its stamp).
            .map(|l| (l.kind, l.severity, std::mem::take(&mut l.suppressed)))
            .collect();
        for (kind, severity, n) in due {
            self.log(
                severity,
                &format!(
                    "{n} more `{kind}` event(s) within {:.1} s (rate limit)",
                    interval.as_secs_f64()
                ),
            );
        }
    }

    /// Reports what the rate limits held back (at shutdown).
    pub fn flush_suppressed(&mut self) {
        let pending: Vec<(&'static str, u64)> = self
            .limits
            .iter_mut()
            .filter(|l| l.suppressed > 0)
            .map(|l| (l.kind, std::mem::take(&mut l.suppressed)))
            .collect();
        for (kind, n) in pending {
            self.log(
                Severity::Info,
                &format!("{n} more `{kind}` event(s) suppressed by the rate limit"),
            );
        }
    }
}

/// Derives log events from consecutive status snapshots of the control thread.
#[derive(Debug, Default)]
pub struct StatusWatch {
    last: Option<StatusSnapshot>,
    stale: bool,
    names: Vec<String>,
}

impl StatusWatch {
    /// A watch naming the controlled joints `names` (a locked joint is named).
    pub fn with_names(names: Vec<String>) -> Self {
        Self {
            names,
            ..Self::default()
        }
    }

    /// Compares `s` with the previous snapshot and logs what changed.
    pub fn observe(&mut self, s: &StatusSnapshot, log: &mut NodeLog) {
        self.observe_inputs(s, log);
        let prev = self.previous(s);
        Self::observe_subscribers(&prev, s, self.last.is_some(), log);
        self.observe_held_locked(&prev, s, log);
        Self::observe_late_ticks(s, log);
        Self::observe_not_following(&prev, s, log);
        Self::observe_counters(&prev, s, log);
        self.last = Some(*s);
    }

    /// Joint states missing, stale, or fresh again.
    fn observe_inputs(&mut self, s: &StatusSnapshot, log: &mut NodeLog) {
        let stale = s.code == StatusCode::StaleJointStates;
        match (self.last, stale) {
            (None, true) => log.log(
                Severity::Warn,
                "no joint state yet: commanding zero velocity / hold until one arrives",
            ),
            (Some(_), true) if !self.stale => log.log(
                Severity::Warn,
                &format!(
                    "joint states stale (age {}): braking to zero velocity / holding",
                    age(s.joint_state_age_s)
                ),
            ),
            (prev, false) if prev.is_none() || self.stale => match prev {
                Some(p) if p.joint_state_age_s >= 0.0 => log.log(
                    Severity::Info,
                    &format!(
                        "joint states fresh again (age {}) after {} stale tick(s): commanding the policy",
                        age(s.joint_state_age_s),
                        s.stale_ticks.saturating_sub(p.stale_ticks)
                    ),
                ),
                _ => log.log(
                    Severity::Info,
                    &format!(
                        "joint states received (age {}): commanding the policy",
                        age(s.joint_state_age_s)
                    ),
                ),
            },
            _ => {}
        }
        self.stale = stale;
    }

    /// The previous snapshot, or (at the first) `s` with its events and counters at zero.
    fn previous(&self, s: &StatusSnapshot) -> StatusSnapshot {
        self.last.unwrap_or(StatusSnapshot {
            held_events: 0,
            locked_events: 0,
            command_subscribers: None,
            fallback_ticks: 0,
            nonfinite_ticks: 0,
            infeasible_ticks: 0,
            restarts: 0,
            not_following_ticks: 0,
            tracking_warning_ticks: 0,
            ..*s
        })
    }

    /// The controller switched off, and on again (`seen_before`: a previous snapshot exists).
    fn observe_subscribers(
        prev: &StatusSnapshot,
        s: &StatusSnapshot,
        seen_before: bool,
        log: &mut NodeLog,
    ) {
        match (prev.command_subscribers, s.command_subscribers) {
            (Some(a), Some(0)) if a > 0 => log.log(
                Severity::Error,
                "the command topic has no subscriber (the controller was switched off): \
                 braking to a hold",
            ),
            (Some(0), Some(n)) if n > 0 && seen_before => log.log(
                Severity::Info,
                &format!(
                    "the command topic has {n} subscriber(s) again: commands restart from the \
                     measured state"
                ),
            ),
            _ => {}
        }
    }

    /// The robot held, or a joint locked, since the previous snapshot.
    fn observe_held_locked(&self, prev: &StatusSnapshot, s: &StatusSnapshot, log: &mut NodeLog) {
        if s.held_events > prev.held_events {
            log.limited(
                "robot_held",
                Severity::Error,
                &format!(
                    "robot held: every joint stopped while commanded to move ({} in all): \
                     holding at the measured state, then trying again",
                    s.held_events
                ),
            );
        }
        if s.locked_events > prev.locked_events {
            let joint = s
                .locked_joint
                .and_then(|j| self.names.get(j))
                .map_or("?", String::as_str);
            log.limited(
                "joint_locked",
                Severity::Error,
                &format!(
                    "joint `{joint}` does not move while commanded to ({} in all): commands \
                     restarted from the measured state",
                    s.locked_events
                ),
            );
        }
    }

    /// A loaded computer: ticks late or never run in the status period.
    fn observe_late_ticks(s: &StatusSnapshot, log: &mut NodeLog) {
        if s.period.late_ticks > 0 || s.period.missed_ticks > 0 {
            log.limited(
                "ticks_late",
                Severity::Warn,
                &format!(
                    "{} tick(s) started more than half a period late and {} never ran since the \
                     last status ({} late, {} missed in all; the latest start so far {:.1} ms \
                     after its time): is the computer loaded? (`[node] realtime`, \
                     docs/guide/node.md)",
                    s.period.late_ticks,
                    s.period.missed_ticks,
                    s.late_ticks,
                    s.missed_ticks,
                    s.tick_late_max_us * 1e-3
                ),
            );
        }
    }

    /// The robot not following is an error, logged when it begins (and again, at most once a
    /// second, while it lasts).
    fn observe_not_following(prev: &StatusSnapshot, s: &StatusSnapshot, log: &mut NodeLog) {
        if s.not_following_ticks > prev.not_following_ticks {
            log.limited(
                "robot_not_following",
                Severity::Error,
                &format!(
                    "the robot does not follow its position commands (more than the allowed \
                     restarts from the measured state, {} in all; tracking error {:.4}): \
                     holding, no policy motion until a new symmetry condition is accepted",
                    s.restarts, s.tracking_error
                ),
            );
        }
    }

    /// The counted events (fallbacks, non-finite outputs, infeasible conditions, restarts,
    /// tracking warnings) new since the previous snapshot.
    fn observe_counters(prev: &StatusSnapshot, s: &StatusSnapshot, log: &mut NodeLog) {
        for (kind, all, before, what, tracking) in [
            (
                "safety_fallback",
                s.fallback_ticks,
                prev.fallback_ticks,
                "safety QP fell back to the clamped policy output",
                false,
            ),
            (
                "policy_nonfinite",
                s.nonfinite_ticks,
                prev.nonfinite_ticks,
                "policy returned non-finite velocities (replaced by 0)",
                false,
            ),
            (
                "condition_infeasible",
                s.infeasible_ticks,
                prev.infeasible_ticks,
                "the policy is undefined at the current joint state under the accepted condition (a canonicalised policy's flows fail, or a task-space head's lift J⁺ is singular): zero velocity",
                false,
            ),
            (
                "restarted_from_measured",
                s.restarts,
                prev.restarts,
                "commands restarted from the measured state (the envelope of the position commands left, a joint locked, a held robot held again or a controller back: safety.max_restarts counts them)",
                true,
            ),
            (
                "tracking_error",
                s.tracking_warning_ticks,
                prev.tracking_warning_ticks,
                "tracking error above safety.tracking_warning",
                true,
            ),
        ] {
            let new = all.saturating_sub(before);
            if new > 0 {
                let line = if tracking {
                    format!(
                        "{what} on {new} tick(s) ({all} in all; tracking error {:.4})",
                        s.tracking_error
                    )
                } else {
                    format!("{what} on {new} tick(s) ({all} in all)")
                };
                log.limited(kind, Severity::Warn, &line);
            }
        }
    }
}

fn age(a: f64) -> String {
    if a < 0.0 {
        "none".into()
    } else {
        format!("{:.1} ms", a * 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    fn capture(min: Severity, interval: Duration) -> (NodeLog, Arc<Mutex<Vec<String>>>) {
        let lines = Arc::new(Mutex::new(Vec::new()));
        let l2 = lines.clone();
        let log = NodeLog::with_sink("n", None, min, interval, move |s| {
            l2.lock().unwrap().push(s.to_string())
        });
        (log, lines)
    }

    #[test]
    fn lines_have_the_rcutils_format() {
        assert_eq!(
            format_line(Severity::Warn, 1_700_000_000.25, "crossym", "hello"),
            "[WARN] [1700000000.250000000] [crossym]: hello"
        );
        assert_eq!(
            Severity::from_rust_log("warn,crossym=debug"),
            Some(Severity::Debug)
        );
        assert_eq!(
            Severity::from_rust_log("rustdds=info,error"),
            Some(Severity::Error)
        );
        assert_eq!(Severity::from_rust_log("rustdds=info"), None);
    }

    #[test]
    fn first_of_a_kind_at_once_then_counted() {
        // The rate limit's clock is driven here: no dependence on how fast the loop runs.
        let (mut log, lines) = capture(Severity::Info, Duration::from_millis(200));
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        for k in 0..50 {
            log.limited_at("a", Severity::Warn, "bad a", at(k * 3));
        }
        log.limited_at("b", Severity::Warn, "bad b", at(150));
        log.log(Severity::Debug, "hidden");
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 2, "{l:?}");
        // 199 ms after the first "a": still inside the interval, counted.
        log.limited_at("a", Severity::Warn, "bad a", at(199));
        assert_eq!(lines.lock().unwrap().len(), 2);
        log.limited_at("a", Severity::Warn, "bad a", at(250));
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 3);
        assert!(
            l[2].ends_with("bad a (50 more since the last report)"),
            "{}",
            l[2]
        );
        log.limited_at("a", Severity::Warn, "bad a", at(260));
        log.flush_suppressed();
        let l = lines.lock().unwrap().clone();
        assert!(
            l[3].ends_with("1 more `a` event(s) suppressed by the rate limit"),
            "{l:?}"
        );
    }

    #[test]
    fn status_transitions_become_lines() {
        use crossym_math::symmetry::compose::Condition;
        let (mut log, lines) = capture(Severity::Info, Duration::from_secs(1));
        let mut w = StatusWatch::with_names(vec!["a0".into(), "a1".into()]);
        let mut s = StatusSnapshot {
            code: StatusCode::StaleJointStates,
            message: "",
            last_error: None,
            active_constraints: 0,
            rejected_joint_states: 0,
            rejected_conditions: 0,
            ticks: 1,
            stale_ticks: 1,
            fallback_ticks: 0,
            nonfinite_ticks: 0,
            infeasible_ticks: 0,
            joint_state_age_s: -1.0,
            tick_time_us: 1.0,
            tick_time_max_us: 1.0,
            condition: Condition::IDENTITY,
            restarts: 0,
            not_following_ticks: 0,
            tracking_warning_ticks: 0,
            tracking_error: 0.0,
            paused: false,
            velocity_scale: 1.0,
            singularity_condition: 1.0,
            singularity_factor: 1.0,
            period_code: StatusCode::StaleJointStates,
            period_ticks: 1,
            period: Default::default(),
            held_events: 0,
            locked_events: 0,
            locked_joint: None,
            command_subscribers: None,
            late_ticks: 0,
            missed_ticks: 0,
            tick_late_max_us: 0.0,
        };
        w.observe(&s, &mut log); // no state yet
        w.observe(&s, &mut log); // unchanged: nothing
        s.code = StatusCode::NoWarning;
        s.joint_state_age_s = 0.002;
        w.observe(&s, &mut log); // fresh
        s.code = StatusCode::StaleJointStates;
        s.stale_ticks = 30;
        w.observe(&s, &mut log); // stale
        s.code = StatusCode::NoWarning;
        s.stale_ticks = 40;
        s.fallback_ticks = 3;
        w.observe(&s, &mut log); // fresh again + fallback
        s.infeasible_ticks = 2;
        w.observe(&s, &mut log); // a canonicalised policy's condition became infeasible
        s.restarts = 1;
        s.tracking_error = 0.031;
        w.observe(&s, &mut log); // a restart from the measured state
        s.restarts = 4;
        s.not_following_ticks = 5;
        w.observe(&s, &mut log); // within the rate limit: no restart line; not following
        s.tracking_warning_ticks = 7;
        w.observe(&s, &mut log); // tracking error
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 9, "{l:?}");
        assert!(
            l[6].contains("restarted") && l[6].contains("on 1 tick") && l[6].contains("0.0310"),
            "{}",
            l[6]
        );
        assert!(
            l[7].contains("[ERROR]") && l[7].contains("does not follow"),
            "{}",
            l[7]
        );
        assert!(
            l[8].contains("tracking error") && l[8].contains("on 7 tick"),
            "{}",
            l[8]
        );
        assert!(l[0].contains("[WARN]") && l[0].contains("no joint state yet"));
        assert!(l[1].contains("joint states received"), "{}", l[1]);
        assert!(l[2].contains("joint states stale"));
        assert!(
            l[3].contains("fresh again") && l[3].contains("after 10 stale tick"),
            "{}",
            l[3]
        );
        assert!(
            l[4].contains("fell back") && l[4].contains("on 3 tick"),
            "{}",
            l[4]
        );
        assert!(
            l[5].contains("flows fail") && l[5].contains("on 2 tick"),
            "{}",
            l[5]
        );
        // A held robot, a locked joint (named), the controller off and on again.
        s.held_events = 1;
        w.observe(&s, &mut log);
        s.locked_events = 1;
        s.locked_joint = Some(1);
        w.observe(&s, &mut log);
        s.command_subscribers = Some(1);
        w.observe(&s, &mut log);
        s.command_subscribers = Some(0);
        w.observe(&s, &mut log);
        s.command_subscribers = Some(2);
        w.observe(&s, &mut log);
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 13, "{l:?}");
        assert!(
            l[9].contains("[ERROR]") && l[9].contains("robot held"),
            "{}",
            l[9]
        );
        assert!(l[10].contains("joint `a1` does not move"), "{}", l[10]);
        assert!(l[11].contains("no subscriber"), "{}", l[11]);
        assert!(l[12].contains("2 subscriber(s) again"), "{}", l[12]);
        // A loaded computer: a period with late and missed ticks warns, a quiet one not.
        s.period.late_ticks = 2;
        s.period.missed_ticks = 1;
        (s.late_ticks, s.missed_ticks, s.tick_late_max_us) = (2, 1, 12_500.0);
        w.observe(&s, &mut log);
        s.period = Default::default();
        w.observe(&s, &mut log);
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 14, "{l:?}");
        assert!(
            l[13].contains("[WARN]")
                && l[13].contains("2 tick(s) started more than half a period late and 1 never ran")
                && l[13].contains("12.5 ms"),
            "{}",
            l[13]
        );
    }

    #[test]
    fn held_back_events_are_reported_once_their_interval_has_passed() {
        let (mut log, lines) = capture(Severity::Info, Duration::from_secs(1));
        let t0 = Instant::now();
        let at = |ms: u64| t0 + Duration::from_millis(ms);
        log.limited_at("restart", Severity::Warn, "restarted", at(0));
        log.limited_at("held", Severity::Error, "held", at(10)); // another kind: at once
        log.limited_at("restart", Severity::Warn, "restarted", at(200)); // held back
        log.flush_due_at(at(500)); // not yet due
        assert_eq!(lines.lock().unwrap().len(), 2);
        log.flush_due_at(at(1000));
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 3, "{l:?}");
        assert!(
            l[2].contains("[WARN]") && l[2].contains("1 more `restart` event(s) within 1.0 s"),
            "{}",
            l[2]
        );
        log.flush_due_at(at(3000)); // nothing left
        assert_eq!(lines.lock().unwrap().len(), 3);
        // A flush does not start a new window: the next event is printed in full at once.
        log.limited_at("restart", Severity::Warn, "restarted again", at(1100));
        let l = lines.lock().unwrap().clone();
        assert_eq!(l.len(), 4, "{l:?}");
        assert!(l[3].ends_with("restarted again"), "{}", l[3]);
    }
}
