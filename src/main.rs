//! `crossym` binary: parses arguments, runs a subcommand, maps errors to exit codes.
//!
//! Exit codes: 0 success, 1 a check failed (e.g. an impossible composition),
//! 2 usage or input error (bad config, URDF, data).

use std::process::ExitCode;

use clap::Parser;

mod cli;

fn main() -> ExitCode {
    // Libraries log at warn (RustDDS at error) unless RUST_LOG names them: `RUST_LOG=info`
    // raises crossym's own lines, not 1500 lines of DDS internals. ros2-client's service
    // wrapper warns on every request from a client that sends no request identity in the
    // inline QoS (any plain DDS writer; rmw_fastrtps sends one) and answers it anyway.
    let mut filter = std::env::var("RUST_LOG").unwrap_or_else(|_| "warn".into());
    for (lib, level) in [
        ("rustdds", "error"),
        ("ros2_client", "warn"),
        ("ros2_client::service::wrappers", "error"),
    ] {
        if !filter.contains(lib) {
            filter.push_str(&format!(",{lib}={level}"));
        }
    }
    env_logger::Builder::new().parse_filters(&filter).init();
    let args = cli::Cli::parse();
    if args.ends_quietly_on_closed_pipe() {
        // `crossym ping | head -1`: end like any Unix tool when the reader goes away, not
        // with a panic in `println!` (Rust ignores SIGPIPE by default).
        // SAFETY: restoring a signal's default disposition before any thread starts.
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }
    match cli::run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}
