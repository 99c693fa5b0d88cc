//! `crossym mock-hw`: the mock hardware over DDS (commands integrated, `/joint_states`
//! published, limit violations logged), or the physics robot in its place.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use crossym::config::Config;
use crossym::ros::dds::DdsSettings;
use crossym::ros::ros_args::{fully_qualified, RosArgs};
use crossym::setup::{node_config, NodeOverrides};
use crossym::sim::physics::Plant;
use crossym::sim::{MockHardware, MockHwConfig};

use ros2_client::ParameterValue;

use super::common::{OutputArg, PlantArg};

/// Options of `crossym mock-hw`.
#[derive(Debug, clap::Args)]
pub struct MockHwArgs {
    /// Config file (TOML) with [robot], [node] and optionally [mock_hw].
    #[arg(long, short)]
    pub config: PathBuf,
    /// Write the run's summary (JSON) here on exit.
    #[arg(long)]
    pub summary: Option<PathBuf>,
    /// Initial positions of the controlled joints (rad), comma-separated.
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub initial_q: Option<Vec<f64>>,
    /// How commands are interpreted (velocity, position, trajectory); default: [mock_hw]
    /// command, else the node's output.
    #[arg(long, value_enum)]
    pub command: Option<OutputArg>,
    /// The robot: `kinematic` (commands executed exactly) or `mujoco` (the physics RB-Y1
    /// of `[mock_hw.mujoco]`, `physics/rby1_mujoco.py`); default: [mock_hw] plant.
    #[arg(long, value_enum)]
    pub plant: Option<PlantArg>,
    /// ROS 2 arguments, as `crossym node` reads them: `--ros-args -r __node:=NAME -r
    /// from:=to …` renames the node (`[mock_hw] name`) and its topics (joint states,
    /// commands); it runs in the root namespace and declares no parameter (`use_sim_time`
    /// only false). Not with the physics robot.
    #[arg(
        value_name = "--ros-args ...",
        trailing_var_arg = true,
        allow_hyphen_values = true,
        num_args = 0..
    )]
    pub ros_args: Vec<String>,
}

/// `crossym mock-hw`. Exits 1 when it saw a limit violation.
pub fn run(a: &MockHwArgs) -> anyhow::Result<ExitCode> {
    let summary = a.summary.as_deref();
    let cfg = Config::from_file(&a.config)?;
    let node = node_config(&cfg, &NodeOverrides::default())?;
    let ros = super::node::ros_arguments(&a.ros_args)?;
    let mut hw_cfg: MockHwConfig = cfg.mock_hw.clone().unwrap_or_default();
    hw_cfg.validate().context("[mock_hw]")?;
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let q0 = a
        .initial_q
        .clone()
        .or_else(|| cfg.start_q())
        .unwrap_or_else(|| vec![0.0; kin.dof()]);
    let plant = a.plant.map_or(hw_cfg.plant, Plant::from);
    if plant == Plant::Mujoco {
        anyhow::ensure!(
            ros.is_none(),
            "--ros-args: the physics robot takes no ROS arguments"
        );
        physics_security(&DdsSettings::from_env()?)?;
        let limits: Vec<(f64, f64)> = kin.limits().iter().map(|l| (l.lower, l.upper)).collect();
        return physics_robot(&cfg, &hw_cfg, kin.joint_names(), &q0, &limits, summary);
    }
    let mode = match a.command {
        Some(c) => c.into(),
        None => hw_cfg.command.unwrap_or(node.output),
    };
    let mut topic = hw_cfg
        .command_topic
        .clone()
        .unwrap_or_else(|| node.topics.command.clone());
    if let Some(ros) = &ros {
        apply_ros_args(ros, &mut hw_cfg, &mut topic)?;
    }
    let hw = MockHardware::new(
        &robot.model,
        kin.joint_names(),
        kin.limits(),
        &cfg.robot.held,
        &q0,
        mode,
        hw_cfg.clone(),
    )
    .context("[mock_hw]")?;
    let enclave = ros.as_ref().and_then(|r| r.enclave.as_deref());
    let settings = DdsSettings::from_env()?.with_enclave(enclave);
    let s = crossym::sim::process::run(hw, &hw_cfg, &topic, mode, settings, summary)?;
    Ok(if s.violation_count == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    })
}

/// The ROS arguments of `crossym mock-hw`: `__node` renames it, topic rules rename its
/// joint-state and command topics (expanded in the root namespace); `__ns` and parameters
/// are refused (`use_sim_time` false aside), as for a node that declares none.
fn apply_ros_args(
    ros: &RosArgs,
    hw: &mut MockHwConfig,
    command_topic: &mut String,
) -> anyhow::Result<()> {
    let (name, namespace) = ros.node_identity(&hw.name, "/");
    anyhow::ensure!(
        namespace == "/",
        "--ros-args: the mock hardware runs in the root namespace (__ns:={namespace})"
    );
    hw.name = name;
    for topic in [&mut hw.joint_states_topic, command_topic] {
        if let Some((to, _)) = ros.remap_topic(topic, "/", &hw.name) {
            *topic = to;
        }
    }
    let fqn = fully_qualified("/", &hw.name);
    for p in ros.params.for_node(&fqn) {
        if !(p.name == "use_sim_time" && p.value == ParameterValue::Boolean(false)) {
            anyhow::bail!(
                "parameter `{}` from {}: the mock hardware declares no parameters",
                p.name,
                p.origin
            );
        }
    }
    Ok(())
}

/// `crossym mock-hw --plant mujoco`: replaces this process by the physics robot
/// (`physics/rby1_mujoco.py`, see [`crossym::sim::physics`]), so that signals reach it.
fn physics_robot(
    cfg: &Config,
    hw: &MockHwConfig,
    joints: &[String],
    q0: &[f64],
    position_limits: &[(f64, f64)],
    summary: Option<&Path>,
) -> anyhow::Result<ExitCode> {
    use std::os::unix::process::CommandExt;
    anyhow::ensure!(
        hw.fault_near_limit.is_none(),
        "[mock_hw] fault_near_limit: the physics robot starts its faults by time only"
    );
    let base = cfg.resolve(Path::new("."));
    let urdf = cfg.resolve(&cfg.robot.urdf);
    let args = hw
        .mujoco
        .args(&crossym::sim::physics::PhysicsRun {
            base_dir: &base,
            urdf: &urdf,
            joints,
            initial_q: q0,
            position_limits,
            rate_hz: hw.rate_hz.min(100.0),
            summary,
            fault: hw.fault,
            fault_joint: hw.fault_joint.as_deref(),
            fault_after_s: hw.fault_after_s,
            fault_duration_s: hw.fault_duration_s,
        })
        .map_err(anyhow::Error::msg)
        .context("[mock_hw.mujoco]")?;
    let program = hw.mujoco.program(&base);
    anyhow::ensure!(
        program.is_file(),
        "the physics robot {} is missing (set [mock_hw.mujoco] program or CROSSYM_PHYSICS_DIR)",
        program.display()
    );
    let err = std::process::Command::new("python3")
        .arg(&program)
        .args(&args)
        .exec();
    Err(anyhow::Error::new(err).context(format!(
        "running python3 {} (install its packages with `bash physics/install.sh`)",
        program.display()
    )))
}

/// The physics robot (Python, Cyclone DDS without its security plugins) joins the domain
/// unsecured: refused under SROS2's Enforce, a warning when permissive.
fn physics_security(settings: &DdsSettings) -> anyhow::Result<()> {
    use crossym::ros::sros2::Strategy;
    let s = &settings.security;
    if s.enable {
        let why = "the physics robot (physics/rby1_mujoco.py, Cyclone DDS) cannot run secured";
        anyhow::ensure!(
            s.strategy != Strategy::Enforce,
            "ROS_SECURITY_STRATEGY=Enforce: {why}; use the kinematic mock (`--plant kinematic`)"
        );
        eprintln!("crossym mock-hw: SECURITY WARNING: running UNSECURED: {why}");
    }
    Ok(())
}
