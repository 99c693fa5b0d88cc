//! `crossym param get|set`: a running node's parameters through its ROS 2 parameter
//! services (`crossym::ros::tools::param`), for machines without the ROS tools
//! (`ros2 param get/set`). The settable ones are listed in the node's startup log and in
//! docs/guide/node.md; a refused set prints the node's reason and exits 1.

use std::process::ExitCode;

use crossym::ros::dds;
use crossym::ros::tools::param::{parse_value, show_value, ParamClient, SetOutcome};

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

/// `crossym param`. Exit 1 when the node does not answer or refuses the set.
pub fn run(a: &ParamArgs) -> anyhow::Result<ExitCode> {
    let value = match (a.verb, &a.value) {
        (ParamVerb::Get, None) => None,
        (ParamVerb::Set, Some(v)) => Some(parse_value(v)),
        _ => anyhow::bail!("usage: crossym param get NAME | crossym param set NAME VALUE"),
    };
    let n = a.node.node_config()?;
    let target = dds::node_name(&n.namespace, &n.name)?.fully_qualified_name();
    let mut client =
        ParamClient::open(&super::common::dds_settings("param")?, &target, a.timeout_s)?;
    let name = &a.name;
    match value {
        None => match client.get(name)? {
            Some(v) => {
                println!("{name} = {}", show_value(&v));
                Ok(ExitCode::SUCCESS)
            }
            None => {
                eprintln!("crossym param: {target} has no parameter `{name}`");
                Ok(ExitCode::from(1))
            }
        },
        Some(v) => {
            let shown = show_value(&v);
            match client.set(name, v)? {
                SetOutcome::Set => {
                    println!("{name} = {shown}: set");
                    Ok(ExitCode::SUCCESS)
                }
                SetOutcome::Refused { reason } => {
                    eprintln!("crossym param: {name} = {shown} refused: {reason}");
                    Ok(ExitCode::from(1))
                }
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
