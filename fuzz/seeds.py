#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets into fuzz/corpus/<target>/ (gitignored).

- bag_reader: the golden bag and the regression bags of tests/data/fuzz/.
- cdr_decode: the first two CDR payloads of every topic of the golden bag.
- config_load: the shipped config/*.toml.
- node_input: short sessions in node_input's byte encoding (see node_input.rs): the rest
  posture of config/letters.toml arriving every period with ticks in between, a condition
  switch, for each output mode, policy choice and input path.

Needs the Python `mcap` package (tests/bags/install.sh installs it).
Usage: python3 fuzz/seeds.py
"""
import math
import pathlib
import shutil
import struct

from mcap.reader import make_reader

FUZZ = pathlib.Path(__file__).resolve().parent
ROOT = FUZZ.parent
CORPUS = FUZZ / "corpus"
GOLDEN = ROOT / "tests/data/golden_letters/bag_0.mcap"


def fresh(name):
    d = CORPUS / name
    d.mkdir(parents=True, exist_ok=True)
    return d


def bag_reader():
    d = fresh("bag_reader")
    shutil.copy(GOLDEN, d / "golden_letters.mcap")
    for p in sorted((ROOT / "tests/data/fuzz").glob("bag_reader_*")):
        shutil.copy(p, d / p.name)


def cdr_decode():
    d = fresh("cdr_decode")
    seen = {}
    with open(GOLDEN, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages():
            k = seen.get(channel.topic, 0)
            if k < 2:
                name = channel.topic.strip("/").replace("/", "_")
                (d / f"{name}_{k}.cdr").write_bytes(message.data)
                seen[channel.topic] = k + 1


def config_load():
    d = fresh("config_load")
    for p in sorted((ROOT / "config").glob("*.toml")):
        shutil.copy(p, d / p.name)


# node_input's encoding (keep in step with node_input.rs).
REST = [math.pi / 4, -math.pi / 6, -math.pi / 8, -math.pi / 10,
        -math.pi / 4, math.pi / 6, math.pi / 8, math.pi / 10]


def small(x):
    """f64 tag 0: x rounded to 1e-3 (|x| < 32.7)."""
    return bytes([0]) + struct.pack("<h", round(x * 1000))


def joint_state(q):
    # stamp = now (tag 2), well-formed (mode 1), no rotation, positions, received now (2).
    return bytes([0, 2, 1, 0]) + b"".join(small(x) for x in q) + bytes([2])


def tick(quarters=4):
    return bytes([4, quarters])


def condition(theta, scale, reflection):
    kind = 0 if reflection == 1 else 2
    return bytes([3, kind]) + struct.pack("<h", round(theta * 1000)) + bytes([round(scale * 200)])


def session(flags, timing, steps=12, drift=0.005):
    out = bytes([flags, timing])
    if (flags >> 5) & 3 == 3:
        # fuzzed policy: output weight scale 1.0, biases 0.05.
        out += small(1.0) + b"".join(small(0.05) for _ in REST)
    q = list(REST)
    for k in range(steps):
        if k == steps // 2:
            out += condition(math.pi / 6, 0.8, -1)
        out += joint_state(q) + tick()
        q = [x + drift for x in q]
    # a stale gap, then recovery
    out += tick(255) + tick(255) + joint_state(q) + tick()
    return out


def node_input():
    d = fresh("node_input")
    for mode in range(3):  # velocity, position, trajectory
        for policy in (0, 1, 3):
            for gate in (0, 0x80):
                flags = mode | (policy << 5) | gate | 16  # with the end-effector barrier
                (d / f"session_m{mode}_p{policy}_g{gate >> 7}").write_bytes(session(flags, 0))
    (d / "session_nostamps_untrained").write_bytes(session(4 | 8, 0x40))


if __name__ == "__main__":
    bag_reader()
    cdr_decode()
    config_load()
    node_input()
    for t in sorted(CORPUS.iterdir()):
        print(f"{t.relative_to(FUZZ)}: {len(list(t.iterdir()))} files")
