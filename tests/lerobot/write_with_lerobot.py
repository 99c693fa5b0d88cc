#!/usr/bin/env python3
"""Write a LeRobotDataset with LeRobot's own writer (PyPI lerobot 0.4.4; needs torch, so not
run in CI): the committed fixture tests/data/lerobot/lerobot-0.4.4-rby1 and its expected.json.

    python3 tests/lerobot/write_with_lerobot.py OUT   # writes OUT/ and OUT.json
"""
import json, math, random, shutil, sys
import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset
out = sys.argv[1]
shutil.rmtree(out, ignore_errors=True)
ARMS = [f"left_arm_{i}" for i in range(7)] + [f"right_arm_{i}" for i in range(7)]
EXTRA = ["torso_0", "head_0", "gripper_left", "gripper_right"]
REST = [-0.4, 0.6, -0.4, -1.8, 0.0, 0.2, 0.0, -0.4, -0.6, 0.4, -1.8, 0.0, 0.2, 0.0]
names = ARMS + EXTRA
random.Random(3).shuffle(names)
n = len(names)
features = {
    "observation.state": {"dtype": "float32", "shape": (n,), "names": names},
    "action": {"dtype": "float32", "shape": (n,), "names": names},
}
ds = LeRobotDataset.create("local/rby1_test", fps=50, features=features, root=out, robot_type="rby1", use_videos=False)
dump = []
for ep in range(3):
    rows = []
    for k in range(200):
        q = {j: REST[i] + 0.2 * (1 - math.exp(-k / 50)) * math.sin(2 * math.pi * 0.3 * k / 50 + 0.4 * i + ep) for i, j in enumerate(ARMS)}
        q.update({j: 0.01 * (i + 1) for i, j in enumerate(EXTRA)})
        st = np.array([q[j] for j in names], dtype=np.float32)
        ds.add_frame({"observation.state": st, "action": st, "task": ["draw", "grasp"][ep % 2]})
        rows.append([float(st[names.index(j)]) for j in ARMS])
    ds.save_episode()
    dump.append(rows)
ds.finalize()
json.dump({"names": names, "joints": ARMS, "q": dump}, open(out + ".json", "w"))
print("ok")
