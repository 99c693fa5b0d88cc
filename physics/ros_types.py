"""ROS 2 message types written by hand for Eclipse Cyclone DDS (no ROS needed).

ROS 2 conventions over DDS: topic names `rt/<ros name>`, type names
`<pkg>::msg::dds_::<Type>_`, plain CDR (XCDR1, little endian, final structs); the field
order is the .msg order.
"""
# No `from __future__ import annotations`: cyclonedds resolves annotations by name.

import math
import time
from dataclasses import dataclass, field

from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types
from cyclonedds.qos import Policy, Qos
from cyclonedds.util import duration


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: types.int32 = 0
    nanosec: types.uint32 = 0


@dataclass
class Duration(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: types.int32 = 0
    nanosec: types.uint32 = 0


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time = field(default_factory=Time)
    frame_id: str = ""


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header = field(default_factory=Header)
    name: types.sequence[str] = field(default_factory=list)
    position: types.sequence[types.float64] = field(default_factory=list)
    velocity: types.sequence[types.float64] = field(default_factory=list)
    effort: types.sequence[types.float64] = field(default_factory=list)


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str = ""
    size: types.uint32 = 0
    stride: types.uint32 = 0


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: types.sequence[MultiArrayDimension] = field(default_factory=list)
    data_offset: types.uint32 = 0


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout = field(default_factory=MultiArrayLayout)
    data: types.sequence[types.float64] = field(default_factory=list)


@dataclass
class JointTrajectoryPoint(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectoryPoint_"):
    positions: types.sequence[types.float64] = field(default_factory=list)
    velocities: types.sequence[types.float64] = field(default_factory=list)
    accelerations: types.sequence[types.float64] = field(default_factory=list)
    effort: types.sequence[types.float64] = field(default_factory=list)
    time_from_start: Duration = field(default_factory=Duration)


@dataclass
class JointTrajectory(IdlStruct, typename="trajectory_msgs::msg::dds_::JointTrajectory_"):
    header: Header = field(default_factory=Header)
    joint_names: types.sequence[str] = field(default_factory=list)
    points: types.sequence[JointTrajectoryPoint] = field(default_factory=list)


TOPIC_JOINT_STATES = "rt/joint_states"
TOPIC_TRAJECTORY = "rt/both_arms_controller/joint_trajectory"
TOPIC_FORWARD = "rt/position_controller/commands"
TOPIC_RESET = "rt/mock_hw/reset"

XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)
# ros2_control's defaults (joint_state_broadcaster, JTC and forward controller subscriptions):
# reliable, volatile, keep last 10; XCDR1 only (what RustDDS / ros2-client speak).
QOS_RELIABLE = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=20)),
                   Policy.Durability.Volatile, Policy.History.KeepLast(10), XCDR1)


def stamp_from_ns(t_ns: int) -> Time:
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    return Time(sec=sec, nanosec=nsec)


def now_stamp(offset_s: float = 0.0) -> Time:
    t = time.time() + offset_s
    sec = int(math.floor(t))
    return Time(sec=sec, nanosec=min(int((t - sec) * 1e9), 999_999_999))


def time_to_ns(t) -> int:
    return int(t.sec) * 1_000_000_000 + int(t.nanosec)
