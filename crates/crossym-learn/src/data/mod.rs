//! Demonstration data: the LASA handwriting letters of the paper's drawing experiment
//! (Sec. VI-A) and the MAT v5 reader for their original files.
//!
//! - [`lasa`]: [`LetterSet`] / [`Demonstration`] from CSV or MAT files (mm, s, mm/s).
//! - [`mat5`]: a small, defensive MATLAB MAT-file Level 5 reader ([`MatFile`], [`MatValue`]).
//! - [`letters`]: letters placed in the robot's workspace and tracked into joint space.
//! - [`augmentation`]: the lifted composed group applied to demonstrations (eq. 23).
//! - [`recording`]: joint-state recordings from rosbag2 bags (MCAP, SQLite3) by joint name.
//! - [`demonstrations`]: `[demonstrations]`, one schema for every source (LASA letters,
//!   reaches, rosbag2 recordings, CSV files), numbered and picked for training and testing.
//! - [`recorded`]: recordings cleaned into demonstrations with task paths and a report.
//! - [`clean`]: recordings → demonstrations (gaps, resampling, Savitzky–Golay velocities,
//!   idle trimming, splitting, limit margins).

pub mod augmentation;
pub mod clean;
pub mod demonstrations;
pub mod lasa;
pub mod letters;
pub mod mat5;
pub mod recorded;
pub mod recording;

pub use lasa::{DataError, Demonstration, LetterSet};
pub use mat5::{Mat5Error, MatFile, MatValue, MatVariable, NumericClass};
