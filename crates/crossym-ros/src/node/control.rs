//! The control thread: the path of one joint state to one command, in one place.
//!
//! ```text
//! UDP → RustDDS event loop (this thread) → reader cache → take
//!     → NodeCore::on_joint_state (validation) → recorder channel
//!     → NodeCore::tick (FK, Jacobian, π(q, s), safety QP: allocates, locks, logs nothing)
//!     → publish → RustDDS event loop (this thread, same wake-up) → UDP
//! ```
//!
//! The control thread *is* the DDS participant's event-loop thread: [`ControlHook`] runs
//! as RustDDS's event-loop hook (vendor/README.md), called each time the loop has
//! delivered what arrived, and what it publishes is transmitted before the loop sleeps
//! again. A joint state therefore costs no thread hand-off between the socket and the
//! tick, nor between the tick and the socket: one wake-up of one thread per round trip,
//! as in Cyclone DDS's synchronous delivery. (Before, the event loop woke this thread
//! through the reader's notification and the publish woke the event loop back: two
//! hand-offs, ≈ 50 µs of the node's ≈ 110 µs at 1 kHz.) Conditions arrive the same way. With `trigger = "joint_states"` every accepted joint state ticks
//! once (several read together tick once, on the latest); without one for
//! `stale_timeout_s` the ticks go on at the period (they command the stale-input stop).
//! With `trigger = "timer"` the ticks run every `period_s` on the latest inputs.
//!
//! Reading a message (deserialisation allocates; the reader locks its cache) happens
//! between ticks, never inside one. What the operator should read (rejections, accepted
//! conditions, status transitions) goes to the I/O thread's log as [`ToIo`] events over a
//! bounded channel that never blocks.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{Receiver, SyncSender, TryRecvError};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::{EventLoopHook, EventLoopWaker};

use super::endpoints::Endpoints;
use super::record::{RecordItem, Recorder};
use super::stats::{span_us, Histogram, TickStats};
use crate::dds;
use crate::event_loop::LoopThread;
use crossym_control::node::{
    Command, NodeCore, OperatorRefusal, OperatorRequest, PoseRejection, Rejection, StatusSnapshot,
    TaskPoseMap, TfBuffer, TfError, Trigger,
};
use crossym_io::msg;
use crossym_math::symmetry::compose::Condition;

/// Messages taken from one subscription before the tick is considered again (a flood of
/// messages cannot starve the tick).
const MAX_READS: usize = 64;
/// TF messages taken from each TF reader when a pose arrives (its history depth).
const TF_READS: usize = 100;

/// What the control thread tells the I/O thread's log. Not boxed: a status snapshot (plain
/// data, a few per second) moves by copy, with no allocation on the control thread.
#[allow(clippy::large_enum_variant)]
pub(super) enum ToIo {
    /// A status snapshot (its transitions are logged).
    Status(StatusSnapshot),
    /// A joint state was rejected.
    JointStateRejected(Rejection),
    /// A condition was rejected; `kept` stays in force.
    ConditionRejected {
        /// Why.
        rejection: Rejection,
        /// The condition in force.
        kept: Condition,
    },
    /// A new condition was accepted.
    ConditionAccepted(Condition),
    /// A task pose gave no condition.
    PoseRejected(PoseRejection),
    /// A TF edge was refused (non-finite, zero rotation, its own parent).
    TfRefused(TfError),
    /// An operator request was applied or refused.
    Operator {
        /// The request.
        request: OperatorRequest,
        /// `parameter` or `service`.
        source: &'static str,
        /// Refused: why (nothing changed).
        result: Result<(), OperatorRefusal>,
    },
    /// The conditions now come from the other source (`true`: the task pose).
    ConditionSource {
        /// From the task pose (else from `symmetry_condition`).
        from_pose: bool,
        /// The pose's tilt out of the rotation's plane (rad), when from the pose.
        tilt: f64,
    },
    /// A message could not be decoded.
    Undecodable {
        /// `joint_states` or `symmetry_condition`.
        topic: &'static str,
        /// The decoder's error.
        error: String,
    },
}

/// What the control thread shares with the rest of the process.
pub(super) struct Links {
    /// Events for the I/O thread's log (never blocks: a full channel drops the event).
    pub(super) to_io: SyncSender<ToIo>,
    /// The controlled joint names (for the commands and the status).
    pub(super) names: Vec<String>,
    /// The bag recorder, if recording.
    pub(super) rec: Option<Recorder>,
    /// Set by the I/O thread on a signal; the control thread then sends its final command.
    pub(super) stop: Arc<AtomicBool>,
    /// Operator requests from the I/O thread (with where they came from), applied between
    /// ticks.
    pub(super) from_io: Receiver<(OperatorRequest, &'static str)>,
    /// Subscribers matched on the command topic, counted by the I/O thread (`u32::MAX`:
    /// not known yet); read between ticks.
    pub(super) command_subscribers: Arc<AtomicU32>,
}

/// How long the loop keeps delivering after the final command: reliable writers deliver
/// (and repair) the last samples before the node drops them.
const DRAIN: Duration = Duration::from_millis(300);
/// How often the hook looks for its [`ControlThread`] before it arrives (setup only).
const SETUP_POLL: Duration = Duration::from_millis(5);

/// The control thread as RustDDS's event-loop hook: waits for the node's setup to hand it
/// a [`ControlThread`], steps it after each wake-up of the loop, then lets the loop deliver
/// the final command for [`DRAIN`] and reports the statistics.
pub(super) struct ControlHook {
    shared: Arc<LoopThread>,
    setup: Receiver<ControlThread>,
    done: SyncSender<TickStats>,
    state: HookState,
}

enum HookState {
    Waiting,
    Running(Box<ControlThread>),
    /// The endpoints stay alive while the loop delivers (and repairs) the final samples:
    /// a dropped writer is removed from the loop with what it has not delivered.
    Draining {
        until: Instant,
        stats: Box<TickStats>,
        _control: Box<ControlThread>,
    },
    Done,
}

impl ControlHook {
    /// The hook, the sender of its [`ControlThread`] and the receiver of its statistics.
    pub(super) fn new(
        shared: Arc<LoopThread>,
    ) -> (Self, SyncSender<ControlThread>, Receiver<TickStats>) {
        let (setup_tx, setup) = std::sync::mpsc::sync_channel(1);
        let (done, done_rx) = std::sync::mpsc::sync_channel(1);
        (
            Self {
                shared,
                setup,
                done,
                state: HookState::Waiting,
            },
            setup_tx,
            done_rx,
        )
    }
}

impl EventLoopHook for ControlHook {
    fn start(&mut self, waker: EventLoopWaker) {
        self.shared.started(waker, c"crossym-control");
    }

    fn run(&mut self) -> Option<Duration> {
        loop {
            match &mut self.state {
                HookState::Waiting => match self.setup.try_recv() {
                    Ok(c) => self.state = HookState::Running(Box::new(c)),
                    Err(TryRecvError::Empty) => return Some(SETUP_POLL),
                    Err(TryRecvError::Disconnected) => self.state = HookState::Done,
                },
                HookState::Running(c) => {
                    if let Some(wait) = c.step() {
                        return Some(wait);
                    }
                    let stats = c.finish();
                    if let HookState::Running(c) =
                        std::mem::replace(&mut self.state, HookState::Done)
                    {
                        self.state = HookState::Draining {
                            until: Instant::now() + DRAIN,
                            stats: Box::new(stats),
                            _control: c,
                        };
                    }
                }
                HookState::Draining { until, stats, .. } => {
                    let now = Instant::now();
                    if now < *until {
                        return Some(*until - now);
                    }
                    let stats = std::mem::take(&mut **stats);
                    // The endpoints go first (their removal is queued to this live loop),
                    // then the statistics, after which the process drops the participant.
                    self.state = HookState::Done;
                    let _ = self.done.try_send(stats);
                }
                HookState::Done => return None,
            }
        }
    }
}

/// The control thread's state (handed to [`ControlHook`] once the node is set up).
pub(super) struct ControlThread {
    core: NodeCore,
    ends: Endpoints,
    links: Links,
    /// The condition last accepted (a change is logged once).
    accepted: Condition,
    /// `[node.task_pose]`'s map from a pose to a condition.
    pose_map: Option<TaskPoseMap>,
    /// Whether the last condition came from a task pose (a switch is logged once).
    from_pose: bool,
    /// The TF tree (`[node.task_pose] tf`), updated from `/tf` and `/tf_static` when a pose
    /// arrives.
    tf: Option<TfBuffer>,
    /// Publisher's source stamp → DDS receive, per joint state (µs).
    dds_in: Histogram,
    /// DDS receive → taken by this thread, per joint state (µs).
    to_control: Histogram,
    /// The tick (µs).
    tick: Histogram,
    /// The command publish call (µs).
    publish: Histogram,
    /// How late each tick started (µs).
    late: Histogram,
    /// The loop's state between steps.
    run: RunState,
}

/// The tick loop's state between two wake-ups.
struct RunState {
    period: Duration,
    status_period: Duration,
    cmd: Command,
    stats: TickStats,
    next: Instant,
    next_status: Instant,
    last_seq: u64,
    /// When the latest accepted joint state was sent (ns, wall clock): its source stamp
    /// when it is plausible (not in the future, under a second old: the driver's clock
    /// agrees with ours), else its DDS receive stamp.
    last_rx_ns: u64,
}

impl ControlThread {
    /// The control state of a node set up with `core` and `ends`. Allocates.
    pub(super) fn new(core: NodeCore, ends: Endpoints, links: Links) -> Result<Self, String> {
        // Checked by `NodeConfig::validate` already.
        let pose_map = core
            .config()
            .task_pose
            .clone()
            .map(TaskPoseMap::new)
            .transpose()
            .map_err(|e| e.to_string())?;
        let tf = ends.tf.as_ref().map(|_| TfBuffer::new());
        let accepted = core.condition();
        let cfg = core.config();
        let period = Duration::from_secs_f64(cfg.period_s);
        let run = RunState {
            period,
            status_period: Duration::from_secs_f64(cfg.status_period_s),
            cmd: core.command(),
            stats: TickStats::default(),
            next: Instant::now() + period,
            next_status: Instant::now(),
            last_seq: 0,
            last_rx_ns: 0,
        };
        Ok(Self {
            core,
            ends,
            links,
            accepted,
            pose_map,
            from_pose: false,
            tf,
            dds_in: Histogram::new(),
            to_control: Histogram::new(),
            tick: Histogram::new(),
            publish: Histogram::new(),
            late: Histogram::new(),
            run,
        })
    }

    /// Reads what the loop delivered, ticks and publishes when due; returns how long the
    /// loop may wait before the next step (`None`: `stop` is set).
    ///
    /// epoll counts whole milliseconds (mio rounds a timeout up), so for timer ticks the
    /// loop waits the whole milliseconds and the last one is slept here: a tick is then not
    /// late by up to 1 ms (a message arriving in that sleep is read right after the tick).
    fn step(&mut self) -> Option<Duration> {
        let trigger = self.core.config().trigger;
        loop {
            if self.links.stop.load(Ordering::Acquire) {
                return None;
            }
            let unread = self.read_inputs((true, true));
            let now = Instant::now();
            let seq = self.core.inputs().joint_state_seq;
            let due = match trigger {
                Trigger::Timer => now >= self.run.next,
                Trigger::JointStates => seq != self.run.last_seq || now >= self.run.next,
            };
            if !due {
                if unread.0 || unread.1 {
                    continue;
                }
                let wait = self.run.next.saturating_duration_since(now);
                if trigger == Trigger::Timer && wait < Duration::from_millis(1) {
                    thread::sleep(wait);
                    continue;
                }
                return Some(if trigger == Trigger::Timer {
                    Duration::from_millis(wait.as_millis() as u64)
                } else {
                    wait
                });
            }
            self.tick_and_publish(seq);
            // Back to the loop, which transmits the command now; inputs left unread (a
            // flood) are taken at once.
            return Some(if unread.0 || unread.1 {
                Duration::ZERO
            } else {
                self.run.next.saturating_duration_since(Instant::now())
            });
        }
    }

    /// One tick on the inputs read, its command published, the status when due.
    fn tick_and_publish(&mut self, seq: u64) {
        let cfg = self.core.config();
        let trigger = cfg.trigger;
        let period_s = cfg.period_s;
        self.operator_requests();
        let matched = self.links.command_subscribers.load(Ordering::Acquire);
        if matched != u32::MAX {
            self.core.set_command_subscribers(matched);
        }
        let t0 = Instant::now();
        let now_ns = dds::wall_time_ns();
        let fresh = seq != self.run.last_seq;
        // How late this tick starts, and the ticks that never ran (`node::timing`): a
        // joint-state tick from its state's sending (`last_rx_ns`), joint states read
        // together but the latest untaken; any other tick from the time it was due (none
        // for the first).
        let (late_s, missed) = if trigger == Trigger::JointStates && fresh {
            let late_ns = (now_ns as i64).saturating_sub(self.run.last_rx_ns as i64);
            let together = seq.saturating_sub(self.run.last_seq).saturating_sub(1);
            (late_ns as f64 * 1e-9, together.min(u32::MAX as u64) as u32)
        } else if self.run.stats.ticks == 0 {
            (0.0, 0)
        } else {
            let late_s = t0.saturating_duration_since(self.run.next).as_secs_f64();
            let skipped = if trigger == Trigger::Timer {
                (late_s / period_s).floor() as u32
            } else {
                0
            };
            (late_s, skipped)
        };
        self.core.record_tick_start(late_s, missed);
        self.late.record(late_s * 1e6);
        self.run.last_seq = seq;
        let report = self.core.tick(now_ns as f64 * 1e-9, &mut self.run.cmd);
        let us = t0.elapsed().as_secs_f64() * 1e6;
        self.core.record_tick_time(us);
        self.tick.record(us);
        self.run.stats.ticks += 1;
        if report.publish {
            let sequence = self.core.inputs().command_sequence();
            let tp = Instant::now();
            if self.publish_command(&self.run.cmd, now_ns, sequence) {
                self.run.stats.commands += 1;
            } else {
                self.run.stats.publish_errors += 1;
            }
            self.publish.record(tp.elapsed().as_secs_f64() * 1e6);
        }
        let period = self.run.period;
        self.run.next = match trigger {
            Trigger::Timer => {
                let n = self.run.next + period;
                if n <= t0 {
                    t0 + period
                } else {
                    n
                }
            }
            // A tick per joint state; without one for the stale timeout the ticks go on
            // at the period (they command the stale-input stop). A fallback at one period
            // would race the driver's next state and double the commands.
            Trigger::JointStates if fresh => {
                let stale = self.core.runtime().stale_timeout_s.max(period_s);
                t0 + Duration::from_secs_f64(stale)
            }
            Trigger::JointStates => t0 + period,
        };
        // The period's status at its end; a new fault's at once (once a period).
        let due = t0 >= self.run.next_status;
        if due || self.core.status_escalated() {
            if due {
                self.run.next_status = t0 + self.run.status_period;
            }
            if !self.publish_status(!due) {
                self.run.stats.publish_errors += 1;
            }
        }
    }

    /// Sends the final zero / hold command and a `SHUTDOWN` status and returns the
    /// statistics (the hook then lets the loop deliver them for [`DRAIN`]).
    fn finish(&mut self) -> TickStats {
        let mut cmd = self.run.cmd.clone();
        if self.shutdown(&mut cmd) {
            self.run.stats.commands += 1;
        }
        let mut stats = std::mem::take(&mut self.run.stats);
        stats.median_us = self.tick.quantile(0.5);
        stats.p99_us = self.tick.quantile(0.99);
        stats.max_us = self.tick.max_us;
        stats.dds_in = self.dds_in.stats();
        stats.to_control = self.to_control.stats();
        stats.publish = self.publish.stats();
        stats.late = self.late.stats();
        let status = self.core.status();
        stats.late_ticks = status.late_ticks;
        stats.missed_ticks = status.missed_ticks;
        stats
    }

    /// Takes what arrived on the subscriptions flagged in `unread`; returns the flags of
    /// those not exhausted (more than [`MAX_READS`] waiting).
    fn read_inputs(&mut self, unread: (bool, bool)) -> (bool, bool) {
        let mut left = (false, false);
        if unread.0 {
            left.0 = true;
            for _ in 0..MAX_READS {
                match self.ends.joint_states.take() {
                    Ok(Some((m, info))) => self.on_joint_state(m, &info),
                    Ok(None) => {
                        left.0 = false;
                        break;
                    }
                    Err(e) => self.tell(ToIo::Undecodable {
                        topic: "joint_states",
                        error: format!("{e:?}"),
                    }),
                }
            }
        }
        if unread.1 {
            left.1 = true;
            for _ in 0..MAX_READS {
                match self.ends.conditions.take() {
                    Ok(Some((m, _))) => {
                        if self.from_pose {
                            self.from_pose = false;
                            self.tell(ToIo::ConditionSource {
                                from_pose: false,
                                tilt: 0.0,
                            });
                        }
                        self.on_condition(m)
                    }
                    Ok(None) => {
                        left.1 = false;
                        break;
                    }
                    Err(e) => self.tell(ToIo::Undecodable {
                        topic: "symmetry_condition",
                        error: format!("{e:?}"),
                    }),
                }
            }
            // The task poses count as condition news too (one flag: either source).
            if self.read_poses() {
                left.1 = true;
            }
        }
        left
    }

    /// Takes the waiting task poses; true when more than [`MAX_READS`] were waiting.
    fn read_poses(&mut self) -> bool {
        for _ in 0..MAX_READS {
            let taken = match self.ends.poses.as_ref() {
                Some(sub) => sub.take(),
                None => return false,
            };
            match taken {
                Ok(Some((m, _))) => self.on_task_pose(m),
                Ok(None) => return false,
                Err(e) => self.tell(ToIo::Undecodable {
                    topic: "task_pose",
                    error: format!("{e:?}"),
                }),
            }
        }
        true
    }

    /// One task pose: mapped to a condition, which then goes the way of a condition
    /// message (validated by the gate, recorded as one, so replay sees what drove the
    /// node); the last source wins and a switch is logged.
    fn on_task_pose(&mut self, m: msg::PoseStamped) {
        if self.pose_map.is_none() {
            return;
        }
        self.read_tf();
        let Some(map) = self.pose_map.as_ref() else {
            return;
        };
        match map.condition(&m, dds::wall_time_s(), self.tf.as_ref()) {
            Ok(pc) => {
                if !self.from_pose {
                    self.from_pose = true;
                    self.tell(ToIo::ConditionSource {
                        from_pose: true,
                        tilt: pc.tilt,
                    });
                }
                let c = msg::SymmetryCondition {
                    header: m.header,
                    theta: pc.condition.theta,
                    scale: pc.condition.scale,
                    reflection: pc.condition.reflection,
                };
                self.on_condition(c);
            }
            Err(r) => self.tell(ToIo::PoseRejected(r)),
        }
    }

    /// Applies the operator requests waiting (between two ticks) and reports each.
    fn operator_requests(&mut self) {
        while let Ok((request, source)) = self.links.from_io.try_recv() {
            let result = self.core.apply(request);
            // A default condition goes through the input gate as a condition message does;
            // recorded as one, so replaying the bag applies it at the same point.
            if let (OperatorRequest::DefaultCondition(c), Ok(()), Some(r)) =
                (request, &result, &self.links.rec)
            {
                let m = msg::SymmetryCondition {
                    header: msg::Header::default(),
                    theta: c.theta,
                    scale: c.scale,
                    reflection: c.reflection,
                };
                r.send(RecordItem::Condition(
                    m,
                    dds::wall_time_ns(),
                    self.core.inputs().condition_seq as u32,
                ));
            }
            // The policy started or stopped: recorded as the event that ends the transition
            // (rcl's second event), so replaying the bag applies it at the same point.
            if let (OperatorRequest::Activate(active), Ok(()), Some(r)) =
                (request, &result, &self.links.rec)
            {
                let now_ns = dds::wall_time_ns();
                let event = super::lifecycle::applied_event(active, source, now_ns);
                r.send(RecordItem::Lifecycle(event, now_ns));
            }
            self.tell(ToIo::Operator {
                request,
                source,
                result,
            });
        }
    }

    /// Takes the TF edges waiting (at most the readers' depth each) into the tree.
    fn read_tf(&mut self) {
        let (Some(subs), Some(tree)) = (self.ends.tf.as_ref(), self.tf.as_mut()) else {
            return;
        };
        let mut events = Vec::new();
        for (sub, fixed) in [(&subs.fixed, true), (&subs.dynamic, false)] {
            for _ in 0..TF_READS {
                match sub.take() {
                    Ok(Some((m, _))) => {
                        if let Err(e) = tree.insert_message(&m, fixed) {
                            events.push(ToIo::TfRefused(e));
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        events.push(ToIo::Undecodable {
                            topic: if fixed { "tf_static" } else { "tf" },
                            error: format!("{e:?}"),
                        });
                        break;
                    }
                }
            }
        }
        for e in events {
            self.tell(e);
        }
    }

    /// One joint state: its DDS hops recorded from the `info` stamps, validated, recorded.
    fn on_joint_state(&mut self, m: msg::JointState, info: &ros2_client::MessageInfo) {
        let now_ns = dds::wall_time_ns();
        if let Some(rx) = info.received_timestamp() {
            let rx = rx.to_nanos();
            if let Some(tx) = info.source_timestamp() {
                self.dds_in.record(span_us(tx.to_nanos(), rx));
            }
            self.to_control.record(span_us(rx, now_ns as i64));
        }
        match self.core.on_joint_state(&m, now_ns as f64 * 1e-9) {
            Ok(()) => {
                // The receive stamp is taken by this thread's event loop when it reads the
                // socket: a thread held off the CPU sees its states late, yet "received"
                // now. The source stamp tells (same host or synchronised clocks).
                let rx = info
                    .received_timestamp()
                    .map_or(now_ns, |rx| rx.to_nanos().max(0) as u64);
                let tx = info
                    .source_timestamp()
                    .map(|tx| tx.to_nanos())
                    .filter(|&tx| {
                        tx > 0 && (tx as u64) <= now_ns && now_ns - (tx as u64) < 1_000_000_000
                    });
                self.run.last_rx_ns = tx.map_or(rx, |tx| tx as u64);
            }
            Err(r) => self.tell(ToIo::JointStateRejected(r)),
        }
        // Recorded before the tick, so the bag keeps each joint state ahead of the command
        // computed from it.
        if let Some(r) = &self.links.rec {
            r.send(RecordItem::JointState(
                m,
                now_ns,
                self.core.inputs().joint_state_seq as u32,
            ));
        }
    }

    /// One symmetry condition: validated (a change or a rejection told to the log),
    /// recorded.
    fn on_condition(&mut self, m: msg::SymmetryCondition) {
        match self.core.on_condition(&m) {
            Ok(()) => {
                let c = self.core.condition();
                if c != self.accepted {
                    self.accepted = c;
                    self.tell(ToIo::ConditionAccepted(c));
                }
            }
            Err(rejection) => self.tell(ToIo::ConditionRejected {
                rejection,
                kept: self.accepted,
            }),
        }
        if let Some(r) = &self.links.rec {
            r.send(RecordItem::Condition(
                m,
                dds::wall_time_ns(),
                self.core.inputs().condition_seq as u32,
            ));
        }
    }

    /// Sends an event to the I/O thread's log (dropped when its channel is full).
    fn tell(&self, e: ToIo) {
        let _ = self.links.to_io.try_send(e);
    }

    /// Publishes `cmd` (a copy to the recorder with the tick time and input `sequence`).
    fn publish_command(&self, cmd: &Command, now_ns: u64, sequence: u32) -> bool {
        let rec = self.links.rec.as_ref().map(|r| (r, now_ns, sequence));
        self.ends.command.publish(
            cmd,
            &self.links.names,
            self.core.config().period_s,
            self.core.config().trajectory_start_point,
            rec,
        )
    }

    /// Publishes `~/status` (and hands the snapshot to the log) and starts the next status
    /// period (`early`: at an escalation, before the period's end); false on a publish
    /// error.
    fn publish_status(&mut self, early: bool) -> bool {
        let stamp_ns = dds::wall_time_ns();
        let snap = self.core.status();
        if early {
            self.core.end_status_period_early();
        } else {
            self.core.end_status_period();
        }
        self.tell(ToIo::Status(snap));
        let m = snap.to_msg(
            msg::Time::from_secs_f64(stamp_ns as f64 * 1e-9),
            &self.links.names,
        );
        if let Some(r) = &self.links.rec {
            r.send(RecordItem::Status(Box::new(m.clone()), stamp_ns));
        }
        self.ends.status.publish(m).is_ok()
    }

    /// The final zero / hold command (ForwardCommandController would repeat the last one
    /// forever) and a `SHUTDOWN` status. True when a command was published.
    fn shutdown(&mut self, cmd: &mut Command) -> bool {
        let sequence =
            self.core.inputs().command_sequence() | crossym_control::node::SHUTDOWN_SEQUENCE_BIT;
        let sent = self.core.shutdown_command(cmd)
            && self.publish_command(cmd, dds::wall_time_ns(), sequence);
        let stamp = msg::Time::from_secs_f64(dds::wall_time_s());
        let _ = self
            .ends
            .status
            .publish(self.core.status().to_msg(stamp, &self.links.names));
        sent
    }
}
