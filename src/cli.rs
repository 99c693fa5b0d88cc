//! Command-line interface: raw arguments → validated configuration → library calls.
//! One file per command under `cli/` (its options and its `run`), what several share in
//! `cli/common.rs`. `anyhow` is used here only, at the binary's edge.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod augment;
mod bag;
mod check;
mod common;
mod demo;
mod demos;
mod density;
mod endurance;
mod eval;
mod export_lerobot;
mod info;
mod lifecycle;
mod mock_hw;
mod node;
mod param;
mod ping;
mod record;
mod replay;
mod rollout;
mod security;
mod status;
mod stress;
mod symmetries;
mod train;

/// `crossym --version`: the package version and the git commit it was built from
/// (`build.rs`; `unknown` outside a git checkout), e.g. `crossym 0.1.0 (84615a6)`.
static VERSION: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
    let hash = option_env!("CROSSYM_GIT_HASH").unwrap_or("unknown");
    format!("{} ({hash})", env!("CARGO_PKG_VERSION"))
});

/// Cross-space symmetry compositions for robot policies.
#[derive(Debug, Parser)]
#[command(name = "crossym", version = VERSION.as_str(), about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Load a robot config and print its chains, joints, limits and FK at a configuration.
    Info(info::InfoArgs),
    /// Load the demonstrations ([demonstrations]) and augment them with the composed group;
    /// prints counts (train/test per sub-group), drops by reason and timing.
    Augment(augment::AugmentArgs),
    /// Train a symmetry-conditioned policy on the demonstrations augmented with a sub-group.
    Train(train::TrainArgs),
    /// Evaluate policies on the test sets of every sub-group (Table II): task-space RMSE.
    Eval(eval::EvalArgs),
    /// The main job: mock hardware + node (in a private network namespace), symmetry
    /// conditions published as a user would, a per-condition table and a PNG of the letters.
    /// Exits 1 if a check failed (limit violation, RMSE ratio, node error).
    Demo(demo::DemoArgs),
    /// Integrate a policy open loop from a start state (a demonstration transformed by the
    /// condition, or --q) and write the states to CSV; scored against the demonstration.
    /// Exits 1 when the rollout turned non-finite.
    Rollout(rollout::RolloutArgs),
    /// Fault campaign: randomized closed-loop episodes of the node core and a simulated
    /// robot (input faults, latency, adversarial policies, tight limits); a table of limit
    /// violations. Exits 1 on any violation or non-finite command.
    Stress(stress::StressArgs),
    /// Endurance: the node core of a config in a long closed loop with a kinematic robot
    /// (faster than real time) under a cyclic schedule of conditions: limit margins, ticks
    /// on a bound, the posture drift of a redundant arm. Exits 1 when a joint left its limits.
    Endurance(endurance::EnduranceArgs),
    /// Get or set a running node's parameter (like `ros2 param get/set`): e.g.
    /// `crossym param set velocity_scale 0.5`.
    Param(param::ParamArgs),
    /// Get or change a running node's lifecycle state (like `ros2 lifecycle get/set`):
    /// e.g. `crossym lifecycle set activate` (the RB-Y1 configs start inactive).
    Lifecycle(lifecycle::LifecycleArgs),
    /// A live one-line view of a running node's ~/status (code, condition, joint-state age,
    /// tick time, counters, last error). Exits 1 when no node answers within --timeout-s.
    Status(status::StatusArgs),
    /// Round trip joint state → command of a running node, from this process: median, p99,
    /// p99.9, max and lost probes (run the node with --trigger joint_states).
    Ping(ping::PingArgs),
    /// Morphological symmetry group of a robot from its URDF: every reflection plane through
    /// the base that maps the kinematic tree onto itself, the group they generate (C2, K4,
    /// …), each element's signed joint permutation; written as TOML and MorphoSymm YAML.
    Symmetries(symmetries::SymmetriesArgs),
    /// The augmentation-density experiment: π_R trained per rotation step Δθ, RMSE against
    /// the test rotation θ (CSV, Markdown and a PNG of the curves).
    Density(density::DensityArgs),
    /// Write the configured demonstrations as a LeRobotDataset (v3.0): one episode per
    /// demonstration, `observation.state` named by joint, for the LeRobot tools.
    ExportLerobot(export_lerobot::ExportLerobotArgs),
    /// Recorded demonstrations of [demonstrations] (rosbag2 bags, MCAP or SQLite3): read by
    /// joint name, resampled, differentiated, idle trimmed; a report per source and figures.
    /// Exits 1 when a source was refused.
    Demos(demos::DemosArgs),
    /// Run the ROS 2 node: joint states + symmetry condition → policy → safety QP → command.
    /// Honours ROS_DOMAIN_ID, ROS_LOCALHOST_ONLY, ROS_AUTOMATIC_DISCOVERY_RANGE, and ROS
    /// arguments after `--ros-args` (remaps, parameters, as a launch file passes them).
    Node(node::NodeArgs),
    /// Record topics over DDS into a new rosbag2 MCAP bag until Ctrl-C (the node's own
    /// `--record` also stores what offline replay needs; this recorder does not).
    Record(record::RecordArgs),
    /// Inspect a rosbag2 MCAP bag.
    Bag(bag::BagArgs),
    /// Replay a recorded bag offline through the node's logic and compare the commands.
    /// Exits 1 when a command deviates beyond the tolerance.
    Replay(replay::ReplayArgs),
    /// Run the mock hardware: integrate commands, publish /joint_states, log limit violations.
    /// Exits 1 when it saw a limit violation.
    MockHw(mock_hw::MockHwArgs),
    /// Transfer and compose the configured symmetries and print the numerical checks.
    /// Exits 1 when a requested composition is impossible or a transfer fails.
    Check(check::CheckArgs),
    /// SROS2 keystores without the ROS tools (like `ros2 security`): create-keystore,
    /// create-enclave, create-permission from a policy file, generate-artifacts,
    /// list-enclaves (cargo feature `security`).
    Security(security::SecurityArgs),
}

impl Cli {
    /// One-shot commands whose output may be piped into `head`; the long-running node
    /// and mock hardware handle their own shutdown (a final command) and keep the default.
    pub fn ends_quietly_on_closed_pipe(&self) -> bool {
        !matches!(
            self.command,
            Command::Node(_) | Command::MockHw(_) | Command::Demo(_)
        )
    }
}

/// Runs one subcommand.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match &cli.command {
        Command::Info(a) => info::run(a),
        Command::Augment(a) => augment::run(a),
        Command::Train(a) => train::run(a),
        Command::Eval(a) => eval::run(a),
        Command::Demo(a) => demo::run(a),
        Command::Rollout(a) => rollout::run(a),
        Command::Stress(a) => stress::run(a),
        Command::Endurance(a) => endurance::run(a),
        Command::Status(a) => status::run(a),
        Command::Param(a) => param::run(a),
        Command::Lifecycle(a) => lifecycle::run(a),
        Command::Ping(a) => ping::run(a),
        Command::Symmetries(a) => symmetries::run(a),
        Command::Density(a) => density::run(a),
        Command::Demos(a) => demos::run(a),
        Command::ExportLerobot(a) => export_lerobot::run(a),
        Command::Node(a) => node::run(a),
        Command::Record(a) => record::run(a),
        Command::Bag(a) => bag::run(a),
        Command::Replay(a) => replay::run(a),
        Command::MockHw(a) => mock_hw::run(a),
        Command::Check(a) => check::run(a),
        Command::Security(a) => security::run(a),
    }
}
