//! The node's DDS endpoints: its input subscriptions (joint states, conditions, task poses,
//! TF), the command writer for the configured output mode and the status writer, created
//! once at startup with their QoS.

use std::sync::Arc;

use super::record::{RecordItem, Recorder};
use crate::dds::{self, DdsError};
use crossym_control::node::{Command, OutputMode};
use crossym_io::msg;

/// The TF topics' readers.
pub(super) struct TfSubscriptions {
    pub(super) dynamic: ros2_client::Subscription<msg::TFMessage>,
    pub(super) fixed: ros2_client::Subscription<msg::TFMessage>,
}

impl TfSubscriptions {
    /// `/tf` and `/tf_static` with tf2's own reader QoS (depth 100; static: transient local).
    pub(super) fn create(node: &mut ros2_client::Node) -> Result<Self, DdsError> {
        let fixed_qos =
            dds::qos_reliable(100).durability(ros2_client::qos::Durability::TransientLocal);
        Ok(Self {
            dynamic: dds::subscription::<msg::TFMessage>(node, "/tf", dds::qos_reliable(100))?,
            fixed: dds::subscription::<msg::TFMessage>(node, "/tf_static", fixed_qos)?,
        })
    }
}

/// The node's topics: two inputs, the command and the status.
pub(super) struct Endpoints {
    pub(super) joint_states: ros2_client::Subscription<msg::JointState>,
    pub(super) conditions: ros2_client::Subscription<msg::SymmetryCondition>,
    /// `[node.task_pose]`: the observed object's pose (best effort: matches reliable and
    /// best-effort perception publishers).
    pub(super) poses: Option<ros2_client::Subscription<msg::PoseStamped>>,
    /// `[node.task_pose] tf`: `/tf` (reliable, volatile) and `/tf_static` (reliable,
    /// transient local: the static edges published before the node started), read when a
    /// pose arrives (never registered with the poll: the tree's traffic does not wake the
    /// control thread).
    pub(super) tf: Option<TfSubscriptions>,
    /// Shared with the I/O thread, which counts its matched subscribers.
    pub(super) command: Arc<CommandPublisher>,
    pub(super) status: ros2_client::Publisher<msg::Status>,
}

impl Endpoints {
    /// Joint states best effort (sensor QoS), everything else reliable (depth 10).
    pub(super) fn create(
        node: &mut ros2_client::Node,
        cfg: &crossym_control::NodeConfig,
    ) -> Result<Self, DdsError> {
        let command = match cfg.output {
            OutputMode::Velocity | OutputMode::Position => {
                CommandPublisher::Array(dds::publisher::<msg::Float64MultiArray>(
                    node,
                    &cfg.topics.command,
                    dds::qos_reliable_nonblocking(10),
                )?)
            }
            OutputMode::Trajectory => {
                CommandPublisher::Trajectory(dds::publisher::<msg::JointTrajectory>(
                    node,
                    &cfg.topics.command,
                    dds::qos_reliable_nonblocking(10),
                )?)
            }
        };
        Ok(Self {
            joint_states: dds::subscription::<msg::JointState>(
                node,
                &cfg.topics.joint_states,
                dds::qos_sensor(),
            )?,
            conditions: dds::subscription::<msg::SymmetryCondition>(
                node,
                &cfg.topics.symmetry_condition,
                dds::qos_reliable(10),
            )?,
            poses: match &cfg.task_pose {
                Some(p) => Some(dds::subscription::<msg::PoseStamped>(
                    node,
                    &p.topic,
                    dds::qos_sensor(),
                )?),
                None => None,
            },
            tf: match &cfg.task_pose {
                Some(p) if p.tf => Some(TfSubscriptions::create(node)?),
                _ => None,
            },
            command: Arc::new(command),
            status: dds::publisher::<msg::Status>(
                node,
                &cfg.topics.status,
                dds::qos_reliable_nonblocking(10),
            )?,
        })
    }
}

/// The command writer for the configured output mode.
pub(super) enum CommandPublisher {
    Array(ros2_client::Publisher<msg::Float64MultiArray>),
    Trajectory(ros2_client::Publisher<msg::JointTrajectory>),
}

impl CommandPublisher {
    /// The subscribers matched with the writer (`node` created it; ros2-client's
    /// `Publisher::get_subscription_count`: the remote readers RustDDS matched, updated by
    /// the spinner from the participant's matched / lost events). Locks the node's map:
    /// the I/O thread calls it, never the tick.
    pub(super) fn subscription_count(&self, node: &ros2_client::Node) -> usize {
        match self {
            CommandPublisher::Array(p) => p.get_subscription_count(node),
            CommandPublisher::Trajectory(p) => p.get_subscription_count(node),
        }
    }

    /// Publishes `cmd` (and hands a copy to the recorder with the tick time and inputs).
    pub(super) fn publish(
        &self,
        cmd: &Command,
        names: &[String],
        dt: f64,
        start_point: bool,
        rec: Option<(&Recorder, u64, u32)>,
    ) -> bool {
        match self {
            CommandPublisher::Array(p) => {
                let m = cmd.to_float64_multi_array();
                if let Some((r, t, q)) = rec {
                    r.send(RecordItem::Array(m.clone(), t, q));
                }
                p.publish(m).is_ok()
            }
            CommandPublisher::Trajectory(p) => {
                // Stamp 0: the controller starts the trajectory when it receives it (a stamp
                // from this machine's clock would shift it by any offset between the clocks).
                let m = cmd.to_joint_trajectory(names, dt, start_point);
                if let Some((r, t, q)) = rec {
                    r.send(RecordItem::Trajectory(m.clone(), t, q));
                }
                p.publish(m).is_ok()
            }
        }
    }
}
