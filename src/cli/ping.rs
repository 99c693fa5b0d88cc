//! `crossym ping`: the round trip joint state → command of a running node, measured from
//! another process as the robot's driver sees it.
//!
//! Each probe publishes one `sensor_msgs/JointState` (stamped with the wall clock, a
//! configuration inside the joint limits) on the node's joint-state topic and waits for the
//! next command on its command topic; the time between the publish call and the command's
//! arrival is one round trip. A probe without a command within `--reply-timeout-ms` is
//! lost. The node should run with `trigger = "joint_states"` (else a round trip includes
//! the wait for the next timer tick, up to a period).
//!
//! ping runs on its DDS participant's event-loop thread (`crossym_ros::event_loop`, the
//! node's own arrangement): it publishes and reads where RustDDS sends and receives, so the
//! measurement adds no thread hand-off of its own. It waits for the command as a driver
//! does, blocked until the datagram wakes it (`--busy-wait` spins instead, taking a core),
//! and splits each round trip with the stamps DDS carries (both processes read the same
//! wall clock): the probe's publish → the command's publish (over DDS to the node and
//! through it), the command's publish → its DDS receive here, and that receive → ping
//! holding it.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossym::config::Config;
use crossym::control::realtime::{self, RealtimeConfig};
use crossym::control::{OutputMode, Trigger};
use crossym::msg;
use crossym::ros::dds::{self, DdsSettings};
use crossym::ros::event_loop::LoopThread;
use ros2_client::dds::rustdds::{EventLoopHook, EventLoopWaker};

use crossym::setup::node_config;

use super::common::NodeOverrideArgs;

/// Options of `crossym ping`.
#[derive(Debug, clap::Args)]
pub struct PingArgs {
    /// Config of the node to measure (robot, [node] topics and output mode).
    #[arg(long, short, default_value = "config/letters.toml")]
    pub config: PathBuf,
    /// Probes per second (Hz).
    #[arg(long, default_value_t = 100.0)]
    pub rate: f64,
    /// Number of probes measured (after the warm-up).
    #[arg(long, default_value_t = 1000)]
    pub count: usize,
    /// A probe without a command within this time is lost (ms).
    #[arg(long, default_value_t = 50.0)]
    pub reply_timeout_ms: f64,
    /// Give up (exit 1) when no command answers within this time at start (s).
    #[arg(long, default_value_t = 20.0)]
    pub connect_timeout_s: f64,
    /// Spin on the subscription instead of blocking until DDS wakes ping (takes a core).
    #[arg(long)]
    pub busy_wait: bool,
    /// Run ping as a real-time driver would: its thread (its DDS event loop) under
    /// SCHED_FIFO at this priority (1 … 99), RustDDS's discovery thread one below, memory
    /// locked (needs privileges).
    #[arg(long, value_name = "PRIORITY")]
    pub realtime: Option<i32>,
    /// The node's flags, when it was started with some (name, namespace, output, topics).
    #[command(flatten)]
    pub node: NodeOverrideArgs,
}

/// Order statistics of round trips (µs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Latency {
    /// Median (µs).
    pub median: f64,
    /// 99th percentile (µs).
    pub p99: f64,
    /// 99.9th percentile (µs).
    pub p999: f64,
    /// Maximum (µs).
    pub max: f64,
}

/// Nearest-rank quantiles of `v` (µs), sorted in place; `None` when empty.
pub fn latency(v: &mut [f64]) -> Option<Latency> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some(Latency {
        median: q(0.5),
        p99: q(0.99),
        p999: q(0.999),
        max: v[v.len() - 1],
    })
}

enum Replies {
    Array(ros2_client::Subscription<msg::Float64MultiArray>),
    Trajectory(ros2_client::Subscription<msg::JointTrajectory>),
}

impl Replies {
    /// Subscribes to the node's commands on `topic`, of the type its `output` publishes.
    fn subscribe(
        node: &mut ros2_client::Node,
        output: OutputMode,
        topic: &str,
    ) -> anyhow::Result<Self> {
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

/// One answered probe: the round trip and its parts (µs).
#[derive(Debug, Clone, Copy)]
struct Probe {
    rtt: f64,
    /// Probe published → command published (source stamps).
    forward: Option<f64>,
    /// Command published → received by ping's DDS event loop.
    back: Option<f64>,
    /// Received → held by ping.
    wake: Option<f64>,
}

impl Probe {
    fn new(rtt: f64, sent_ns: i64, taken_ns: i64, info: &ros2_client::MessageInfo) -> Self {
        let us = |a: i64, b: i64| (b - a) as f64 * 1e-3;
        let tx = info.source_timestamp().map(|t| t.to_nanos());
        let rx = info.received_timestamp().map(|t| t.to_nanos());
        Self {
            rtt,
            forward: tx.map(|tx| us(sent_ns, tx)),
            back: tx.zip(rx).map(|(tx, rx)| us(tx, rx)),
            wake: rx.map(|rx| us(rx, taken_ns)),
        }
    }
}

/// Wall clock (ns since the Unix epoch).
fn wall_ns() -> i64 {
    dds::wall_time_ns() as i64
}

/// `crossym ping`. Exit 1 when no command answers.
pub fn run(a: &PingArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.rate.is_finite() && a.rate > 0.0,
        "--rate {} must be positive",
        a.rate
    );
    anyhow::ensure!(a.count > 0, "--count must be positive");
    anyhow::ensure!(
        a.reply_timeout_ms.is_finite() && a.reply_timeout_ms > 0.0,
        "--reply-timeout-ms must be positive"
    );
    let cfg = Config::from_file(&a.config)?;
    let n = node_config(&cfg, &a.node.overrides())?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    if n.trigger != Trigger::JointStates {
        eprintln!(
            "crossym ping: the node's trigger is `timer`: round trips include the wait for its next tick (up to {} ms); run it with --trigger joint_states to measure the transport",
            n.period_s * 1e3
        );
    }
    let q = probe_q(&cfg, kin);
    let js_topic = dds::expand_topic(&n.topics.joint_states, &n.namespace, &n.name);
    let cmd_topic = dds::expand_topic(&n.topics.command, &n.namespace, &n.name);
    let looper = Arc::new(LoopThread::default());
    let (hook, job_tx, done_rx) = PingHook::new(looper.clone());
    let ctx = DdsSettings::from_env()?.context_with_hook(Some(Box::new(hook)))?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_ping_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let thread = looper
        .wait(Duration::from_secs(5))
        .ok_or_else(|| anyhow::anyhow!("the DDS event loop did not start within 5 s"))?;
    if let Some(p) = a.realtime {
        apply_realtime(p, thread)?;
    }
    // Written from the event loop itself: a full send window fails at once.
    let js_pub =
        dds::publisher::<msg::JointState>(&mut node, &js_topic, dds::qos_reliable_nonblocking(10))?;
    let replies = Replies::subscribe(&mut node, n.output, &cmd_topic)?;
    eprintln!(
        "crossym ping: {js_topic} → {cmd_topic}, {} probes at {} Hz",
        a.count, a.rate
    );
    let job = PingJob {
        probe: msg::JointState {
            header: msg::Header::default(),
            name: kin.joint_names().to_vec(),
            position: q,
            ..Default::default()
        },
        js_pub,
        replies,
        connect_timeout: Duration::from_secs_f64(a.connect_timeout_s),
        period: Duration::from_secs_f64(1.0 / a.rate),
        timeout: Duration::from_secs_f64(a.reply_timeout_ms * 1e-3),
        count: a.count,
        busy_wait: a.busy_wait,
        stale_s: n.stale_timeout_s.max(n.period_s),
        state: JobState::WarmUp {
            start: Instant::now(),
            warm: 0,
            next: Instant::now(),
            last_ns: 0,
        },
        probes: Vec::with_capacity(a.count),
        lost: 0,
        extra: Unanswered::new(0, 0.0),
    };
    if job_tx.send(job).is_err() {
        anyhow::bail!("the DDS event loop stopped before ping started");
    }
    looper.wake();
    let outcome = done_rx
        .recv()
        .map_err(|_| anyhow::anyhow!("the DDS event loop stopped during the measurement"))?;
    match outcome {
        PingOutcome::Publish(e) => anyhow::bail!("publishing on {js_topic}: {e}"),
        PingOutcome::NoNode => {
            eprintln!(
                "crossym ping: no command on {cmd_topic} within {} s: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?",
                a.connect_timeout_s
            );
            Ok(ExitCode::from(1))
        }
        PingOutcome::Done {
            probes,
            lost,
            extra,
        } => Ok(report(a, &probes, lost, &extra)),
    }
}

/// What the measurement ended with.
enum PingOutcome {
    /// The round trips.
    Done {
        probes: Vec<Probe>,
        lost: usize,
        extra: Unanswered,
    },
    /// No command came back within the connect timeout.
    NoNode,
    /// A probe could not be published.
    Publish(String),
}

/// ping as RustDDS's event-loop hook: waits for its [`PingJob`], steps it after each
/// wake-up of the loop (a datagram, its own timeout), reports the outcome once.
struct PingHook {
    looper: Arc<LoopThread>,
    jobs: Receiver<PingJob>,
    job: Option<Box<PingJob>>,
    done: SyncSender<PingOutcome>,
    finished: bool,
}

impl PingHook {
    fn new(looper: Arc<LoopThread>) -> (Self, SyncSender<PingJob>, Receiver<PingOutcome>) {
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

/// The measurement, stepped by [`PingHook`] on the DDS event loop.
struct PingJob {
    probe: msg::JointState,
    js_pub: ros2_client::Publisher<msg::JointState>,
    replies: Replies,
    connect_timeout: Duration,
    period: Duration,
    timeout: Duration,
    count: usize,
    busy_wait: bool,
    stale_s: f64,
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

impl PingJob {
    /// Publishes one probe stamped with the wall clock; its publish time (ns).
    fn send(&mut self) -> Result<i64, PingOutcome> {
        let now = wall_ns();
        self.probe.header.stamp = msg::Time::from_secs_f64(now as f64 * 1e-9);
        self.js_pub
            .publish(self.probe.clone())
            .map_err(|e| PingOutcome::Publish(format!("{e:?}")))?;
        Ok(now)
    }

    /// Advances the measurement; how long the loop may wait (`Err`: finished).
    fn step(&mut self) -> Result<Duration, PingOutcome> {
        loop {
            match self.state {
                JobState::WarmUp {
                    start,
                    mut warm,
                    next,
                    last_ns,
                } => {
                    while self.replies.try_info().is_some() {
                        warm += 1;
                    }
                    if warm >= 20 {
                        self.extra = Unanswered::new(last_ns, self.stale_s);
                        self.state = JobState::Idle {
                            next: Instant::now(),
                        };
                        continue;
                    }
                    if start.elapsed() > self.connect_timeout {
                        return Err(PingOutcome::NoNode);
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
                    return Ok(next.saturating_duration_since(Instant::now()));
                }
                JobState::Idle { next } => {
                    if self.probes.len() + self.lost >= self.count {
                        return Err(PingOutcome::Done {
                            probes: std::mem::take(&mut self.probes),
                            lost: self.lost,
                            extra: self.extra.clone(),
                        });
                    }
                    while let Some(i) = self.replies.try_info() {
                        self.extra.count(&i);
                    }
                    let wait = next.saturating_duration_since(Instant::now());
                    if wait >= SLEEP_BELOW && !self.busy_wait {
                        return Ok(Duration::from_millis(wait.as_millis() as u64));
                    }
                    if !wait.is_zero() {
                        if self.busy_wait {
                            return Ok(Duration::ZERO);
                        }
                        std::thread::sleep(wait);
                    }
                    let t0 = Instant::now();
                    let sent_ns = self.send()?;
                    self.state = JobState::Waiting {
                        t0,
                        sent_ns,
                        next: next + self.period,
                    };
                    // Back to the loop: it transmits the probe now.
                    return Ok(if self.busy_wait {
                        Duration::ZERO
                    } else {
                        self.timeout
                    });
                }
                JobState::Waiting { t0, sent_ns, next } => {
                    while let Some(i) = self.replies.try_info() {
                        let answers = i.source_timestamp().is_none_or(|t| t.to_nanos() >= sent_ns);
                        if !answers {
                            self.extra.count(&i);
                            continue;
                        }
                        self.probes.push(Probe::new(
                            t0.elapsed().as_secs_f64() * 1e6,
                            sent_ns,
                            wall_ns(),
                            &i,
                        ));
                        self.extra.probe(sent_ns, true);
                        self.state = JobState::Idle { next };
                        break;
                    }
                    if let JobState::Waiting { .. } = self.state {
                        let left = self.timeout.saturating_sub(t0.elapsed());
                        if !left.is_zero() {
                            return Ok(if self.busy_wait { Duration::ZERO } else { left });
                        }
                        self.lost += 1;
                        self.extra.probe(sent_ns, false);
                        self.state = JobState::Idle { next };
                    }
                }
            }
        }
    }
}

/// Commands that answer no probe, by what explains them (their DDS source stamps against
/// the previous probe's publish time): the node's own ticks once no joint state came for
/// its stale timeout (ping stalled: the node rightly commands the stale-input stop at its
/// period), a late answer to a lost probe, or a stray (a command nothing explains, e.g.
/// a second tick per joint state, which a driver would take for the answer to its next
/// state).
#[derive(Debug, Clone, PartialEq)]
struct Unanswered {
    /// Publish time of the previous probe (ns) and whether a command answered it.
    prev: (i64, bool),
    /// The node's stale timeout (at least its period), ns.
    stale_ns: i64,
    stray: usize,
    own_ticks: usize,
    late: usize,
}

impl Unanswered {
    fn new(warm_sent_ns: i64, stale_s: f64) -> Self {
        Self {
            prev: (warm_sent_ns, true),
            stale_ns: (stale_s * 1e9) as i64,
            stray: 0,
            own_ticks: 0,
            late: 0,
        }
    }

    /// The probe published at `sent_ns` was answered (or not).
    fn probe(&mut self, sent_ns: i64, answered: bool) {
        self.prev = (sent_ns, answered);
    }

    /// Counts a command that answers no probe.
    fn count(&mut self, info: &ros2_client::MessageInfo) {
        self.count_stamp(info.source_timestamp().map(|t| t.to_nanos()));
    }

    fn count_stamp(&mut self, source_ns: Option<i64>) {
        let (sent, answered) = self.prev;
        match source_ns {
            Some(t) if t >= sent + self.stale_ns => self.own_ticks += 1,
            Some(t) if t >= sent && !answered => self.late += 1,
            _ => self.stray += 1,
        }
    }
}

/// `--realtime PRIORITY`: ping's thread (its DDS event loop) under SCHED_FIFO at `p`,
/// RustDDS's discovery thread one below, memory locked; what could not be applied is
/// printed.
fn apply_realtime(p: i32, thread: libc::pthread_t) -> anyhow::Result<()> {
    let rt = RealtimeConfig {
        priority: p,
        lock_memory: true,
        dds_priority: Some((p - 1).max(1)),
        cpu_latency_us: None,
        idle_poll: false,
    };
    rt.validate()
        .map_err(|e| anyhow::anyhow!("--realtime: {e}"))?;
    for o in realtime::apply(&rt, thread) {
        eprintln!(
            "crossym ping: {}",
            o.to_string().replace("control thread", "ping thread")
        );
    }
    Ok(())
}

/// A configuration inside the limits where the policy runs: the mock hardware's start
/// (`[mock_hw] initial_q`, else `[check] reference_q`), else mid-range. (Mid-range is
/// q = 0 on the planar arms: stretched out, where a task head's lift is singular and
/// the node commands zero without running its policy.)
fn probe_q(cfg: &Config, kin: &crossym::kinematics::Kinematics) -> Vec<f64> {
    cfg.start_q()
        .filter(|q| q.len() == kin.dof())
        .unwrap_or_else(|| {
            kin.limits()
                .iter()
                .map(|l| 0.5 * (l.lower + l.upper))
                .collect()
        })
}

/// Prints the round trips' order statistics and their parts; exit 1 when all were lost.
fn report(a: &PingArgs, probes: &[Probe], lost: usize, extra: &Unanswered) -> ExitCode {
    let mut rtt: Vec<f64> = probes.iter().map(|p| p.rtt).collect();
    let Some(l) = latency(&mut rtt) else {
        println!("ping: {} probes, all lost", a.count);
        return ExitCode::from(1);
    };
    println!(
        "ping: {} round trips at {} Hz ({}): median {:.0} µs, p99 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs; {lost} lost (no command within {} ms), {} stray commands (published before their probe); {} late answers to lost probes, {} commands of the node's own ticks (no probe for its stale timeout)",
        rtt.len(),
        a.rate,
        if a.busy_wait { "busy-wait" } else { "blocking wait" },
        l.median,
        l.p99,
        l.p999,
        l.max,
        a.reply_timeout_ms,
        extra.stray,
        extra.late,
        extra.own_ticks
    );
    for (label, part) in [
        (
            "probe published → command published (to the node and through it)",
            &(|p: &Probe| p.forward) as &dyn Fn(&Probe) -> Option<f64>,
        ),
        ("command published → received here (DDS)", &|p: &Probe| {
            p.back
        }),
        ("received here → held by ping", &|p: &Probe| p.wake),
    ] {
        let mut v: Vec<f64> = probes.iter().filter_map(part).collect();
        if let Some(l) = latency(&mut v) {
            println!(
                "  {label}: median {:.0} µs, p99 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs",
                l.median, l.p99, l.p999, l.max
            );
        }
    }
    ExitCode::SUCCESS
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_quantiles() {
        let mut v: Vec<f64> = (1..=1000).rev().map(f64::from).collect();
        let l = latency(&mut v).unwrap();
        assert_eq!(
            (l.median, l.p99, l.p999, l.max),
            (500.0, 990.0, 999.0, 1000.0)
        );
        assert!(latency(&mut []).is_none());
    }

    /// Unanswered commands by their source stamps (stale timeout 100 ms, probe at 1 s).
    #[test]
    fn unanswered_commands_are_told_apart_by_their_stamps() {
        const MS: i64 = 1_000_000;
        let mut u = Unanswered::new(0, 0.1);
        u.probe(1000 * MS, true);
        // A second command 10 ms after an answered probe: nothing explains it.
        u.count_stamp(Some(1010 * MS));
        // No stamp: cannot be explained either.
        u.count_stamp(None);
        // 100 ms and more after the probe: the node's stale-input ticks.
        u.count_stamp(Some(1100 * MS));
        u.count_stamp(Some(1110 * MS));
        // After a lost probe, a command inside its stale window is its late answer; one
        // from before it is still a stray.
        u.probe(2000 * MS, false);
        u.count_stamp(Some(2060 * MS));
        u.count_stamp(Some(1990 * MS));
        assert_eq!((u.stray, u.late, u.own_ticks), (3, 1, 2));
    }
}
