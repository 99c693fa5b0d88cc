//! The ROS 2 node process: [`NodeCore`] over DDS (ros2-client).
//!
//! Threads:
//! - **Control** (`control.rs`, the DDS participant's event-loop thread, through RustDDS's
//!   event-loop hook): takes what the loop delivered on the subscriptions (`/joint_states`
//!   best effort, `~/symmetry_condition` reliable), validates each message into the
//!   [`NodeCore`], and every `period_s` (or on every accepted joint state with
//!   `trigger = "joint_states"`) runs [`NodeCore::tick`] —
//!   kinematics, policy `π(q, s)`, safety QP — which allocates, locks and logs nothing;
//!   then it publishes the command, and `~/status` every `status_period_s`. The path of one
//!   joint state to one command reads in that one file.
//! - **I/O** (`io.rs`, tokio, one worker): the ros2-client spinner (graph, parameter
//!   services), the SIGINT/SIGTERM handler and the node's log ([`NodeLog`]: console and
//!   `/rosout`): a startup summary, then what the control thread reports (rejections,
//!   condition changes, status transitions).
//! - **Bag** (`record.rs`, with `--record`): writes what the control thread hands it.
//! - On SIGINT/SIGTERM the control thread sends one final zero-velocity / hold command and
//!   a `SHUTDOWN` status, lets reliable delivery drain, and the process exits 0; the
//!   shutdown line reports the tick and the hops of the joint state → command path
//!   (`stats.rs`).

mod control;
mod endpoints;
mod error;
mod io;
pub mod lifecycle;
mod params;
mod record;
mod services;
mod stats;

use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use self::control::{ControlHook, ControlThread, Links};
use self::endpoints::Endpoints;
pub use self::error::NodeRunError;
use self::io::IoSide;
use self::params::Operator;
pub use self::params::{apply_start_value, check_start_parameter, StartParamRefusal};
pub use self::record::LIFECYCLE_TOPIC;
use self::record::{start_recorder, Recorder};
use self::services::Services;
pub use self::stats::{HopStats, TickStats};
use super::dds::{self, DdsError, DdsSettings};
use super::event_loop::LoopThread;
use super::log::{NodeLog, StatusWatch};
use super::realtime::{apply_realtime, RealtimeHold};
use crossym_control::node::{InputGate, NodeConfig, NodeCore, OutputMode};
use crossym_control::Severity;
use crossym_io::bag::BagError;

/// Runs the node until SIGINT/SIGTERM (or `stop` is set); returns the tick statistics.
///
/// Setup (recorder, DDS node and endpoints, I/O runtime, log) allocates; then the control
/// thread (`ControlThread::run`) and the I/O loop (`IoSide::serve`) run until a signal,
/// and `finish` joins them and writes the shutdown summary.
pub fn run(
    mut core: NodeCore,
    settings: DdsSettings,
    stop: Option<Arc<AtomicBool>>,
    record: Option<&Path>,
) -> Result<TickStats, NodeRunError> {
    let cfg = core.config().clone();
    lifecycle::apply_autostart(&mut core);
    // Checked against SUPPORTED_ROS_DISTROS when the config was read.
    let settings = settings.with_config_distro(cfg.ros_distro.as_deref())?;
    let recorder = record.map(|dir| start_recorder(dir, &cfg)).transpose()?;
    // The control thread is the participant's event-loop thread: the hook waits for its
    // state until the node is set up.
    let shared = Arc::new(LoopThread::default());
    let (hook, setup_tx, done_rx) = ControlHook::new(shared.clone());
    let ctx = settings.context_with_hook(Some(Box::new(hook)))?;
    // Operator requests: parameter sets and service calls → the I/O thread (logs them) →
    // the control thread (applies them between ticks).
    let (ops_tx, ops_rx) = std::sync::mpsc::sync_channel::<Operator>(64);
    let (to_control, from_io) = std::sync::mpsc::sync_channel(64);
    let GraphNode {
        node,
        ends,
        services,
        lifecycle_services,
        logger,
        spinner,
    } = GraphNode::create(&ctx, &cfg, &core, ops_tx)?;
    let command_pub = ends.command.clone();
    let command_subscribers = Arc::new(AtomicU32::new(u32::MAX));
    let runtime = io_runtime()?;

    let stop = stop.unwrap_or_else(|| Arc::new(AtomicBool::new(false)));
    let gate = core.input_gate();
    let names = core.joint_names().to_vec();
    let mut log = open_log(&core, &gate, &settings, record, logger)?;
    let (to_io, from_control) = std::sync::mpsc::sync_channel(256);
    let links = Links {
        to_io,
        names: names.clone(),
        rec: recorder.as_ref().map(|r| r.0.clone()),
        stop: stop.clone(),
        from_io,
        command_subscribers: command_subscribers.clone(),
    };
    let control_thread = start_control(core, ends, links, &setup_tx, &shared)?;
    // Held until the node stops (the kernel drops the CPU latency request on close).
    let RealtimeHold {
        cpu_latency: _cpu_latency,
        idle_poll,
    } = hold_realtime(&cfg, control_thread, &mut log);

    let mut io = IoSide {
        gate,
        watch: StatusWatch::with_names(names.clone()),
        names,
        from_control,
        log,
        ops: ops_rx,
        to_control,
        services,
        paused: false,
        lifecycle: initial_lifecycle(&cfg),
        lifecycle_services,
        command_subscribers,
    };
    let matched = || command_pub.subscription_count(&node);
    runtime.block_on(io.serve(spinner, &stop, &matched));
    stop.store(true, Ordering::Release);
    shared.wake();
    let stats = finish(&done_rx, recorder, io);
    drop(idle_poll);
    drop(node);
    runtime.shutdown_timeout(Duration::from_millis(200));
    stats
}

/// The node on the DDS graph with its endpoints and services (parameter, operator and
/// lifecycle), before the control thread takes the endpoints, its `/rosout` handle and
/// its spinner.
struct GraphNode {
    node: ros2_client::Node,
    ends: Endpoints,
    services: Services,
    lifecycle_services: lifecycle::LifecycleServices,
    logger: ros2_client::NodeLoggingHandle,
    spinner: ros2_client::Spinner,
}

impl GraphNode {
    /// Creates the node in `ctx` (its parameter requests sent on `ops_tx`), then its
    /// endpoints and services (parameter requests are served from then on), its `/rosout`
    /// handle and its spinner.
    fn create(
        ctx: &ros2_client::Context,
        cfg: &NodeConfig,
        core: &NodeCore,
        ops_tx: std::sync::mpsc::SyncSender<Operator>,
    ) -> Result<Self, NodeRunError> {
        let started = Arc::new(AtomicBool::new(false));
        let mut node = ctx
            .new_node(
                dds::node_name(&cfg.namespace, &cfg.name)?,
                params::node_options(core, ops_tx, started.clone()),
            )
            .map_err(|e| DdsError::Create {
                what: format!("node {}/{}", cfg.namespace, cfg.name),
                message: format!("{e:?}"),
            })?;
        let ends = Endpoints::create(&mut node, cfg)?;
        let services = Services::create(&mut node)?;
        let lifecycle_services = lifecycle::LifecycleServices::create(&mut node)?;
        started.store(true, Ordering::Release);
        let logger = node.logging_handle();
        let spinner = node.spinner().map_err(|e| DdsError::Create {
            what: "spinner".into(),
            message: format!("{e:?}"),
        })?;
        Ok(Self {
            node,
            ends,
            services,
            lifecycle_services,
            logger,
            spinner,
        })
    }
}

/// The lifecycle state the node starts in: active with `[node] autostart`, else inactive.
fn initial_lifecycle(cfg: &NodeConfig) -> lifecycle::Lifecycle {
    lifecycle::Lifecycle::new(if cfg.autostart {
        lifecycle::Primary::Active
    } else {
        lifecycle::Primary::Inactive
    })
}

/// The I/O thread's tokio runtime (one worker).
fn io_runtime() -> Result<tokio::runtime::Runtime, NodeRunError> {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .thread_name("crossym-io")
        .build()
        .map_err(|e| NodeRunError::Runtime {
            message: e.to_string(),
        })
}

/// The node's log (console and `/rosout` through `logger`), opened with the startup
/// summary and the SROS2 line: secured as which enclave, off, or the permissive
/// fallback's warning.
fn open_log(
    core: &NodeCore,
    gate: &InputGate,
    settings: &DdsSettings,
    record: Option<&Path>,
    logger: ros2_client::NodeLoggingHandle,
) -> Result<NodeLog, NodeRunError> {
    let cfg = core.config();
    let mut log = NodeLog::new(
        &cfg.name,
        Some(logger),
        cfg.log_level,
        Duration::from_secs(1),
    );
    for line in startup_summary(core, gate, settings, record) {
        log.log(Severity::Info, &line);
    }
    let security = settings.security_mode()?;
    let severity = match security.warning() {
        Some(_) => Severity::Warn,
        None => Severity::Info,
    };
    log.log(severity, &security.describe());
    let ephemeral = dds::ephemeral_ports();
    if let Some(w) = ephemeral.and_then(|e| dds::ephemeral_overlap(settings.domain_id, &e)) {
        log.log(Severity::Warn, &w);
    }
    Ok(log)
}

/// Hands the control thread its state through the event-loop hook (`setup_tx`) and waits
/// until the participant's event loop runs it; returns that thread.
fn start_control(
    core: NodeCore,
    ends: Endpoints,
    links: Links,
    setup_tx: &std::sync::mpsc::SyncSender<ControlThread>,
    shared: &LoopThread,
) -> Result<libc::pthread_t, NodeRunError> {
    let control = ControlThread::new(core, ends, links).map_err(|e| NodeRunError::Runtime {
        message: format!("control thread: {e}"),
    })?;
    if setup_tx.send(control).is_err() {
        return Err(NodeRunError::Runtime {
            message: "the DDS event loop stopped before the node started".into(),
        });
    }
    let control_thread =
        shared
            .wait(Duration::from_secs(5))
            .ok_or_else(|| NodeRunError::Runtime {
                message: "the DDS event loop did not start within 5 s".into(),
            })?;
    shared.wake();
    Ok(control_thread)
}

/// Applies `[node] realtime` to the control thread (each outcome logged, a refusal as a
/// warning); what it returns is held until the node stops.
fn hold_realtime(
    cfg: &NodeConfig,
    control_thread: libc::pthread_t,
    log: &mut NodeLog,
) -> RealtimeHold {
    match &cfg.realtime {
        Some(rt) => apply_realtime(rt, control_thread, |o| {
            let severity = if o.is_refused() {
                Severity::Warn
            } else {
                Severity::Info
            };
            log.log(severity, &o.to_string());
        }),
        None => RealtimeHold::default(),
    }
}

/// Waits for the control thread's statistics (sent after the final command was
/// delivered), joins the recorder, logs the last events and the shutdown summary with the
/// hops of the joint state → command path.
fn finish(
    done: &std::sync::mpsc::Receiver<TickStats>,
    recorder: Option<(Recorder, thread::JoinHandle<Result<u64, BagError>>)>,
    mut io: IoSide,
) -> Result<TickStats, NodeRunError> {
    let mut stats =
        done.recv_timeout(Duration::from_secs(10))
            .map_err(|e| NodeRunError::Runtime {
                message: format!("control thread: no final statistics ({e})"),
            })?;
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
    io.drain();
    io.log.flush_suppressed();
    io.log.log(
        Severity::Info,
        &format!(
            "stopped: {} ticks, {} commands, {} publish errors; tick median {:.1} µs, p99 {:.1} µs, max {:.1} µs",
            stats.ticks, stats.commands, stats.publish_errors, stats.median_us, stats.p99_us, stats.max_us
        ),
    );
    if stats.dds_in.count + stats.to_control.count > 0 {
        io.log.log(
            Severity::Info,
            &format!(
                "joint state → command hops: DDS in (publisher → this node) {}; DDS receive → control thread {}; tick median {:.0} µs, p99 {:.0} µs, max {:.0} µs; publish call {}",
                stats.dds_in, stats.to_control, stats.median_us, stats.p99_us, stats.max_us, stats.publish
            ),
        );
    }
    io.log.log(
        Severity::Info,
        &format!(
            "tick start after its time: {}; {} tick(s) more than half a period late, {} never ran",
            stats.late, stats.late_ticks, stats.missed_ticks
        ),
    );
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
    let mut lines = vec![
        robot_line(core),
        format!(
            "policy {}; conditions accepted: {}",
            cfg.policy
                .as_ref()
                .map_or("(none)".into(), |p| p.display().to_string()),
            conditions_accepted(core, gate)
        ),
        topics_line(cfg, settings),
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
    lines.extend(task_pose_lines(cfg));
    lines.push(singularity_line(cfg));
    lines.push(services_line(cfg));
    lines.push(lifecycle_line(cfg));
    if let Some(dir) = record {
        lines.push(format!("recording to {}", dir.display()));
    }
    lines
}

/// A topic name of the node's configuration, expanded (`~/…` in the node's namespace).
fn node_topic(cfg: &NodeConfig, t: &str) -> String {
    dds::expand_topic(t, &cfg.namespace, &cfg.name)
}

/// The robot and its kinematic chains.
fn robot_line(core: &NodeCore) -> String {
    let kin = core.kinematics();
    let chains: Vec<String> = kin
        .chains()
        .iter()
        .map(|c| format!("{} ({} joints, {} → {})", c.name, c.dof(), c.base, c.tip))
        .collect();
    format!(
        "robot `{}`: {} controlled joints in {}",
        kin.robot,
        kin.dof(),
        chains.join(", ")
    )
}

/// Which symmetry conditions the gate accepts.
fn conditions_accepted(core: &NodeCore, gate: &InputGate) -> String {
    match (gate.domain(), gate.checks_feasibility()) {
        (_, true) => "any whose lifted flows are feasible from the current joint state \
                      (canonicalised policy)"
            .to_string(),
        (Some(d), false) => format!("the trained box, {}", d.describe()),
        (None, false) if core.policy().task_head().is_some() => {
            "any valid (task-space head of the whole group: equivariant in task space \
             wherever the arms reach the drawing)"
                .to_string()
        }
        (None, false) => {
            "any valid (accept_untrained_conditions, or no training record)".to_string()
        }
    }
}

/// The topics in and out with their QoS, the DDS domain and the ROS 2 distribution.
fn topics_line(cfg: &NodeConfig, settings: &DdsSettings) -> String {
    let topic = |t: &str| node_topic(cfg, t);
    format!(
        "topics: in {} (JointState, best effort, keep last 5), {} (SymmetryCondition, reliable, keep last 10); out {} ({}, reliable, keep last 10), {} (Status every {} s, reliable, keep last 10); DDS domain {}, ROS 2 {} graph formats",
        topic(&cfg.topics.joint_states),
        topic(&cfg.topics.symmetry_condition),
        topic(&cfg.topics.command),
        match cfg.output {
            OutputMode::Trajectory => "JointTrajectory",
            _ => "Float64MultiArray",
        },
        topic(&cfg.topics.status),
        cfg.status_period_s,
        settings.domain_id,
        settings.distro
    )
}

/// Conditions from an observed object's pose (with `[node.task_pose]`), and its frames
/// through /tf.
fn task_pose_lines(cfg: &NodeConfig) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(p) = &cfg.task_pose {
        lines.push(format!(
            "conditions also from the object pose on {} (PoseStamped in `{}`, best effort; θ about {:?}, σ by the side of the mirror plane of {:?} on the object, λ = {}; the last source wins)",
            node_topic(cfg, &p.topic),
            p.frame,
            p.axis,
            p.side_point,
            p.scale
        ));
        if p.tf {
            lines.push(format!(
                "poses in other frames carried into `{}` through /tf and /tf_static (moving transforms within {} s of the pose's stamp)",
                p.frame, p.tf_tolerance_s
            ));
        }
    }
    lines
}

/// The singularity band, on or off.
fn singularity_line(cfg: &NodeConfig) -> String {
    let band = &cfg.singularity;
    if band.enabled {
        format!(
            "singularity band: commands toward a singular posture slow down from condition number {} and stop at {} ([node.singularity])",
            band.slowdown, band.stop
        )
    } else {
        "singularity band off ([node.singularity] enabled = false)".to_string()
    }
}

/// The operator's services and the runtime-settable parameters.
fn services_line(cfg: &NodeConfig) -> String {
    let services: Vec<String> = services::NAMES
        .iter()
        .map(|(n, t)| format!("{} ({t})", node_topic(cfg, &format!("~/{n}"))))
        .collect();
    let settable: Vec<String> = params::SETTABLE
        .iter()
        .map(|(n, t)| format!("{n} ({t})"))
        .collect();
    format!(
        "services: {}; settable parameters (ros2 param set, crossym param set): {}; velocity_scale {}",
        services.join(", "),
        settable.join(", "),
        cfg.velocity_scale
    )
}

/// The lifecycle state at start, its services and transition events.
fn lifecycle_line(cfg: &NodeConfig) -> String {
    let lifecycle: Vec<String> = lifecycle::NAMES
        .iter()
        .map(|(n, _)| node_topic(cfg, &format!("~/{n}")))
        .collect();
    format!(
        "lifecycle: {} ({}); services {}, events on {}",
        if cfg.autostart { "active" } else { "inactive" },
        if cfg.autostart {
            "[node] autostart = true: the policy runs on the first joint state"
        } else {
            "[node] autostart = false: no command until `activate` (ros2 lifecycle set <node> activate)"
        },
        lifecycle.join(", "),
        node_topic(cfg, "~/transition_event")
    )
}
