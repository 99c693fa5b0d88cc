//! `crossym record`: topics over DDS into a new rosbag2 MCAP bag.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::ros::dds::DdsSettings;
use crossym::setup::{node_config, NodeOverrides};

/// Options of `crossym record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// Output bag directory (must not exist).
    #[arg(long, short)]
    pub out: PathBuf,
    /// Record the four topics of the node configured here.
    #[arg(long, short)]
    pub config: Option<PathBuf>,
    /// Extra topic `NAME:pkg/msg/Type`, repeatable.
    #[arg(long = "topic")]
    pub topics: Vec<String>,
    /// Stop after this many seconds.
    #[arg(long)]
    pub duration_s: Option<f64>,
}

/// `crossym record`.
pub fn run(a: &RecordArgs) -> anyhow::Result<ExitCode> {
    record(&a.out, &a.topics, a.config.as_deref(), a.duration_s)
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
    use crossym::msg::{self, RosMessage};
    use crossym::ros::dds;
    use std::sync::atomic::{AtomicBool, Ordering};
    let list = topic_list(topics, config)?;
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

/// The topics to record, `(name, type)`: the four of the node configured in `config`, then
/// each `--topic NAME:pkg/msg/Type`.
fn topic_list(topics: &[String], config: Option<&Path>) -> anyhow::Result<Vec<(String, String)>> {
    use crossym::control::OutputMode;
    use crossym::msg::{self, RosMessage};
    use crossym::ros::dds;
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
    Ok(list)
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
