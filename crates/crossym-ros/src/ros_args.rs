//! Command-line ROS arguments (`--ros-args …`), read as rcl reads them, so that the node
//! starts from a ROS 2 launch file: `launch_ros`'s `Node(...)` runs
//! `crossym node --config c.toml --ros-args -r __node:=NAME -r __ns:=/NS --params-file F … -r from:=to`.
//!
//! The grammar is rcl's (`rcl/src/rcl/arguments.c`, `rcl_yaml_param_parser`), read, not
//! ported:
//! - everything after `--ros-args` up to `--` or the end is a ROS argument; there may be
//!   several `--ros-args` blocks, and the arguments outside them are the program's own;
//! - `-r`/`--remap [node:]from:=to` (`rostopic://` / `rosservice://` restrict a rule to
//!   topics or services), `__node:=` / `__name:=` (node name), `__ns:=` (namespace);
//! - `-p`/`--param [node:]name:=value`, the value a YAML scalar or sequence typed as rcl
//!   types them ([`scalar_value`]): `true`/`yes`/`on` … bool, `5`/`0x1F`/`010` integer, `0.5`/
//!   `.inf` double, anything else (or quoted, or `!!str`) a string; a sequence is an array of
//!   its first element's type and must not mix types;
//! - `--params-file FILE`: `<node>: {ros__parameters: {…}}` with `<node>` a name (`crossym`),
//!   a path (`/robot1/crossym`), nested keys (`robot1: {crossym: {…}}`) or wildcards
//!   (`/**`, `/*`, `/robot1/*`); nested parameter maps are flattened with `.`
//!   (`safety: {margin: 0.1}` → `safety.margin`);
//! - `--log-level [logger:=]LEVEL`, `--log-file-name`, `--log-config-file`, `-e`/`--enclave`
//!   (SROS2's enclave: [`crate::sros2`]), `--enable-`/`--disable-{stdout,rosout,external-lib}-logs`;
//! - anything else after `--ros-args` is refused, naming the argument.
//!
//! Parameters are kept as rcl keeps them: one table per node name as written, in order of
//! first appearance, files and `-p` rules in command-line order (a later value of a name in
//! the same table replaces the earlier one); a node takes the tables whose name matches its
//! fully qualified name, later tables over earlier ones, as rclcpp resolves them
//! ([`ParamOverrides::for_node`]). Rules that name another node are ignored. Remap rules
//! apply first match first, on the fully expanded names ([`RosArgs::remap_topic`]).
//!
//! Not covered: the deprecated remap rules outside `--ros-args` (`from:=to` alone), the
//! `{node}`/`{ns}` substitutions in topic names, hexadecimal floats and `nan(…)` in values.

use std::fmt;
use std::path::{Path, PathBuf};

use crossym_control::{NodeConfig, NodeCore, NodeError};
use ros2_client::ParameterValue;
use saphyr_parser::{Event, Parser, ScalarStyle, StrInput};

use crate::dds::expand_topic;
use crate::node::{apply_start_value, check_start_parameter, StartParamRefusal};
use crossym_control::Severity;

/// The argument that starts a block of ROS arguments.
pub const ROS_ARGS_FLAG: &str = "--ros-args";
/// The argument that ends one.
pub const ROS_ARGS_END: &str = "--";
/// The key under a node name that holds its parameters.
const PARAMS_KEY: &str = "ros__parameters";
/// The node table of a `-p` rule without a node prefix.
const ALL_NODES: &str = "/**";

/// Why the ROS arguments could not be read. `position` is the argument's index in the
/// command line (the program's name is argument 0).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RosArgsError {
    /// A flag that takes a value is the last argument.
    #[error("ROS argument {position} `{flag}`: {what} must follow it")]
    MissingValue {
        /// Position of the flag.
        position: usize,
        /// The flag.
        flag: String,
        /// What it takes.
        what: &'static str,
    },
    /// An argument after `--ros-args` that rcl does not know.
    #[error(
        "ROS argument {position}: unknown ROS argument `{arg}` (after --ros-args: -r/--remap, \
         -p/--param, --params-file, --log-level, --log-file-name, --log-config-file, \
         -e/--enclave, --enable-/--disable-stdout-logs, -rosout-logs, -external-lib-logs; \
         `--` ends the ROS arguments)"
    )]
    Unknown {
        /// Its position.
        position: usize,
        /// The argument.
        arg: String,
    },
    /// A `-r` rule rcl would not parse.
    #[error("ROS argument {position}: remap rule `{rule}`: {reason}")]
    Remap {
        /// Position of the rule.
        position: usize,
        /// The rule.
        rule: String,
        /// What is wrong.
        reason: String,
    },
    /// A `-p` rule rcl would not parse.
    #[error("ROS argument {position}: parameter rule `{rule}`: {reason}")]
    Param {
        /// Position of the rule.
        position: usize,
        /// The rule.
        rule: String,
        /// What is wrong.
        reason: String,
    },
    /// A `--log-level` value rcl would not parse.
    #[error("ROS argument {position}: --log-level `{rule}`: {reason}")]
    LogLevel {
        /// Position of the value.
        position: usize,
        /// The value.
        rule: String,
        /// What is wrong.
        reason: String,
    },
    /// A `--params-file` that cannot be read.
    #[error("ROS argument {position}: --params-file {}: {reason}", path.display())]
    ParamsFile {
        /// Position of the path.
        position: usize,
        /// The file.
        path: PathBuf,
        /// What went wrong.
        reason: String,
    },
    /// A `--params-file` that is not a parameters file as rcl reads them.
    #[error("ROS argument {position}: --params-file {}, line {line}: {reason}", path.display())]
    ParamsYaml {
        /// Position of the path.
        position: usize,
        /// The file.
        path: PathBuf,
        /// Line (1-based).
        line: usize,
        /// What is wrong.
        reason: String,
    },
}

/// What a remap rule renames.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemapKind {
    /// `from:=to`: topics and services.
    Name,
    /// `rostopic://from:=to`.
    Topic,
    /// `rosservice://from:=to`.
    Service,
    /// `__node:=name` (or `__name:=`).
    NodeName,
    /// `__ns:=/namespace`.
    Namespace,
}

/// One `-r` rule.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RemapRule {
    /// `node:` prefix: the rule applies to that node only.
    pub node: Option<String>,
    /// What it renames.
    pub kind: RemapKind,
    /// The name matched (as written; empty for node name and namespace rules).
    pub from: String,
    /// The replacement (a namespace without its trailing `/`).
    pub to: String,
    /// Position of the rule on the command line.
    pub position: usize,
}

impl RemapRule {
    fn applies_to(&self, node: &str) -> bool {
        self.node.as_deref().is_none_or(|n| n == node)
    }
}

impl fmt::Display for RemapRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(n) = &self.node {
            write!(f, "{n}:")?;
        }
        match self.kind {
            RemapKind::Name => write!(f, "{}:={}", self.from, self.to),
            RemapKind::Topic => write!(f, "rostopic://{}:={}", self.from, self.to),
            RemapKind::Service => write!(f, "rosservice://{}:={}", self.from, self.to),
            RemapKind::NodeName => write!(f, "__node:={}", self.to),
            RemapKind::Namespace => write!(f, "__ns:={}", self.to),
        }
    }
}

/// Where a parameter's value came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ParamOrigin {
    /// A `--params-file` (line of the value).
    File {
        /// The file as given.
        path: PathBuf,
        /// Line (1-based).
        line: usize,
    },
    /// A `-p` rule.
    Rule {
        /// Position of the rule on the command line.
        position: usize,
    },
}

impl fmt::Display for ParamOrigin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::File { path, line } => write!(f, "--params-file {}:{line}", path.display()),
            Self::Rule { position } => write!(f, "-p (ROS argument {position})"),
        }
    }
}

/// One parameter value given at start.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamOverride {
    /// Parameter name (nested keys joined with `.`).
    pub name: String,
    /// Its value, typed as rcl types it.
    pub value: ParameterValue,
    /// Where it came from.
    pub origin: ParamOrigin,
}

/// The parameters of one node name as written (`/**`, `crossym`, `/robot1/crossym`).
#[derive(Debug, Clone, PartialEq)]
pub struct NodeParams {
    /// The node name or pattern.
    pub node: String,
    /// Its parameters, in order of first appearance.
    pub params: Vec<ParamOverride>,
}

/// Every parameter given at start, per node name, as rcl keeps them (`rcl_params_t`).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParamOverrides {
    nodes: Vec<NodeParams>,
}

impl ParamOverrides {
    /// The tables in order of first appearance.
    pub fn nodes(&self) -> &[NodeParams] {
        &self.nodes
    }

    /// Sets `p` in the table of `node` (created at the end when new; a name already there
    /// keeps its place and takes the new value).
    fn set(&mut self, node: &str, p: ParamOverride) {
        let i = match self.nodes.iter().position(|n| n.node == node) {
            Some(i) => i,
            None => {
                self.nodes.push(NodeParams {
                    node: node.to_string(),
                    params: Vec::new(),
                });
                self.nodes.len() - 1
            }
        };
        let params = &mut self.nodes[i].params;
        match params.iter_mut().find(|q| q.name == p.name) {
            Some(q) => *q = p,
            None => params.push(p),
        }
    }

    /// The parameters of the node whose fully qualified name is `fqn` (`/robot1/arm`): the
    /// tables whose name matches it, in order, a later table's value over an earlier one's
    /// (rclcpp's `parameter_map_from` and `resolve_parameter_overrides`).
    pub fn for_node(&self, fqn: &str) -> Vec<ParamOverride> {
        let mut out: Vec<ParamOverride> = Vec::new();
        for table in self.nodes.iter().filter(|t| node_matches(&t.node, fqn)) {
            for p in &table.params {
                match out.iter_mut().find(|q| q.name == p.name) {
                    Some(q) => *q = p.clone(),
                    None => out.push(p.clone()),
                }
            }
        }
        out
    }
}

/// Whether the node name or pattern `pattern` (`/**` any depth, `/*` one name) names the
/// node `fqn`; a name without a leading `/` is read from the root, as rclcpp reads it.
pub fn node_matches(pattern: &str, fqn: &str) -> bool {
    fn glob(pat: &[&str], name: &[&str]) -> bool {
        match pat.split_first() {
            None => name.is_empty(),
            Some((&"**", rest)) => (0..=name.len()).any(|k| glob(rest, &name[k..])),
            Some((&"*", rest)) => !name.is_empty() && glob(rest, &name[1..]),
            Some((p, rest)) => name.first() == Some(p) && glob(rest, &name[1..]),
        }
    }
    let split = |s: &str| -> Vec<String> {
        s.split('/')
            .filter(|p| !p.is_empty())
            .map(str::to_string)
            .collect()
    };
    let pat = split(pattern);
    let name = split(fqn);
    let pat: Vec<&str> = pat.iter().map(String::as_str).collect();
    let name: Vec<&str> = name.iter().map(String::as_str).collect();
    glob(&pat, &name)
}

/// A log level as rcutils spells them (any case).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosLogLevel {
    /// `unset`: the default.
    Unset,
    /// `debug`.
    Debug,
    /// `info`.
    Info,
    /// `warn`.
    Warn,
    /// `error`.
    Error,
    /// `fatal` (the node logs errors only).
    Fatal,
}

impl RosLogLevel {
    /// rcutils' names, case-insensitive (`warning` is not one).
    pub fn parse(s: &str) -> Option<Self> {
        Some(match s.to_ascii_uppercase().as_str() {
            "UNSET" => Self::Unset,
            "DEBUG" => Self::Debug,
            "INFO" => Self::Info,
            "WARN" => Self::Warn,
            "ERROR" => Self::Error,
            "FATAL" => Self::Fatal,
            _ => return None,
        })
    }

    /// The node's severity for this level (`None`: unset, keep the default).
    pub fn severity(self) -> Option<Severity> {
        match self {
            Self::Unset => None,
            Self::Debug => Some(Severity::Debug),
            Self::Info => Some(Severity::Info),
            Self::Warn => Some(Severity::Warn),
            Self::Error | Self::Fatal => Some(Severity::Error),
        }
    }
}

/// The ROS arguments of a command line.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct RosArgs {
    /// `-r` rules in order.
    pub remaps: Vec<RemapRule>,
    /// `-p` rules and `--params-file` contents.
    pub params: ParamOverrides,
    /// The `--params-file` paths in order.
    pub params_files: Vec<PathBuf>,
    /// `--log-level LEVEL` (the last one).
    pub log_level: Option<RosLogLevel>,
    /// `--log-level logger:=LEVEL` (the last one per logger).
    pub logger_levels: Vec<(String, RosLogLevel)>,
    /// `--enclave`: SROS2's enclave ([`crate::sros2`]; `ROS_SECURITY_ENCLAVE_OVERRIDE` wins).
    pub enclave: Option<String>,
    /// `--log-file-name` (stored; the node writes no log file).
    pub log_file_name: Option<String>,
    /// `--log-config-file` (stored; not used).
    pub log_config_file: Option<PathBuf>,
    /// `--enable-`/`--disable-stdout-logs`.
    pub stdout_logs: Option<bool>,
    /// `--enable-`/`--disable-rosout-logs`.
    pub rosout_logs: Option<bool>,
    /// `--enable-`/`--disable-external-lib-logs`.
    pub external_lib_logs: Option<bool>,
}

/// A command line split into its ROS arguments and the program's own.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ParsedArgs {
    /// The ROS arguments.
    pub ros: RosArgs,
    /// The other arguments with their positions.
    pub rest: Vec<(usize, String)>,
}

impl RosArgs {
    /// Reads `args`, the command line from position `first` on (`first` = 1 for
    /// `std::env::args().skip(1)`): the ROS arguments of every `--ros-args` block, and the
    /// rest. Parameter files are read here, relative to the working directory.
    pub fn parse(args: &[String], first: usize) -> Result<ParsedArgs, RosArgsError> {
        let mut out = ParsedArgs::default();
        let mut in_ros = false;
        let mut i = 0;
        while i < args.len() {
            let position = first + i;
            let arg = args[i].as_str();
            if !in_ros {
                if arg == ROS_ARGS_FLAG {
                    in_ros = true;
                } else {
                    out.rest.push((position, arg.to_string()));
                }
            } else if arg == ROS_ARGS_END {
                in_ros = false;
            } else if arg != ROS_ARGS_FLAG {
                let value = args.get(i + 1).map(String::as_str);
                if out.ros.one(arg, value, position)? {
                    i += 1;
                }
            }
            i += 1;
        }
        Ok(out)
    }

    /// One ROS argument at `position` with the argument after it; `true` when it took that
    /// one as its value.
    fn one(
        &mut self,
        arg: &str,
        value: Option<&str>,
        position: usize,
    ) -> Result<bool, RosArgsError> {
        let need = |what: &'static str| {
            value.ok_or_else(|| RosArgsError::MissingValue {
                position,
                flag: arg.to_string(),
                what,
            })
        };
        let at = position + 1;
        match arg {
            "-r" | "--remap" => {
                let rule = need("a remap rule [node:]from:=to")?;
                self.remaps.push(parse_remap(rule, at)?);
            }
            "-p" | "--param" => {
                parse_param_rule(
                    need("a parameter rule [node:]name:=value")?,
                    at,
                    &mut self.params,
                )?;
            }
            "--params-file" => {
                let path = Path::new(need("a parameters file (YAML)")?);
                read_params_file(path, at, &mut self.params)?;
                self.params_files.push(path.to_path_buf());
            }
            "--log-level" => self.log_level_rule(need("a level [logger:=]LEVEL")?, at)?,
            "--log-file-name" => self.log_file_name = Some(need("a file name prefix")?.into()),
            "--log-config-file" => self.log_config_file = Some(need("a file")?.into()),
            "-e" | "--enclave" => self.enclave = Some(need("an enclave path")?.into()),
            _ => {
                let slot = match toggle(arg) {
                    Some(("stdout-logs", on)) => (&mut self.stdout_logs, on),
                    Some(("rosout-logs", on)) => (&mut self.rosout_logs, on),
                    Some(("external-lib-logs", on)) => (&mut self.external_lib_logs, on),
                    _ => {
                        return Err(RosArgsError::Unknown {
                            position,
                            arg: arg.to_string(),
                        })
                    }
                };
                *slot.0 = Some(slot.1);
                return Ok(false);
            }
        }
        Ok(true)
    }

    /// `--log-level LEVEL` or `--log-level logger:=LEVEL`.
    fn log_level_rule(&mut self, rule: &str, position: usize) -> Result<(), RosArgsError> {
        let err = |reason: &str| RosArgsError::LogLevel {
            position,
            rule: rule.to_string(),
            reason: reason.to_string(),
        };
        let bad_level = "not a level: unset, debug, info, warn, error or fatal (any case)";
        match rule.split_once(":=") {
            Some((logger, level)) => {
                if logger.is_empty() {
                    return Err(err("the logger name is empty"));
                }
                let level = RosLogLevel::parse(level).ok_or_else(|| err(bad_level))?;
                self.logger_levels.retain(|(l, _)| l != logger);
                self.logger_levels.push((logger.to_string(), level));
            }
            None => self.log_level = Some(RosLogLevel::parse(rule).ok_or_else(|| err(bad_level))?),
        }
        Ok(())
    }

    /// The node's name and namespace after the `__node` and `__ns` rules: the first rule
    /// that applies wins; a `node:` prefix of a `__node` rule names the node as the program
    /// names it, of an `__ns` rule as renamed (rcl's `rcl_node_init`).
    pub fn node_identity(&self, name: &str, namespace: &str) -> (String, String) {
        let first = |kind: RemapKind, node: &str| {
            self.remaps
                .iter()
                .find(|r| r.kind == kind && r.applies_to(node))
                .map(|r| r.to.clone())
        };
        let name = first(RemapKind::NodeName, name).unwrap_or_else(|| name.to_string());
        let namespace = first(RemapKind::Namespace, &name).unwrap_or_else(|| namespace.to_string());
        (name, namespace)
    }

    /// The topic `topic` of node `name` in `namespace` after the remap rules: the first
    /// topic rule for this node whose match, expanded, is the expanded topic gives its
    /// expanded replacement (`rcl_remap_topic_name`); `None` when no rule matches.
    pub fn remap_topic(
        &self,
        topic: &str,
        namespace: &str,
        name: &str,
    ) -> Option<(String, &RemapRule)> {
        self.remap(RemapKind::Topic, topic, namespace, name)
    }

    /// The service `service` after the remap rules (`rcl_remap_service_name`).
    pub fn remap_service(
        &self,
        service: &str,
        namespace: &str,
        name: &str,
    ) -> Option<(String, &RemapRule)> {
        self.remap(RemapKind::Service, service, namespace, name)
    }

    fn remap(
        &self,
        kind: RemapKind,
        topic: &str,
        namespace: &str,
        name: &str,
    ) -> Option<(String, &RemapRule)> {
        let full = expand_topic(topic, namespace, name);
        self.remaps
            .iter()
            .filter(|r| r.kind == kind || r.kind == RemapKind::Name)
            .filter(|r| r.applies_to(name))
            .find(|r| expand_topic(&r.from, namespace, name) == full)
            .map(|r| (expand_topic(&r.to, namespace, name), r))
    }

    /// The `--log-level` of logger `logger` (`robot1.arm`): the most specific named level
    /// of it or an ancestor (`robot1`), else the default level (rcutils' effective level).
    pub fn logger_level(&self, logger: &str) -> Option<RosLogLevel> {
        let mut name = logger;
        loop {
            if let Some((_, l)) = self.logger_levels.iter().find(|(n, _)| n == name) {
                return Some(*l);
            }
            match name.rfind('.') {
                Some(i) => name = &name[..i],
                None => return self.log_level,
            }
        }
    }
}

/// `--enable-X` → `(X, true)`, `--disable-X` → `(X, false)`.
fn toggle(arg: &str) -> Option<(&str, bool)> {
    arg.strip_prefix("--enable-")
        .map(|s| (s, true))
        .or_else(|| arg.strip_prefix("--disable-").map(|s| (s, false)))
}

/// rcl's name token: `(([a-zA-Z](_)?)|_)([0-9a-zA-Z](_)?)*` — letters, digits and single
/// underscores, not starting with a digit.
fn is_token(s: &str) -> bool {
    !s.is_empty()
        && !s.starts_with(|c: char| c.is_ascii_digit())
        && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !s.contains("__")
}

/// An optional `node:` prefix (a token and a `:` that does not start `:=`), as rcl's lexer
/// reads it (`rostopic://` and `rosservice://` are no prefix).
fn node_prefix(rule: &str) -> (Option<&str>, &str) {
    if rule.starts_with("rostopic://") || rule.starts_with("rosservice://") {
        return (None, rule);
    }
    let end = rule
        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .unwrap_or(rule.len());
    let (head, rest) = rule.split_at(end);
    match rest.strip_prefix(':') {
        Some(after) if !after.starts_with('=') && is_token(head) => (Some(head), after),
        _ => (None, rule),
    }
}

/// A topic or service name of a rule: `/abs`, `~/private` or `relative`, tokens between
/// slashes.
fn check_name(name: &str) -> Result<(), String> {
    let body = name
        .strip_prefix("~/")
        .or_else(|| name.strip_prefix('/'))
        .unwrap_or(name);
    if body.is_empty() {
        return Err(format!("`{name}` is not a name"));
    }
    for part in body.split('/') {
        if part == "*" || part == "**" {
            return Err(format!("wildcard `{part}` is not implemented (nor in rcl)"));
        }
        if part.starts_with('\\') {
            return Err(format!(
                "backreference `{part}` is not implemented (nor in rcl)"
            ));
        }
        if !is_token(part) {
            return Err(format!(
                "`{part}` in `{name}` is not a name token (letters, digits and single underscores, not starting with a digit)"
            ));
        }
    }
    Ok(())
}

/// `__ns:=` value: `/` or `/a/b` (a trailing `/` allowed and dropped).
fn namespace_value(ns: &str) -> Result<String, String> {
    let Some(body) = ns.strip_prefix('/') else {
        return Err(format!(
            "namespace `{ns}` is not fully qualified (must start with /)"
        ));
    };
    let body = body.strip_suffix('/').unwrap_or(body);
    if body.is_empty() {
        return Ok("/".into());
    }
    match body.split('/').find(|p| !is_token(p)) {
        Some(p) => Err(format!("`{p}` in namespace `{ns}` is not a name token")),
        None => Ok(format!("/{body}")),
    }
}

/// One `-r` rule at `position`.
fn parse_remap(rule: &str, position: usize) -> Result<RemapRule, RosArgsError> {
    let err = |reason: String| RosArgsError::Remap {
        position,
        rule: rule.to_string(),
        reason,
    };
    let (node, rest) = node_prefix(rule);
    let make = |kind, from: &str, to: String| RemapRule {
        node: node.map(str::to_string),
        kind,
        from: from.to_string(),
        to,
        position,
    };
    if let Some(v) = rest
        .strip_prefix("__node:=")
        .or_else(|| rest.strip_prefix("__name:="))
    {
        if !is_token(v) {
            return Err(err(format!("`{v}` is not a valid node name")));
        }
        return Ok(make(RemapKind::NodeName, "", v.to_string()));
    }
    if let Some(v) = rest.strip_prefix("__ns:=") {
        return Ok(make(
            RemapKind::Namespace,
            "",
            namespace_value(v).map_err(err)?,
        ));
    }
    let (kind, rest) = if let Some(r) = rest.strip_prefix("rostopic://") {
        (RemapKind::Topic, r)
    } else if let Some(r) = rest.strip_prefix("rosservice://") {
        (RemapKind::Service, r)
    } else {
        (RemapKind::Name, rest)
    };
    let Some((from, to)) = rest.split_once(":=") else {
        return Err(err(
            "expected [node:]from:=to, __node:=name or __ns:=/namespace".into(),
        ));
    };
    check_name(from).map_err(|e| err(format!("match: {e}")))?;
    check_name(to).map_err(|e| err(format!("replacement: {e}")))?;
    Ok(make(kind, from, to.to_string()))
}

/// A parameter name: `.`-separated parts, each of tokens and slashes.
fn check_param_name(name: &str) -> Result<(), String> {
    for part in name.split('.') {
        let pieces: Vec<&str> = part.split('/').filter(|p| !p.is_empty()).collect();
        if pieces.is_empty() {
            return Err(format!("`{name}` is not a parameter name (empty part)"));
        }
        if let Some(p) = pieces.iter().find(|p| !is_token(p)) {
            return Err(match *p {
                "*" | "**" => format!("wildcard `{p}` is not implemented (nor in rcl)"),
                _ => format!("`{p}` in `{name}` is not a name token"),
            });
        }
    }
    Ok(())
}

/// One `-p` rule at `position`, into the table of its node (`/**` without a prefix).
fn parse_param_rule(
    rule: &str,
    position: usize,
    params: &mut ParamOverrides,
) -> Result<(), RosArgsError> {
    let err = |reason: String| RosArgsError::Param {
        position,
        rule: rule.to_string(),
        reason,
    };
    let (node, rest) = node_prefix(rule);
    let Some((name, text)) = rest.split_once(":=") else {
        return Err(err("expected [node:]name:=value".into()));
    };
    check_param_name(name).map_err(err)?;
    if text.is_empty() {
        return Err(err("no value after :=".into()));
    }
    let docs = load_yaml(text).map_err(|e| err(e.reason))?;
    let value = match docs.as_slice() {
        [one] => yaml_value(one).map_err(err)?,
        [] => return Err(err("no value after :=".into())),
        _ => return Err(err("one YAML value expected".into())),
    };
    let p = ParamOverride {
        name: name.to_string(),
        value,
        origin: ParamOrigin::Rule { position },
    };
    params.set(node.unwrap_or(ALL_NODES), p);
    Ok(())
}

/// A YAML node as the parameter parser sees it.
#[derive(Debug, Clone, PartialEq)]
enum Yaml {
    /// A scalar: its text, style, whether tagged `!!str`, its line.
    Scalar {
        text: String,
        style: ScalarStyle,
        str_tag: bool,
        line: usize,
    },
    /// A sequence.
    Seq { items: Vec<Yaml>, line: usize },
    /// A mapping, in order.
    Map {
        entries: Vec<(Yaml, Yaml)>,
        line: usize,
    },
}

impl Yaml {
    fn line(&self) -> usize {
        match self {
            Self::Scalar { line, .. } | Self::Seq { line, .. } | Self::Map { line, .. } => *line,
        }
    }
}

/// A YAML error at a line.
#[derive(Debug, Clone, PartialEq)]
struct YamlError {
    line: usize,
    reason: String,
}

type Events<'a> = Parser<'a, StrInput<'a>>;

/// The documents of `text`.
fn load_yaml(text: &str) -> Result<Vec<Yaml>, YamlError> {
    let mut events = Parser::new_from_str(text);
    let mut docs = Vec::new();
    loop {
        let (ev, line) = next_event(&mut events)?;
        match ev {
            Event::StreamEnd => return Ok(docs),
            Event::StreamStart | Event::DocumentStart(_) | Event::DocumentEnd | Event::Nothing => {}
            ev => docs.push(build(ev, line, &mut events)?),
        }
    }
}

fn next_event<'a>(events: &mut Events<'a>) -> Result<(Event<'a>, usize), YamlError> {
    match events.next_event() {
        Some(Ok((ev, span))) => Ok((ev, span.start.line())),
        Some(Err(e)) => Err(YamlError {
            line: e.marker().line(),
            reason: format!("YAML: {}", e.info()),
        }),
        None => Err(YamlError {
            line: 0,
            reason: "YAML: unexpected end".into(),
        }),
    }
}

/// The node that starts with `ev` (on `line`).
fn build<'a>(ev: Event<'a>, line: usize, events: &mut Events<'a>) -> Result<Yaml, YamlError> {
    match ev {
        Event::Scalar(text, style, _, tag) => Ok(Yaml::Scalar {
            text: text.into_owned(),
            style,
            str_tag: tag.is_some_and(|t| t.is_yaml_core_schema() && t.suffix == "str"),
            line,
        }),
        Event::SequenceStart(..) => {
            let mut items = Vec::new();
            loop {
                match next_event(events)? {
                    (Event::SequenceEnd, _) => return Ok(Yaml::Seq { items, line }),
                    (e, l) => items.push(build(e, l, events)?),
                }
            }
        }
        Event::MappingStart(..) => {
            let mut entries = Vec::new();
            loop {
                let key = match next_event(events)? {
                    (Event::MappingEnd, _) => return Ok(Yaml::Map { entries, line }),
                    (e, l) => build(e, l, events)?,
                };
                let (e, l) = next_event(events)?;
                entries.push((key, build(e, l, events)?));
            }
        }
        Event::Alias(_) => Err(YamlError {
            line,
            reason: "aliases are not supported (nor by rcl)".into(),
        }),
        other => Err(YamlError {
            line,
            reason: format!("unexpected YAML event {other:?}"),
        }),
    }
}

/// rcl's booleans (plain scalars only).
const TRUE: [&str; 11] = [
    "Y", "y", "yes", "Yes", "YES", "true", "True", "TRUE", "on", "On", "ON",
];
const FALSE: [&str; 11] = [
    "N", "n", "no", "No", "NO", "false", "False", "FALSE", "off", "Off", "OFF",
];

/// A scalar typed as rcl types it (`get_value`): `!!str` or quoted → string; else one of
/// rcl's booleans; else a whole C `strtoll` (base 0: `0x1F`, `010` octal) → integer; else a
/// whole C `strtod` or `.inf`/`.nan` → double; else string. An empty plain scalar is no
/// value.
pub fn scalar_value(
    text: &str,
    style: ScalarStyle,
    str_tag: bool,
) -> Result<ParameterValue, String> {
    let quoted = matches!(style, ScalarStyle::SingleQuoted | ScalarStyle::DoubleQuoted);
    if str_tag || quoted {
        return Ok(ParameterValue::String(text.to_string()));
    }
    if text.is_empty() {
        return Err("no value".into());
    }
    if TRUE.contains(&text) {
        return Ok(ParameterValue::Boolean(true));
    }
    if FALSE.contains(&text) {
        return Ok(ParameterValue::Boolean(false));
    }
    if let Some(i) = c_strtoll(text) {
        return Ok(ParameterValue::Integer(i));
    }
    if let Some(d) = c_strtod(text) {
        return Ok(ParameterValue::Double(d));
    }
    Ok(ParameterValue::String(text.to_string()))
}

/// C's `strtoll(s, &end, 0)` consuming all of `s` without overflow.
fn c_strtoll(s: &str) -> Option<i64> {
    let t = s.trim_start_matches(|c: char| c.is_ascii_whitespace());
    let (neg, t) = match t.strip_prefix('-') {
        Some(r) => (true, r),
        None => (false, t.strip_prefix('+').unwrap_or(t)),
    };
    let (radix, digits) = if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        (16, h)
    } else if t.len() > 1 && t.starts_with('0') {
        (8, &t[1..])
    } else {
        (10, t)
    };
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    let m = i128::from_str_radix(digits, radix).ok()?;
    i64::try_from(if neg { -m } else { m }).ok()
}

/// C's `strtod` consuming all of `s` without a range error, and YAML's `.inf`/`.nan`.
fn c_strtod(s: &str) -> Option<f64> {
    match s {
        ".nan" | ".NaN" | ".NAN" => return Some(f64::NAN),
        ".inf" | ".Inf" | ".INF" | "+.inf" | "+.Inf" | "+.INF" => return Some(f64::INFINITY),
        "-.inf" | "-.Inf" | "-.INF" => return Some(f64::NEG_INFINITY),
        _ => {}
    }
    let t = s.trim_start_matches(|c: char| c.is_ascii_whitespace());
    let v: f64 = t.parse().ok()?;
    let body = t.trim_start_matches(['+', '-']).to_ascii_lowercase();
    let literal = body.starts_with("inf") || body.starts_with("nan");
    let mantissa = body.split('e').next().unwrap_or_default();
    let overflow = v.is_infinite() && !literal;
    let underflow = v == 0.0 && mantissa.chars().any(|c| ('1'..='9').contains(&c));
    (!overflow && !underflow).then_some(v)
}

/// A parameter value from a YAML node: a scalar, or a sequence of scalars of one type.
fn yaml_value(y: &Yaml) -> Result<ParameterValue, String> {
    match y {
        Yaml::Scalar {
            text,
            style,
            str_tag,
            ..
        } => scalar_value(text, *style, *str_tag),
        Yaml::Seq { items, .. } => array_value(items),
        Yaml::Map { .. } => Err("a mapping is not a parameter value".into()),
    }
}

/// An array parameter: every element a scalar of the first one's type (rcl: "Sequence should
/// be of same type").
fn array_value(items: &[Yaml]) -> Result<ParameterValue, String> {
    use ParameterValue as V;
    let mut values = Vec::with_capacity(items.len());
    for item in items {
        match item {
            Yaml::Scalar { .. } => values.push(yaml_value(item)?),
            _ => return Err("an array holds scalars only".into()),
        }
    }
    let kind = |v: &V| std::mem::discriminant(v);
    let Some(first) = values.first() else {
        return Err("an empty sequence has no type (rcl sets no value)".into());
    };
    if let Some(odd) = values.iter().find(|v| kind(v) != kind(first)) {
        return Err(format!(
            "a sequence must be of one type: {odd:?} among {first:?}… (write 1.0, not 1, in an array of doubles)"
        ));
    }
    Ok(match first {
        V::Boolean(_) => V::BooleanArray(
            values
                .iter()
                .map(|v| matches!(v, V::Boolean(true)))
                .collect(),
        ),
        V::Integer(_) => V::IntegerArray(
            values
                .iter()
                .filter_map(|v| {
                    if let V::Integer(i) = v {
                        Some(*i)
                    } else {
                        None
                    }
                })
                .collect(),
        ),
        V::Double(_) => V::DoubleArray(
            values
                .iter()
                .filter_map(|v| if let V::Double(d) = v { Some(*d) } else { None })
                .collect(),
        ),
        _ => V::StringArray(
            values
                .iter()
                .filter_map(|v| {
                    if let V::String(s) = v {
                        Some(s.clone())
                    } else {
                        None
                    }
                })
                .collect(),
        ),
    })
}

/// Reads the parameters file `path` (given at `position`) into `params`.
fn read_params_file(
    path: &Path,
    position: usize,
    params: &mut ParamOverrides,
) -> Result<(), RosArgsError> {
    let text = std::fs::read_to_string(path).map_err(|e| RosArgsError::ParamsFile {
        position,
        path: path.to_path_buf(),
        reason: e.to_string(),
    })?;
    let yaml_err = |e: YamlError| RosArgsError::ParamsYaml {
        position,
        path: path.to_path_buf(),
        line: e.line,
        reason: e.reason,
    };
    for doc in load_yaml(&text).map_err(yaml_err)? {
        file_nodes(&doc, &mut Vec::new(), path, params).map_err(yaml_err)?;
    }
    Ok(())
}

/// The text of a mapping key.
fn key_text(k: &Yaml) -> Result<&str, YamlError> {
    match k {
        Yaml::Scalar { text, .. } if !text.is_empty() => Ok(text),
        _ => Err(YamlError {
            line: k.line(),
            reason: "a key must be a non-empty scalar".into(),
        }),
    }
}

/// The node levels of a parameters file: keys are node names (joined with `/`) until
/// `ros__parameters`.
fn file_nodes(
    doc: &Yaml,
    ns: &mut Vec<String>,
    path: &Path,
    out: &mut ParamOverrides,
) -> Result<(), YamlError> {
    let Yaml::Map { entries, .. } = doc else {
        return Err(YamlError {
            line: doc.line(),
            reason: "expected `<node name>: {ros__parameters: {…}}`".into(),
        });
    };
    for (k, v) in entries {
        let key = key_text(k)?;
        let at = |reason: String| YamlError {
            line: k.line(),
            reason,
        };
        if key.starts_with(PARAMS_KEY) {
            if ns.is_empty() {
                return Err(at(format!("no node name before `{PARAMS_KEY}`")));
            }
            let node = ns.join("/");
            check_node_pattern(&node).map_err(at)?;
            if !matches!(v, Yaml::Map { .. }) {
                return Err(at(format!(
                    "`{PARAMS_KEY}` must map parameter names to values"
                )));
            }
            flatten(v, "", &node, path, out)?;
        } else if matches!(v, Yaml::Map { .. }) {
            ns.push(key.to_string());
            file_nodes(v, ns, path, out)?;
            ns.pop();
        } else {
            return Err(at(format!(
                "`{key}` holds a value before `{PARAMS_KEY}` (expected `<node name>: {{{PARAMS_KEY}: {{…}}}}`)"
            )));
        }
    }
    Ok(())
}

/// A node name of a parameters file: names or `*`/`**` between slashes.
fn check_node_pattern(node: &str) -> Result<(), String> {
    let body = node.strip_prefix('/').unwrap_or(node);
    match body
        .split('/')
        .find(|p| !(is_token(p) || *p == "*" || *p == "**"))
    {
        Some(p) => Err(format!(
            "`{p}` in node name `{node}` is not a name, `*` or `**`"
        )),
        None => Ok(()),
    }
}

/// The parameters under `ros__parameters`, nested maps joined with `.`.
fn flatten(
    map: &Yaml,
    prefix: &str,
    node: &str,
    path: &Path,
    out: &mut ParamOverrides,
) -> Result<(), YamlError> {
    let Yaml::Map { entries, .. } = map else {
        return Ok(());
    };
    for (k, v) in entries {
        let key = key_text(k)?;
        let name = if prefix.is_empty() {
            key.to_string()
        } else {
            format!("{prefix}.{key}")
        };
        if matches!(v, Yaml::Map { .. }) {
            flatten(v, &name, node, path, out)?;
            continue;
        }
        let value = yaml_value(v).map_err(|reason| YamlError {
            line: v.line(),
            reason: format!("`{name}`: {reason}"),
        })?;
        let origin = ParamOrigin::File {
            path: path.to_path_buf(),
            line: v.line(),
        };
        out.set(
            node,
            ParamOverride {
                name,
                value,
                origin,
            },
        );
    }
    Ok(())
}

/// Why the ROS arguments do not fit the node: it does not start.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RosStartError {
    /// A parameter the node does not declare, a read-only one given another value, or a
    /// value of the wrong type or out of its domain.
    #[error("parameter `{name}` from {origin}: {refusal}")]
    Parameter {
        /// The parameter.
        name: String,
        /// Where its value came from.
        origin: ParamOrigin,
        /// Why it is refused.
        refusal: Box<StartParamRefusal>,
    },
    /// A remap rule the node cannot apply.
    #[error("remap rule `{rule}` (ROS argument {position}): {reason}")]
    Remap {
        /// The rule.
        rule: String,
        /// Its position.
        position: usize,
        /// Why.
        reason: String,
    },
    /// The node's settings with the ROS arguments applied are not valid.
    #[error("the node's settings with the ROS arguments: {source}")]
    Node {
        /// What is wrong.
        #[from]
        source: NodeError,
    },
}

/// What [`RosArgs::configure_node`] did: the parameters to check on the built node
/// ([`check_parameters`]) and lines for the node's log.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct NodeSetup {
    /// The parameters given to this node, each name once, with the value in force.
    pub params: Vec<ParamOverride>,
    /// Log lines: what was renamed and what was not.
    pub log: Vec<(Severity, String)>,
}

/// The fully qualified name of node `name` in `namespace` (`/robot1/arm`).
pub fn fully_qualified(namespace: &str, name: &str) -> String {
    format!("{}/{name}", namespace.trim_end_matches('/'))
}

/// rcl's logger name of a node: its namespace and name joined with `.` (`robot1.arm`).
pub fn logger_name(namespace: &str, name: &str) -> String {
    fully_qualified(namespace, name)
        .trim_start_matches('/')
        .replace('/', ".")
}

impl RosArgs {
    /// Applies the ROS arguments to the node's settings `cfg` (its config with the command
    /// line's overrides), before the node is built: `__node`/`__ns`; the start values of the
    /// settable parameters given to this node (the others are checked on the built node,
    /// [`check_parameters`]); `--log-level` of the node's logger; the topic remaps.
    pub fn configure_node(&self, cfg: &mut NodeConfig) -> Result<NodeSetup, RosStartError> {
        let (name, namespace) = self.node_identity(&cfg.name, &cfg.namespace);
        cfg.name = name;
        cfg.namespace = namespace;
        let params = self
            .params
            .for_node(&fully_qualified(&cfg.namespace, &cfg.name));
        for p in &params {
            apply_start_value(cfg, &p.name, &p.value).map_err(|refusal| {
                RosStartError::Parameter {
                    name: p.name.clone(),
                    origin: p.origin.clone(),
                    refusal: Box::new(refusal),
                }
            })?;
        }
        let logger = logger_name(&cfg.namespace, &cfg.name);
        if let Some(level) = self.logger_level(&logger).and_then(RosLogLevel::severity) {
            cfg.log_level = level;
        }
        let log = self.remap_node_topics(cfg)?;
        cfg.validate()?;
        Ok(NodeSetup { params, log })
    }

    /// Replaces each of the node's topics that a rule matches by the rule's expanded
    /// replacement; refuses a rule on `/tf` or `/tf_static` when the node reads them (not
    /// remappable yet) and notes rules on its services (not remapped yet).
    fn remap_node_topics(
        &self,
        cfg: &mut NodeConfig,
    ) -> Result<Vec<(Severity, String)>, RosStartError> {
        let (ns, name) = (cfg.namespace.clone(), cfg.name.clone());
        let mut log = Vec::new();
        let t = &mut cfg.topics;
        let mut topics = vec![
            &mut t.joint_states,
            &mut t.symmetry_condition,
            &mut t.command,
            &mut t.status,
        ];
        if let Some(p) = cfg.task_pose.as_mut() {
            topics.push(&mut p.topic);
        }
        for topic in topics {
            if let Some((to, rule)) = self.remap_topic(topic, &ns, &name) {
                let from = expand_topic(topic, &ns, &name);
                let at = rule.position;
                log.push((
                    Severity::Info,
                    format!("remap: topic {from} → {to} (ROS argument {at})"),
                ));
                *topic = to;
            }
        }
        let tf = cfg.task_pose.as_ref().is_some_and(|p| p.tf);
        for topic in ["/tf", "/tf_static"].into_iter().filter(|_| tf) {
            if let Some((to, rule)) = self.remap_topic(topic, &ns, &name) {
                return Err(RosStartError::Remap {
                    rule: rule.to_string(),
                    position: rule.position,
                    reason: format!("{topic} → {to}: the TF topics cannot be remapped yet"),
                });
            }
        }
        for service in ["~/pause", "~/reset"] {
            if let Some((to, rule)) = self.remap_service(service, &ns, &name) {
                let from = expand_topic(service, &ns, &name);
                log.push((
                    Severity::Warn,
                    format!(
                        "remap rule `{rule}` (ROS argument {}) not applied to service {from} (→ {to}): service names are not remapped yet",
                        rule.position
                    ),
                ));
            }
        }
        Ok(log)
    }
}

/// Checks the parameters given at start on the built node: each must be declared, a
/// read-only one must have its declared value, a settable one pass the parameter
/// service's check.
pub fn check_parameters(core: &NodeCore, params: &[ParamOverride]) -> Result<(), RosStartError> {
    for p in params {
        check_start_parameter(core, &p.name, &p.value).map_err(|refusal| {
            RosStartError::Parameter {
                name: p.name.clone(),
                origin: p.origin.clone(),
                refusal: Box::new(refusal),
            }
        })?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use ParameterValue as V;

    /// A command line from whitespace-separated words.
    fn argv(words: &str) -> Vec<String> {
        words.split_whitespace().map(str::to_string).collect()
    }

    /// The ROS arguments of `words` (positions from 1).
    fn ros(words: &str) -> RosArgs {
        RosArgs::parse(&argv(words), 1).unwrap().ros
    }

    fn err(words: &str) -> RosArgsError {
        RosArgs::parse(&argv(words), 1).unwrap_err()
    }

    /// The value of `-p rule` (argument 3) for every node.
    fn p(rule: &str) -> Result<V, RosArgsError> {
        let a = vec!["--ros-args".into(), "-p".into(), rule.to_string()];
        let r = RosArgs::parse(&a, 1)?.ros;
        Ok(r.params.for_node("/crossym")[0].value.clone())
    }

    /// A file in a fresh temporary directory; its path.
    fn file(name: &str, text: &str) -> String {
        let dir = std::env::temp_dir().join(format!(
            "crossym-ros-args-{}-{}",
            std::process::id(),
            name.replace(['/', '.'], "_")
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        path.to_str().unwrap().to_string()
    }

    fn values(r: &RosArgs, fqn: &str) -> Vec<(String, V)> {
        let all = r.params.for_node(fqn).into_iter();
        all.map(|p| (p.name, p.value)).collect()
    }

    fn value(r: &RosArgs, fqn: &str, name: &str) -> Option<V> {
        values(r, fqn)
            .into_iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
    }

    #[test]
    fn ros_arguments_run_from_ros_args_to_the_end_or_a_double_dash() {
        let a = argv("node --config x.toml --ros-args -r __ns:=/robot1 -- extra --ros-args --ros-args -p a:=1");
        let parsed = RosArgs::parse(&a, 1).unwrap();
        let rest: Vec<(usize, &str)> = parsed.rest.iter().map(|(i, s)| (*i, s.as_str())).collect();
        assert_eq!(
            rest,
            [(1, "node"), (2, "--config"), (3, "x.toml"), (8, "extra")]
        );
        assert_eq!(parsed.ros.remaps.len(), 1);
        assert_eq!(parsed.ros.remaps[0].position, 6);
        let p = &parsed.ros.params.for_node("/x")[0];
        assert_eq!((p.name.as_str(), &p.value), ("a", &V::Integer(1)));
        assert_eq!(p.origin, ParamOrigin::Rule { position: 12 });
        assert_eq!(p.origin.to_string(), "-p (ROS argument 12)");
        // Nothing after --ros-args: no ROS argument, nothing left over.
        assert_eq!(
            RosArgs::parse(&argv("--ros-args"), 1).unwrap(),
            ParsedArgs::default()
        );
    }

    #[test]
    fn node_name_and_namespace_rules() {
        for rule in ["__node:=arm", "__name:=arm"] {
            let r = ros(&format!("--ros-args -r {rule}"));
            assert_eq!(r.node_identity("crossym", "/"), ("arm".into(), "/".into()));
        }
        let r = ros("--ros-args --remap __ns:=/robot1/");
        assert_eq!(
            r.node_identity("crossym", "/"),
            ("crossym".into(), "/robot1".into())
        );
        assert_eq!(r.remaps[0].to_string(), "__ns:=/robot1");
        // The first rule that applies wins; a prefix names the node as the program does
        // (`__node`) or as renamed (`__ns`); a rule for another node is ignored.
        let r = ros(
            "--ros-args -r other:__node:=x -r crossym:__node:=arm -r __node:=late \
                     -r crossym:__ns:=/no -r arm:__ns:=/yes -r __ns:=/late",
        );
        assert_eq!(
            r.node_identity("crossym", "/"),
            ("arm".into(), "/yes".into())
        );
        assert_eq!(r.remaps[0].node.as_deref(), Some("other"));
        let r = ros("--ros-args -r __ns:=/");
        assert_eq!(r.node_identity("n", "/a"), ("n".into(), "/".into()));
    }

    #[test]
    fn topic_rules_match_on_expanded_names() {
        let r = ros("--ros-args -r /joint_states:=/robot1/js -r commands:=cmd -r ~/status:=state \
                     -r rosservice://~/pause:=halt -r arm:rostopic://x:=/y -r /joint_states:=/never");
        let t =
            |topic: &str, ns: &str, name: &str| r.remap_topic(topic, ns, name).map(|(to, _)| to);
        assert_eq!(
            t("/joint_states", "/robot1", "arm").as_deref(),
            Some("/robot1/js")
        );
        // Relative names expand in the node's namespace, `~` under its name.
        assert_eq!(
            t("commands", "/robot1", "arm").as_deref(),
            Some("/robot1/cmd")
        );
        assert_eq!(
            t("/robot1/commands", "/robot1", "arm").as_deref(),
            Some("/robot1/cmd")
        );
        assert_eq!(t("/commands", "/robot1", "arm"), None);
        assert_eq!(
            t("~/status", "/robot1", "arm").as_deref(),
            Some("/robot1/state")
        );
        assert_eq!(
            t("/robot1/arm/status", "/robot1", "arm").as_deref(),
            Some("/robot1/state")
        );
        // A service rule is not a topic rule and the other way round; a prefix selects.
        assert_eq!(t("~/pause", "/", "arm"), None);
        let s = r.remap_service("~/pause", "/", "arm").map(|(to, _)| to);
        assert_eq!(s.as_deref(), Some("/halt"));
        assert_eq!(r.remap_service("/x", "/", "arm"), None);
        assert_eq!(t("x", "/", "arm").as_deref(), Some("/y"));
        assert_eq!(t("x", "/", "other"), None);
        assert_eq!(r.remaps[4].to_string(), "arm:rostopic://x:=/y");
    }

    #[test]
    fn bad_remap_rules_are_refused_with_their_position() {
        for (rule, why) in [
            ("/a", "expected [node:]from:=to"),
            ("/a/*:=/b", "wildcard `*` is not implemented"),
            ("/a:=/b/**", "wildcard `**` is not implemented"),
            ("/a:=\\1", "backreference"),
            ("/1a:=/b", "`1a` in `/1a` is not a name token"),
            ("/a__b:=/b", "not a name token"),
            ("/a:=", "`` is not a name"),
            ("__ns:=robot1", "not fully qualified"),
            ("__ns:=/a:b", "`a:b` in namespace"),
            ("__node:=/arm", "`/arm` is not a valid node name"),
            ("__node:=", "is not a valid node name"),
        ] {
            match err(&format!("x --ros-args -r {rule}")) {
                RosArgsError::Remap {
                    position,
                    rule: r,
                    reason,
                } => {
                    assert_eq!((position, r.as_str()), (4, rule));
                    assert!(reason.contains(why), "{rule}: {reason}");
                }
                e => panic!("{rule}: {e}"),
            }
        }
        let e = err("--ros-args -r");
        let what = "a remap rule [node:]from:=to";
        assert_eq!(
            e,
            RosArgsError::MissingValue {
                position: 2,
                flag: "-r".into(),
                what
            }
        );
        assert!(
            e.to_string()
                .starts_with("ROS argument 2 `-r`: a remap rule"),
            "{e}"
        );
    }

    #[test]
    fn unknown_ros_arguments_are_refused_by_name() {
        let e = err("node --ros-args -r a:=b --config x.toml");
        assert_eq!(
            e,
            RosArgsError::Unknown {
                position: 5,
                arg: "--config".into()
            }
        );
        assert!(
            e.to_string().contains("unknown ROS argument `--config`"),
            "{e}"
        );
        // `--` ends the block: the program's arguments may follow.
        let parsed = RosArgs::parse(&argv("--ros-args -- --config x"), 1).unwrap();
        assert_eq!(parsed.rest.len(), 2);
        assert!(matches!(
            err("--ros-args --enable-nothing"),
            RosArgsError::Unknown { .. }
        ));
    }

    #[test]
    fn log_enclave_and_logging_flags() {
        let r = ros("--ros-args --log-level DEBUG --log-level robot1:=warn --log-level robot1.arm:=error \
                     --log-level robot1:=Info -e /crossym --enclave /crossym/node --disable-rosout-logs \
                     --enable-stdout-logs --disable-external-lib-logs --log-file-name f --log-config-file c.conf");
        assert_eq!(r.log_level, Some(RosLogLevel::Debug));
        assert_eq!(r.logger_levels.len(), 2);
        assert_eq!(r.logger_level("robot1.arm"), Some(RosLogLevel::Error));
        assert_eq!(r.logger_level("robot1.other"), Some(RosLogLevel::Info));
        assert_eq!(r.logger_level("crossym"), Some(RosLogLevel::Debug));
        assert_eq!(r.enclave.as_deref(), Some("/crossym/node"));
        let flags = (r.rosout_logs, r.stdout_logs, r.external_lib_logs);
        assert_eq!(flags, (Some(false), Some(true), Some(false)));
        assert_eq!(r.log_file_name.as_deref(), Some("f"));
        assert_eq!(r.log_config_file, Some(PathBuf::from("c.conf")));
        assert_eq!(RosLogLevel::Fatal.severity(), Some(Severity::Error));
        assert_eq!(RosLogLevel::Unset.severity(), None);
        for bad in ["warning", ":=info", "arm:=loud"] {
            let e = err(&format!("--ros-args --log-level {bad}"));
            assert!(
                matches!(e, RosArgsError::LogLevel { position: 3, .. }),
                "{bad}"
            );
        }
        assert_eq!(ros("--ros-args").logger_level("x"), None);
    }

    #[test]
    fn parameter_values_are_typed_as_rcl_types_them() {
        for t in [
            "true", "True", "TRUE", "yes", "Yes", "YES", "y", "Y", "on", "On", "ON",
        ] {
            assert_eq!(p(&format!("a:={t}")).unwrap(), V::Boolean(true), "{t}");
        }
        for f in ["false", "no", "n", "N", "off", "OFF"] {
            assert_eq!(p(&format!("a:={f}")).unwrap(), V::Boolean(false), "{f}");
        }
        let s = |t: &str| V::String(t.into());
        for (text, want) in [
            ("5", V::Integer(5)),
            ("-5", V::Integer(-5)),
            ("+7", V::Integer(7)),
            ("0x1F", V::Integer(31)),
            ("010", V::Integer(8)),
            ("08", V::Double(8.0)),
            ("0.5", V::Double(0.5)),
            ("1e3", V::Double(1000.0)),
            ("-.5", V::Double(-0.5)),
            (".inf", V::Double(f64::INFINITY)),
            ("-.Inf", V::Double(f64::NEG_INFINITY)),
            ("inf", V::Double(f64::INFINITY)),
            ("9223372036854775808", V::Double(9223372036854775808.0)),
            ("1e400", s("1e400")),
            ("'1'", s("1")),
            ("\"true\"", s("true")),
            ("!!str 5", s("5")),
            ("hello world", s("hello world")),
            ("~", s("~")),
            ("a:=b", s("a:=b")),
            // launch_ros writes a `Parameter` with yaml.dump: a document end follows.
            ("0.5\n...\n", V::Double(0.5)),
            ("[1.0, 2.0]", V::DoubleArray(vec![1.0, 2.0])),
            ("[0, 1, 1]", V::IntegerArray(vec![0, 1, 1])),
            ("[true, no]", V::BooleanArray(vec![true, false])),
            (
                "[a, 'b', '1']",
                V::StringArray(vec!["a".into(), "b".into(), "1".into()]),
            ),
            ("- 0.0\n- 1.0\n", V::DoubleArray(vec![0.0, 1.0])),
        ] {
            assert_eq!(p(&format!("a:={text}")).unwrap(), want, "{text}");
        }
        assert!(matches!(p("a:=.nan").unwrap(), V::Double(d) if d.is_nan()));
    }

    #[test]
    fn bad_parameter_rules_are_refused_with_their_position() {
        for (rule, why) in [
            ("a:=", "no value"),
            ("a:=[1, 2.0]", "one type"),
            ("a:=[]", "empty sequence"),
            ("a:={b: 1}", "mapping"),
            ("a:=[[1]]", "scalars only"),
            ("a:=1\n---\n2", "one YAML value"),
            ("a:=&x [1]\n---\n*x", "aliases"),
            ("a:=[1", "YAML"),
            ("a", "expected [node:]name:=value"),
            ("a..b:=1", "empty part"),
            ("a.*:=1", "wildcard"),
            ("1a:=1", "not a name token"),
        ] {
            match p(rule) {
                Err(RosArgsError::Param {
                    position: 3,
                    reason,
                    ..
                }) => {
                    assert!(reason.contains(why), "{rule}: {reason}")
                }
                other => panic!("{rule}: {other:?}"),
            }
        }
    }

    #[test]
    fn parameter_rules_with_a_node_prefix_apply_to_that_root_node_only() {
        let r = ros("--ros-args -p crossym:velocity_scale:=0.5 -p safety.margin:=0.1");
        assert_eq!(r.params.nodes()[0].node, "crossym");
        assert_eq!(r.params.nodes()[1].node, "/**");
        let both = [
            ("velocity_scale".into(), V::Double(0.5)),
            ("safety.margin".into(), V::Double(0.1)),
        ];
        assert_eq!(values(&r, "/crossym"), both);
        // rcl's `node:` prefix is one name: it names `/crossym`, not `/robot1/crossym`.
        assert_eq!(values(&r, "/robot1/crossym"), both[1..]);
        assert_eq!(values(&r, "/other"), both[1..]);
    }

    #[test]
    fn parameter_files_in_every_node_form() {
        let path = file(
            "forms.yaml",
            "# every form rcl reads\n\
             /**:\n  ros__parameters:\n    velocity_scale: 0.3\n    safety:\n      margin: 0.1\n      deep: {x: [1.0, 2.0]}\n\
             crossym:\n  ros__parameters:\n    log_level: debug\n\
             /robot1/crossym:\n  ros__parameters:\n    velocity_scale: 0.4\n\
             robot2:\n  crossym:\n    ros__parameters: {velocity_scale: 0.6}\n\
             /robot3/*:\n  ros__parameters:\n    default_condition:\n    - 0.5\n    - 1.0\n    - -1.0\n\
             /**/arm:\n  ros__parameters: {accept_untrained_conditions: yes}\n",
        );
        let r = ros(&format!("--ros-args --params-file {path}"));
        assert_eq!(r.params_files, [PathBuf::from(&path)]);
        let scale = |fqn: &str| value(&r, fqn, "velocity_scale");
        assert_eq!(scale("/crossym"), Some(V::Double(0.3)));
        assert_eq!(scale("/robot1/crossym"), Some(V::Double(0.4)));
        assert_eq!(scale("/robot2/crossym"), Some(V::Double(0.6)));
        let root = values(&r, "/crossym");
        assert_eq!(root[1], ("safety.margin".into(), V::Double(0.1)));
        assert_eq!(
            root[2],
            ("safety.deep.x".into(), V::DoubleArray(vec![1.0, 2.0]))
        );
        assert_eq!(root[3], ("log_level".into(), V::String("debug".into())));
        assert_eq!(root.len(), 4);
        let condition = V::DoubleArray(vec![0.5, 1.0, -1.0]);
        assert_eq!(
            value(&r, "/robot3/arm", "default_condition"),
            Some(condition)
        );
        assert_eq!(
            value(&r, "/robot3/arm", "accept_untrained_conditions"),
            Some(V::Boolean(true))
        );
        assert_eq!(value(&r, "/robot3/a/b", "default_condition"), None);
        let p = r.params.for_node("/x").remove(0);
        assert_eq!(
            p.origin,
            ParamOrigin::File {
                path: path.clone().into(),
                line: 4
            }
        );
        assert_eq!(p.origin.to_string(), format!("--params-file {path}:4"));
    }

    #[test]
    fn malformed_parameter_files_are_refused_with_their_line() {
        for (name, text, line, why) in [
            (
                "value.yaml",
                "crossym:\n  velocity_scale: 0.5\n",
                2,
                "holds a value before",
            ),
            (
                "nonode.yaml",
                "ros__parameters:\n  a: 1\n",
                1,
                "no node name before",
            ),
            (
                "empty.yaml",
                "/**:\n  ros__parameters:\n    a:\n",
                3,
                "`a`: no value",
            ),
            (
                "mixed.yaml",
                "/**:\n  ros__parameters:\n    a: [1, 0.5]\n",
                3,
                "one type",
            ),
            (
                "alias.yaml",
                "/**:\n  ros__parameters:\n    a: &x 1\n    b: *x\n",
                4,
                "aliases",
            ),
            (
                "badnode.yaml",
                "/a b:\n  ros__parameters: {a: 1}\n",
                2,
                "not a name",
            ),
            ("list.yaml", "- 1\n", 1, "expected `<node name>"),
            ("syntax.yaml", "/**: [\n", 2, "YAML"),
        ] {
            let path = file(name, text);
            match err(&format!("--ros-args --params-file {path}")) {
                RosArgsError::ParamsYaml {
                    position: 3,
                    line: l,
                    reason,
                    ..
                } => {
                    assert_eq!(l, line, "{name}: {reason}");
                    assert!(reason.contains(why), "{name}: {reason}");
                }
                e => panic!("{name}: {e}"),
            }
        }
        let missing = std::env::temp_dir().join("crossym-no-such-params.yaml");
        let e = err(&format!("--ros-args --params-file {}", missing.display()));
        assert!(
            matches!(e, RosArgsError::ParamsFile { position: 3, .. }),
            "{e}"
        );
        // An empty file holds no parameters.
        let path = file("nothing.yaml", "# nothing\n");
        assert!(ros(&format!("--ros-args --params-file {path}"))
            .params
            .nodes()
            .is_empty());
    }

    #[test]
    fn later_values_win_in_command_line_order_as_in_rcl() {
        let f1 = file(
            "first.yaml",
            "/**:\n  ros__parameters: {velocity_scale: 0.3, safety.margin: 0.1}\n",
        );
        let f2 = file(
            "second.yaml",
            "/**:\n  ros__parameters: {velocity_scale: 0.4}\n",
        );
        let own = file(
            "own.yaml",
            "crossym:\n  ros__parameters: {velocity_scale: 0.7}\n",
        );
        let get = |a: String| value(&ros(&a), "/crossym", "velocity_scale").unwrap();
        let scale = "velocity_scale:=0.5";
        let f = "--ros-args --params-file";
        assert_eq!(get(format!("{f} {f1} -p {scale}")), V::Double(0.5));
        assert_eq!(get(format!("{f} {f1} --params-file {f2}")), V::Double(0.4));
        assert_eq!(get(format!("{f} {f2} --params-file {f1}")), V::Double(0.3));
        // rcl keeps files and rules in one table per node name, in command-line order: a
        // file after a rule wins.
        assert_eq!(
            get(format!("--ros-args -p {scale} --params-file {f1}")),
            V::Double(0.3)
        );
        // A node's own table comes after `/**` when it first appears later, and rclcpp takes
        // the later table: a `-p` rule (in `/**`) does not beat it, a `crossym:` rule does.
        assert_eq!(
            get(format!("{f} {f1} --params-file {own} -p {scale}")),
            V::Double(0.7)
        );
        assert_eq!(
            get(format!("{f} {f1} --params-file {own} -p crossym:{scale}")),
            V::Double(0.5)
        );
    }

    /// `Node(package='crossym', executable='crossym', name='crossym', namespace='robot1',
    /// parameters=['p.yaml', {'velocity_scale': 0.5}], remappings=[('/joint_states',
    /// '/robot1/joint_states')], arguments=['node', '--config', 'x.toml'])`: launch_ros
    /// (`launch_ros/actions/node.py`) runs the executable with `arguments`, then
    /// `--ros-args -r __node:=NAME`, `-r __ns:=/NS`, one `--params-file` per `parameters`
    /// entry (a dict written by `yaml.dump` to a temporary file under the node's full name,
    /// or `/**` when the name is not fully specified), then the remappings.
    #[test]
    fn the_argument_vector_launch_ros_builds() {
        let user = file(
            "p.yaml",
            "/**:\n  ros__parameters:\n    velocity_scale: 0.3\n    safety:\n      margin: 0.02\n",
        );
        let dict = file(
            "launch_params_4kx1",
            "/robot1/crossym:\n  ros__parameters:\n    velocity_scale: 0.5\n",
        );
        let a = argv(&format!(
            "/opt/crossym/bin/crossym node --config x.toml --ros-args -r __node:=crossym -r __ns:=/robot1 \
             --params-file {user} --params-file {dict} -r /joint_states:=/robot1/joint_states"
        ));
        let parsed = RosArgs::parse(&a[1..], 1).unwrap();
        let rest: Vec<&str> = parsed.rest.iter().map(|(_, s)| s.as_str()).collect();
        assert_eq!(rest, ["node", "--config", "x.toml"]);
        let r = parsed.ros;
        let (name, ns) = r.node_identity("crossym", "/");
        assert_eq!((name.as_str(), ns.as_str()), ("crossym", "/robot1"));
        let got = values(&r, &fully_qualified(&ns, &name));
        let want = [
            ("velocity_scale".into(), V::Double(0.5)),
            ("safety.margin".into(), V::Double(0.02)),
        ];
        assert_eq!(got, want);
        let js = r.remap_topic("/joint_states", &ns, &name).unwrap();
        assert_eq!((js.0.as_str(), js.1.position), ("/robot1/joint_states", 14));
        assert_eq!(r.remap_topic("~/status", &ns, &name), None);
        // Without a name, launch_ros writes the dict under `/**` (yaml.dump, block style).
        let anon = file(
            "launch_params_anon",
            "/**:\n  ros__parameters:\n    accept_untrained_conditions: true\n    default_condition:\n    \
             - 0.0\n    - 1.0\n    - 1.0\n    log_level: debug\n    safety.margin: 0.02\n",
        );
        let r = ros(&format!("--ros-args --params-file {anon}"));
        let want = [
            ("accept_untrained_conditions".into(), V::Boolean(true)),
            (
                "default_condition".into(),
                V::DoubleArray(vec![0.0, 1.0, 1.0]),
            ),
            ("log_level".into(), V::String("debug".into())),
            ("safety.margin".into(), V::Double(0.02)),
        ];
        assert_eq!(values(&r, "/any/node"), want);
    }

    #[test]
    fn node_patterns() {
        for (pat, fqn, want) in [
            ("/**", "/a", true),
            ("/**", "/a/b/c", true),
            ("/*", "/a", true),
            ("/*", "/a/b", false),
            ("crossym", "/crossym", true),
            ("crossym", "/r/crossym", false),
            ("/r/*", "/r/crossym", true),
            ("/**/crossym", "/r/s/crossym", true),
            ("/**/crossym", "/crossym", true),
            ("r/crossym", "/r/crossym", true),
        ] {
            assert_eq!(node_matches(pat, fqn), want, "{pat} {fqn}");
        }
        assert_eq!(fully_qualified("/", "arm"), "/arm");
        assert_eq!(logger_name("/robot1/a", "arm"), "robot1.a.arm");
        assert_eq!(logger_name("/", "arm"), "arm");
    }

    #[test]
    fn configure_node_applies_name_parameters_level_and_remaps() {
        let path = file("node.yaml", "/**:\n  ros__parameters: {velocity_scale: 0.3, safety: {margin: 0.02}, period_s: 0.5}\n");
        let r = ros(&format!(
            "--ros-args -r __ns:=/robot1 -r __node:=arm --params-file {path} -p velocity_scale:=0.5 \
             -p other:log_level:=debug --log-level robot1.arm:=warn -r /joint_states:=/robot1/js -r ~/pause:=stop"
        ));
        let mut cfg = NodeConfig::default();
        let setup = r.configure_node(&mut cfg).unwrap();
        assert_eq!(
            (cfg.name.as_str(), cfg.namespace.as_str()),
            ("arm", "/robot1")
        );
        assert_eq!((cfg.velocity_scale, cfg.safety.margin), (0.5, 0.02));
        assert_eq!(cfg.log_level, Severity::Warn);
        assert_eq!(
            (cfg.topics.joint_states.as_str(), cfg.topics.status.as_str()),
            ("/robot1/js", "~/status")
        );
        // period_s (read-only) is left for the check on the built node.
        assert_eq!(cfg.period_s, 0.01);
        let names: Vec<&str> = setup.params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["velocity_scale", "safety.margin", "period_s"]);
        let remapped = "remap: topic /joint_states → /robot1/js (ROS argument 15)";
        assert_eq!(setup.log[0], (Severity::Info, remapped.into()));
        assert_eq!(setup.log[1].0, Severity::Warn);
        let service = "service /robot1/arm/pause (→ /robot1/stop)";
        assert!(setup.log[1].1.contains(service), "{:?}", setup.log);
        // A start value the settings refuse (stale timeout below the period).
        let r = ros("--ros-args -p stale_timeout_s:=0.001");
        let e = r.configure_node(&mut NodeConfig::default());
        assert!(matches!(e, Err(RosStartError::Node { .. })));
    }

    #[test]
    fn settable_parameters_of_a_wrong_type_or_domain_are_refused_with_their_origin() {
        for (rule, why) in [
            (
                "velocity_scale:=fast",
                "`velocity_scale` takes a double in (0, 1]",
            ),
            ("velocity_scale:=1", "write 1.0, not 1"),
            ("velocity_scale:=2.0", "velocity_scale must be in (0, 1]"),
            (
                "default_condition:=[0.0, 1.0, 0.5]",
                "σ = 0.5 must be +1 or -1",
            ),
            (
                "log_level:=loud",
                "`log_level` must be debug, info, warn or error",
            ),
        ] {
            let a = vec![
                "prog".into(),
                "--ros-args".into(),
                "-p".into(),
                rule.to_string(),
            ];
            let r = RosArgs::parse(&a, 1).unwrap().ros;
            let e = r.configure_node(&mut NodeConfig::default()).unwrap_err();
            let text = e.to_string();
            let at_4 = ParamOrigin::Rule { position: 4 };
            assert!(
                matches!(e, RosStartError::Parameter { ref origin, .. } if *origin == at_4),
                "{text}"
            );
            assert!(
                text.contains(why) && text.contains("from -p (ROS argument 4)"),
                "{text}"
            );
        }
    }
}
