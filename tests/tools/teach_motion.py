#!/usr/bin/env python3
"""The scripted motion of the teach-by-demonstration test (issue 19), defined once.

The planar dual arm (`urdf/planar_dual_arm.urdf`) starts at the rest posture of the
letter task (left q0, right −q0), holds still for HOLD_BEFORE_S, then the LEFT arm moves
by minimum jerk to GOAL_LEFT in MOVE_S while the right arm holds, then everything holds
still for HOLD_AFTER_S. Joint order: left_joint1..4, right_joint1..4 (rad).

Used by `tests/peer/teach_driver.py` (drives `crossym mock-hw` live over DDS),
`tests/bags/write_recording.py --motion teach` (the same motion written by rosbags) and
`tests/integration/teach.rs` (the reference the reproduced motion is checked against):

    python3 tests/tools/teach_motion.py [--rate 100]   # JSON on stdout

prints {"joints", "rest", "goal", "hold_before_s", "move_s", "hold_after_s",
"duration_s", "rate_hz", "t": [...], "q": [[8 values], ...]} — the scripted motion
sampled at --rate Hz from t = 0 to duration_s, positions computed here, independently of
crossym.
"""
from __future__ import annotations

import argparse
import json
import math

JOINTS = [f'left_joint{i}' for i in range(1, 5)] + [f'right_joint{i}' for i in range(1, 5)]
# The letter task's rest posture (config/letters.toml [check] reference_q).
REST_LEFT = [math.pi / 4, -math.pi / 6, -math.pi / 8, -math.pi / 10]
REST = REST_LEFT + [-v for v in REST_LEFT]
# Left arm: +0.5, −0.45, +0.4 rad on joints 1–3, joint 4 holds (the limits are ±2π).
DELTA_LEFT = [0.5, -0.45, 0.4, 0.0]
GOAL_LEFT = [q + d for q, d in zip(REST_LEFT, DELTA_LEFT)]
GOAL = GOAL_LEFT + REST[4:]
HOLD_BEFORE_S = 0.5
MOVE_S = 2.0
HOLD_AFTER_S = 0.5
DURATION_S = HOLD_BEFORE_S + MOVE_S + HOLD_AFTER_S


def min_jerk(s: float) -> float:
    """Minimum-jerk profile on [0, 1]: 10s³ − 15s⁴ + 6s⁵ (zero velocity and acceleration
    at both ends)."""
    s = min(max(s, 0.0), 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def position(t: float) -> list[float]:
    """Positions of the eight controlled joints at time t (s) of the scripted motion;
    before 0 the rest posture, after DURATION_S the goal."""
    a = min_jerk((t - HOLD_BEFORE_S) / MOVE_S)
    return [r + a * (g - r) for r, g in zip(REST, GOAL)]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--rate', type=float, default=100.0, help='samples per second of the printed path')
    args = ap.parse_args()
    n = int(round(DURATION_S * args.rate))
    ts = [k / args.rate for k in range(n + 1)]
    print(json.dumps({
        'joints': JOINTS, 'rest': REST, 'goal': GOAL,
        'hold_before_s': HOLD_BEFORE_S, 'move_s': MOVE_S, 'hold_after_s': HOLD_AFTER_S,
        'duration_s': DURATION_S, 'rate_hz': args.rate,
        't': ts, 'q': [position(t) for t in ts],
    }))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
