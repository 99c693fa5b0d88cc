//! `crossym lifecycle get|set`: a running node's lifecycle state through its
//! `lifecycle_msgs` services, for machines without the ROS tools (`ros2 lifecycle get|set`).
//! The RB-Y1 configs start the node inactive: `crossym lifecycle set activate` lets the
//! policy drive the robot.

use std::process::ExitCode;
use std::time::Duration;

use crossym::ros::dds::{self, DdsSettings};
use crossym::ros::lifecycle_client::LifecycleClient;

/// Options of `crossym lifecycle`.
#[derive(Debug, clap::Args)]
pub struct LifecycleArgs {
    /// `get`, or `set TRANSITION` (configure, activate, deactivate, cleanup, shutdown).
    #[arg(num_args = 1..=2, value_names = ["get|set", "TRANSITION"])]
    pub words: Vec<String>,
    #[command(flatten)]
    pub node: super::common::NodeTarget,
    /// Give up (exit 1) when the node does not answer within this time (s).
    #[arg(long, default_value_t = 5.0)]
    pub timeout_s: f64,
}

/// `crossym lifecycle`. Exit 1 when the node does not answer or refuses the transition.
pub fn run(a: &LifecycleArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.timeout_s.is_finite() && a.timeout_s > 0.0,
        "--timeout-s {} must be positive",
        a.timeout_s
    );
    let n = a.node.node_config()?;
    let target = dds::node_name(&n.namespace, &n.name)?.fully_qualified_name();
    let settings = DdsSettings::from_env()?.with_config_distro(n.ros_distro.as_deref())?;
    let ctx = settings.context()?;
    let client = LifecycleClient::new(&ctx, &target)?;
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let words: Vec<&str> = a.words.iter().map(String::as_str).collect();
    let result = match words[..] {
        ["get"] => client.get_state(timeout),
        ["set", t] => client.change_state(t, timeout),
        _ => anyhow::bail!("usage: crossym lifecycle get | crossym lifecycle set TRANSITION"),
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
