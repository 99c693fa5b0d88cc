"""Build one MJCF string for the RB-Y1 from the vendor SDK's MuJoCo files (no meshes needed).

The vendor's `mujoco/` folder (rby1-sdk, Apache-2.0; the XML of it in robots/rby1a/vendor-sdk/) has
`model_act.xml` (<option>, <default> with position actuators kp 4000 / kv 400, <actuator>)
and `rby1_v<version>.xml` (the bodies), which `<include>` per-link `assets/*/assets.xml`
and `geoms.xml`. Only the XML is present: the .obj meshes are not. MuJoCo >= 3.3 also
refuses a file included twice (assets/WHEEL/geoms.xml is). So this module:

- inlines every <include> recursively, each file once (a repeated include is skipped; the
  only repeats in the vendor files are per-link geoms.xml files that hold mesh geoms only,
  and the skip is checked: a skipped file holding anything but mesh geoms is an error);
- drops every <mesh> asset, every geom with a mesh= attribute or of a mesh-typed default
  class ("visual", "collision"), and those default classes themselves; keeps the primitive
  geoms ("in-model-collision") with contype=0 conaffinity=0 (no contacts are simulated);
- removes the free joint `world_j` (the base is welded to the world) and the floor;
- takes <option> and <default> (actuator defaults) and <actuator> from model_act.xml, and
  ignores model_act.xml's own <include> of a body file;
- keeps inertias, joint armature/damping, joint ranges, the equality constraints (gripper
  fingers), gravity;
- optionally: force limits per position actuator from a URDF's <limit effort>, and MuJoCo's
  passive gravity compensation (gravcomp="1" on every body).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

VERSIONS = ("1.0", "1.1", "1.2")
MESH_CLASSES = ("visual", "collision")
DEFAULT_JOINTS = [f"left_arm_{i}" for i in range(7)] + [f"right_arm_{i}" for i in range(7)]


@dataclass
class UrdfJoint:
    name: str
    kind: str
    parent: str
    child: str
    xyz: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    rpy: Tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis: Tuple[float, float, float] = (1.0, 0.0, 0.0)
    lower: float = -math.inf
    upper: float = math.inf
    velocity: float = math.inf
    effort: float = math.inf


def read_urdf(path: str) -> Dict[str, UrdfJoint]:
    """Every <joint> of a URDF by name (document order kept by dict insertion)."""
    root = ET.parse(path).getroot()
    out: Dict[str, UrdfJoint] = {}
    for j in root.findall("joint"):
        kind = j.get("type", "fixed")
        o = j.find("origin")
        xyz = tuple(float(v) for v in (o.get("xyz", "0 0 0") if o is not None else "0 0 0").split())
        rpy = tuple(float(v) for v in (o.get("rpy", "0 0 0") if o is not None else "0 0 0").split())
        a = j.find("axis")
        axis = tuple(float(v) for v in a.get("xyz").split()) if a is not None else (1.0, 0.0, 0.0)
        uj = UrdfJoint(j.get("name"), kind, j.find("parent").get("link"), j.find("child").get("link"),
                       xyz, rpy, axis)
        lim = j.find("limit")
        if lim is not None:
            if kind in ("revolute", "prismatic"):
                uj.lower = float(lim.get("lower", "0"))
                uj.upper = float(lim.get("upper", "0"))
            if lim.get("velocity") is not None:
                uj.velocity = float(lim.get("velocity"))
            if lim.get("effort") is not None:
                uj.effort = float(lim.get("effort"))
        out[uj.name] = uj
    return out


def _is_mesh_geom(g: ET.Element) -> bool:
    return g.get("mesh") is not None or g.get("type") == "mesh" or g.get("class") in MESH_CLASSES


def _inline(elem: ET.Element, base_dir: str, seen: set, skipped: list) -> None:
    """Replace every <include file=...> under elem by the children of the included root."""
    i = 0
    while i < len(elem):
        child = elem[i]
        if child.tag == "include":
            path = os.path.normpath(os.path.join(base_dir, child.get("file")))
            elem.remove(child)
            if path in seen:
                # each file once: check that nothing but mesh geoms / mesh assets is lost
                sub = ET.parse(path).getroot()
                for e in sub.iter():
                    if e is sub:
                        continue
                    if e.tag == "geom" and not _is_mesh_geom(e):
                        raise ValueError(f"{path} is included twice and holds a non-mesh geom")
                    if e.tag not in ("geom", "mesh", "material", "default", "asset", "worldbody", "body"):
                        raise ValueError(f"{path} is included twice and holds <{e.tag}>")
                skipped.append(path)
                continue
            seen.add(path)
            sub = ET.parse(path).getroot()
            _inline(sub, os.path.dirname(path), seen, skipped)
            for k, c in enumerate(list(sub)):
                elem.insert(i + k, c)
            continue  # re-examine position i (first inlined child)
        _inline(child, base_dir, seen, skipped)
        i += 1


def _strip(elem: ET.Element) -> None:
    """Drop mesh assets, mesh geoms, mesh default classes, the floor, the free joint."""
    for child in list(elem):
        tag = child.tag
        if tag == "mesh":
            elem.remove(child)
            continue
        if tag == "geom" and (_is_mesh_geom(child) or child.get("name") == "floor"):
            elem.remove(child)
            continue
        if tag == "default" and child.get("class") in MESH_CLASSES:
            elem.remove(child)
            continue
        if tag == "joint" and (child.get("name") == "world_j" or child.get("type") == "free"):
            elem.remove(child)
            continue
        if tag == "freejoint":
            elem.remove(child)
            continue
        _strip(child)
    if elem.tag == "geom":
        elem.set("contype", "0")
        elem.set("conaffinity", "0")


@dataclass
class BuildInfo:
    version: str
    xml: str
    skipped_includes: List[str] = field(default_factory=list)
    force_limits: Dict[str, float] = field(default_factory=dict)  # actuator joint -> effort
    gravcomp: bool = False


def build_mjcf(model_dir: str, version: str = "1.0", urdf: Optional[str] = None,
               force_limits: bool = True, gravcomp: bool = False) -> BuildInfo:
    """The MJCF string of the welded, mesh-free RB-Y1 (see the module docstring)."""
    if version not in VERSIONS:
        raise ValueError(f"version {version!r} not in {VERSIONS}")
    act_path = os.path.join(model_dir, "model_act.xml")
    body_path = os.path.join(model_dir, f"rby1_v{version}.xml")
    act = ET.parse(act_path).getroot()
    body = ET.parse(body_path).getroot()
    seen: set = {os.path.normpath(body_path)}
    skipped: List[str] = []
    _inline(body, os.path.dirname(body_path), seen, skipped)
    _strip(body)

    out = ET.Element("mujoco", {"model": f"rby1a_v{version}_welded"})
    comp = body.find("compiler")
    out.append(comp if comp is not None else ET.Element("compiler", {"angle": "radian", "autolimits": "true"}))
    opt = act.find("option")
    if opt is not None:
        out.append(opt)
    # One <default>: model_act's (actuator defaults, in-model-collision class; the mesh
    # classes are dropped) merged with the body file's (joint armature/damping, material).
    dflt = ET.SubElement(out, "default")
    ET.SubElement(dflt, "geom", {"contype": "0", "conaffinity": "0"})
    for src in (act.findall("default"), body.findall("default")):
        for d in src:
            for c in list(d):
                if c.tag == "default" and c.get("class") in MESH_CLASSES:
                    continue
                if c.tag == "geom":  # merge geom defaults with contype/conaffinity 0
                    g = dflt.find("geom")
                    for k, v in c.attrib.items():
                        if k not in ("contype", "conaffinity"):
                            g.set(k, v)
                    continue
                dflt.append(c)
    for tag in ("visual", "asset", "worldbody", "equality", "contact", "tendon", "sensor"):
        for e in body.findall(tag):
            out.append(e)
    # <actuator> from model_act.xml (its <include> of a body file is ignored)
    info = BuildInfo(version=version, xml="", skipped_includes=skipped, gravcomp=gravcomp)
    acts = act.find("actuator")
    if acts is None:
        raise ValueError(f"{act_path}: no <actuator>")
    efforts: Dict[str, float] = {}
    if urdf and force_limits:
        efforts = {n: j.effort for n, j in read_urdf(urdf).items() if math.isfinite(j.effort)}
    for a in acts:
        if a.tag == "position" and force_limits and urdf:
            jn = a.get("joint")
            if jn in efforts and (jn.startswith(("left_arm_", "right_arm_", "torso_", "head_"))):
                e = efforts[jn]
                a.set("forcelimited", "true")
                a.set("forcerange", f"{-e:.17g} {e:.17g}")
                info.force_limits[jn] = e
    out.append(acts)
    if gravcomp:
        for b in out.iter("body"):
            b.set("gravcomp", "1")
    ET.indent(out)
    info.xml = ET.tostring(out, encoding="unicode")
    return info


def load_model(model_dir: str, version: str = "1.0", urdf: Optional[str] = None,
               force_limits: bool = True, gravcomp: bool = False):
    """(mujoco.MjModel, BuildInfo)."""
    import mujoco

    info = build_mjcf(model_dir, version, urdf, force_limits, gravcomp)
    return mujoco.MjModel.from_xml_string(info.xml), info


def default_urdf(model_dir: str, version: str) -> Optional[str]:
    """The SDK's versioned URDF next to the mujoco folder (../urdf/model_v<version>.urdf)."""
    p = os.path.normpath(os.path.join(model_dir, "..", "urdf", f"model_v{version}.urdf"))
    return p if os.path.exists(p) else None
