//! One demonstration schema for every source (`[demonstrations]`): LASA letters placed in
//! the workspace, synthetic reaches, rosbag2 joint-state recordings and CSV files, each
//! turned into joint-space demonstrations `(q_i, q̇_i, x_i = f(q_i))` sampled every `dt`,
//! numbered `1 … N` in source order and selected for training and testing by number or by
//! name.
//!
//! ```toml
//! [demonstrations]
//! dt = 0.01                          # s: sample period of every demonstration
//! train = ["pick_1", "pick_2"]       # names (a source: all its demonstrations) or numbers
//! test = ["pick_3"]
//! [[demonstrations.sources]]
//! name = "pick_1"
//! bag = "recordings/pick_1"          # rosbag2 directory (metadata.yaml + .mcap or .db3)
//! topic = "/joint_states"            # default
//! ```
//!
//! Source kinds (`kind`, inferred from the keys when absent):
//! - `lasa` (`arms` with a `letter`): the letter task's placement and damped-least-squares
//!   tracking protocol ([`super::letters`]); one demonstration per LASA demonstration.
//! - `reach` (`arms` with `reach`): minimum-jerk reaches tracked the same way.
//! - `bag` (`bag`): a `sensor_msgs/JointState` topic of a rosbag2 bag, MCAP or SQLite3,
//!   read by joint name ([`super::recording`]) and cleaned ([`super::clean`]).
//! - `csv` (`csv`): a header row, an optional `t` column (s) and either one column per
//!   configured joint (joint positions, cleaned like a recording) or `<chain>.x`,
//!   `<chain>.y`(, `<chain>.z`) task columns sampled every `dt` (tracked from `start` like a
//!   letter; chains without columns hold their `start`).
//! - `lerobot` (`dataset`): a LeRobot dataset (v3.0 or v2.1), its state feature read by
//!   joint name, one demonstration per episode named `name#<episode_index>`, cleaned like a
//!   recording (`lerobot`).
//!
//! A source that yields one demonstration names it after itself; one that yields several
//! (a LASA file, reaches, a recording split at idle periods) names them `name#1 … name#k`.
//!
//! Files: [`config`] (the schema and its checks), [`load`] (every source loaded, numbered
//! and picked), `csv` (CSV sources).

pub mod config;
mod csv;
#[cfg(feature = "lerobot")]
mod lerobot;
pub mod load;

#[cfg(test)]
mod tests;

pub use config::{
    AngleUnit, DemonstrationsConfig, DemonstrationsConfigError, Pick, SourceConfig, SourceKind,
};
pub use load::{load_each, Demonstrations, SourceDemos, SourceDetail, SourceError};
