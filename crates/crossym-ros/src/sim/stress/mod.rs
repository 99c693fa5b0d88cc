//! Fault campaign (`crossym stress`): randomized closed-loop episodes of the node's core
//! ([`NodeCore`](crossym_control::NodeCore), no DDS) and a simulated robot, counting every limit violation.
//!
//! The robot here is independent of the node and of [`super::MockHardware`]: it keeps time
//! in integer microseconds, integrates velocity commands exactly (piecewise constant
//! between events, so a position's extremes lie at event times) or jumps to position
//! commands (an ideal servo), holds the last command it received, and enforces nothing.
//! Commands reach it after a drawn latency (in order; some dropped), joint states reach the
//! node after a drawn delay. The checks use only the episode's limits:
//!
//! - **position**: the robot's true position beyond `[lower, upper]` (not the margin);
//! - **velocity**: a velocity command, or the implied velocity `(p_k − p_{k−1})/Δt` of
//!   position commands, beyond `v_max`;
//! - **acceleration**: `(u_k − u_{k−1})/Δt` of successive published velocities (or implied
//!   velocities) beyond `a_max`;
//! - **non-finite**: any published value that is NaN or infinite.
//!
//! The final shutdown command is not part of an episode. Each episode draws its geometry,
//! output mode, limits (tight: rest ± 0.15–0.5 rad, 0.2–1 × the velocity limit; or the
//! robot's own), a start state (anywhere inside, some joints within 0–5 mrad of a bound),
//! a condition (trained, or extrapolated with `accept_untrained_conditions`), a policy (the
//! real one or an adversary) and input faults (see [`Fault`]). The node's
//! `safety.latency_s` and `safety.state_delay_s` are set to the envelope the episode's
//! transport can reach: the guarantee is stated for that envelope.

mod adversary;
mod episode;
mod plan;
mod robot;
mod tally;

use rayon::prelude::*;

use crossym_control::safety::BoundRules;
use crossym_control::{NodeConfig, OutputMode};
use crossym_math::kinematics::{Kinematics, NullSpaceSettings};
use crossym_policy::Policy;

pub use self::adversary::Adversary;
pub use self::episode::run_episode;
pub use self::robot::Fault;
pub use self::tally::Tally;

/// One robot the campaign can draw: kinematics, a policy for it and the node's settings.
#[derive(Clone)]
pub struct Geometry {
    /// Short name for the report (e.g. `planar`, `rby1`).
    pub name: String,
    /// Kinematics with the robot's own limits.
    pub kinematics: Kinematics,
    /// The policy the node runs when the episode draws the real one.
    pub policy: Policy,
    /// The node settings of the robot's config.
    pub node: NodeConfig,
    /// Rest posture (rad or m), the centre of tight limits.
    pub rest: Vec<f64>,
    /// The config's null-space term of a task head's lift (`[redundancy]`: settings and
    /// rest posture), built per episode against the episode's limits.
    pub null_space: Option<(NullSpaceSettings, Vec<f64>)>,
}

/// What a campaign runs.
#[derive(Debug, Clone)]
pub struct StressSettings {
    /// Episodes per output mode.
    pub episodes: usize,
    /// Seed of the whole campaign (episode `k` of mode `m` is reproducible from it).
    pub seed: u64,
    /// Output modes to run.
    pub modes: Vec<OutputMode>,
    /// Simulated time per episode (s).
    pub duration_s: f64,
}

impl Default for StressSettings {
    fn default() -> Self {
        Self {
            episodes: 1000,
            seed: 1,
            modes: vec![
                OutputMode::Velocity,
                OutputMode::Position,
                OutputMode::Trajectory,
            ],
            duration_s: 3.0,
        }
    }
}

/// The campaign's result per output mode.
#[derive(Debug, Clone)]
pub struct StressReport {
    /// (mode, its tally), in the order of [`StressSettings::modes`].
    pub modes: Vec<(OutputMode, Tally)>,
}

impl StressReport {
    /// True when no mode saw a violation.
    pub fn clean(&self) -> bool {
        self.modes.iter().all(|(_, t)| t.clean())
    }
}

/// The seed of episode `k` of mode index `m` in a campaign seeded `seed`.
pub fn episode_seed(seed: u64, m: usize, k: usize) -> u64 {
    // SplitMix64 of the triple: distinct, well-mixed seeds.
    let mut z = seed
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((m as u64) << 40)
        .wrapping_add(k as u64);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Runs the campaign over `geometries` (episodes in parallel) with the safety filter's bound
/// rules `rules`: [`ExactBounds`](crossym_control::safety::ExactBounds), the node's own, or
/// a deliberate defect (feature `fault-injection` of crossym-control) the campaign must catch.
pub fn run_campaign<R: BoundRules + Clone + Send + Sync>(
    geometries: &[Geometry],
    s: &StressSettings,
    rules: R,
) -> Result<StressReport, String> {
    if geometries.is_empty() {
        return Err("no geometry to run".into());
    }
    let mut modes = Vec::new();
    for (m, &mode) in s.modes.iter().enumerate() {
        let tallies: Result<Vec<Tally>, String> = (0..s.episodes)
            .into_par_iter()
            .map(|k| {
                let seed = episode_seed(s.seed, m, k);
                run_episode(geometries, mode, seed, s.duration_s, rules.clone())
            })
            .collect();
        let mut total = Tally::default();
        for t in tallies? {
            total.add(&t);
        }
        modes.push((mode, total));
    }
    Ok(StressReport { modes })
}

/// The report as a Markdown table (one row per mode) with the fault mix below it.
pub fn report_table(r: &StressReport) -> String {
    use std::fmt::Write as _;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| mode | episodes | ticks | commands | position viol. (worst) | velocity viol. (worst) | acceleration viol. (worst) | non-finite |"
    );
    let _ = writeln!(s, "|---|---:|---:|---:|---:|---:|---:|---:|");
    for (mode, t) in &r.modes {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} ({:.2e}) | {} ({:.2e}) | {} ({:.2e}) | {} |",
            mode_name(*mode),
            t.episodes,
            t.ticks,
            t.commands,
            t.position,
            t.position_worst,
            t.velocity,
            t.velocity_worst,
            t.acceleration,
            t.acceleration_worst,
            t.nonfinite
        );
    }
    let mut all = Tally::default();
    for (_, t) in &r.modes {
        all.add(t);
    }
    let list = |v: &[(&str, u64)]| {
        v.iter()
            .map(|(n, c)| format!("{n} {c}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let _ = writeln!(
        s,
        "\nepisodes: {} on tight limits, {} with an extrapolated condition, {} starting within 5 mrad of a bound, {} with dropped commands",
        all.tight, all.untrained, all.near_bound, all.with_drops
    );
    let _ = writeln!(s, "policies: {}", list(&all.adversaries));
    let _ = writeln!(s, "input fault windows: {}", list(&all.faults));
    if !all.failing_seeds.is_empty() {
        let _ = writeln!(
            s,
            "episodes with a violation (seeds): {:?}",
            all.failing_seeds
        );
    }
    s
}

/// `velocity`, `position` or `trajectory`.
pub fn mode_name(m: OutputMode) -> &'static str {
    match m {
        OutputMode::Velocity => "velocity",
        OutputMode::Position => "position",
        OutputMode::Trajectory => "trajectory",
    }
}
