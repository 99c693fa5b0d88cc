//! `crossym lifecycle get|set`: a running node's lifecycle state through its
//! `lifecycle_msgs` services, for machines without the ROS tools (`ros2 lifecycle get|set`).
//! The RB-Y1 configs start the node inactive: `crossym lifecycle set activate` lets the
//! policy drive the robot.

use std::process::ExitCode;
use std::time::Duration;

use crossym::ros::dds;
use crossym::ros::lifecycle_client::LifecycleClient;

/// Options of `crossym lifecycle`. The verb and the transition are separate positional
/// arguments, so options may stand anywhere among them (`lifecycle set --config C activate`).
#[derive(Debug, clap::Args)]
pub struct LifecycleArgs {
    /// `get`, or `set TRANSITION`.
    #[arg(value_enum)]
    pub verb: LifecycleVerb,
    /// The transition to request (`set` only): configure, activate, deactivate, cleanup,
    /// shutdown.
    pub transition: Option<String>,
    #[command(flatten)]
    pub node: super::common::NodeTarget,
    /// Give up (exit 1) when the node does not answer within this time (s).
    #[arg(long, default_value_t = 5.0)]
    pub timeout_s: f64,
}

/// What `crossym lifecycle` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum LifecycleVerb {
    // Print the node's lifecycle state.
    Get,
    // Request TRANSITION.
    Set,
}

/// `crossym lifecycle`. Exit 1 when the node does not answer or refuses the transition.
pub fn run(a: &LifecycleArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.timeout_s.is_finite() && a.timeout_s > 0.0,
        "--timeout-s {} must be positive",
        a.timeout_s
    );
    // None: get; Some: set.
    let transition = match (a.verb, a.transition.as_deref()) {
        (LifecycleVerb::Get, None) => None,
        (LifecycleVerb::Set, Some(t)) => Some(t),
        _ => anyhow::bail!("usage: crossym lifecycle get | crossym lifecycle set TRANSITION"),
    };
    let n = a.node.node_config()?;
    let target = dds::node_name(&n.namespace, &n.name)?.fully_qualified_name();
    let settings =
        super::common::dds_settings("lifecycle")?.with_config_distro(n.ros_distro.as_deref())?;
    let ctx = settings.context()?;
    let client = LifecycleClient::new(&ctx, &target)?;
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let result = match transition {
        None => client.get_state(timeout),
        Some(t) => client.change_state(t, timeout),
    };
    match result {
        Ok(s) => {
            println!("{target}: {} [{}]", s.label, s.id);
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => {
            eprintln!("crossym lifecycle: {e}");
            Ok(ExitCode::from(1))
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::LifecycleVerb;
    use crate::cli::{Cli, Command};

    #[test]
    fn options_may_stand_anywhere_among_the_words() {
        for argv in [
            &[
                "crossym",
                "lifecycle",
                "set",
                "--config",
                "c.toml",
                "activate",
            ][..],
            &[
                "crossym",
                "lifecycle",
                "set",
                "activate",
                "--config",
                "c.toml",
            ],
            &[
                "crossym",
                "lifecycle",
                "--config",
                "c.toml",
                "set",
                "activate",
            ],
        ] {
            let cli = Cli::try_parse_from(argv).unwrap_or_else(|e| panic!("{argv:?}: {e}"));
            let Command::Lifecycle(a) = cli.command else {
                panic!("{argv:?}: not `lifecycle`");
            };
            assert_eq!(a.verb, LifecycleVerb::Set, "{argv:?}");
            assert_eq!(a.transition.as_deref(), Some("activate"), "{argv:?}");
            assert_eq!(a.node.config.to_str(), Some("c.toml"), "{argv:?}");
        }
    }
}
