//! Configuration files (TOML): raw text → validated, typed configuration.
//!
//! A file is parsed once at startup; relative paths inside it (the URDF) resolve
//! against the directory of the file, like Cargo manifests. Every error names the
//! file and the key that is wrong.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::control::NodeConfig;
use crate::data::augmentation::AugmentationConfig;
use crate::data::demonstrations::DemonstrationsConfig;
use crate::data::letters::LetterTaskConfig;
use crate::eval::EvalConfig;
use crate::kinematics::{ChainSpec, Kinematics, KinematicsError, KinematicsSettings, RobotModel};
use crate::policy::TrainConfig;
use crate::symmetry::spec::{CheckConfig, CompositionConfig, SymmetryConfig};

/// Errors while reading or validating a configuration file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read config {path}: {source}")]
    Io {
        /// Config path.
        path: PathBuf,
        /// Underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The TOML is malformed or has unknown/mistyped keys.
    #[error("invalid config {path}: {message}")]
    Parse {
        /// Config path.
        path: PathBuf,
        /// Parser message (with line and column).
        message: String,
    },
    /// The robot section does not describe a valid robot.
    #[error("config {path}: {source}")]
    Robot {
        /// Config path.
        path: PathBuf,
        /// What the kinematics layer rejected.
        #[source]
        source: KinematicsError,
    },
}

/// Overrides of one joint's limits (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct LimitOverride {
    /// Velocity limit (rad/s or m/s).
    pub velocity: Option<f64>,
    /// Acceleration limit (rad/s² or m/s²); supplies one where the URDF has none.
    pub acceleration: Option<f64>,
    /// Lower position limit (rad or m), inside the URDF's range: narrows the range the
    /// safety filter keeps the joint in (e.g. a workcell); per joint only (not in `hardware_limits`).
    pub lower: Option<f64>,
    /// Upper position limit (rad or m), inside the URDF's range.
    pub upper: Option<f64>,
}

/// `[redundancy]`: the null-space term of task-space heads' lift,
/// `(I − J⁺J) v₀(q)`, toward a rest posture and away from the limits
/// ([`crate::kinematics::null_space`]). Absent or `weight = 0`: the plain lift.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RedundancyConfig {
    /// Gain of the pull toward the rest posture (1/s); 0: off.
    #[serde(default)]
    pub weight: f64,
    /// Width of the band at each limit where the limit term acts (fraction of the range).
    #[serde(default = "default_limit_band")]
    pub limit_band: f64,
    /// Gain of the limit term relative to the rest term.
    #[serde(default = "default_limit_gain")]
    pub limit_gain: f64,
    /// The rest posture (rad or m, one per controlled joint); default: the config's start
    /// posture (`[mock_hw] initial_q`, else `[check] reference_q`), else mid-range.
    #[serde(default)]
    pub rest: Option<Vec<f64>>,
}

fn default_limit_band() -> f64 {
    crate::kinematics::NullSpaceSettings::default().limit_band
}

fn default_limit_gain() -> f64 {
    crate::kinematics::NullSpaceSettings::default().limit_gain
}

impl Default for RedundancyConfig {
    fn default() -> Self {
        Self {
            weight: 0.0,
            limit_band: default_limit_band(),
            limit_gain: default_limit_gain(),
            rest: None,
        }
    }
}

impl RedundancyConfig {
    /// The settings part.
    pub fn settings(&self) -> crate::kinematics::NullSpaceSettings {
        crate::kinematics::NullSpaceSettings {
            weight: self.weight,
            limit_band: self.limit_band,
            limit_gain: self.limit_gain,
        }
    }
}

/// `[robot]`: which URDF, which chains, which joints are held fixed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotConfig {
    /// URDF path, relative to the config file's directory unless absolute.
    pub urdf: PathBuf,
    /// Kinematic chains, stacked in this order to form `Q` and `X`.
    pub chains: Vec<ChainSpec>,
    /// Movable joints outside the controlled set held at these values (rad or m).
    #[serde(default)]
    pub held: BTreeMap<String, f64>,
    /// Per-joint limit overrides.
    #[serde(default)]
    pub limits: BTreeMap<String, LimitOverride>,
    /// Limits of the robot's hardware interface, applied to every joint of the URDF where
    /// they are tighter than the URDF's (e.g. RB-Y1's ros2_control hardware streams targets
    /// under 4.712 rad/s and 1.0 rad/s²): the safety filter then never commands what the
    /// hardware would clip. Per-joint `limits` apply after these.
    #[serde(default)]
    pub hardware_limits: Option<LimitOverride>,
    /// The URDF's `<robot name>` this configuration was made for (a vendor names its
    /// versions there, e.g. `RBY1_A_v1.0`); a URDF of another name is refused, since robot
    /// versions differ in joint origins, limits and axes.
    #[serde(default)]
    pub urdf_name: Option<String>,
}

/// A loaded robot: the URDF model (with overrides applied) and its chain kinematics.
#[derive(Debug, Clone)]
pub struct LoadedRobot {
    /// The URDF tree.
    pub model: RobotModel,
    /// The stacked chains with the pseudo-inverse settings.
    pub kinematics: Kinematics,
}

impl RobotConfig {
    /// Loads the URDF (resolved against `base_dir`) and builds the kinematics.
    pub fn load(
        &self,
        base_dir: &Path,
        settings: &KinematicsSettings,
    ) -> Result<LoadedRobot, KinematicsError> {
        let path = if self.urdf.is_absolute() {
            self.urdf.clone()
        } else {
            base_dir.join(&self.urdf)
        };
        let mut model = RobotModel::from_urdf_file(&path)?;
        if let Some(want) = &self.urdf_name {
            if &model.name != want {
                return Err(KinematicsError::InvalidSetting {
                    field: "robot.urdf_name".into(),
                    message: format!(
                        "the config is for the robot `{want}`, but {} describes `{}` (robot \
                         versions differ in joint origins, limits and axes: point `urdf` at the \
                         URDF of your robot's version, or use a config made for it)",
                        path.display(),
                        model.name
                    ),
                });
            }
        }
        if let Some(hw) = &self.hardware_limits {
            if hw.lower.is_some() || hw.upper.is_some() {
                return Err(KinematicsError::InvalidSetting {
                    field: "robot.hardware_limits".into(),
                    message: "position limits are per joint: give them in [robot.limits]".into(),
                });
            }
            let movable: Vec<(String, f64, Option<f64>)> = model
                .joints
                .iter()
                .filter(|j| j.kind.is_movable())
                .map(|j| (j.name.clone(), j.limits.velocity, j.limits.acceleration))
                .collect();
            for (joint, v, a) in movable {
                if let Some(h) = hw.acceleration {
                    if a.is_none_or(|a| h < a) {
                        model.set_acceleration_limit(&joint, h)?;
                    }
                }
                if let Some(h) = hw.velocity {
                    if h < v {
                        model.set_velocity_limit(&joint, h)?;
                    }
                }
            }
        }
        for (joint, o) in &self.limits {
            if let Some(a) = o.acceleration {
                model.set_acceleration_limit(joint, a)?;
            }
            if let Some(v) = o.velocity {
                model.set_velocity_limit(joint, v)?;
            }
            if o.lower.is_some() || o.upper.is_some() {
                model.narrow_position_limits(joint, o.lower, o.upper)?;
            }
        }
        let held: HashMap<String, f64> = self.held.iter().map(|(k, v)| (k.clone(), *v)).collect();
        let kinematics = Kinematics::new(&model, &self.chains, &held, settings)?;
        Ok(LoadedRobot { model, kinematics })
    }
}

/// A whole configuration file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Config {
    /// The robot and its chains.
    pub robot: RobotConfig,
    /// Pseudo-inverse settings (damping, metric, singularity threshold).
    #[serde(default)]
    pub kinematics: KinematicsSettings,
    /// Symmetries of the task and robot (`[[symmetries]]`).
    #[serde(default)]
    pub symmetries: Vec<SymmetryConfig>,
    /// How the symmetries are composed (`[composition]`).
    #[serde(default)]
    pub composition: CompositionConfig,
    /// Where conditions are tested numerically (`[check]`).
    #[serde(default)]
    pub check: CheckConfig,
    /// Demonstrations (`[demonstrations]`: letters, reaches, recordings, CSV files).
    #[serde(default)]
    pub demonstrations: Option<DemonstrationsConfig>,
    /// A legacy `[letters]` section, converted into `demonstrations` when the file is
    /// parsed (so always `None` afterwards).
    #[serde(default, rename = "letters", skip_serializing)]
    legacy_letters: Option<LetterTaskConfig>,
    /// Augmentation grids (`[augmentation]`).
    #[serde(default)]
    pub augmentation: Option<AugmentationConfig>,
    /// Policy training (`[train]`).
    #[serde(default)]
    pub train: Option<TrainConfig>,
    /// Training of a task-space head (`[train_task_head]`, `crossym train --task-head`;
    /// absent: `[train]`). Task features are always off: the head reads the task point.
    #[serde(default)]
    pub train_task_head: Option<TrainConfig>,
    /// Evaluation (`[eval]`).
    #[serde(default)]
    pub eval: EvalConfig,
    /// The ROS 2 node (`[node]`).
    #[serde(default)]
    pub node: Option<NodeConfig>,
    /// The mock hardware (`[mock_hw]`).
    #[serde(default)]
    pub mock_hw: Option<crate::sim::MockHwConfig>,
    /// Redundancy resolution of task-space heads (`[redundancy]`).
    #[serde(default)]
    pub redundancy: Option<RedundancyConfig>,
    /// Directory of the file, for resolving relative paths (not read from TOML).
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// Path of the file (not read from TOML).
    #[serde(skip)]
    pub path: PathBuf,
}

impl Config {
    /// Reads and parses a config file.
    pub fn from_file(path: impl AsRef<Path>) -> Result<Self, ConfigError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let mut cfg = Self::from_toml_str(&text, path)?;
        cfg.base_dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        Ok(cfg)
    }

    /// Parses TOML text; `path` labels errors.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Self, ConfigError> {
        let mut cfg: Self = toml::from_str(text).map_err(|e| ConfigError::Parse {
            path: path.to_path_buf(),
            message: e.to_string(),
        })?;
        cfg.path = path.to_path_buf();
        if let Some(l) = cfg.legacy_letters.take() {
            if cfg.demonstrations.is_some() {
                return Err(ConfigError::Parse {
                    path: path.to_path_buf(),
                    message: "both [letters] and [demonstrations]: [letters] is the old \
                              name of a [demonstrations] source; keep one"
                        .into(),
                });
            }
            cfg.demonstrations = Some(DemonstrationsConfig::from_letters(&l));
        }
        if let Some(d) = &cfg.demonstrations {
            d.validate().map_err(|m| ConfigError::Parse {
                path: path.to_path_buf(),
                message: format!("[demonstrations]: {m}"),
            })?;
        }
        Ok(cfg)
    }

    /// The joint posture (rad or m, controlled joints in order) a simulated robot starts
    /// from: `[mock_hw] initial_q`, else `[check] reference_q`; `None` when neither is set.
    pub fn start_q(&self) -> Option<Vec<f64>> {
        self.mock_hw
            .as_ref()
            .and_then(|m| m.initial_q.clone())
            .or_else(|| self.check.reference_q.clone())
    }

    /// The null-space term of `[redundancy]` for `kin` (its limits), `None` when absent or
    /// off (`weight = 0`).
    pub fn null_space_term(
        &self,
        kin: &Kinematics,
    ) -> Result<Option<crate::kinematics::NullSpaceTerm>, crate::kinematics::NullSpaceError> {
        let Some(r) = self.redundancy.as_ref() else {
            return Ok(None);
        };
        let settings = r.settings();
        settings.validate()?;
        if !settings.enabled() {
            return Ok(None);
        }
        let rest = r
            .rest
            .clone()
            .or_else(|| self.start_q().filter(|q| q.len() == kin.dof()))
            .unwrap_or_else(|| kin.limits().iter().map(|l| l.centre()).collect());
        crate::kinematics::NullSpaceTerm::new(settings, &rest, kin.limits()).map(Some)
    }

    /// Resolves a path given in this config file (relative to the file's directory).
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.base_dir.join(p)
        }
    }

    /// `[node]` (defaults when absent) with its policy path resolved against the config
    /// file's directory; not yet validated (overrides may follow).
    pub fn node_config(&self) -> crate::control::NodeConfig {
        let mut n = self.node.clone().unwrap_or_default();
        if let Some(p) = &n.policy {
            n.policy = Some(self.resolve(p));
        }
        n
    }

    /// Loads the demonstrations of `[demonstrations]` for `kin` (paths relative to this
    /// file); an error naming the file when the section is absent.
    pub fn load_demonstrations(
        &self,
        kin: &Kinematics,
    ) -> Result<crate::data::demonstrations::Demonstrations, crate::data::DataError> {
        let d = self
            .demonstrations
            .as_ref()
            .ok_or_else(|| crate::data::DataError::Invalid {
                message: format!("{}: no [demonstrations] section", self.path.display()),
            })?;
        crate::data::demonstrations::Demonstrations::load(d, |p| self.resolve(p), kin)
    }

    /// Loads the robot of `[robot]` with the `[kinematics]` settings.
    pub fn load_robot(&self) -> Result<LoadedRobot, ConfigError> {
        self.robot
            .load(&self.base_dir, &self.kinematics)
            .map_err(|source| ConfigError::Robot {
                path: self.path.clone(),
                source,
            })
    }
}
