#!/usr/bin/env python3
"""Drive a position-commanded robot through the scripted teach motion, live over DDS.

The demonstrator of `tests/integration/teach.rs` (issue 19): on Eclipse Cyclone DDS (PyPI
`cyclonedds`, the hand-written ROS 2 types of `dds_peer.py`, no code shared with crossym)
it publishes std_msgs/Float64MultiArray position commands of the eight controlled joints
of the planar dual arm on `rt/forward_velocity_controller/commands` (reliable, keep last
10: what `crossym mock-hw --command position` subscribes) at --rate Hz, the positions of
`tests/tools/teach_motion.py` at the elapsed wall-clock time:

1. waits (up to --timeout s) until the command writer matched a reader and a joint state
   arrived on `rt/joint_states` (the robot runs);
2. holds the rest posture for --lead-s seconds (time for a recorder to join), then runs the
   scripted motion (its own hold, the left arm's minimum-jerk move, the hold at the goal);
3. waits for the commands to be acknowledged and exits.

    python3 tests/peer/teach_driver.py [--domain N] [--rate 100] [--lead-s 1.5]
        [--timeout 30] [--json OUT]

Exit status: 0 done, 2 no robot within --timeout. The JSON report has the commands sent,
the first joint state received (names, positions), the largest gap between two commands
(s) and the script's start on the wall clock (s since the epoch). Run it in the robot's
network namespace and ROS_DOMAIN_ID.
"""
# No `from __future__ import annotations`: cyclonedds resolves annotations by name.

import argparse
import json
import os
import sys
import time
from pathlib import Path

from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.qos import Policy, Qos
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from dds_peer import XCDR1, Float64MultiArray, JointState, TOPIC_COMMANDS, TOPIC_JOINT_STATES

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tools'))
import teach_motion  # noqa: E402  (tests/tools)

# ForwardCommandController-like QoS (system default: reliable, volatile, keep last 10).
QOS_COMMANDS_W = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(milliseconds=50)),
                     Policy.Durability.Volatile, Policy.History.KeepLast(10), XCDR1)
QOS_JOINT_STATES_R = Qos(Policy.Reliability.BestEffort, Policy.Durability.Volatile,
                         Policy.History.KeepLast(10), XCDR1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--domain', type=int, default=int(os.environ.get('ROS_DOMAIN_ID', '0')))
    ap.add_argument('--rate', type=float, default=100.0, help='commands per second')
    ap.add_argument('--lead-s', type=float, default=1.5, help='rest held before the script (s)')
    ap.add_argument('--timeout', type=float, default=30.0, help='wait this long for the robot (s)')
    ap.add_argument('--json', metavar='OUT', help='write the report here')
    args = ap.parse_args(argv)

    dp = DomainParticipant(args.domain)
    cmd_w = DataWriter(dp, Topic(dp, TOPIC_COMMANDS, Float64MultiArray), qos=QOS_COMMANDS_W)
    js_r = DataReader(dp, Topic(dp, TOPIC_JOINT_STATES, JointState), qos=QOS_JOINT_STATES_R)

    deadline = time.monotonic() + args.timeout
    first_js = None
    while time.monotonic() < deadline:
        for s in js_r.take(N=100):
            if first_js is None and isinstance(s, JointState):
                first_js = s
        if first_js is not None and cmd_w.get_publication_matched_status().current_count > 0:
            break
        time.sleep(0.01)
    else:
        print(f'teach_driver: no robot within {args.timeout} s (joint state seen: {first_js is not None}, '
              f'command readers matched: {cmd_w.get_publication_matched_status().current_count})',
              file=sys.stderr)
        return 2

    period = 1.0 / args.rate
    sent, max_gap = 0, 0.0
    t0 = time.monotonic() + args.lead_s  # the script's t = 0
    start_wall = time.time() + args.lead_s
    next_t = time.monotonic()
    last = None
    while True:
        now = time.monotonic()
        if now < next_t:
            time.sleep(next_t - now)
            continue
        next_t += period
        if next_t < now - 0.05:  # fell far behind: resynchronise instead of bursting
            next_t = now + period
        t = now - t0
        cmd_w.write(Float64MultiArray(data=teach_motion.position(t)))
        sent += 1
        if last is not None:
            max_gap = max(max_gap, now - last)
        last = now
        if t >= teach_motion.DURATION_S:
            break
    try:
        cmd_w.wait_for_acks(duration(seconds=2))
    except Exception as e:  # noqa: BLE001 — a missing ack is reported, not fatal
        print(f'teach_driver: waiting for acks: {e}', file=sys.stderr)
    report = {
        'commands_sent': sent, 'max_command_gap_s': max_gap, 'script_start_wall_s': start_wall,
        'first_joint_state': {'name': list(first_js.name), 'position': list(first_js.position)},
        'domain': args.domain,
    }
    if args.json:
        Path(args.json).write_text(json.dumps(report))
    print(f'teach_driver: {sent} commands, largest gap {max_gap * 1e3:.1f} ms')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
