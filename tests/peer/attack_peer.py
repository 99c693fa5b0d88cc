#!/usr/bin/env python3
"""An unsecured, independent DDS peer attacking the crossym node (no credentials).

Plain Cyclone DDS (PyPI `cyclonedds`, no security plugins, no keystore), with the
ROS 2 names and types of tests/peer/dds_peer.py. For --seconds it

  - publishes a symmetry condition on rt/crossym/symmetry_condition every 200 ms
    (what an attacker wants the node to apply), and
  - reads the node's command topic (rt/forward_velocity_controller/commands) and its
    status (rt/crossym/status),
  - with --pause, calls the node's ~/pause (std_srvs/SetBool, data = true) every 200 ms
    instead of publishing a condition: the request on rq/crossym/pauseRequest, the reply
    read on rr/crossym/pauseReply. The node serves ~/pause with ros2-client's "Enhanced"
    mapping (RPC over DDS, as Fast DDS): the payload is the bare request, the request id
    travels as inline QoS (related_sample_identity) and, when absent as here, is the
    request sample's own identity (writer GUID, sequence number); the reply is the bare
    response. So a plain DDS writer of SetBool_Request_ calls it (as
    tests/peer/operator_peer.py does, whose types this peer uses).

then prints one JSON line: {"sent": conditions (or pause requests) written, "commands":
commands received, "statuses": statuses received, "paused": statuses saying paused,
"replies": ~/pause replies received, "matched_readers": node readers matched by its
condition (or request) writer, "matched_writers": node writers matched by its command
reader}. Exit 0 whatever it saw: tests/integration/security.rs judges (against an
unsecured node the attack must succeed, against a secured one it must not).

    python3 tests/peer/attack_peer.py --domain N [--seconds S] [--theta T --scale L --reflection R]
    python3 tests/peer/attack_peer.py --domain N --pause [--seconds S]
"""

import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import dds_peer as p  # noqa: E402  (the node's topics, types and QoS)
from operator_peer import SetBoolRequest, SetBoolResponse  # noqa: E402  (std_srvs/SetBool)

from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402


TOPIC_PAUSE_REQUEST = "rq/crossym/pauseRequest"
TOPIC_PAUSE_REPLY = "rr/crossym/pauseReply"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--domain", type=int, required=True)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--theta", type=float, default=0.5)
    ap.add_argument("--scale", type=float, default=0.8)
    ap.add_argument("--reflection", type=int, default=1)
    ap.add_argument("--pause", action="store_true", help="call ~/pause instead of publishing a condition")
    a = ap.parse_args(argv)

    dp = DomainParticipant(a.domain)
    if a.pause:
        cond_w = DataWriter(dp, Topic(dp, TOPIC_PAUSE_REQUEST, SetBoolRequest), qos=p.QOS_CONDITION_W)
        reply_r = DataReader(dp, Topic(dp, TOPIC_PAUSE_REPLY, SetBoolResponse), qos=p.QOS_NODE_OUTPUT_R)
    else:
        cond_w = DataWriter(dp, Topic(dp, p.TOPIC_CONDITION, p.SymmetryCondition), qos=p.QOS_CONDITION_W)
        reply_r = None
    cmd_r = DataReader(dp, Topic(dp, p.TOPIC_COMMANDS, p.Float64MultiArray), qos=p.QOS_NODE_OUTPUT_R)
    # Status decoded as raw samples are not needed: a count of what arrives is the point.
    st_r = DataReader(dp, Topic(dp, p.TOPIC_STATUS, p.Status), qos=p.QOS_NODE_OUTPUT_R)
    sent = commands = statuses = paused = replies = 0
    matched_readers = matched_writers = 0
    t_end = time.monotonic() + a.seconds
    last = 0.0
    while time.monotonic() < t_end:
        now = time.monotonic()
        if now - last >= 0.2:
            if a.pause:
                cond_w.write(SetBoolRequest(data=True))
            else:
                cond_w.write(p.make_condition(a.theta, a.scale, a.reflection))
            sent += 1
            last = now
        for reader in (cmd_r, st_r, reply_r):
            if reader is None:
                continue
            try:
                samples = reader.take(N=1000)
                n = len(samples)
            except Exception:  # an undecodable sample still arrived
                samples, n = [], 1
            if reader is cmd_r:
                commands += n
            elif reader is st_r:
                statuses += n
                paused += sum(1 for s in samples if getattr(s, "paused", False))
            else:
                replies += n
        matched_readers = max(matched_readers, len(cond_w.get_matched_subscriptions()))
        matched_writers = max(matched_writers, len(cmd_r.get_matched_publications()))
        time.sleep(0.01)
    print(json.dumps({"sent": sent, "commands": commands, "statuses": statuses,
                      "paused": paused, "replies": replies, "matched_readers": matched_readers, "matched_writers": matched_writers}),
          flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
