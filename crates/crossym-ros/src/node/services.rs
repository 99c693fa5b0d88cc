//! The operator's services, as MoveIt Servo offers them: `~/pause` (`std_srvs/SetBool`:
//! `true` pauses, `false` resumes) and `~/reset` (`std_srvs/Trigger`: clears a latched
//! `ROBOT_NOT_FOLLOWING` and starts again from the measured state).
//!
//! Both use the request/reply mapping of ros2-client's own parameter services
//! ("Enhanced": the request's identity travels in the sample's inline QoS, the payload is
//! the request alone) — the mapping of `rmw_fastrtps`, ROS 2's default middleware. The I/O
//! thread answers at once and hands the request to the control thread, which applies it
//! before its next tick ([`crossym_control::node::NodeCore::apply`]).

use ros2_client::service::{Server, ServiceMapping};
use ros2_client::{Name, ServiceTypeName};
use serde::{Deserialize, Serialize};

use crate::dds;
use crate::dds::DdsError;

/// `std_srvs/SetBool` request.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetBoolRequest {
    /// `true`: pause; `false`: resume.
    pub data: bool,
}

/// `std_srvs/SetBool` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetBoolResponse {
    /// The request was accepted.
    pub success: bool,
    /// What happens now.
    pub message: String,
}

/// `std_srvs/Trigger` request (empty; IDL needs one member).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TriggerRequest {
    /// Unused.
    pub structure_needs_at_least_one_member: u8,
}

/// `std_srvs/Trigger` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TriggerResponse {
    /// The request was accepted.
    pub success: bool,
    /// What happens now.
    pub message: String,
}

impl ros2_client::Message for SetBoolRequest {}
impl ros2_client::Message for SetBoolResponse {}
impl ros2_client::Message for TriggerRequest {}
impl ros2_client::Message for TriggerResponse {}

/// The node's operator services.
pub(super) struct Services {
    pub(super) pause: Server<SetBoolRequest, SetBoolResponse>,
    pub(super) reset: Server<TriggerRequest, TriggerResponse>,
}

/// The service names, for the startup log.
pub(super) const NAMES: [(&str, &str); 2] = [
    ("pause", "std_srvs/srv/SetBool"),
    ("reset", "std_srvs/srv/Trigger"),
];

impl Services {
    /// Creates `~/pause` and `~/reset` (reliable, keep last 10).
    pub(super) fn create(node: &mut ros2_client::Node) -> Result<Self, DdsError> {
        let full = node.fully_qualified_name();
        let qos = dds::qos_reliable(10);
        let name = |s: &str| {
            Name::new(&full, s).map_err(|e| DdsError::Create {
                what: format!("service name ~/{s}"),
                message: format!("{e:?}"),
            })
        };
        let err = |s: &str| {
            let s = s.to_string();
            move |e| DdsError::Create {
                what: format!("service ~/{s}"),
                message: format!("{e:?}"),
            }
        };
        Ok(Self {
            pause: node
                .create_server(
                    ServiceMapping::Enhanced,
                    &name("pause")?,
                    &ServiceTypeName::new("std_srvs", "SetBool"),
                    qos.clone(),
                    qos.clone(),
                )
                .map_err(err("pause"))?,
            reset: node
                .create_server(
                    ServiceMapping::Enhanced,
                    &name("reset")?,
                    &ServiceTypeName::new("std_srvs", "Trigger"),
                    qos.clone(),
                    qos,
                )
                .map_err(err("reset"))?,
        })
    }
}
