//! Rust mirrors of the ROS 2 messages the node speaks, fields in CDR (declaration) order.
//!
//! Each type implements [`RosMessage`]: its DDS type name (`pkg::msg::dds_::Name_`), its
//! ROS type (`pkg/msg/Name`) and a hand-maintained field table in `.msg` syntax. The
//! integration tests check the tables against the shipped `msgs/msg/*.msg` files and
//! against serde's field order, so the layout cannot drift silently.

use serde::{Deserialize, Serialize};

/// A ROS 2 message type mirrored in Rust.
pub trait RosMessage {
    /// DDS type name, e.g. `sensor_msgs::msg::dds_::JointState_`.
    const TYPE_NAME: &'static str;
    /// ROS type, e.g. `sensor_msgs/msg/JointState`.
    const ROS_TYPE: &'static str;
    /// `(name, type)` of every field in declaration (CDR) order, types in `.msg` syntax.
    const FIELDS: &'static [(&'static str, &'static str)];
}

macro_rules! ros_message {
    ($t:ty, $dds:literal, $ros:literal, [$(($n:literal, $ty:literal)),* $(,)?]) => {
        impl RosMessage for $t {
            const TYPE_NAME: &'static str = $dds;
            const ROS_TYPE: &'static str = $ros;
            const FIELDS: &'static [(&'static str, &'static str)] = &[$(($n, $ty)),*];
        }
    };
}

/// `builtin_interfaces/Time`: a point in time (s + ns since the clock's epoch).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds (s).
    pub sec: i32,
    /// Nanoseconds within the second (ns, < 1e9).
    pub nanosec: u32,
}

impl Time {
    /// From seconds (s); saturates outside the `i32` range, non-finite → 0.
    pub fn from_secs_f64(t: f64) -> Self {
        if !t.is_finite() {
            return Self::default();
        }
        let s = t.floor();
        let ns = ((t - s) * 1e9).round().clamp(0.0, 999_999_999.0) as u32;
        Self {
            sec: s.clamp(i32::MIN as f64, i32::MAX as f64) as i32,
            nanosec: ns,
        }
    }

    /// As seconds (s).
    pub fn as_secs_f64(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }

    /// True for the zero stamp (publishers that leave the header empty).
    pub fn is_zero(&self) -> bool {
        self.sec == 0 && self.nanosec == 0
    }
}

ros_message!(
    Time,
    "builtin_interfaces::msg::dds_::Time_",
    "builtin_interfaces/msg/Time",
    [("sec", "int32"), ("nanosec", "uint32")]
);

/// `builtin_interfaces/Duration`: a time span (s + ns).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds (s).
    pub sec: i32,
    /// Nanoseconds within the second (ns, < 1e9).
    pub nanosec: u32,
}

impl Duration {
    /// From seconds (s); non-finite → 0.
    pub fn from_secs_f64(t: f64) -> Self {
        let Time { sec, nanosec } = Time::from_secs_f64(t);
        Self { sec, nanosec }
    }
}

ros_message!(
    Duration,
    "builtin_interfaces::msg::dds_::Duration_",
    "builtin_interfaces/msg/Duration",
    [("sec", "int32"), ("nanosec", "uint32")]
);

/// `std_msgs/Header`: stamp and coordinate frame.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Acquisition time.
    pub stamp: Time,
    /// Coordinate frame (may be empty).
    pub frame_id: String,
}

ros_message!(
    Header,
    "std_msgs::msg::dds_::Header_",
    "std_msgs/msg/Header",
    [("stamp", "builtin_interfaces/Time"), ("frame_id", "string")]
);

/// `sensor_msgs/JointState`: named joint positions (rad or m), velocities, efforts.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp of the measurement.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions (rad or m), one per name.
    pub position: Vec<f64>,
    /// Velocities (rad/s or m/s); empty or one per name.
    pub velocity: Vec<f64>,
    /// Efforts (N·m or N); empty or one per name.
    pub effort: Vec<f64>,
}

ros_message!(
    JointState,
    "sensor_msgs::msg::dds_::JointState_",
    "sensor_msgs/msg/JointState",
    [
        ("header", "std_msgs/Header"),
        ("name", "string[]"),
        ("position", "float64[]"),
        ("velocity", "float64[]"),
        ("effort", "float64[]"),
    ]
);

/// `geometry_msgs/Point`: a position (m).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    /// x (m).
    pub x: f64,
    /// y (m).
    pub y: f64,
    /// z (m).
    pub z: f64,
}

ros_message!(
    Point,
    "geometry_msgs::msg::dds_::Point_",
    "geometry_msgs/msg/Point",
    [("x", "float64"), ("y", "float64"), ("z", "float64")]
);

/// `geometry_msgs/Quaternion`: an orientation `x i + y j + z k + w`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w (1 in the identity, ROS's default).
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

ros_message!(
    Quaternion,
    "geometry_msgs::msg::dds_::Quaternion_",
    "geometry_msgs/msg/Quaternion",
    [
        ("x", "float64"),
        ("y", "float64"),
        ("z", "float64"),
        ("w", "float64"),
    ]
);

/// `geometry_msgs/Pose`: a position and an orientation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    /// Position (m).
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

ros_message!(
    Pose,
    "geometry_msgs::msg::dds_::Pose_",
    "geometry_msgs/msg/Pose",
    [
        ("position", "geometry_msgs/Point"),
        ("orientation", "geometry_msgs/Quaternion"),
    ]
);

/// `geometry_msgs/PoseStamped`: a pose in a frame at a time (e.g. a perceived object).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and frame of the pose.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

ros_message!(
    PoseStamped,
    "geometry_msgs::msg::dds_::PoseStamped_",
    "geometry_msgs/msg/PoseStamped",
    [
        ("header", "std_msgs/Header"),
        ("pose", "geometry_msgs/Pose")
    ]
);

/// `geometry_msgs/Vector3`: a free vector (here a translation, m).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

ros_message!(
    Vector3,
    "geometry_msgs::msg::dds_::Vector3_",
    "geometry_msgs/msg/Vector3",
    [("x", "float64"), ("y", "float64"), ("z", "float64")]
);

/// `geometry_msgs/Transform`: the pose of a child frame in its parent (`p_parent =
/// R(rotation) p_child + translation`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation (m).
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

ros_message!(
    Transform,
    "geometry_msgs::msg::dds_::Transform_",
    "geometry_msgs/msg/Transform",
    [
        ("translation", "geometry_msgs/Vector3"),
        ("rotation", "geometry_msgs/Quaternion"),
    ]
);

/// `geometry_msgs/TransformStamped`: one edge of the TF tree (`header.frame_id` the parent).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// The child frame.
    pub child_frame_id: String,
    /// The child's pose in the parent.
    pub transform: Transform,
}

ros_message!(
    TransformStamped,
    "geometry_msgs::msg::dds_::TransformStamped_",
    "geometry_msgs/msg/TransformStamped",
    [
        ("header", "std_msgs/Header"),
        ("child_frame_id", "string"),
        ("transform", "geometry_msgs/Transform"),
    ]
);

/// `tf2_msgs/TFMessage`: the edges `/tf` and `/tf_static` carry.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// The transforms.
    pub transforms: Vec<TransformStamped>,
}

ros_message!(
    TFMessage,
    "tf2_msgs::msg::dds_::TFMessage_",
    "tf2_msgs/msg/TFMessage",
    [("transforms", "geometry_msgs/TransformStamped[]")]
);

/// `std_msgs/MultiArrayDimension`: one dimension of a multi-array layout.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    /// Dimension label (e.g. `joints`).
    pub label: String,
    /// Number of elements along it (count).
    pub size: u32,
    /// Stride (count of elements).
    pub stride: u32,
}

ros_message!(
    MultiArrayDimension,
    "std_msgs::msg::dds_::MultiArrayDimension_",
    "std_msgs/msg/MultiArrayDimension",
    [
        ("label", "string"),
        ("size", "uint32"),
        ("stride", "uint32")
    ]
);

/// `std_msgs/MultiArrayLayout`: dimensions and data offset.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    /// Dimensions (ForwardCommandController leaves this empty).
    pub dim: Vec<MultiArrayDimension>,
    /// Padding elements at the front of `data` (count).
    pub data_offset: u32,
}

ros_message!(
    MultiArrayLayout,
    "std_msgs::msg::dds_::MultiArrayLayout_",
    "std_msgs/msg/MultiArrayLayout",
    [
        ("dim", "std_msgs/MultiArrayDimension[]"),
        ("data_offset", "uint32")
    ]
);

/// `std_msgs/Float64MultiArray`: the command of ros2_control's ForwardCommandController.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    /// Layout (empty for a flat vector).
    pub layout: MultiArrayLayout,
    /// Values (rad/s or rad, in the controller's joint order).
    pub data: Vec<f64>,
}

ros_message!(
    Float64MultiArray,
    "std_msgs::msg::dds_::Float64MultiArray_",
    "std_msgs/msg/Float64MultiArray",
    [
        ("layout", "std_msgs/MultiArrayLayout"),
        ("data", "float64[]")
    ]
);

/// `trajectory_msgs/JointTrajectoryPoint`: one waypoint.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    /// Positions (rad or m).
    pub positions: Vec<f64>,
    /// Velocities (rad/s or m/s).
    pub velocities: Vec<f64>,
    /// Accelerations (rad/s² or m/s²).
    pub accelerations: Vec<f64>,
    /// Efforts (N·m or N).
    pub effort: Vec<f64>,
    /// Time of the point relative to the trajectory's header stamp.
    pub time_from_start: Duration,
}

ros_message!(
    JointTrajectoryPoint,
    "trajectory_msgs::msg::dds_::JointTrajectoryPoint_",
    "trajectory_msgs/msg/JointTrajectoryPoint",
    [
        ("positions", "float64[]"),
        ("velocities", "float64[]"),
        ("accelerations", "float64[]"),
        ("effort", "float64[]"),
        ("time_from_start", "builtin_interfaces/Duration"),
    ]
);

/// `trajectory_msgs/JointTrajectory`: named joints and waypoints.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    /// Start time (zero: start now).
    pub header: Header,
    /// Joint names, the order of every point's vectors.
    pub joint_names: Vec<String>,
    /// Waypoints.
    pub points: Vec<JointTrajectoryPoint>,
}

ros_message!(
    JointTrajectory,
    "trajectory_msgs::msg::dds_::JointTrajectory_",
    "trajectory_msgs/msg/JointTrajectory",
    [
        ("header", "std_msgs/Header"),
        ("joint_names", "string[]"),
        ("points", "trajectory_msgs/JointTrajectoryPoint[]"),
    ]
);

/// `crossym_msgs/SymmetryCondition`: the policy's condition `s = (θ, λ, σ)`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SymmetryCondition {
    /// Stamp of the request.
    pub header: Header,
    /// Rotation angle `θ` (rad).
    pub theta: f64,
    /// Scaling factor `λ` (dimensionless, > 0).
    pub scale: f64,
    /// Reflection index `σ` (±1).
    pub reflection: i8,
}

ros_message!(
    SymmetryCondition,
    "crossym_msgs::msg::dds_::SymmetryCondition_",
    "crossym_msgs/msg/SymmetryCondition",
    [
        ("header", "std_msgs/Header"),
        ("theta", "float64"),
        ("scale", "float64"),
        ("reflection", "int8"),
    ]
);

/// `crossym_msgs/Status`: the node's state, last error and tick timing.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Status {
    /// Stamp of the tick described.
    pub header: Header,
    /// Status code (`crossym_control::StatusCode` names them).
    pub code: i8,
    /// Text of the code.
    pub message: String,
    /// Reason of the last rejected input (empty when none).
    pub last_error: String,
    /// Joints on a bound in the last tick (count).
    pub active_constraints: u32,
    /// Rejected joint_states messages since start (count).
    pub rejected_joint_states: u32,
    /// Rejected symmetry_condition messages since start (count).
    pub rejected_conditions: u32,
    /// Ticks since start (count).
    pub ticks: u64,
    /// Ticks with stale or missing joint states (count).
    pub stale_ticks: u64,
    /// Age of the joint state of the last tick (s); negative when none.
    pub joint_state_age_s: f64,
    /// Duration of the last tick (µs).
    pub tick_time_us: f64,
    /// Maximum tick duration since start (µs).
    pub tick_time_max_us: f64,
    /// Condition of the last tick.
    pub condition: SymmetryCondition,
    /// Position modes: restarts from the measured state since start (count).
    pub restarts: u64,
    /// Position modes: ticks held because the robot does not follow (count).
    pub not_following_ticks: u64,
    /// Position modes: ticks reported as TRACKING_ERROR (count).
    pub tracking_warning_ticks: u64,
    /// Position modes: largest |measured − commanded| over the joints at the last tick (rad or m).
    pub tracking_error: f64,
    /// Paused by an operator (`~/pause`).
    pub paused: bool,
    /// `velocity_scale` in force.
    pub velocity_scale: f64,
    /// Worst condition number of the chains' task Jacobians at the last tick.
    pub singularity_condition: f64,
    /// Factor the singularity band applied at the last tick.
    pub singularity_factor: f64,
    /// Worst code of the ticks since the previous status.
    pub period_code: i8,
    /// Ticks since the previous status (count).
    pub period_ticks: u32,
    /// Restarts from the measured state since the previous status (count).
    pub period_restarts: u32,
    /// Robot-held detections since the previous status (count).
    pub period_held: u32,
    /// Locked-joint detections since the previous status (count).
    pub period_locked: u32,
    /// Rejected input messages since the previous status (count).
    pub period_rejected: u32,
    /// Stale ticks since the previous status (count).
    pub period_stale_ticks: u32,
    /// Safety fallbacks since the previous status (count).
    pub period_fallback_ticks: u32,
    /// Robot-held detections since start (count).
    pub held_events: u64,
    /// Locked-joint detections since start (count).
    pub locked_events: u64,
    /// The joint last found locked (empty: none).
    pub locked_joint: String,
    /// Subscribers matched on the command topic (−1: not known).
    pub command_subscribers: i32,
    /// Ticks started more than half a period late since start (count).
    pub late_ticks: u64,
    /// Ticks never run since start: timer ticks skipped, joint states ticked together (count).
    pub missed_ticks: u64,
    /// Late ticks since the previous status (count).
    pub period_late_ticks: u32,
    /// Missed ticks since the previous status (count).
    pub period_missed_ticks: u32,
    /// Largest lateness of a tick's start since start (µs).
    pub tick_late_max_us: f64,
}

ros_message!(
    Status,
    "crossym_msgs::msg::dds_::Status_",
    "crossym_msgs/msg/Status",
    [
        ("header", "std_msgs/Header"),
        ("code", "int8"),
        ("message", "string"),
        ("last_error", "string"),
        ("active_constraints", "uint32"),
        ("rejected_joint_states", "uint32"),
        ("rejected_conditions", "uint32"),
        ("ticks", "uint64"),
        ("stale_ticks", "uint64"),
        ("joint_state_age_s", "float64"),
        ("tick_time_us", "float64"),
        ("tick_time_max_us", "float64"),
        ("condition", "crossym_msgs/SymmetryCondition"),
        ("restarts", "uint64"),
        ("not_following_ticks", "uint64"),
        ("tracking_warning_ticks", "uint64"),
        ("tracking_error", "float64"),
        ("paused", "bool"),
        ("velocity_scale", "float64"),
        ("singularity_condition", "float64"),
        ("singularity_factor", "float64"),
        ("period_code", "int8"),
        ("period_ticks", "uint32"),
        ("period_restarts", "uint32"),
        ("period_held", "uint32"),
        ("period_locked", "uint32"),
        ("period_rejected", "uint32"),
        ("period_stale_ticks", "uint32"),
        ("period_fallback_ticks", "uint32"),
        ("held_events", "uint64"),
        ("locked_events", "uint64"),
        ("locked_joint", "string"),
        ("command_subscribers", "int32"),
        ("late_ticks", "uint64"),
        ("missed_ticks", "uint64"),
        ("period_late_ticks", "uint32"),
        ("period_missed_ticks", "uint32"),
        ("tick_late_max_us", "float64"),
    ]
);

/// `lifecycle_msgs/State`: a state of a managed (lifecycle) node.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LifecycleState {
    /// State id (`lifecycle_msgs/State` constants: 1 unconfigured, 2 inactive, 3 active,
    /// 4 finalized, 10–15 the transition states).
    pub id: u8,
    /// State label (`"inactive"`, …).
    pub label: String,
}

ros_message!(
    LifecycleState,
    "lifecycle_msgs::msg::dds_::State_",
    "lifecycle_msgs/msg/State",
    [("id", "uint8"), ("label", "string")]
);

/// `lifecycle_msgs/Transition`: a transition of a managed node.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct LifecycleTransition {
    /// Transition id (`lifecycle_msgs/Transition` constants: 1 configure, 2 cleanup,
    /// 3 activate, 4 deactivate, 5–7 shutdown, 10–52 the transition states' outcomes).
    pub id: u8,
    /// Transition label (`"activate"`, …); a request naming a label is looked up by it.
    pub label: String,
}

ros_message!(
    LifecycleTransition,
    "lifecycle_msgs::msg::dds_::Transition_",
    "lifecycle_msgs/msg/Transition",
    [("id", "uint8"), ("label", "string")]
);

/// `lifecycle_msgs/TransitionDescription`: a transition with its start and goal states.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TransitionDescription {
    /// The transition.
    pub transition: LifecycleTransition,
    /// The state it starts from.
    pub start_state: LifecycleState,
    /// The state it leads to.
    pub goal_state: LifecycleState,
}

ros_message!(
    TransitionDescription,
    "lifecycle_msgs::msg::dds_::TransitionDescription_",
    "lifecycle_msgs/msg/TransitionDescription",
    [
        ("transition", "lifecycle_msgs/Transition"),
        ("start_state", "lifecycle_msgs/State"),
        ("goal_state", "lifecycle_msgs/State"),
    ]
);

/// `lifecycle_msgs/TransitionEvent`: published on `~/transition_event` at each step of a
/// transition.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct TransitionEvent {
    /// When (ns since the Unix epoch).
    pub timestamp: u64,
    /// The transition taken.
    pub transition: LifecycleTransition,
    /// The state left.
    pub start_state: LifecycleState,
    /// The state reached.
    pub goal_state: LifecycleState,
}

ros_message!(
    TransitionEvent,
    "lifecycle_msgs::msg::dds_::TransitionEvent_",
    "lifecycle_msgs/msg/TransitionEvent",
    [
        ("timestamp", "uint64"),
        ("transition", "lifecycle_msgs/Transition"),
        ("start_state", "lifecycle_msgs/State"),
        ("goal_state", "lifecycle_msgs/State"),
    ]
);
