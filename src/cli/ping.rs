//! `crossym ping`: the round trip joint state → command of a running node, measured from
//! another process as the robot's driver sees it.
//!
//! Each probe publishes one `sensor_msgs/JointState` (stamped with the wall clock, a
//! configuration inside the joint limits) on the node's joint-state topic and waits for the
//! next command on its command topic; the time between the publish call and the command's
//! arrival is one round trip. A probe without a command within `--reply-timeout-ms` is
//! lost. The node should run with `trigger = "joint_states"` (else a round trip includes
//! the wait for the next timer tick, up to a period).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crossym::config::Config;
use crossym::ros::dds::{self, DdsSettings};
use crossym::ros::{msg, OutputMode, Trigger};

use super::ros::{node_config, NodeOverrides};

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
    /// The node's flags, when it was started with some (name, namespace, output, topics).
    #[command(flatten)]
    pub node: NodeOverrides,
}

/// Order statistics of round trips (µs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Latency {
    /// Median (µs).
    pub median: f64,
    /// 99th percentile (µs).
    pub p99: f64,
    /// 99.9th percentile (µs).
    pub p999: f64,
    /// Maximum (µs).
    pub max: f64,
}

/// Nearest-rank quantiles of `v` (µs), sorted in place; `None` when empty.
pub fn latency(v: &mut [f64]) -> Option<Latency> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let q = |p: f64| v[((p * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
    Some(Latency {
        median: q(0.5),
        p99: q(0.99),
        p999: q(0.999),
        max: v[v.len() - 1],
    })
}

enum Replies {
    Array(ros2_client::Subscription<msg::Float64MultiArray>),
    Trajectory(ros2_client::Subscription<msg::JointTrajectory>),
}

impl Replies {
    /// True when a command was waiting.
    fn take(&self) -> bool {
        match self {
            Self::Array(s) => matches!(s.take(), Ok(Some(_))),
            Self::Trajectory(s) => matches!(s.take(), Ok(Some(_))),
        }
    }
}

/// `crossym ping`. Exit 1 when no command answers.
pub fn ping(a: &PingArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.rate.is_finite() && a.rate > 0.0,
        "--rate {} must be positive",
        a.rate
    );
    anyhow::ensure!(a.count > 0, "--count must be positive");
    anyhow::ensure!(
        a.reply_timeout_ms.is_finite() && a.reply_timeout_ms > 0.0,
        "--reply-timeout-ms must be positive"
    );
    let cfg = Config::from_file(&a.config)?;
    let n = node_config(&cfg, &a.node)?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    if n.trigger != Trigger::JointStates {
        eprintln!(
            "crossym ping: the node's trigger is `timer`: round trips include the wait for its next tick (up to {} ms); run it with --trigger joint_states to measure the transport",
            n.period_s * 1e3
        );
    }
    // A configuration inside the limits: the mock hardware's start, else mid-range.
    let q: Vec<f64> = cfg
        .mock_hw
        .as_ref()
        .and_then(|m| m.initial_q.clone())
        .filter(|q| q.len() == kin.dof())
        .unwrap_or_else(|| {
            kin.limits()
                .iter()
                .map(|l| 0.5 * (l.lower + l.upper))
                .collect()
        });
    let js_topic = dds::expand_topic(&n.topics.joint_states, &n.namespace, &n.name);
    let cmd_topic = dds::expand_topic(&n.topics.command, &n.namespace, &n.name);
    let ctx = DdsSettings::from_env()?.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_ping_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let js_pub = dds::publisher::<msg::JointState>(&mut node, &js_topic, dds::qos_reliable(10))?;
    let replies = match n.output {
        OutputMode::Trajectory => Replies::Trajectory(dds::subscription::<msg::JointTrajectory>(
            &mut node,
            &cmd_topic,
            dds::qos_reliable(10),
        )?),
        _ => Replies::Array(dds::subscription::<msg::Float64MultiArray>(
            &mut node,
            &cmd_topic,
            dds::qos_reliable(10),
        )?),
    };
    let names = kin.joint_names().to_vec();
    let send = || -> anyhow::Result<()> {
        let now = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .unwrap_or_default();
        js_pub
            .publish(msg::JointState {
                header: msg::Header {
                    stamp: msg::Time::from_secs_f64(now.as_secs_f64()),
                    frame_id: String::new(),
                },
                name: names.clone(),
                position: q.clone(),
                ..Default::default()
            })
            .map_err(|e| anyhow::anyhow!("publishing on {js_topic}: {e:?}"))
    };
    eprintln!(
        "crossym ping: {js_topic} → {cmd_topic}, {} probes at {} Hz",
        a.count, a.rate
    );
    // Discovery and warm-up: until 20 commands came back.
    let start = Instant::now();
    let mut warm = 0;
    while warm < 20 {
        if start.elapsed().as_secs_f64() > a.connect_timeout_s {
            eprintln!(
                "crossym ping: no command on {cmd_topic} within {} s: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?",
                a.connect_timeout_s
            );
            return Ok(ExitCode::from(1));
        }
        send()?;
        std::thread::sleep(Duration::from_millis(20));
        while replies.take() {
            warm += 1;
        }
    }
    let period = Duration::from_secs_f64(1.0 / a.rate);
    let timeout = Duration::from_secs_f64(a.reply_timeout_ms * 1e-3);
    let mut rtt = Vec::with_capacity(a.count);
    let mut lost = 0usize;
    let mut next = Instant::now();
    for _ in 0..a.count {
        while replies.take() {}
        let now = Instant::now();
        if next > now {
            std::thread::sleep(next - now);
        }
        next += period;
        let t0 = Instant::now();
        send()?;
        loop {
            if replies.take() {
                rtt.push(t0.elapsed().as_secs_f64() * 1e6);
                break;
            }
            if t0.elapsed() > timeout {
                lost += 1;
                break;
            }
            std::hint::spin_loop();
        }
    }
    let Some(l) = latency(&mut rtt) else {
        println!("ping: {} probes, all lost", a.count);
        return Ok(ExitCode::from(1));
    };
    println!(
        "ping: {} round trips at {} Hz: median {:.0} µs, p99 {:.0} µs, p99.9 {:.0} µs, max {:.0} µs; {lost} lost (no command within {} ms)",
        rtt.len(),
        a.rate,
        l.median,
        l.p99,
        l.p999,
        l.max,
        a.reply_timeout_ms
    );
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_quantiles() {
        let mut v: Vec<f64> = (1..=1000).rev().map(f64::from).collect();
        let l = latency(&mut v).unwrap();
        assert_eq!(
            (l.median, l.p99, l.p999, l.max),
            (500.0, 990.0, 999.0, 1000.0)
        );
        assert!(latency(&mut []).is_none());
    }
}
