#!/usr/bin/env python3
"""Self-test of the physics-simulated RB-Y1 without DDS (prints the measured numbers).

    python3 physics/selftest.py [--model-dir SDK/mujoco] [--urdf URDF] [--json OUT]

Checks: the model of every version compiles; gravity sag of the shoulders at a bent posture
(a few mrad without gravity compensation, < 1e-4 rad with it); the lag with which a 0.5 rad/s
ramp reference is followed (whole chain, and each layer off); the hardware follower's
velocity/acceleration limits and overshoot; the target filter; the JointTrajectoryController
port against hand-computed samples (linear, cubic, quintic, hold after the end, start from
measured vs last reference, stamps, partial goals, rejections); a trajectory, a reset, a
frozen joint and a collision hold through the whole simulated robot; the CPU time of one
100 Hz iteration (5 physics steps + the joint-state arrays).
Closes with `selftest: N passed, N failed`; exit 0 if all passed.
"""

import argparse
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import rby1_mujoco as R  # noqa: E402
import jtc as J  # noqa: E402
from rby1_model import VERSIONS, default_urdf, load_model  # noqa: E402

SDK = os.path.join(HERE, "..", "robots", "rby1a", "vendor-sdk", "mujoco")
URDF = os.path.join(HERE, "..", "robots", "rby1a", "model.urdf")
NS = J.NS

results = []
numbers = {}


def check(name, ok, detail=""):
    results.append((name, bool(ok)))
    print(f"{'PASS' if ok else 'FAIL'} {name}{(': ' + detail) if detail else ''}", flush=True)


def make_sim(model_dir, urdf, extra=(), initial_q=None):
    argv = ["--model-dir", model_dir, "--urdf", urdf] + list(extra)
    if initial_q is not None:
        argv.append("--initial-q=" + ",".join(repr(float(x)) for x in initial_q))
    args = R.make_parser().parse_args(argv)
    sim, _, _ = R.build_sim(args, clock_origin_ns=1_700_000_000 * NS)
    return sim


BENT_LEFT = [-1.0, 0.3, 0.0, -1.2, 0.0, 0.0, 0.0]
BENT_RIGHT = [-1.0, -0.3, 0.0, -1.2, 0.0, 0.0, 0.0]
BENT = BENT_LEFT + BENT_RIGHT


def test_compile(model_dir):
    for v in VERSIONS:
        try:
            m, info = load_model(model_dir, v, default_urdf(model_dir, v))
            ok = m.nq == 28 and m.nu == 26 and len(info.force_limits) == 22
            check(f"model v{v} compiles", ok, f"nq {m.nq}, nu {m.nu}, {m.ngeom} primitive geoms, "
                  f"{len(info.force_limits)} force-limited actuators, timestep {m.opt.timestep}")
        except Exception as e:  # pragma: no cover
            check(f"model v{v} compiles", False, repr(e))


def test_sag(model_dir, urdf):
    out = {}
    for gc in (False, True):
        sim = make_sim(model_dir, urdf, ["--gravity-compensation"] if gc else [], BENT)
        sim.run(int(3.0 / sim.dt))
        err = sim.reference - sim.measured()
        out[gc] = {n: float(e) for n, e in zip(sim.joints, err)}
    sh = ["left_arm_0", "left_arm_1", "right_arm_0", "right_arm_1"]
    no = {n: out[False][n] for n in sh}
    yes = {n: out[True][n] for n in sh}
    numbers["sag_without_gravcomp_rad"] = out[False]
    numbers["sag_with_gravcomp_rad"] = out[True]
    worst_no = max(abs(v) for v in no.values())
    worst_yes = max(abs(v) for v in out[True].values())
    check("shoulder sag without gravity compensation is a few mrad", 1e-3 <= worst_no <= 2e-2,
          ", ".join(f"{n} {v * 1e3:+.3f} mrad" for n, v in no.items()))
    check("sag with gravity compensation < 1e-4 rad (all 14 joints)", worst_yes < 1e-4,
          ", ".join(f"{n} {v * 1e3:+.5f} mrad" for n, v in yes.items()) + f"; worst {worst_yes:.2e} rad")


def ramp_lag(model_dir, urdf, extra, joint="left_arm_3", q_start=-0.3, v=-0.5, T=3.0):
    """Forward-command a ramp (one value per controller tick) and measure the lag."""
    q0 = list(BENT)
    k = R.DEFAULT_JOINTS.index(joint)
    q0[k] = q_start
    sim = make_sim(model_dir, urdf, ["--gravity-compensation"] + list(extra), q0)
    n = int(T / sim.dt)
    ref = np.array(q0)
    ts, refs, qs = [], [], []
    for i in range(n):
        if sim.k % sim.ctrl_every == 0:
            t = sim.k * sim.dt
            ref[k] = q_start + v * t
            sim.submit_forward(ref)
        sim.step()
        ts.append(sim.k * sim.dt)
        refs.append(sim.reference[k])
        qs.append(sim.measured()[k])
    ts, refs, qs = np.array(ts), np.array(refs), np.array(qs)
    w = ts >= T - 1.0  # steady window (last second)
    lag_err = float(np.mean((refs[w] - qs[w]) / v))
    # time shift: q(t) = q_start + v (t - tau)  ->  tau = t - (q - q_start)/v
    tau = float(np.mean(ts[w] - (qs[w] - q_start) / v))
    return tau, lag_err, sim


def test_ramp(model_dir, urdf):
    cases = [("whole chain (defaults)", []), ("no hw follower", ["--no-hw-limits"]),
             ("no target filter", ["--target-filter-hz", "0"]),
             ("PD only (no follower, no filter)", ["--no-hw-limits", "--target-filter-hz", "0"])]
    lags = {}
    for name, extra in cases:
        tau, _, sim = ramp_lag(model_dir, urdf, extra)
        lags[name] = tau
    numbers["ramp_lag_s"] = lags
    # expectations: PD (kv + damping)/kp = 450/4000 = 0.1125 s, + half a controller period
    # (forward command held for 10 ms) = 0.005 s; filter 1/(2 pi 15) = 0.0106 s; follower
    # v/(2a) = 0.25 s at 0.5 rad/s, 1 rad/s^2.
    pd = lags["PD only (no follower, no filter)"]
    full = lags["whole chain (defaults)"]
    check("0.5 rad/s ramp followed with a lag", 0.0 < pd < full < 1.0,
          ", ".join(f"{k}: {v:.4f} s" for k, v in lags.items()) +
          " (expected: PD 0.1125 + hold 0.005, filter +0.0106, follower +0.25)")
    check("ramp lag, PD only, near (kv+damping)/kp + 5 ms", abs(pd - 0.1175) < 0.01, f"{pd:.4f} s")
    check("ramp lag, whole chain, near 0.378 s", abs(full - 0.378) < 0.03, f"{full:.4f} s")


def test_follower():
    dt = 0.002
    worst = {}
    ok = True
    details = []
    for vmax, amax, d in [(4.712, 1.0, 2.0), (4.712, 1.0, 1e-3), (4.712, 20.0, 3.0), (4.712, 1.0, -0.5)]:
        f = J.HwFollower(1, vmax, amax, 0.01, dt)
        f.reset(np.zeros(1))
        tgt = np.array([d])
        ps, vs = [], []
        for _ in range(int(6.0 / dt)):
            f.step(tgt)
            ps.append(f.p[0])
            vs.append(f.v[0])
        ps, vs = np.array(ps), np.array(vs)
        acc = np.abs(np.diff(np.concatenate([[0.0], vs]))) / dt
        over = float(max(0.0, np.max(np.sign(d) * (ps - d))))
        arrive = float((np.argmax(np.abs(ps - d) < 1e-6) + 1) * dt) if np.any(np.abs(ps - d) < 1e-6) else math.inf
        # time-optimal rest-to-rest time under (vmax, amax)
        D = abs(d)
        t_opt = 2 * math.sqrt(D / amax) if D < vmax ** 2 / amax else D / vmax + vmax / amax
        good = np.max(np.abs(vs)) <= vmax * (1 + 1e-12) and np.max(acc) <= amax * (1 + 1e-9) and over <= 1e-6 \
            and arrive < t_opt + 0.1
        ok &= bool(good)
        details.append(f"step {d:+g} (a {amax:g}): max|v| {np.max(np.abs(vs)):.4f}, max|a| {np.max(acc):.4f}, "
                       f"overshoot {over:.1e}, arrives {arrive:.3f} s (time-optimal {t_opt:.3f} s)")
        worst[f"step_{d:g}_a{amax:g}"] = {"max_v": float(np.max(np.abs(vs))), "max_a": float(np.max(acc)),
                                          "overshoot": over, "arrival_s": arrive, "time_optimal_s": t_opt}
    # random references at 100 Hz
    rng = np.random.default_rng(1)
    f = J.HwFollower(14, 4.712, 1.0, 0.01, dt)
    f.reset(np.zeros(14))
    tgt = np.zeros(14)
    vmax_seen, amax_seen = 0.0, 0.0
    prev = f.v.copy()
    for i in range(int(20.0 / dt)):
        if i % 5 == 0:
            tgt = tgt + rng.normal(0, 0.05, 14)
            if i % 500 == 0:
                tgt = rng.uniform(-2, 2, 14)
        f.step(tgt)
        vmax_seen = max(vmax_seen, float(np.max(np.abs(f.v))))
        amax_seen = max(amax_seen, float(np.max(np.abs(f.v - prev)) / dt))
        prev = f.v.copy()
    good = vmax_seen <= 4.712 * (1 + 1e-12) and amax_seen <= 1.0 * (1 + 1e-9)
    ok &= good
    details.append(f"random 100 Hz references, 14 joints, 20 s: max|v| {vmax_seen:.4f} <= 4.712, "
                   f"max|a| {amax_seen:.6f} <= 1.0")
    worst["random"] = {"max_v": vmax_seen, "max_a": amax_seen}
    numbers["hw_follower"] = worst
    check("hw follower respects vmax/amax, no overshoot, near time-optimal", ok, "; ".join(details))

    flt = J.TargetFilter(1, 15.0, dt)
    flt.reset(np.zeros(1))
    tau = 1.0 / (2 * math.pi * 15.0)
    y = None
    for i in range(int(round(tau / dt))):
        y = flt.step(np.ones(1))[0]
    t_done = round(tau / dt) * dt
    expect = 1 - math.exp(-t_done / tau)
    check("target filter: first-order step response", abs(y - expect) < 1e-9,
          f"{y:.4f} after {t_done * 1e3:.1f} ms (1 - exp(-t/tau) = {expect:.4f}, tau {tau * 1e3:.2f} ms)")


def test_jtc():
    t0 = 1_700_000_000 * NS
    ms = lambda s: int(round(s * NS))
    joints = ["a", "b"]

    def ctl(**kw):
        c = J.JointTrajectoryController(joints, **kw)
        c.activate(np.array([0.1, -0.2]))
        c.update(t0, np.array([0.1, -0.2]))
        return c

    # linear: positions only, from the measured state (0.1) to 0.5 in 1 s
    c = ctl()
    assert c.submit(J.make_msg(["a", "b"], [{"positions": [0.5, -0.2], "t": 1.0}]), t0) is None
    c.update(t0 + ms(0.01), np.array([0.1, -0.2]))  # first sample: starts now
    got = c.update(t0 + ms(0.26), np.array([0.1, -0.2]))[0]
    exp = 0.1 + 0.25 * (0.5 - 0.1)
    check("JTC linear sample", abs(got - exp) < 1e-12, f"{got:.12f} vs hand {exp:.12f}")

    # cubic: velocities present -> Hermite from (0.1, v 0) to (0.5, 0) over 1 s, s = 0.25
    c = ctl()
    c.submit(J.make_msg(["a", "b"], [{"positions": [0.5, -0.2], "velocities": [0.0, 0.0], "t": 1.0}]), t0)
    c.update(t0 + ms(0.01), np.array([0.1, -0.2]))
    got = c.update(t0 + ms(0.26), np.array([0.1, -0.2]))[0]
    s = 0.25
    exp = (2 * s ** 3 - 3 * s ** 2 + 1) * 0.1 + (-2 * s ** 3 + 3 * s ** 2) * 0.5
    check("JTC cubic sample (first segment, zero start velocity)", abs(got - exp) < 1e-12, f"{got:.12f} vs hand {exp:.12f}")

    # cubic between two points with velocities: (0.5, 0.2) at 1 s -> (1.0, 0) at 2 s, t = 1.5
    c = ctl()
    c.submit(J.make_msg(["a", "b"], [{"positions": [0.5, 0], "velocities": [0.2, 0], "t": 1.0},
                                     {"positions": [1.0, 0], "velocities": [0.0, 0], "t": 2.0}]), t0)
    c.update(t0, np.array([0.1, -0.2]))
    got = c.update(t0 + ms(1.5), np.array([0.1, -0.2]))[0]
    s, T = 0.5, 1.0
    exp = (2 * s ** 3 - 3 * s ** 2 + 1) * 0.5 + (s ** 3 - 2 * s ** 2 + s) * T * 0.2 + (-2 * s ** 3 + 3 * s ** 2) * 1.0
    check("JTC cubic sample (between points)", abs(got - exp) < 1e-12, f"{got:.12f} vs hand {exp:.12f}")

    # quintic: velocities + accelerations, 0 -> 1 in 1 s at rest = minimum jerk
    c = J.JointTrajectoryController(joints)
    c.activate(np.zeros(2))
    c.update(t0, np.zeros(2))
    c.submit(J.make_msg(["a", "b"], [{"positions": [1.0, 0], "velocities": [0, 0], "accelerations": [0, 0], "t": 1.0}]), t0)
    c.update(t0, np.zeros(2))
    got = c.update(t0 + ms(0.25), np.zeros(2))[0]
    s = 0.25
    exp = 10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5
    check("JTC quintic sample (minimum jerk)", abs(got - exp) < 1e-12, f"{got:.12f} vs hand {exp:.12f}")
    got = c.update(t0 + ms(3.0), np.zeros(2))[0]
    check("JTC holds the last point after the end", got == 1.0, f"{got}")

    # start state: closed loop (measured) vs open loop (last reference)
    res = {}
    for ol in (False, True):
        c = J.JointTrajectoryController(joints, open_loop_control=ol)
        c.activate(np.zeros(2))
        c.update(t0, np.zeros(2))
        c.submit(J.make_msg(["a", "b"], [{"positions": [1.0, 0], "t": 1.0}]), t0)
        c.update(t0, np.zeros(2))
        c.update(t0 + ms(0.5), np.zeros(2))  # reference 0.5
        c.submit(J.make_msg(["a", "b"], [{"positions": [2.0, 0], "t": 1.0}]), t0 + ms(0.5))
        c.update(t0 + ms(0.51), np.array([0.3, 0.0]))  # measured 0.3 (lagging): first sample
        res[ol] = c.update(t0 + ms(1.01), np.array([0.3, 0.0]))[0]
    check("JTC closed loop: new trajectory starts from the measured position", abs(res[False] - (0.3 + 0.5 * 1.7)) < 1e-12,
          f"{res[False]:.6f} (0.3 + 0.5 * (2 - 0.3))")
    check("JTC open loop: new trajectory starts from the last reference", abs(res[True] - (0.5 + 0.5 * 1.5)) < 1e-12,
          f"{res[True]:.6f} (0.5 + 0.5 * (2 - 0.5))")

    # future stamp: interpolates from the first sample to stamp + time_from_start
    c = ctl()
    c.submit(J.make_msg(["a", "b"], [{"positions": [1.1, -0.2], "t": 1.0}], stamp_ns=t0 + ms(1.0)), t0)
    c.update(t0, np.array([0.1, -0.2]))
    got = c.update(t0 + ms(1.0), np.array([0.1, -0.2]))[0]
    check("JTC future header.stamp: starts at stamp (linear from now to stamp + 1 s)", abs(got - 0.6) < 1e-12, f"{got}")

    # partial goal: missing joint keeps its command
    c = ctl()
    c.submit(J.make_msg(["b"], [{"positions": [0.8], "t": 1.0}]), t0)
    c.update(t0, np.array([0.1, -0.2]))
    got = c.update(t0 + ms(2.0), np.array([0.1, -0.2]))
    check("JTC partial goal: other joints hold their command", abs(got[0] - 0.1) < 1e-12 and abs(got[1] - 0.8) < 1e-12,
          f"{got.tolist()}")
    c = J.JointTrajectoryController(joints, allow_partial_joints_goal=False)
    c.activate(np.zeros(2))
    why = c.submit(J.make_msg(["b"], [{"positions": [0.8], "t": 1.0}]), t0)
    check("JTC with allow_partial_joints_goal false rejects a subset", why is not None, str(why))

    # rejections
    c = ctl()
    bad = {
        "unknown joint": J.make_msg(["a", "zz"], [{"positions": [0, 0], "t": 1.0}]),
        "effort": J.make_msg(["a", "b"], [{"positions": [0, 0], "effort": [1, 1], "t": 1.0}]),
        "not increasing": J.make_msg(["a", "b"], [{"positions": [0, 0], "t": 1.0}, {"positions": [0, 0], "t": 1.0}]),
        "ends in the past": J.make_msg(["a", "b"], [{"positions": [0, 0], "t": 1.0}], stamp_ns=t0 - ms(5.0)),
        "size mismatch": J.make_msg(["a", "b"], [{"positions": [0], "t": 1.0}]),
        "empty points": J.TrajectoryMsg(["a", "b"], [], 0),
        "NaN": J.make_msg(["a", "b"], [{"positions": [float("nan"), 0], "t": 1.0}]),
    }
    reasons = {k: c.submit(m, t0) for k, m in bad.items()}
    check("JTC rejects invalid trajectories", all(v is not None for v in reasons.values()),
          "; ".join(f"{k} -> {v}" for k, v in reasons.items()))
    # the latest valid message before an update wins
    c = ctl()
    c.submit(J.make_msg(["a", "b"], [{"positions": [5.0, 0], "t": 0.5}]), t0)
    c.submit(J.make_msg(["a", "b"], [{"positions": [0.7, 0], "t": 0.5}]), t0)
    c.update(t0, np.array([0.1, -0.2]))
    got = c.update(t0 + ms(1.0), np.array([0.1, -0.2]))[0]
    check("JTC: a newer message replaces an unused one", got == 0.7 and c.superseded == 1, f"{got}, superseded {c.superseded}")


def test_pipeline(model_dir, urdf):
    # trajectory: left_arm_3 by -0.2 rad over 1 s (stamp 0), gravity on, defaults
    sim = make_sim(model_dir, urdf, [], BENT)
    k = sim.joints.index("left_arm_3")
    start = sim.measured()[k]
    msg = J.make_msg(["left_arm_3"], [{"positions": [BENT[k] - 0.2], "t": 1.0}])
    why = sim.submit_trajectory(msg)
    sim.run(int(4.0 / sim.dt))
    moved = sim.measured()[k] - start
    rep = sim.report()
    te = rep["tracking_error"]["left_arm_3"]
    numbers["trajectory_left_arm_3"] = {"moved_rad": float(moved), "tracking_error": te,
                                        "violations": rep["violation_count"]}
    check("trajectory through the simulated robot (left_arm_3 -0.2 rad in 1 s)",
          why is None and abs(moved + 0.2) < 0.01 and rep["violation_count"] == 0,
          f"moved {moved:+.4f} rad after 4 s, tracking |ref-q| p50 {te['p50']:.4f} p99 {te['p99']:.4f} "
          f"max {te['max']:.4f} rad, violations {rep['violation_count']}")

    # reset
    q = list(BENT)
    q[k] = -0.5
    sim.reset(q)
    ok = np.allclose(sim.measured(), q) and np.allclose(sim.reference, q) and sim.resets == 1
    sim.run(50)
    check("reset teleports and holds", ok and abs(sim.measured()[k] + 0.5) < 2e-3, f"q {sim.measured()[k]:+.5f} after 0.1 s")

    # freeze: the joint stops following
    sim = make_sim(model_dir, urdf, [], BENT)
    sim.start_freeze("left_arm_3", 0.0)
    sim.submit_trajectory(J.make_msg(["left_arm_3"], [{"positions": [BENT[k] - 0.3], "t": 0.5}]))
    sim.run(int(2.0 / sim.dt))
    rep = sim.report()
    check("frozen joint does not follow", abs(sim.measured()[k] - BENT[k]) < 1e-12 and
          rep["tracking_error"]["left_arm_3"]["max"] > 0.29, f"q {sim.measured()[k]:+.6f}, max |ref-q| "
          f"{rep['tracking_error']['left_arm_3']['max']:.4f}, fault_started_s {rep['fault_started_s']}")

    # collision hold: commands ignored by the hardware
    sim = make_sim(model_dir, urdf, ["--gravity-compensation"], BENT)
    sim.run(100)
    sim.start_hold(0.2)
    before = sim.measured()
    sim.submit_trajectory(J.make_msg(["left_arm_3"], [{"positions": [BENT[k] - 0.3], "t": 0.5}]))
    sim.run(int(2.0 / sim.dt))
    drift = float(np.max(np.abs(sim.measured() - before)))
    check("collision hold: the hardware ignores commands", drift < 1e-3 and abs(sim.reference[k] - (BENT[k] - 0.3)) < 1e-9,
          f"max drift {drift:.2e} rad while the reference moved 0.3 rad")

    # force limits: a torque-saturating step is counted
    sim = make_sim(model_dir, urdf, ["--no-hw-limits", "--target-filter-hz", "0"], BENT)
    sim.submit_forward(np.array(BENT) + np.array([0.5] + [0.0] * 13))
    sim.run(500)
    tl = sim.report()["torque_limit_time_s"]["left_arm_0"]
    check("torque limit time is counted on a step without the streaming layers", tl > 0.0,
          f"left_arm_0 at |force| >= 0.999 * 70 N m for {tl:.3f} s")


def test_cpu(model_dir, urdf):
    sim = make_sim(model_dir, urdf, [], BENT)
    sim.run(500)
    n = 1000
    t = time.perf_counter()
    c = time.process_time()
    for _ in range(n):
        sim.run(5)
        sim.joint_state_arrays()
    wall = (time.perf_counter() - t) / n * 1e3
    cpu = (time.process_time() - c) / n * 1e3
    numbers["iteration_ms"] = {"wall": wall, "cpu": cpu}
    check("one 100 Hz iteration (5 physics steps + joint-state arrays) is light", wall < 5.0,
          f"{wall:.3f} ms wall, {cpu:.3f} ms CPU per iteration (= {cpu * 10:.1f} % of one core at 100 Hz)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model-dir", default=SDK)
    ap.add_argument("--urdf", default=URDF)
    ap.add_argument("--json", metavar="OUT")
    args = ap.parse_args(argv)
    t = time.monotonic()
    test_compile(args.model_dir)
    test_sag(args.model_dir, args.urdf)
    test_ramp(args.model_dir, args.urdf)
    test_follower()
    test_jtc()
    test_pipeline(args.model_dir, args.urdf)
    test_cpu(args.model_dir, args.urdf)
    npass = sum(1 for _, ok in results if ok)
    nfail = len(results) - npass
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"results": results, "numbers": numbers}, f, indent=2)
    print(f"selftest: ran in {time.monotonic() - t:.1f} s")
    print(f"selftest: {npass} passed, {nfail} failed")
    return 0 if nfail == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
