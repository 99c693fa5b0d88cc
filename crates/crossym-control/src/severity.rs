//! Severity of the node's log messages, a setting of the node ([`crate::NodeConfig`]).

/// Severity filter of the node's log, from `--log-level` or the environment.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// Everything, including per-message details.
    Debug,
    /// Events: startup, condition changes, transitions, shutdown (default).
    Info,
    /// Rejections, faults.
    Warn,
    /// Errors only.
    Error,
}

impl Severity {
    /// Parses `debug`, `info`, `warn`/`warning`, `error` (case-insensitive).
    pub fn parse(s: &str) -> Option<Self> {
        match s.trim().to_ascii_lowercase().as_str() {
            "debug" | "trace" => Some(Self::Debug),
            "info" => Some(Self::Info),
            "warn" | "warning" => Some(Self::Warn),
            "error" | "fatal" => Some(Self::Error),
            _ => None,
        }
    }

    /// The level from `RUST_LOG`: a `crossym=LEVEL` directive, else a bare `LEVEL`; `None`
    /// when it names neither.
    pub fn from_rust_log(v: &str) -> Option<Self> {
        let dirs: Vec<&str> = v.split(',').map(str::trim).collect();
        dirs.iter()
            .filter_map(|d| d.strip_prefix("crossym="))
            .find_map(Self::parse)
            .or_else(|| dirs.iter().find_map(|d| Self::parse(d)))
    }

    /// The label of console lines (`DEBUG`, `INFO`, `WARN`, `ERROR`).
    pub fn label(self) -> &'static str {
        match self {
            Self::Debug => "DEBUG",
            Self::Info => "INFO",
            Self::Warn => "WARN",
            Self::Error => "ERROR",
        }
    }
}
