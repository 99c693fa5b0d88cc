//! The one integration-test binary (ripgrep style): shared fixtures in `common`,
//! one module per concept.

mod augmentation;
mod bag;
mod canonical;
mod check;
mod common;
mod data;
mod dds;
mod demo;
mod descend;
mod docs;
mod equivariant;
mod equivariant_node;
mod eval;
mod faults;
mod kinematics;
mod load;
// Needs the `teach` feature (training, LeRobot datasets, SQLite3 bags; CI: --all-features).
#[cfg(feature = "teach")]
mod lerobot;
mod lifecycle;
mod lift_compose;
mod morpho_robots;
mod operator;
mod operator_services;
mod physics;
mod physics_faults;
mod pins;
// Needs the `teach` feature (training, LeRobot datasets, SQLite3 bags; CI: --all-features).
#[cfg(feature = "teach")]
mod policy;
mod rby1_tasks;
mod rclpy;
// Needs the `teach` feature (training, LeRobot datasets, SQLite3 bags; CI: --all-features).
#[cfg(feature = "teach")]
mod recordings;
mod redundancy;
mod reference;
mod ros;
mod ros_args;
mod safety;
// Needs the `security` feature (SROS2 keystores, OpenSSL; CI: --all-features).
#[cfg(feature = "security")]
mod security;
mod servo;
mod sim;
#[path = "../support/skip.rs"]
mod skip;
mod task_induced;
// Needs the `teach` feature (training, LeRobot datasets, SQLite3 bags; CI: --all-features).
#[cfg(feature = "teach")]
mod teach;
