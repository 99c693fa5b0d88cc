//! `crossym bag`: inspect a rosbag2 bag.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

/// Options of `crossym bag`.
#[derive(Debug, clap::Args)]
pub struct BagArgs {
    #[command(subcommand)]
    pub what: BagCommand,
}

/// What `crossym bag` does.
#[derive(Debug, Subcommand)]
pub enum BagCommand {
    /// Topics, types, counts and duration (like `ros2 bag info`).
    Info {
        /// Bag directory or .mcap file.
        bag: PathBuf,
    },
}

/// `crossym bag`.
pub fn run(a: &BagArgs) -> anyhow::Result<ExitCode> {
    match &a.what {
        BagCommand::Info { bag } => {
            let bag = crossym::bag::Bag::open(bag)?;
            print!("{}", bag.info());
            Ok(ExitCode::SUCCESS)
        }
    }
}
