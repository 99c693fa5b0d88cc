//! Topics over DDS into a new rosbag2 MCAP bag (`crossym record`): the four topics of a
//! configured node and any `NAME:pkg/msg/Type` of the message types crossym knows, each
//! subscribed best effort (which matches reliable and best-effort writers) and written
//! with its receive time, until a stop flag or a duration.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::dds::{self, DdsError, DdsSettings};
use crossym_control::node::{NodeConfig, OutputMode};
use crossym_io::bag::writer::TopicId;
use crossym_io::bag::{BagError, BagWriter, Qos};
use crossym_io::msg::{self, RosMessage};

/// Errors of a recording.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// A topic is not written `NAME:pkg/msg/Type`.
    #[error("topic `{spec}`: expected /name:pkg/msg/Type")]
    Spec {
        /// The text given.
        spec: String,
    },
    /// A topic's type is not one crossym can record.
    #[error("topic {topic}: type `{ros_type}` is not one crossym can record (JointState, SymmetryCondition, Float64MultiArray, JointTrajectory, Status)")]
    UnknownType {
        /// The topic.
        topic: String,
        /// Its type as given.
        ros_type: String,
    },
    /// No topic to record.
    #[error("nothing to record: no topics (a node's config or NAME:pkg/msg/Type)")]
    Nothing,
    /// The duration is negative or not a number.
    #[error("duration_s = {value} must be ≥ 0")]
    Duration {
        /// The duration given (s).
        value: f64,
    },
    /// DDS setup failed.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// The bag could not be created or written.
    #[error(transparent)]
    Bag(#[from] BagError),
}

/// The message types crossym records.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RecordedType {
    /// `sensor_msgs/msg/JointState`.
    JointState,
    /// `crossym_msgs/msg/SymmetryCondition`.
    SymmetryCondition,
    /// `std_msgs/msg/Float64MultiArray`.
    Float64MultiArray,
    /// `trajectory_msgs/msg/JointTrajectory`.
    JointTrajectory,
    /// `crossym_msgs/msg/Status`.
    Status,
}

impl RecordedType {
    /// Every type crossym records.
    pub const ALL: [Self; 5] = [
        Self::JointState,
        Self::SymmetryCondition,
        Self::Float64MultiArray,
        Self::JointTrajectory,
        Self::Status,
    ];

    /// The ROS type name (`pkg/msg/Type`).
    pub fn ros_type(self) -> &'static str {
        match self {
            Self::JointState => msg::JointState::ROS_TYPE,
            Self::SymmetryCondition => msg::SymmetryCondition::ROS_TYPE,
            Self::Float64MultiArray => msg::Float64MultiArray::ROS_TYPE,
            Self::JointTrajectory => msg::JointTrajectory::ROS_TYPE,
            Self::Status => msg::Status::ROS_TYPE,
        }
    }

    /// The type named `ros_type` (`pkg/msg/Type`), if crossym records it.
    pub fn from_ros_type(ros_type: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.ros_type() == ros_type)
    }
}

/// One topic to record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordTopic {
    /// The topic's absolute name.
    pub name: String,
    /// Its message type.
    pub kind: RecordedType,
}

impl RecordTopic {
    /// Reads `NAME:pkg/msg/Type` (the last `:` separates the type).
    pub fn parse(spec: &str) -> Result<Self, RecordError> {
        let (name, ty) = spec.rsplit_once(':').ok_or_else(|| RecordError::Spec {
            spec: spec.to_string(),
        })?;
        let kind = RecordedType::from_ros_type(ty).ok_or_else(|| RecordError::UnknownType {
            topic: name.to_string(),
            ros_type: ty.to_string(),
        })?;
        Ok(Self {
            name: name.to_string(),
            kind,
        })
    }

    /// The four topics of the node configured by `n`: joint states, conditions, commands
    /// (of its output mode's type) and status.
    pub fn node_topics(n: &NodeConfig) -> Vec<Self> {
        let topic = |t: &str, kind| Self {
            name: dds::expand_topic(t, &n.namespace, &n.name),
            kind,
        };
        let command = match n.output {
            OutputMode::Trajectory => RecordedType::JointTrajectory,
            _ => RecordedType::Float64MultiArray,
        };
        vec![
            topic(&n.topics.joint_states, RecordedType::JointState),
            topic(
                &n.topics.symmetry_condition,
                RecordedType::SymmetryCondition,
            ),
            topic(&n.topics.command, command),
            topic(&n.topics.status, RecordedType::Status),
        ]
    }
}

/// What to record and where, validated once by [`Recorder::open`].
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSettings {
    /// The bag directory (must not exist).
    pub out: PathBuf,
    /// The topics (at least one).
    pub topics: Vec<RecordTopic>,
    /// Stop after this many seconds (`None`: only when stopped).
    pub duration_s: Option<f64>,
}

impl RecordSettings {
    /// Checks that there is a topic and the duration is a number ≥ 0.
    pub fn validate(&self) -> Result<(), RecordError> {
        if self.topics.is_empty() {
            return Err(RecordError::Nothing);
        }
        match self.duration_s {
            Some(d) if d.is_nan() || d < 0.0 => Err(RecordError::Duration { value: d }),
            _ => Ok(()),
        }
    }
}

/// A subscription of one recorded type.
enum Sub {
    Js(ros2_client::Subscription<msg::JointState>),
    Cond(ros2_client::Subscription<msg::SymmetryCondition>),
    Arr(ros2_client::Subscription<msg::Float64MultiArray>),
    Traj(ros2_client::Subscription<msg::JointTrajectory>),
    Status(ros2_client::Subscription<msg::Status>),
}

/// A recording under way: the subscriptions and the bag they are written to.
pub struct Recorder {
    writer: BagWriter,
    subs: Vec<(Sub, TopicId)>,
    settings: RecordSettings,
    _node: ros2_client::Node,
    _ctx: ros2_client::Context,
}

/// Subscribes to `name` and adds it to the bag.
fn add<M>(
    node: &mut ros2_client::Node,
    w: &mut BagWriter,
    name: &str,
) -> Result<(ros2_client::Subscription<M>, TopicId), RecordError>
where
    M: RosMessage + DeserializeOwned + 'static,
{
    // Best effort matches reliable and best-effort writers.
    let sub = dds::subscription::<M>(node, name, dds::qos_sensor())?;
    let id = w.add_topic::<M>(name, Qos::best_effort(5))?;
    Ok((sub, id))
}

/// Writes every waiting message of `sub` with its receive time; whether there was one.
fn drain<M: Serialize + DeserializeOwned + 'static>(
    sub: &ros2_client::Subscription<M>,
    w: &mut BagWriter,
    id: TopicId,
) -> Result<bool, BagError> {
    let mut any = false;
    while let Ok(Some((m, _))) = sub.take() {
        w.write(id, &m, dds::wall_time_ns(), 0)?;
        any = true;
    }
    Ok(any)
}

impl Recorder {
    /// Validates `settings`, opens a participant with `dds`, creates the bag and subscribes
    /// to every topic.
    pub fn open(settings: RecordSettings, dds: &DdsSettings) -> Result<Self, RecordError> {
        settings.validate()?;
        let ctx = dds.context()?;
        let mut node = ctx
            .new_node(
                dds::node_name("/", &format!("crossym_recorder_{}", std::process::id()))?,
                ros2_client::NodeOptions::new().enable_rosout(false),
            )
            .map_err(|e| DdsError::Create {
                what: "recorder node".into(),
                message: format!("{e:?}"),
            })?;
        let mut w = BagWriter::create(&settings.out)?;
        let mut subs = Vec::with_capacity(settings.topics.len());
        for t in &settings.topics {
            let (n, name) = (&mut node, t.name.as_str());
            subs.push(match t.kind {
                RecordedType::JointState => {
                    let (s, id) = add(n, &mut w, name)?;
                    (Sub::Js(s), id)
                }
                RecordedType::SymmetryCondition => {
                    let (s, id) = add(n, &mut w, name)?;
                    (Sub::Cond(s), id)
                }
                RecordedType::Float64MultiArray => {
                    let (s, id) = add(n, &mut w, name)?;
                    (Sub::Arr(s), id)
                }
                RecordedType::JointTrajectory => {
                    let (s, id) = add(n, &mut w, name)?;
                    (Sub::Traj(s), id)
                }
                RecordedType::Status => {
                    let (s, id) = add(n, &mut w, name)?;
                    (Sub::Status(s), id)
                }
            });
        }
        Ok(Self {
            writer: w,
            subs,
            settings,
            _node: node,
            _ctx: ctx,
        })
    }

    /// The settings recorded with.
    pub fn settings(&self) -> &RecordSettings {
        &self.settings
    }

    /// Records until `stop` is set or the duration has passed, then closes the bag;
    /// returns the number of messages written.
    pub fn run(mut self, stop: &AtomicBool) -> Result<u64, RecordError> {
        let start = Instant::now();
        let duration = self.settings.duration_s;
        while !stop.load(Ordering::Relaxed)
            && duration.is_none_or(|d| start.elapsed().as_secs_f64() < d)
        {
            let mut any = false;
            for (sub, id) in &self.subs {
                let w = &mut self.writer;
                any |= match sub {
                    Sub::Js(s) => drain(s, w, *id)?,
                    Sub::Cond(s) => drain(s, w, *id)?,
                    Sub::Arr(s) => drain(s, w, *id)?,
                    Sub::Traj(s) => drain(s, w, *id)?,
                    Sub::Status(s) => drain(s, w, *id)?,
                };
            }
            if !any {
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        let n = self.writer.message_count();
        self.writer.finish()?;
        Ok(n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_are_read_and_their_types_checked() {
        let t = RecordTopic::parse("/joint_states:sensor_msgs/msg/JointState").unwrap();
        assert_eq!(
            (t.name.as_str(), t.kind),
            ("/joint_states", RecordedType::JointState)
        );
        // The last `:` separates the type.
        let t = RecordTopic::parse("/a:b:std_msgs/msg/Float64MultiArray").unwrap();
        assert_eq!(t.name, "/a:b");
        assert!(matches!(
            RecordTopic::parse("/joint_states"),
            Err(RecordError::Spec { .. })
        ));
        let e = RecordTopic::parse("/x:geometry_msgs/msg/Twist").unwrap_err();
        assert!(matches!(e, RecordError::UnknownType { .. }));
        assert!(e.to_string().contains("geometry_msgs/msg/Twist"), "{e}");
        for t in RecordedType::ALL {
            assert_eq!(RecordedType::from_ros_type(t.ros_type()), Some(t));
        }
    }

    #[test]
    fn settings_need_a_topic_and_a_duration_of_at_least_zero() {
        let s = |topics: Vec<RecordTopic>, duration_s| RecordSettings {
            out: "bag".into(),
            topics,
            duration_s,
        };
        let one = || vec![RecordTopic::parse("/js:sensor_msgs/msg/JointState").unwrap()];
        assert!(matches!(
            s(vec![], None).validate(),
            Err(RecordError::Nothing)
        ));
        assert!(s(one(), None).validate().is_ok());
        assert!(s(one(), Some(0.0)).validate().is_ok());
        for bad in [-1.0, f64::NAN] {
            assert!(matches!(
                s(one(), Some(bad)).validate(),
                Err(RecordError::Duration { .. })
            ));
        }
    }
}
