//! # crossym-control — the control floor of crossym
//!
//! Everything between a joint state and a command, without a network:
//! - [`safety`]: the QP joint-limit safety filter (active set, Clarabel as fallback);
//! - [`node`]: the node's logic: joint-state and condition validation ([`InputGate`]), the
//!   control tick `π(q, s)` → safety filter → command ([`NodeCore`]), stale-state handling
//!   and the status snapshot;
//! - [`realtime`]: the control thread's real-time settings (SCHED_FIFO, mlockall);
//! - `faults` (feature `fault-injection`): deliberate filter defects and policy overrides
//!   for tests and fault campaigns; a node's `NodeCore` never runs them.
//!
//! The DDS node, bag replay and the mock robots (crate `crossym-ros`) wrap [`NodeCore`];
//! everything here is testable without a network, and bag replay drives it bit for bit.
//!
//! ## Example: one control tick
//!
//! A two-link planar arm from a URDF string and a tiny policy `π(q, s)` (untrained: random
//! weights in the shape of a trained one). A joint state and a symmetry condition arrive as
//! the DDS node would hand them over; one tick runs the policy and the safety filter and
//! fills the command: joint velocities within the URDF's limits.
//!
//! ```
//! use std::collections::HashMap;
//!
//! use crossym_control::safety::SafetySettings;
//! use crossym_control::{NodeConfig, NodeCore, StatusCode};
//! use crossym_io::msg::{JointState, SymmetryCondition};
//! use crossym_policy::Policy;
//! use crossym_math::kinematics::{ChainSpec, Kinematics, KinematicsSettings, RobotModel, TaskSpace};
//!
//! const URDF: &str = r#"<robot name="arm2">
//!   <link name="base"/> <link name="l1"/> <link name="l2"/> <link name="tip"/>
//!   <joint name="j1" type="revolute"> <parent link="base"/> <child link="l1"/>
//!     <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2" acceleration="20"/> </joint>
//!   <joint name="j2" type="revolute"> <parent link="l1"/> <child link="l2"/>
//!     <origin xyz="1 0 0"/> <axis xyz="0 0 1"/> <limit lower="-3" upper="3" effort="10" velocity="2" acceleration="20"/> </joint>
//!   <joint name="tool" type="fixed"> <parent link="l2"/> <child link="tip"/> <origin xyz="1 0 0"/> </joint>
//! </robot>"#;
//!
//! let model = RobotModel::from_urdf_str(URDF, "arm2.urdf")?;
//! let chains = [ChainSpec::new("arm", "base", "tip", TaskSpace::Xy)];
//! let kin = Kinematics::new(&model, &chains, &HashMap::new(), &KinematicsSettings::default())?;
//! let joints = kin.joint_names().to_vec();
//! let policy = Policy::synthetic(2, joints.clone(), &[8], 7); // 2 joints, one hidden layer of 8
//! let mut node = NodeCore::new(kin, policy, SafetySettings::default(), NodeConfig::default())?;
//!
//! let t = 0.0; // s, the node's clock
//! let state = JointState { name: joints, position: vec![0.4, 1.2], ..Default::default() };
//! node.on_joint_state(&state, t).expect("a valid joint state");
//! let condition = SymmetryCondition { theta: 0.5, scale: 1.0, reflection: 1, ..Default::default() };
//! node.on_condition(&condition).expect("a valid condition (θ rad, λ, σ)");
//!
//! let mut command = node.command();
//! let report = node.tick(t + 0.001, &mut command);
//! assert!(report.publish && report.safety.is_some()); // the policy ran, the filter too
//! assert!(matches!(report.code, StatusCode::NoWarning | StatusCode::JointBound));
//! assert!(command.velocities.iter().all(|v| v.is_finite() && v.abs() <= 2.0)); // rad/s
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]
// Numerical kernels index several arrays with one loop variable; iterator chains obscure them.
#![allow(clippy::needless_range_loop)]

#[cfg(feature = "fault-injection")]
pub mod faults;
pub mod node;
pub mod realtime;
pub mod safety;
pub mod severity;

pub use node::{
    Command, InputGate, Inputs, NodeConfig, NodeCore, NodeError, OperatorRefusal, OperatorRequest,
    OutputMode, Rejection, RuntimeBounds, SingularitySettings, StatusCode, StatusSnapshot,
    TickReport, TopicNames, Trigger,
};
pub use severity::Severity;
