//! # crossym — cross-space symmetry compositions for robot policies
//!
//! Implements *Symmetries Here and There, Combined Everywhere: Cross-space Symmetry
//! Compositions in Robotics* (Hadjiloizou, Pérez-Dattari, Jaquier): symmetries of a
//! robot's configuration space `Q` and task space `X` are transferred across the
//! forward kinematics `f: Q → X` (descended by equivariance, eq. 8; lifted by the
//! horizontal lift, eqs. 13–18), composed by direct or semi-direct products
//! (eqs. 19–23), and used to train symmetry-conditioned joint-space policies run by a
//! ROS 2 node.
//!
//! This crate is the application floor of a workspace whose crates depend only downward
//! (`docs/ARCHITECTURE.md`):
//!
//! | floor | crate | modules (re-exported here) |
//! |---|---|---|
//! | 5 app | `crossym` | [`config`], [`setup`], [`pipeline`], [`demo`], the CLI |
//! | 4 ROS 2 | [`crossym_ros`] | [`ros`] (DDS node, log, replay), [`sim`] (mock hardware, physics robot, stress) |
//! | 3 control | [`crossym_control`] | [`control`] (node core, real-time settings), [`safety`] |
//! | 2 learning | [`crossym_learn`] | [`data`], [`policy`], [`eval`] |
//! | 1 maths, formats | [`crossym_math`], [`crossym_io`] | [`kinematics`], [`symmetry`]; [`msg`], [`msgdef`], [`bag`] |
//!
//! Here only what needs a config file: [`config`] (TOML, validated once at startup),
//! [`setup`] (the floors' objects built from a config, with the command line's
//! overrides), [`pipeline`] (demonstrations → augmentation → training → evaluation, as
//! library calls) and [`demo`] (the closed loop of `crossym demo`: mock hardware and node
//! as processes, the conditions published over DDS, the report).
//!
//! ## Example: a configuration, read and checked
//!
//! Every key is in `docs/reference/config.md`; unknown keys are refused by name.
//!
//! ```
//! use std::path::{Path, PathBuf};
//!
//! use crossym::config::Config;
//!
//! let text = r#"
//!     [robot]
//!     urdf = "urdf/planar_dual_arm.urdf"
//!     chains = [{ name = "left", base = "base", tip = "left_ee", task = "xy" }]
//!
//!     [node]
//!     period_s = 0.002          # 500 Hz
//!     safety = { margin = 0.02 }
//! "#;
//! let mut cfg = Config::from_toml_str(text, Path::new("arm.toml"))?;
//! cfg.base_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")); // where `urdf` resolves
//! let robot = cfg.load_robot()?;
//! assert_eq!(robot.kinematics.dof(), 4);
//! let node = cfg.node_config(); // defaults for what the file leaves out
//! assert_eq!((node.period_s, node.safety.margin, node.stale_timeout_s), (0.002, 0.02, 0.1));
//!
//! let typo = text.replace("margin", "margn");
//! let refused = Config::from_toml_str(&typo, Path::new("arm.toml")).unwrap_err();
//! assert!(refused.to_string().contains("unknown field `margn`"));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub use crossym_control as control;
pub use crossym_control::safety;
#[cfg(feature = "teach")]
pub use crossym_io::lerobot;
pub use crossym_io::{bag, msg, msgdef};
#[cfg(feature = "teach")]
pub use crossym_learn::train;
pub use crossym_learn::{data, eval};
pub use crossym_math::{kinematics, symmetry};
pub use crossym_policy as policy;
pub use crossym_ros as ros;
pub use crossym_ros::sim;

pub mod config;
pub mod demo;
pub mod pipeline;
pub mod setup;
