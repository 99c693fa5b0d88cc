//! ping on its DDS participant's event-loop thread ([`crate::event_loop`], the node's own
//! arrangement): [`PingHook`] waits for its [`PingJob`] and steps it after each wake-up of
//! the loop (a datagram, its own timeout), so a probe is published and its command read
//! where RustDDS sends and receives, with no thread hand-off of ping's own.
//!
//! The job: a warm-up (a probe every 20 ms until 20 commands came back, or the connect
//! timeout), then `count` probes at the rate, each waiting for the next command up to the
//! reply timeout — blocked until the datagram wakes the loop, or spinning (`busy_wait`).

use std::sync::mpsc::{Receiver, SyncSender, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::{EventLoopHook, EventLoopWaker};

use super::stats::{PingReport, Probe, Unanswered};
use crate::dds::{self, DdsError};
use crate::event_loop::LoopThread;
use crossym_control::node::OutputMode;
use crossym_io::msg;

/// The node's commands, of the type its output mode publishes.
pub(crate) enum Replies {
    Array(ros2_client::Subscription<msg::Float64MultiArray>),
    Trajectory(ros2_client::Subscription<msg::JointTrajectory>),
}

impl Replies {
    /// Subscribes to the node's commands on `topic`, of the type its `output` publishes.
    pub(crate) fn subscribe(
        node: &mut ros2_client::Node,
        output: OutputMode,
        topic: &str,
    ) -> Result<Self, DdsError> {
        Ok(match output {
            OutputMode::Trajectory => Self::Trajectory(dds::subscription::<msg::JointTrajectory>(
                node,
                topic,
                dds::qos_reliable(10),
            )?),
            _ => Self::Array(dds::subscription::<msg::Float64MultiArray>(
                node,
                topic,
                dds::qos_reliable(10),
            )?),
        })
    }

    /// The stamps of a waiting command, without blocking.
    fn try_info(&self) -> Option<ros2_client::MessageInfo> {
        match self {
            Self::Array(s) => s.take().ok().flatten().map(|(_, i)| i),
            Self::Trajectory(s) => s.take().ok().flatten().map(|(_, i)| i),
        }
    }
}

/// What the measurement ended with.
pub(crate) enum JobEnd {
    /// The round trips.
    Done(PingReport),
    /// No command came back within the connect timeout.
    NoNode,
    /// A probe could not be published (the middleware's error text).
    Publish(String),
}

/// ping as RustDDS's event-loop hook: waits for its [`PingJob`], steps it after each
/// wake-up of the loop, reports the outcome once.
pub(crate) struct PingHook {
    looper: Arc<LoopThread>,
    jobs: Receiver<PingJob>,
    job: Option<Box<PingJob>>,
    done: SyncSender<JobEnd>,
    finished: bool,
}

impl PingHook {
    /// The hook, the sender of its job and the receiver of its outcome.
    pub(crate) fn new(looper: Arc<LoopThread>) -> (Self, SyncSender<PingJob>, Receiver<JobEnd>) {
        let (job_tx, jobs) = std::sync::mpsc::sync_channel(1);
        let (done, done_rx) = std::sync::mpsc::sync_channel(1);
        (
            Self {
                looper,
                jobs,
                job: None,
                done,
                finished: false,
            },
            job_tx,
            done_rx,
        )
    }
}

impl EventLoopHook for PingHook {
    fn start(&mut self, waker: EventLoopWaker) {
        self.looper.started(waker, c"crossym-ping");
    }

    fn run(&mut self) -> Option<Duration> {
        if self.finished {
            return None;
        }
        let job = match self.job.as_mut() {
            Some(job) => job,
            None => match self.jobs.try_recv() {
                Ok(job) => self.job.insert(Box::new(job)),
                Err(TryRecvError::Empty) => return Some(Duration::from_millis(5)),
                Err(TryRecvError::Disconnected) => return None,
            },
        };
        match job.step() {
            Ok(wait) => Some(wait),
            Err(outcome) => {
                // The process reports it and drops the participant.
                let _ = self.done.try_send(outcome);
                self.job = None;
                self.finished = true;
                None
            }
        }
    }
}

/// The measurement's timing, from validated settings.
pub(crate) struct JobTiming {
    pub(crate) connect_timeout: Duration,
    pub(crate) period: Duration,
    pub(crate) timeout: Duration,
    pub(crate) count: usize,
    pub(crate) busy_wait: bool,
    /// The node's stale timeout (at least its period), s.
    pub(crate) stale_s: f64,
}

/// The measurement, stepped by [`PingHook`] on the DDS event loop.
pub(crate) struct PingJob {
    probe: msg::JointState,
    js_pub: ros2_client::Publisher<msg::JointState>,
    replies: Replies,
    timing: JobTiming,
    state: JobState,
    probes: Vec<Probe>,
    lost: usize,
    extra: Unanswered,
}

enum JobState {
    /// Discovery and warm-up: a probe every 20 ms until 20 commands came back.
    WarmUp {
        start: Instant,
        warm: usize,
        next: Instant,
        last_ns: i64,
    },
    /// The next probe goes out at `next`.
    Idle { next: Instant },
    /// A probe published at `t0` (`sent_ns` on the wall clock) waits for its command.
    Waiting {
        t0: Instant,
        sent_ns: i64,
        next: Instant,
    },
}

/// Below this, a wait is slept on the loop's thread (epoll counts whole milliseconds and
/// mio rounds up).
const SLEEP_BELOW: Duration = Duration::from_millis(1);

/// Wall clock (ns since the Unix epoch).
fn wall_ns() -> i64 {
    dds::wall_time_ns() as i64
}

impl PingJob {
    /// A measurement publishing `probe` (its stamp set per probe) on `js_pub`, waiting for
    /// `replies`; it starts with the warm-up.
    pub(crate) fn new(
        probe: msg::JointState,
        js_pub: ros2_client::Publisher<msg::JointState>,
        replies: Replies,
        timing: JobTiming,
    ) -> Self {
        let count = timing.count;
        Self {
            probe,
            js_pub,
            replies,
            timing,
            state: JobState::WarmUp {
                start: Instant::now(),
                warm: 0,
                next: Instant::now(),
                last_ns: 0,
            },
            probes: Vec::with_capacity(count),
            lost: 0,
            extra: Unanswered::new(0, 0.0),
        }
    }

    /// Publishes one probe stamped with the wall clock; its publish time (ns).
    fn send(&mut self) -> Result<i64, JobEnd> {
        let now = wall_ns();
        self.probe.header.stamp = msg::Time::from_secs_f64(now as f64 * 1e-9);
        self.js_pub
            .publish(self.probe.clone())
            .map_err(|e| JobEnd::Publish(format!("{e:?}")))?;
        Ok(now)
    }

    /// Counts a command that answers no probe.
    fn count_extra(&mut self, info: &ros2_client::MessageInfo) {
        self.extra
            .count_stamp(info.source_timestamp().map(|t| t.to_nanos()));
    }

    /// Advances the measurement; how long the loop may wait (`Err`: finished).
    fn step(&mut self) -> Result<Duration, JobEnd> {
        loop {
            match self.state {
                JobState::WarmUp {
                    start,
                    warm,
                    next,
                    last_ns,
                } => {
                    if let Some(wait) = self.warm_up(start, warm, next, last_ns)? {
                        return Ok(wait);
                    }
                }
                JobState::Idle { next } => return self.idle(next),
                JobState::Waiting { t0, sent_ns, next } => {
                    if let Some(wait) = self.waiting(t0, sent_ns, next) {
                        return Ok(wait);
                    }
                }
            }
        }
    }

    /// Warm-up: counts commands, sends a probe every 20 ms; `None` when it is over.
    fn warm_up(
        &mut self,
        start: Instant,
        mut warm: usize,
        next: Instant,
        last_ns: i64,
    ) -> Result<Option<Duration>, JobEnd> {
        while self.replies.try_info().is_some() {
            warm += 1;
        }
        if warm >= 20 {
            self.extra = Unanswered::new(last_ns, self.timing.stale_s);
            self.state = JobState::Idle {
                next: Instant::now(),
            };
            return Ok(None);
        }
        if start.elapsed() > self.timing.connect_timeout {
            return Err(JobEnd::NoNode);
        }
        let now = Instant::now();
        let (next, last_ns) = if now >= next {
            (now + Duration::from_millis(20), self.send()?)
        } else {
            (next, last_ns)
        };
        self.state = JobState::WarmUp {
            start,
            warm,
            next,
            last_ns,
        };
        Ok(Some(next.saturating_duration_since(Instant::now())))
    }

    /// Between probes: finishes after `count` probes, else sends the next one at `next`
    /// (the state moves on to waiting for its command); how long the loop may wait.
    fn idle(&mut self, next: Instant) -> Result<Duration, JobEnd> {
        if self.probes.len() + self.lost >= self.timing.count {
            return Err(JobEnd::Done(PingReport {
                probes: std::mem::take(&mut self.probes),
                lost: self.lost,
                unanswered: self.extra.clone(),
            }));
        }
        while let Some(i) = self.replies.try_info() {
            self.count_extra(&i);
        }
        let busy = self.timing.busy_wait;
        let wait = next.saturating_duration_since(Instant::now());
        if wait >= SLEEP_BELOW && !busy {
            return Ok(Duration::from_millis(wait.as_millis() as u64));
        }
        if !wait.is_zero() {
            if busy {
                return Ok(Duration::ZERO);
            }
            std::thread::sleep(wait);
        }
        let t0 = Instant::now();
        let sent_ns = self.send()?;
        self.state = JobState::Waiting {
            t0,
            sent_ns,
            next: next + self.timing.period,
        };
        // Back to the loop: it transmits the probe now.
        Ok(if busy {
            Duration::ZERO
        } else {
            self.timing.timeout
        })
    }

    /// A probe waits for its command: takes it (or counts it lost at the reply timeout);
    /// `None` when the probe is settled (the state moved on).
    fn waiting(&mut self, t0: Instant, sent_ns: i64, next: Instant) -> Option<Duration> {
        while let Some(i) = self.replies.try_info() {
            let answers = i.source_timestamp().is_none_or(|t| t.to_nanos() >= sent_ns);
            if !answers {
                self.count_extra(&i);
                continue;
            }
            self.probes.push(Probe::from_stamps(
                t0.elapsed().as_secs_f64() * 1e6,
                sent_ns,
                wall_ns(),
                i.source_timestamp().map(|t| t.to_nanos()),
                i.received_timestamp().map(|t| t.to_nanos()),
            ));
            self.extra.probe(sent_ns, true);
            self.state = JobState::Idle { next };
            return None;
        }
        let left = self.timing.timeout.saturating_sub(t0.elapsed());
        if !left.is_zero() {
            return Some(if self.timing.busy_wait {
                Duration::ZERO
            } else {
                left
            });
        }
        self.lost += 1;
        self.extra.probe(sent_ns, false);
        self.state = JobState::Idle { next };
        None
    }
}
