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
expected condition); a pose in another frame, a moved pan and a stale pose (each for 1 s:
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
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

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
    last = expected(math.radians(-110.0))

    # Refused poses: the condition in force stays for a second of them.
    for name, make in (("another frame", lambda: pan_pose(0.3, frame="world")),
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
