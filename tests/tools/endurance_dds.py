#!/usr/bin/env python3
"""Endurance over DDS: `crossym mock-hw` and `crossym node` as processes, a new symmetry
condition every period (the config's test conditions in turn), for minutes; reports what
an outsider sees on the wire (Cyclone DDS, not crossym's code).

    tools/netns-run python3 tests/tools/endurance_dds.py --config config/rby1-letters.toml \
        [--crossym target/release/crossym] [--seconds 600] [--period 10] [--urdf PATH]

Reported: joint states received, the smallest distance of any controlled joint to its URDF
position limit as a fraction of its range (from /joint_states and the URDF's limits, read
here with xml.etree), the share of status messages with a joint on a bound
(`active_constraints > 0`), status codes seen, and the mock hardware's own summary (limit
violations, invalid commands). Exit 1 when the mock hardware saw a violation.
"""
# No `from __future__ import annotations`: cyclonedds resolves field annotations by name.

import argparse
import json
import math
import os
import subprocess
import sys
import time
import tomllib
import xml.etree.ElementTree as ET

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tests", "peer"))
from dds_peer import (QOS_CONDITION_W, QOS_NODE_OUTPUT_R, Header, JointState,  # noqa: E402
                      Status, SymmetryCondition, now_stamp)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--config", required=True)
    ap.add_argument("--crossym", default=os.path.join(ROOT, "target", "release", "crossym"))
    ap.add_argument("--seconds", type=float, default=600.0)
    ap.add_argument("--period", type=float, default=10.0)
    ap.add_argument("--urdf", help="default: the config's [robot] urdf")
    ap.add_argument("--out", default="/tmp/crossym-endurance-dds")
    args = ap.parse_args()

    cfg_path = os.path.abspath(args.config)
    with open(cfg_path, "rb") as f:
        cfg = tomllib.load(f)
    urdf = args.urdf or os.path.normpath(os.path.join(os.path.dirname(cfg_path), cfg["robot"]["urdf"]))
    limits = {}
    for j in ET.parse(urdf).getroot().iter("joint"):
        lim = j.find("limit")
        if lim is not None and j.get("type") in ("revolute", "prismatic"):
            limits[j.get("name")] = (float(lim.get("lower")), float(lim.get("upper")))
    conds = [(math.radians(t), l, int(s)) for t, l, s in cfg["augmentation"]["test"]["conditions"]]

    os.makedirs(args.out, exist_ok=True)
    summary = os.path.join(args.out, "hw.json")
    hw = subprocess.Popen([args.crossym, "mock-hw", "--config", cfg_path, "--summary", summary],
                          stdout=open(os.path.join(args.out, "hw.log"), "w"), stderr=subprocess.STDOUT)
    node = subprocess.Popen([args.crossym, "node", "--config", cfg_path],
                            stdout=open(os.path.join(args.out, "node.log"), "w"), stderr=subprocess.STDOUT)
    dp = DomainParticipant(int(os.environ.get("ROS_DOMAIN_ID", "0")))
    cond_w = DataWriter(dp, Topic(dp, "rt/crossym/symmetry_condition", SymmetryCondition), qos=QOS_CONDITION_W)
    status_r = DataReader(dp, Topic(dp, "rt/crossym/status", Status), qos=QOS_NODE_OUTPUT_R)
    js_r = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=QOS_NODE_OUTPUT_R)
    n_js, n_status, bound, codes = 0, 0, 0, {}
    min_margin, min_joint = math.inf, ""
    t0 = time.time()
    k = -1
    try:
        while time.time() - t0 < args.seconds:
            kk = int((time.time() - t0) // args.period)
            if kk != k:
                k = kk
                t, l, s = conds[k % len(conds)]
                cond_w.write(SymmetryCondition(header=Header(stamp=now_stamp()), theta=t, scale=l, reflection=s))
            for m in js_r.take(N=500):
                n_js += 1
                for name, q in zip(m.name, m.position):
                    if name in limits and name.startswith(("left_arm", "right_arm")):
                        lo, hi = limits[name]
                        margin = min(q - lo, hi - q) / (hi - lo)
                        if margin < min_margin:
                            min_margin, min_joint = margin, name
            for st in status_r.take(N=100):
                n_status += 1
                bound += st.active_constraints > 0
                codes[st.code] = codes.get(st.code, 0) + 1
            time.sleep(0.02)
    finally:
        for p in (node, hw):
            p.send_signal(2)
        for p in (node, hw):
            p.wait(timeout=20)
    with open(summary) as f:
        s = json.load(f)
    report = {
        "seconds": args.seconds, "conditions_sent": k + 1, "joint_states": n_js,
        "min_margin_fraction": min_margin, "min_margin_joint": min_joint,
        "statuses": n_status, "status_on_a_bound_share": bound / max(n_status, 1),
        "status_codes": codes, "hw_violations": s["violation_count"], "hw_commands_invalid": s["commands_invalid"],
    }
    print(json.dumps(report, indent=1))
    return 1 if s["violation_count"] else 0


if __name__ == "__main__":
    raise SystemExit(main())
