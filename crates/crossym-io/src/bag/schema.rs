//! Message definitions as rosbag2 stores them in MCAP schemas (encoding `ros2msg`): the
//! type's `.msg` text, then every dependency once, each after a line of 80 `=` and a
//! `MSG: pkg/Type` line. crossym's own types use the `.msg` files of `msgs/`; the standard
//! types (comment-free, fully qualified field types) are written here.

use crate::msg::{
    Float64MultiArray, JointState, JointTrajectory, PoseStamped, RosMessage, Status,
    SymmetryCondition, TransitionEvent,
};

const TIME: &str = "int32 sec\nuint32 nanosec\n";
const DURATION: &str = "int32 sec\nuint32 nanosec\n";
const HEADER: &str = "builtin_interfaces/Time stamp\nstring frame_id\n";
const JOINT_STATE: &str = "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n";
const MULTI_ARRAY_DIMENSION: &str = "string label\nuint32 size\nuint32 stride\n";
const MULTI_ARRAY_LAYOUT: &str = "std_msgs/MultiArrayDimension[] dim\nuint32 data_offset\n";
const FLOAT64_MULTI_ARRAY: &str = "std_msgs/MultiArrayLayout layout\nfloat64[] data\n";
const JOINT_TRAJECTORY_POINT: &str = "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\nbuiltin_interfaces/Duration time_from_start\n";
const JOINT_TRAJECTORY: &str =
    "std_msgs/Header header\nstring[] joint_names\ntrajectory_msgs/JointTrajectoryPoint[] points\n";
const POINT: &str = "float64 x\nfloat64 y\nfloat64 z\n";
const QUATERNION: &str = "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1\n";
const POSE: &str = "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation\n";
const POSE_STAMPED: &str = "std_msgs/Header header\ngeometry_msgs/Pose pose\n";
const LIFECYCLE_STATE: &str = "uint8 id\nstring label\n";
const LIFECYCLE_TRANSITION: &str = "uint8 id\nstring label\n";
const TRANSITION_EVENT: &str = "uint64 timestamp\nlifecycle_msgs/Transition transition\nlifecycle_msgs/State start_state\nlifecycle_msgs/State goal_state\n";
const SYMMETRY_CONDITION: &str = include_str!("../../../../msgs/msg/SymmetryCondition.msg");
const STATUS: &str = include_str!("../../../../msgs/msg/Status.msg");

/// A dependency: `(pkg/Type, text)`.
type Dep = (&'static str, &'static str);

/// `(ROS type, own text, dependencies in order)`.
const TABLE: &[(&str, &str, &[Dep])] = &[
    (
        JointState::ROS_TYPE,
        JOINT_STATE,
        &[
            ("std_msgs/Header", HEADER),
            ("builtin_interfaces/Time", TIME),
        ],
    ),
    (
        Float64MultiArray::ROS_TYPE,
        FLOAT64_MULTI_ARRAY,
        &[
            ("std_msgs/MultiArrayLayout", MULTI_ARRAY_LAYOUT),
            ("std_msgs/MultiArrayDimension", MULTI_ARRAY_DIMENSION),
        ],
    ),
    (
        JointTrajectory::ROS_TYPE,
        JOINT_TRAJECTORY,
        &[
            ("std_msgs/Header", HEADER),
            ("builtin_interfaces/Time", TIME),
            (
                "trajectory_msgs/JointTrajectoryPoint",
                JOINT_TRAJECTORY_POINT,
            ),
            ("builtin_interfaces/Duration", DURATION),
        ],
    ),
    (
        PoseStamped::ROS_TYPE,
        POSE_STAMPED,
        &[
            ("std_msgs/Header", HEADER),
            ("builtin_interfaces/Time", TIME),
            ("geometry_msgs/Pose", POSE),
            ("geometry_msgs/Point", POINT),
            ("geometry_msgs/Quaternion", QUATERNION),
        ],
    ),
    (
        SymmetryCondition::ROS_TYPE,
        SYMMETRY_CONDITION,
        &[
            ("std_msgs/Header", HEADER),
            ("builtin_interfaces/Time", TIME),
        ],
    ),
    (
        TransitionEvent::ROS_TYPE,
        TRANSITION_EVENT,
        &[
            ("lifecycle_msgs/Transition", LIFECYCLE_TRANSITION),
            ("lifecycle_msgs/State", LIFECYCLE_STATE),
        ],
    ),
    (
        Status::ROS_TYPE,
        STATUS,
        &[
            ("std_msgs/Header", HEADER),
            ("builtin_interfaces/Time", TIME),
            ("crossym_msgs/SymmetryCondition", SYMMETRY_CONDITION),
        ],
    ),
];

/// The rosbag2 schema text of a ROS type (`pkg/msg/Type`), or `None` if crossym does not
/// know the type.
pub fn schema_text(ros_type: &str) -> Option<String> {
    let (_, own, deps) = TABLE.iter().find(|(t, _, _)| *t == ros_type)?;
    let mut s = own.to_string();
    for (name, text) in deps.iter() {
        if !s.ends_with('\n') {
            s.push('\n');
        }
        s.push_str(&"=".repeat(80));
        s.push_str("\nMSG: ");
        s.push_str(name);
        s.push('\n');
        s.push_str(text);
    }
    Some(s)
}

/// The schema text of message type `M`.
pub fn schema_of<M: RosMessage>() -> String {
    schema_text(M::ROS_TYPE).expect("every crossym message type has a schema")
}
