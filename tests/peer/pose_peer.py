#!/usr/bin/env python3
"""A perception node's stand-in: publishes the pan's pose and watches the crossym node's
condition follow it (independent of crossym: Cyclone DDS, types written by hand).

    python3 tests/peer/pose_peer.py [--domain N] [--timeout S] [--json OUT]

The node runs config/rby1-pan.toml ([node.task_pose]: frame link_torso_5, the pan's centre
(0.38, 0, -0.25) m, its vertical axis z, the handle 0.18 m along the pan's -y, mirror plane
y = 0). The pan is turned about its axis step by step while the robot works; for each pose
the expected condition is computed here from the handle's position (not by crossym's
formula): the handle direction h = R_z(yaw) (0, -1); on the right (h_y < 0) the arm that
demonstrated grasps, sigma = +1 and theta with R(theta) (0, -1) = h; on the left sigma = -1
and theta with M R(theta) (0, -1) = h (M: y -> -y), i.e. R(theta) (0, -1) = (h_x, -h_y).

Steps: four poses (each published at 20 Hz with fresh stamps until ~/status shows the
expected condition); two poses seen from a camera (the config's `tf = true`): the
camera's mount fixed on the torso on /tf_static (transient local, published once), the
camera on its pan joint on /tf (fresh stamps with every pose), the pose stated in the
camera's frame (computed here by inverting the two edges); the camera's /tf edge stopped
(its last stamp ages past the tolerance: refused); a pose in a frame no edge names, a moved pan and a stale pose (each for 1 s:
the condition must stay); a symmetry_condition message (the last source wins: the status
shows it); the pose again (it wins back). Exit 0 when every check passed, 1 otherwise, 2
when the node never answered.
"""
# No `from __future__ import annotations`: cyclonedds resolves field annotations by name.

import argparse
import json
import math
import os
import sys
import time
from dataclasses import dataclass, field

from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dds_peer import (QOS_CONDITION_W, QOS_JOINT_STATES_W, QOS_NODE_OUTPUT_R,  # noqa: E402
                      Header, Status, SymmetryCondition, now_stamp)


@dataclass
class Point(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: types.float64 = 0.0
    y: types.float64 = 0.0
    z: types.float64 = 0.0


@dataclass
class Quaternion(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: types.float64 = 0.0
    y: types.float64 = 0.0
    z: types.float64 = 0.0
    w: types.float64 = 1.0


@dataclass
class Pose(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point = field(default_factory=Point)
    orientation: Quaternion = field(default_factory=Quaternion)


@dataclass
class PoseStamped(IdlStruct, typename="geometry_msgs::msg::dds_::PoseStamped_"):
    header: Header = field(default_factory=Header)
    pose: Pose = field(default_factory=Pose)


@dataclass
class Vector3(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: types.float64 = 0.0
    y: types.float64 = 0.0
    z: types.float64 = 0.0


@dataclass
class Transform(IdlStruct, typename="geometry_msgs::msg::dds_::Transform_"):
    translation: Vector3 = field(default_factory=Vector3)
    rotation: Quaternion = field(default_factory=Quaternion)


@dataclass
class TransformStamped(IdlStruct, typename="geometry_msgs::msg::dds_::TransformStamped_"):
    header: Header = field(default_factory=Header)
    child_frame_id: str = ""
    transform: Transform = field(default_factory=Transform)


@dataclass
class TFMessage(IdlStruct, typename="tf2_msgs::msg::dds_::TFMessage_"):
    transforms: types.sequence[TransformStamped] = field(default_factory=list)


# tf2's static broadcaster QoS (reliable, transient local, depth 1) and its /tf one.
QOS_TF_STATIC_W = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                      Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
QOS_TF_W = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
               Policy.Durability.Volatile, Policy.History.KeepLast(100))


def qmul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def qconj(q):
    return (-q[0], -q[1], -q[2], q[3])


def qrot(q, v):
    x, y, z, _ = qmul(qmul(q, (v[0], v[1], v[2], 0.0)), qconj(q))
    return (x, y, z)


# The camera: its mount 0.45 m above the torso frame, pitched 0.6 rad down (static); the
# camera itself on a pan joint 3 cm above the mount, turned 0.25 rad (moving).
MOUNT = ((0.05, 0.0, 0.45), (0.0, math.sin(0.3), 0.0, math.cos(0.3)))
CAMERA = ((0.0, 0.0, 0.03), (0.0, 0.0, math.sin(0.125), math.cos(0.125)))


def edge(parent: str, child: str, t, q, age: float = 0.0) -> TransformStamped:
    return TransformStamped(
        header=Header(stamp=now_stamp(-age), frame_id=parent), child_frame_id=child,
        transform=Transform(translation=Vector3(*t), rotation=Quaternion(*q)))


def seen_from_camera(pose: PoseStamped) -> PoseStamped:
    """The pose (in the torso frame) stated in the camera's frame: T_cam = (S D)^-1."""
    (ts, qs), (td, qd) = MOUNT, CAMERA
    q_tot = qmul(qs, qd)
    t_tot = tuple(a + b for a, b in zip(qrot(qs, td), ts))
    inv = qconj(q_tot)
    p = pose.pose.position
    o = pose.pose.orientation
    pc = qrot(inv, (p.x - t_tot[0], p.y - t_tot[1], p.z - t_tot[2]))
    qc = qmul(inv, (o.x, o.y, o.z, o.w))
    return PoseStamped(header=Header(stamp=pose.header.stamp, frame_id="camera"),
                       pose=Pose(position=Point(*pc), orientation=Quaternion(*qc)))


CENTRE = (0.38, 0.0, -0.25)
FRAME = "link_torso_5"


def pan_pose(yaw: float, frame: str = FRAME, dx: float = 0.0, age: float = 0.0) -> PoseStamped:
    return PoseStamped(
        header=Header(stamp=now_stamp(-age), frame_id=frame),
        pose=Pose(position=Point(x=CENTRE[0] + dx, y=CENTRE[1], z=CENTRE[2]),
                  orientation=Quaternion(z=math.sin(yaw / 2), w=math.cos(yaw / 2))))


def expected(yaw: float):
    """(theta, sigma) from the handle's direction (module docstring)."""
    hx, hy = math.sin(yaw), -math.cos(yaw)
    if hy < 0:
        return math.atan2(hx, -hy), 1
    return math.atan2(hx, hy), -1


def angle_diff(a: float, b: float) -> float:
    return abs(math.atan2(math.sin(a - b), math.cos(a - b)))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--json", type=str)
    args = ap.parse_args()

    dp = DomainParticipant(args.domain)
    pose_w = DataWriter(dp, Topic(dp, "rt/crossym/task_pose", PoseStamped), qos=QOS_JOINT_STATES_W)
    cond_w = DataWriter(dp, Topic(dp, "rt/crossym/symmetry_condition", SymmetryCondition), qos=QOS_CONDITION_W)
    status_r = DataReader(dp, Topic(dp, "rt/crossym/status", Status), qos=QOS_NODE_OUTPUT_R)
    tf_static_w = DataWriter(dp, Topic(dp, "rt/tf_static", TFMessage), qos=QOS_TF_STATIC_W)
    tf_w = DataWriter(dp, Topic(dp, "rt/tf", TFMessage), qos=QOS_TF_W)
    # Published once, before anything else: the node gets it from the writer's history.
    tf_static_w.write(TFMessage(transforms=[edge(FRAME, "mount", *MOUNT)]))
    latest = {"status": None}
    results = []

    def poll_status():
        for s in status_r.take(N=100):
            latest["status"] = s

    def shows(theta: float, sigma: int) -> bool:
        s = latest["status"]
        return (s is not None and s.condition.reflection == sigma
                and angle_diff(s.condition.theta, theta) < 1e-6 and abs(s.condition.scale - 1.0) < 1e-9)

    def publish_until(make, pred, timeout: float) -> bool:
        end = time.time() + timeout
        while time.time() < end:
            pose_w.write(make())
            poll_status()
            if pred():
                return True
            time.sleep(0.05)
        return False

    def check(name: str, ok: bool, detail: str = ""):
        results.append({"check": name, "ok": ok, "detail": detail})
        print(("PASS " if ok else "FAIL ") + name + (": " + detail if detail else ""), flush=True)

    # The node is up once a status arrives.
    end = time.time() + args.timeout
    while latest["status"] is None and time.time() < end:
        poll_status()
        time.sleep(0.05)
    if latest["status"] is None:
        print("no status from the node within the timeout", file=sys.stderr)
        return 2

    for deg in (20.0, -40.0, 150.0, -110.0):
        yaw = math.radians(deg)
        theta, sigma = expected(yaw)
        ok = publish_until(lambda: pan_pose(yaw), lambda: shows(theta, sigma), args.timeout)
        s = latest["status"]
        check(f"pan turned {deg:+.0f} deg -> theta {math.degrees(theta):+.1f} deg, sigma {sigma:+d}", ok,
              f"status shows theta {math.degrees(s.condition.theta):+.3f} deg, sigma {s.condition.reflection:+d}")

    # Seen from the camera: the camera's pan edge on /tf with every pose.
    def from_camera(yaw: float, edge_age: float = 0.0) -> PoseStamped:
        if edge_age == 0.0:
            tf_w.write(TFMessage(transforms=[edge("mount", "camera", *CAMERA)]))
        return seen_from_camera(pan_pose(yaw))

    for deg in (60.0, 170.0):
        yaw = math.radians(deg)
        theta, sigma = expected(yaw)
        ok = publish_until(lambda: from_camera(yaw), lambda: shows(theta, sigma), args.timeout)
        s = latest["status"]
        check(f"seen from the camera through /tf: pan turned {deg:+.0f} deg -> theta "
              f"{math.degrees(theta):+.1f} deg, sigma {sigma:+d}", ok,
              f"status shows theta {math.degrees(s.condition.theta):+.3f} deg, sigma {s.condition.reflection:+d}")
    last = expected(math.radians(170.0))
    # The camera's /tf edge stops (its last stamp ages past tf_tolerance_s): refused.
    time.sleep(0.3)
    moved = publish_until(lambda: from_camera(0.3, edge_age=1.0), lambda: not shows(*last), 1.0)
    check("a camera pose whose /tf edge stopped is refused", not moved, "the condition changed" if moved else "")

    # Refused poses: the condition in force stays for a second of them.
    for name, make in (("a frame no edge names", lambda: pan_pose(0.3, frame="world")),
                       ("a moved pan", lambda: pan_pose(0.3, dx=0.1)),
                       ("a stale pose", lambda: pan_pose(0.3, age=2.0))):
        moved = publish_until(make, lambda: not shows(*last), 1.0)
        check(f"{name} is refused", not moved, "the condition changed" if moved else "")

    # A condition message: the last source wins.
    t_end = time.time() + args.timeout
    ok = False
    while time.time() < t_end and not ok:
        cond_w.write(SymmetryCondition(header=Header(stamp=now_stamp()), theta=0.1, scale=1.0, reflection=1))
        time.sleep(0.1)
        poll_status()
        ok = shows(0.1, 1)
    check("a symmetry_condition message takes over from the pose", ok)
    yaw = math.radians(10.0)
    theta, sigma = expected(yaw)
    ok = publish_until(lambda: pan_pose(yaw), lambda: shows(theta, sigma), args.timeout)
    check("the pose takes over again", ok)

    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0 if all(r["ok"] for r in results) else 1


if __name__ == "__main__":
    raise SystemExit(main())
