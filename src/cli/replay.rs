//! `crossym replay`: a recorded bag through the node's logic offline, commands compared;
//! or, `--live`, its inputs published over DDS at the recorded rate.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::ros::dds::DdsSettings;
use crossym::setup::{build_core, node_config, NodeOverrides};

use super::common::NodeOverrideArgs;

/// Options of `crossym replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// Bag directory or .mcap file.
    pub bag: PathBuf,
    /// Config file (TOML) the node ran with.
    #[arg(long, short)]
    pub config: PathBuf,
    #[command(flatten)]
    pub overrides: NodeOverrideArgs,
    /// Largest accepted |recorded − recomputed| (rad/s or rad).
    #[arg(long, default_value_t = 1e-9)]
    pub tolerance: f64,
    /// Instead: publish the recorded joint states and conditions over DDS at the
    /// recorded rate (like `ros2 bag play`), for a node or driver under test.
    #[arg(long)]
    pub live: bool,
    /// Playback rate factor (with --live).
    #[arg(long, default_value_t = 1.0)]
    pub rate: f64,
    /// Keep the recorded header stamps (with --live; by default they are set to the
    /// publish time, as a node checking stamps needs).
    #[arg(long)]
    pub keep_stamps: bool,
    /// Wait this long for discovery before the first message (s, with --live).
    #[arg(long, default_value_t = 1.0)]
    pub delay_s: f64,
}

/// `crossym replay`. Exits 1 when a command deviates beyond the tolerance.
pub fn run(a: &ReplayArgs) -> anyhow::Result<ExitCode> {
    if a.live {
        replay_live(&a.bag, &a.config, a.rate, a.keep_stamps, a.delay_s)
    } else {
        replay(&a.bag, &a.config, &a.overrides.overrides(), a.tolerance)
    }
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
