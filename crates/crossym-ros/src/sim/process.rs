//! The mock hardware as a DDS process: subscribes the command topic and the reset topic,
//! steps [`MockHardware`] at `rate_hz` and publishes `sensor_msgs/JointState` with the full
//! joint list. Stops on SIGINT/SIGTERM and writes its summary (JSON) if asked.

use std::path::Path;
use std::time::Duration;

use ros2_client::NodeOptions;

use super::{MockHardware, MockHwConfig, MockHwSummary};
use crate::dds::{self, DdsError, DdsSettings};
use crate::node::NodeRunError;
use crossym_control::OutputMode;
use crossym_io::msg;

/// The command subscription: arrays (velocity, position) or trajectories.
enum Cmd {
    Array(ros2_client::Subscription<msg::Float64MultiArray>),
    Traj(ros2_client::Subscription<msg::JointTrajectory>),
}

impl Cmd {
    /// Hands every waiting command to `hw` in arrival order (a trajectory's last point).
    fn drain_into(&self, hw: &mut MockHardware) {
        match self {
            Cmd::Array(s) => loop {
                match s.take() {
                    Ok(Some((m, _))) => {
                        hw.command(&m.data);
                    }
                    Ok(None) => break,
                    Err(e) => {
                        eprintln!("mock_hw: undecodable command: {e:?}");
                        break;
                    }
                }
            },
            Cmd::Traj(s) => loop {
                match s.take() {
                    Ok(Some((m, _))) => {
                        let p = m.points.last().map(|p| p.positions.as_slice());
                        hw.command(p.unwrap_or(&[]));
                    }
                    Ok(None) => break,
                    Err(e) => {
                        eprintln!("mock_hw: undecodable command: {e:?}");
                        break;
                    }
                }
            },
        }
    }
}

/// The mock hardware's node on the DDS graph: joint states out, resets and commands in
/// (fields in reverse order of creation: dropped the endpoints first, then the node).
struct MockHwNode {
    cmd_sub: Cmd,
    reset_sub: ros2_client::Subscription<msg::Float64MultiArray>,
    js_pub: ros2_client::Publisher<msg::JointState>,
    _node: ros2_client::Node,
}

impl MockHwNode {
    /// Creates the node `cfg.name` in `ctx` with its endpoints (commands of `mode` on
    /// `command_topic`).
    fn create(
        ctx: &ros2_client::Context,
        cfg: &MockHwConfig,
        command_topic: &str,
        mode: OutputMode,
    ) -> Result<Self, NodeRunError> {
        let mut node = ctx
            .new_node(
                dds::node_name("/", &cfg.name)?,
                NodeOptions::new().enable_rosout(true),
            )
            .map_err(|e| DdsError::Create {
                what: format!("node {}", cfg.name),
                message: format!("{e:?}"),
            })?;
        let js_pub = dds::publisher::<msg::JointState>(
            &mut node,
            &cfg.joint_states_topic,
            dds::qos_reliable(10),
        )?;
        let reset_sub = dds::subscription::<msg::Float64MultiArray>(
            &mut node,
            &cfg.reset_topic,
            dds::qos_reliable(10),
        )?;
        let cmd_sub = match mode {
            OutputMode::Velocity | OutputMode::Position => Cmd::Array(dds::subscription(
                &mut node,
                command_topic,
                dds::qos_reliable(10),
            )?),
            OutputMode::Trajectory => Cmd::Traj(dds::subscription(
                &mut node,
                command_topic,
                dds::qos_reliable(10),
            )?),
        };
        Ok(Self {
            cmd_sub,
            reset_sub,
            js_pub,
            _node: node,
        })
    }

    /// One timer tick: the waiting commands and resets to `hw`, a step of `dt`, the joint
    /// state published (`names`, `positions`: buffers kept between ticks).
    fn step(
        &self,
        hw: &mut MockHardware,
        dt: f64,
        names: &mut Vec<String>,
        positions: &mut Vec<f64>,
    ) {
        self.cmd_sub.drain_into(hw);
        while let Ok(Some((m, _))) = self.reset_sub.take() {
            if !hw.reset(&m.data) {
                eprintln!("mock_hw: ignored reset with {} values", m.data.len());
            }
        }
        hw.step(dt);
        if hw.joint_state(names, positions) {
            let m = msg::JointState {
                header: msg::Header {
                    stamp: msg::Time::from_secs_f64(dds::wall_time_s()),
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: positions.clone(),
                velocity: Vec::new(),
                effort: Vec::new(),
            };
            if let Err(e) = self.js_pub.publish(m) {
                eprintln!("mock_hw: publish failed: {e:?}");
            }
        }
    }
}

/// Runs `hw` over DDS until SIGINT/SIGTERM; writes the summary to `summary_path` (JSON).
pub fn run(
    mut hw: MockHardware,
    cfg: &MockHwConfig,
    command_topic: &str,
    mode: OutputMode,
    settings: DdsSettings,
    summary_path: Option<&Path>,
) -> Result<MockHwSummary, NodeRunError> {
    let ctx = settings.context()?;
    if settings.security.enable {
        eprintln!("mock_hw: {}", settings.security_mode()?.describe());
    }
    let dds_node = MockHwNode::create(&ctx, cfg, command_topic, mode)?;
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| NodeRunError::Runtime {
            message: e.to_string(),
        })?;
    let dt = 1.0 / cfg.rate_hz;
    eprintln!(
        "mock_hw: {} joints ({} controlled, {:?} commands on {}), {} Hz, publishing {}",
        hw.names.len(),
        hw.summary().max_abs_velocity.len(),
        mode,
        dds::expand_topic(command_topic, "/", &cfg.name),
        cfg.rate_hz,
        cfg.joint_states_topic
    );
    // The first and last timer ticks: the periods between them the timer skipped.
    let (mut first_tick, mut last_tick) = (None, None);
    runtime.block_on(async {
        let signals = dds::shutdown_signal();
        tokio::pin!(signals);
        let mut timer = tokio::time::interval(Duration::from_secs_f64(dt));
        timer.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        let mut positions = Vec::new();
        let mut names = Vec::new();
        loop {
            tokio::select! {
                _ = &mut signals => break,
                at = timer.tick() => {
                    first_tick.get_or_insert(at);
                    last_tick = Some(at);
                    dds_node.step(&mut hw, dt, &mut names, &mut positions);
                }
            }
        }
        Ok::<(), NodeRunError>(())
    })?;
    let mut summary = hw.summary().clone();
    if let (Some(first), Some(last)) = (first_tick, last_tick) {
        let periods = ((last - first).as_secs_f64() / dt).round() as u64 + 1;
        summary.missed_steps = periods.saturating_sub(summary.steps);
    }
    report_stop(&hw, &summary, summary_path)?;
    Ok(summary)
}

/// The stop line, and the summary written to `summary_path` (JSON).
fn report_stop(
    hw: &MockHardware,
    summary: &MockHwSummary,
    summary_path: Option<&Path>,
) -> Result<(), NodeRunError> {
    eprintln!(
        "mock_hw: stopped after {:.2} s: {} commands, {} limit violations, {} faulty joint states, {} timer periods missed",
        hw.time_s(),
        summary.commands_received,
        summary.violation_count,
        summary.joint_states_faulted,
        summary.missed_steps
    );
    if let Some(p) = summary_path {
        let text = serde_json::to_string_pretty(summary).unwrap_or_default();
        std::fs::write(p, text).map_err(|e| NodeRunError::Runtime {
            message: format!("writing {}: {e}", p.display()),
        })?;
    }
    Ok(())
}
