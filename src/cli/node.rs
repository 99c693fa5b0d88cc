//! `crossym node`: config + command-line overrides (+ ROS arguments, as `launch_ros` passes
//! them) → the ROS 2 node over DDS.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use crossym::config::Config;
use crossym::control::NodeCore;
use crossym::control::Severity;
use crossym::ros::dds::{self, DdsSettings};
use crossym::ros::log::format_line;
use crossym::ros::ros_args::{check_parameters, fully_qualified, NodeSetup, RosArgs};
use crossym::setup::{build_core, node_config, node_core};
use ros2_client::ParameterValue;

use super::common::NodeOverrideArgs;

/// Options of `crossym node`.
#[derive(Debug, clap::Args)]
pub struct NodeArgs {
    /// Config file (TOML) with [robot] and [node].
    #[arg(long, short)]
    pub config: PathBuf,
    #[command(flatten)]
    pub overrides: NodeOverrideArgs,
    /// Record joint states, conditions, commands and status to this new rosbag2 (MCAP)
    /// directory.
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// ROS 2 arguments after crossym's own, read as rcl reads them (`launch_ros` appends
    /// them): `--ros-args`, then `-r [node:]from:=to` (`__node:=NAME`, `__ns:=/NS`, topic
    /// names), `-p [node:]name:=value` (a YAML value), `--params-file FILE`
    /// (`/**:`/`node:`/`/ns/node:` → `ros__parameters:`), `--log-level [logger:=]LEVEL`,
    /// `-e/--enclave E` (SROS2's enclave, docs/guide/security.md),
    /// `--enable-/--disable-{stdout,rosout,external-lib}-logs`,
    /// up to `--` or the end. Parameter values: config, then the files and `-p` in
    /// command-line order; an undeclared parameter, a read-only one given another value or
    /// a wrong type stops the node (exit 2). Service names are not remapped yet.
    #[arg(
        value_name = "--ros-args ...",
        trailing_var_arg = true,
        allow_hyphen_values = true,
        num_args = 0..
    )]
    pub ros_args: Vec<String>,
}

/// `crossym node`.
pub fn run(a: &NodeArgs) -> anyhow::Result<ExitCode> {
    let record = a.record.as_deref();
    let ros = ros_arguments(&a.ros_args)?;
    let core = match &ros {
        Some(ros) => core_with_ros_args(a, ros)?,
        None => build_core(&a.config, &a.overrides.overrides())?.1,
    };
    // SROS2: the enclave of `--ros-args --enclave` (ROS_SECURITY_ENCLAVE_OVERRIDE wins).
    let enclave = ros.as_ref().and_then(|r| r.enclave.as_deref());
    let settings = DdsSettings::from_env()?.with_enclave(enclave);
    let stats = crossym::ros::node::run(core, settings, None, record)?;
    if let Some(dir) = record {
        eprintln!(
            "crossym node: recorded {} messages to {} ({} dropped)",
            stats.bag_messages,
            dir.display(),
            stats.bag_dropped
        );
    }
    // The tick summary is the node's last log line.
    Ok(ExitCode::SUCCESS)
}

/// The ROS arguments in `tail`, the end of the command line that clap left after crossym's
/// own options; `None` without any. Anything there outside a `--ros-args` block is refused.
pub fn ros_arguments(tail: &[String]) -> anyhow::Result<Option<RosArgs>> {
    if tail.is_empty() {
        return Ok(None);
    }
    // Positions as on the command line (the program is argument 0).
    let first = std::env::args().count().saturating_sub(tail.len());
    let parsed = RosArgs::parse(tail, first)?;
    if let Some((position, arg)) = parsed.rest.first() {
        bail!(
            "unexpected argument `{arg}` (argument {position}): crossym's own options go before --ros-args"
        );
    }
    Ok(Some(parsed.ros))
}

/// The node core of `a` with the ROS arguments applied to its settings, its start
/// parameters checked against its declarations.
fn core_with_ros_args(a: &NodeArgs, ros: &RosArgs) -> anyhow::Result<NodeCore> {
    let cfg = Config::from_file(&a.config)?;
    let mut n = node_config(&cfg, &a.overrides.overrides())?;
    let setup = ros.configure_node(&mut n)?;
    let (level, name, namespace) = (n.log_level, n.name.clone(), n.namespace.clone());
    let core = node_core(&cfg, n)?;
    check_parameters(&core, &setup.params)?;
    for (severity, text) in summary(ros, &setup, &namespace, &name) {
        if severity >= level {
            let now = dds::wall_time_ns() as f64 * 1e-9;
            eprintln!("{}", format_line(severity, now, &name, &text));
        }
    }
    Ok(core)
}

/// The log lines of what the ROS arguments set: the node's name, the parameters and where
/// each came from, the remaps, what was accepted but is not applied.
fn summary(
    ros: &RosArgs,
    setup: &NodeSetup,
    namespace: &str,
    name: &str,
) -> Vec<(Severity, String)> {
    let params: Vec<String> = setup
        .params
        .iter()
        .map(|p| format!("{} = {} ({})", p.name, yaml(&p.value), p.origin))
        .collect();
    let mut lines = vec![(
        Severity::Info,
        format!(
            "ROS arguments: node {}; parameters: {}",
            fully_qualified(namespace, name),
            if params.is_empty() {
                "none".to_string()
            } else {
                params.join(", ")
            }
        ),
    )];
    lines.extend(setup.log.iter().cloned());
    let stored = [
        ros.log_file_name
            .as_ref()
            .map(|f| format!("--log-file-name {f}")),
        ros.log_config_file
            .as_ref()
            .map(|f| format!("--log-config-file {}", f.display())),
        ros.rosout_logs
            .map(|on| format!("rosout logs {}", if on { "on" } else { "off" })),
        ros.stdout_logs
            .map(|on| format!("stdout logs {}", if on { "on" } else { "off" })),
    ];
    let stored: Vec<String> = stored.into_iter().flatten().collect();
    if !stored.is_empty() {
        lines.push((
            Severity::Warn,
            format!(
                "ROS arguments accepted but not applied yet: {}",
                stored.join(", ")
            ),
        ));
    }
    lines
}

/// A parameter value as YAML writes it (`0.5`, `[0.0, 1.0]`, `"debug"`).
fn yaml(v: &ParameterValue) -> String {
    fn list<T: std::fmt::Debug>(v: &[T]) -> String {
        let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        format!("[{}]", items.join(", "))
    }
    match v {
        ParameterValue::NotSet => "~".into(),
        ParameterValue::Boolean(b) => b.to_string(),
        ParameterValue::Integer(i) => i.to_string(),
        ParameterValue::Double(d) => format!("{d:?}"),
        ParameterValue::String(s) => format!("{s:?}"),
        ParameterValue::ByteArray(b) => list(b),
        ParameterValue::BooleanArray(b) => list(b),
        ParameterValue::IntegerArray(i) => list(i),
        ParameterValue::DoubleArray(d) => list(d),
        ParameterValue::StringArray(s) => list(s),
    }
}
