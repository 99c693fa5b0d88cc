//! Step 1 of the demo, without a process or DDS: the settings checked, the node's settings
//! and policy, the conditions, the scenario steps (nominal trajectories, truncated to
//! `duration_s`) and their offline scores.

use std::path::PathBuf;

use crate::config::{Config, LoadedRobot};
use crate::control::NodeConfig;
use crate::eval::{score, EvalConfig};
use crate::kinematics::Kinematics;
use crate::pipeline::{load_any_policy, nominal_trajectories, pick_demo};
use crate::policy::JointTrajectory;
use crate::policy::{AnyPolicy, ConditionDomain};
use crate::setup::{node_config, parse_condition};
use crate::sim::physics::Plant;
use crate::sim::scenario::ScenarioStep;
use crate::sim::MockHwConfig;
use crate::symmetry::compose::Condition;

use super::{default_max_excess, DemoError, DemoSettings};

/// Everything the closed loop needs, prepared without a process or DDS ([`prepare`]).
pub struct Prepared {
    /// The config file.
    pub cfg: Config,
    /// `[node]` with the settings' policy.
    pub node: NodeConfig,
    /// `[mock_hw]` (defaults when absent).
    pub mock_hw: MockHwConfig,
    /// The robot of `[robot]`.
    pub robot: LoadedRobot,
    /// The demonstration drawn (1-based number).
    pub demo: usize,
    /// The policy file.
    pub policy_path: PathBuf,
    /// The policy.
    pub policy: AnyPolicy,
    /// The conditions the node accepts: a plain policy's trained box, `None` when it
    /// accepts every valid condition.
    pub domain: Option<ConditionDomain>,
    /// Labels of the default conditions left out (outside [`Prepared::domain`]).
    pub left_out: Vec<String>,
    /// One step per condition, in order.
    pub steps: Vec<ScenarioStep>,
    /// The offline rollout's RMSE per step (task units).
    pub offline: Vec<f64>,
    /// The robot simulated.
    pub plant: Plant,
    /// The allowance on top of `max_ratio × offline` (task units).
    pub max_excess: f64,
}

/// The conditions a demo runs ([`select_conditions`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Conditions {
    /// Label and condition of each step, in order.
    pub kept: Vec<(String, Condition)>,
    /// Labels of the default conditions left out (outside the trained box).
    pub left_out: Vec<String>,
}

/// Step 1: checks the settings, loads the config, the policy and the demonstration, and
/// builds the steps and their offline scores ([`select_conditions`], [`steps`],
/// [`offline_scores`]).
pub fn prepare(s: &DemoSettings) -> Result<Prepared, DemoError> {
    s.validate()?;
    let cfg = Config::from_file(&s.config)?;
    let node = node_config(&cfg, &s.overrides())?;
    let mock_hw = cfg.mock_hw.clone().unwrap_or_default();
    let robot = cfg.load_robot()?;
    let kin = &robot.kinematics;
    let demos = cfg.load_demonstrations(kin)?;
    let demo = pick_demo(&demos, s.demo)?;
    let policy_path = node.policy.clone().ok_or_else(|| DemoError::NoPolicy {
        config: s.config.clone(),
    })?;
    let policy = load_any_policy(&cfg, kin, &policy_path)?;
    // The node rejects conditions outside a plain policy's trained box: refuse given ones
    // here with the reason, leave default ones out, instead of a node that ignores them. A
    // canonicalised policy has no box (the node checks feasibility).
    let domain = node
        .condition_domain(&policy)
        .map_err(|message| DemoError::PolicyDomain {
            policy: policy_path.clone(),
            message,
        })?;
    let conditions = select_conditions(&s.conditions, &policy, domain.as_ref())?;
    let plant = s.plant.unwrap_or(mock_hw.plant);
    let max_excess = s.max_excess.unwrap_or(default_max_excess(plant));
    let steps = steps(&cfg, kin, demo, &conditions.kept, s.duration_s)?;
    let offline = offline_scores(&policy, kin, &steps);
    Ok(Prepared {
        demo: demo.demo,
        cfg,
        node,
        mock_hw,
        robot,
        policy_path,
        policy,
        domain,
        left_out: conditions.left_out,
        steps,
        offline,
        plant,
        max_excess,
    })
}

/// The original, rotated 30°, scaled 0.8, reflected, and all three composed.
pub fn default_conditions() -> Vec<(String, Condition)> {
    let r = std::f64::consts::FRAC_PI_6;
    let c = |theta, scale, reflection| Condition {
        theta,
        scale,
        reflection,
    };
    vec![
        ("original".into(), c(0.0, 1.0, 1)),
        ("rotated 30°".into(), c(r, 1.0, 1)),
        ("scaled 0.8".into(), c(0.0, 0.8, 1)),
        ("reflected".into(), c(0.0, 1.0, -1)),
        ("rot 30° + scale 0.8 + refl".into(), c(r, 0.8, -1)),
    ]
}

/// Conditions off every training grid, for a canonicalised policy (exactly equivariant
/// wherever the lifted flows are feasible): θ = 17°, λ = 0.73 and θ = 170°, λ = 1.15 (a
/// scale above the grid's largest, 1), both reflected.
pub fn off_grid_conditions() -> Vec<(String, Condition)> {
    vec![
        (
            "off-grid: rot 17° + scale 0.73 + refl".into(),
            Condition {
                theta: 17f64.to_radians(),
                scale: 0.73,
                reflection: -1,
            },
        ),
        (
            "off-grid: rot 170° + scale 1.15 + refl".into(),
            Condition {
                theta: 170f64.to_radians(),
                scale: 1.15,
                reflection: -1,
            },
        ),
    ]
}

/// The conditions of a demo: the `given` texts (`theta_rad:scale:reflection`, each its own
/// label), refused when one lies outside `domain`; without any, the
/// [`default_conditions`] (and the [`off_grid_conditions`] for a canonicalised policy)
/// that lie inside `domain`, an error when none does.
pub fn select_conditions(
    given: &[String],
    policy: &AnyPolicy,
    domain: Option<&ConditionDomain>,
) -> Result<Conditions, DemoError> {
    if !given.is_empty() {
        let mut kept = Vec::with_capacity(given.len());
        for text in given {
            let c = parse_condition(text)?;
            if let Some(Err(part)) = domain.map(|d| d.check(&c)) {
                return Err(DemoError::OutsideDomain {
                    condition: text.clone(),
                    part,
                    domain: domain.map(ConditionDomain::describe).unwrap_or_default(),
                });
            }
            kept.push((text.clone(), c));
        }
        return Ok(Conditions {
            kept,
            left_out: Vec::new(),
        });
    }
    let mut all = default_conditions();
    if policy.composition().is_some() {
        all.extend(off_grid_conditions());
    }
    let (kept, out): (Vec<_>, Vec<_>) = all
        .into_iter()
        .partition(|(_, c)| domain.is_none_or(|d| d.check(c).is_ok()));
    if kept.is_empty() {
        return Err(DemoError::NoDefaultCondition {
            domain: domain.map(ConditionDomain::describe).unwrap_or_default(),
        });
    }
    Ok(Conditions {
        kept,
        left_out: out.into_iter().map(|(label, _)| label).collect(),
    })
}

/// Samples kept of a trajectory of `len` samples `dt` apart drawn for `duration_s`: the
/// samples up to the one nearest `duration_s`, at least 2 and at most `len`; all of them
/// without a duration.
pub fn truncated_len(len: usize, dt: f64, duration_s: Option<f64>) -> usize {
    match duration_s {
        Some(d) => ((d / dt).round() as usize + 1).max(2).min(len),
        None => len,
    }
}

/// One scenario step per condition: the nominal trajectory of `demo` under it (the task of
/// `cfg`), truncated to `duration_s` ([`truncated_len`]).
pub fn steps(
    cfg: &Config,
    kin: &Kinematics,
    demo: &JointTrajectory,
    conditions: &[(String, Condition)],
    duration_s: Option<f64>,
) -> Result<Vec<ScenarioStep>, DemoError> {
    let conds: Vec<Condition> = conditions.iter().map(|c| c.1).collect();
    let nominal = nominal_trajectories(cfg, kin, demo, &conds)
        .map_err(|message| DemoError::Nominal { message })?;
    Ok(conditions
        .iter()
        .zip(nominal)
        .map(|((label, c), aug)| {
            let mut t = aug.traj;
            let keep = truncated_len(t.len(), t.dt, duration_s);
            t.q.truncate(keep * t.n);
            t.qdot.truncate(keep * t.n);
            t.x.truncate(keep * t.m);
            ScenarioStep {
                label: label.clone(),
                condition: *c,
                nominal: t,
            }
        })
        .collect())
}

/// The task-space RMSE of `policy` rolled out offline from each step's start, against its
/// nominal trajectory ([`crate::eval::score`], default settings).
pub fn offline_scores(policy: &AnyPolicy, kin: &Kinematics, steps: &[ScenarioStep]) -> Vec<f64> {
    steps
        .iter()
        .map(|s| {
            score(
                policy,
                kin,
                &s.nominal,
                &s.condition,
                &EvalConfig::default(),
            )
            .rmse
        })
        .collect()
}
