#!/usr/bin/env python3
"""Write a reference rosbag2 bag (MCAP storage) with rosbags' Writer.

Independent of the Rust code: the bag is made by rosbags (CDR via its
typestore), so the Rust reader in crates/crossym-io/src/bag can be checked against it, and the
bag's layout (example_schemas.txt, example_metadata.yaml) is what the Rust
writer must match.

    python3 tests/bags/write_bag.py OUTDIR --msgs msgs/msg [--seconds 2]
        [--all-topics] [--version 9|8] [--no-qos] [--compress zstd]

OUTDIR must not exist (rosbags never overwrites). A JSON summary (topics,
types, counts, first/last log times) is printed on stdout.

Content, with t0 = 1_700_000_000 s and every header stamp = log time:
  /joint_states (sensor_msgs/msg/JointState), 100 Hz: left_joint1..4,
      right_joint1..4, position = rest posture + small sinusoids, velocity =
      their derivative, effort empty.
  /crossym/symmetry_condition (crossym_msgs/msg/SymmetryCondition): at t=0
      (theta 0, scale 1, reflection 1) and at t=S/2 (0.5236, 0.8, -1).
  with --all-topics, also:
  /forward_velocity_controller/commands (std_msgs/msg/Float64MultiArray),
      100 Hz, 8 values, empty layout.
  /crossym/status (crossym_msgs/msg/Status), 10 Hz.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from importlib.metadata import version as pkg_version
from pathlib import Path

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

T0_NS = 1_700_000_000 * 1_000_000_000
JOINT_NAMES = [f'left_joint{i}' for i in range(1, 5)] + [f'right_joint{i}' for i in range(1, 5)]
REST = [0.785398, -0.523599, -0.392699, -0.314159, -0.785398, 0.523599, 0.392699, 0.314159]
AMPLITUDE = 0.05  # rad
FREQ = 0.5  # Hz

TOPIC_JS = '/joint_states'
TOPIC_COND = '/crossym/symmetry_condition'
TOPIC_CMD = '/forward_velocity_controller/commands'
TOPIC_STATUS = '/crossym/status'

T_JS = 'sensor_msgs/msg/JointState'
T_COND = 'crossym_msgs/msg/SymmetryCondition'
T_CMD = 'std_msgs/msg/Float64MultiArray'
T_STATUS = 'crossym_msgs/msg/Status'

# rosbag2's representation of an infinite duration (RMW_DURATION_INFINITE).
INFINITE = QosTime(sec=9223372036, nsec=854775807)
# What a default rclcpp publisher offers: keep_last 10, reliable, volatile.
DEFAULT_QOS = Qos(
    history=QosHistory.KEEP_LAST,
    depth=10,
    reliability=QosReliability.RELIABLE,
    durability=QosDurability.VOLATILE,
    deadline=INFINITE,
    lifespan=INFINITE,
    liveliness=QosLiveliness.AUTOMATIC,
    liveliness_lease_duration=INFINITE,
    avoid_ros_namespace_conventions=False,
)


def make_typestore(msgs_dir: Path):
    """Jazzy typestore plus crossym_msgs registered from the .msg files."""
    store = get_typestore(Stores.ROS2_JAZZY)
    add = {}
    files = sorted(msgs_dir.glob('*.msg'))
    if not files:
        sys.exit(f'write_bag.py: no .msg files in {msgs_dir}')
    for path in files:
        add.update(get_types_from_msg(path.read_text(), f'crossym_msgs/msg/{path.stem}'))
    store.register(add)
    return store


def positions(t: float) -> list[float]:
    w = 2.0 * math.pi * FREQ
    return [r + AMPLITUDE * math.sin(w * t + 0.3 * i) for i, r in enumerate(REST)]


def velocities(t: float) -> list[float]:
    w = 2.0 * math.pi * FREQ
    return [AMPLITUDE * w * math.cos(w * t + 0.3 * i) for i in range(len(REST))]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('outdir', type=Path, help='bag directory to create (must not exist)')
    ap.add_argument('--msgs', type=Path, required=True, help='folder with crossym_msgs .msg files')
    ap.add_argument('--seconds', type=float, default=2.0, help='bag length S (default 2)')
    ap.add_argument('--all-topics', action='store_true',
                    help='also write Float64MultiArray commands (100 Hz) and Status (10 Hz)')
    ap.add_argument('--version', type=int, choices=(8, 9), default=9,
                    help='rosbag2 metadata version (default 9, rosbags\' latest)')
    ap.add_argument('--no-qos', action='store_true', help='write empty offered_qos_profiles')
    ap.add_argument('--compress', choices=('none', 'zstd'), default='none',
                    help='zstd: MCAP chunk compression (rosbags CompressionMode.STORAGE)')
    args = ap.parse_args()

    store = make_typestore(args.msgs)
    JointState = store.types[T_JS]
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    Cond = store.types[T_COND]
    F64MA = store.types[T_CMD]
    Layout = store.types['std_msgs/msg/MultiArrayLayout']
    Status = store.types[T_STATUS]

    import numpy as np

    def header(ns: int, frame: str = '') -> object:
        return Header(stamp=Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000), frame_id=frame)

    n_fast = int(round(args.seconds * 100))
    half_ns = T0_NS + int(round(args.seconds / 2 * 1e9))
    conds = [(T0_NS, 0.0, 1.0, 1), (half_ns, 0.5236, 0.8, -1)]

    # (log_time_ns, order, topic, msg)
    events: list[tuple[int, int, str, object]] = []
    for ns, theta, scale, refl in conds:
        events.append((ns, 0, TOPIC_COND,
                       Cond(header=header(ns), theta=theta, scale=scale, reflection=refl)))
    for i in range(n_fast):
        ns = T0_NS + i * 10_000_000
        t = i * 0.01
        events.append((ns, 1, TOPIC_JS, JointState(
            header=header(ns),
            name=list(JOINT_NAMES),
            position=np.array(positions(t), dtype=np.float64),
            velocity=np.array(velocities(t), dtype=np.float64),
            effort=np.array([], dtype=np.float64),
        )))
    if args.all_topics:
        for i in range(n_fast):
            ns = T0_NS + i * 10_000_000 + 1_000_000  # 1 ms after the joint state
            t = i * 0.01
            events.append((ns, 2, TOPIC_CMD, F64MA(
                layout=Layout(dim=[], data_offset=0),
                data=np.array([-0.5 * v for v in velocities(t)], dtype=np.float64),
            )))
        n_status = int(round(args.seconds * 10))
        for k in range(n_status):
            ns = T0_NS + k * 100_000_000 + 2_000_000
            active = conds[1] if ns >= conds[1][0] else conds[0]
            code = 3 if k % 7 == 6 else 0
            events.append((ns, 3, TOPIC_STATUS, Status(
                header=header(ns),
                code=code,
                message='DECELERATE_FOR_COLLISION' if code == 3 else 'NO_WARNING',
                last_error='',
                active_constraints=k % 3,
                rejected_joint_states=0,
                rejected_conditions=0,
                ticks=10 * k + 1,
                stale_ticks=0,
                joint_state_age_s=0.002,
                tick_time_us=100.0 + k,
                tick_time_max_us=150.0 + 2 * k,
                condition=Cond(header=header(active[0]), theta=active[1], scale=active[2],
                               reflection=active[3]),
                restarts=0,
                not_following_ticks=0,
                tracking_warning_ticks=0,
                tracking_error=0.001 * (k % 4),
                paused=(k % 5 == 4),
                velocity_scale=1.0 - 0.1 * (k % 2),
                singularity_condition=2.0 + k,
                singularity_factor=1.0,
                period_code=code,
                period_ticks=10,
                period_restarts=0,
                period_held=0,
                period_locked=0,
                period_rejected=0,
                period_stale_ticks=0,
                period_fallback_ticks=0,
                held_events=0,
                locked_events=0,
                locked_joint='',
                command_subscribers=1,
                late_ticks=0,
                missed_ticks=0,
                period_late_ticks=0,
                period_missed_ticks=0,
                tick_late_max_us=0.0,
            )))
    events.sort(key=lambda e: (e[0], e[1]))

    types = {TOPIC_JS: T_JS, TOPIC_COND: T_COND, TOPIC_CMD: T_CMD, TOPIC_STATUS: T_STATUS}
    order = [TOPIC_JS, TOPIC_COND] + ([TOPIC_CMD, TOPIC_STATUS] if args.all_topics else [])
    qos = [] if args.no_qos else [DEFAULT_QOS]

    writer = Writer(args.outdir, version=args.version, storage_plugin=StoragePlugin.MCAP)
    if args.compress == 'zstd':
        writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
    counts = {t: 0 for t in order}
    times: dict[str, list[int]] = {t: [] for t in order}
    with writer:
        conns = {
            t: writer.add_connection(t, types[t], typestore=store, offered_qos_profiles=qos)
            for t in order
        }
        for ns, _, topic, msg in events:
            writer.write(conns[topic], ns, store.serialize_cdr(msg, types[topic]))
            counts[topic] += 1
            times[topic].append(ns)

    summary = {
        'bag': str(args.outdir),
        'storage': 'mcap',
        'rosbag2_version': args.version,
        'rosbags': pkg_version('rosbags'),
        'files': sorted(p.name for p in args.outdir.iterdir()),
        'message_count': sum(counts.values()),
        'topics': {
            t: {
                'type': types[t],
                'count': counts[t],
                'first_log_time_ns': times[t][0] if times[t] else None,
                'last_log_time_ns': times[t][-1] if times[t] else None,
            }
            for t in order
        },
    }
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == '__main__':
    sys.exit(main())
