//! `crossym status`: a live, one-line view of a running node's `~/status`, for machines
//! without the ROS tools (`ros2 topic echo`).

use std::io::{IsTerminal, Write};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use crossym::control::StatusCode;
use crossym::msg;
use crossym::ros::dds::{self, DdsSettings};

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

/// One human-readable line of a status message.
pub fn status_line(m: &msg::Status) -> String {
    let code = StatusCode::ALL
        .iter()
        .find(|c| c.value() == m.code)
        .map_or_else(
            || format!("CODE_{}", m.code),
            |c| c.constant_name().to_string(),
        );
    let c = &m.condition;
    let age = if m.joint_state_age_s < 0.0 {
        "none".to_string()
    } else {
        format!("{:.1} ms", m.joint_state_age_s * 1e3)
    };
    let mut s = format!(
        "{code} | θ {:+.3} rad λ {:.3} σ {:+} | joint state age {age} | tick {:.1} µs (max {:.1}) | ticks {} (stale {}) | rejected js {} cond {} | on a bound {}",
        c.theta,
        c.scale,
        c.reflection,
        m.tick_time_us,
        m.tick_time_max_us,
        m.ticks,
        m.stale_ticks,
        m.rejected_joint_states,
        m.rejected_conditions,
        m.active_constraints
    );
    if m.paused {
        s.push_str(" | PAUSED");
    }
    if m.velocity_scale != 1.0 {
        s.push_str(&format!(" | velocity ×{}", m.velocity_scale));
    }
    if m.singularity_factor < 1.0 {
        s.push_str(&format!(
            " | near a singularity: κ {:.1}, speed ×{:.2}",
            m.singularity_condition, m.singularity_factor
        ));
    }
    if !m.last_error.is_empty() {
        s.push_str(&format!(" | last error: {}", m.last_error));
    }
    s
}

/// `crossym status`. Exit 1 when no node answers within the timeout.
pub fn run(a: &StatusArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.timeout_s.is_finite() && a.timeout_s > 0.0,
        "--timeout-s {} must be positive",
        a.timeout_s
    );
    let n = a.node.node_config()?;
    let topic = dds::expand_topic(&n.topics.status, &n.namespace, &n.name);
    let ctx = DdsSettings::from_env()?.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_status_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let sub = dds::subscription::<msg::Status>(&mut node, &topic, dds::qos_sensor())?;
    let tty = std::io::stdout().is_terminal();
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let mut last = Instant::now();
    let mut seen = 0u64;
    eprintln!("crossym status: watching {topic} (Ctrl-C to stop)");
    loop {
        match sub.take() {
            Ok(Some((m, _))) => {
                seen += 1;
                last = Instant::now();
                let line = status_line(&m);
                let mut out = std::io::stdout().lock();
                if tty {
                    // Rewrite one line in place.
                    let _ = write!(out, "\r\x1b[2K{line}");
                } else {
                    let _ = writeln!(out, "{line}");
                }
                let _ = out.flush();
                let done =
                    m.code == StatusCode::Shutdown.value() || a.count.is_some_and(|c| seen >= c);
                if done {
                    if tty {
                        println!();
                    }
                    return Ok(ExitCode::SUCCESS);
                }
            }
            Ok(None) => {
                if last.elapsed() > timeout {
                    if tty && seen > 0 {
                        println!();
                    }
                    eprintln!(
                        "crossym status: no status on {topic} for {} s{}: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?",
                        a.timeout_s,
                        if seen == 0 { " (none at all)" } else { "" }
                    );
                    return Ok(ExitCode::from(1));
                }
                std::thread::sleep(Duration::from_millis(5));
            }
            Err(e) => {
                eprintln!("crossym status: undecodable status sample: {e:?}");
            }
        }
    }
}
