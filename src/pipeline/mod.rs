//! The learning pipeline as library calls: demonstrations (`[demonstrations]`, any source)
//! → augmentation by the lifted composed group (eq. 23; `[augmentation]`) → training of a
//! symmetry-conditioned policy `π(q, s)` (`[train]`) → evaluation (Table II, `[eval]`).
//!
//! The CLI (`crossym augment`, `train`, `eval`, `demo`, `rollout`, `density`), the tests and
//! the benches call these functions; the CLI only parses arguments and prints.
//!
//! - [`build`]: demonstrations and the augmented sets a step needs ([`Splits`]).
//! - [`train`]: a policy on a sub-group's augmented training set.
//! - [`table2`]: every test trajectory rolled out per policy, Table II's cells and files.
//! - [`paper`]: Table II under the paper's own evaluation protocol.
//! - [`figures`]: the conditions a figure shows per sub-group, with a caption.

use std::path::{Path, PathBuf};

use crate::config::Config;
use crate::data::augmentation::{letter_augmenter, AugmentedSet};
use crate::data::demonstrations::Demonstrations;
use crate::kinematics::Kinematics;
use crate::policy::JointTrajectory;
#[cfg(feature = "teach")]
use crate::policy::PolicyMeta;
use crate::policy::{AnyPolicy, Policy, TaskFeatures, TrainConfig};
use crate::policy::{GroupGrid, SubGroup};
use crate::symmetry::affine::CanonicalMap;
use crate::symmetry::built::BuiltSymmetry;
use crate::symmetry::compose::Condition;
use crate::symmetry::transfer::composed::{ComposedSpec, LiftIntegrator};
#[cfg(feature = "teach")]
use crate::train::TrainReport;

pub mod figures;
pub mod fit;
pub mod paper;
pub mod table2;

/// Why a pipeline step failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PipelineError {
    /// The config lacks a section the step needs.
    #[error("{path}: no [{section}] section")]
    Missing {
        /// Config path.
        path: PathBuf,
        /// The section.
        section: &'static str,
    },
    /// A setting is invalid or inconsistent with the robot or the symmetries.
    #[error("{path}: {message}")]
    Invalid {
        /// Config (or policy) path.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The demonstration asked for does not exist (`None`: none asked and no test one).
    #[error("{}: the demonstrations are 1 … {count}: {names}", which.map_or_else(|| "no demonstration given and no test demonstration".to_string(), |w| format!("no demonstration {w}")))]
    NoDemonstration {
        /// The number asked for (1-based).
        which: Option<usize>,
        /// How many there are.
        count: usize,
        /// Their names, in number order.
        names: String,
    },
    /// Demonstrations could not be loaded.
    #[error(transparent)]
    Data(#[from] crate::data::DataError),
    /// The symmetries could not be built.
    #[error(transparent)]
    Symmetry(#[from] crate::symmetry::check::CheckError),
    /// Training or loading a policy failed.
    #[error(transparent)]
    Policy(#[from] crate::policy::PolicyError),
    /// Writing an output failed.
    #[error("writing {path}: {message}")]
    Write {
        /// The file or directory.
        path: PathBuf,
        /// What failed.
        message: String,
    },
}

fn invalid(cfg: &Config, message: impl Into<String>) -> PipelineError {
    PipelineError::Invalid {
        path: cfg.path.clone(),
        message: message.into(),
    }
}

/// `[augmentation]`, or an error naming the config.
fn augmentation(
    cfg: &Config,
) -> Result<&crate::data::augmentation::AugmentationConfig, PipelineError> {
    cfg.augmentation
        .as_ref()
        .ok_or_else(|| PipelineError::Missing {
            path: cfg.path.clone(),
            section: "augmentation",
        })
}

/// Which augmented sets [`build`] makes (the others stay empty).
#[derive(Debug, Clone, Copy, Default)]
pub struct Splits {
    /// The training demonstrations under the training grid.
    pub train: bool,
    /// The test demonstrations under the test grid.
    pub test: bool,
    /// The training demonstrations under the test grid (Table II's no-learning reference).
    pub reference: bool,
}

/// Progress of a long step, for a caller's progress bar.
#[derive(Debug, Clone, Copy)]
pub enum Progress<'a> {
    /// A step starts with this many tasks.
    Start {
        /// What runs (`augmenting train`, …).
        label: &'a str,
        /// Tasks it will report.
        tasks: usize,
    },
    /// One task done (may be called from worker threads).
    Tick,
    /// The step ended.
    Done,
}

/// Demonstrations and their augmented sets.
#[derive(Debug, Clone)]
pub struct Pipeline {
    /// The demonstrations (train / test selection included).
    pub demos: Demonstrations,
    /// Training demonstrations under the training grid.
    pub train: AugmentedSet,
    /// Test demonstrations under the test grid.
    pub test: AugmentedSet,
    /// Training demonstrations under the test grid.
    pub reference: AugmentedSet,
    /// Wall time of the training augmentation (s).
    pub train_secs: f64,
    /// Wall time of the test augmentation (s).
    pub test_secs: f64,
}

/// Loads `[demonstrations]` and builds the augmented sets `splits` asks for, reporting
/// progress through `progress`.
pub fn build(
    cfg: &Config,
    kin: &Kinematics,
    splits: Splits,
    progress: &(dyn Fn(Progress<'_>) + Sync),
) -> Result<Pipeline, PipelineError> {
    let aug = augmentation(cfg)?;
    for (label, grid) in [("train", &aug.train), ("test", &aug.test)] {
        grid.validate()
            .map_err(|e| invalid(cfg, format!("[augmentation] {label}: {e}")))?;
    }
    let demos = cfg.load_demonstrations(kin)?;
    let (built, _) = crate::symmetry::check::build(kin, &cfg.symmetries)?;
    let augmenter = letter_augmenter(kin, &built, &cfg.composition.order)
        .map_err(|e| invalid(cfg, format!("[augmentation]: {e}")))?;
    for (label, grid) in [("train", &aug.train), ("test", &aug.test)] {
        augmenter
            .supports(grid)
            .map_err(|e| invalid(cfg, format!("[augmentation] {label}: {e}")))?;
    }
    let run = |label: &str, grid: &GroupGrid, which: &[usize]| {
        let sel = demos.select(which);
        progress(Progress::Start {
            label,
            tasks: sel.len() * grid.scales.len(),
        });
        let t = std::time::Instant::now();
        let set = augmenter.augment(&sel, grid, &|| progress(Progress::Tick));
        progress(Progress::Done);
        (set, t.elapsed().as_secs_f64())
    };
    let (train, train_secs) = if splits.train {
        run("augmenting train", &aug.train, &demos.train)
    } else {
        (AugmentedSet::default(), 0.0)
    };
    let (test, test_secs) = if splits.test {
        run("augmenting test", &aug.test, &demos.test)
    } else {
        (AugmentedSet::default(), 0.0)
    };
    let reference = if splits.reference {
        run("augmenting reference", &aug.test, &demos.train).0
    } else {
        AugmentedSet::default()
    };
    Ok(Pipeline {
        demos,
        train,
        test,
        reference,
        train_secs,
        test_secs,
    })
}

/// The canonical task-space features `[train] task_features` asks for (`None` without),
/// restricted to the sub-group `group` the policy is trained on.
pub fn task_features_for(
    cfg: &Config,
    kin: &Kinematics,
    built: &[BuiltSymmetry],
    tc: &TrainConfig,
    group: SubGroup,
) -> Result<Option<TaskFeatures>, PipelineError> {
    if !tc.task_features {
        return Ok(None);
    }
    let mut f = TaskFeatures::for_robot(kin, built, &cfg.composition.order)
        .map_err(|e| invalid(cfg, format!("[train] task_features: {e}")))?;
    f.restrict_to(group);
    Ok(Some(f))
}

/// Loads a policy and checks that it drives `kin`'s joints, in the same order, with the
/// same kinematics for its task features.
pub fn load_policy_for(kin: &Kinematics, file: &Path) -> Result<Policy, PipelineError> {
    let policy = Policy::load(file)?;
    let bad = |message: String| PipelineError::Invalid {
        path: file.to_path_buf(),
        message,
    };
    let names = match policy.meta.task_head {
        Some(_) => crate::policy::task_coordinate_names(kin),
        None => kin.joint_names().to_vec(),
    };
    if policy.meta.joint_names != names {
        return Err(bad(format!(
            "policy {} {:?} differ from the robot's {names:?}",
            if policy.meta.task_head.is_some() {
                "task coordinates"
            } else {
                "joints"
            },
            policy.meta.joint_names,
        )));
    }
    if let Some(t) = policy.task_features() {
        t.check_kinematics(kin).map_err(|e| bad(e.to_string()))?;
    }
    Ok(policy)
}

/// How canonicalised policies integrate their lifted flows: Dormand–Prince 5(4) at rtol
/// 1e-5, atol 1e-7, warm-started from the previous tick's step sizes (the "Canonicalised
/// policies" entries of bench/runs/ have the measurement behind the choice: fixed-step RK4
/// costs more for large angles and crosses singularities unnoticed; tighter tolerances cost
/// 2×).
pub fn canonical_integrator() -> LiftIntegrator {
    LiftIntegrator::Adaptive {
        settings: crate::symmetry::transfer::flow::FlowSettings {
            rtol: 1e-5,
            atol: 1e-7,
            warm_start: true,
            ..Default::default()
        },
    }
}

/// The configuration's composition `[composition] order` of its symmetries, as a
/// canonicalised policy stores it, integrated by `integrator`.
pub fn composition(
    cfg: &Config,
    kin: &Kinematics,
    integrator: LiftIntegrator,
) -> Result<ComposedSpec, PipelineError> {
    let (built, _) = crate::symmetry::check::build(kin, &cfg.symmetries)?;
    ComposedSpec::from_symmetries(kin, &built, &cfg.composition.order, integrator).map_err(|e| {
        invalid(
            cfg,
            format!("[composition] for a canonicalised policy: {e}"),
        )
    })
}

/// Canonicalises a plain policy by the configuration's composition (`π` is used as `π₀`,
/// at the identity condition).
pub fn canonicalise(
    cfg: &Config,
    kin: &Kinematics,
    mut policy: Policy,
) -> Result<AnyPolicy, PipelineError> {
    policy.meta.canonicalised = Some(composition(cfg, kin, canonical_integrator())?);
    AnyPolicy::new(policy, kin).map_err(|e| invalid(cfg, e))
}

/// Loads a policy of either kind ([`load_policy_for`]'s checks); a canonicalised one must
/// be canonicalised by the configuration's composition (same order, reflection and
/// task-space generators), else it is refused with what differs. A task head gets the
/// config's `[redundancy]` null-space term in its lift ([`Config::null_space_term`]).
pub fn load_any_policy(
    cfg: &Config,
    kin: &Kinematics,
    file: &Path,
) -> Result<AnyPolicy, PipelineError> {
    let policy = load_policy_for(kin, file)?;
    let bad = |message: String| PipelineError::Invalid {
        path: file.to_path_buf(),
        message,
    };
    let any = AnyPolicy::new(policy, kin).map_err(|e| bad(e.to_string()))?;
    if let Some(head) = any.task_head() {
        let want = group_map(cfg, kin, SubGroup::MRT)?;
        let own = head.map();
        let same = |a: bool, b: bool| !a || b;
        if !(own.dim == want.dim
            && same(own.reflection.is_some(), own.reflection == want.reflection)
            && same(own.rotation.is_some(), own.rotation == want.rotation)
            && same(own.scaling.is_some(), own.scaling == want.scaling))
        {
            return Err(bad(format!(
                "the task head acts on X by another group than the config's `[composition]` \
                 (config {})",
                cfg.path.display()
            )));
        }
    }
    if let Some(own) = any.composition() {
        let want = composition(cfg, kin, own.integrator)?;
        any.check_composition(&want)
            .map_err(|e| bad(format!("{e} (config {})", cfg.path.display())))?;
    }
    // `[redundancy]`: the null-space term joins a task head's lift (other policies have no
    // lift to add it to and are left as they are).
    let term = cfg
        .null_space_term(kin)
        .map_err(|e| bad(format!("{e} (config {})", cfg.path.display())))?;
    match term {
        Some(term) => Ok(any.with_null_space(term).map_err(|e| bad(e.to_string()))?.0),
        None => Ok(any),
    }
}

/// The nominal trajectories of `demo` under each of `conditions` for the task of `cfg`
/// (`[[symmetries]]`, `[composition]`), in the order given
/// ([`crate::data::augmentation::nominal_trajectories`]).
pub fn nominal_trajectories(
    cfg: &Config,
    kin: &Kinematics,
    demo: &JointTrajectory,
    conditions: &[Condition],
) -> Result<Vec<crate::data::augmentation::Augmented>, String> {
    let (built, _) =
        crate::symmetry::check::build(kin, &cfg.symmetries).map_err(|e| e.to_string())?;
    crate::data::augmentation::nominal_trajectories(
        kin,
        &built,
        &cfg.composition.order,
        demo,
        conditions,
    )
}

/// Demonstration number `which` (1-based) of `demos`, by default the first test one.
pub fn pick_demo(
    demos: &Demonstrations,
    which: Option<usize>,
) -> Result<&JointTrajectory, PipelineError> {
    let missing = |which: Option<usize>| PipelineError::NoDemonstration {
        which,
        count: demos.demos.len(),
        names: demos.names.join(", "),
    };
    let which = which
        .or_else(|| demos.test.first().copied())
        .ok_or_else(|| missing(None))?;
    demos
        .demos
        .iter()
        .find(|d| d.demo == which)
        .ok_or_else(|| missing(Some(which)))
}

#[cfg(feature = "teach")]
/// What [`train`] produced.
#[derive(Debug)]
pub struct Trained {
    /// The policy (not yet saved).
    pub policy: Policy,
    /// Loss and timing.
    pub report: TrainReport,
    /// Augmented trajectories trained on.
    pub trajectories: usize,
}

#[cfg(feature = "teach")]
/// Trains a policy on the training demonstrations augmented with sub-group `group` under
/// `tc` (usually `[train]`, iterations possibly overridden); `on_iteration(it, loss)` is
/// called as training goes.
pub fn train(
    cfg: &Config,
    kin: &Kinematics,
    p: &Pipeline,
    group: SubGroup,
    tc: &TrainConfig,
    on_iteration: impl FnMut(usize, f64),
) -> Result<Trained, PipelineError> {
    let data: Vec<_> = p
        .train
        .subset(group)
        .into_iter()
        .map(|a| (&a.traj, a.condition))
        .collect();
    let symmetry = serde_json::json!({
        "group": group.label(),
        "order": cfg.composition.order,
        "grid": cfg.augmentation.as_ref().map(|a| serde_json::to_value(&a.train).unwrap_or_default()),
    });
    let meta = PolicyMeta::new(&kin.robot, kin.joint_names().to_vec(), symmetry);
    let (built, _) = crate::symmetry::check::build(kin, &cfg.symmetries)?;
    let features = task_features_for(cfg, kin, &built, tc, group)?;
    let (policy, report) =
        crate::train::train_with_features(&data, tc, meta, features, on_iteration)?;
    Ok(Trained {
        policy,
        report,
        trajectories: data.len(),
    })
}

#[cfg(feature = "teach")]
/// Trains `π₀` on the original demonstrations (identity condition) and canonicalises it by
/// the configuration's composition (issue 18): the policy file's sidecar records the
/// composition ([`PolicyMeta::canonicalised`]) and every consumer evaluates
/// `π(q, s) = dΦ_g|_{q₀} π₀(q₀)`, `q₀ = Φ_g⁻¹(q)`: exactly equivariant by construction,
/// for any condition whose flows are feasible, with no augmentation.
pub fn train_equivariant(
    cfg: &Config,
    kin: &Kinematics,
    p: &Pipeline,
    tc: &TrainConfig,
    on_iteration: impl FnMut(usize, f64),
) -> Result<Trained, PipelineError> {
    let composition = composition(cfg, kin, canonical_integrator())?;
    let mut trained = train(cfg, kin, p, SubGroup::Identity, tc, on_iteration)?;
    let meta = &mut trained.policy.meta;
    meta.symmetry = serde_json::json!({
        "group": SubGroup::Identity.label(),
        "order": cfg.composition.order,
        "grid": serde_json::Value::Null,
        "canonicalised": true,
    });
    meta.canonicalised = Some(composition);
    Ok(trained)
}

/// The action on `X` of sub-group `group` of the configuration's letter group
/// (`[composition]`): the inverse map a task head is canonicalised by.
pub fn group_map(
    cfg: &Config,
    kin: &Kinematics,
    group: SubGroup,
) -> Result<CanonicalMap, PipelineError> {
    let (built, _) = crate::symmetry::check::build(kin, &cfg.symmetries)?;
    let mut f = TaskFeatures::for_robot(kin, &built, &cfg.composition.order)
        .map_err(|e| invalid(cfg, format!("[composition] for a task head: {e}")))?;
    f.restrict_to(group);
    Ok(f.spec().map.clone())
}

#[cfg(feature = "teach")]
/// Trains a task-space head `h` on the original demonstrations' task paths (identity
/// condition; `[train]` with task features off, as `h` reads the task point itself) and
/// writes it canonicalised by `group`'s action on `X` and lifted to `Q` (issue 17,
/// [`crate::policy::TaskHeadPolicy`]): `π(q, s) = J⁺(q) Dg(s) h(g(s)⁻¹ f(q))`, exactly
/// equivariant in `X` under `group` for every condition whose drawing the arms reach.
/// Augmented data would add nothing: canonicalised, it is the original data.
pub fn train_task_head(
    cfg: &Config,
    kin: &Kinematics,
    p: &Pipeline,
    group: SubGroup,
    tc: &TrainConfig,
    on_iteration: impl FnMut(usize, f64),
) -> Result<Trained, PipelineError> {
    let paths: Vec<JointTrajectory> = p
        .demos
        .select(&p.demos.train)
        .into_iter()
        .map(crate::policy::task_path_trajectory)
        .collect();
    let data: Vec<_> = paths.iter().map(|t| (t, Condition::IDENTITY)).collect();
    let meta = PolicyMeta::new(
        &kin.robot,
        crate::policy::task_coordinate_names(kin),
        serde_json::Value::Null,
    );
    let tc = TrainConfig {
        task_features: false,
        ..tc.clone()
    };
    let (head, report) = crate::train::train(&data, &tc, meta, on_iteration)?;
    Ok(Trained {
        policy: task_head_for(cfg, kin, &head, group)?,
        report,
        trajectories: data.len(),
    })
}

/// The task head `head` (a network over `X`) canonicalised by sub-group `group`'s action
/// on `X` (its sidecar records the map, the group and, below the whole group, the
/// training grid restricted to it, which the node's condition box is built from). The
/// four Table II policies of a task head share one network.
pub fn task_head_for(
    cfg: &Config,
    kin: &Kinematics,
    head: &Policy,
    group: SubGroup,
) -> Result<Policy, PipelineError> {
    let mut policy = head.clone();
    let grid = (group != SubGroup::MRT)
        .then_some(cfg.augmentation.as_ref())
        .flatten()
        .map(|a| serde_json::to_value(&a.train).unwrap_or_default());
    policy.meta.symmetry = serde_json::json!({
        "group": group.label(),
        "order": cfg.composition.order,
        "grid": grid,
        "task_head": true,
    });
    policy.meta.task_head = Some(group_map(cfg, kin, group)?);
    policy.meta.canonicalised = None;
    AnyPolicy::new(policy.clone(), kin).map_err(|e| invalid(cfg, e))?;
    Ok(policy)
}

/// Writes `text` to `dir/name`, creating `dir` as needed; returns the path.
pub fn write_text(dir: &Path, name: &str, text: &str) -> Result<PathBuf, PipelineError> {
    let path = dir.join(name);
    create_parent(&path)?;
    std::fs::write(&path, text).map_err(|e| PipelineError::Write {
        path: path.clone(),
        message: e.to_string(),
    })?;
    Ok(path)
}

/// Creates the parent directory of `file` (if any).
pub fn create_parent(file: &Path) -> Result<(), PipelineError> {
    if let Some(dir) = file.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| PipelineError::Write {
            path: dir.to_path_buf(),
            message: e.to_string(),
        })?;
    }
    Ok(())
}
