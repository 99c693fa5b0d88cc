//! The round trip joint state → command of a running node, measured from another process
//! as the robot's driver sees it (`crossym ping`).
//!
//! Each probe publishes one `sensor_msgs/JointState` (stamped with the wall clock, a
//! configuration inside the joint limits) on the node's joint-state topic and waits for the
//! next command on its command topic; the time between the publish call and the command's
//! arrival is one round trip. A probe without a command within the reply timeout is lost.
//! The node should run with `trigger = "joint_states"` (else a round trip includes the wait
//! for the next timer tick, up to a period).
//!
//! ping runs on its DDS participant's event-loop thread (`hook.rs`, the node's own
//! arrangement): it publishes and reads where RustDDS sends and receives, so the
//! measurement adds no thread hand-off of its own. It waits for the command as a driver
//! does, blocked until the datagram wakes it (`busy_wait` spins instead, taking a core),
//! and splits each round trip with the stamps DDS carries (both processes read the same
//! wall clock): the probe's publish → the command's publish (over DDS to the node and
//! through it), the command's publish → its DDS receive here, and that receive → ping
//! holding it ([`PingReport`]).

mod hook;
mod stats;

use std::sync::mpsc::{Receiver, SyncSender};
use std::sync::Arc;
use std::time::Duration;

use self::hook::{JobEnd, JobTiming, PingHook, PingJob, Replies};
pub use self::stats::{latency, Latency, PingReport, Probe, Unanswered};
use crate::dds::{self, DdsError, DdsSettings};
use crate::event_loop::LoopThread;
use crate::realtime::{apply_realtime, RealtimeHold};
use crossym_control::node::{NodeConfig, OutputMode};
use crossym_control::realtime::{RealtimeConfig, RealtimeConfigError, RealtimeOutcome};
use crossym_io::msg;
use crossym_math::kinematics::JointLimits;

/// Errors of a ping measurement (a node that never answers included).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PingError {
    /// A setting that must be positive is not.
    #[error("{setting} = {value} must be positive")]
    Setting {
        /// The setting (`rate`, `count`, `reply_timeout_ms`, `connect_timeout_s`).
        setting: &'static str,
        /// Its value.
        value: f64,
    },
    /// The real-time priority is out of range.
    #[error("realtime: {0}")]
    Realtime(#[from] RealtimeConfigError),
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// ping's DDS event loop did not start, or stopped.
    #[error("the DDS event loop {what}")]
    EventLoop {
        /// What happened to it.
        what: &'static str,
    },
    /// A probe could not be published.
    #[error("publishing on {topic}: {message}")]
    Publish {
        /// The joint-state topic.
        topic: String,
        /// The middleware's error text.
        message: String,
    },
    /// No command answered the warm-up probes.
    #[error("no command on {topic} within {timeout_s} s: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?")]
    NoCommand {
        /// The command topic.
        topic: String,
        /// The connect timeout (s).
        timeout_s: f64,
    },
}

/// How ping measures, validated once by [`Ping::connect`].
#[derive(Debug, Clone, PartialEq)]
pub struct PingSettings {
    /// Probes per second (Hz).
    pub rate_hz: f64,
    /// Number of probes measured (after the warm-up).
    pub count: usize,
    /// A probe without a command within this time is lost (ms).
    pub reply_timeout_ms: f64,
    /// No command within this time at start: the node is not there (s).
    pub connect_timeout_s: f64,
    /// Spin on the subscription instead of blocking until DDS wakes ping (takes a core).
    pub busy_wait: bool,
    /// Run as a real-time driver would: ping's thread (its DDS event loop) under
    /// `SCHED_FIFO` at this priority (1 … 99), RustDDS's discovery thread one below, memory
    /// locked.
    pub realtime_priority: Option<i32>,
}

impl PingSettings {
    /// Checks that rate, count and timeouts are positive and the priority in range.
    pub fn validate(&self) -> Result<(), PingError> {
        for (setting, value) in [
            ("rate", self.rate_hz),
            ("count", self.count as f64),
            ("reply_timeout_ms", self.reply_timeout_ms),
            ("connect_timeout_s", self.connect_timeout_s),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(PingError::Setting { setting, value });
            }
        }
        if let Some(rt) = self.realtime() {
            rt.validate()?;
        }
        Ok(())
    }

    /// The real-time settings `realtime_priority` stands for: the thread at `p`, RustDDS's
    /// threads at `p − 1` (at least 1), memory locked, nothing else.
    pub fn realtime(&self) -> Option<RealtimeConfig> {
        self.realtime_priority.map(|p| RealtimeConfig {
            priority: p,
            lock_memory: true,
            dds_priority: Some((p - 1).max(1)),
            cpu_latency_us: None,
            idle_poll: false,
        })
    }
}

/// The node ping measures and the probe it sends.
#[derive(Debug, Clone, PartialEq)]
pub struct PingTarget {
    /// The node's joint-state topic (expanded).
    pub joint_states_topic: String,
    /// The node's command topic (expanded).
    pub command_topic: String,
    /// What the node publishes (the command topic's type).
    pub output: OutputMode,
    /// The probe's joint names, in the node's order.
    pub joint_names: Vec<String>,
    /// The probe's joint positions.
    pub position: Vec<f64>,
    /// The node's stale timeout, at least its period (s): commands that long after a probe
    /// are the node's own ticks.
    pub stale_s: f64,
}

impl PingTarget {
    /// The node configured by `n`, probed at `position` of the joints `joint_names`.
    pub fn for_node(n: &NodeConfig, joint_names: Vec<String>, position: Vec<f64>) -> Self {
        Self {
            joint_states_topic: dds::expand_topic(&n.topics.joint_states, &n.namespace, &n.name),
            command_topic: dds::expand_topic(&n.topics.command, &n.namespace, &n.name),
            output: n.output,
            joint_names,
            position,
            stale_s: n.stale_timeout_s.max(n.period_s),
        }
    }
}

/// A configuration inside the limits where the policy runs: `start` (a config's mock
/// hardware start or reference posture) when it has one position per joint, else
/// mid-range. (Mid-range is q = 0 on the planar arms: stretched out, where a task head's
/// lift is singular and the node commands zero without running its policy.)
pub fn probe_position(start: Option<Vec<f64>>, limits: &[JointLimits]) -> Vec<f64> {
    start
        .filter(|q| q.len() == limits.len())
        .unwrap_or_else(|| limits.iter().map(|l| 0.5 * (l.lower + l.upper)).collect())
}

/// ping connected: its participant, its event loop (under the real-time settings when
/// asked) and the measurement ready on it.
pub struct Ping {
    target: PingTarget,
    connect_timeout_s: f64,
    looper: Arc<LoopThread>,
    job_tx: SyncSender<PingJob>,
    done_rx: Receiver<JobEnd>,
    job: PingJob,
    _realtime: RealtimeHold,
    _node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

impl Ping {
    /// Validates `settings`, opens a participant with `dds` whose event loop runs ping,
    /// applies the real-time settings to that thread (`report` receives each outcome),
    /// and creates the probe publisher and the command subscription of `target`.
    pub fn connect(
        target: PingTarget,
        settings: &PingSettings,
        dds: &DdsSettings,
        report: impl FnMut(&RealtimeOutcome),
    ) -> Result<Self, PingError> {
        settings.validate()?;
        let looper = Arc::new(LoopThread::default());
        let (hook, job_tx, done_rx) = PingHook::new(looper.clone());
        let ctx = dds.context_with_hook(Some(Box::new(hook)))?;
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_ping_{}", std::process::id()))?,
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "ping node".into(),
                message: format!("{e:?}"),
            })?;
        let thread = looper
            .wait(Duration::from_secs(5))
            .ok_or(PingError::EventLoop {
                what: "did not start within 5 s",
            })?;
        let realtime = match settings.realtime() {
            Some(rt) => apply_realtime(&rt, thread, report),
            None => RealtimeHold::default(),
        };
        // Written from the event loop itself: a full send window fails at once.
        let js_pub = dds::publisher::<msg::JointState>(
            &mut node,
            &target.joint_states_topic,
            dds::qos_reliable_nonblocking(10),
        )?;
        let replies = Replies::subscribe(&mut node, target.output, &target.command_topic)?;
        let probe = msg::JointState {
            header: msg::Header::default(),
            name: target.joint_names.clone(),
            position: target.position.clone(),
            ..Default::default()
        };
        let timing = JobTiming {
            connect_timeout: Duration::from_secs_f64(settings.connect_timeout_s),
            period: Duration::from_secs_f64(1.0 / settings.rate_hz),
            timeout: Duration::from_secs_f64(settings.reply_timeout_ms * 1e-3),
            count: settings.count,
            busy_wait: settings.busy_wait,
            stale_s: target.stale_s,
        };
        Ok(Self {
            job: PingJob::new(probe, js_pub, replies, timing),
            target,
            connect_timeout_s: settings.connect_timeout_s,
            looper,
            job_tx,
            done_rx,
            _realtime: realtime,
            _node: node,
            _ctx: ctx,
        })
    }

    /// The node measured and the probe.
    pub fn target(&self) -> &PingTarget {
        &self.target
    }

    /// Runs the measurement on the event loop: the warm-up, then the probes. A node that
    /// answers no warm-up probe is [`PingError::NoCommand`].
    pub fn measure(self) -> Result<PingReport, PingError> {
        if self.job_tx.send(self.job).is_err() {
            return Err(PingError::EventLoop {
                what: "stopped before ping started",
            });
        }
        self.looper.wake();
        let end = self.done_rx.recv().map_err(|_| PingError::EventLoop {
            what: "stopped during the measurement",
        })?;
        match end {
            JobEnd::Done(report) => Ok(report),
            JobEnd::NoNode => Err(PingError::NoCommand {
                topic: self.target.command_topic,
                timeout_s: self.connect_timeout_s,
            }),
            JobEnd::Publish(message) => Err(PingError::Publish {
                topic: self.target.joint_states_topic,
                message,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> PingSettings {
        PingSettings {
            rate_hz: 100.0,
            count: 1000,
            reply_timeout_ms: 50.0,
            connect_timeout_s: 20.0,
            busy_wait: false,
            realtime_priority: None,
        }
    }

    #[test]
    fn settings_are_checked_once_and_name_the_culprit() {
        assert!(settings().validate().is_ok());
        for (bad, name) in [
            (
                PingSettings {
                    rate_hz: 0.0,
                    ..settings()
                },
                "rate",
            ),
            (
                PingSettings {
                    rate_hz: f64::NAN,
                    ..settings()
                },
                "rate",
            ),
            (
                PingSettings {
                    count: 0,
                    ..settings()
                },
                "count",
            ),
            (
                PingSettings {
                    reply_timeout_ms: -1.0,
                    ..settings()
                },
                "reply_timeout_ms",
            ),
            (
                PingSettings {
                    connect_timeout_s: f64::INFINITY,
                    ..settings()
                },
                "connect_timeout_s",
            ),
        ] {
            match bad.validate() {
                Err(PingError::Setting { setting, .. }) => assert_eq!(setting, name),
                other => panic!("{name}: {other:?}"),
            }
        }
        let rt = |p| PingSettings {
            realtime_priority: Some(p),
            ..settings()
        };
        assert!(matches!(rt(0).validate(), Err(PingError::Realtime(_))));
        assert!(matches!(rt(100).validate(), Err(PingError::Realtime(_))));
        assert!(rt(99).validate().is_ok());
    }

    /// `--realtime P`: the thread at P, RustDDS's one below (never below 1), memory locked.
    #[test]
    fn the_realtime_priority_stands_for_a_driver_s_settings() {
        assert_eq!(settings().realtime(), None);
        let rt = |p| {
            PingSettings {
                realtime_priority: Some(p),
                ..settings()
            }
            .realtime()
            .unwrap()
        };
        let r = rt(80);
        assert_eq!(
            (r.priority, r.dds_priority, r.lock_memory),
            (80, Some(79), true)
        );
        assert_eq!((r.cpu_latency_us, r.idle_poll), (None, false));
        assert_eq!(rt(1).dds_priority, Some(1));
    }

    #[test]
    fn the_probe_is_the_start_posture_else_mid_range() {
        let limits = [
            JointLimits {
                lower: -1.0,
                upper: 3.0,
                ..JointLimits::UNBOUNDED
            },
            JointLimits {
                lower: 0.0,
                upper: 0.5,
                ..JointLimits::UNBOUNDED
            },
        ];
        assert_eq!(probe_position(Some(vec![0.1, 0.2]), &limits), [0.1, 0.2]);
        assert_eq!(probe_position(None, &limits), [1.0, 0.25]);
        // A start posture of another robot (wrong length) is not used.
        assert_eq!(probe_position(Some(vec![0.1]), &limits), [1.0, 0.25]);
    }
}
