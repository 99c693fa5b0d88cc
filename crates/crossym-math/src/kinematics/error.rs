//! Errors of the kinematics module: URDF loading and chain construction.

use std::path::PathBuf;

/// What can go wrong while loading a robot model or building a kinematic chain.
///
/// Per-tick functions never return these; they are setup errors.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum KinematicsError {
    /// The URDF file could not be read from disk.
    #[error("cannot read URDF file {path}: {source}")]
    Io {
        /// File that was being read.
        path: PathBuf,
        /// Underlying I/O error.
        #[source]
        source: std::io::Error,
    },
    /// `urdf-rs` rejected the XML.
    #[error("malformed URDF {origin}: {message}")]
    Urdf {
        /// File name, or `<string>` when parsed from memory.
        origin: String,
        /// Parser message.
        message: String,
    },
    /// A `<joint>` element is inconsistent (unknown parent/child link, bad axis, bad limit, …).
    #[error("URDF {origin}: joint `{joint}`: {message}")]
    BadJoint {
        /// File name, or `<string>`.
        origin: String,
        /// Name of the offending joint element.
        joint: String,
        /// What is wrong with it.
        message: String,
    },
    /// The link graph is not a tree (a link with two parents, a cycle, several roots).
    #[error("URDF {origin}: link `{link}`: {message}")]
    BadTree {
        /// File name, or `<string>`.
        origin: String,
        /// Link where the problem was found.
        link: String,
        /// What is wrong.
        message: String,
    },
    /// A link name given in configuration is not in the model.
    #[error("unknown link `{link}` in robot `{robot}` (known links: {known})")]
    UnknownLink {
        /// Robot name from the URDF.
        robot: String,
        /// The name that was asked for.
        link: String,
        /// Comma-separated list of the model's links (truncated).
        known: String,
    },
    /// A joint name given in configuration is not in the model.
    #[error("unknown joint `{joint}` in robot `{robot}` (known joints: {known})")]
    UnknownJoint {
        /// Robot name from the URDF.
        robot: String,
        /// The name that was asked for.
        joint: String,
        /// Comma-separated list of the model's movable joints (truncated).
        known: String,
    },
    /// The requested base link is not an ancestor of the tip link.
    #[error("chain `{chain}`: link `{base}` is not an ancestor of `{tip}`")]
    NotAChain {
        /// Chain name from configuration.
        chain: String,
        /// Requested base link.
        base: String,
        /// Requested tip link.
        tip: String,
    },
    /// A chain has no movable joint.
    #[error("chain `{chain}` from `{base}` to `{tip}` has no movable joint")]
    EmptyChain {
        /// Chain name.
        chain: String,
        /// Base link.
        base: String,
        /// Tip link.
        tip: String,
    },
    /// Two chains of one robot share a movable joint.
    #[error("joint `{joint}` is movable in both chain `{first}` and chain `{second}`")]
    SharedJoint {
        /// Joint name.
        joint: String,
        /// First chain using it.
        first: String,
        /// Second chain using it.
        second: String,
    },
    /// A joint type this library does not model inside a chain (floating, planar, spherical).
    #[error("chain `{chain}`: joint `{joint}` has unsupported type {kind}")]
    UnsupportedJoint {
        /// Chain name.
        chain: String,
        /// Joint name.
        joint: String,
        /// URDF type.
        kind: String,
    },
    /// A configuration value is out of its domain (negative damping, non-SPD metric, NaN, …).
    #[error("invalid kinematics setting `{field}`: {message}")]
    InvalidSetting {
        /// Configuration key.
        field: String,
        /// Why it is invalid.
        message: String,
    },
}
