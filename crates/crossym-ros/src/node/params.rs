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
    let mut options = NodeOptions::new()
        .enable_rosout(true)
        .start_parameter_services(true);
    for (k, v) in &params {
        options = options.declare_parameter(k, v.clone());
    }
    let bounds = core.runtime_bounds();
    let refusals = ops.clone();
    // A read-only parameter accepts only its declared value (the declaration itself).
    let declared: Vec<(String, ParameterValue)> = params
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
    options
        .parameter_validator(Box::new(move |name, value| {
            let verdict = match request_of(name, value, &bounds) {
                Ok(Some(_)) => Ok(()),
                Ok(None) => match declared.iter().find(|(k, _)| k == name) {
                    Some((_, v)) if v == value => Ok(()),
                    _ => Err(read_only_reason(name)),
                },
                Err(e) => Err(e),
            };
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
