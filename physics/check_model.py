#!/usr/bin/env python3
"""Check the MJCF that rby1_mujoco.py builds against the URDF of the same robot version.

    python3 physics/check_model.py --version 1.0 --urdf model.urdf --model-dir SDK/mujoco [--json OUT]
        [--postures 64] [--seed 0]

1. Forward kinematics: for --postures random postures of the 14 arm joints (uniform in the
   intersection of the URDF limits and the MJCF joint ranges; torso/head at 0), the positions
   of link_right_arm_0..6, link_left_arm_0..6 and link_torso_5 relative to link_torso_5 from
   MuJoCo (mj_kinematics) against an independent numpy URDF forward kinematics (joint origin
   xyz/rpy, axis, revolute/continuous/prismatic/fixed; product of homogeneous transforms).
   The maximum error must be <= 1e-6 m. The orientation error of those frames is reported too.
2. Lists, per joint, the URDF limits (lower, upper, velocity, effort) against the MJCF joint
   range and the actuator ctrlrange/forcerange, and the joint axes that differ (in the
   joint's own frame and in the world at the zero posture).

Exit 0 if the FK agrees, 1 otherwise (2 on a usage error).
"""

import argparse
import json
import math
import os
import sys
import xml.etree.ElementTree as ET

import numpy as np
import mujoco

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from rby1_model import DEFAULT_JOINTS, VERSIONS, build_mjcf  # noqa: E402

FK_TOL = 1e-6  # m
BODIES = ["link_torso_5"] + [f"link_right_arm_{i}" for i in range(7)] + [f"link_left_arm_{i}" for i in range(7)]
REFERENCE = "link_torso_5"


# ---------------------------------------------------------------------------------------
# Independent URDF forward kinematics (numpy only)
# ---------------------------------------------------------------------------------------

def rpy_matrix(r: float, p: float, y: float) -> np.ndarray:
    """URDF rpy: fixed-axis roll (x), pitch (y), yaw (z): R = Rz(y) Ry(p) Rx(r)."""
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_angle(axis: np.ndarray, q: float) -> np.ndarray:
    """Rodrigues: rotation by q about the unit vector axis."""
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(q) * kx + (1 - math.cos(q)) * (kx @ kx)


class UrdfFK:
    def __init__(self, path: str):
        root = ET.parse(path).getroot()
        self.joints = {}
        self.parent_joint = {}  # child link -> joint name
        for j in root.findall("joint"):
            o = j.find("origin")
            xyz = np.array([float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split()])
            rpy = [float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split()]
            a = j.find("axis")
            axis = np.array([float(v) for v in a.get("xyz").split()]) if a is not None else np.array([1.0, 0, 0])
            lim = j.find("limit")
            rec = {"name": j.get("name"), "type": j.get("type"), "parent": j.find("parent").get("link"),
                   "child": j.find("child").get("link"), "xyz": xyz, "R0": rpy_matrix(*rpy), "axis": axis,
                   "lower": None, "upper": None, "velocity": None, "effort": None}
            if lim is not None:
                for key in ("lower", "upper", "velocity", "effort"):
                    if lim.get(key) is not None:
                        rec[key] = float(lim.get(key))
            self.joints[rec["name"]] = rec
            self.parent_joint[rec["child"]] = rec["name"]

    def link_transform(self, link: str, q: dict) -> np.ndarray:
        """4x4 transform of `link` in the root link's frame at joint values q (name -> value)."""
        chain = []
        cur = link
        while cur in self.parent_joint:
            jn = self.parent_joint[cur]
            chain.append(self.joints[jn])
            cur = self.joints[jn]["parent"]
        T = np.eye(4)
        for j in reversed(chain):
            A = np.eye(4)
            A[:3, :3] = j["R0"]
            A[:3, 3] = j["xyz"]
            M = np.eye(4)
            v = q.get(j["name"], 0.0)
            if j["type"] in ("revolute", "continuous"):
                M[:3, :3] = axis_angle(j["axis"], v)
            elif j["type"] == "prismatic":
                M[:3, 3] = j["axis"] / np.linalg.norm(j["axis"]) * v
            T = T @ A @ M
        return T


# ---------------------------------------------------------------------------------------


def rot_angle(R: np.ndarray) -> float:
    return math.acos(max(-1.0, min(1.0, (np.trace(R) - 1.0) / 2.0)))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--version", choices=VERSIONS, default="1.0")
    ap.add_argument("--urdf", required=True)
    ap.add_argument("--model-dir", required=True)
    ap.add_argument("--postures", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", metavar="OUT")
    args = ap.parse_args(argv)
    if args.postures < 1:
        print("check_model: --postures must be >= 1", file=sys.stderr)
        return 2

    info = build_mjcf(args.model_dir, args.version, args.urdf, force_limits=True, gravcomp=False)
    m = mujoco.MjModel.from_xml_string(info.xml)
    d = mujoco.MjData(m)
    fk = UrdfFK(args.urdf)

    jname = lambda j: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j)
    mj_joints = {jname(j): j for j in range(m.njnt)}
    act_of = {}
    for a in range(m.nu):
        act_of[jname(m.actuator_trnid[a, 0])] = a

    # ---- limits and axes -------------------------------------------------------------
    mujoco.mj_kinematics(m, d)  # zero posture
    T5 = fk.link_transform(REFERENCE, {})
    limits = []
    axis_diffs = []
    for name, j in fk.joints.items():
        if j["type"] == "fixed":
            continue
        row = {"joint": name, "urdf_type": j["type"], "urdf_lower": j["lower"], "urdf_upper": j["upper"],
               "urdf_velocity": j["velocity"], "urdf_effort": j["effort"]}
        if name in mj_joints:
            mj = mj_joints[name]
            row["mjcf_limited"] = bool(m.jnt_limited[mj])
            row["mjcf_range"] = [float(x) for x in m.jnt_range[mj]] if m.jnt_limited[mj] else None
            if name in act_of:
                a = act_of[name]
                row["actuator"] = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a)
                row["ctrlrange"] = [float(x) for x in m.actuator_ctrlrange[a]] if m.actuator_ctrllimited[a] else None
                row["forcerange"] = [float(x) for x in m.actuator_forcerange[a]] if m.actuator_forcelimited[a] else None
            if j["lower"] is not None and row["mjcf_range"] is not None:
                row["range_differs"] = bool(abs(row["mjcf_range"][0] - j["lower"]) > 1e-4
                                            or abs(row["mjcf_range"][1] - j["upper"]) > 1e-4)
            if row.get("ctrlrange") is not None and j["lower"] is not None:
                row["ctrlrange_differs"] = bool(abs(row["ctrlrange"][0] - j["lower"]) > 1e-4
                                                or abs(row["ctrlrange"][1] - j["upper"]) > 1e-4)
            # axes: own frame and world at zero posture
            ua = j["axis"] / np.linalg.norm(j["axis"])
            ma = np.array(m.jnt_axis[mj], dtype=float)
            ma = ma / np.linalg.norm(ma)
            child_T = fk.link_transform(j["child"], {})
            uw = child_T[:3, :3] @ ua
            mw = np.array(d.xaxis[mj])
            local = float(np.linalg.norm(ua - ma))
            world = float(np.linalg.norm(uw - mw))
            if local > 1e-6 or world > 1e-6:
                axis_diffs.append({"joint": name, "urdf_axis": ua.tolist(), "mjcf_axis": ma.tolist(),
                                   "urdf_world_axis": uw.tolist(), "mjcf_world_axis": mw.tolist(),
                                   "local_diff": local, "world_diff": world})
        else:
            row["mjcf"] = "missing"
        limits.append(row)
    missing_in_urdf = [n for n in mj_joints if n not in fk.joints]

    # ---- masses of same-named links / bodies (information) ----------------------------
    mass_diffs = []
    for link in ET.parse(args.urdf).getroot().findall("link"):
        b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, link.get("name"))
        mel = link.find("inertial/mass")
        if b < 0 or mel is None:
            continue
        um, mm = float(mel.get("value")), float(m.body_mass[b])
        if abs(um - mm) > 1e-4 * max(1.0, um):
            mass_diffs.append({"link": link.get("name"), "urdf_mass": um, "mjcf_mass": mm})

    # ---- forward kinematics ----------------------------------------------------------
    rng = np.random.default_rng(args.seed)
    arm = list(DEFAULT_JOINTS)
    lo, hi = [], []
    for n in arm:
        j = fk.joints[n]
        l, h = j["lower"], j["upper"]
        mj = mj_joints[n]
        if m.jnt_limited[mj]:
            l, h = max(l, m.jnt_range[mj][0]), min(h, m.jnt_range[mj][1])
        lo.append(l)
        hi.append(h)
    lo, hi = np.array(lo), np.array(hi)
    bids = {b: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in BODIES}
    for b, i in bids.items():
        if i < 0:
            print(f"check_model: body {b} not in the MJCF", file=sys.stderr)
            return 1
    worst = {b: 0.0 for b in BODIES}
    worst_rot = {b: 0.0 for b in BODIES}
    worst_posture = None
    max_err = 0.0
    for k in range(args.postures):
        qv = lo + (hi - lo) * rng.random(len(arm)) if k > 0 else np.zeros(len(arm))
        d.qpos[:] = 0.0
        for n, v in zip(arm, qv):
            d.qpos[m.jnt_qposadr[mj_joints[n]]] = v
        mujoco.mj_kinematics(m, d)
        qd = dict(zip(arm, qv))
        T5 = fk.link_transform(REFERENCE, qd)
        R5m = d.xmat[bids[REFERENCE]].reshape(3, 3)
        p5m = d.xpos[bids[REFERENCE]]
        for b in BODIES:
            Tb = fk.link_transform(b, qd)
            pu = np.linalg.solve(T5, Tb)
            pm = R5m.T @ (d.xpos[bids[b]] - p5m)
            Rm = R5m.T @ d.xmat[bids[b]].reshape(3, 3)
            e = float(np.linalg.norm(pu[:3, 3] - pm))
            er = rot_angle(pu[:3, :3].T @ Rm)
            worst[b] = max(worst[b], e)
            worst_rot[b] = max(worst_rot[b], er)
            if e > max_err:
                max_err = e
                worst_posture = {"posture": k, "body": b, "q": qd}
    # also the torso frame itself relative to the base at the zero posture (absolute check)
    ok = max_err <= FK_TOL

    rep = {"version": args.version, "urdf": os.path.abspath(args.urdf), "model_dir": os.path.abspath(args.model_dir),
           "postures": args.postures, "seed": args.seed, "fk_tolerance_m": FK_TOL, "fk_ok": ok,
           "fk_max_error_m": max_err, "fk_max_error_by_body_m": worst,
           "fk_max_rotation_error_rad_by_body": worst_rot, "worst": worst_posture,
           "limits": limits, "axis_differences": axis_diffs, "mjcf_joints_not_in_urdf": missing_in_urdf,
           "mass_differences": mass_diffs,
           "skipped_duplicate_includes": info.skipped_includes}

    print(f"check_model: version {args.version}, URDF {os.path.basename(args.urdf)}, {args.postures} postures: "
          f"FK max position error {max_err:.3e} m (tolerance {FK_TOL:g}) -> {'OK' if ok else 'MISMATCH'}; "
          f"max rotation error {max(worst_rot.values()):.3e} rad")
    if not ok:
        for b in BODIES:
            if worst[b] > FK_TOL:
                print(f"  {b}: {worst[b]:.6f} m, {worst_rot[b]:.6f} rad")
    print("  joint          URDF [lower, upper] vel effort  | MJCF range          | ctrlrange           | forcerange")
    for r in limits:
        if r.get("mjcf") == "missing":
            print(f"  {r['joint']:<14} missing in the MJCF")
            continue
        fmt = lambda x: "-" if x is None else f"[{x[0]:+.4f}, {x[1]:+.4f}]"
        ul = "-" if r["urdf_lower"] is None else f"[{r['urdf_lower']:+.4f}, {r['urdf_upper']:+.4f}]"
        flag = []
        if r.get("range_differs"):
            flag.append("range!=URDF")
        if r.get("ctrlrange_differs"):
            flag.append("ctrl!=URDF")
        print(f"  {r['joint']:<14} {ul:<20} {r['urdf_velocity'] if r['urdf_velocity'] is not None else '-':<8} "
              f"{r['urdf_effort'] if r['urdf_effort'] is not None else '-':<6} | {fmt(r['mjcf_range']):<19} | "
              f"{fmt(r.get('ctrlrange')):<19} | {fmt(r.get('forcerange'))} {' '.join(flag)}")
    if axis_diffs:
        print("  joint axes that differ:")
        for a in axis_diffs:
            print(f"    {a['joint']}: URDF {np.round(a['urdf_axis'], 6).tolist()} vs MJCF "
                  f"{np.round(a['mjcf_axis'], 6).tolist()} (world: {np.round(a['urdf_world_axis'], 6).tolist()} vs "
                  f"{np.round(a['mjcf_world_axis'], 6).tolist()})")
    else:
        print("  joint axes: all agree")
    if missing_in_urdf:
        print(f"  MJCF joints not in the URDF: {missing_in_urdf}")
    if mass_diffs:
        print("  link masses that differ (URDF vs MJCF, kg): " + ", ".join(
            f"{x['link']} {x['urdf_mass']:.4f} vs {x['mjcf_mass']:.4f}" for x in mass_diffs))
    else:
        print("  link masses (same-named links/bodies): all agree")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rep, f, indent=2)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
