//! `crossym` binary: parses arguments, runs a subcommand, maps errors to exit codes.
//!
//! Exit codes: 0 success, 1 a check failed (e.g. an impossible composition),
//! 2 usage or input error (bad config, URDF, data).

use std::process::ExitCode;

use clap::Parser;

mod cli;

fn main() -> ExitCode {
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or("warn,rustdds=error"),
    )
    .init();
    let args = cli::Cli::parse();
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
