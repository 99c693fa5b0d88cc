//! `crossym node`, `crossym mock-hw`: config + CLI overrides → the DDS processes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use crossym::config::Config;
use crossym::control::{NodeConfig, NodeCore, OutputMode, Trigger};
use crossym::ros::dds::DdsSettings;
use crossym::ros::log::Severity;
use crossym::sim::{MockHardware, MockHwConfig};

/// Overrides of `[node]` from the command line.
#[derive(Debug, Args, Clone, Default)]
pub struct NodeOverrides {
    /// Policy file (`.safetensors`, `.json` sidecar beside it); overrides `[node] policy`.
    #[arg(long)]
    pub policy: Option<PathBuf>,
    /// Node name.
    #[arg(long)]
    pub name: Option<String>,
    /// Node namespace (starts with `/`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Command output: velocity, position or trajectory.
    #[arg(long, value_parser = parse_output)]
    pub output: Option<OutputMode>,
    /// Tick trigger: timer or joint_states.
    #[arg(long, value_parser = parse_trigger)]
    pub trigger: Option<Trigger>,
    /// Control period (s).
    #[arg(long)]
    pub period_s: Option<f64>,
    /// Command topic.
    #[arg(long)]
    pub command_topic: Option<String>,
    /// Stale timeout for joint states (s).
    #[arg(long)]
    pub stale_timeout_s: Option<f64>,
    /// Console and /rosout log level of the node: debug, info, warn, error (default: a
    /// `crossym=LEVEL` or bare level in RUST_LOG, else `[node] log_level`, else info).
    #[arg(long, value_parser = parse_severity)]
    pub log_level: Option<Severity>,
}

fn parse_severity(s: &str) -> Result<Severity, String> {
    Severity::parse(s).ok_or_else(|| format!("`{s}`: expected debug, info, warn or error"))
}

fn parse_output(s: &str) -> Result<OutputMode, String> {
    match s {
        "velocity" => Ok(OutputMode::Velocity),
        "position" => Ok(OutputMode::Position),
        "trajectory" => Ok(OutputMode::Trajectory),
        _ => Err(format!("`{s}`: expected velocity, position or trajectory")),
    }
}

fn parse_trigger(s: &str) -> Result<Trigger, String> {
    match s {
        "timer" => Ok(Trigger::Timer),
        "joint_states" => Ok(Trigger::JointStates),
        _ => Err(format!("`{s}`: expected timer or joint_states")),
    }
}

/// `[node]` of `cfg` with the overrides applied and validated; the policy path resolved.
pub fn node_config(cfg: &Config, o: &NodeOverrides) -> anyhow::Result<NodeConfig> {
    let mut n = cfg.node_config();
    if let Some(p) = &o.policy {
        n.policy = Some(p.clone());
    }
    if let Some(v) = &o.name {
        n.name = v.clone();
    }
    if let Some(v) = &o.namespace {
        n.namespace = v.clone();
    }
    if let Some(v) = o.output {
        n.output = v;
    }
    if let Some(v) = o.trigger {
        n.trigger = v;
    }
    if let Some(v) = o.period_s {
        n.period_s = v;
    }
    if let Some(v) = &o.command_topic {
        n.topics.command = v.clone();
    }
    if let Some(v) = o.stale_timeout_s {
        n.stale_timeout_s = v;
    }
    if let Some(l) = o.log_level.or_else(|| {
        std::env::var("RUST_LOG")
            .ok()
            .and_then(|v| Severity::from_rust_log(&v))
    }) {
        n.log_level = l;
    }
    n.validate()?;
    Ok(n)
}

/// Builds the node's logic from a config file and overrides.
pub fn build_core(path: &Path, o: &NodeOverrides) -> anyhow::Result<(Config, NodeCore)> {
    let cfg = Config::from_file(path)?;
    let n = node_config(&cfg, o)?;
    let core = crossym::setup::node_core(&cfg, n)?;
    Ok((cfg, core))
}

/// `crossym node`.
pub fn node(path: &Path, o: &NodeOverrides, record: Option<&Path>) -> anyhow::Result<ExitCode> {
    let (_, core) = build_core(path, o)?;
    let settings = DdsSettings::from_env()?;
    let stats = crossym::ros::node::run(core, settings, None, record)?;
    if let Some(dir) = record {
        eprintln!(
            "crossym node: recorded {} messages to {} ({} dropped)",
            stats.bag_messages,
            dir.display(),
            stats.bag_dropped
        );
    }
    // The tick summary is the node's last log line.
    Ok(ExitCode::SUCCESS)
}

/// `crossym mock-hw`.
pub fn mock_hw(
    path: &Path,
    summary: Option<&Path>,
    initial_q: Option<Vec<f64>>,
    command: Option<&str>,
    plant: Option<crossym::sim::physics::Plant>,
) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(path)?;
    let node = node_config(&cfg, &NodeOverrides::default())?;
    let hw_cfg: MockHwConfig = cfg.mock_hw.clone().unwrap_or_default();
    hw_cfg
        .validate()
        .map_err(anyhow::Error::msg)
        .context("[mock_hw]")?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let q0 = initial_q
        .or_else(|| cfg.start_q())
        .unwrap_or_else(|| vec![0.0; kin.dof()]);
    if plant.unwrap_or(hw_cfg.plant) == crossym::sim::physics::Plant::Mujoco {
        let limits: Vec<(f64, f64)> = kin.limits().iter().map(|l| (l.lower, l.upper)).collect();
        return physics_robot(&cfg, &hw_cfg, kin.joint_names(), &q0, &limits, summary);
    }
    let mode = match command {
        Some(c) => parse_output(c).map_err(anyhow::Error::msg)?,
        None => hw_cfg.command.unwrap_or(node.output),
    };
    let topic = hw_cfg
        .command_topic
        .clone()
        .unwrap_or_else(|| node.topics.command.clone());
    let hw = MockHardware::new(
        &robot.model,
        kin.joint_names(),
        kin.limits(),
        &cfg.robot.held,
        &q0,
        mode,
        hw_cfg.clone(),
    )
    .map_err(anyhow::Error::msg)
    .context("[mock_hw]")?;
    let settings = DdsSettings::from_env()?;
    let s = crossym::sim::process::run(hw, &hw_cfg, &topic, mode, settings, summary)?;
    Ok(if s.violation_count == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `crossym mock-hw --plant mujoco`: replaces this process by the physics robot
/// (`physics/rby1_mujoco.py`, see [`crossym::sim::physics`]), so that signals reach it.
fn physics_robot(
    cfg: &Config,
    hw: &MockHwConfig,
    joints: &[String],
    q0: &[f64],
    position_limits: &[(f64, f64)],
    summary: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    use std::os::unix::process::CommandExt;
    anyhow::ensure!(
        hw.fault_near_limit.is_none(),
        "[mock_hw] fault_near_limit: the physics robot starts its faults by time only"
    );
    let base = cfg.resolve(Path::new("."));
    let urdf = cfg.resolve(&cfg.robot.urdf);
    let args = hw
        .mujoco
        .args(&crossym::sim::physics::PhysicsRun {
            base_dir: &base,
            urdf: &urdf,
            joints,
            initial_q: q0,
            position_limits,
            rate_hz: hw.rate_hz.min(100.0),
            summary,
            fault: hw.fault,
            fault_joint: hw.fault_joint.as_deref(),
            fault_after_s: hw.fault_after_s,
            fault_duration_s: hw.fault_duration_s,
        })
        .map_err(anyhow::Error::msg)
        .context("[mock_hw.mujoco]")?;
    let program = hw.mujoco.program(&base);
    anyhow::ensure!(
        program.is_file(),
        "the physics robot {} is missing (set [mock_hw.mujoco] program or CROSSYM_PHYSICS_DIR)",
        program.display()
    );
    let err = std::process::Command::new("python3")
        .arg(&program)
        .args(&args)
        .exec();
    Err(anyhow::Error::new(err).context(format!(
        "running python3 {} (install its packages with `bash physics/install.sh`)",
        program.display()
    )))
}

/// `crossym bag info`.
pub fn bag_info(path: &Path) -> anyhow::Result<ExitCode> {
    let bag = crossym::bag::Bag::open(path)?;
    print!("{}", bag.info());
    Ok(ExitCode::SUCCESS)
}

/// `crossym replay`: recorded inputs through the node's logic, commands compared.
pub fn replay(
    bag_path: &Path,
    config: &Path,
    o: &NodeOverrides,
    tolerance: f64,
) -> anyhow::Result<ExitCode> {
    use crossym::ros::replay::{replay, ReplayTopics};
    let bag = crossym::bag::Bag::open(bag_path)?;
    let (_, mut core) = build_core(config, o)?;
    let topics = ReplayTopics::for_node(core.config());
    let r = replay(&bag, &mut core, &topics)?;
    println!(
        "replayed {}: {} inputs, {} commands recomputed, {} without their input snapshot",
        bag_path.display(),
        r.inputs,
        r.commands,
        r.unmatched
    );
    println!("max |recorded - recomputed| per joint:");
    for (name, d) in core.joint_names().iter().zip(&r.max_abs_deviation) {
        println!("  {name:<24} {d:.3e}");
    }
    let ok = r.commands > 0 && r.unmatched == 0 && r.max() <= tolerance;
    println!(
        "replay: {} (max deviation {:.3e}, tolerance {tolerance:e})",
        if ok { "OK" } else { "FAILED" },
        r.max()
    );
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// `crossym replay BAG --live`: publishes the recorded joint states and conditions over DDS
/// at the recorded rate (like `ros2 bag play`), for a node or driver under test.
pub fn replay_live(
    bag_path: &Path,
    config: &Path,
    rate: f64,
    keep_stamps: bool,
    delay_s: f64,
) -> anyhow::Result<ExitCode> {
    use crossym::msg;
    use crossym::ros::dds;
    use crossym::ros::replay::ReplayTopics;
    anyhow::ensure!(rate.is_finite() && rate > 0.0, "--rate must be positive");
    anyhow::ensure!(
        delay_s.is_finite() && delay_s >= 0.0,
        "--delay-s must be >= 0"
    );
    let bag = crossym::bag::Bag::open(bag_path)?;
    let cfg = Config::from_file(config)?;
    let n = node_config(&cfg, &NodeOverrides::default())?;
    let topics = ReplayTopics::for_node(&n);
    let js = bag
        .topic(&topics.joint_states)
        .with_context(|| format!("{}: no {} topic", bag_path.display(), topics.joint_states))?;
    let cond = bag.topic(&topics.condition);
    let settings = DdsSettings::from_env()?;
    let ctx = settings.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_player_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let js_pub =
        dds::publisher::<msg::JointState>(&mut node, &topics.joint_states, dds::qos_reliable(10))?;
    let cond_pub = dds::publisher::<msg::SymmetryCondition>(
        &mut node,
        &topics.condition,
        dds::qos_reliable(10),
    )?;
    // Give discovery time to match the subscribers before the first sample.
    std::thread::sleep(std::time::Duration::from_secs_f64(delay_s));
    let first = bag
        .messages
        .iter()
        .find(|m| m.topic == js || Some(m.topic) == cond)
        .map(|m| m.log_ns)
        .context("the bag has no joint states or conditions")?;
    let start = std::time::Instant::now();
    let (mut n_js, mut n_cond) = (0usize, 0usize);
    for (i, m) in bag.messages.iter().enumerate() {
        if m.topic != js && Some(m.topic) != cond {
            continue;
        }
        let due = std::time::Duration::from_secs_f64((m.log_ns - first) as f64 * 1e-9 / rate);
        if let Some(wait) = due.checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        if m.topic == js {
            let mut s: msg::JointState = bag.decode(i)?;
            if !keep_stamps {
                s.header.stamp = msg::Time::from_secs_f64(dds::wall_time_s());
            }
            js_pub
                .publish(s)
                .map_err(|e| anyhow::anyhow!("publish joint state: {e:?}"))?;
            n_js += 1;
        } else {
            let s: msg::SymmetryCondition = bag.decode(i)?;
            cond_pub
                .publish(s)
                .map_err(|e| anyhow::anyhow!("publish condition: {e:?}"))?;
            n_cond += 1;
        }
    }
    // Let reliable writers deliver the tail.
    std::thread::sleep(std::time::Duration::from_millis(300));
    println!(
        "played {}: {n_js} joint states on {}, {n_cond} conditions on {} in {:.2} s (rate {rate}×)",
        bag_path.display(),
        topics.joint_states,
        topics.condition,
        start.elapsed().as_secs_f64()
    );
    Ok(ExitCode::SUCCESS)
}

/// `crossym record`: subscribes over DDS and writes a rosbag2 MCAP bag until SIGINT/SIGTERM
/// (or `duration_s`). Topics: `name:pkg/msg/Type` of the types crossym knows.
pub fn record(
    out: &Path,
    topics: &[String],
    config: Option<&Path>,
    duration_s: Option<f64>,
) -> anyhow::Result<ExitCode> {
    use crossym::bag::{BagWriter, Qos};
    use crossym::control::OutputMode;
    use crossym::msg::{self, RosMessage};
    use crossym::ros::dds;
    use std::sync::atomic::{AtomicBool, Ordering};
    let mut list: Vec<(String, String)> = Vec::new();
    if let Some(c) = config {
        let cfg = Config::from_file(c)?;
        let n = node_config(&cfg, &NodeOverrides::default())?;
        let name = |t: &str| dds::expand_topic(t, &n.namespace, &n.name);
        let cmd_type = match n.output {
            OutputMode::Trajectory => msg::JointTrajectory::ROS_TYPE,
            _ => msg::Float64MultiArray::ROS_TYPE,
        };
        list.push((
            name(&n.topics.joint_states),
            msg::JointState::ROS_TYPE.into(),
        ));
        list.push((
            name(&n.topics.symmetry_condition),
            msg::SymmetryCondition::ROS_TYPE.into(),
        ));
        list.push((name(&n.topics.command), cmd_type.into()));
        list.push((name(&n.topics.status), msg::Status::ROS_TYPE.into()));
    }
    for t in topics {
        let (name, ty) = t
            .rsplit_once(':')
            .with_context(|| format!("--topic `{t}`: expected /name:pkg/msg/Type"))?;
        list.push((name.to_string(), ty.to_string()));
    }
    anyhow::ensure!(
        !list.is_empty(),
        "nothing to record: give --config and/or --topic"
    );
    let settings = DdsSettings::from_env()?;
    let ctx = settings.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_recorder_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let mut w = BagWriter::create(out)?;
    enum Sub {
        Js(ros2_client::Subscription<msg::JointState>),
        Cond(ros2_client::Subscription<msg::SymmetryCondition>),
        Arr(ros2_client::Subscription<msg::Float64MultiArray>),
        Traj(ros2_client::Subscription<msg::JointTrajectory>),
        Status(ros2_client::Subscription<msg::Status>),
    }
    let mut subs = Vec::new();
    for (name, ty) in &list {
        // Best effort matches reliable and best-effort writers.
        let qos = dds::qos_sensor();
        let (sub, id) = match ty.as_str() {
            t if t == msg::JointState::ROS_TYPE => (
                Sub::Js(dds::subscription(&mut node, name, qos)?),
                w.add_topic::<msg::JointState>(name, Qos::best_effort(5))?,
            ),
            t if t == msg::SymmetryCondition::ROS_TYPE => (
                Sub::Cond(dds::subscription(&mut node, name, qos)?),
                w.add_topic::<msg::SymmetryCondition>(name, Qos::best_effort(5))?,
            ),
            t if t == msg::Float64MultiArray::ROS_TYPE => (
                Sub::Arr(dds::subscription(&mut node, name, qos)?),
                w.add_topic::<msg::Float64MultiArray>(name, Qos::best_effort(5))?,
            ),
            t if t == msg::JointTrajectory::ROS_TYPE => (
                Sub::Traj(dds::subscription(&mut node, name, qos)?),
                w.add_topic::<msg::JointTrajectory>(name, Qos::best_effort(5))?,
            ),
            t if t == msg::Status::ROS_TYPE => (
                Sub::Status(dds::subscription(&mut node, name, qos)?),
                w.add_topic::<msg::Status>(name, Qos::best_effort(5))?,
            ),
            other => anyhow::bail!(
                "--topic {name}: type `{other}` is not one crossym can record (JointState, SymmetryCondition, Float64MultiArray, JointTrajectory, Status)"
            ),
        };
        subs.push((sub, id));
    }
    let stop = std::sync::Arc::new(AtomicBool::new(false));
    for sig in [signal_hook_lite::SIGINT, signal_hook_lite::SIGTERM] {
        signal_hook_lite::register(sig, stop.clone())?;
    }
    eprintln!(
        "crossym record: {} topics into {} (Ctrl-C to stop)",
        list.len(),
        out.display()
    );
    let start = std::time::Instant::now();
    while !stop.load(Ordering::Relaxed)
        && duration_s.is_none_or(|d| start.elapsed().as_secs_f64() < d)
    {
        let mut any = false;
        for (sub, id) in &subs {
            macro_rules! drain {
                ($s:expr) => {
                    while let Ok(Some((m, _))) = $s.take() {
                        w.write(*id, &m, dds::wall_time_ns(), 0)?;
                        any = true;
                    }
                };
            }
            match sub {
                Sub::Js(s) => drain!(s),
                Sub::Cond(s) => drain!(s),
                Sub::Arr(s) => drain!(s),
                Sub::Traj(s) => drain!(s),
                Sub::Status(s) => drain!(s),
            }
        }
        if !any {
            std::thread::sleep(std::time::Duration::from_millis(1));
        }
    }
    let n = w.message_count();
    w.finish()?;
    println!("recorded {n} messages to {}", out.display());
    Ok(ExitCode::SUCCESS)
}

/// Minimal SIGINT/SIGTERM → flag, via a tokio signal task on a helper thread.
mod signal_hook_lite {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    pub const SIGINT: i32 = 2;
    pub const SIGTERM: i32 = 15;

    /// Sets `flag` when signal `sig` arrives.
    pub fn register(sig: i32, flag: Arc<AtomicBool>) -> anyhow::Result<()> {
        let kind = tokio::signal::unix::SignalKind::from_raw(sig);
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        let mut s = rt.block_on(async { tokio::signal::unix::signal(kind) })?;
        std::thread::spawn(move || {
            rt.block_on(async move {
                s.recv().await;
                flag.store(true, Ordering::Relaxed);
            })
        });
        Ok(())
    }
}
