//! A running node's `~/status` watched from another process, for machines without the ROS
//! tools (`ros2 topic echo`; `crossym status`): one human-readable line per message, until
//! the node's `SHUTDOWN`, a number of messages, or a silence longer than the timeout.

use std::time::{Duration, Instant};

use crate::dds::{self, DdsError, DdsSettings};
use crossym_control::node::{NodeConfig, StatusCode};
use crossym_io::msg;

/// Errors of a status watch.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StatusWatchError {
    /// The timeout is not a positive number of seconds.
    #[error("timeout_s = {value} must be positive")]
    Timeout {
        /// The timeout given (s).
        value: f64,
    },
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// No status within the timeout, at start or later.
    #[error("no status on {topic} for {timeout_s} s{}: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?", none_at_all(*.seen))]
    Silent {
        /// The status topic.
        topic: String,
        /// The timeout (s).
        timeout_s: f64,
        /// Status messages received before the silence.
        seen: u64,
    },
}

fn none_at_all(seen: u64) -> &'static str {
    if seen == 0 {
        " (none at all)"
    } else {
        ""
    }
}

/// How long to watch, validated once by [`StatusWatch::open`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StatusWatchSettings {
    /// Give up when no status arrives within this time (s), at start or later.
    pub timeout_s: f64,
    /// Stop after this many status messages (`None`: until the node's `SHUTDOWN`).
    pub count: Option<u64>,
}

/// What a watch sees.
#[derive(Debug)]
pub enum StatusEvent<'a> {
    /// A status message.
    Status(&'a msg::Status),
    /// A sample that did not decode as a status (the middleware's error text).
    Undecodable(String),
}

/// A subscription to a node's `~/status`, on a participant of its own.
pub struct StatusWatch {
    topic: String,
    settings: StatusWatchSettings,
    sub: ros2_client::Subscription<msg::Status>,
    _node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

impl StatusWatch {
    /// Subscribes (best effort) to the status topic of the node configured by `n`.
    pub fn open(
        n: &NodeConfig,
        settings: StatusWatchSettings,
        dds: &DdsSettings,
    ) -> Result<Self, StatusWatchError> {
        if !(settings.timeout_s.is_finite() && settings.timeout_s > 0.0) {
            return Err(StatusWatchError::Timeout {
                value: settings.timeout_s,
            });
        }
        let topic = dds::expand_topic(&n.topics.status, &n.namespace, &n.name);
        let ctx = dds.context()?;
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_status_{}", std::process::id()))?,
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "status node".into(),
                message: format!("{e:?}"),
            })?;
        let sub = dds::subscription::<msg::Status>(&mut node, &topic, dds::qos_sensor())?;
        Ok(Self {
            topic,
            settings,
            sub,
            _node: node,
            _ctx: ctx,
        })
    }

    /// The status topic watched.
    pub fn topic(&self) -> &str {
        &self.topic
    }

    /// Hands each status (and each undecodable sample) to `on` until the node's
    /// `SHUTDOWN` or `count` messages; returns the number of messages seen.
    pub fn run(&self, mut on: impl FnMut(StatusEvent<'_>)) -> Result<u64, StatusWatchError> {
        let timeout = Duration::from_secs_f64(self.settings.timeout_s);
        let mut last = Instant::now();
        let mut seen = 0u64;
        loop {
            match self.sub.take() {
                Ok(Some((m, _))) => {
                    seen += 1;
                    last = Instant::now();
                    on(StatusEvent::Status(&m));
                    if is_last(&m, seen, self.settings.count) {
                        return Ok(seen);
                    }
                }
                Ok(None) => {
                    if last.elapsed() > timeout {
                        return Err(StatusWatchError::Silent {
                            topic: self.topic.clone(),
                            timeout_s: self.settings.timeout_s,
                            seen,
                        });
                    }
                    std::thread::sleep(Duration::from_millis(5));
                }
                Err(e) => on(StatusEvent::Undecodable(format!("{e:?}"))),
            }
        }
    }
}

/// Whether the watch ends with `m`, the `seen`-th message: the node's `SHUTDOWN`, or
/// `count` reached.
fn is_last(m: &msg::Status, seen: u64, count: Option<u64>) -> bool {
    m.code == StatusCode::Shutdown.value() || count.is_some_and(|c| seen >= c)
}

/// One human-readable line of a status message.
pub fn status_line(m: &msg::Status) -> String {
    let code = StatusCode::ALL
        .iter()
        .find(|c| c.value() == m.code)
        .map_or_else(
            || format!("CODE_{}", m.code),
            |c| c.constant_name().to_string(),
        );
    let c = &m.condition;
    let age = if m.joint_state_age_s < 0.0 {
        "none".to_string()
    } else {
        format!("{:.1} ms", m.joint_state_age_s * 1e3)
    };
    let mut s = format!(
        "{code} | θ {:+.3} rad λ {:.3} σ {:+} | joint state age {age} | tick {:.1} µs (max {:.1}) | ticks {} (stale {}) | rejected js {} cond {} | on a bound {}",
        c.theta,
        c.scale,
        c.reflection,
        m.tick_time_us,
        m.tick_time_max_us,
        m.ticks,
        m.stale_ticks,
        m.rejected_joint_states,
        m.rejected_conditions,
        m.active_constraints
    );
    if m.paused {
        s.push_str(" | PAUSED");
    }
    if m.velocity_scale != 1.0 {
        s.push_str(&format!(" | velocity ×{}", m.velocity_scale));
    }
    if m.singularity_factor < 1.0 {
        s.push_str(&format!(
            " | near a singularity: κ {:.1}, speed ×{:.2}",
            m.singularity_condition, m.singularity_factor
        ));
    }
    if m.late_ticks > 0 || m.missed_ticks > 0 {
        s.push_str(&format!(
            " | late ticks {} (this period {}), missed {} ({}), worst start {:.1} ms late",
            m.late_ticks,
            m.period_late_ticks,
            m.missed_ticks,
            m.period_missed_ticks,
            m.tick_late_max_us * 1e-3
        ));
    }
    if !m.last_error.is_empty() {
        s.push_str(&format!(" | last error: {}", m.last_error));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn running() -> msg::Status {
        msg::Status {
            code: StatusCode::NoWarning.value(),
            velocity_scale: 1.0,
            singularity_factor: 1.0,
            joint_state_age_s: 0.0123,
            ticks: 42,
            ..Default::default()
        }
    }

    #[test]
    fn a_status_reads_as_one_line() {
        let s = status_line(&running());
        assert!(s.starts_with("NO_WARNING | θ +0.000 rad"), "{s}");
        assert!(s.contains("| joint state age 12.3 ms |"), "{s}");
        assert!(s.contains("| ticks 42 (stale 0) |"), "{s}");
        assert!(!s.contains("PAUSED") && !s.contains("velocity ×"), "{s}");
        assert!(!s.contains("late ticks"), "{s}");
        let s = status_line(&msg::Status {
            late_ticks: 3,
            missed_ticks: 29,
            period_missed_ticks: 29,
            period_late_ticks: 1,
            tick_late_max_us: 301_200.0,
            ..running()
        });
        assert!(
            s.ends_with(
                " | late ticks 3 (this period 1), missed 29 (29), worst start 301.2 ms late"
            ),
            "{s}"
        );
        let s = status_line(&msg::Status {
            code: 99,
            joint_state_age_s: -1.0,
            paused: true,
            velocity_scale: 0.5,
            singularity_factor: 0.25,
            singularity_condition: 80.0,
            last_error: "boom".into(),
            ..running()
        });
        assert!(s.starts_with("CODE_99 | "), "{s}");
        assert!(s.contains("joint state age none"), "{s}");
        assert!(
            s.ends_with(
                " | PAUSED | velocity ×0.5 | near a singularity: κ 80.0, speed ×0.25 | last error: boom"
            ),
            "{s}"
        );
    }

    #[test]
    fn a_watch_ends_at_shutdown_or_after_count_messages() {
        let shutdown = msg::Status {
            code: StatusCode::Shutdown.value(),
            ..running()
        };
        assert!(is_last(&shutdown, 1, None));
        assert!(!is_last(&running(), 100, None));
        assert!(!is_last(&running(), 2, Some(3)));
        assert!(is_last(&running(), 3, Some(3)));
    }

    #[test]
    fn a_silence_says_whether_anything_came() {
        let e = |seen| {
            StatusWatchError::Silent {
                topic: "/crossym/status".into(),
                timeout_s: 1.0,
                seen,
            }
            .to_string()
        };
        assert!(
            e(0).starts_with(
                "no status on /crossym/status for 1 s (none at all): is `crossym node` running"
            ),
            "{}",
            e(0)
        );
        assert!(
            e(3).starts_with("no status on /crossym/status for 1 s: is"),
            "{}",
            e(3)
        );
    }
}
