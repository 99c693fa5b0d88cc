#!/usr/bin/env python3
"""Independent ROS 2-compatible DDS peer for the crossym node (no ROS needed).

It speaks to the node with Eclipse Cyclone DDS (PyPI `cyclonedds`), using the ROS 2
DDS conventions by hand: topic names `rt/<ros name>`, type names
`<pkg>::msg::dds_::<Type>_`, plain XCDR1 (CDR, little endian, final structs).

    python3 tests/peer/dds_peer.py --scenario {basic,bad_input} [--domain N]
                                   [--timeout S] [--json OUT]
    python3 tests/peer/dds_peer.py --cdr-selftest   # types' CDR bytes only, no DDS traffic

Topics (as seen from the node):
  node subscribes  rt/joint_states                sensor_msgs/JointState        best effort
  node subscribes  rt/crossym/symmetry_condition  crossym_msgs/SymmetryCondition reliable, volatile, keep last
  node publishes   rt/forward_velocity_controller/commands  std_msgs/Float64MultiArray  reliable, keep last 10
  node publishes   rt/crossym/status              crossym_msgs/Status           reliable, keep last 10

Exit status: 0 all checks passed, 1 a check failed, 2 nothing was received from the
node within --timeout (reason on stderr). Run it in the same network namespace as the
node (e.g. both under `tools/netns-run`): discovery uses SPDP multicast on
`lo`, which netns-run enables; no CYCLONEDDS_URI is needed there.
"""
# No `from __future__ import annotations` here: cyclonedds resolves string annotations
# such as "types.sequence[str]" by name in this module and fails on them.

import argparse
import json
import math
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import Callable, List, Optional

from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

# --------------------------------------------------------------------------------------
# ROS 2 message types (field order = the .msg order; ROS 2 structs are final, XCDR1)
# --------------------------------------------------------------------------------------


# The standard ROS 2 types (builtin_interfaces, std_msgs, sensor_msgs) are the physics
# robot's (`physics/ros_types.py`, also written by hand for Cyclone DDS, no crossym code);
# the crossym_msgs types below are this peer's own.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "physics"))
from ros_types import (Float64MultiArray, Header, JointState, MultiArrayDimension,  # noqa: E402,F401
                       MultiArrayLayout, Time)


@dataclass
class SymmetryCondition(IdlStruct, typename="crossym_msgs::msg::dds_::SymmetryCondition_"):
    header: Header = field(default_factory=Header)
    theta: types.float64 = 0.0
    scale: types.float64 = 1.0
    reflection: types.int8 = 1


@dataclass
class Status(IdlStruct, typename="crossym_msgs::msg::dds_::Status_"):
    header: Header = field(default_factory=Header)
    code: types.int8 = 0
    message: str = ""
    last_error: str = ""
    active_constraints: types.uint32 = 0
    rejected_joint_states: types.uint32 = 0
    rejected_conditions: types.uint32 = 0
    ticks: types.uint64 = 0
    stale_ticks: types.uint64 = 0
    joint_state_age_s: types.float64 = 0.0
    tick_time_us: types.float64 = 0.0
    tick_time_max_us: types.float64 = 0.0
    condition: SymmetryCondition = field(default_factory=SymmetryCondition)
    restarts: types.uint64 = 0
    not_following_ticks: types.uint64 = 0
    tracking_warning_ticks: types.uint64 = 0
    tracking_error: types.float64 = 0.0
    paused: bool = False
    velocity_scale: types.float64 = 1.0
    singularity_condition: types.float64 = 0.0
    singularity_factor: types.float64 = 1.0
    period_code: types.int8 = 0
    period_ticks: types.uint32 = 0
    period_restarts: types.uint32 = 0
    period_held: types.uint32 = 0
    period_locked: types.uint32 = 0
    period_rejected: types.uint32 = 0
    period_stale_ticks: types.uint32 = 0
    period_fallback_ticks: types.uint32 = 0
    held_events: types.uint64 = 0
    locked_events: types.uint64 = 0
    locked_joint: str = ""
    command_subscribers: types.int32 = -1
    late_ticks: types.uint64 = 0
    missed_ticks: types.uint64 = 0
    period_late_ticks: types.uint32 = 0
    period_missed_ticks: types.uint32 = 0
    tick_late_max_us: types.float64 = 0.0


# crossym_msgs/Status constants
NO_WARNING = 0
JOINT_BOUND = 5
STALE_JOINT_STATES = 16
INVALID_INPUT = 17
SAFETY_FALLBACK = 18
POLICY_NONFINITE = 19
SHUTDOWN = 20

# --------------------------------------------------------------------------------------
# The node's interface
# --------------------------------------------------------------------------------------

TOPIC_JOINT_STATES = "rt/joint_states"
TOPIC_CONDITION = "rt/crossym/symmetry_condition"
TOPIC_COMMANDS = "rt/forward_velocity_controller/commands"
TOPIC_STATUS = "rt/crossym/status"

JOINTS = [f"left_joint{i}" for i in range(1, 5)] + [f"right_joint{i}" for i in range(1, 5)]
REST = [0.785398, -0.523599, -0.392699, -0.314159, -0.785398, 0.523599, 0.392699, 0.314159]
VEL_LIMIT = 3.0  # rad/s, every controlled joint
VEL_TOL = 1e-9
JS_PERIOD = 0.01  # 100 Hz
STALE_TIMEOUT = 0.1  # s, the node's joint-state stale timeout
# No rates or durations are asserted (a loaded CI machine would fail them; speed is measured
# by the criterion benches): each window waits until it holds this many messages, or until
# --timeout passes, and then checks the count.
STEADY_COMMANDS = 150  # the node ticks at 100 Hz: about 1.5 s
STEADY_STATUSES = 15  # status at 10 Hz: about 1.5 s

# ROS 2 default-ish QoS, XCDR1 only (what RustDDS / ros2-client speak).
XCDR1 = Policy.DataRepresentation(use_cdrv0_representation=True)
QOS_JOINT_STATES_W = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile,
                         Policy.History.KeepLast(10), XCDR1)
QOS_CONDITION_W = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                      Policy.Durability.Volatile, Policy.History.KeepLast(10), XCDR1)
QOS_NODE_OUTPUT_R = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                        Policy.Durability.Volatile, Policy.History.KeepLast(1000), XCDR1)


def now_stamp(offset_s: float = 0.0) -> Time:
    t = time.time() + offset_s
    sec = int(math.floor(t))
    return Time(sec=sec, nanosec=min(int((t - sec) * 1e9), 999_999_999))


def good_joint_state(extra: bool = False) -> JointState:
    names, pos = list(JOINTS), list(REST)
    if extra:
        names.append("torso_joint")
        pos.append(0.1)
    n = len(names)
    return JointState(header=Header(stamp=now_stamp(), frame_id=""), name=names, position=pos,
                      velocity=[0.0] * n, effort=[0.0] * n)


def make_condition(theta: float, scale: float, reflection: int) -> SymmetryCondition:
    return SymmetryCondition(header=Header(stamp=now_stamp(), frame_id=""), theta=theta,
                             scale=scale, reflection=reflection)


# Bad joint states: name -> builder. Each must be rejected by the node.
def _bad_nan() -> JointState:
    m = good_joint_state()
    m.position[2] = float("nan")
    return m


def _bad_missing() -> JointState:
    m = good_joint_state()
    for seq in (m.name, m.position, m.velocity, m.effort):
        del seq[-1]  # drops right_joint4
    return m


def _bad_length() -> JointState:
    m = good_joint_state()
    del m.position[-1]  # 8 names, 7 positions
    return m


def _bad_duplicate() -> JointState:
    m = good_joint_state()
    m.name.append("left_joint1")
    m.position.append(0.0)
    m.velocity.append(0.0)
    m.effort.append(0.0)
    return m


def _bad_unknown_only() -> JointState:
    return JointState(header=Header(stamp=now_stamp()), name=["torso_joint"], position=[0.0],
                      velocity=[0.0], effort=[0.0])


def _bad_stale_stamp() -> JointState:
    m = good_joint_state()
    m.header.stamp = now_stamp(-5.0)
    return m


BAD_JOINT_STATES = [
    ("nan_position", _bad_nan),
    ("missing_joint", _bad_missing),
    ("length_mismatch", _bad_length),
    ("duplicate_joint", _bad_duplicate),
    ("unknown_names_only", _bad_unknown_only),
    ("stale_stamp", _bad_stale_stamp),
]

BAD_CONDITIONS = [
    ("reflection_3", (0.0, 1.0, 3)),
    ("scale_0", (0.0, 0.0, 1)),
    ("scale_negative", (0.0, -1.0, 1)),
    ("theta_nan", (float("nan"), 1.0, 1)),
    # Valid, but outside the conditions the shipped policy was trained on (λ ∈ [0.5, 1]).
    ("scale_untrained_large", (0.0, 1.2, 1)),
    ("scale_untrained_small", (0.0, 0.3, -1)),
]

# --------------------------------------------------------------------------------------
# Peer machinery
# --------------------------------------------------------------------------------------


class Peer:
    def __init__(self, domain: int):
        self.dp = DomainParticipant(domain)
        t_js = Topic(self.dp, TOPIC_JOINT_STATES, JointState)
        t_cond = Topic(self.dp, TOPIC_CONDITION, SymmetryCondition)
        t_cmd = Topic(self.dp, TOPIC_COMMANDS, Float64MultiArray)
        t_status = Topic(self.dp, TOPIC_STATUS, Status)
        self.js_writer = DataWriter(self.dp, t_js, qos=QOS_JOINT_STATES_W)
        self.cond_writer = DataWriter(self.dp, t_cond, qos=QOS_CONDITION_W)
        self.cmd_reader = DataReader(self.dp, t_cmd, qos=QOS_NODE_OUTPUT_R)
        self.status_reader = DataReader(self.dp, t_status, qos=QOS_NODE_OUTPUT_R)

        self.lock = threading.Lock()
        self.commands: List[tuple] = []  # (monotonic recv time, list of floats)
        self.statuses: List[tuple] = []  # (monotonic recv time, Status)
        self._stop = threading.Event()
        # joint-state stream control
        self._js_enabled = False
        self._js_extra = False
        self._js_override: Optional[Callable[[], JointState]] = None
        self._js_override_until = 0.0
        self.js_sent = 0
        self.js_bad_sent = 0
        self._threads = [threading.Thread(target=self._rx_loop, daemon=True),
                         threading.Thread(target=self._js_loop, daemon=True)]
        for t in self._threads:
            t.start()

    # ---- threads -------------------------------------------------------------------
    def _rx_loop(self):
        while not self._stop.is_set():
            got = False
            for reader, sink in ((self.cmd_reader, self.commands), (self.status_reader, self.statuses)):
                try:
                    samples = reader.take(N=1000)
                except Exception as e:  # pragma: no cover - diagnostics only
                    print(f"take failed: {e}", file=sys.stderr)
                    samples = []
                t = time.monotonic()
                valid = [s for s in samples if isinstance(s, (Float64MultiArray, Status))]
                if valid:
                    got = True
                    with self.lock:
                        for s in valid:
                            sink.append((t, list(s.data) if isinstance(s, Float64MultiArray) else s))
            if not got:
                time.sleep(0.002)

    def _js_loop(self):
        next_t = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if now < next_t:
                time.sleep(next_t - now)
                continue
            next_t += JS_PERIOD
            if next_t < now - 0.05:  # fell far behind: do not burst
                next_t = now + JS_PERIOD
            with self.lock:
                enabled, extra = self._js_enabled, self._js_extra
                override = self._js_override if now < self._js_override_until else None
            if not enabled:
                continue
            msg = override() if override else good_joint_state(extra)
            try:
                self.js_writer.write(msg)
                self.js_sent += 1
                if override:
                    self.js_bad_sent += 1
            except Exception as e:  # pragma: no cover
                print(f"joint_states write failed: {e}", file=sys.stderr)

    def close(self):
        self._stop.set()
        for t in self._threads:
            t.join(timeout=1.0)

    # ---- controls ------------------------------------------------------------------
    def set_joint_states(self, enabled: bool, extra: bool = False):
        with self.lock:
            self._js_enabled, self._js_extra = enabled, extra

    def inject_joint_state(self, builder: Callable[[], JointState], seconds: float):
        """Replace the good stream by `builder()` messages for `seconds` (keep it < stale timeout)."""
        with self.lock:
            self._js_override = builder
            self._js_override_until = time.monotonic() + seconds
        time.sleep(seconds + 0.005)

    def publish_condition(self, c: SymmetryCondition):
        self.cond_writer.write(c)

    # ---- queries -------------------------------------------------------------------
    def n_commands(self) -> int:
        with self.lock:
            return len(self.commands)

    def n_statuses(self) -> int:
        with self.lock:
            return len(self.statuses)

    def commands_since(self, t0: float) -> List[tuple]:
        with self.lock:
            return [c for c in self.commands if c[0] >= t0]

    def statuses_since(self, t0: float) -> List[tuple]:
        with self.lock:
            return [s for s in self.statuses if s[0] >= t0]

    def wait_counts(self, since: float, n_commands: int, n_statuses: int, timeout: float):
        """Commands and statuses received at or after `since`, once there are at least
        `n_commands` and `n_statuses` of them or `timeout` has passed (the caller checks the
        counts)."""
        deadline = time.monotonic() + timeout
        while True:
            cmds, sts = self.commands_since(since), self.statuses_since(since)
            if (len(cmds) >= n_commands and len(sts) >= n_statuses) or time.monotonic() >= deadline:
                return cmds, sts
            time.sleep(0.01)

    def first_status(self) -> Optional[Status]:
        with self.lock:
            return self.statuses[0][1] if self.statuses else None

    def latest_status(self) -> Optional[Status]:
        with self.lock:
            return self.statuses[-1][1] if self.statuses else None

    def wait_status(self, pred: Callable[[Status], bool], timeout: float, since: float) -> Optional[Status]:
        """First status received at or after `since` that satisfies `pred`, or None."""
        deadline = time.monotonic() + timeout
        idx = 0
        while True:
            with self.lock:
                cand = [s for s in self.statuses if s[0] >= since][idx:]
            for _, s in cand:
                if pred(s):
                    return s
            idx += len(cand)
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.01)

    def wait_matched_writer(self, writer: DataWriter, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if writer.get_publication_matched_status().current_count > 0:
                return True
            time.sleep(0.02)
        return False

    def diagnostics(self) -> str:
        lines = []
        for label, ent, kind in (("joint_states writer", self.js_writer, "w"),
                                 ("symmetry_condition writer", self.cond_writer, "w"),
                                 ("commands reader", self.cmd_reader, "r"),
                                 ("status reader", self.status_reader, "r")):
            try:
                if kind == "w":
                    m = ent.get_publication_matched_status().current_count
                    inc = ent.get_offered_incompatible_qos_status()
                else:
                    m = ent.get_subscription_matched_status().current_count
                    inc = ent.get_requested_incompatible_qos_status()
                lines.append(f"  {label}: matched {m}, incompatible-QoS events {inc.total_count}"
                             + (f" (last policy id {inc.last_policy_id})" if inc.total_count else ""))
            except Exception as e:  # pragma: no cover
                lines.append(f"  {label}: status unavailable ({e})")
        try:
            from cyclonedds.builtin import (BuiltinDataReader, BuiltinTopicDcpsPublication,
                                            BuiltinTopicDcpsSubscription)
            own = str(self.dp.guid)[:24] if hasattr(self.dp, "guid") else None
            for label, bt in (("remote publications", BuiltinTopicDcpsPublication),
                              ("remote subscriptions", BuiltinTopicDcpsSubscription)):
                r = BuiltinDataReader(self.dp, bt)
                eps = [e for e in r.read(N=200) if hasattr(e, "topic_name")]
                eps = [e for e in eps if own is None or not str(e.participant_key).startswith(own)]
                lines.append(f"  {label} discovered: {len(eps)}")
                for e in eps:
                    rel = "?"
                    try:
                        rel = type(e.qos[Policy.Reliability]).__name__
                        if rel == "Policy":  # singleton BestEffort
                            rel = "BestEffort"
                    except Exception:
                        pass
                    lines.append(f"    {e.topic_name}  [{e.type_name}]  {rel}")
        except Exception as e:  # pragma: no cover
            lines.append(f"  builtin-topic discovery listing unavailable ({e})")
        return "\n".join(lines)


# --------------------------------------------------------------------------------------
# Checks
# --------------------------------------------------------------------------------------


class Report:
    def __init__(self):
        self.checks: List[dict] = []
        self.info: List[str] = []

    def check(self, name: str, ok: bool, detail: str = "") -> bool:
        self.checks.append({"name": name, "ok": bool(ok), "detail": detail})
        print(f"{'PASS' if ok else 'FAIL'}  {name}" + (f": {detail}" if detail else ""), flush=True)
        return bool(ok)

    def note(self, text: str):
        self.info.append(text)
        print(f"INFO  {text}", flush=True)

    @property
    def failed(self) -> int:
        return sum(1 for c in self.checks if not c["ok"])

    @property
    def passed(self) -> int:
        return sum(1 for c in self.checks if c["ok"])


def command_problems(cmds: List[tuple]) -> List[str]:
    bad = []
    for i, (_, data) in enumerate(cmds):
        if len(data) != len(JOINTS):
            bad.append(f"#{i}: {len(data)} entries")
        elif not all(math.isfinite(v) for v in data):
            bad.append(f"#{i}: non-finite {data}")
        elif max(abs(v) for v in data) > VEL_LIMIT + VEL_TOL:
            bad.append(f"#{i}: |v| max {max(abs(v) for v in data):.6g} > {VEL_LIMIT}")
    return bad


def check_commands(rep: Report, name: str, cmds: List[tuple], min_count: int = 1) -> bool:
    bad = command_problems(cmds)
    ok = len(cmds) >= min_count and not bad
    detail = f"{len(cmds)} commands"
    if len(cmds) < min_count:
        detail += f" (< {min_count})"
    if bad:
        detail += f", {len(bad)} invalid, e.g. {bad[0]}"
    return rep.check(name, ok, detail)


def cond_matches(c: SymmetryCondition, theta: float, scale: float, reflection: int) -> bool:
    return (abs(c.theta - theta) <= 1e-9 and abs(c.scale - scale) <= 1e-9
            and int(c.reflection) == int(reflection))


def fmt_cond(c: SymmetryCondition) -> str:
    return f"(theta {c.theta:.6g}, scale {c.scale:.6g}, reflection {c.reflection})"


def wait_for_node(peer: Peer, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if peer.n_commands() > 0 and peer.n_statuses() > 0:
            return True
        time.sleep(0.02)
    return peer.n_commands() > 0 or peer.n_statuses() > 0


def apply_condition(peer: Peer, rep: Report, name: str, cond: tuple, timeout: float) -> Optional[Status]:
    """Publish a good condition; PASS when a later status echoes it (re-publish once if lost)."""
    t0 = time.monotonic()
    peer.publish_condition(make_condition(*cond))
    st = peer.wait_status(lambda s: cond_matches(s.condition, *cond), min(timeout, 3.0), t0)
    if st is None:  # a volatile sample may race the node's discovery of our writer
        rep.note(f"{name}: no echo after 3 s, publishing the condition again")
        peer.publish_condition(make_condition(*cond))
        st = peer.wait_status(lambda s: cond_matches(s.condition, *cond), timeout, t0)
    last = peer.latest_status()
    rep.check(name, st is not None,
              f"echoed {fmt_cond(st.condition)}" if st else
              f"sent {cond}, latest status.condition {fmt_cond(last.condition) if last else 'none'}")
    return st


def scenario_basic(peer: Peer, rep: Report, timeout: float):
    # steady state with fresh joint states
    time.sleep(0.5)
    t0 = time.monotonic()
    cmds, sts = peer.wait_counts(t0, STEADY_COMMANDS, STEADY_STATUSES, timeout)
    check_commands(rep, f"commands with fresh joint states: >= {STEADY_COMMANDS}, 8 finite entries within "
                   f"±3 rad/s (within {timeout:g} s)", cmds, STEADY_COMMANDS)
    rep.check(f"status with fresh joint states: >= {STEADY_STATUSES} (within {timeout:g} s)",
              len(sts) >= STEADY_STATUSES, f"{len(sts)} statuses")
    if sts:
        codes = sorted({int(s.code) for _, s in sts})
        rep.check("status: code not STALE/INVALID with fresh joint states",
                  all(int(s.code) not in (STALE_JOINT_STATES, INVALID_INPUT) for _, s in sts),
                  f"codes seen {codes}")
        last = sts[-1][1]
        first = peer.first_status()
        fresh_node = first.rejected_joint_states == 0 and first.rejected_conditions == 0
        rep.check("status: no rejected input" + ("" if fresh_node else " since the peer started"),
                  last.rejected_joint_states == first.rejected_joint_states
                  and last.rejected_conditions == first.rejected_conditions
                  and (last.last_error == "" or not fresh_node),
                  f"rejected js {first.rejected_joint_states} -> {last.rejected_joint_states}, cond "
                  f"{first.rejected_conditions} -> {last.rejected_conditions}, last_error {last.last_error!r}")
        ages = [s.joint_state_age_s for _, s in sts]
        rep.check("status: joint_state_age_s in [0, 0.1) s", all(0.0 <= a < STALE_TIMEOUT for a in ages),
                  f"min {min(ages):.4f}, max {max(ages):.4f}")
        ticks = [s.ticks for _, s in sts]
        rep.check("status: ticks increase", ticks[-1] > ticks[0], f"{ticks[0]} -> {ticks[-1]}")
        rep.note(f"status: code {last.code} {last.message!r}, tick_time_us {last.tick_time_us:.1f}, "
                 f"tick_time_max_us {last.tick_time_max_us:.1f}, active_constraints {last.active_constraints}")
        if cmds:
            rep.note(f"last command {['%.4f' % v for v in cmds[-1][1]]}")

    # symmetry condition
    matched = peer.wait_matched_writer(peer.cond_writer, timeout)
    rep.check("symmetry_condition: node's reader matched (Reliable, volatile)", matched)
    if matched:
        time.sleep(0.2)  # let the node's side of discovery settle too
    last = peer.latest_status()
    if last is not None and cond_matches(last.condition, 0.5236, 0.8, -1):  # node already there: move it first
        apply_condition(peer, rep, "symmetry_condition (0, 1, 1) echoed in status.condition", (0.0, 1.0, 1), timeout)
    apply_condition(peer, rep, "symmetry_condition (0.5236, 0.8, -1) echoed in status.condition",
                    (0.5236, 0.8, -1), timeout)
    t0 = time.monotonic()
    cmds, _ = peer.wait_counts(t0, 10, 0, timeout)
    check_commands(rep, "commands under the new condition: valid", cmds, 10)

    # extra unknown joint is ignored, not rejected
    before = peer.latest_status()
    peer.set_joint_states(True, extra=True)
    t0 = time.monotonic()
    # statuses of ticks that used the extra-joint messages (the first may predate them)
    cmds, _ = peer.wait_counts(t0, 10, 3, timeout)
    after = peer.latest_status()
    peer.set_joint_states(True, extra=False)
    if before and after:
        rep.check("joint_states with an extra 'torso_joint' accepted",
                  after.rejected_joint_states == before.rejected_joint_states
                  and int(after.code) not in (STALE_JOINT_STATES, INVALID_INPUT),
                  f"rejected {before.rejected_joint_states} -> {after.rejected_joint_states}, code {after.code}")
    check_commands(rep, "commands with the extra joint: valid", cmds, 10)

    # stale: stop joint states -> zero velocities and STALE_JOINT_STATES
    peer.set_joint_states(False)
    t_stop = time.monotonic()
    st = peer.wait_status(lambda s: int(s.code) == STALE_JOINT_STATES, timeout, t_stop)
    if st is not None:  # and the next one: commands of earlier, fresh ticks have arrived by then
        st = peer.wait_status(lambda s: int(s.code) == STALE_JOINT_STATES, timeout, time.monotonic())
    rep.check("stale joint states: node reports STALE_JOINT_STATES (16)", st is not None,
              "" if st else f"not within {timeout:g} s")
    # from then on: every command zero and every status stale
    t0 = time.monotonic()
    cmds, sts = peer.wait_counts(t0, 20, 3, timeout)
    rep.check("stale joint states: commands are all zero",
              len(cmds) > 0 and all(len(d) == len(JOINTS) and all(v == 0.0 for v in d) for _, d in cmds),
              f"{len(cmds)} commands, nonzero {sum(1 for _, d in cmds if any(v != 0.0 for v in d))}")
    rep.check("stale joint states: status code STALE_JOINT_STATES (16)",
              len(sts) > 0 and all(int(s.code) == STALE_JOINT_STATES for _, s in sts),
              f"codes seen {sorted({int(s.code) for _, s in sts})}")
    if len(sts) >= 2:
        rep.check("stale joint states: stale_ticks increase", sts[-1][1].stale_ticks > sts[0][1].stale_ticks,
                  f"{sts[0][1].stale_ticks} -> {sts[-1][1].stale_ticks}")
    # recovery
    peer.set_joint_states(True)
    t0 = time.monotonic()
    st = peer.wait_status(lambda s: int(s.code) != STALE_JOINT_STATES, timeout, t0 + 0.05)
    rep.check("recovery: fresh joint states clear STALE_JOINT_STATES", st is not None,
              f"code {st.code}" if st else f"still stale after {timeout:g} s")


def scenario_bad_input(peer: Peer, rep: Report, timeout: float):
    time.sleep(0.5)
    matched = peer.wait_matched_writer(peer.cond_writer, timeout)
    rep.check("symmetry_condition: node's reader matched (Reliable, volatile)", matched)
    time.sleep(0.2)
    good_idx = [0]
    # Inside the shipped policy's trained box (any θ, λ ∈ [0.5, 1], σ = ±1).
    goods = [(0.0, 1.0, 1), (0.1, 0.95, 1), (-0.2, 0.9, -1), (0.3, 0.6, 1), (-0.4, 0.7, -1), (0.6, 0.55, 1)]
    current = goods[0]
    st = apply_condition(peer, rep, f"initial good condition {current} accepted", current, timeout)
    if st is None:
        return

    # ---- bad joint states ----
    for name, builder in BAD_JOINT_STATES:
        base = peer.latest_status()
        t0 = time.monotonic()
        peer.inject_joint_state(builder, 0.05)  # 5 messages at 100 Hz, shorter than the stale timeout
        st = peer.wait_status(lambda s: s.rejected_joint_states >= base.rejected_joint_states + 1
                              and s.last_error != "", timeout, t0)
        rep.check(f"joint_states {name}: rejected (counter +1, last_error set)", st is not None,
                  f"rejected_joint_states {base.rejected_joint_states} -> {st.rejected_joint_states}, "
                  f"last_error {st.last_error!r}" if st else
                  f"rejected_joint_states stayed {peer.latest_status().rejected_joint_states}")
        seen17 = any(int(s.code) == INVALID_INPUT for _, s in peer.statuses_since(t0))
        rep.note(f"joint_states {name}: INVALID_INPUT {'seen' if seen17 else 'not seen'} in the 50 ms window"
                 " (informational: good messages resume right after)")
        t_good = time.monotonic() + 0.05
        ok_code = peer.wait_status(lambda s: int(s.code) != INVALID_INPUT, timeout, t_good)
        rep.check(f"joint_states {name}: code leaves INVALID_INPUT after good messages", ok_code is not None,
                  f"code {ok_code.code}" if ok_code else f"still INVALID_INPUT after {timeout:g} s")
        cmds, _ = peer.wait_counts(t0, 5, 0, timeout)
        check_commands(rep, f"joint_states {name}: commands continue, finite, within limits", cmds, 5)

    # ---- bad conditions ----
    for name, cond in BAD_CONDITIONS:
        base = peer.latest_status()
        t0 = time.monotonic()
        peer.publish_condition(make_condition(*cond))
        st = peer.wait_status(lambda s: s.rejected_conditions >= base.rejected_conditions + 1
                              and s.last_error != "", timeout, t0)
        rep.check(f"symmetry_condition {name}: rejected (counter +1, last_error set)", st is not None,
                  f"rejected_conditions {base.rejected_conditions} -> {st.rejected_conditions}, "
                  f"last_error {st.last_error!r}" if st else
                  f"rejected_conditions stayed {peer.latest_status().rejected_conditions}")
        if st is not None and name.startswith("scale_untrained"):
            rep.check(f"symmetry_condition {name}: last_error names the trained range",
                      "scale outside the policy's trained range" in st.last_error, repr(st.last_error))
        if st is not None:
            st17 = peer.wait_status(lambda s: int(s.code) == INVALID_INPUT, timeout, t0)
            rep.check(f"symmetry_condition {name}: code INVALID_INPUT while it is the latest",
                      st17 is not None, "" if st17 else f"codes seen "
                      f"{sorted({int(s.code) for _, s in peer.statuses_since(t0)})}")
            time.sleep(0.1)
            last = peer.latest_status()
            rep.check(f"symmetry_condition {name}: previous condition kept",
                      cond_matches(last.condition, *current), f"status.condition {fmt_cond(last.condition)}")
        cmds, _ = peer.wait_counts(t0, 5, 0, timeout)
        check_commands(rep, f"symmetry_condition {name}: commands continue, finite, within limits", cmds, 5)
        good_idx[0] += 1
        current = goods[good_idx[0] % len(goods)]
        t_good = time.monotonic()
        apply_condition(peer, rep, f"symmetry_condition {name}: next good condition {current} accepted",
                        current, timeout)
        ok_code = peer.wait_status(lambda s: int(s.code) != INVALID_INPUT, timeout, t_good)
        rep.check(f"symmetry_condition {name}: code leaves INVALID_INPUT after a good condition",
                  ok_code is not None,
                  f"code {ok_code.code}" if ok_code else f"still INVALID_INPUT after {timeout:g} s")

    # ---- afterwards ----
    apply_condition(peer, rep, "final good condition (0.5236, 0.8, -1) accepted", (0.5236, 0.8, -1), timeout)
    t0 = time.monotonic()
    cmds, _ = peer.wait_counts(t0, 10, 0, timeout)
    check_commands(rep, "commands after all bad input: valid", cmds, 10)
    last, first = peer.latest_status(), peer.first_status()
    d_js = last.rejected_joint_states - first.rejected_joint_states
    d_c = last.rejected_conditions - first.rejected_conditions
    rep.check("totals: rejected joint_states >= number of bad joint_states kinds",
              len(BAD_JOINT_STATES) <= d_js <= peer.js_bad_sent,
              f"+{d_js} (>= {len(BAD_JOINT_STATES)}, <= {peer.js_bad_sent} bad messages sent)")
    rep.check("totals: rejected conditions == number of bad conditions", d_c == len(BAD_CONDITIONS),
              f"+{d_c} (== {len(BAD_CONDITIONS)})")
    rep.check("final code not INVALID_INPUT/STALE", int(last.code) not in (INVALID_INPUT, STALE_JOINT_STATES),
              f"code {last.code} {last.message!r}")


# --------------------------------------------------------------------------------------
# CDR self-test: the types' XCDR1 bytes against a layout built by hand (no DDS traffic)
# --------------------------------------------------------------------------------------


def _cdr_expected_bytes():
    """Hand-built plain-CDR (XCDR1, little endian) samples; alignment counts from the
    byte after the 4-byte encapsulation header 00 01 00 00 (CDR_LE)."""
    import struct

    def align(b, n):
        return b + b"\0" * (-len(b) % n)

    def s(b, txt):  # uint32 length incl. NUL, bytes, NUL
        e = txt.encode() + b"\0"
        return align(b, 4) + struct.pack("<I", len(e)) + e

    def seq_str(b, xs):
        b = align(b, 4) + struct.pack("<I", len(xs))
        for x in xs:
            b = s(b, x)
        return b

    def seq_f64(b, xs):
        b = align(b, 4) + struct.pack("<I", len(xs))
        if xs:
            b = align(b, 8)
        return b + b"".join(struct.pack("<d", x) for x in xs)

    enc = b"\x00\x01\x00\x00"
    out = []
    js = JointState(header=Header(stamp=Time(sec=1700000000, nanosec=123456789), frame_id="base"),
                    name=["left_joint1", "ab"], position=[0.5, -1.25], velocity=[], effort=[3.0])
    b = struct.pack("<iI", 1700000000, 123456789)
    b = s(b, "base")
    b = seq_str(b, ["left_joint1", "ab"])
    b = seq_f64(seq_f64(seq_f64(b, [0.5, -1.25]), []), [3.0])
    out.append(("JointState", js, enc + b))

    fm = Float64MultiArray(layout=MultiArrayLayout(dim=[MultiArrayDimension(label="j", size=8, stride=1)],
                                                   data_offset=0), data=[1.0] * 8)
    b = struct.pack("<I", 1)
    b = s(b, "j")
    b = align(b, 4) + struct.pack("<II", 8, 1)
    b = align(b, 4) + struct.pack("<I", 0)
    out.append(("Float64MultiArray", fm, enc + seq_f64(b, [1.0] * 8)))

    cond = SymmetryCondition(header=Header(stamp=Time(sec=7, nanosec=8), frame_id="x"), theta=0.5, scale=0.8,
                             reflection=-1)
    cb = struct.pack("<iI", 7, 8)
    cb = s(cb, "x")
    cb = align(cb, 8) + struct.pack("<ddb", 0.5, 0.8, -1)
    out.append(("SymmetryCondition", cond, enc + cb))

    st = Status(header=Header(stamp=Time(sec=5, nanosec=6), frame_id=""), code=17, message="m", last_error="e",
                active_constraints=1, rejected_joint_states=2, rejected_conditions=3, ticks=4, stale_ticks=5,
                joint_state_age_s=0.25, tick_time_us=1.5, tick_time_max_us=2.5, condition=cond,
                restarts=9, not_following_ticks=10, tracking_warning_ticks=11, tracking_error=0.125,
                paused=True, velocity_scale=0.5, singularity_condition=12.5, singularity_factor=0.75,
                period_code=22, period_ticks=10, period_restarts=1, period_held=2, period_locked=3,
                period_rejected=4, period_stale_ticks=5, period_fallback_ticks=6, held_events=13,
                locked_events=14, locked_joint="j", command_subscribers=1, late_ticks=15,
                missed_ticks=16, period_late_ticks=2, period_missed_ticks=3, tick_late_max_us=6.5)
    b = struct.pack("<iI", 5, 6)
    b = s(b, "")
    b += struct.pack("<b", 17)
    b = s(s(b, "m"), "e")
    b = align(b, 4) + struct.pack("<III", 1, 2, 3)
    b = align(b, 8) + struct.pack("<QQddd", 4, 5, 0.25, 1.5, 2.5)
    b = align(b, 4) + struct.pack("<iI", 7, 8)  # condition.header.stamp
    b = s(b, "x")
    b = align(b, 8) + struct.pack("<ddb", 0.5, 0.8, -1)
    b = align(b, 8) + struct.pack("<QQQd", 9, 10, 11, 0.125)
    b += struct.pack("<?", True)
    b = align(b, 8) + struct.pack("<ddd", 0.5, 12.5, 0.75)
    b += struct.pack("<b", 22)
    b = align(b, 4) + struct.pack("<IIIIIII", 10, 1, 2, 3, 4, 5, 6)
    b = align(b, 8) + struct.pack("<QQ", 13, 14)
    b = s(b, "j")
    b = align(b, 4) + struct.pack("<i", 1)
    b = align(b, 8) + struct.pack("<QQII", 15, 16, 2, 3)
    b = align(b, 8) + struct.pack("<d", 6.5)
    out.append(("Status", st, enc + b))
    return out


def cdr_selftest(rep: Report):
    for name, sample, expected in _cdr_expected_bytes():
        got = sample.serialize()
        # a serializer may pad the end to a multiple of 4 (RTPS); the payload must agree
        same = got[:len(expected)] == expected and not got[len(expected):].strip(b"\0")
        rep.check(f"CDR {name} ({type(sample).__idl_typename__}) matches the hand-built layout", same,
                  f"{len(got)} bytes" if same else f"got {got.hex()} expected {expected.hex()}")
        back = type(sample).deserialize(expected + b"\0" * (-len(expected) % 4))
        rep.check(f"CDR {name} decodes the hand-built bytes", back == sample)


SCENARIOS = {"basic": scenario_basic, "bad_input": scenario_bad_input}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", choices=sorted(SCENARIOS))
    ap.add_argument("--cdr-selftest", action="store_true",
                    help="only check the types' CDR bytes against a hand-built layout (no DDS traffic)")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--timeout", type=float, default=20.0,
                    help="seconds to wait for the node to appear (and per waiting step)")
    ap.add_argument("--json", metavar="OUT", help="write a JSON summary here")
    args = ap.parse_args(argv)
    if args.cdr_selftest:
        rep = Report()
        cdr_selftest(rep)
        print(f"dds_peer: {rep.passed} passed, {rep.failed} failed")
        return 1 if rep.failed else 0
    if not args.scenario:
        ap.error("--scenario is required (or --cdr-selftest)")

    try:
        from importlib.metadata import version
        cdds_version = version("cyclonedds")
    except Exception:
        cdds_version = "?"
    print(f"dds_peer: scenario {args.scenario}, domain {args.domain}, cyclonedds {cdds_version}, "
          f"CYCLONEDDS_URI={os.environ.get('CYCLONEDDS_URI', '(unset)')}", flush=True)

    rep = Report()
    t_start = time.monotonic()
    peer = Peer(args.domain)
    exit_code = 0
    try:
        peer.set_joint_states(True)
        if not wait_for_node(peer, args.timeout):
            print(f"dds_peer: nothing received from the node within {args.timeout:g} s on domain "
                  f"{args.domain} (topics {TOPIC_COMMANDS}, {TOPIC_STATUS}). Is the node running in the "
                  "same network namespace and domain, with these topic and type names and QoS "
                  "(Reliable writers, XCDR1)?\n" + peer.diagnostics(), file=sys.stderr)
            exit_code = 2
        else:
            rep.check("node discovered: commands received", peer.n_commands() > 0,
                      f"after {time.monotonic() - t_start:.2f} s")
            rep.check("node discovered: status received", peer.n_statuses() > 0)
            SCENARIOS[args.scenario](peer, rep, args.timeout)
            check_commands(rep, "all commands of the run: 8 finite entries within ±3 rad/s",
                           peer.commands_since(0.0))
            exit_code = 1 if rep.failed else 0
            if rep.failed:
                print("dds_peer: diagnostics\n" + peer.diagnostics(), file=sys.stderr)
    except Exception as e:
        import traceback
        traceback.print_exc()
        rep.check("peer ran without exception", False, repr(e))
        exit_code = 1
    finally:
        n_cmd, n_st = peer.n_commands(), peer.n_statuses()
        peer.close()

    print(f"dds_peer: {n_cmd} commands, {n_st} statuses received, {peer.js_sent} joint_states sent "
          f"in {time.monotonic() - t_start:.1f} s")
    print(f"dds_peer: {rep.passed} passed, {rep.failed} failed")
    if args.json:
        summary = {
            "scenario": args.scenario, "domain": args.domain, "cyclonedds": cdds_version,
            "exit_code": exit_code, "passed": rep.passed, "failed": rep.failed,
            "commands_received": n_cmd, "statuses_received": n_st, "joint_states_sent": peer.js_sent,
            "duration_s": round(time.monotonic() - t_start, 3),
            "checks": rep.checks, "info": rep.info,
        }
        with open(args.json, "w") as f:
            json.dump(summary, f, indent=2)
    return exit_code


if __name__ == "__main__":
    sys.exit(main())
