//! `crossym param get|set`: a running node's parameters through its ROS 2 parameter
//! services (`~/get_parameters`, `~/set_parameters`), for machines without the ROS tools
//! (`ros2 param get/set`). The settable ones are listed in the node's startup log and in
//! docs/guide/node.md; a refused set prints the node's reason and exits 1.

use std::process::ExitCode;
use std::time::{Duration, Instant};

use ros2_client::parameters::raw::{Parameter, ParameterType, ParameterValue};
use ros2_client::rcl_interfaces::{
    GetParametersRequest, GetParametersResponse, SetParametersRequest, SetParametersResponse,
};
use ros2_client::service::{Client, ServiceMapping};
use ros2_client::{Name, ServiceTypeName};

use crossym::ros::dds::{self, DdsSettings};

/// Options of `crossym param`. The verb, the name and the value are separate positional
/// arguments, so options may stand anywhere among them (`param set --config C NAME VALUE`,
/// as `ros2 param set` users type them).
#[derive(Debug, clap::Args)]
pub struct ParamArgs {
    /// `get` or `set`.
    #[arg(value_enum)]
    pub verb: ParamVerb,
    /// The parameter's name.
    #[arg(id = "parameter", value_name = "NAME")]
    pub name: String,
    /// The value to set (`set` only): a number, true/false, [a, b, c], or text.
    #[arg(allow_negative_numbers = true)]
    pub value: Option<String>,
    #[command(flatten)]
    pub node: super::common::NodeTarget,
    /// Give up (exit 1) when the node does not answer within this time (s).
    #[arg(long, default_value_t = 5.0)]
    pub timeout_s: f64,
}

/// What `crossym param` does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ParamVerb {
    // Print the parameter's value.
    Get,
    // Set the parameter to VALUE.
    Set,
}

/// The parameter value a command-line word asks for: `true`/`false`, a number (always a
/// double: the node's settable numbers are doubles), `[a, b, c]` (doubles), else a string.
pub fn parse_value(s: &str) -> ParameterValue {
    let mut v = ParameterValue {
        ptype: ParameterType::STRING,
        boolean_value: false,
        int_value: 0,
        double_value: 0.0,
        string_value: String::new(),
        byte_array: vec![],
        bool_array: vec![],
        int_array: vec![],
        double_array: vec![],
        string_array: vec![],
    };
    let t = s.trim();
    if let Ok(b) = t.parse::<bool>() {
        v.ptype = ParameterType::BOOL;
        v.boolean_value = b;
    } else if let Ok(x) = t.parse::<f64>() {
        v.ptype = ParameterType::DOUBLE;
        v.double_value = x;
    } else if let Some(inner) = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
        let xs: Result<Vec<f64>, _> = inner.split(',').map(|x| x.trim().parse::<f64>()).collect();
        match xs {
            Ok(xs) => {
                v.ptype = ParameterType::DOUBLE_ARRAY;
                v.double_array = xs;
            }
            Err(_) => v.string_value = t.to_string(),
        }
    } else {
        v.string_value = t.to_string();
    }
    v
}

/// A parameter value as text.
pub fn show_value(v: &ParameterValue) -> String {
    match v.ptype {
        ParameterType::BOOL => v.boolean_value.to_string(),
        ParameterType::INTEGER => v.int_value.to_string(),
        ParameterType::DOUBLE => v.double_value.to_string(),
        ParameterType::STRING => v.string_value.clone(),
        ParameterType::DOUBLE_ARRAY => format!("{:?}", v.double_array),
        ParameterType::STRING_ARRAY => format!("{:?}", v.string_array),
        ParameterType::BOOL_ARRAY => format!("{:?}", v.bool_array),
        ParameterType::INTEGER_ARRAY => format!("{:?}", v.int_array),
        ParameterType::NOT_SET => "(not set)".into(),
        t => format!("(type {t})"),
    }
}

/// Calls `client` with `req`, re-sending every 0.5 s until discovery has matched and a
/// response arrives, or `timeout` (requests are idempotent).
fn call<Req, Resp>(client: &Client<Req, Resp>, req: Req, timeout: Duration) -> anyhow::Result<Resp>
where
    Req: ros2_client::Message + Clone + 'static,
    Resp: ros2_client::Message + 'static,
{
    let start = Instant::now();
    let mut sent = Instant::now() - Duration::from_secs(1);
    while start.elapsed() < timeout {
        if sent.elapsed() >= Duration::from_millis(500) {
            client
                .send_request(req.clone())
                .map_err(|e| anyhow::anyhow!("request not sent: {e:?}"))?;
            sent = Instant::now();
        }
        if let Ok(Some((_, r))) = client.receive_response() {
            return Ok(r);
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    anyhow::bail!("no answer within {} s", timeout.as_secs_f64())
}

/// `crossym param`. Exit 1 when the node does not answer or refuses the set.
pub fn run(a: &ParamArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.timeout_s.is_finite() && a.timeout_s > 0.0,
        "--timeout-s {} must be positive",
        a.timeout_s
    );
    let name = a.name.clone();
    let value = match (a.verb, &a.value) {
        (ParamVerb::Get, None) => None,
        (ParamVerb::Set, Some(v)) => Some(parse_value(v)),
        _ => anyhow::bail!("usage: crossym param get NAME | crossym param set NAME VALUE"),
    };
    let n = a.node.node_config()?;
    let target = dds::node_name(&n.namespace, &n.name)?.fully_qualified_name();
    let ctx = DdsSettings::from_env()?.context()?;
    let mut node = ctx
        .new_node(
            dds::node_name("/", &format!("crossym_param_{}", std::process::id()))?,
            ros2_client::NodeOptions::new().enable_rosout(false),
        )
        .map_err(|e| anyhow::anyhow!("DDS node: {e:?}"))?;
    let qos = dds::qos_reliable(10);
    let timeout = Duration::from_secs_f64(a.timeout_s);
    let service = |s: &str| Name::new(&target, s).map_err(|e| anyhow::anyhow!("{e:?}"));
    let answer = |e: anyhow::Error| {
        anyhow::anyhow!("{target}: {e}: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?")
    };
    match value {
        None => {
            let client: Client<GetParametersRequest, GetParametersResponse> = node
                .create_client(
                    ServiceMapping::Enhanced,
                    &service("get_parameters")?,
                    &ServiceTypeName::new("rcl_interfaces", "GetParameters"),
                    qos.clone(),
                    qos,
                )
                .map_err(|e| anyhow::anyhow!("client: {e:?}"))?;
            let r = call(
                &client,
                GetParametersRequest {
                    names: vec![name.clone()],
                },
                timeout,
            )
            .map_err(answer)?;
            match r.values.first() {
                Some(v) if v.ptype != ParameterType::NOT_SET => {
                    println!("{name} = {}", show_value(v));
                    Ok(ExitCode::SUCCESS)
                }
                _ => {
                    eprintln!("crossym param: {target} has no parameter `{name}`");
                    Ok(ExitCode::from(1))
                }
            }
        }
        Some(v) => {
            let client: Client<SetParametersRequest, SetParametersResponse> = node
                .create_client(
                    ServiceMapping::Enhanced,
                    &service("set_parameters")?,
                    &ServiceTypeName::new("rcl_interfaces", "SetParameters"),
                    qos.clone(),
                    qos,
                )
                .map_err(|e| anyhow::anyhow!("client: {e:?}"))?;
            let shown = show_value(&v);
            let req = SetParametersRequest {
                parameter: vec![Parameter {
                    name: name.clone(),
                    value: v,
                }],
            };
            let r = call(&client, req, timeout).map_err(answer)?;
            match r.results.first() {
                Some(res) if res.successful => {
                    println!("{name} = {shown}: set");
                    Ok(ExitCode::SUCCESS)
                }
                Some(res) => {
                    eprintln!("crossym param: {name} = {shown} refused: {}", res.reason);
                    Ok(ExitCode::from(1))
                }
                None => anyhow::bail!("{target}: empty answer"),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::ParamVerb;
    use crate::cli::{Cli, Command};

    /// `crossym ARGS…` parsed as the binary parses it: the `param` arguments.
    fn param(args: &[&str]) -> Result<super::ParamArgs, clap::Error> {
        let cli = Cli::try_parse_from(std::iter::once("crossym").chain(args.iter().copied()))?;
        match cli.command {
            Command::Param(a) => Ok(a),
            other => panic!("not `param`: {other:?}"),
        }
    }

    #[test]
    fn options_may_stand_anywhere_among_the_words() {
        let orders: [&[&str]; 4] = [
            &[
                "param",
                "set",
                "--config",
                "c.toml",
                "velocity_scale",
                "0.5",
            ],
            &[
                "param",
                "set",
                "velocity_scale",
                "0.5",
                "--config",
                "c.toml",
            ],
            &[
                "param",
                "--config",
                "c.toml",
                "set",
                "velocity_scale",
                "0.5",
            ],
            &[
                "param",
                "set",
                "velocity_scale",
                "--config",
                "c.toml",
                "0.5",
            ],
        ];
        for argv in orders {
            let a = param(argv).unwrap_or_else(|e| panic!("{argv:?}: {e}"));
            assert_eq!(a.verb, ParamVerb::Set, "{argv:?}");
            assert_eq!(a.name, "velocity_scale", "{argv:?}");
            assert_eq!(a.value.as_deref(), Some("0.5"), "{argv:?}");
            assert_eq!(a.node.config.to_str(), Some("c.toml"), "{argv:?}");
        }
        let a = param(&["param", "get", "--timeout-s", "2", "velocity_scale"]).unwrap();
        assert_eq!(
            (a.verb, a.name.as_str(), a.value),
            (ParamVerb::Get, "velocity_scale", None)
        );
        assert_eq!(a.timeout_s, 2.0);
    }

    #[test]
    fn values_may_be_negative_and_words_are_checked() {
        let a = param(&["param", "set", "--config", "c.toml", "offset", "-0.5"]).unwrap();
        assert_eq!(a.value.as_deref(), Some("-0.5"));
        // An unknown verb, a missing name, a fourth word: refused by the parser.
        for argv in [
            &["param", "put", "x", "1"][..],
            &["param", "get"],
            &["param", "set", "x", "1", "2"],
        ] {
            assert!(param(argv).is_err(), "{argv:?} parsed");
        }
    }
}
