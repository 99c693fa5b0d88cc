//! `crossym replay`: a recorded bag through the node's logic offline, commands compared;
//! or, `--live`, its inputs published over DDS at the recorded rate.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use crossym::config::Config;
use crossym::ros::replay::{self as offline, ReplayTopics};
use crossym::ros::tools::play::{play, PlaySettings};
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
        let settings = PlaySettings {
            rate: a.rate,
            keep_stamps: a.keep_stamps,
            delay_s: a.delay_s,
        };
        replay_live(&a.bag, &a.config, &settings)
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
    let bag = crossym::bag::Bag::open(bag_path)?;
    let (_, mut core) = build_core(config, o)?;
    let topics = ReplayTopics::for_node(core.config());
    let r = offline::replay(&bag, &mut core, &topics)?;
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
    settings: &PlaySettings,
) -> anyhow::Result<ExitCode> {
    let cfg = Config::from_file(config)?;
    let n = node_config(&cfg, &NodeOverrides::default())?;
    let topics = ReplayTopics::for_node(&n);
    let played = play(
        bag_path,
        &topics,
        settings,
        &super::common::dds_settings("replay")?,
    )?;
    println!(
        "played {}: {} joint states on {}, {} conditions on {} in {:.2} s (rate {}×)",
        bag_path.display(),
        played.joint_states,
        topics.joint_states,
        played.conditions,
        topics.condition,
        played.elapsed_s,
        settings.rate
    );
    Ok(ExitCode::SUCCESS)
}
