#!/usr/bin/env python3
"""Write a LeRobotDataset of RB-Y1 joint states with PyPI pyarrow, to LeRobot's documented
layout (independent of crossym; LeRobot's own writer needs torch, which CI does not install).

    python3 tests/lerobot/write_dataset.py OUT --version v3.0|v2.1 [--layout list|scalars]
        [--compression snappy|zstd|none] [--fault none|nan|backwards|gap|shape|version|noinfo|truncate]
        [--dump FILE.json] [--episodes 3] [--fps 50] [--seconds 4] [--degrees]
        [--teach [--noise STD] [--seed N]]

Content: `--episodes` episodes of a smooth motion of RB-Y1's two arms about the letter
task's rest posture, two tasks (episode k has task k % 2), frames at `--fps`. The state is
`observation.state` (float32, shape [N], `names` the 14 arm joints shuffled among joints
crossym does not control: torso, head, grippers) with `--layout list`, or one float32
column per joint named `<joint>.pos` with `--layout scalars` (as LeRobot's robot plugins
write motors). Plus `action` (the state of the next frame), an image feature stored as a
path string, and the standard columns `timestamp` (float32, frame / fps), `frame_index`,
`episode_index`, `index`, `task_index` (int64).

v3.0: `data/chunk-000/file-000.parquet` holds episodes 0 and 1, `file-001.parquet` the
rest; `meta/episodes/chunk-000/file-000.parquet`, `meta/tasks.parquet`. v2.1: one
`data/chunk-000/episode_00000k.parquet` per episode, `meta/episodes.jsonl`,
`meta/tasks.jsonl`. `meta/info.json` in both.

Faults (in episode 1, frame 40): nan (a NaN state element), backwards (its timestamp
before the previous frame's), gap (frames 40-49 missing), shape (info.json's state shape
one longer than its names), version (codebase_version v1.6), noinfo (no meta/info.json),
truncate (the first data file cut to a third).

--teach writes instead one episode of the planar dual arm's scripted teach motion
(tests/tools/teach_motion.py, the one the bag teach test uses) at 100 fps over its duration,
the state named by its eight joints among joints it does not control, with Gaussian encoder
noise of --noise (rad, seeded by --seed).

--dump writes, per episode, the episode index, the timestamps and the 14 arm joints' values
(left_arm_0..6, right_arm_0..6) as float32 rounded, i.e. what a reader must return.
"""
import argparse
import json
import math
import random
from pathlib import Path

import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / 'tools'))
import teach_motion  # noqa: E402  (tests/tools)

ARMS = [f"left_arm_{i}" for i in range(7)] + [f"right_arm_{i}" for i in range(7)]
EXTRA = ["torso_0", "torso_1", "head_0", "head_1", "gripper_left", "gripper_right"]
REST = [-0.4, 0.6, -0.4, -1.8, 0.0, 0.2, 0.0, -0.4, -0.6, 0.4, -1.8, 0.0, 0.2, 0.0]
TASKS = ["draw the letters", "grasp the pan"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", type=Path)
    ap.add_argument("--version", choices=("v3.0", "v2.1"), required=True)
    ap.add_argument("--layout", choices=("list", "scalars"), default="list")
    ap.add_argument("--compression", choices=("snappy", "zstd", "none"), default="snappy")
    ap.add_argument("--fault", default="none",
                    choices=("none", "nan", "backwards", "gap", "shape", "version", "noinfo", "truncate"))
    ap.add_argument("--dump", type=Path)
    ap.add_argument("--episodes", type=int, default=3)
    ap.add_argument("--fps", type=int, default=50)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--degrees", action="store_true", help="store revolute positions in degrees")
    ap.add_argument("--teach", action="store_true", help="the planar arms' scripted teach motion")
    ap.add_argument("--noise", type=float, default=0.0)
    ap.add_argument("--seed", type=int, default=7)
    args = ap.parse_args()
    if args.teach:
        return write_teach(args)

    rng = random.Random(7)
    names = ARMS + EXTRA
    rng.shuffle(names)
    n = len(names)
    frames = int(round(args.seconds * args.fps))
    episodes = []  # (episode_index, task_index, rows: [(frame, t, state)])
    index = 0
    for ep in range(args.episodes):
        rows = []
        for k in range(frames):
            if args.fault == "gap" and ep == 1 and 40 <= k < 50:
                continue
            t = np.float32(k / args.fps)
            if args.fault == "backwards" and ep == 1 and k == 40:
                t = np.float32(rows[-1][1] - 0.005)
            q = {}
            for i, j in enumerate(ARMS):
                s = 1.0 - math.exp(-float(k) / args.fps)
                q[j] = REST[i] + 0.25 * s * math.sin(2 * math.pi * 0.3 * float(k) / args.fps + 0.4 * i + ep)
            for i, j in enumerate(EXTRA):
                q[j] = 0.01 * (i + 1)
            if args.degrees:
                q = {j: math.degrees(v) for j, v in q.items()}
            if args.fault == "nan" and ep == 1 and k == 40:
                q["right_arm_2"] = float("nan")
            state = np.array([q[nm] for nm in names], dtype=np.float32)
            rows.append((k, t, state))
        episodes.append((ep, ep % 2, rows))

    def table(eps):
        nonlocal index
        cols = {"timestamp": [], "frame_index": [], "episode_index": [], "index": [], "task_index": [],
                "observation.images.head": []}
        states, actions = [], []
        for ep, task, rows in eps:
            for i, (k, t, st) in enumerate(rows):
                cols["timestamp"].append(t)
                cols["frame_index"].append(k)
                cols["episode_index"].append(ep)
                cols["index"].append(index)
                cols["task_index"].append(task)
                cols["observation.images.head"].append(f"images/episode_{ep:06d}/frame_{k:06d}.png")
                states.append(st)
                actions.append(rows[min(i + 1, len(rows) - 1)][2])
                index += 1
        arrays = {
            "timestamp": pa.array(cols["timestamp"], pa.float32()),
            "frame_index": pa.array(cols["frame_index"], pa.int64()),
            "episode_index": pa.array(cols["episode_index"], pa.int64()),
            "index": pa.array(cols["index"], pa.int64()),
            "task_index": pa.array(cols["task_index"], pa.int64()),
            "observation.images.head": pa.array(cols["observation.images.head"], pa.string()),
        }
        flat = np.stack(states) if states else np.zeros((0, n), np.float32)
        if args.layout == "list":
            arrays["observation.state"] = pa.FixedSizeListArray.from_arrays(
                pa.array(flat.reshape(-1), pa.float32()), n)
        else:
            for i, nm in enumerate(names):
                arrays[f"{nm}.pos"] = pa.array(flat[:, i], pa.float32())
        arrays["action"] = pa.FixedSizeListArray.from_arrays(
            pa.array(np.stack(actions).reshape(-1) if actions else [], pa.float32()), n)
        return pa.table(arrays)

    comp = None if args.compression == "none" else args.compression
    out = args.out
    (out / "meta").mkdir(parents=True)
    data_files = []
    if args.version == "v3.0":
        groups = [episodes[:2], episodes[2:]]
        for fi, g in enumerate(groups):
            if not g:
                continue
            p = out / "data" / "chunk-000" / f"file-{fi:03d}.parquet"
            p.parent.mkdir(parents=True, exist_ok=True)
            pq.write_table(table(g), p, compression=comp)
            data_files.append(p)
        ep_meta = pa.table({
            "episode_index": pa.array([e[0] for e in episodes], pa.int64()),
            "tasks": pa.array([[TASKS[e[1]]] for e in episodes], pa.list_(pa.string())),
            "length": pa.array([len(e[2]) for e in episodes], pa.int64()),
            "data/chunk_index": pa.array([0 for _ in episodes], pa.int64()),
            "data/file_index": pa.array([0 if e[0] < 2 else 1 for e in episodes], pa.int64()),
        })
        (out / "meta" / "episodes" / "chunk-000").mkdir(parents=True)
        pq.write_table(ep_meta, out / "meta" / "episodes" / "chunk-000" / "file-000.parquet")
        pq.write_table(pa.table({"task": TASKS, "task_index": pa.array([0, 1], pa.int64())}),
                       out / "meta" / "tasks.parquet")
        data_path = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
    else:
        for e in episodes:
            p = out / "data" / "chunk-000" / f"episode_{e[0]:06d}.parquet"
            p.parent.mkdir(parents=True, exist_ok=True)
            pq.write_table(table([e]), p, compression=comp)
            data_files.append(p)
        with open(out / "meta" / "episodes.jsonl", "w") as f:
            for e in episodes:
                f.write(json.dumps({"episode_index": e[0], "tasks": [TASKS[e[1]]], "length": len(e[2])}) + "\n")
        with open(out / "meta" / "tasks.jsonl", "w") as f:
            for i, t in enumerate(TASKS):
                f.write(json.dumps({"task_index": i, "task": t}) + "\n")
        data_path = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"

    features = {
        "timestamp": {"dtype": "float32", "shape": [1], "names": None},
        "frame_index": {"dtype": "int64", "shape": [1], "names": None},
        "episode_index": {"dtype": "int64", "shape": [1], "names": None},
        "index": {"dtype": "int64", "shape": [1], "names": None},
        "task_index": {"dtype": "int64", "shape": [1], "names": None},
        "observation.images.head": {"dtype": "image", "shape": [480, 640, 3],
                                    "names": ["height", "width", "channels"]},
        "action": {"dtype": "float32", "shape": [n], "names": names},
    }
    if args.layout == "list":
        features["observation.state"] = {"dtype": "float32", "shape": [n + (args.fault == "shape")],
                                         "names": names}
    else:
        for nm in names:
            features[f"{nm}.pos"] = {"dtype": "float32", "shape": [1], "names": None}
    info = {
        "codebase_version": "v1.6" if args.fault == "version" else args.version,
        "robot_type": "rby1",
        "total_episodes": len(episodes),
        "total_frames": index,
        "total_tasks": len(TASKS),
        "chunks_size": 1000,
        "fps": args.fps,
        "splits": {"train": f"0:{len(episodes)}"},
        "data_path": data_path,
        "features": features,
    }
    if args.fault != "noinfo":
        (out / "meta" / "info.json").write_text(json.dumps(info, indent=4))
    if args.fault == "truncate":
        b = data_files[0].read_bytes()
        data_files[0].write_bytes(b[: len(b) // 3])
    if args.dump:
        dump = []
        for ep, task, rows in episodes:
            dump.append({
                "episode_index": ep, "task_index": task,
                "t": [float(r[1]) for r in rows],
                "q": [[float(r[2][names.index(j)]) for j in ARMS] for r in rows],
            })
        args.dump.write_text(json.dumps({"joints": ARMS, "names": names, "episodes": dump}))
    print(json.dumps({"dataset": str(out), "frames": index, "files": [str(p) for p in data_files]}))
    return 0


def write_teach(args) -> int:
    """One episode of the teach motion (v3.0 or v2.1 layout, list state, float32)."""
    fps = 100
    extra = ["torso_joint", "head_pan", "gripper_left_finger", "gripper_right_finger"]
    names = teach_motion.JOINTS + extra
    random.Random(args.seed).shuffle(names)
    noise = np.random.default_rng(args.seed)
    frames = int(round(teach_motion.DURATION_S * fps)) + 1
    ts, states = [], []
    for k in range(frames):
        t = k / fps
        q = dict(zip(teach_motion.JOINTS, teach_motion.position(t)))
        if args.noise > 0:
            q = {j: v + float(noise.normal(0.0, args.noise)) for j, v in q.items()}
        q.update({j: 0.1 * (i + 1) for i, j in enumerate(extra)})
        ts.append(np.float32(t))
        states.append(np.array([q[j] for j in names], dtype=np.float32))
    n = len(names)
    tbl = pa.table({
        "timestamp": pa.array(ts, pa.float32()),
        "frame_index": pa.array(range(frames), pa.int64()),
        "episode_index": pa.array([0] * frames, pa.int64()),
        "index": pa.array(range(frames), pa.int64()),
        "task_index": pa.array([0] * frames, pa.int64()),
        "observation.state": pa.FixedSizeListArray.from_arrays(
            pa.array(np.stack(states).reshape(-1), pa.float32()), n),
    })
    out = args.out
    if args.version == "v3.0":
        p = out / "data" / "chunk-000" / "file-000.parquet"
    else:
        p = out / "data" / "chunk-000" / "episode_000000.parquet"
    p.parent.mkdir(parents=True)
    comp = None if args.compression == "none" else args.compression
    pq.write_table(tbl, p, compression=comp)
    scalar = lambda dt: {"dtype": dt, "shape": [1], "names": None}  # noqa: E731
    info = {
        "codebase_version": args.version, "robot_type": "planar_dual_arm", "total_episodes": 1,
        "total_frames": frames, "total_tasks": 1, "chunks_size": 1000, "fps": fps,
        "splits": {"train": "0:1"},
        "features": {
            "observation.state": {"dtype": "float32", "shape": [n], "names": names},
            "timestamp": scalar("float32"), "frame_index": scalar("int64"),
            "episode_index": scalar("int64"), "index": scalar("int64"), "task_index": scalar("int64"),
        },
    }
    (out / "meta").mkdir(parents=True, exist_ok=True)
    (out / "meta" / "info.json").write_text(json.dumps(info, indent=4))
    print(json.dumps({"dataset": str(out), "frames": frames}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
