#!/usr/bin/env python3
"""Independent numpy check of the expected morphological-symmetry tables.

Usage:
    python3 tests/data/morpho/check_expected.py [--robots DIR] [--samples 64] [FILE.toml ...]

DIR defaults to example-robot-data's `robots` directory found through the
installed Python package (cmeel prefix) or $EXAMPLE_ROBOT_DATA_ROBOTS.
Without FILE arguments every tests/data/morpho/expected/*.toml is checked.

Nothing here shares code with the Rust crate: a minimal URDF tree forward
kinematics (xml.etree; joint origin xyz/rpy, axis; revolute, continuous,
prismatic; fixed, floating and planar joints held at 0; a revolute, continuous
or prismatic <mimic> joint FOLLOWS its leader, q_mimic = multiplier * q_leader
+ offset (multiplier default 1, offset default 0), with q_leader = 0 when the
leader is not a considered joint; mimic joints are not in q) and, for each
reflection listed in a table,

  1. table sanity: every considered joint (revolute/continuous/prismatic
     without <mimic>, URDF order) exactly once as a first entry, the map a
     bijection and an involution, signs +-1, sign(j) == sign(image(j));
  2. the axis rule at q = 0 (root frame): revolute: the mirrored axis line
     S(p_j + t z_j) passes within tol of the image's axis line and the sign is
     +1 iff -S z_j == z_img (axial vector); prismatic: +1 iff S z_j == z_img
     (polar vector; the line is not checked, the residual below is). z_img is
     the effective axis of the joint carrying the partner (see 3) of j's child
     link: the image joint's axis, or multiplier * axis of a mimic joint that
     follows the image joint (e.g. Baxter: the right driven finger pairs with
     the left gripper's mimic finger, multiplier -1);
  3. forward kinematics on `--samples` random configurations inside the joint
     limits (continuous: +-pi): with (rho q)[img(j)] = s_j q[j],
     pos  = max |p_L'(rho q) - S p_L(q)|            (also shown / size,
                                                      size = max_L |p_L(0)|)
     rot  = max |R_L'(rho q) - S R_L(q) E_L|_max,    E_L = R_L(0)^T S R_L'(0)
     over all links L that have a partner L'. L's driver is the considered
     joint that drives its nearest moving ancestor joint (a considered joint
     drives itself, a following mimic joint is driven by its leader; None =
     root group). The partner of L is searched among the links whose driver is
     the image of L's driver (root group -> root group), as the one whose
     q = 0 position is nearest to S p_L(0); so a driven finger may pair with
     the other gripper's mimic finger. Structural links (root, children of
     moving joints, links with a moving joint below) always take that nearest
     candidate; other links (fixed sensors, frames) only within tol, else they
     are listed as unpaired (not mirror-symmetric, not counted). E_L absorbs
     only the constant q = 0 frame difference, so a wrong sign on a joint whose
     child lies on its own axis (no position change) still shows in rot;
  4. joint limits: s = +1 needs [lo', hi'] = [lo, hi], s = -1 needs
     [lo', hi'] = [-hi, -lo]; the mismatching pairs (each unordered pair once)
     are compared with the table's `limit_mismatches` (informational, a
     difference is printed as a note and does not fail).
tol = the table's `tolerance_m` (metres) if present, else 1e-6 * size;
rot tolerance = `tolerance_rot` if present, else 1e-6.
Exit status 1 if any table fails 1-3 (pos > tol, rot > rot tolerance, a sanity
or axis error), or its group / order / normals are inconsistent.
"""
import argparse
import glob
import math
import os
import sys
import tomllib
import xml.etree.ElementTree as ET

import numpy as np

MOVING = ("revolute", "continuous", "prismatic")
POS_TOL = 1e-6  # relative to robot size, unless the table sets tolerance_m (metres)
ROT_TOL = 1e-6  # rotation-matrix entries, unless the table sets tolerance_rot
AXIS_TOL = 1e-6  # unit axis directions


def default_robots_dir():
    env = os.environ.get("EXAMPLE_ROBOT_DATA_ROBOTS")
    if env:
        return env
    for base in sys.path:
        cand = os.path.join(base, "cmeel.prefix", "share", "example-robot-data", "robots")
        if os.path.isdir(cand):
            return cand
    return "/root/.pyenv/versions/3.11.7/lib/python3.11/site-packages/cmeel.prefix/share/example-robot-data/robots"


def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def axis_angle(a, t):
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * (k @ k)


def floats(s, default):
    return np.array([float(v) for v in s.split()]) if s is not None else np.array(default, float)


def mimic_of(j):
    """URDF <mimic joint=.. multiplier=.. offset=..> -> dict(leader, mult, off), or None."""
    m = j.find("mimic")
    if m is None:
        return None
    return dict(leader=m.get("joint"), mult=float(m.get("multiplier", "1")), off=float(m.get("offset", "0")))


class Urdf:
    def __init__(self, path):
        root = ET.parse(path).getroot()
        self.links = [l.get("name") for l in root.findall("link")]
        self.joints = []
        for j in root.findall("joint"):
            o = j.find("origin")
            a = j.find("axis")
            lim = j.find("limit")
            jt = j.get("type")
            lo = hi = None
            if lim is not None and jt in ("revolute", "prismatic"):
                lo = float(lim.get("lower", "0"))
                hi = float(lim.get("upper", "0"))
            self.joints.append(dict(
                name=j.get("name"), type=jt,
                parent=j.find("parent").get("link"), child=j.find("child").get("link"),
                xyz=floats(o.get("xyz") if o is not None else None, [0, 0, 0]),
                rpy=floats(o.get("rpy") if o is not None else None, [0, 0, 0]),
                axis=floats(a.get("xyz") if a is not None else None, [1, 0, 0]),
                mimic=mimic_of(j), lo=lo, hi=hi))
        children = {j["child"] for j in self.joints}
        roots = [l for l in self.links if l not in children]
        assert len(roots) == 1, roots
        self.root = roots[0]
        self.by_child = {j["child"]: j for j in self.joints}
        self.kids = {}
        for j in self.joints:
            self.kids.setdefault(j["parent"], []).append(j)
        self.considered = [j["name"] for j in self.joints if j["type"] in MOVING and j["mimic"] is None]
        self.jidx = {n: i for i, n in enumerate(self.considered)}
        self.jd = {j["name"]: j for j in self.joints}
        # moving joint -> its driver (the considered joint whose q moves it):
        # considered joints drive themselves, a mimic joint whose leader is
        # considered is driven by the leader; a mimic of a held leader sits at
        # its constant offset (not moving).
        self.driver = {n: n for n in self.considered}
        for j in self.joints:
            m = j["mimic"]
            if j["type"] in MOVING and m is not None and m["leader"] in self.jidx and m["mult"] != 0:
                self.driver[j["name"]] = m["leader"]
        # body (driver of the nearest moving ancestor joint, None = root group) of every link
        self.body = {self.root: None}
        order = [self.root]
        k = 0
        while k < len(order):
            l = order[k]
            k += 1
            for j in self.kids.get(l, []):
                self.body[j["child"]] = self.driver.get(j["name"], self.body[l])
                order.append(j["child"])
        self.order = order

    def limits(self, name):
        j = self.jd[name]
        if j["type"] == "continuous" or j["lo"] is None or j["lo"] >= j["hi"]:
            return (-math.pi, math.pi) if j["type"] != "prismatic" else (-0.1, 0.1)
        return j["lo"], j["hi"]

    def value(self, j, q):
        """Joint value of joint dict j for q (over self.considered); None = not moving."""
        if j["type"] not in MOVING:
            return None
        i = self.jidx.get(j["name"])
        if i is not None:
            return q[i]
        m = j["mimic"]  # a mimic joint follows its leader; a held leader counts as 0
        li = self.jidx.get(m["leader"])
        return m["mult"] * (q[li] if li is not None else 0.0) + m["off"]

    def fk(self, q):
        """Link name -> 4x4 pose in the root frame. q: array over self.considered."""
        T = {self.root: np.eye(4)}
        for l in self.order[1:]:
            j = self.by_child[l]
            M = np.eye(4)
            M[:3, :3] = rpy_matrix(*j["rpy"])
            M[:3, 3] = j["xyz"]
            v = self.value(j, q)
            if v is not None and v != 0.0:
                J = np.eye(4)
                if j["type"] == "prismatic":
                    J[:3, 3] = j["axis"] / np.linalg.norm(j["axis"]) * v
                else:
                    J[:3, :3] = axis_angle(j["axis"], v)
                M = M @ J
            T[l] = T[j["parent"]] @ M
        return T


def check_reflection(u, refl, samples, rng, size, tol, rot_tol):
    errs, notes = [], []
    n = np.array(refl["normal"], float)
    n /= np.linalg.norm(n)
    S = np.eye(3) - 2 * np.outer(n, n)
    img, sgn = {}, {}
    for row in refl["map"]:
        a, b, s = row
        if a in img:
            errs.append(f"{a} listed twice")
        if a not in u.jidx or b not in u.jidx:
            errs.append(f"unknown joint in {row}")
            continue
        if s not in (1, -1):
            errs.append(f"bad sign in {row}")
        img[a], sgn[a] = b, s
    missing = [j for j in u.considered if j not in img]
    if missing:
        errs.append(f"joints missing from map: {missing}")
    if sorted(img.values()) != sorted(img.keys()):
        errs.append("map is not a bijection")
    for a, b in img.items():
        if img.get(b) != a:
            errs.append(f"not an involution: {a}->{b}->{img.get(b)}")
        elif sgn[b] != sgn[a]:
            errs.append(f"sign({a}) != sign({b})")
    if errs:
        return errs, notes, None, None, []
    T0 = u.fk(np.zeros(len(u.considered)))
    # 3a. pair links (before the axis rule, which uses the pairing): the partner of L is searched among the links whose driver
    # (considered joint moving L's nearest moving ancestor joint; a following
    # mimic joint counts as its leader; None = root group) is the image of L's
    # driver, nearest to S p_L(0). Structural links (the root, children of
    # moving joints, links with a moving joint below) always get their nearest
    # candidate (a miss shows up in the residual); other links (fixed sensors,
    # frames) only within tol, else they are reported as unpaired.
    pos0 = {l: T0[l][:3, 3] for l in u.links}
    groups = {}
    for l in u.links:
        groups.setdefault(u.body[l], []).append(l)
    structural = {u.root} | {u.jd[j]["child"] for j in u.driver}
    for j in u.driver:
        l = u.jd[j]["parent"]
        while l != u.root:
            structural.add(l)
            l = u.by_child[l]["parent"]
    partner, unpaired = {}, []
    for l in u.links:
        bimg = None if u.body[l] is None else img[u.body[l]]
        target = S @ pos0[l]
        best = min(groups.get(bimg, []), key=lambda m: np.linalg.norm(pos0[m] - target), default=None)
        if best is None:
            errs.append(f"link {l}: no candidate partner")
        elif l in structural or np.linalg.norm(pos0[best] - target) <= tol:
            partner[l] = best
        else:
            unpaired.append(f"{l} ({np.linalg.norm(pos0[best] - target) * 1e3:.3g} mm)")
    if unpaired:
        notes.append("unpaired links (fixed, no moving joint below; miss at q = 0): " + ", ".join(unpaired))
    # 2. axis rule at q = 0. The image axis is that of the moving joint that
    # carries the partner of a's child link (its nearest moving ancestor
    # joint): b itself, or a mimic joint following b, whose effective axis is
    # multiplier * its axis (it moves by multiplier * q_b).
    def frame(j):  # joint frame = parent pose * origin: (origin, unit axis) in the root frame
        M = np.eye(4)
        M[:3, :3] = rpy_matrix(*j["rpy"])
        M[:3, 3] = j["xyz"]
        F = T0[j["parent"]] @ M
        return F[:3, 3], F[:3, :3] @ (j["axis"] / np.linalg.norm(j["axis"]))

    def carrier(l):  # nearest moving ancestor joint of link l
        while l != u.root and u.by_child[l]["name"] not in u.driver:
            l = u.by_child[l]["parent"]
        return None if l == u.root else u.by_child[l]

    for a, b in img.items():
        ja = u.jd[a]
        jb = carrier(partner.get(ja["child"], u.root))
        if jb is None or u.driver[jb["name"]] != b:
            errs.append(f"{a}->{b}: child {ja['child']} does not pair with a link moved by {b}")
            continue
        mult = 1.0 if jb["name"] == b else jb["mimic"]["mult"]
        via = "" if jb["name"] == b else f" (via mimic {jb['name']}, multiplier {mult:g})"
        pa, za = frame(ja)
        pb, zb = frame(jb)
        if ja["type"] != jb["type"] and "prismatic" in (ja["type"], jb["type"]):
            errs.append(f"{a}->{b}{via}: prismatic vs revolute")
            continue
        if ja["type"] == "prismatic":
            want = S @ za
        else:
            want = -(S @ za)
            d = S @ pa - pb  # mirrored line through S pa must contain pb
            off = d - np.dot(d, zb) * zb
            if np.linalg.norm(off) > tol:
                errs.append(f"{a}->{b}{via}: mirrored axis line misses the image line by {np.linalg.norm(off):.3g} m")
        c = float(np.dot(want, mult * zb))
        if abs(abs(c) - 1) > AXIS_TOL:
            errs.append(f"{a}->{b}{via}: mirrored axis not parallel to the image's effective axis (cos {c:.6f})")
        elif (1 if c > 0 else -1) != sgn[a]:
            errs.append(f"{a}->{b}{via}: axis rule gives sign {1 if c > 0 else -1}, table {sgn[a]}")
    E = {l: T0[l][:3, :3].T @ S @ T0[partner[l]][:3, :3] for l in partner}
    lims = [u.limits(n) for n in u.considered]
    worst_p = worst_r = 0.0
    for _ in range(samples):
        q = np.array([rng.uniform(lo, hi) for lo, hi in lims])
        rq = np.zeros_like(q)
        for a, b in img.items():
            rq[u.jidx[b]] = sgn[a] * q[u.jidx[a]]
        T = u.fk(q)
        Tr = u.fk(rq)
        for l, m in partner.items():
            worst_p = max(worst_p, np.linalg.norm(Tr[m][:3, 3] - S @ T[l][:3, 3]) / size)
            worst_r = max(worst_r, np.abs(Tr[m][:3, :3] - S @ T[l][:3, :3] @ E[l]).max())
    if worst_p * size > tol:
        errs.append(f"position residual {worst_p * size:.3g} m > tolerance {tol:.3g} m")
    if worst_r > rot_tol:
        errs.append(f"orientation residual {worst_r:.3g} > {rot_tol:.3g}")
    # 4. limits
    mism = []
    for a, b in img.items():
        ja, jb = u.jd[a], u.jd[b]
        if ja["type"] == "continuous" and jb["type"] == "continuous":
            continue
        if ja["type"] == "continuous" or jb["type"] == "continuous":
            mism.append([a, b])
            continue
        lo, hi = ja["lo"], ja["hi"]
        want = (lo, hi) if sgn[a] == 1 else (-hi, -lo)
        if abs(want[0] - jb["lo"]) > 1e-9 or abs(want[1] - jb["hi"]) > 1e-9:
            mism.append([a, b])
    return errs, notes, worst_p, worst_r, mism


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--robots", default=default_robots_dir())
    ap.add_argument("--samples", type=int, default=64)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    here = os.path.dirname(os.path.abspath(__file__))
    files = args.files or sorted(glob.glob(os.path.join(here, "expected", "*.toml")))
    failed = False
    print(f"{'robot':<10} {'group':<5} {'joints':>6} {'reflection':<10} {'pos (rel)':>10} {'pos (m)':>10} {'rot':>10} {'tol (m)':>9} {'lim. mism.':>10} result")
    for f in files:
        with open(f, "rb") as fh:
            t = tomllib.load(fh)
        u = Urdf(os.path.join(args.robots, t["urdf"]))
        size = max(np.linalg.norm(T[:3, 3]) for T in u.fk(np.zeros(len(u.considered))).values())
        refls = t["reflection"]
        if len(refls) != {"C2": 1, "K4": 2}.get(t["group"]) or t["order"] != 2 * len(refls):
            print(f"{t['robot']}: group/order/reflection count inconsistent")
            failed = True
        if len(refls) == 2:
            n1, n2 = (np.array(r["normal"], float) for r in refls)
            if abs(np.dot(n1, n2)) > 1e-9:
                print(f"{t['robot']}: K4 normals not perpendicular")
                failed = True
        rng = np.random.default_rng(args.seed)
        for r in refls:
            tol = t.get("tolerance_m", POS_TOL * size)
            errs, notes, wp, wr, mism = check_reflection(u, r, args.samples, rng, size, tol, t.get("tolerance_rot", ROT_TOL))
            pairs = lambda l: sorted({tuple(sorted(p, key=u.considered.index)) for p in l})
            if pairs(mism) != pairs(r.get("limit_mismatches", [])):
                notes.append(f"limit_mismatches differ from the table: computed {pairs(mism)}")
            ok = not errs
            failed |= not ok
            wps = f"{wp:.2e}" if wp is not None else "-"
            wrs = f"{wr:.2e}" if wr is not None else "-"
            wpm = f"{wp * size:.2e}" if wp is not None else "-"
            print(f"{t['robot']:<10} {t['group']:<5} {len(u.considered):>6} {r['name']:<10} {wps:>10} {wpm:>10} {wrs:>10} {tol:>9.2e} {len(pairs(mism)):>10} {'ok' if ok else 'FAIL'}")
            for e in errs:
                print(f"    ERROR {e}")
            for n_ in notes:
                print(f"    note  {n_}")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
