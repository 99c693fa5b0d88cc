#!/usr/bin/env python3
"""Write a joint-state recording as `ros2 bag record /joint_states` would, with rosbags.

    python3 tests/bags/write_recording.py OUTDIR --storage sqlite3|mcap [--seconds 3]
        [--rate 100] [--fault none|nan|backwards|duplicate|missing-joint|zero-stamps]
        [--dump FILE.json] [--motion wave|teach] [--noise STD] [--seed 7] [--split K]

Independent of crossym: the bag is written by rosbags' Writer (SQLite3 or MCAP storage,
CDR by its typestore). Content: /joint_states (sensor_msgs/msg/JointState) at --rate Hz,
naming the planar dual arm's eight joints in a shuffled order among joints it does not
control (torso, head, grippers), positions = a smooth motion, velocity and effort empty;
header stamps = receive time − 2 ms (a driver's measurement time), receive times jittered
by up to ±0.5 ms; a /tf_static-like decoy topic of another type.

--motion teach writes the scripted motion of tests/tools/teach_motion.py instead of the
smooth wave (rest, hold, the left arm's minimum-jerk move, hold at the goal; --seconds
defaults to its duration, the goal held after it); --noise adds Gaussian encoder noise of
that standard deviation (rad) to the controlled joints' positions; --seed seeds the joint
order, the stamp jitter and the noise (7, the default, gives the bags the wave always had).

--split K writes a split bag, as `ros2 bag record --max-bag-duration` does: K storage
files `OUTDIR_0` … `OUTDIR_{K-1}` (each written by its own rosbags Writer, the joint
states cut into K consecutive runs, the decoy in the first) listed in one metadata.yaml
(`relative_file_paths`, `files`, topic counts summed); rosbags' Reader then reads the
directory as one bag (checked before the script exits).

--dump writes, per message, the header stamp (ns), the receive time (ns) and the positions
of the eight controlled joints in the order left_joint1..4, right_joint1..4 — what a
reader mapping joints by name must return.

Faults (one message in the middle): nan (a NaN position of right_joint2), backwards (a
header stamp 5 ms before the previous), duplicate (the previous header stamp again),
missing-joint (left_joint3 absent), zero-stamps (every header stamp 0: a driver that
does not stamp), gap (the messages of 0.3 s from the middle on are missing: a dropout).
"""
from __future__ import annotations

import argparse
import json
import math
import random
import sys
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tools'))
import teach_motion  # noqa: E402  (tests/tools)

CONTROLLED = [f'left_joint{i}' for i in range(1, 5)] + [f'right_joint{i}' for i in range(1, 5)]
EXTRA = ['torso_joint', 'head_pan', 'gripper_left_finger', 'gripper_right_finger']
REST = [0.785398, -0.523599, -0.392699, -0.314159, -0.785398, 0.523599, 0.392699, 0.314159]
T0_NS = 1_750_000_000 * 1_000_000_000


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('outdir', type=Path)
    ap.add_argument('--storage', choices=('sqlite3', 'mcap'), required=True)
    ap.add_argument('--seconds', type=float, help='length (s); default 3, or the teach motion\'s duration')
    ap.add_argument('--rate', type=float, default=100.0)
    ap.add_argument('--fault', default='none',
                    choices=('none', 'nan', 'backwards', 'duplicate', 'missing-joint', 'zero-stamps', 'gap'))
    ap.add_argument('--dump', type=Path)
    ap.add_argument('--motion', choices=('wave', 'teach'), default='wave')
    ap.add_argument('--noise', type=float, default=0.0, help='encoder noise std (rad), controlled joints')
    ap.add_argument('--seed', type=int, default=7)
    ap.add_argument('--split', type=int, default=1, help='storage files (a split bag)')
    args = ap.parse_args()
    if args.seconds is None:
        args.seconds = teach_motion.DURATION_S if args.motion == 'teach' else 3.0
    noise = np.random.default_rng(args.seed) if args.noise > 0.0 else None

    store = get_typestore(Stores.ROS2_HUMBLE)
    JointState = store.types['sensor_msgs/msg/JointState']
    Header = store.types['std_msgs/msg/Header']
    Time = store.types['builtin_interfaces/msg/Time']
    Str = store.types['std_msgs/msg/String']
    rng = random.Random(args.seed)
    order = CONTROLLED + EXTRA
    rng.shuffle(order)

    n = int(round(args.seconds * args.rate))
    bad = n // 2
    plugin = StoragePlugin.SQLITE3 if args.storage == 'sqlite3' else StoragePlugin.MCAP
    rows = []
    decoy = (T0_NS - 1_000_000, store.serialize_cdr(Str(data='<robot/>'), 'std_msgs/msg/String'))
    states = []
    prev_stamp = None
    for k in range(n):
        if args.fault == 'gap' and bad <= k < bad + int(round(0.3 * args.rate)):
            continue
        t = k / args.rate
        receive = T0_NS + int(round(t * 1e9)) + rng.randint(-500_000, 500_000)
        stamp = receive - 2_000_000
        if args.fault == 'backwards' and k == bad:
            stamp = prev_stamp - 5_000_000
        if args.fault == 'duplicate' and k == bad:
            stamp = prev_stamp
        if args.fault == 'zero-stamps':
            stamp = 0
        prev_stamp = stamp
        if args.motion == 'teach':
            q = dict(zip(teach_motion.JOINTS, teach_motion.position(t)))
        else:
            q = {name: REST[i] + 0.3 * math.sin(2 * math.pi * 0.4 * t + 0.5 * i) * (1 - math.exp(-t))
                 for i, name in enumerate(CONTROLLED)}
        if noise is not None:
            q = {name: v + float(noise.normal(0.0, args.noise)) for name, v in q.items()}
        q.update({name: 0.1 * (i + 1) + 0.01 * t for i, name in enumerate(EXTRA)})
        if args.fault == 'nan' and k == bad:
            q['right_joint2'] = float('nan')
        names = [nm for nm in order if not (args.fault == 'missing-joint' and k == bad and nm == 'left_joint3')]
        msg = JointState(
            header=Header(stamp=Time(sec=stamp // 1_000_000_000, nanosec=stamp % 1_000_000_000), frame_id=''),
            name=names,
            position=np.array([q[nm] for nm in names], dtype=np.float64),
            velocity=np.array([], dtype=np.float64),
            effort=np.array([], dtype=np.float64),
        )
        states.append((receive, store.serialize_cdr(msg, 'sensor_msgs/msg/JointState')))
        rows.append({'stamp_ns': stamp, 'receive_ns': receive, 'q': [q[nm] for nm in CONTROLLED]})
    if args.split <= 1:
        write_part(args.outdir, plugin, store, [decoy], states)
    else:
        write_split(args.outdir, plugin, store, decoy, states, args.split)
    if args.dump:
        args.dump.write_text(json.dumps({'joints': CONTROLLED, 'order': order, 'rows': rows}))
    print(json.dumps({'bag': str(args.outdir), 'messages': len(rows), 'storage': args.storage}))
    return 0


def write_part(outdir, plugin, store, decoys, states) -> None:
    """One bag directory: the decoy topic's messages, then the joint states."""
    with Writer(outdir, version=8, storage_plugin=plugin) as w:
        js = w.add_connection('/joint_states', 'sensor_msgs/msg/JointState', typestore=store)
        decoy = w.add_connection('/robot_description', 'std_msgs/msg/String', typestore=store)
        for t, data in decoys:
            w.write(decoy, t, data)
        for t, data in states:
            w.write(js, t, data)


def write_split(outdir: Path, plugin, store, decoy, states, parts: int) -> None:
    """A split bag of `parts` storage files and one metadata.yaml listing them."""
    from rosbags.rosbag2 import Reader
    from ruamel.yaml import YAML

    yaml = YAML(typ='safe')
    outdir.mkdir(parents=True)
    per = -(-len(states) // parts)
    metas = []
    for i in range(parts):
        tmp = outdir.parent / f'.{outdir.name}-part{i}'
        write_part(tmp, plugin, store, [decoy] if i == 0 else [], states[i * per:(i + 1) * per])
        (storage,) = [p for p in tmp.iterdir() if p.suffix in ('.mcap', '.db3')]
        name = f'{outdir.name}_{i}{storage.suffix}'
        storage.rename(outdir / name)
        meta = yaml.load((tmp / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
        (tmp / 'metadata.yaml').unlink()
        tmp.rmdir()
        metas.append((name, meta))
    info = metas[0][1]
    info['relative_file_paths'] = [name for name, _ in metas]
    info['files'] = [{**m['files'][0], 'path': name} for name, m in metas]
    info['message_count'] = sum(m['message_count'] for _, m in metas)
    start = min(m['starting_time']['nanoseconds_since_epoch'] for _, m in metas)
    end = max(m['starting_time']['nanoseconds_since_epoch'] + m['duration']['nanoseconds'] for _, m in metas)
    info['starting_time'] = {'nanoseconds_since_epoch': start}
    info['duration'] = {'nanoseconds': end - start}
    for t in info['topics_with_message_count']:
        name = t['topic_metadata']['name']
        t['message_count'] = sum(
            u['message_count'] for _, m in metas for u in m['topics_with_message_count']
            if u['topic_metadata']['name'] == name)
    with (outdir / 'metadata.yaml').open('w') as f:
        yaml.dump({'rosbag2_bagfile_information': info}, f)
    with Reader(outdir) as r:
        got = sum(1 for c, _, _ in r.messages() if c.topic == '/joint_states')
    if got != len(states):
        raise SystemExit(f'rosbags reads {got} joint states from the split bag, {len(states)} written')


if __name__ == '__main__':
    raise SystemExit(main())
