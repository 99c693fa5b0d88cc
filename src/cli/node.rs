//! `crossym node`: config + command-line overrides → the ROS 2 node over DDS.

use std::path::PathBuf;
use std::process::ExitCode;

use crossym::ros::dds::DdsSettings;
use crossym::setup::build_core;

use super::common::NodeOverrideArgs;

/// Options of `crossym node`.
#[derive(Debug, clap::Args)]
pub struct NodeArgs {
    /// Config file (TOML) with [robot] and [node].
    #[arg(long, short)]
    pub config: PathBuf,
    #[command(flatten)]
    pub overrides: NodeOverrideArgs,
    /// Record joint states, conditions, commands and status to this new rosbag2 (MCAP)
    /// directory.
    #[arg(long)]
    pub record: Option<PathBuf>,
}

/// `crossym node`.
pub fn run(a: &NodeArgs) -> anyhow::Result<ExitCode> {
    let record = a.record.as_deref();
    let (_, core) = build_core(&a.config, &a.overrides.overrides())?;
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
