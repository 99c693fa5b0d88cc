//! A running node's parameters through its ROS 2 parameter services (`~/get_parameters`,
//! `~/set_parameters`, ros2-client's Enhanced request/reply mapping), as `ros2 param
//! get|set` calls them (`crossym param`). Requests are idempotent: one is re-sent every
//! 0.5 s until discovery has matched and an answer arrives, or the timeout.

use std::time::{Duration, Instant};

use ros2_client::parameters::raw::{Parameter, ParameterType, ParameterValue};
use ros2_client::rcl_interfaces::{
    GetParametersRequest, GetParametersResponse, SetParametersRequest, SetParametersResponse,
};
use ros2_client::service::{Client, ServiceMapping};
use ros2_client::{Name, ServiceTypeName};

use crate::dds::{self, DdsError, DdsSettings};

/// Errors of a parameter call.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamError {
    /// The timeout is not a positive number of seconds.
    #[error("timeout_s = {value} must be positive")]
    Timeout {
        /// The timeout given (s).
        value: f64,
    },
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// A request could not be sent.
    #[error("{node}: request not sent: {message}: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?")]
    Send {
        /// The node's fully qualified name.
        node: String,
        /// The middleware's error text.
        message: String,
    },
    /// The node did not answer in time.
    #[error("{node}: no answer within {timeout_s} s: is `crossym node` running with this config, the same ROS_DOMAIN_ID and network?")]
    NoAnswer {
        /// The node's fully qualified name.
        node: String,
        /// The time waited (s).
        timeout_s: f64,
    },
    /// The node answered a set with no result.
    #[error("{node}: empty answer")]
    EmptyAnswer {
        /// The node's fully qualified name.
        node: String,
    },
}

/// What the node answered to a set.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SetOutcome {
    /// The value was applied.
    Set,
    /// The node refused it.
    Refused {
        /// The node's reason.
        reason: String,
    },
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

/// Parameter calls to one node, from a participant of its own.
pub struct ParamClient {
    target: String,
    timeout_s: f64,
    node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

impl ParamClient {
    /// A client of node `target` (fully qualified, e.g. `/crossym`) on a participant of
    /// `dds`; each call waits at most `timeout_s` (validated here) for its answer.
    pub fn open(dds: &DdsSettings, target: &str, timeout_s: f64) -> Result<Self, ParamError> {
        if !(timeout_s.is_finite() && timeout_s > 0.0) {
            return Err(ParamError::Timeout { value: timeout_s });
        }
        let ctx = dds.context()?;
        let node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_param_{}", std::process::id()))?,
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "parameter client node".into(),
                message: format!("{e:?}"),
            })?;
        Ok(Self {
            target: target.to_string(),
            timeout_s,
            node,
            _ctx: ctx,
        })
    }

    /// The node's fully qualified name.
    pub fn target(&self) -> &str {
        &self.target
    }

    /// The value of parameter `name`; `None` when the node has no such parameter.
    pub fn get(&mut self, name: &str) -> Result<Option<ParameterValue>, ParamError> {
        let client: Client<GetParametersRequest, GetParametersResponse> =
            self.client("get_parameters", "GetParameters")?;
        let req = GetParametersRequest {
            names: vec![name.to_string()],
        };
        let r = self.call(&client, req)?;
        Ok(r.values
            .into_iter()
            .next()
            .filter(|v| v.ptype != ParameterType::NOT_SET))
    }

    /// Sets parameter `name` to `value`; the node applies or refuses it.
    pub fn set(&mut self, name: &str, value: ParameterValue) -> Result<SetOutcome, ParamError> {
        let client: Client<SetParametersRequest, SetParametersResponse> =
            self.client("set_parameters", "SetParameters")?;
        let req = SetParametersRequest {
            parameter: vec![Parameter {
                name: name.to_string(),
                value,
            }],
        };
        let r = self.call(&client, req)?;
        match r.results.into_iter().next() {
            Some(res) if res.successful => Ok(SetOutcome::Set),
            Some(res) => Ok(SetOutcome::Refused { reason: res.reason }),
            None => Err(ParamError::EmptyAnswer {
                node: self.target.clone(),
            }),
        }
    }

    /// A client of the target's service `~/service` of type `rcl_interfaces/srv/ty`.
    fn client<Req, Resp>(&mut self, service: &str, ty: &str) -> Result<Client<Req, Resp>, DdsError>
    where
        Req: ros2_client::Message + Clone + 'static,
        Resp: ros2_client::Message + 'static,
    {
        let name = Name::new(&self.target, service).map_err(|e| DdsError::Name {
            name: format!("{}/{service}", self.target),
            message: format!("{e:?}"),
        })?;
        let qos = dds::qos_reliable(10);
        self.node
            .create_client(
                ServiceMapping::Enhanced,
                &name,
                &ServiceTypeName::new("rcl_interfaces", ty),
                qos.clone(),
                qos,
            )
            .map_err(|e| dds::create_error(format!("client of {}/{service}", self.target), &e))
    }

    /// Calls `client` with `req`, re-sending every 0.5 s until a response arrives, or the
    /// timeout.
    fn call<Req, Resp>(&self, client: &Client<Req, Resp>, req: Req) -> Result<Resp, ParamError>
    where
        Req: ros2_client::Message + Clone + 'static,
        Resp: ros2_client::Message + 'static,
    {
        let start = Instant::now();
        let timeout = Duration::from_secs_f64(self.timeout_s);
        let mut sent: Option<Instant> = None;
        while start.elapsed() < timeout {
            if sent.is_none_or(|s| s.elapsed() >= Duration::from_millis(500)) {
                client
                    .send_request(req.clone())
                    .map_err(|e| ParamError::Send {
                        node: self.target.clone(),
                        message: format!("{e:?}"),
                    })?;
                sent = Some(Instant::now());
            }
            if let Ok(Some((_, r))) = client.receive_response() {
                return Ok(r);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Err(ParamError::NoAnswer {
            node: self.target.clone(),
            timeout_s: self.timeout_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_read_as_the_values_they_name() {
        let v = parse_value("true");
        assert_eq!((v.ptype, v.boolean_value), (ParameterType::BOOL, true));
        // Numbers are doubles, negative and integral ones too.
        for (s, x) in [("0.5", 0.5), ("-2", -2.0), (" 3 ", 3.0)] {
            let v = parse_value(s);
            assert_eq!((v.ptype, v.double_value), (ParameterType::DOUBLE, x), "{s}");
        }
        let v = parse_value("[1, -2.5,3]");
        assert_eq!(v.ptype, ParameterType::DOUBLE_ARRAY);
        assert_eq!(v.double_array, [1.0, -2.5, 3.0]);
        // Anything else is text, a list of non-numbers included.
        for s in ["velocity", "[a, b]"] {
            let v = parse_value(s);
            assert_eq!(
                (v.ptype, v.string_value.as_str()),
                (ParameterType::STRING, s),
                "{s}"
            );
        }
    }

    #[test]
    fn values_show_as_they_were_typed() {
        for s in ["true", "0.25", "[1.0, 2.0]", "text"] {
            assert_eq!(show_value(&parse_value(s)), s);
        }
        let mut v = parse_value("x");
        v.ptype = ParameterType::INTEGER;
        v.int_value = 7;
        assert_eq!(show_value(&v), "7");
        v.ptype = ParameterType::NOT_SET;
        assert_eq!(show_value(&v), "(not set)");
    }
}
