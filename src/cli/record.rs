//! `crossym record`: topics over DDS into a new rosbag2 MCAP bag
//! (`crossym::ros::tools::record`), until Ctrl-C or `--duration-s`.

use std::path::PathBuf;
use std::process::ExitCode;

use crossym::config::Config;
use crossym::ros::tools::record::{RecordSettings, RecordTopic, Recorder};
use crossym::ros::tools::stop::stop_on_signals;
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

/// `crossym record`: the four topics of the node configured in `--config`, then each
/// `--topic NAME:pkg/msg/Type`, until SIGINT/SIGTERM (or `--duration-s`).
pub fn run(a: &RecordArgs) -> anyhow::Result<ExitCode> {
    let mut topics = Vec::new();
    if let Some(c) = &a.config {
        let n = node_config(&Config::from_file(c)?, &NodeOverrides::default())?;
        topics.extend(RecordTopic::node_topics(&n));
    }
    for t in &a.topics {
        topics.push(RecordTopic::parse(t)?);
    }
    let settings = RecordSettings {
        out: a.out.clone(),
        topics,
        duration_s: a.duration_s,
    };
    let recorder = Recorder::open(settings, &super::common::dds_settings("record")?)?;
    let stop = stop_on_signals()?;
    eprintln!(
        "crossym record: {} topics into {} (Ctrl-C to stop)",
        recorder.settings().topics.len(),
        a.out.display()
    );
    let n = recorder.run(&stop)?;
    println!("recorded {n} messages to {}", a.out.display());
    Ok(ExitCode::SUCCESS)
}
