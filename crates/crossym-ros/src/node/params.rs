//! The node's ROS 2 parameters: read-only ones describing its configuration, and the
//! settable subset (MoveIt Servo's `enable_parameter_update`) — `velocity_scale`,
//! `default_condition`, `accept_untrained_conditions`, `stale_timeout_s`, `safety.margin`,
//! `log_level`. A set is checked here, in ros2-client's parameter service (a refusal is
//! `SetParametersResult.successful = false` with the reason), then handed to the I/O
//! thread, which logs it and passes a node request on to the control thread; that applies
//! it before its next tick. Every other parameter refuses a set: it needs a restart.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::SyncSender;
use std::sync::Arc;

use ros2_client::{NodeOptions, ParameterValue};

use crossym_control::node::{NodeCore, OperatorRequest, RuntimeBounds};
use crossym_control::NodeConfig;
use crossym_control::Severity;
use crossym_math::symmetry::compose::Condition;

/// What an operator asked for, on its way from a service or parameter callback to the I/O
/// thread.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Operator {
    /// A request the control thread applies; `source` says where it came from.
    Node {
        /// The request.
        request: OperatorRequest,
        /// `parameter` or `service`.
        source: &'static str,
    },
    /// `log_level`: the I/O thread's log filter.
    LogLevel(Severity),
    /// A parameter set was refused (already answered; logged).
    Refused {
        /// The parameter.
        name: String,
        /// The reason given to the caller.
        reason: String,
    },
}

/// The settable parameters and the type each takes, for the startup log and refusals.
pub(super) const SETTABLE: [(&str, &str); 6] = [
    ("velocity_scale", "double in (0, 1]"),
    ("default_condition", "double[3] [θ rad, λ, σ = ±1]"),
    ("accept_untrained_conditions", "bool"),
    ("stale_timeout_s", "double in (0, start value]"),
    (
        "safety.margin",
        "double in [0, half the smallest joint range)",
    ),
    ("log_level", "string debug|info|warn|error"),
];

/// Why a read-only parameter needs a restart.
fn read_only_reason(name: &str) -> String {
    let why = match name {
        "period_s" => "the tick's timer and the safety filter's Δt are set at start",
        "output" => "the command publisher's type is created at start",
        "joint_names" => "the controlled joints come from the robot model",
        "policy" => "the policy and its workspaces are loaded at start",
        "topics.command" => "the command publisher is created at start",
        "trigger" => "the control loop's trigger is chosen at start",
        "check_stamps" => "the input gate is built at start",
        _ => "the QP and the tick's buffers are sized at start",
    };
    format!("`{name}` needs a restart: {why}")
}

/// The request a settable parameter's value asks for; `Ok(None)` for a name that is not
/// settable (the caller refuses it), `Err` for a bad value.
pub(super) fn request_of(
    name: &str,
    value: &ParameterValue,
    bounds: &RuntimeBounds,
) -> Result<Option<Operator>, String> {
    let ty = || {
        let want = SETTABLE
            .iter()
            .find(|(n, _)| *n == name)
            .map_or("", |(_, t)| *t);
        format!("`{name}` takes a {want}, got {value:?}")
    };
    let request = match (name, value) {
        ("velocity_scale", ParameterValue::Double(s)) => OperatorRequest::VelocityScale(*s),
        ("stale_timeout_s", ParameterValue::Double(s)) => OperatorRequest::StaleTimeout(*s),
        ("safety.margin", ParameterValue::Double(m)) => OperatorRequest::Margin(*m),
        ("accept_untrained_conditions", ParameterValue::Boolean(b)) => {
            OperatorRequest::AcceptUntrained(*b)
        }
        ("default_condition", ParameterValue::DoubleArray(v)) if v.len() == 3 => {
            let sigma = v[2];
            if sigma != 1.0 && sigma != -1.0 {
                return Err(format!("`default_condition`: σ = {sigma} must be +1 or -1"));
            }
            OperatorRequest::DefaultCondition(Condition {
                theta: v[0],
                scale: v[1],
                reflection: sigma as i8,
            })
        }
        ("log_level", ParameterValue::String(s)) => {
            return Severity::parse(s)
                .map(|l| Some(Operator::LogLevel(l)))
                .ok_or_else(|| {
                    format!("`log_level` must be debug, info, warn or error, got `{s}`")
                });
        }
        (n, _) if SETTABLE.iter().any(|(s, _)| *s == n) => return Err(ty()),
        _ => return Ok(None),
    };
    bounds.check(&request).map_err(|e| e.to_string())?;
    Ok(Some(Operator::Node {
        request,
        source: "parameter",
    }))
}

/// The node's options: its parameters (read-only and settable, see the module docs),
/// rosout and the parameter services; accepted sets go to `ops` once `started` is set
/// (ros2-client runs the validator and the set action on the declarations too).
pub(super) fn node_options(
    core: &NodeCore,
    ops: SyncSender<Operator>,
    started: Arc<AtomicBool>,
) -> NodeOptions {
    let params = declarations(core);
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true);
    for (k, v) in &params {
        options = options.declare_parameter(k, v.clone());
    }
    let bounds = core.runtime_bounds();
    let refusals = ops.clone();
    // A read-only parameter accepts only its declared value (the declaration itself).
    let declared = params;
    options
        .parameter_describer(Box::new(move |name, value| {
            Some(describe(name, value, &bounds))
        }))
        .parameter_validator(Box::new(move |name, value| {
            let verdict = validate(name, value, &bounds, &declared);
            if let Err(reason) = &verdict {
                // Logged by the I/O thread; a full queue only loses the log line.
                let _ = refusals.try_send(Operator::Refused {
                    name: name.to_string(),
                    reason: reason.clone(),
                });
            }
            verdict
        }))
        .parameter_set_action(Box::new(move |name, value| {
            if !started.load(Ordering::Acquire) {
                return Ok(());
            }
            match request_of(name, value, &bounds)? {
                Some(op) => ops
                    .try_send(op)
                    .map_err(|e| format!("`{name}` not applied: the node is busy ({e})")),
                None => Err(read_only_reason(name)),
            }
        }))
}

/// What `ros2 param describe` shows of parameter `name`: its meaning, whether it is
/// read-only (everything but [`SETTABLE`]), the constraint and, for the bounded doubles,
/// their range.
fn describe(
    name: &str,
    value: &ParameterValue,
    bounds: &RuntimeBounds,
) -> ros2_client::parameters::ParameterDescriptor {
    use ros2_client::parameters::{NumericRange, ParameterDescriptor};
    let settable = SETTABLE.iter().find(|(n, _)| *n == name);
    let range = |from_value: f64, to_value: f64| NumericRange::FloatingPointRange {
        from_value,
        to_value,
        step: 0.0,
    };
    let description = match name {
        "period_s" => "control period (s)",
        "stale_timeout_s" => "joint states older than this (s) are stale: the command brakes",
        "check_stamps" => "reject joint states whose non-zero stamp is older than stale_timeout_s",
        "output" => "what the command topic carries: velocity, position or trajectory",
        "trigger" => "when the tick runs: timer or joint_states",
        "joint_names" => "the controlled joints, in the command's order",
        "topics.command" => "the command topic",
        "velocity_scale" => "the policy's velocity is multiplied by this before the safety filter",
        "default_condition" => "the condition [θ rad, λ, σ] applied until a condition arrives",
        "accept_untrained_conditions" => "accept conditions outside the policy's trained box",
        "safety.margin" => "distance kept inside the URDF position limits (rad or m)",
        "log_level" => "console and /rosout log level",
        "policy" => "the policy file",
        _ => "",
    };
    ParameterDescriptor {
        name: name.to_string(),
        param_type: value.to_parameter_type(),
        description: description.to_string(),
        additional_constraints: match settable {
            Some((_, t)) => (*t).to_string(),
            None => read_only_reason(name),
        },
        read_only: settable.is_none(),
        dynamic_typing: false,
        range: match name {
            "velocity_scale" => range(0.0, 1.0),
            "stale_timeout_s" => range(0.0, bounds.max_stale_timeout_s),
            "safety.margin" => range(0.0, bounds.max_margin),
            _ => NumericRange::NotSpecified,
        },
    }
}

/// The node's parameters and their values at start, read-only and settable (module docs).
fn declarations(core: &NodeCore) -> Vec<(String, ParameterValue)> {
    let cfg = core.config();
    let c = cfg.default_condition;
    let mut params: Vec<(&str, ParameterValue)> = vec![
        ("period_s", ParameterValue::Double(cfg.period_s)),
        (
            "stale_timeout_s",
            ParameterValue::Double(cfg.stale_timeout_s),
        ),
        ("check_stamps", ParameterValue::Boolean(cfg.check_stamps)),
        (
            "output",
            ParameterValue::String(format!("{:?}", cfg.output).to_lowercase()),
        ),
        (
            "trigger",
            ParameterValue::String(format!("{:?}", cfg.trigger).to_lowercase()),
        ),
        (
            "joint_names",
            ParameterValue::StringArray(core.joint_names().to_vec()),
        ),
        (
            "topics.command",
            ParameterValue::String(cfg.topics.command.clone()),
        ),
        ("velocity_scale", ParameterValue::Double(cfg.velocity_scale)),
        (
            "default_condition",
            ParameterValue::DoubleArray(vec![c.theta, c.scale, f64::from(c.reflection)]),
        ),
        (
            "accept_untrained_conditions",
            ParameterValue::Boolean(cfg.accept_untrained_conditions),
        ),
        ("safety.margin", ParameterValue::Double(cfg.safety.margin)),
        (
            "log_level",
            ParameterValue::String(format!("{:?}", cfg.log_level).to_lowercase()),
        ),
    ];
    if let Some(p) = &cfg.policy {
        params.push(("policy", ParameterValue::String(p.display().to_string())));
    }
    params
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect()
}

/// The parameter service's check of a set: a settable parameter's value ([`request_of`]);
/// any other declared parameter accepts only its declared value.
fn validate(
    name: &str,
    value: &ParameterValue,
    bounds: &RuntimeBounds,
    declared: &[(String, ParameterValue)],
) -> Result<(), String> {
    match request_of(name, value, bounds)? {
        Some(_) => Ok(()),
        None => match declared.iter().find(|(k, _)| k == name) {
            Some((_, v)) if v == value => Ok(()),
            _ => Err(read_only_reason(name)),
        },
    }
}

/// Why a parameter given at start (a `--params-file`, `-p`) is refused: the node does not
/// start.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum StartParamRefusal {
    /// The node declares no such parameter.
    #[error("the node declares no parameter `{name}` (it declares {declared})")]
    Undeclared {
        /// The parameter.
        name: String,
        /// The declared names.
        declared: String,
    },
    /// A read-only parameter given another value than its declared one.
    #[error("`{name}` is read-only: it accepts only its value from the config and command line, {declared}; got {given}")]
    ReadOnly {
        /// The parameter.
        name: String,
        /// Its declared value.
        declared: String,
        /// The value given.
        given: String,
    },
    /// A settable parameter's value refused by the parameter service's check (wrong type,
    /// out of its domain).
    #[error("{reason}")]
    Invalid {
        /// The parameter service's reason.
        reason: String,
    },
}

/// A parameter value as a YAML file would hold it (`0.5`, `[0.0, 1.0]`, `"velocity"`).
fn show(v: &ParameterValue) -> String {
    fn list<T: std::fmt::Debug>(v: &[T]) -> String {
        let items: Vec<String> = v.iter().map(|x| format!("{x:?}")).collect();
        format!("[{}]", items.join(", "))
    }
    match v {
        ParameterValue::NotSet => "(not set)".into(),
        ParameterValue::Boolean(b) => format!("{b} (bool)"),
        ParameterValue::Integer(i) => format!("{i} (integer)"),
        ParameterValue::Double(d) => format!("{d:?} (double)"),
        ParameterValue::String(s) => format!("{s:?} (string)"),
        ParameterValue::ByteArray(b) => format!("{} (byte array)", list(b)),
        ParameterValue::BooleanArray(b) => format!("{} (bool array)", list(b)),
        ParameterValue::IntegerArray(i) => format!("{} (integer array)", list(i)),
        ParameterValue::DoubleArray(d) => format!("{} (double array)", list(d)),
        ParameterValue::StringArray(s) => format!("{} (string array)", list(s)),
    }
}

/// Writes the start value of the settable parameter `name` into `cfg` (checked as a set
/// is, `request_of`, except against the bounds fixed at start: those are checked on the
/// built node by [`check_start_parameter`]); `Ok(false)` when `name` is not settable.
pub fn apply_start_value(
    cfg: &mut NodeConfig,
    name: &str,
    value: &ParameterValue,
) -> Result<bool, StartParamRefusal> {
    let open = RuntimeBounds {
        max_stale_timeout_s: f64::INFINITY,
        max_margin: f64::INFINITY,
    };
    let op = request_of(name, value, &open).map_err(|reason| StartParamRefusal::Invalid {
        reason: integer_hint(reason, value),
    })?;
    match op {
        Some(Operator::Node { request, .. }) => match request {
            OperatorRequest::VelocityScale(s) => cfg.velocity_scale = s,
            OperatorRequest::StaleTimeout(t) => cfg.stale_timeout_s = t,
            OperatorRequest::AcceptUntrained(a) => cfg.accept_untrained_conditions = a,
            OperatorRequest::Margin(m) => cfg.safety.margin = m,
            OperatorRequest::DefaultCondition(c) => cfg.default_condition = c,
            _ => return Ok(false),
        },
        Some(Operator::LogLevel(l)) => cfg.log_level = l,
        _ => return Ok(false),
    }
    Ok(true)
}

/// rcl types `1` as an integer: say so where a double was expected.
fn integer_hint(reason: String, value: &ParameterValue) -> String {
    match value {
        ParameterValue::Integer(_) | ParameterValue::IntegerArray(_) => {
            format!("{reason} (an integer: write 1.0, not 1, for a double)")
        }
        _ => reason,
    }
}

/// Checks a parameter given at start against the built node's declarations with the
/// parameter service's own check (`validate`); `use_sim_time`, ros2-client's own
/// parameter, is read-only `false` (the node runs on wall-clock time).
pub fn check_start_parameter(
    core: &NodeCore,
    name: &str,
    value: &ParameterValue,
) -> Result<(), StartParamRefusal> {
    let mut declared = declarations(core);
    declared.push(("use_sim_time".into(), ParameterValue::Boolean(false)));
    let Some((_, start)) = declared.iter().find(|(k, _)| k == name) else {
        let names: Vec<&str> = declared.iter().map(|(k, _)| k.as_str()).collect();
        return Err(StartParamRefusal::Undeclared {
            name: name.into(),
            declared: names.join(", "),
        });
    };
    validate(name, value, &core.runtime_bounds(), &declared).map_err(|reason| {
        if name == "use_sim_time" {
            StartParamRefusal::Invalid {
                reason: "`use_sim_time` must be false: the node runs on wall-clock time".into(),
            }
        } else if SETTABLE.iter().any(|(s, _)| *s == name) {
            StartParamRefusal::Invalid {
                reason: integer_hint(reason, value),
            }
        } else {
            StartParamRefusal::ReadOnly {
                name: name.into(),
                declared: show(start),
                given: show(value),
            }
        }
    })
}

#[cfg(test)]
mod describe_tests {
    use super::*;
    use ros2_client::parameters::NumericRange;

    #[test]
    fn read_only_is_what_cannot_be_set_and_ranges_are_the_bounds() {
        let b = RuntimeBounds {
            max_stale_timeout_s: 0.2,
            max_margin: 0.4,
        };
        for (name, v) in [
            ("period_s", ParameterValue::Double(0.01)),
            ("output", ParameterValue::String("velocity".into())),
            ("joint_names", ParameterValue::StringArray(vec![])),
        ] {
            let d = describe(name, &v, &b);
            assert!(d.read_only, "{name}");
            assert!(
                d.additional_constraints.contains("restart"),
                "{name}: {}",
                d.additional_constraints
            );
        }
        for (name, _) in SETTABLE {
            let d = describe(name, &ParameterValue::Double(0.1), &b);
            assert!(!d.read_only, "{name}");
            assert!(!d.description.is_empty(), "{name}");
        }
        match describe("safety.margin", &ParameterValue::Double(0.0), &b).range {
            NumericRange::FloatingPointRange {
                from_value,
                to_value,
                ..
            } => {
                assert_eq!((from_value, to_value), (0.0, 0.4))
            }
            _ => panic!("safety.margin has no range"),
        }
    }
}
