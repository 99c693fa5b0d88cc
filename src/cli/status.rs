//! `crossym status`: a live, one-line view of a running node's `~/status`, for machines
//! without the ROS tools (`ros2 topic echo`): `crossym::ros::tools::status` watches, this
//! file prints (one line rewritten in place on a terminal).

use std::io::{IsTerminal, Write};
use std::process::ExitCode;

use crossym::ros::tools::status::{
    status_line, StatusEvent, StatusWatch, StatusWatchError, StatusWatchSettings,
};

/// Options of `crossym status`.
#[derive(Debug, clap::Args)]
pub struct StatusArgs {
    #[command(flatten)]
    pub node: super::common::NodeTarget,
    /// Give up (exit 1) when no status arrives within this time (s), at start or later.
    #[arg(long, default_value_t = 5.0)]
    pub timeout_s: f64,
    /// Exit 0 after this many status messages (default: until Ctrl-C or the node's SHUTDOWN).
    #[arg(long)]
    pub count: Option<u64>,
}

/// `crossym status`. Exit 1 when no node answers within the timeout.
pub fn run(a: &StatusArgs) -> anyhow::Result<ExitCode> {
    let n = a.node.node_config()?;
    let settings = StatusWatchSettings {
        timeout_s: a.timeout_s,
        count: a.count,
    };
    let watch = StatusWatch::open(&n, settings, &super::common::dds_settings("status")?)?;
    let tty = std::io::stdout().is_terminal();
    eprintln!(
        "crossym status: watching {} (Ctrl-C to stop)",
        watch.topic()
    );
    let result = watch.run(|event| match event {
        StatusEvent::Status(m) => {
            let line = status_line(m);
            let mut out = std::io::stdout().lock();
            if tty {
                // Rewrite one line in place.
                let _ = write!(out, "\r\x1b[2K{line}");
            } else {
                let _ = writeln!(out, "{line}");
            }
            let _ = out.flush();
        }
        StatusEvent::Undecodable(e) => {
            eprintln!("crossym status: undecodable status sample: {e}");
        }
    });
    match result {
        Ok(_) => {
            if tty {
                println!();
            }
            Ok(ExitCode::SUCCESS)
        }
        Err(e @ StatusWatchError::Silent { seen, .. }) => {
            if tty && seen > 0 {
                println!();
            }
            eprintln!("crossym status: {e}");
            Ok(ExitCode::from(1))
        }
        Err(e) => Err(e.into()),
    }
}
