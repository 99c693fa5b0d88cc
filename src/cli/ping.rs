//! `crossym ping`: the round trip joint state → command of a running node, measured from
//! another process as the robot's driver sees it (`crossym::ros::tools::ping`, which
//! explains how; this file reads the options and the config and prints the report).

use std::path::PathBuf;
use std::process::ExitCode;

use crossym::config::Config;
use crossym::control::Trigger;
use crossym::ros::tools::ping::{
    probe_position, Latency, Ping, PingError, PingReport, PingSettings, PingTarget,
};
use crossym::setup::node_config;

use super::common::NodeOverrideArgs;

/// Options of `crossym ping`.
#[derive(Debug, clap::Args)]
pub struct PingArgs {
    /// Config of the node to measure (robot, [node] topics and output mode).
    #[arg(long, short, default_value = "config/letters.toml")]
    pub config: PathBuf,
    /// Probes per second (Hz).
    #[arg(long, default_value_t = 100.0)]
    pub rate: f64,
    /// Number of probes measured (after the warm-up).
    #[arg(long, default_value_t = 1000)]
    pub count: usize,
    /// A probe without a command within this time is lost (ms).
    #[arg(long, default_value_t = 50.0)]
    pub reply_timeout_ms: f64,
    /// Give up (exit 1) when no command answers within this time at start (s).
    #[arg(long, default_value_t = 20.0)]
    pub connect_timeout_s: f64,
    /// Spin on the subscription instead of blocking until DDS wakes ping (takes a core).
    #[arg(long)]
    pub busy_wait: bool,
    /// Run ping as a real-time driver would: its thread (its DDS event loop) under
    /// SCHED_FIFO at this priority (1 … 99), RustDDS's discovery thread one below, memory
    /// locked (needs privileges).
    #[arg(long, value_name = "PRIORITY")]
    pub realtime: Option<i32>,
    /// The node's flags, when it was started with some (name, namespace, output, topics).
    #[command(flatten)]
    pub node: NodeOverrideArgs,
}

/// `crossym ping`. Exit 1 when no command answers.
pub fn run(a: &PingArgs) -> anyhow::Result<ExitCode> {
    let settings = PingSettings {
        rate_hz: a.rate,
        count: a.count,
        reply_timeout_ms: a.reply_timeout_ms,
        connect_timeout_s: a.connect_timeout_s,
        busy_wait: a.busy_wait,
        realtime_priority: a.realtime,
    };
    let cfg = Config::from_file(&a.config)?;
    let n = node_config(&cfg, &a.node.overrides())?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    if n.trigger != Trigger::JointStates {
        eprintln!(
            "crossym ping: the node's trigger is `timer`: round trips include the wait for its next tick (up to {} ms); run it with --trigger joint_states to measure the transport",
            n.period_s * 1e3
        );
    }
    let position = probe_position(cfg.start_q(), kin.limits());
    let target = PingTarget::for_node(&n, kin.joint_names().to_vec(), position);
    let ping = Ping::connect(
        target,
        &settings,
        &super::common::dds_settings("ping")?,
        |o| {
            eprintln!(
                "crossym ping: {}",
                o.to_string().replace("control thread", "ping thread")
            )
        },
    )?;
    let t = ping.target();
    eprintln!(
        "crossym ping: {} → {}, {} probes at {} Hz",
        t.joint_states_topic, t.command_topic, a.count, a.rate
    );
    match ping.measure() {
        Ok(r) => Ok(report(a, &r)),
        Err(e @ PingError::NoCommand { .. }) => {
            eprintln!("crossym ping: {e}");
            Ok(ExitCode::from(1))
        }
        Err(e) => Err(e.into()),
    }
}

/// `median … µs, p99 … µs, p99.9 … µs, max … µs`.
fn quantiles(l: &Latency) -> String {
    format!(
        "median {:.0} µs, p99 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs",
        l.median, l.p99, l.p999, l.max
    )
}

/// Prints the round trips' order statistics and their parts; exit 1 when all were lost.
fn report(a: &PingArgs, r: &PingReport) -> ExitCode {
    let Some(l) = r.round_trips() else {
        println!("ping: {} probes, all lost", a.count);
        return ExitCode::from(1);
    };
    let u = &r.unanswered;
    println!(
        "ping: {} round trips at {} Hz ({}): {}; {} lost (no command within {} ms), {} stray commands (published before their probe); {} late answers to lost probes, {} commands of the node's own ticks (no probe for its stale timeout)",
        r.probes.len(),
        a.rate,
        if a.busy_wait { "busy-wait" } else { "blocking wait" },
        quantiles(&l),
        r.lost,
        a.reply_timeout_ms,
        u.stray,
        u.late,
        u.own_ticks
    );
    for (label, part) in [
        (
            "probe published → command published (to the node and through it)",
            r.forward(),
        ),
        ("command published → received here (DDS)", r.back()),
        ("received here → held by ping", r.wake()),
    ] {
        if let Some(l) = part {
            println!("  {label}: {}", quantiles(&l));
        }
    }
    ExitCode::SUCCESS
}
