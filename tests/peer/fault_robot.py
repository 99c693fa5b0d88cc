#!/usr/bin/env python3
"""Independent mock robot with input faults, for the crossym node (issue 16).

A velocity-controlled robot on Eclipse Cyclone DDS (PyPI `cyclonedds`), sharing no code
with crossym (the ROS message types come from `dds_peer.py`, written by hand):

- publishes sensor_msgs/JointState on `rt/joint_states` at 100 Hz (reliable, wall-clock
  stamps) with every movable joint of the URDF it is given;
- integrates the std_msgs/Float64MultiArray velocity commands it receives on
  `rt/forward_velocity_controller/commands` (reliable) over one 10 ms period of its own
  simulated clock per loop tick, holding the last command (as ros2_control's
  ForwardCommandController does); a late tick (the loop stalled) is counted in
  `late_ticks`, never integrated as a longer step;
- publishes crossym_msgs/SymmetryCondition on `rt/crossym/symmetry_condition`
  (reliable), switching every `--switch-s` seconds among conditions the shipped planar
  policy was trained on (any θ, λ ∈ [0.5, 1], σ = ±1);
- after `--warmup-s`, once a joint moves toward one of its position limits (at least
  `--min-speed` rad/s, within `--near` rad of it), injects input faults while STILL
  integrating commands: `--fault-s` seconds with one controlled joint's position NaN, then
  `--fault-s` seconds with that joint missing from the message, then `--after-s` seconds
  of valid states again;
- counts, from ITS OWN integrated positions, every controlled joint position beyond the
  limits of the URDF (`<limit lower upper velocity>`, tolerance 1e-9 rad) at every loop
  tick, every command beyond the velocity limit, and every non-finite command.

    python3 tests/peer/fault_robot.py --urdf tight.urdf [--joints a,b,...] [--initial-q ...]
        [--domain N] [--seed S] [--fault-joint NAME|random] [--bound upper|lower|any]
        [--trigger-joint NAME|any] [--json OUT]

Exit status: 0 no violation, 1 a position or velocity limit violation or a non-finite
command, 2 no command received from the node within `--timeout` s. The JSON report has
`violations`, `worst_excess_rad`, `ticks`, `commands_received`, `nonfinite_commands` and
more (see `main`). Run it in the node's network namespace and ROS_DOMAIN_ID.
"""
# No `from __future__ import annotations`: cyclonedds resolves annotations by name.

import argparse
import json
import math
import os
import random
import sys
import time
import xml.etree.ElementTree as ET

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

# The hand-written ROS 2 types and topic names of the independent peer (no side effects).
from dds_peer import (XCDR1, Float64MultiArray, Header, JointState, SymmetryCondition,
                      TOPIC_COMMANDS, TOPIC_CONDITION, TOPIC_JOINT_STATES, now_stamp)

PERIOD = 0.01  # s, 100 Hz
POS_TOL = 1e-9  # rad
VEL_TOL = 1e-9  # rad/s

# ros2_control-like QoS: joint_state_broadcaster and ForwardCommandController use the
# system default (reliable, volatile, keep last 10).
QOS_RELIABLE_W = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=20)),
                     Policy.Durability.Volatile, Policy.History.KeepLast(10), XCDR1)
QOS_RELIABLE_R = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=20)),
                     Policy.Durability.Volatile, Policy.History.KeepLast(10), XCDR1)

# (θ rad, λ, σ) inside the shipped planar π_MRT's trained box.
TRAINED_CONDITIONS = [
    (0.0, 1.0, 1),
    (0.5235987755982988, 0.8, -1),
    (-0.7853981633974483, 1.0, 1),
    (1.0471975511965976, 0.6, 1),
    (-1.5707963267948966, 0.9, -1),
    (2.6179938779914944, 0.5, 1),
    (0.2617993877991494, 0.7, -1),
    (-2.356194490192345, 1.0, -1),
]


def read_urdf_limits(path):
    """Movable joints of a URDF in document order: [(name, lower, upper, velocity)]."""
    root = ET.parse(path).getroot()
    out = []
    for j in root.iter("joint"):
        kind = j.get("type")
        if kind not in ("revolute", "prismatic", "continuous"):
            continue
        lim = j.find("limit")
        lo, hi, vel = -math.inf, math.inf, math.inf
        if lim is not None:
            if kind != "continuous":
                lo = float(lim.get("lower", "0"))
                hi = float(lim.get("upper", "0"))
            if lim.get("velocity") is not None:
                vel = float(lim.get("velocity"))
        out.append((j.get("name"), lo, hi, vel))
    return out


def parse_floats(s):
    return [float(x) for x in s.split(",") if x.strip()]


class Robot:
    """The simulated robot: positions of all movable joints, the held command."""

    def __init__(self, args, rng):
        joints = read_urdf_limits(args.urdf)
        if not joints:
            raise SystemExit(f"fault_robot: no movable joint in {args.urdf}")
        self.all_names = [j[0] for j in joints]
        by_name = {j[0]: j for j in joints}
        self.controlled = args.joints.split(",") if args.joints else list(self.all_names)
        for n in self.controlled:
            if n not in by_name:
                raise SystemExit(f"fault_robot: controlled joint {n!r} is not a movable joint of {args.urdf}")
        n = len(self.controlled)
        self.lower = [by_name[c][1] for c in self.controlled]
        self.upper = [by_name[c][2] for c in self.controlled]
        self.vmax = [by_name[c][3] for c in self.controlled]
        if args.initial_q:
            q0 = parse_floats(args.initial_q)
            if len(q0) != n:
                raise SystemExit(f"fault_robot: --initial-q has {len(q0)} values, {n} controlled joints")
        else:
            q0 = [0.5 * (lo + hi) if math.isfinite(lo + hi) else 0.0 for lo, hi in zip(self.lower, self.upper)]
        self.q = list(q0)
        self.others = {name: 0.0 for name in self.all_names if name not in self.controlled}
        self.cmd = [0.0] * n
        # fault joint (index into controlled)
        if args.fault_joint == "random":
            self.fault_idx = rng.randrange(n)
        elif args.fault_joint in self.controlled:
            self.fault_idx = self.controlled.index(args.fault_joint)
        else:
            raise SystemExit(f"fault_robot: --fault-joint {args.fault_joint!r} is not a controlled joint")
        if args.trigger_joint == "any":
            self.trigger_idx = list(range(n))
        elif args.trigger_joint == "random":
            self.trigger_idx = [rng.randrange(n)]
        elif args.trigger_joint in self.controlled:
            self.trigger_idx = [self.controlled.index(args.trigger_joint)]
        else:
            raise SystemExit(f"fault_robot: --trigger-joint {args.trigger_joint!r} is not a controlled joint")

    def joint_state(self, phase):
        """The message of this tick: NaN in `nan`, the fault joint dropped in `missing`."""
        names, pos = [], []
        ctrl = {c: k for k, c in enumerate(self.controlled)}
        for name in self.all_names:
            if name in ctrl:
                k = ctrl[name]
                if phase == "missing" and k == self.fault_idx:
                    continue
                pos.append(float("nan") if phase == "nan" and k == self.fault_idx else self.q[k])
            else:
                pos.append(self.others[name])
            names.append(name)
        return JointState(header=Header(stamp=now_stamp(), frame_id=""), name=names, position=pos,
                          velocity=[], effort=[])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--urdf", required=True, help="URDF whose <limit> the robot checks (the tightened copy)")
    ap.add_argument("--joints", help="controlled joints in command order, comma-separated "
                    "(default: every movable URDF joint in document order)")
    ap.add_argument("--initial-q", help="initial positions of the controlled joints (rad), comma-separated "
                    "(default: middle of the limits)")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--seed", type=int, default=0, help="condition order and random choices")
    ap.add_argument("--fault-joint", default="random", help="controlled joint made NaN / dropped, or 'random'")
    ap.add_argument("--trigger-joint", default="any",
                    help="joint whose approach to a limit starts the faults: a name, 'any' or 'random'")
    ap.add_argument("--bound", choices=["upper", "lower", "any"], default="any",
                    help="which limit the trigger joint must move toward")
    ap.add_argument("--near", type=float, default=0.03, help="trigger distance to the limit (rad)")
    ap.add_argument("--min-speed", type=float, default=0.3, help="trigger speed toward the limit (rad/s)")
    ap.add_argument("--warmup-s", type=float, default=0.5, help="valid states before faults may start (s)")
    ap.add_argument("--max-wait-s", type=float, default=8.0,
                    help="start the faults anyway this long after the warm-up (s; reported as a timeout)")
    ap.add_argument("--fault-s", type=float, default=2.0, help="length of each fault window (s)")
    ap.add_argument("--after-s", type=float, default=1.5, help="valid states after the faults (s)")
    ap.add_argument("--switch-s", type=float, default=2.0, help="symmetry condition switch period (s)")
    ap.add_argument("--timeout", type=float, default=20.0, help="wait this long for the node's first command (s)")
    ap.add_argument("--json", metavar="OUT", help="write the report here")
    args = ap.parse_args(argv)

    rng = random.Random(args.seed)
    robot = Robot(args, rng)
    n = len(robot.controlled)
    conditions = list(TRAINED_CONDITIONS)
    rng.shuffle(conditions)

    dp = DomainParticipant(args.domain)
    js_w = DataWriter(dp, Topic(dp, TOPIC_JOINT_STATES, JointState), qos=QOS_RELIABLE_W)
    cond_w = DataWriter(dp, Topic(dp, TOPIC_CONDITION, SymmetryCondition), qos=QOS_RELIABLE_W)
    cmd_r = DataReader(dp, Topic(dp, TOPIC_COMMANDS, Float64MultiArray), qos=QOS_RELIABLE_R)

    rep = {
        "domain": args.domain, "seed": args.seed, "urdf": args.urdf,
        "controlled": robot.controlled, "fault_joint": robot.controlled[robot.fault_idx],
        "lower": robot.lower, "upper": robot.upper, "velocity_limit": robot.vmax,
        "violations": 0, "position_violations": 0, "velocity_violations": 0,
        "worst_excess_rad": 0.0, "worst_joint": None, "worst_phase": None,
        "worst_velocity_excess": 0.0,
        "violations_by_phase": {}, "worst_excess_by_phase": {},
        "ticks": 0, "ticks_by_phase": {}, "late_ticks": 0, "max_loop_period_s": 0.0,
        "commands_received": 0, "nonfinite_commands": 0, "wrong_length_commands": 0,
        "commands_by_phase": {}, "nonzero_commands_by_phase": {},
        "joint_states_sent": 0, "conditions_sent": [], "trigger": None, "phases": {},
        "max_abs_velocity": [0.0] * n, "first_violation": None, "exit_code": 0,
    }

    def publish_condition(c):
        cond_w.write(SymmetryCondition(header=Header(stamp=now_stamp(), frame_id=""), theta=c[0],
                                       scale=c[1], reflection=c[2]))
        rep["conditions_sent"].append(list(c))

    t_start = time.monotonic()
    t_prev = t_start
    next_t = t_start
    phase = "discovery"  # discovery, warmup, armed, nan, missing, after, done
    phase_t0 = t_start
    first_cmd_t = None
    cond_k, next_cond_t = 0, math.inf
    cond_matched = False

    def enter(p, t):
        nonlocal phase, phase_t0
        phase, phase_t0 = p, t
        rep["phases"][p] = round(t - t_start, 4)

    try:
        while phase != "done":
            now = time.monotonic()
            if now < next_t:
                time.sleep(next_t - now)
                continue
            next_t += PERIOD
            if next_t < now - 0.05:  # fell far behind: resynchronise instead of bursting
                next_t = now + PERIOD
            dt = now - t_prev
            t_prev = now
            rep["ticks"] += 1
            rep["ticks_by_phase"][phase] = rep["ticks_by_phase"].get(phase, 0) + 1
            rep["max_loop_period_s"] = max(rep["max_loop_period_s"], dt)
            if dt > 2.0 * PERIOD:
                rep["late_ticks"] += 1

            # 1. Motion over one period of the robot's own (simulated) clock under the held
            #    command (the robot keeps moving whatever its sensors report). Simulated
            #    time: a stalled Python loop (late_ticks) slows this robot down instead of
            #    stepping it past the node's latency envelope; the test treats many late
            #    ticks as a failed precondition.
            for k in range(n):
                robot.q[k] += PERIOD * robot.cmd[k]

            # 2. Limits, from the robot's own positions.
            for k in range(n):
                lo, hi, q = robot.lower[k], robot.upper[k], robot.q[k]
                excess = q - hi if q > hi + POS_TOL else (lo - q if q < lo - POS_TOL else 0.0)
                if excess > 0.0:
                    rep["position_violations"] += 1
                    rep["violations_by_phase"][phase] = rep["violations_by_phase"].get(phase, 0) + 1
                    byp = rep["worst_excess_by_phase"]
                    byp[phase] = max(byp.get(phase, 0.0), excess)
                    if rep["first_violation"] is None:
                        rep["first_violation"] = {"t_s": round(now - t_start, 4), "phase": phase,
                                                  "joint": robot.controlled[k], "q": q, "excess_rad": excess}
                    if excess > rep["worst_excess_rad"]:
                        rep["worst_excess_rad"] = excess
                        rep["worst_joint"] = robot.controlled[k]
                        rep["worst_phase"] = phase

            # 3. Latest command (ForwardCommandController: the last message wins, held).
            samples = [s for s in cmd_r.take(N=100) if isinstance(s, Float64MultiArray)]
            for s in samples:
                data = list(s.data)
                rep["commands_received"] += 1
                rep["commands_by_phase"][phase] = rep["commands_by_phase"].get(phase, 0) + 1
                if any(v != 0.0 for v in data):
                    nz = rep["nonzero_commands_by_phase"]
                    nz[phase] = nz.get(phase, 0) + 1
                if len(data) != n:
                    rep["wrong_length_commands"] += 1
                    continue
                if not all(math.isfinite(v) for v in data):
                    rep["nonfinite_commands"] += 1
                    continue  # a real controller would forward it; we count and hold
                for k, v in enumerate(data):
                    rep["max_abs_velocity"][k] = max(rep["max_abs_velocity"][k], abs(v))
                    ex = abs(v) - robot.vmax[k]
                    if ex > VEL_TOL:
                        rep["velocity_violations"] += 1
                        rep["worst_velocity_excess"] = max(rep["worst_velocity_excess"], ex)
                robot.cmd = data

            # 4. Phase machine.
            if phase == "discovery":
                if rep["commands_received"] > 0:
                    first_cmd_t = now
                    enter("warmup", now)
                elif now - t_start > args.timeout:
                    break
            if not cond_matched and cond_w.get_publication_matched_status().current_count > 0:
                cond_matched = True
                next_cond_t = now + 0.2  # let the node's side of discovery settle
            if now >= next_cond_t:
                publish_condition(conditions[cond_k % len(conditions)])
                cond_k += 1
                next_cond_t = now + args.switch_s
            if phase == "warmup" and now - phase_t0 >= args.warmup_s and cond_k > 0:
                enter("armed", now)
            elif phase == "armed":
                hit = None
                for k in robot.trigger_idx:
                    v, q = robot.cmd[k], robot.q[k]
                    if args.bound in ("upper", "any") and v >= args.min_speed and robot.upper[k] - q <= args.near:
                        hit = (k, "upper", robot.upper[k] - q)
                    elif args.bound in ("lower", "any") and -v >= args.min_speed and q - robot.lower[k] <= args.near:
                        hit = (k, "lower", q - robot.lower[k])
                    if hit:
                        break
                timed_out = now - phase_t0 >= args.max_wait_s
                if hit or timed_out:
                    if hit:
                        k, b, d = hit
                        rep["trigger"] = {"kind": "approach", "joint": robot.controlled[k], "bound": b,
                                          "distance_rad": d, "velocity": robot.cmd[k], "q": robot.q[k],
                                          "t_s": round(now - t_start, 4)}
                    else:
                        rep["trigger"] = {"kind": "timeout", "t_s": round(now - t_start, 4)}
                    enter("nan", now)
            elif phase == "nan" and now - phase_t0 >= args.fault_s:
                enter("missing", now)
            elif phase == "missing" and now - phase_t0 >= args.fault_s:
                enter("after", now)
            elif phase == "after" and now - phase_t0 >= args.after_s:
                enter("done", now)
                break

            # 5. Joint states of this tick.
            try:
                js_w.write(robot.joint_state(phase))
                rep["joint_states_sent"] += 1
            except Exception as e:  # pragma: no cover - diagnostics only
                print(f"fault_robot: joint_states write failed: {e}", file=sys.stderr)
    finally:
        rep["duration_s"] = round(time.monotonic() - t_start, 3)
        rep["final_q"] = robot.q
        rep["final_command"] = robot.cmd
        rep["conditions_matched"] = cond_matched

    rep["violations"] = rep["position_violations"] + rep["velocity_violations"]
    if first_cmd_t is None:
        print(f"fault_robot: no command from the node within {args.timeout:g} s on domain {args.domain} "
              f"({TOPIC_COMMANDS})", file=sys.stderr)
        rep["exit_code"] = 2
    elif rep["violations"] or rep["nonfinite_commands"]:
        rep["exit_code"] = 1
    print(f"fault_robot: seed {args.seed}, fault joint {rep['fault_joint']}, trigger {rep['trigger']}")
    print(f"fault_robot: {rep['ticks']} ticks ({rep['late_ticks']} late, max period "
          f"{rep['max_loop_period_s'] * 1e3:.1f} ms), {rep['commands_received']} commands "
          f"({rep['nonfinite_commands']} non-finite), {rep['position_violations']} position and "
          f"{rep['velocity_violations']} velocity violations, worst excess "
          f"{rep['worst_excess_rad'] * 1e3:.3f} mrad ({rep['worst_joint']}, {rep['worst_phase']}), "
          f"by phase {rep['violations_by_phase']}, exit {rep['exit_code']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rep, f, indent=2)
    return rep["exit_code"]


if __name__ == "__main__":
    sys.exit(main())
