//! A client of a managed node's lifecycle services (`~/get_state`, `~/change_state`), as
//! `ros2 lifecycle get|set` calls them, for `crossym lifecycle` and the demo's scenario
//! (which activates a node that starts inactive).
//!
//! `get_state` is idempotent and re-sent every 0.5 s until an answer comes (discovery may
//! take a moment). `change_state` is not: it is sent once the node has answered
//! `get_state` (its services are discovered), and when its answer is lost or says no, the
//! state is read back — a transition that was taken is reported as taken.

use std::time::{Duration, Instant};

use ros2_client::service::{Client, ServiceMapping};
use ros2_client::{Name, ServiceTypeName};

use crate::dds::{self, DdsError};
use crate::node::lifecycle::{
    ChangeStateRequest, ChangeStateResponse, EmptyRequest, GetStateResponse,
};
use crossym_io::msg::{LifecycleState, LifecycleTransition};

/// Errors of a lifecycle call.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LifecycleCallError {
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The node did not answer in time.
    #[error("{node}: no answer from ~/{service} within {timeout_s} s: is the node running, with the same ROS_DOMAIN_ID and network?")]
    NoAnswer {
        /// The node's fully qualified name.
        node: String,
        /// The service called.
        service: &'static str,
        /// The time waited (s).
        timeout_s: f64,
    },
    /// The node refused the transition (not available from its state).
    #[error("{node}: transition `{transition}` refused in state `{state}`")]
    Refused {
        /// The node's fully qualified name.
        node: String,
        /// The transition asked for.
        transition: String,
        /// The node's state after the refusal.
        state: String,
    },
}

/// The goal state of a transition label, from any state it is available in.
fn goal_of(label: &str) -> Option<&'static str> {
    match label {
        "configure" | "deactivate" => Some("inactive"),
        "cleanup" => Some("unconfigured"),
        "activate" => Some("active"),
        "shutdown" => Some("finalized"),
        _ => None,
    }
}

/// Lifecycle calls to one node, from a participant of its own.
pub struct LifecycleClient {
    target: String,
    get: Client<EmptyRequest, GetStateResponse>,
    change: Client<ChangeStateRequest, ChangeStateResponse>,
    _node: ros2_client::Node,
}

impl LifecycleClient {
    /// Clients of the lifecycle services of node `target` (fully qualified, e.g.
    /// `/crossym`), on a new node of `ctx`.
    pub fn new(ctx: &ros2_client::Context, target: &str) -> Result<Self, DdsError> {
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_lifecycle_{}", std::process::id()))?,
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "lifecycle client node".into(),
                message: format!("{e:?}"),
            })?;
        let qos = dds::qos_reliable(10);
        let name = |s: &str| {
            Name::new(target, s).map_err(|e| DdsError::Name {
                name: format!("{target}/{s}"),
                message: format!("{e:?}"),
            })
        };
        let err = |e: ros2_client::CreateError| {
            dds::create_error(format!("lifecycle client of {target}"), &e)
        };
        let get = node
            .create_client(
                ServiceMapping::Enhanced,
                &name("get_state")?,
                &ServiceTypeName::new("lifecycle_msgs", "GetState"),
                qos.clone(),
                qos.clone(),
            )
            .map_err(err)?;
        let change = node
            .create_client(
                ServiceMapping::Enhanced,
                &name("change_state")?,
                &ServiceTypeName::new("lifecycle_msgs", "ChangeState"),
                qos.clone(),
                qos,
            )
            .map_err(err)?;
        Ok(Self {
            target: target.to_string(),
            get,
            change,
            _node: node,
        })
    }

    /// The node's current state (re-asked every 0.5 s until `timeout`).
    pub fn get_state(&self, timeout: Duration) -> Result<LifecycleState, LifecycleCallError> {
        let start = Instant::now();
        let mut sent: Option<Instant> = None;
        while start.elapsed() < timeout {
            if sent.is_none_or(|s| s.elapsed() >= Duration::from_millis(500)) {
                // A failed send (no reader matched yet) is retried on the next round.
                let _ = self.get.send_request(EmptyRequest::default());
                sent = Some(Instant::now());
            }
            if let Ok(Some((_, r))) = self.get.receive_response() {
                return Ok(r.current_state);
            }
            std::thread::sleep(Duration::from_millis(5));
        }
        Err(self.no_answer("get_state", timeout))
    }

    /// Takes the transition labelled `label` (`configure`, `activate`, `deactivate`,
    /// `cleanup`, `shutdown`); returns the state reached.
    pub fn change_state(
        &self,
        label: &str,
        timeout: Duration,
    ) -> Result<LifecycleState, LifecycleCallError> {
        let start = Instant::now();
        self.get_state(timeout)?;
        let req = ChangeStateRequest {
            transition: LifecycleTransition {
                id: 0,
                label: label.to_string(),
            },
        };
        let _ = self.change.send_request(req);
        let rest = timeout.saturating_sub(start.elapsed());
        let answered = loop {
            if let Ok(Some((_, r))) = self.change.receive_response() {
                break Some(r.success);
            }
            if start.elapsed() >= timeout.max(Duration::from_millis(100)) {
                break None;
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        let state = self.get_state(rest.max(Duration::from_secs(1)))?;
        let reached = goal_of(label) == Some(state.label.as_str());
        match (answered, reached) {
            (Some(true), _) | (None, true) => Ok(state),
            (None, false) => Err(self.no_answer("change_state", timeout)),
            (Some(false), _) => Err(LifecycleCallError::Refused {
                node: self.target.clone(),
                transition: label.to_string(),
                state: state.label,
            }),
        }
    }

    fn no_answer(&self, service: &'static str, timeout: Duration) -> LifecycleCallError {
        LifecycleCallError::NoAnswer {
            node: self.target.clone(),
            service,
            timeout_s: timeout.as_secs_f64(),
        }
    }
}
