//! The ROS 2 node process: [`NodeCore`] over DDS (ros2-client).
//!
//! Threads:
//! - **I/O** (tokio, one worker): the subscriptions `/joint_states` (best effort) and
//!   `~/symmetry_condition` (reliable) feed an [`InputGate`]; after each message the
//!   validated [`Inputs`] are published into a lock-free triple buffer (latest value wins).
//!   The node's log ([`NodeLog`]: console and `/rosout`, like an rclcpp node) is written
//!   here: a startup summary, each kind of rejection at once and then at most once per
//!   second with a count, accepted condition changes, and transitions read from the status
//!   snapshots the control thread hands over (stale ↔ fresh, safety fallbacks, policy
//!   faults). The ros2-client spinner (graph, parameter services) and the SIGINT/SIGTERM
//!   handler run here too.
//! - **Control** (a dedicated thread): every `period_s` (or on every accepted joint state
//!   with `trigger = "joint_states"`), it takes the latest inputs and runs
//!   [`NodeCore::tick`] — kinematics, policy `π(q, s)`, safety QP — which allocates, locks
//!   and logs nothing; then it publishes the command, and `~/status` every
//!   `status_period_s`. The tick never waits on I/O.
//! - On SIGINT/SIGTERM the control thread sends one final zero-velocity / hold command and
//!   a `SHUTDOWN` status, lets reliable delivery drain, and the process exits 0.

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicI64, Ordering};
use std::sync::Arc;
use std::thread::{self, Thread};
use std::time::{Duration, Instant};

use futures::StreamExt;
use ros2_client::{NodeOptions, ParameterValue};

use super::core::{Command, InputGate, Inputs, NodeCore, OutputMode, StatusSnapshot, Trigger};
use super::dds::{self, DdsError, DdsSettings};
use super::log::{NodeLog, Severity, StatusWatch};
use super::msg;
use crate::bag::{BagError, BagWriter};

/// Errors that stop the node process.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum NodeRunError {
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The async runtime or a thread could not start.
    #[error("runtime: {message}")]
    Runtime {
        /// What failed.
        message: String,
    },
}

/// Tick-duration statistics of one run (µs), from a fixed histogram of 1 µs bins.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TickStats {
    /// Ticks run (count).
    pub ticks: u64,
    /// Commands published (count).
    pub commands: u64,
    /// Publish errors (count).
    pub publish_errors: u64,
    /// Median tick duration (µs).
    pub median_us: f64,
    /// 99th percentile tick duration (µs).
    pub p99_us: f64,
    /// Maximum tick duration (µs).
    pub max_us: f64,
    /// Messages written to the bag (count).
    pub bag_messages: u64,
    /// Messages dropped because the bag writer fell behind (count).
    pub bag_dropped: u64,
    /// Joint state written by its publisher (its source stamp) → received by this node's
    /// DDS event loop (wall clock of both processes, µs).
    pub dds_in: HopStats,
    /// DDS receive → the I/O task holds the joint state (µs).
    pub to_io: HopStats,
    /// I/O task hands the inputs over and wakes the control thread → the tick starts (µs;
    /// `trigger = "joint_states"` only).
    pub handoff: HopStats,
    /// The command publish call (serialisation, hand-off to the DDS writer; µs).
    pub publish: HopStats,
}

/// Latency of one hop of the joint state → command path (µs), from a histogram of 1 µs bins.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct HopStats {
    /// Samples (count).
    pub count: u64,
    /// Median (µs).
    pub median_us: f64,
    /// 99th percentile (µs).
    pub p99_us: f64,
    /// Maximum (µs).
    pub max_us: f64,
}

impl std::fmt::Display for HopStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "median {:.0} µs, p99 {:.0} µs, max {:.0} µs ({} samples)",
            self.median_us, self.p99_us, self.max_us, self.count
        )
    }
}

/// Fixed-size histogram of durations, 1 µs bins up to 20 ms (no allocation per sample).
struct Histogram {
    bins: Vec<u32>,
    n: u64,
    max_us: f64,
}

impl Histogram {
    fn new() -> Self {
        Self {
            bins: vec![0; 20_000],
            n: 0,
            max_us: 0.0,
        }
    }

    fn record(&mut self, us: f64) {
        let last = self.bins.len() - 1;
        let b = if us.is_finite() && us >= 0.0 {
            (us as usize).min(last)
        } else {
            last
        };
        self.bins[b] = self.bins[b].saturating_add(1);
        self.n += 1;
        self.max_us = self.max_us.max(us);
    }

    fn quantile(&self, p: f64) -> f64 {
        if self.n == 0 {
            return 0.0;
        }
        let target = (p * self.n as f64).ceil().max(1.0) as u64;
        let mut acc = 0u64;
        for (i, &c) in self.bins.iter().enumerate() {
            acc += u64::from(c);
            if acc >= target {
                return i as f64 + 0.5;
            }
        }
        self.max_us
    }

    fn stats(&self) -> HopStats {
        HopStats {
            count: self.n,
            median_us: self.quantile(0.5),
            p99_us: self.quantile(0.99),
            max_us: self.max_us,
        }
    }
}

/// Microseconds from wall-clock stamp `from_ns` to `to_ns` (ns since the Unix epoch), at
/// least 0 (stamps of two threads or processes of one host).
fn span_us(from_ns: i64, to_ns: i64) -> f64 {
    (to_ns.saturating_sub(from_ns)).max(0) as f64 * 1e-3
}

/// Wall-clock now (ns since the Unix epoch) as the `i64` of ROS times.
fn wall_ns() -> i64 {
    dds::wall_time_ns() as i64
}

/// Runs the node until SIGINT/SIGTERM (or `stop` is set); returns the tick statistics.
///
/// Setup (recorder, DDS node and endpoints, I/O runtime, log) allocates; then the control
/// thread (`control_loop`) and the I/O loop (`InputPath::serve`) run until a signal,
/// and `finish` joins them and writes the shutdown summary.
pub fn run(
    core: NodeCore,
    settings: DdsSettings,
    stop: Option<Arc<AtomicBool>>,
    record: Option<&Path>,
) -> Result<TickStats, NodeRunError> {
    let cfg = core.config().clone();
    let recorder = match record {
        Some(dir) => Some(start_recorder(dir, &cfg)?),
        None => None,
    };
    let ctx = settings.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name(&cfg.namespace, &cfg.name)?,
            node_options(&core),
        )
        .map_err(|e| DdsError::Create {
            what: format!("node {}/{}", cfg.namespace, cfg.name),
            message: format!("{e:?}"),
        })?;
    let ends = Endpoints::create(&mut node, &cfg)?;
    let logger = node.logging_handle();
    let spinner = node.spinner().map_err(|e| DdsError::Create {
        what: "spinner".into(),
        message: format!("{e:?}"),
    })?;
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .thread_name("crossym-io")
        .build()
        .map_err(|e| NodeRunError::Runtime {
            message: e.to_string(),
        })?;

    let stop = stop.unwrap_or_else(|| Arc::new(AtomicBool::new(false)));
    let gate = core.input_gate();
    let (input, output) = triple_buffer::triple_buffer(gate.inputs());
    let names = core.joint_names().to_vec();
    let mut log = NodeLog::new(
        &cfg.name,
        Some(logger),
        cfg.log_level,
        Duration::from_secs(1),
    );
    for line in startup_summary(&core, &gate, &settings, record) {
        log.log(Severity::Info, &line);
    }
    let (status_tx, status_rx) = std::sync::mpsc::sync_channel::<StatusSnapshot>(64);

    // Control thread.
    let stop_ctl = stop.clone();
    let status_names = names.clone();
    let rec_ctl = recorder.as_ref().map(|r| r.0.clone());
    let command = ends.command;
    let status_pub = ends.status;
    let handed_ns = Arc::new(AtomicI64::new(0));
    let handed_ctl = handed_ns.clone();
    let control = thread::Builder::new()
        .name("crossym-control".into())
        .spawn(move || {
            control_loop(
                core,
                output,
                command,
                StatusOut {
                    publisher: status_pub,
                    log: status_tx,
                },
                ControlLinks {
                    stop: stop_ctl,
                    handed_ns: handed_ctl,
                },
                status_names,
                rec_ctl,
            )
        })
        .map_err(|e| NodeRunError::Runtime {
            message: format!("control thread: {e}"),
        })?;
    if let Some(rt) = &cfg.realtime {
        use std::os::unix::thread::JoinHandleExt;
        for o in super::realtime::apply(rt, control.as_pthread_t()) {
            match o {
                super::realtime::RealtimeOutcome::Applied { what } => {
                    log.log(Severity::Info, &format!("realtime: {what}"))
                }
                super::realtime::RealtimeOutcome::Refused { what, reason } => log.log(
                    Severity::Warn,
                    &format!("realtime: {what} REFUSED ({reason}); running without it"),
                ),
            }
        }
    }

    // I/O: inputs in, log out.
    let mut path = InputPath {
        accepted: gate.inputs().condition,
        gate,
        input,
        names,
        recorder: recorder.as_ref().map(|r| r.0.clone()),
        wake: (cfg.trigger == Trigger::JointStates).then(|| control.thread().clone()),
        watch: StatusWatch::default(),
        status: status_rx,
        log,
        dds_in: Histogram::new(),
        to_io: Histogram::new(),
        handed_ns,
    };
    runtime.block_on(path.serve(ends.joint_states, ends.conditions, spinner, &stop));
    stop.store(true, Ordering::Release);
    control.thread().unpark();
    let stats = finish(control, recorder, path);
    drop(node);
    runtime.shutdown_timeout(Duration::from_millis(200));
    stats
}

/// The node's options: read-only parameters describing its configuration, rosout and the
/// parameter services.
fn node_options(core: &NodeCore) -> NodeOptions {
    let cfg = core.config();
    let mut params: Vec<(&str, ParameterValue)> = vec![
        ("period_s", ParameterValue::Double(cfg.period_s)),
        (
            "stale_timeout_s",
            ParameterValue::Double(cfg.stale_timeout_s),
        ),
        ("check_stamps", ParameterValue::Boolean(cfg.check_stamps)),
        (
            "output",
            ParameterValue::String(format!("{:?}", cfg.output).to_lowercase()),
        ),
        (
            "trigger",
            ParameterValue::String(format!("{:?}", cfg.trigger).to_lowercase()),
        ),
        (
            "joint_names",
            ParameterValue::StringArray(core.joint_names().to_vec()),
        ),
        (
            "topics.command",
            ParameterValue::String(cfg.topics.command.clone()),
        ),
    ];
    if let Some(p) = &cfg.policy {
        params.push(("policy", ParameterValue::String(p.display().to_string())));
    }
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true);
    for (k, v) in &params {
        options = options.declare_parameter(k, v.clone());
    }
    // Parameters are read-only at runtime: the tick's buffers and the QP are set up once.
    let fixed: Vec<(String, ParameterValue)> = params
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    options.parameter_validator(Box::new(move |name, value| {
        match fixed.iter().find(|(k, _)| k == name) {
            Some((_, v)) if v == value => Ok(()),
            _ => Err(format!(
                "`{name}` is read-only at runtime: set it in the TOML config or on the command line"
            )),
        }
    }))
}

/// The node's topics: two inputs, the command and the status.
struct Endpoints {
    joint_states: ros2_client::Subscription<msg::JointState>,
    conditions: ros2_client::Subscription<msg::SymmetryCondition>,
    command: CommandPublisher,
    status: ros2_client::Publisher<msg::Status>,
}

impl Endpoints {
    /// Joint states best effort (sensor QoS), everything else reliable (depth 10).
    fn create(node: &mut ros2_client::Node, cfg: &super::NodeConfig) -> Result<Self, DdsError> {
        let command = match cfg.output {
            OutputMode::Velocity | OutputMode::Position => {
                CommandPublisher::Array(dds::publisher::<msg::Float64MultiArray>(
                    node,
                    &cfg.topics.command,
                    dds::qos_reliable(10),
                )?)
            }
            OutputMode::Trajectory => {
                CommandPublisher::Trajectory(dds::publisher::<msg::JointTrajectory>(
                    node,
                    &cfg.topics.command,
                    dds::qos_reliable(10),
                )?)
            }
        };
        Ok(Self {
            joint_states: dds::subscription::<msg::JointState>(
                node,
                &cfg.topics.joint_states,
                dds::qos_sensor(),
            )?,
            conditions: dds::subscription::<msg::SymmetryCondition>(
                node,
                &cfg.topics.symmetry_condition,
                dds::qos_reliable(10),
            )?,
            command,
            status: dds::publisher::<msg::Status>(node, &cfg.topics.status, dds::qos_reliable(10))?,
        })
    }
}

/// The I/O side: one received message → validation ([`InputGate`]) → the latest inputs in
/// the triple buffer → (trigger `joint_states`) the control thread woken; plus the node's
/// log of rejections, condition changes and status transitions.
struct InputPath {
    gate: InputGate,
    input: triple_buffer::Input<Inputs>,
    names: Vec<String>,
    recorder: Option<Recorder>,
    /// The control thread, when every accepted joint state triggers a tick.
    wake: Option<Thread>,
    /// The condition last accepted (for change and rejection messages).
    accepted: crate::symmetry::compose::Condition,
    watch: StatusWatch,
    status: std::sync::mpsc::Receiver<StatusSnapshot>,
    log: NodeLog,
    /// Publisher's source stamp → DDS receive, per joint state (µs).
    dds_in: Histogram,
    /// DDS receive → this task, per joint state (µs).
    to_io: Histogram,
    /// Wall-clock time (ns) of the last hand-over, read by the control thread.
    handed_ns: Arc<AtomicI64>,
}

impl InputPath {
    /// Hands the gate's current inputs to the control thread (latest value wins).
    fn hand_over(&mut self) {
        self.input.input_buffer_mut().copy_from(self.gate.inputs());
        self.input.publish();
    }

    /// One joint state: validated, handed over, recorded, the control thread woken; the
    /// DDS hops it took are recorded from its `info` stamps.
    fn on_joint_state(&mut self, m: msg::JointState, info: &ros2_client::MessageInfo) {
        let now_ns = dds::wall_time_ns();
        if let Some(rx) = info.received_timestamp() {
            let rx = rx.to_nanos();
            if let Some(tx) = info.source_timestamp() {
                self.dds_in.record(span_us(tx.to_nanos(), rx));
            }
            self.to_io.record(span_us(rx, now_ns as i64));
        }
        if let Err(r) = self.gate.on_joint_state(&m, now_ns as f64 * 1e-9) {
            self.log.limited(
                r.describe(),
                Severity::Warn,
                &format!("rejected joint_states: {}", r.explain(&self.names)),
            );
        }
        // Stamped before the hand-over: a control thread that wakes on its own between the
        // two must not pair the new inputs with the previous stamp.
        if self.wake.is_some() {
            self.handed_ns.store(wall_ns(), Ordering::Release);
        }
        self.hand_over();
        // Recorded before the wake-up, so the bag keeps each joint state ahead of the command
        // computed from it.
        if let Some(r) = &self.recorder {
            r.send(RecordItem::JointState(
                m,
                now_ns,
                self.gate.inputs().joint_state_seq as u32,
            ));
        }
        if let Some(t) = &self.wake {
            t.unpark();
        }
    }

    /// One symmetry condition: validated (a change is logged), handed over, recorded.
    fn on_condition(&mut self, m: msg::SymmetryCondition) {
        match self.gate.on_condition(&m) {
            Ok(()) => {
                let c = self.gate.inputs().condition;
                if c != self.accepted {
                    self.accepted = c;
                    self.log.log(
                        Severity::Info,
                        &format!(
                            "symmetry condition accepted: θ = {:.4} rad ({:.1}°), λ = {}, σ = {:+}",
                            c.theta,
                            c.theta.to_degrees(),
                            c.scale,
                            c.reflection
                        ),
                    );
                }
            }
            Err(r) => {
                let a = self.accepted;
                let why = self.gate.explain(&r);
                self.log.limited(
                    r.describe(),
                    Severity::Warn,
                    &format!(
                        "rejected symmetry_condition (keeping θ = {:.4} rad, λ = {}, σ = {:+}): {why}",
                        a.theta, a.scale, a.reflection
                    ),
                );
            }
        }
        self.hand_over();
        if let Some(r) = &self.recorder {
            r.send(RecordItem::Condition(
                m,
                dds::wall_time_ns(),
                self.gate.inputs().condition_seq as u32,
            ));
        }
    }

    /// Logs the transitions in the status snapshots the control thread sent.
    fn drain_status(&mut self) {
        while let Ok(snap) = self.status.try_recv() {
            self.watch.observe(&snap, &mut self.log);
        }
    }

    /// The I/O loop: both subscriptions, the spinner, signals, and every 20 ms the status
    /// snapshots and `stop`; returns on a signal, `stop` or a closed subscription.
    async fn serve(
        &mut self,
        joint_states: ros2_client::Subscription<msg::JointState>,
        conditions: ros2_client::Subscription<msg::SymmetryCondition>,
        spinner: ros2_client::Spinner,
        stop: &AtomicBool,
    ) {
        tokio::spawn(spinner.spin());
        let signals = dds::shutdown_signal();
        tokio::pin!(signals);
        let mut js_stream = Box::pin(joint_states.async_stream());
        let mut cond_stream = Box::pin(conditions.async_stream());
        let mut poll = tokio::time::interval(Duration::from_millis(20));
        loop {
            tokio::select! {
                m = js_stream.next() => match m {
                    Some(Ok((m, info))) => self.on_joint_state(m, &info),
                    Some(Err(e)) => self.log.limited("undecodable", Severity::Warn, &format!("joint_states not decodable: {e:?}")),
                    None => break,
                },
                m = cond_stream.next() => match m {
                    Some(Ok((m, _))) => self.on_condition(m),
                    Some(Err(e)) => self.log.limited("undecodable", Severity::Warn, &format!("symmetry_condition not decodable: {e:?}")),
                    None => break,
                },
                _ = &mut signals => break,
                _ = poll.tick() => {
                    self.drain_status();
                    if stop.load(Ordering::Acquire) {
                        break;
                    }
                }
            }
        }
    }
}

/// Joins the control thread (which sent the final command) and the recorder, logs the
/// last transitions and the shutdown summary.
fn finish(
    control: thread::JoinHandle<TickStats>,
    recorder: Option<(Recorder, thread::JoinHandle<Result<u64, BagError>>)>,
    mut path: InputPath,
) -> Result<TickStats, NodeRunError> {
    let mut stats = control.join().map_err(|_| NodeRunError::Runtime {
        message: "control thread panicked".into(),
    })?;
    path.recorder = None;
    if let Some((r, handle)) = recorder {
        stats.bag_dropped = r.dropped.load(Ordering::Relaxed);
        drop(r);
        stats.bag_messages = handle
            .join()
            .map_err(|_| NodeRunError::Runtime {
                message: "bag thread panicked".into(),
            })?
            .map_err(|e| NodeRunError::Runtime {
                message: format!("recording: {e}"),
            })?;
    }
    stats.dds_in = path.dds_in.stats();
    stats.to_io = path.to_io.stats();
    path.drain_status();
    path.log.flush_suppressed();
    path.log.log(
        Severity::Info,
        &format!(
            "stopped: {} ticks, {} commands, {} publish errors; tick median {:.1} µs, p99 {:.1} µs, max {:.1} µs",
            stats.ticks, stats.commands, stats.publish_errors, stats.median_us, stats.p99_us, stats.max_us
        ),
    );
    if stats.dds_in.count + stats.to_io.count > 0 {
        path.log.log(
            Severity::Info,
            &format!(
                "joint state → command hops: DDS in (publisher → this node) {}; DDS receive → I/O task {}; hand-over → tick {}; tick median {:.0} µs, p99 {:.0} µs, max {:.0} µs; publish call {}",
                stats.dds_in, stats.to_io, stats.handoff, stats.median_us, stats.p99_us, stats.max_us, stats.publish
            ),
        );
    }
    Ok(stats)
}

/// The node's startup lines: robot, policy and conditions, topics with QoS, output and
/// rate, safety settings (what an operator checks first).
fn startup_summary(
    core: &NodeCore,
    gate: &InputGate,
    settings: &DdsSettings,
    record: Option<&Path>,
) -> Vec<String> {
    let cfg = core.config();
    let kin = core.kinematics();
    let topic = |t: &str| dds::expand_topic(t, &cfg.namespace, &cfg.name);
    let chains: Vec<String> = kin
        .chains()
        .iter()
        .map(|c| format!("{} ({} joints, {} → {})", c.name, c.dof(), c.base, c.tip))
        .collect();
    let mut lines = vec![
        format!(
            "robot `{}`: {} controlled joints in {}",
            kin.robot,
            kin.dof(),
            chains.join(", ")
        ),
        format!(
            "policy {}; conditions accepted: {}",
            cfg.policy
                .as_ref()
                .map_or("(none)".into(), |p| p.display().to_string()),
            match (gate.domain(), gate.checks_feasibility()) {
                (_, true) => "any whose lifted flows are feasible from the current joint state \
                              (canonicalised policy)"
                    .to_string(),
                (Some(d), false) => format!("the trained box, {}", d.describe()),
                (None, false) => {
                    "any valid (accept_untrained_conditions, or no training record)".to_string()
                }
            }
        ),
        format!(
            "topics: in {} (JointState, best effort, keep last 5), {} (SymmetryCondition, reliable, keep last 10); out {} ({}, reliable, keep last 10), {} (Status every {} s, reliable, keep last 10); DDS domain {}",
            topic(&cfg.topics.joint_states),
            topic(&cfg.topics.symmetry_condition),
            topic(&cfg.topics.command),
            match cfg.output {
                OutputMode::Trajectory => "JointTrajectory",
                _ => "Float64MultiArray",
            },
            topic(&cfg.topics.status),
            cfg.status_period_s,
            settings.domain_id
        ),
        format!(
            "output {} at {:.0} Hz (period {} s, trigger {}), joint states stale after {} s",
            format!("{:?}", cfg.output).to_lowercase(),
            1.0 / cfg.period_s,
            cfg.period_s,
            format!("{:?}", cfg.trigger).to_lowercase(),
            cfg.stale_timeout_s
        ),
        format!(
            "safety: QP filter on position, velocity and acceleration limits (margin {} rad, latency {} s, state delay {} s), end-effector distance {}",
            cfg.safety.margin,
            cfg.safety.latency_s.unwrap_or(cfg.period_s),
            cfg.safety.state_delay_s,
            cfg.safety
                .min_ee_distance
                .map_or("unbounded".into(), |d| format!("≥ {d} m"))
        ),
    ];
    if let Some(dir) = record {
        lines.push(format!("recording to {}", dir.display()));
    }
    lines
}

/// A message for the bag recorder (sent off the tick over a bounded channel).
enum RecordItem {
    JointState(msg::JointState, u64, u32),
    Condition(msg::SymmetryCondition, u64, u32),
    Array(msg::Float64MultiArray, u64, u32),
    Trajectory(msg::JointTrajectory, u64, u32),
    Status(msg::Status, u64),
}

/// The sending side of the recorder; `send` never blocks (drops and counts when full).
#[derive(Clone)]
struct Recorder {
    tx: std::sync::mpsc::SyncSender<RecordItem>,
    dropped: Arc<std::sync::atomic::AtomicU64>,
}

impl Recorder {
    fn send(&self, item: RecordItem) {
        if self.tx.try_send(item).is_err() {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// Opens the bag and starts the writer thread; returns the sender and the thread handle.
fn start_recorder(
    dir: &Path,
    cfg: &super::NodeConfig,
) -> Result<(Recorder, thread::JoinHandle<Result<u64, BagError>>), NodeRunError> {
    use crate::bag::Qos;
    let mut w = BagWriter::create(dir).map_err(|e| NodeRunError::Runtime {
        message: format!("recording: {e}"),
    })?;
    let name = |t: &str| dds::expand_topic(t, &cfg.namespace, &cfg.name);
    let topics = (|| -> Result<_, BagError> {
        let js =
            w.add_topic::<msg::JointState>(&name(&cfg.topics.joint_states), Qos::best_effort(5))?;
        let cond = w.add_topic::<msg::SymmetryCondition>(
            &name(&cfg.topics.symmetry_condition),
            Qos::reliable(10),
        )?;
        let cmd = match cfg.output {
            OutputMode::Trajectory => {
                w.add_topic::<msg::JointTrajectory>(&name(&cfg.topics.command), Qos::reliable(10))?
            }
            _ => w.add_topic::<msg::Float64MultiArray>(
                &name(&cfg.topics.command),
                Qos::reliable(10),
            )?,
        };
        let status = w.add_topic::<msg::Status>(&name(&cfg.topics.status), Qos::reliable(10))?;
        Ok((js, cond, cmd, status))
    })()
    .map_err(|e| NodeRunError::Runtime {
        message: format!("recording: {e}"),
    })?;
    let (tx, rx) = std::sync::mpsc::sync_channel::<RecordItem>(4096);
    let handle = thread::Builder::new()
        .name("crossym-bag".into())
        .spawn(move || {
            let (js, cond, cmd, status) = topics;
            let mut first_err: Option<BagError> = None;
            for item in rx {
                let r = match item {
                    RecordItem::JointState(m, t, q) => w.write(js, &m, t, q),
                    RecordItem::Condition(m, t, q) => w.write(cond, &m, t, q),
                    RecordItem::Array(m, t, q) => w.write(cmd, &m, t, q),
                    RecordItem::Trajectory(m, t, q) => w.write(cmd, &m, t, q),
                    RecordItem::Status(m, t) => w.write(status, &m, t, 0),
                };
                if let Err(e) = r {
                    first_err.get_or_insert(e);
                }
            }
            let n = w.message_count();
            w.finish()?;
            match first_err {
                Some(e) => Err(e),
                None => Ok(n),
            }
        })
        .map_err(|e| NodeRunError::Runtime {
            message: format!("bag thread: {e}"),
        })?;
    Ok((
        Recorder {
            tx,
            dropped: Arc::new(std::sync::atomic::AtomicU64::new(0)),
        },
        handle,
    ))
}

/// The command writer for the configured output mode.
enum CommandPublisher {
    Array(ros2_client::Publisher<msg::Float64MultiArray>),
    Trajectory(ros2_client::Publisher<msg::JointTrajectory>),
}

impl CommandPublisher {
    /// Publishes `cmd` (and hands a copy to the recorder with the tick time and inputs).
    fn publish(
        &self,
        cmd: &Command,
        names: &[String],
        dt: f64,
        rec: Option<(&Recorder, u64, u32)>,
    ) -> bool {
        match self {
            CommandPublisher::Array(p) => {
                let m = cmd.to_float64_multi_array();
                if let Some((r, t, q)) = rec {
                    r.send(RecordItem::Array(m.clone(), t, q));
                }
                p.publish(m).is_ok()
            }
            CommandPublisher::Trajectory(p) => {
                let mut m = cmd.to_joint_trajectory(names, dt);
                m.header.stamp = msg::Time::from_secs_f64(dds::wall_time_s());
                if let Some((r, t, q)) = rec {
                    r.send(RecordItem::Trajectory(m.clone(), t, q));
                }
                p.publish(m).is_ok()
            }
        }
    }
}

/// What the control thread shares with the I/O side: the stop flag, and the wall-clock
/// time (ns) of the last hand-over (for the hand-over → tick latency).
struct ControlLinks {
    stop: Arc<AtomicBool>,
    handed_ns: Arc<AtomicI64>,
}

/// Where the control thread sends each status: the `~/status` topic and the I/O side's log.
struct StatusOut {
    publisher: ros2_client::Publisher<msg::Status>,
    log: std::sync::mpsc::SyncSender<StatusSnapshot>,
}

fn control_loop(
    mut core: NodeCore,
    mut inputs: triple_buffer::Output<Inputs>,
    out: CommandPublisher,
    status: StatusOut,
    links: ControlLinks,
    names: Vec<String>,
    rec: Option<Recorder>,
) -> TickStats {
    let ControlLinks { stop, handed_ns } = links;
    let cfg = core.config().clone();
    let period = Duration::from_secs_f64(cfg.period_s);
    let stale_after = Duration::from_secs_f64(cfg.stale_timeout_s.max(cfg.period_s));
    let status_period = Duration::from_secs_f64(cfg.status_period_s);
    let mut cmd = core.command();
    let mut hist = Histogram::new();
    let (mut handoff, mut publish) = (Histogram::new(), Histogram::new());
    let mut stats = TickStats::default();
    let mut next = Instant::now() + period;
    let mut next_status = Instant::now();
    let mut last_seq = 0u64;
    loop {
        if stop.load(Ordering::Acquire) {
            break;
        }
        let now = Instant::now();
        let updated = inputs.update();
        if updated {
            core.load_inputs(inputs.peek_output_buffer());
        }
        let seq = inputs.peek_output_buffer().joint_state_seq;
        let due = match cfg.trigger {
            Trigger::Timer => now >= next,
            Trigger::JointStates => seq != last_seq || now >= next,
        };
        if !due {
            thread::park_timeout(next.saturating_duration_since(now));
            continue;
        }
        let t0 = Instant::now();
        let now_ns = dds::wall_time_ns();
        let fresh = seq != last_seq;
        if cfg.trigger == Trigger::JointStates && fresh {
            handoff.record(span_us(handed_ns.load(Ordering::Acquire), now_ns as i64));
        }
        last_seq = seq;
        let report = core.tick(now_ns as f64 * 1e-9, &mut cmd);
        let us = t0.elapsed().as_secs_f64() * 1e6;
        core.record_tick_time(us);
        hist.record(us);
        stats.ticks += 1;
        if report.publish {
            let r = rec
                .as_ref()
                .map(|r| (r, now_ns, inputs.peek_output_buffer().command_sequence()));
            let tp = Instant::now();
            if out.publish(&cmd, &names, cfg.period_s, r) {
                stats.commands += 1;
            } else {
                stats.publish_errors += 1;
            }
            publish.record(tp.elapsed().as_secs_f64() * 1e6);
        }
        next = match cfg.trigger {
            Trigger::Timer => {
                let n = next + period;
                if n <= t0 {
                    t0 + period
                } else {
                    n
                }
            }
            // A tick per joint state; without one for the stale timeout the ticks go on at
            // the period (they command the stale-input stop). A fallback at one period
            // would race the driver's next state and double the commands.
            Trigger::JointStates if fresh => t0 + stale_after,
            Trigger::JointStates => t0 + period,
        };
        if t0 >= next_status {
            next_status = t0 + status_period;
            let stamp_ns = dds::wall_time_ns();
            let snap = core.status();
            // To the I/O side's log (never blocks: a full channel drops the snapshot).
            let _ = status.log.try_send(snap);
            let m = snap.to_msg(msg::Time::from_secs_f64(stamp_ns as f64 * 1e-9), &names);
            if let Some(r) = &rec {
                r.send(RecordItem::Status(m.clone(), stamp_ns));
            }
            if status.publisher.publish(m).is_err() {
                stats.publish_errors += 1;
            }
        }
    }
    // Final zero / hold command: ForwardCommandController would repeat the last one forever.
    let now_ns = dds::wall_time_ns();
    let r = rec.as_ref().map(|r| {
        let q = inputs.peek_output_buffer().command_sequence();
        (r, now_ns, q | super::core::SHUTDOWN_SEQUENCE_BIT)
    });
    if core.shutdown_command(&mut cmd) && out.publish(&cmd, &names, cfg.period_s, r) {
        stats.commands += 1;
    }
    let stamp = msg::Time::from_secs_f64(dds::wall_time_s());
    let _ = status
        .publisher
        .publish(core.status().to_msg(stamp, &names));
    // Let reliable writers deliver (and repair) the last samples before they are dropped.
    thread::sleep(Duration::from_millis(300));
    stats.median_us = hist.quantile(0.5);
    stats.p99_us = hist.quantile(0.99);
    stats.max_us = hist.max_us;
    stats.handoff = handoff.stats();
    stats.publish = publish.stats();
    stats
}
