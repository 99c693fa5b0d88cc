#!/usr/bin/env python3
"""The robot and the operator of a crossym node, over DDS, independent of crossym (Eclipse
Cyclone DDS from PyPI, every type and mapping written by hand): checks the node's operator
controls — the `~/pause` and `~/reset` services and the settable parameters.

    python3 tests/peer/operator_peer.py [--config config/letters.toml] [--domain N]
                                        [--timeout S] [--json OUT]

The robot: joint states of the rest posture at 100 Hz with fresh stamps (`dds_peer.Peer`),
never moving, so the policy's output is constant and the node's velocity command settles
to it (times `velocity_scale`, within the safety filter's limits). The operator: service
requests in ros2-client's "Enhanced" request/reply mapping (rmw_fastrtps's): the plain
request on `rq/<service>Request`, the plain reply on `rr/<service>Reply` (the request's
identity travels in inline QoS, which this peer, the only client, ignores).

Limits come from the config: each controlled joint's `<limit velocity=… acceleration=…>`
in its URDF, `[node] safety.default_acceleration` (else 10 rad/s², the filter's default)
for a joint without one, `[node] period_s`; `[node] safety.margin` (expected unchanged).

Checks (each a PASS/FAIL line and an entry of the JSON's `checks`):
  the node answers; the policy moves (a settled non-zero command within the limits);
  pause: reply, commands at zero within max_j |v_j| / a_j + 3 periods + 0.3 s of the
  request and held there, no command beyond the velocity limits, status PAUSED;
  resume: reply, the same settled command as before the pause, status not PAUSED;
  velocity_scale 0.5: accepted, the settled command halved (1e-6 relative), status shows
  it; velocity_scale 1.0: accepted, the command back; six refused sets (NaN, -1, 1.5, a
  string, period_s, safety.margin 10), each with its reason, and afterwards the command and
  the parameters unchanged; `~/reset`: success; every command of the run within the
  velocity limits. Exit 0 when all passed, 1 otherwise, 2 when the node never answered.
"""
# No `from __future__ import annotations`: cyclonedds resolves field annotations by name.

import argparse
import json
import math
import os
import sys
import time
import tomllib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import List, Optional

from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dds_peer import JOINTS, Peer, Report  # noqa: E402

ROOT = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
NODE = "crossym"  # [node] name of config/letters.toml, namespace /
PAUSED = 25  # crossym_msgs/Status PAUSED
ZERO = 1e-9  # |v| of a zero command
RATIO_TOL = 1e-6  # relative, settled command against the scaled one
SETTLE_N = 20  # commands of a settled window
BRAKE_SLACK_S = 0.3  # DDS and a loaded machine, on top of the braking time and 3 periods
DEFAULT_ACCELERATION = 10.0  # the safety filter's default of [node] safety.default_acceleration

# --------------------------------------------------------------------------------------
# Service types (std_srvs, rcl_interfaces), field order of the .srv/.msg files
# --------------------------------------------------------------------------------------


@dataclass
class SetBoolRequest(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Request_"):
    data: bool = False


@dataclass
class SetBoolResponse(IdlStruct, typename="std_srvs::srv::dds_::SetBool_Response_"):
    success: bool = False
    message: str = ""


@dataclass
class TriggerRequest(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Request_"):
    structure_needs_at_least_one_member: types.uint8 = 0


@dataclass
class TriggerResponse(IdlStruct, typename="std_srvs::srv::dds_::Trigger_Response_"):
    success: bool = False
    message: str = ""


@dataclass
class ParameterValue(IdlStruct, typename="rcl_interfaces::msg::dds_::ParameterValue_"):
    type: types.uint8 = 0
    bool_value: bool = False
    integer_value: types.int64 = 0
    double_value: types.float64 = 0.0
    string_value: str = ""
    byte_array_value: types.sequence[types.uint8] = field(default_factory=list)
    bool_array_value: types.sequence[bool] = field(default_factory=list)
    integer_array_value: types.sequence[types.int64] = field(default_factory=list)
    double_array_value: types.sequence[types.float64] = field(default_factory=list)
    string_array_value: types.sequence[str] = field(default_factory=list)


@dataclass
class Parameter(IdlStruct, typename="rcl_interfaces::msg::dds_::Parameter_"):
    name: str = ""
    value: ParameterValue = field(default_factory=ParameterValue)


@dataclass
class SetParametersRequest(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Request_"):
    parameters: types.sequence[Parameter] = field(default_factory=list)


@dataclass
class SetParametersResult(IdlStruct, typename="rcl_interfaces::msg::dds_::SetParametersResult_"):
    successful: bool = False
    reason: str = ""


@dataclass
class SetParametersResponse(IdlStruct, typename="rcl_interfaces::srv::dds_::SetParameters_Response_"):
    results: types.sequence[SetParametersResult] = field(default_factory=list)


@dataclass
class GetParametersRequest(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Request_"):
    names: types.sequence[str] = field(default_factory=list)


@dataclass
class GetParametersResponse(IdlStruct, typename="rcl_interfaces::srv::dds_::GetParameters_Response_"):
    values: types.sequence[ParameterValue] = field(default_factory=list)


# rcl_interfaces/ParameterType
P_BOOL, P_INTEGER, P_DOUBLE, P_STRING, P_DOUBLE_ARRAY = 1, 2, 3, 4, 8


def double(x: float) -> ParameterValue:
    return ParameterValue(type=P_DOUBLE, double_value=x)


def string(s: str) -> ParameterValue:
    return ParameterValue(type=P_STRING, string_value=s)


def value_text(v: ParameterValue) -> str:
    """The value of a ParameterValue as Python would print it."""
    t = int(v.type)
    value = {P_BOOL: v.bool_value, P_INTEGER: v.integer_value, P_DOUBLE: v.double_value,
             P_STRING: v.string_value, P_DOUBLE_ARRAY: list(v.double_array_value)}.get(t, f"type {t}")
    return repr(value)


QOS_SERVICE = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=100)),
                  Policy.Durability.Volatile, Policy.History.KeepLast(10),
                  Policy.DataRepresentation(use_cdrv0_representation=True))


class Client:
    """A service client in the Enhanced mapping: `rq/<name>Request` → `rr/<name>Reply`."""

    def __init__(self, peer: Peer, name: str, req_type, resp_type):
        self.name, self.resp_type = name, resp_type
        self.writer = DataWriter(peer.dp, Topic(peer.dp, f"rq/{NODE}/{name}Request", req_type), qos=QOS_SERVICE)
        self.reader = DataReader(peer.dp, Topic(peer.dp, f"rr/{NODE}/{name}Reply", resp_type), qos=QOS_SERVICE)

    def matched(self) -> bool:
        return (self.writer.get_publication_matched_status().current_count > 0
                and self.reader.get_subscription_matched_status().current_count > 0)

    def _replies(self) -> list:
        return [s for s in self.reader.take(N=100) if isinstance(s, self.resp_type)]

    def call(self, request, timeout: float):
        """(reply or None, note): waits for the node's endpoints, then sends; once more if no
        reply comes within 3 s (a sample may race discovery; every request here is
        idempotent)."""
        deadline = time.monotonic() + timeout
        while not self.matched():
            if time.monotonic() >= deadline:
                return None, f"~/{self.name}: request/reply endpoints not matched within {timeout:g} s"
            time.sleep(0.02)
        self._replies()  # nothing stale
        note = ""
        for attempt in range(2):
            self.writer.write(request)
            until = min(deadline, time.monotonic() + (3.0 if attempt == 0 else timeout))
            while time.monotonic() < until:
                got = self._replies()
                if got:
                    return got[-1], note
                time.sleep(0.005)
            note = f"~/{self.name}: no reply within 3 s, sent again"
        return None, f"~/{self.name}: no reply within {timeout:g} s"


# --------------------------------------------------------------------------------------
# Limits from the config and its URDF
# --------------------------------------------------------------------------------------


def load_limits(config: str):
    """(velocity limits, acceleration limits) of the controlled joints, [node] period_s and
    safety.margin."""
    with open(config, "rb") as f:
        cfg = tomllib.load(f)
    node = cfg.get("node", {})
    default_a = float(node.get("safety", {}).get("default_acceleration", DEFAULT_ACCELERATION))
    urdf = os.path.normpath(os.path.join(os.path.dirname(os.path.abspath(config)), cfg["robot"]["urdf"]))
    joints = {j.get("name"): j.find("limit") for j in ET.parse(urdf).getroot().iter("joint")}
    vel, acc = [], []
    for name in JOINTS:
        lim = joints[name]
        vel.append(float(lim.get("velocity")))
        acc.append(float(lim.get("acceleration")) if lim.get("acceleration") else default_a)
    return vel, acc, float(node.get("period_s", 0.01)), float(node.get("safety", {}).get("margin", 0.0))


# --------------------------------------------------------------------------------------
# The operator's scenario
# --------------------------------------------------------------------------------------


class Operator:
    def __init__(self, peer: Peer, rep: Report, limits: tuple, timeout: float):
        self.peer, self.rep, self.timeout = peer, rep, timeout
        self.vel, self.acc, self.period, self.margin = limits
        self.pause = Client(peer, "pause", SetBoolRequest, SetBoolResponse)
        self.reset = Client(peer, "reset", TriggerRequest, TriggerResponse)
        self.set_params = Client(peer, "set_parameters", SetParametersRequest, SetParametersResponse)
        self.get_params = Client(peer, "get_parameters", GetParametersRequest, GetParametersResponse)

    # ---- commands ------------------------------------------------------------------
    def over_limit(self, cmds) -> List[str]:
        return [f"{JOINTS[j]} {d[j]:+.6g} (limit {self.vel[j]:g})" for _, d in cmds for j in range(len(JOINTS))
                if len(d) != len(JOINTS) or not math.isfinite(d[j]) or abs(d[j]) > self.vel[j] + ZERO]

    def settled(self, since: float, timeout: Optional[float] = None) -> Optional[List[float]]:
        """The mean of the first SETTLE_N consecutive commands received after `since` that agree
        to 1e-9 relative (the robot stands still: the command is constant once the filter's
        acceleration limits let it be), or None if none within `timeout`."""
        deadline = time.monotonic() + (timeout or self.timeout)
        while True:
            cmds = [d for _, d in self.peer.commands_since(since) if len(d) == len(JOINTS)]
            for k in range(len(cmds) - SETTLE_N + 1):
                w = cmds[k:k + SETTLE_N]
                scale = max(1e-12, max(abs(v) for v in w[-1]))
                if all(max(c[j] for c in w) - min(c[j] for c in w) <= 1e-9 * scale for j in range(len(JOINTS))):
                    return [sum(c[j] for c in w) / SETTLE_N for j in range(len(JOINTS))]
            if time.monotonic() >= deadline:
                return None
            time.sleep(0.02)

    @staticmethod
    def deviation(got: List[float], ref: List[float], s: float) -> float:
        """max_j |got_j - s·ref_j| / (s·max|ref|): the relative error of a scaled command."""
        top = s * max(abs(v) for v in ref)
        return max(abs(g - s * r) for g, r in zip(got, ref)) / top if top > 0 else math.inf

    def wait_for_status(self, since: float, pred, what: str):
        st = self.peer.wait_status(pred, self.timeout, since)
        last = self.peer.latest_status()
        return st, (f"{what}: code {st.code} {st.message!r}, paused {st.paused}, velocity_scale "
                    f"{st.velocity_scale:g}" if st else f"no such status; latest code "
                    f"{last.code if last else '-'} {last.message if last else ''!r}")

    def set_param(self, name: str, value: ParameterValue):
        reply, note = self.set_params.call(SetParametersRequest(parameters=[Parameter(name=name, value=value)]),
                                           self.timeout)
        if note:
            self.rep.note(note)
        if reply is None or len(reply.results) != 1:
            return None, f"reply {reply!r}"
        r = reply.results[0]
        return r, f"successful {r.successful}, reason {r.reason!r}"

    # ---- steps ---------------------------------------------------------------------
    def run(self):
        rep, peer = self.rep, self.peer
        v0 = self.settled(time.monotonic())
        moves = v0 is not None and max(abs(v) for v in v0) > 1e-3 and not self.over_limit([(0, v0)])
        rep.check("policy moves: the settled command is non-zero and within the velocity limits", moves,
                  f"settled command {fmt(v0)}" if v0 else f"no {SETTLE_N} equal commands within {self.timeout:g} s")
        if not moves:
            return
        st = peer.latest_status()
        rep.note(f"status before the pause: code {st.code} {st.message!r}, velocity_scale {st.velocity_scale:g}, "
                 f"singularity_factor {st.singularity_factor:g}")

        # ---- pause ----
        last = peer.commands_since(0.0)[-1][1]
        bound = max(abs(v) / a for v, a in zip(last, self.acc)) + 3 * self.period + BRAKE_SLACK_S
        t_req = time.monotonic()
        reply, note = self.pause.call(SetBoolRequest(data=True), self.timeout)
        if note:
            rep.note(note)
        rep.check("~/pause true: reply success", reply is not None and reply.success,
                  f"message {reply.message!r}" if reply else note)
        # the braking bound, then a hold of at least 20 commands
        while time.monotonic() < t_req + bound + 0.25 or sum(
                1 for t, _ in peer.commands_since(t_req) if t > t_req + bound) < 20:
            if time.monotonic() > t_req + bound + self.timeout:
                break
            time.sleep(0.01)
        cmds = peer.commands_since(t_req)
        nonzero = [i for i, (_, d) in enumerate(cmds) if any(abs(v) >= ZERO for v in d)]
        first_zero = nonzero[-1] + 1 if nonzero else 0
        held = len(cmds) - first_zero
        t_zero = cmds[first_zero][0] - t_req if first_zero < len(cmds) else math.inf
        rep.check(f"~/pause true: commands reach zero (|v| < {ZERO:g}) within max_j |v_j|/a_j + 3 periods + "
                  f"{BRAKE_SLACK_S:g} s of the request and stay there", held >= 20 and t_zero <= bound,
                  f"zero from {t_zero:.3f} s after the request (bound {bound:.3f} s), then {held} zero commands; "
                  f"{len(nonzero)} non-zero ones after the request, last {fmt(cmds[nonzero[-1]][1]) if nonzero else '-'}")
        bad = self.over_limit(cmds)
        rep.check("~/pause true: no command beyond the joint velocity limits while braking", not bad,
                  f"{len(cmds)} commands" + (f", {len(bad)} over, e.g. {bad[0]}" if bad else ""))
        st, detail = self.wait_for_status(t_req, lambda s: int(s.code) == PAUSED and s.paused
                                        and s.message.startswith("PAUSED:"), "status")
        rep.check("~/pause true: status PAUSED (25), paused = true, message 'PAUSED: …'", st is not None, detail)

        # ---- resume ----
        t_req = time.monotonic()
        reply, note = self.pause.call(SetBoolRequest(data=False), self.timeout)
        if note:
            rep.note(note)
        rep.check("~/pause false: reply success", reply is not None and reply.success,
                  f"message {reply.message!r}" if reply else note)
        v1 = self.settled(t_req)
        dev = self.deviation(v1, v0, 1.0) if v1 else math.inf
        rep.check("~/pause false: commands non-zero again, settled at the command before the pause",
                  v1 is not None and max(abs(v) for v in v1) > 1e-3 and dev <= RATIO_TOL,
                  f"settled command {fmt(v1)}, relative deviation {dev:.3g}" if v1 else "never settled")
        t_st = time.monotonic()
        st, detail = self.wait_for_status(t_st, lambda s: int(s.code) != PAUSED and not s.paused
                                        and not s.message.startswith("PAUSED"), "status")
        rep.check("~/pause false: status no longer PAUSED", st is not None, detail)
        if v1 is None:
            return
        before = v1

        # ---- velocity_scale ----
        for scale in (0.5, 1.0):
            r, detail = self.set_param("velocity_scale", double(scale))
            t_set = time.monotonic()
            rep.check(f"velocity_scale {scale:g}: successful", r is not None and r.successful, detail)
            # commands of ticks after the set (the node applies it before its next tick)
            v = self.settled(t_set + 0.1)
            dev = self.deviation(v, before, scale) if v else math.inf
            st = peer.wait_status(lambda s: s.velocity_scale == scale, self.timeout, t_set)
            rep.check(f"velocity_scale {scale:g}: the settled command is {scale:g} × the one before "
                      f"(per joint, {RATIO_TOL:g} relative), status.velocity_scale {scale:g}",
                      dev <= RATIO_TOL and st is not None,
                      (f"settled command {fmt(v)}, relative deviation {dev:.3g}" if v else "never settled")
                      + ("" if st else f"; status.velocity_scale {peer.latest_status().velocity_scale:g}"))

        # ---- refused sets ----
        refusals = [("velocity_scale", double(math.nan), "NaN", ""),
                    ("velocity_scale", double(-1.0), "-1.0", ""),
                    ("velocity_scale", double(1.5), "1.5", ""),
                    ("velocity_scale", string("0.5"), "the string '0.5'", ""),
                    ("period_s", double(0.02), "0.02", "restart"),
                    ("safety.margin", double(10.0), "10.0 (more than half a joint's range)", "")]
        for name, value, what, must in refusals:
            t_set = time.monotonic()
            r, detail = self.set_param(name, value)
            refused = r is not None and not r.successful and r.reason.strip() != "" and must in r.reason
            v = self.settled(max(t_set + 0.1, time.monotonic() + 0.06))
            dev = self.deviation(v, before, 1.0) if v else math.inf
            rep.check(f"{name} {what}: refused with a reason" + (f" naming '{must}'" if must else "")
                      + ", the command unchanged", refused and dev <= RATIO_TOL,
                      f"{detail}; settled command relative deviation {dev:.3g}")
        reply, note = self.get_params.call(
            GetParametersRequest(names=["velocity_scale", "period_s", "safety.margin"]), self.timeout)
        got = [value_text(v) for v in reply.values] if reply else []
        want = [repr(1.0), repr(self.period), repr(self.margin)]
        st = peer.latest_status()
        rep.check(f"after the refusals: get_parameters velocity_scale, period_s, safety.margin = {want}; "
                  "status.velocity_scale 1", reply is not None and got == want and st.velocity_scale == 1.0,
                  f"{got}, status.velocity_scale {st.velocity_scale:g}" if reply else note)

        # ---- reset ----
        reply, note = self.reset.call(TriggerRequest(), self.timeout)
        if note:
            rep.note(note)
        rep.check("~/reset: success", reply is not None and reply.success,
                  f"message {reply.message!r}" if reply else note)


def fmt(v) -> str:
    return "[" + ", ".join(f"{x:+.5f}" for x in v) + "]" if v is not None else "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--config", default=os.path.join(ROOT, "config", "letters.toml"))
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    ap.add_argument("--timeout", type=float, default=10.0,
                    help="seconds to wait for the node to appear, and per waiting step")
    ap.add_argument("--json", metavar="OUT", help="write the checks here")
    args = ap.parse_args(argv)
    limits = load_limits(args.config)
    print(f"operator_peer: domain {args.domain}, velocity limits {limits[0]}, acceleration limits "
          f"{limits[1]}, period {limits[2]:g} s, margin {limits[3]:g}", flush=True)

    rep = Report()
    t_start = time.monotonic()
    peer = Peer(args.domain)
    exit_code = 0
    try:
        op = Operator(peer, rep, limits, args.timeout)
        peer.set_joint_states(True)
        deadline = time.monotonic() + args.timeout
        while time.monotonic() < deadline and not (peer.n_commands() and peer.n_statuses()):
            time.sleep(0.02)
        if not rep.check("the node answers: status and commands arrive",
                         peer.n_commands() > 0 and peer.n_statuses() > 0,
                         f"{peer.n_commands()} commands, {peer.n_statuses()} statuses after "
                         f"{time.monotonic() - t_start:.2f} s"):
            print("operator_peer: diagnostics\n" + peer.diagnostics(), file=sys.stderr)
            exit_code = 2
        else:
            op.run()
            bad = op.over_limit(peer.commands_since(0.0))
            rep.check("every command of the run: 8 finite entries within the joint velocity limits", not bad,
                      f"{peer.n_commands()} commands" + (f", {len(bad)} over, e.g. {bad[0]}" if bad else ""))
            exit_code = 1 if rep.failed else 0
    except Exception as e:
        import traceback
        traceback.print_exc()
        rep.check("peer ran without exception", False, repr(e))
        exit_code = 1
    finally:
        n_cmd, n_st = peer.n_commands(), peer.n_statuses()
        peer.close()
    print(f"operator_peer: {n_cmd} commands, {n_st} statuses received, {peer.js_sent} joint_states sent "
          f"in {time.monotonic() - t_start:.1f} s; {rep.passed} passed, {rep.failed} failed", flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"exit_code": exit_code, "passed": rep.passed, "failed": rep.failed,
                       "checks": rep.checks, "info": rep.info}, f, indent=1)
    return exit_code


if __name__ == "__main__":
    sys.exit(main())
