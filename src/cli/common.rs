//! What several commands share: the closed sets of values their options take (clap
//! `ValueEnum`s mapped to the library's types), the node's overrides (`crossym node`,
//! `replay`, `ping`), and the pipeline with a progress bar (`augment`, `train`, `eval`).

use std::ffi::OsStr;
use std::marker::PhantomData;
use std::path::PathBuf;

use clap::builder::{EnumValueParser, PossibleValue, TypedValueParser};
use clap::{Args, ValueEnum};
use crossym::config::Config;
use crossym::control::Severity;
use crossym::control::{OutputMode, Trigger};
use crossym::pipeline::Splits;
use crossym::setup::NodeOverrides;
use crossym::sim::physics::Plant;

/// A [`ValueEnum`] read after trimming the whitespace around the value (`--group "R, RT"`
/// reads `R` and `RT`), honouring the argument's `ignore_case`; its help lists the values.
#[derive(Debug)]
pub struct Trimmed<E>(PhantomData<E>);

impl<E> Trimmed<E> {
    pub fn new() -> Self {
        Self(PhantomData)
    }
}

impl<E> Default for Trimmed<E> {
    fn default() -> Self {
        Self::new()
    }
}

impl<E> Clone for Trimmed<E> {
    fn clone(&self) -> Self {
        Self::new()
    }
}

impl<E: ValueEnum + Clone + Send + Sync + 'static> TypedValueParser for Trimmed<E> {
    type Value = E;

    fn parse_ref(
        &self,
        cmd: &clap::Command,
        arg: Option<&clap::Arg>,
        value: &OsStr,
    ) -> Result<E, clap::Error> {
        let value = value.to_str().map_or(value, |s| OsStr::new(s.trim()));
        EnumValueParser::<E>::new().parse_ref(cmd, arg, value)
    }

    fn possible_values(&self) -> Option<Box<dyn Iterator<Item = PossibleValue> + '_>> {
        Some(Box::new(
            E::value_variants()
                .iter()
                .filter_map(ValueEnum::to_possible_value),
        ))
    }
}

/// What the node publishes (`--output`, `mock-hw --command`, `stress --modes`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OutputArg {
    Velocity,
    Position,
    Trajectory,
}

impl From<OutputArg> for OutputMode {
    fn from(a: OutputArg) -> Self {
        match a {
            OutputArg::Velocity => Self::Velocity,
            OutputArg::Position => Self::Position,
            OutputArg::Trajectory => Self::Trajectory,
        }
    }
}

/// When the node ticks (`--trigger`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TriggerArg {
    Timer,
    #[value(name = "joint_states")]
    JointStates,
}

impl From<TriggerArg> for Trigger {
    fn from(a: TriggerArg) -> Self {
        match a {
            TriggerArg::Timer => Self::Timer,
            TriggerArg::JointStates => Self::JointStates,
        }
    }
}

/// The node's log level (`--log-level`): the spellings of [`Severity::parse`], any case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SeverityArg {
    #[value(alias = "trace")]
    Debug,
    Info,
    #[value(alias = "warning")]
    Warn,
    #[value(alias = "fatal")]
    Error,
}

impl From<SeverityArg> for Severity {
    fn from(a: SeverityArg) -> Self {
        match a {
            SeverityArg::Debug => Self::Debug,
            SeverityArg::Info => Self::Info,
            SeverityArg::Warn => Self::Warn,
            SeverityArg::Error => Self::Error,
        }
    }
}

/// The robot simulated (`--plant`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PlantArg {
    Kinematic,
    Mujoco,
}

impl From<PlantArg> for Plant {
    fn from(a: PlantArg) -> Self {
        match a {
            PlantArg::Kinematic => Self::Kinematic,
            PlantArg::Mujoco => Self::Mujoco,
        }
    }
}

/// Overrides of `[node]` from the command line.
#[derive(Debug, Args, Clone, Default)]
pub struct NodeOverrideArgs {
    /// Policy file (`.safetensors`, `.json` sidecar beside it); overrides `[node] policy`.
    #[arg(long)]
    pub policy: Option<PathBuf>,
    /// Node name.
    #[arg(long)]
    pub name: Option<String>,
    /// Node namespace (starts with `/`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Command output: velocity, position or trajectory.
    #[arg(long, value_enum)]
    pub output: Option<OutputArg>,
    /// Tick trigger: timer or joint_states.
    #[arg(long, value_enum)]
    pub trigger: Option<TriggerArg>,
    /// Control period (s).
    #[arg(long)]
    pub period_s: Option<f64>,
    /// Command topic.
    #[arg(long)]
    pub command_topic: Option<String>,
    /// Stale timeout for joint states (s).
    #[arg(long)]
    pub stale_timeout_s: Option<f64>,
    /// Console and /rosout log level of the node: debug, info, warn, error (default: a
    /// `crossym=LEVEL` or bare level in RUST_LOG, else `[node] log_level`, else info).
    #[arg(long, ignore_case = true, value_parser = Trimmed::<SeverityArg>::new())]
    pub log_level: Option<SeverityArg>,
}

impl NodeOverrideArgs {
    /// The library's overrides.
    pub fn overrides(&self) -> NodeOverrides {
        NodeOverrides {
            policy: self.policy.clone(),
            name: self.name.clone(),
            namespace: self.namespace.clone(),
            output: self.output.map(Into::into),
            trigger: self.trigger.map(Into::into),
            period_s: self.period_s,
            command_topic: self.command_topic.clone(),
            stale_timeout_s: self.stale_timeout_s,
            log_level: self.log_level.map(Into::into),
        }
    }
}

/// A progress bar for [`crossym::pipeline::build`]'s augmentation steps.
fn progress_bar() -> impl Fn(crossym::pipeline::Progress<'_>) + Sync {
    use crossym::pipeline::Progress;
    let bar = indicatif::ProgressBar::hidden();
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "  {msg} [{bar:30}] {pos}/{len} (demo, scale) tasks {elapsed}",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    move |p| match p {
        Progress::Start { label, tasks } => {
            bar.reset();
            bar.set_length(tasks as u64);
            bar.set_message(label.to_string());
            bar.set_draw_target(indicatif::ProgressDrawTarget::stderr());
        }
        Progress::Tick => bar.inc(1),
        Progress::Done => bar.finish_and_clear(),
    }
}

/// [`crossym::pipeline::build`] with a progress bar.
pub fn pipeline(
    cfg: &Config,
    kin: &crossym::kinematics::Kinematics,
    splits: Splits,
) -> anyhow::Result<crossym::pipeline::Pipeline> {
    Ok(crossym::pipeline::build(cfg, kin, splits, &progress_bar())?)
}

/// Which running node a client command talks to (`crossym status`, `crossym param`): its
/// config's `[node]` name and namespace, unless it was started with others.
#[derive(Debug, Args)]
pub struct NodeTarget {
    /// Config of the node (its [node] name, namespace and topics).
    #[arg(long, short, default_value = "config/letters.toml")]
    pub config: PathBuf,
    /// Node name, when it was started with --name.
    #[arg(long)]
    pub name: Option<String>,
    /// Node namespace, when it was started with --namespace.
    #[arg(long)]
    pub namespace: Option<String>,
}

impl NodeTarget {
    /// The node's settings as the target started it.
    pub fn node_config(&self) -> anyhow::Result<crossym::control::NodeConfig> {
        let cfg = Config::from_file(&self.config)?;
        let over = NodeOverrides {
            name: self.name.clone(),
            namespace: self.namespace.clone(),
            ..NodeOverrides::default()
        };
        Ok(crossym::setup::node_config(&cfg, &over)?)
    }
}

/// The error of a command this build leaves out (the `teach` feature: training with
/// candle, LeRobot datasets, SQLite3 bags), with the command that builds it.
#[cfg(not(feature = "teach"))]
pub fn needs_teach(command: &str) -> anyhow::Result<std::process::ExitCode> {
    anyhow::bail!(
        "`crossym {command}` is part of the teaching stack (training with candle, LeRobot \
         datasets, SQLite3 bags), which this build of crossym leaves out; build it with the \
         `teach` feature: `cargo build --release --features teach` (or `cargo run --release \
         --features teach -- {command} …`)"
    )
}

/// The DDS settings of `crossym TOOL` (`ping`, `param`, `status`, `record`, `replay
/// --live`, `lifecycle`): the ROS environment, SROS2's variables included
/// (docs/guide/security.md); when security was asked for, one line on stderr says whether
/// the tool runs secured and as which enclave (a permissive fallback's warning).
pub fn dds_settings(tool: &str) -> anyhow::Result<crossym::ros::dds::DdsSettings> {
    let s = crossym::ros::dds::DdsSettings::from_env()?;
    print_security(tool, &s)?;
    Ok(s)
}

/// Prints on stderr how `crossym TOOL`'s participant will run when SROS2 security was
/// asked for (`ROS_SECURITY_ENABLE=true`); an error where Enforce stops.
pub fn print_security(tool: &str, s: &crossym::ros::dds::DdsSettings) -> anyhow::Result<()> {
    if s.security.enable {
        eprintln!("crossym {tool}: {}", s.security_mode()?.describe());
    }
    Ok(())
}
