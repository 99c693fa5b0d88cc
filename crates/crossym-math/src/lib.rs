//! # crossym-math — the maths floor of crossym
//!
//! Implements the geometry of *Symmetries Here and There, Combined Everywhere: Cross-space
//! Symmetry Compositions in Robotics* (Hadjiloizou, Pérez-Dattari, Jaquier): symmetries of
//! a robot's configuration space `Q` and task space `X` are transferred across the forward
//! kinematics `f: Q → X` (descended by equivariance, eq. 8; lifted by the horizontal lift,
//! eqs. 13–18) and composed by direct or semi-direct products (eqs. 19–23).
//!
//! - [`kinematics`]: URDF model, FK, Jacobian, metric pseudo-inverse.
//! - [`symmetry`]: groups, actions, transfer (descend / lift), composition, morphological
//!   symmetries of a URDF, and the numerical checks.
//!
//! This crate knows no task (letters, pans), no file format beyond URDF and its own TOML
//! specs, no network: every crate of the workspace sits above it.
//!
//! ## Example: a robot from a URDF, a task-space rotation lifted to its joints
//!
//! A planar arm of three 1 m links (`Q = T³`, its tip in `X = R²`: redundant by one). The
//! rotations of the plane about the origin (SO(2), Example 2) act on `X`; the horizontal
//! lift (eqs. 17–18) carries them to `Q`, and the lifted action is equivariant (eq. 19):
//! the tip of the moved arm is the rotated tip.
//!
//! ```
//! use std::collections::HashMap;
//!
//! use crossym_math::kinematics::{ChainSpec, Kinematics, KinematicsSettings, RobotModel, TaskSpace};
//! use crossym_math::symmetry::lie::{AffineAction, LieGroupSpec};
//! use crossym_math::symmetry::transfer::{flow::FlowSettings, lift::LiftedAction};
//!
//! const URDF: &str = r#"<robot name="arm3">
//!   <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="l3"/> <link name="tip"/>
//!   <joint name="j1" type="revolute"> <parent link="base"/> <child link="l1"/>
//!     <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
//!   <joint name="j2" type="revolute"> <parent link="l1"/> <child link="l2"/>
//!     <origin xyz="1 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
//!   <joint name="j3" type="revolute"> <parent link="l2"/> <child link="l3"/>
//!     <origin xyz="1 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2"/> </joint>
//!   <joint name="tool" type="fixed"> <parent link="l3"/> <child link="tip"/> <origin xyz="1 0 0"/> </joint>
//! </robot>"#;
//!
//! let model = RobotModel::from_urdf_str(URDF, "arm3.urdf")?;
//! let chains = [ChainSpec::new("arm", "base", "tip", TaskSpace::Xy)];
//! let kin = Kinematics::new(&model, &chains, &HashMap::new(), &KinematicsSettings::default())?;
//! assert_eq!((kin.dof(), kin.task_dim()), (3, 2));
//!
//! // SO(2) on the task plane (one 2-D block, about the origin), lifted through J⁺.
//! let rotation = AffineAction::new("R", LieGroupSpec::So2 { axis: None }, 2, 1, None)?;
//! let lifted = LiftedAction::new(&kin, &rotation, FlowSettings::default())?;
//! let (q, theta) = ([0.3, 0.6, -0.4], 0.5); // rad
//! let mut q_rotated = [0.0; 3];
//! lifted.act(&[theta], &q, &mut q_rotated, &mut lifted.workspace())?;
//!
//! let mut ws = kin.workspace();
//! let x = kin.forward(&q, &mut ws).clone();
//! let x_rotated = kin.forward(&q_rotated, &mut ws);
//! let (c, s) = (theta.cos(), theta.sin());
//! assert!((x_rotated[0] - (c * x[0] - s * x[1])).abs() < 1e-6);
//! assert!((x_rotated[1] - (s * x[0] + c * x[1])).abs() < 1e-6);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

pub mod kinematics;
pub mod symmetry;
