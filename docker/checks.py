#!/usr/bin/env python3
"""Static checks of docker/ that need no Docker engine and no ROS install.

Called by docker/build.sh, one check per invocation:

    checks.py msgs            msgs/ is a well-formed ament_cmake rosidl interface package
    checks.py dockerfile      COPY sources exist and survive Dockerfile.dockerignore,
                              --from stages exist, FROM args are declared
    checks.py stage DIR       copy what the `build` stage copies (after the dockerignore
                              filter) into DIR, with the Dockerfile's COPY semantics
    checks.py embeds DIR      every include_str!/include_bytes! in DIR/src and DIR/crates/*/src resolves inside DIR
    checks.py compose         compose.yaml parses; services, mounts and defaults are consistent
    checks.py config          docker/config/rby1.toml agrees with config/rby1.toml
    checks.py config-for-host OUT   writes the example config with the host URDF path
    checks.py subcommands HELP      prints the subcommands listed by `crossym --help`

Exit status: 0 passed, 1 failed, 3 skipped (a needed Python module is missing).
Standard library only, except PyYAML for `compose` (skipped without it).
"""

from __future__ import annotations

import fnmatch
import os
import re
import shutil
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
DOCKERFILE = HERE / "Dockerfile"
DOCKERIGNORE = HERE / "Dockerfile.dockerignore"
COMPOSE = HERE / "compose.yaml"
SKIP = 3


class Report:
    def __init__(self, name: str) -> None:
        self.name = name
        self.errors: list[str] = []

    def check(self, cond: bool, message: str) -> bool:
        if not cond:
            self.errors.append(message)
        return cond

    def done(self, summary: str) -> int:
        if self.errors:
            for e in self.errors:
                print(f"  FAIL {self.name}: {e}")
            return 1
        print(f"  ok   {self.name}: {summary}")
        return 0


# --------------------------------------------------------------------------------------
# msgs/: the crossym_msgs interface package

PRIMITIVES = {
    "bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16",
    "int32", "uint32", "int64", "uint64", "string", "wstring",
}
FIELD_NAME = re.compile(r"^[a-z][a-z0-9_]*$")
CONST_NAME = re.compile(r"^[A-Z][A-Z0-9_]*$")
MSG_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
TYPE = re.compile(
    r"^(?P<base>(?:(?P<pkg>[a-z][a-z0-9_]*)/)?(?P<name>[A-Za-z][A-Za-z0-9_]*)"
    r"(?:<=(?P<strbound>[0-9]+))?)(?P<array>\[(?:<=)?[0-9]*\])?$"
)


INT_RANGE = {
    "int8": (-2**7, 2**7 - 1), "uint8": (0, 2**8 - 1), "byte": (0, 2**8 - 1), "char": (0, 2**8 - 1),
    "int16": (-2**15, 2**15 - 1), "uint16": (0, 2**16 - 1),
    "int32": (-2**31, 2**31 - 1), "uint32": (0, 2**32 - 1),
    "int64": (-2**63, 2**63 - 1), "uint64": (0, 2**64 - 1),
}


def const_value_ok(ty: str, value: str) -> bool:
    base = ty.split("<=")[0]
    if base in ("string", "wstring"):
        return True
    if base == "bool":
        return value in ("true", "false", "True", "False", "0", "1")
    try:
        if base.startswith("float"):
            float(value)
            return True
        lo, hi = INT_RANGE[base]
        return lo <= int(value, 0) <= hi
    except (ValueError, KeyError):
        return False


def parse_msg(text: str) -> tuple[list[tuple[str, str]], list[tuple[str, str, str]], list[str]]:
    """rosidl's .msg grammar (messages): returns fields, constants and errors."""
    fields: list[tuple[str, str]] = []
    consts: list[tuple[str, str, str]] = []
    errors: list[str] = []
    for n, raw in enumerate(text.splitlines(), 1):
        # `#` starts a comment, except in the value of a string constant.
        is_str_const = re.match(r"^\s*w?string(<=[0-9]+)?\s+[A-Z][A-Z0-9_]*\s*=", raw)
        line = raw.strip() if is_str_const else raw.split("#", 1)[0].strip()
        if not line:
            continue
        m = re.match(r"^(\S+)\s+([A-Za-z][A-Za-z0-9_]*)\s*=\s*(.+)$", line)
        if m:
            ty, name, value = m.group(1), m.group(2), m.group(3).strip()
            if ty.split("<=")[0] not in PRIMITIVES:
                errors.append(f"line {n}: constant {name} has non-primitive type {ty}")
            if not CONST_NAME.match(name):
                errors.append(f"line {n}: constant name {name} is not UPPER_CASE")
            if not const_value_ok(ty, value):
                errors.append(f"line {n}: constant {name}: `{value}` is not a {ty}")
            consts.append((ty, name, value))
            continue
        parts = line.split()
        if len(parts) < 2:
            errors.append(f"line {n}: `{raw.strip()}` is neither a field nor a constant")
            continue
        ty, name = parts[0], parts[1]
        tm = TYPE.match(ty)
        if not tm:
            errors.append(f"line {n}: bad type `{ty}`")
        else:
            base = tm.group("name")
            if tm.group("pkg") is None and base not in PRIMITIVES and not MSG_NAME.match(base):
                errors.append(f"line {n}: bad type `{ty}`")
            if tm.group("strbound") and base not in ("string", "wstring"):
                errors.append(f"line {n}: only strings take a <=N bound: `{ty}`")
        if not FIELD_NAME.match(name) or "__" in name or name.endswith("_"):
            errors.append(f"line {n}: field name `{name}` is not snake_case")
        if len(parts) > 2 and tm and tm.group("array") is not None:
            errors.append(f"line {n}: array field `{name}` with a default value")
        fields.append((ty, name))
    return fields, consts, errors


def cmake_calls(text: str, command: str) -> list[list[str]]:
    """Arguments of every `command(...)` call in CMake text (comments dropped)."""
    text = re.sub(r"#[^\n]*", "", text)
    out = []
    for m in re.finditer(rf"\b{re.escape(command)}\s*\(", text, re.IGNORECASE):
        depth, i = 1, m.end()
        while i < len(text) and depth:
            depth += {"(": 1, ")": -1}.get(text[i], 0)
            i += 1
        body = text[m.end():i - 1]
        out.append([a.strip('"') for a in re.findall(r'"[^"]*"|[^\s"]+', body)])
    return out


def check_msgs() -> int:
    r = Report("msgs")
    pkg_dir = REPO / "msgs"
    pxml, cml = pkg_dir / "package.xml", pkg_dir / "CMakeLists.txt"
    if not r.check(pxml.is_file() and cml.is_file(), "msgs/package.xml or msgs/CMakeLists.txt missing"):
        return r.done("")
    try:
        root = ET.parse(pxml).getroot()
    except ET.ParseError as e:
        r.check(False, f"package.xml is not well-formed XML: {e}")
        return r.done("")
    text = lambda tag: [(e.text or "").strip() for e in root.findall(tag)]  # noqa: E731
    name = (root.findtext("name") or "").strip()
    r.check(root.tag == "package", "package.xml root is not <package>")
    r.check(root.get("format") == "3", f"package format is {root.get('format')}, want 3")
    r.check(name == "crossym_msgs", f"package name is `{name}`, want crossym_msgs")
    for tag in ("version", "description", "maintainer", "license"):
        r.check(bool(text(tag)) and all(text(tag)), f"package.xml lacks <{tag}>")
    r.check(re.fullmatch(r"[0-9]+\.[0-9]+\.[0-9]+", root.findtext("version", "").strip()) is not None,
            "<version> is not MAJOR.MINOR.PATCH")
    r.check(root.find("maintainer") is not None and root.find("maintainer").get("email"),
            "<maintainer> has no email")
    buildtool = set(text("buildtool_depend"))
    r.check("ament_cmake" in buildtool, "no <buildtool_depend>ament_cmake")
    r.check("rosidl_default_generators" in buildtool, "no <buildtool_depend>rosidl_default_generators")
    r.check("rosidl_default_runtime" in set(text("exec_depend")) | set(text("depend")),
            "no <exec_depend>rosidl_default_runtime")
    r.check("rosidl_interface_packages" in text("member_of_group"),
            "not <member_of_group>rosidl_interface_packages")
    r.check(root.findtext("export/build_type", "").strip() == "ament_cmake",
            "<export><build_type> is not ament_cmake")
    deps = set(text("depend")) | set(text("build_depend"))

    # CMakeLists.txt
    cm = cml.read_text()
    proj = cmake_calls(cm, "project")
    r.check(bool(proj) and proj[0][:1] == [name], "CMakeLists project() is not the package name")
    found = {c[0] for c in cmake_calls(cm, "find_package") if c}
    for need in ("ament_cmake", "rosidl_default_generators"):
        r.check(need in found, f"CMakeLists does not find_package({need} REQUIRED)")
    r.check(bool(cmake_calls(cm, "ament_package")), "CMakeLists does not call ament_package()")
    gen = cmake_calls(cm, "rosidl_generate_interfaces")
    r.check(len(gen) == 1, f"{len(gen)} rosidl_generate_interfaces() calls, want 1")
    listed: list[str] = []
    gen_deps: set[str] = set()
    if gen:
        args = gen[0]
        r.check(args[:1] == ["${PROJECT_NAME}"], "rosidl_generate_interfaces target is not ${PROJECT_NAME}")
        kw = None
        for a in args[1:]:
            if a in ("DEPENDENCIES", "LIBRARY_NAME", "ADD_LINTER_TESTS", "SKIP_INSTALL", "SKIP_GROUP_MEMBERSHIP_CHECK"):
                kw = a
            elif kw == "DEPENDENCIES":
                gen_deps.add(a)
            elif kw is None:
                listed.append(a)
    present = sorted(p.relative_to(pkg_dir).as_posix() for p in pkg_dir.glob("msg/*.msg"))
    r.check(sorted(listed) == present,
            f"rosidl_generate_interfaces lists {sorted(listed)}, msg/ holds {present}")
    r.check(len(set(listed)) == len(listed), "rosidl_generate_interfaces lists a file twice")
    r.check(bool(present), "msgs/msg/ holds no .msg file")

    # The .msg files
    names = {Path(p).stem for p in present}
    used_pkgs: set[str] = set()
    nfields = nconsts = 0
    for rel in present:
        stem = Path(rel).stem
        r.check(MSG_NAME.match(stem) is not None, f"{rel}: message name is not CamelCase")
        fields, consts, errs = parse_msg((pkg_dir / rel).read_text())
        for e in errs:
            r.check(False, f"{rel}: {e}")
        nfields += len(fields)
        nconsts += len(consts)
        seen: set[str] = set()
        for ty, fname in fields:
            r.check(fname not in seen, f"{rel}: field `{fname}` twice")
            seen.add(fname)
            tm = TYPE.match(ty)
            if not tm:
                continue
            pkg, base = tm.group("pkg"), tm.group("name")
            if pkg is None and base not in PRIMITIVES:
                r.check(base in names, f"{rel}: `{ty}` is not a message of this package")
            elif pkg == name:
                r.check(base in names, f"{rel}: `{ty}` is not in msgs/msg/")
            elif pkg is not None:
                used_pkgs.add(pkg)
        for _, cname, _ in consts:
            r.check(cname not in seen, f"{rel}: constant `{cname}` twice")
            seen.add(cname)
    for pkg in sorted(used_pkgs):
        r.check(pkg in deps, f"the .msg files use {pkg} but package.xml does not <depend> on it")
        r.check(pkg in found, f"the .msg files use {pkg} but CMakeLists does not find_package it")
        r.check(pkg in gen_deps, f"the .msg files use {pkg} but it is not in DEPENDENCIES")

    # catkin_pkg (ROS's own package.xml parser and validator), when installed.
    extra = ""
    try:
        from catkin_pkg.package import parse_package  # type: ignore
    except ImportError:
        extra = "; catkin_pkg not installed (its validation skipped)"
    else:
        try:
            p = parse_package(str(pkg_dir))
            p.validate()
            extra = f"; catkin_pkg {p.name} {p.version} (format {p.package_format}) validates"
        except Exception as e:  # catkin_pkg raises InvalidPackage and friends
            r.check(False, f"catkin_pkg: {e}")
    return r.done(
        f"package.xml (format 3, {name}, ament_cmake, rosidl_interface_packages), "
        f"CMakeLists lists exactly {', '.join(present)}; {nfields} fields, {nconsts} constants "
        f"parse; uses {', '.join(sorted(used_pkgs)) or 'no other package'}{extra}"
    )


# --------------------------------------------------------------------------------------
# Dockerfile and its dockerignore

def dockerfile_instructions(path: Path) -> list[tuple[int, str, str]]:
    """(line, INSTRUCTION, arguments) with continuations joined and comments dropped."""
    out: list[tuple[int, str, str]] = []
    buf, start = "", 0
    for n, line in enumerate(path.read_text().splitlines(), 1):
        s = line.strip()
        if not buf and (not s or s.startswith("#")):
            continue
        if buf and s.startswith("#"):
            continue  # comment lines inside a continuation are dropped by Docker
        if not buf:
            start = n
        if s.endswith("\\"):
            buf += s[:-1] + " "
            continue
        buf += s
        parts = buf.split(None, 1)
        out.append((start, parts[0].upper(), parts[1] if len(parts) > 1 else ""))
        buf = ""
    return out


def split_flags(args: str) -> tuple[dict[str, str], list[str]]:
    """`--from=x --chmod=755 a b c` -> ({from: x, chmod: 755}, [a, b, c]); JSON form too."""
    import json
    flags: dict[str, str] = {}
    words = args.split()
    while words and words[0].startswith("--"):
        k, _, v = words.pop(0)[2:].partition("=")
        flags[k] = v
    rest = " ".join(words)
    if rest.startswith("["):
        return flags, json.loads(rest)
    return flags, rest.split()


class DockerIgnore:
    """moby/patternmatcher semantics: last match wins, `!` re-includes, a path matches
    when it or one of its parent directories matches, `**` spans directories."""

    def __init__(self, path: Path) -> None:
        self.patterns: list[tuple[bool, re.Pattern[str], str]] = []
        if not path.exists():
            return
        for line in path.read_text().splitlines():
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            neg = s.startswith("!")
            if neg:
                s = s[1:].strip()
            s = os.path.normpath(s.lstrip("/")).replace(os.sep, "/")
            self.patterns.append((neg, re.compile(self._regex(s)), s))

    @staticmethod
    def _regex(p: str) -> str:
        out, i = "^", 0
        while i < len(p):
            c = p[i]
            if c == "*":
                if p[i:i + 2] == "**":
                    i += 2
                    if p[i:i + 1] == "/":
                        out += "(.*/)?"
                        i += 1
                    else:
                        out += ".*"
                    continue
                out += "[^/]*"
            elif c == "?":
                out += "[^/]"
            elif c == "[":
                j = p.find("]", i)
                if j < 0:
                    out += re.escape(c)
                else:
                    out += "[" + p[i + 1:j].replace("!", "^", 1) + "]"
                    i = j
            elif c == "\\" and i + 1 < len(p):
                i += 1
                out += re.escape(p[i])
            else:
                out += re.escape(c)
            i += 1
        return out + "$"

    def excluded(self, rel: str) -> bool:
        parents = rel.split("/")
        prefixes = ["/".join(parents[:k]) for k in range(1, len(parents))]
        ex = False
        for neg, rx, _ in self.patterns:
            hit = bool(rx.match(rel)) or any(rx.match(p) for p in prefixes)
            if hit:
                ex = not neg
        return ex

    def may_include_below(self, rel_dir: str) -> bool:
        """False when no `!` pattern can re-include anything under rel_dir (prune)."""
        return any(neg and (pat == rel_dir or pat.startswith(rel_dir + "/") or pat.startswith("*"))
                   for neg, _, pat in self.patterns)


def context_files(ignore: DockerIgnore) -> list[str]:
    """Files of the build context (repo root) after the dockerignore filter."""
    files: list[str] = []
    for d, dirs, fnames in os.walk(REPO):
        rd = os.path.relpath(d, REPO).replace(os.sep, "/")
        rd = "" if rd == "." else rd
        keep = []
        for x in dirs:
            rel = f"{rd}/{x}" if rd else x
            if ignore.excluded(rel) and not ignore.may_include_below(rel):
                continue
            keep.append(x)
        dirs[:] = keep
        for f in fnames:
            rel = f"{rd}/{f}" if rd else f
            if not ignore.excluded(rel):
                files.append(rel)
    return sorted(files)


def parse_stages() -> tuple[list[dict], list[str], list[str]]:
    """Stages of the Dockerfile: name, base, COPY/ADD list, RUN texts; plus global ARGs."""
    stages: list[dict] = []
    global_args: list[str] = []
    errors: list[str] = []
    for line, ins, args in dockerfile_instructions(DOCKERFILE):
        if ins == "FROM":
            m = re.match(r"^(?:--\S+\s+)*(\S+)(?:\s+AS\s+(\S+))?\s*$", args, re.IGNORECASE)
            if not m:
                errors.append(f"line {line}: cannot parse FROM {args}")
                continue
            stages.append({"name": m.group(2), "base": m.group(1), "line": line,
                           "copies": [], "runs": [], "workdir": "/", "args": []})
        elif not stages:
            if ins == "ARG":
                global_args.append(args.split("=", 1)[0].strip())
            else:
                errors.append(f"line {line}: {ins} before the first FROM")
        elif ins in ("COPY", "ADD"):
            flags, words = split_flags(args)
            stages[-1]["copies"].append({"line": line, "flags": flags, "src": words[:-1],
                                         "dest": words[-1] if words else "",
                                         "workdir": stages[-1]["workdir"]})
        elif ins == "RUN":
            stages[-1]["runs"].append(args)
        elif ins == "WORKDIR":
            w = args.strip()
            stages[-1]["workdir"] = w if w.startswith("/") else os.path.join(stages[-1]["workdir"], w)
        elif ins == "ARG":
            stages[-1]["args"].append(args.split("=", 1)[0].strip())
    return stages, global_args, errors


def check_dockerfile() -> int:
    r = Report("dockerfile")
    stages, global_args, errs = parse_stages()
    for e in errs:
        r.check(False, e)
    ignore = DockerIgnore(DOCKERIGNORE)
    r.check(DOCKERIGNORE.exists(), "docker/Dockerfile.dockerignore is missing (the context would be the whole repo incl. target/)")
    files = context_files(ignore)
    fileset = set(files)
    names = [s["name"] for s in stages]
    r.check({"build", "msgs", "runtime"} <= set(names), f"stages are {names}, want build, msgs and runtime")
    r.check(bool(names) and names[-1] == "runtime", "the last (default) stage is not runtime")
    for s in stages:
        for var in re.findall(r"\$\{?([A-Za-z_][A-Za-z0-9_]*)", s["base"]):
            r.check(var in global_args, f"FROM {s['base']} (line {s['line']}): ARG {var} not declared before the first FROM")
    ncopy = nsrc = 0
    for i, s in enumerate(stages):
        for c in s["copies"]:
            ncopy += 1
            src_from = c["flags"].get("from")
            if src_from is not None:
                earlier = [x["name"] for x in stages[:i]]
                if src_from in earlier:
                    continue
                r.check(":" in src_from or "/" in src_from or src_from.isdigit(),
                        f"line {c['line']}: COPY --from={src_from}: no earlier stage of that name")
                continue
            r.check(bool(c["src"]), f"line {c['line']}: COPY without a source")
            for src in c["src"]:
                nsrc += 1
                p = os.path.normpath(src).replace(os.sep, "/").lstrip("/")
                if p in ("", "."):
                    continue
                on_disk = list(REPO.glob(p)) if any(ch in p for ch in "*?[") else [REPO / p]
                r.check(any(x.exists() for x in on_disk), f"line {c['line']}: COPY source `{src}` does not exist in the repository")
                hit = any(f == p or f.startswith(p + "/") or fnmatch.fnmatch(f, p) for f in fileset)
                r.check(hit, f"line {c['line']}: COPY source `{src}` is excluded by Dockerfile.dockerignore (or empty)")
    # The runtime must read crossym's bags (MCAP) with `ros2 bag`.
    runtime = next((s for s in stages if s["name"] == "runtime"), None)
    if runtime:
        r.check(any("rosbag2-storage-mcap" in x for x in runtime["runs"]),
                "runtime does not install ros-$ROS_DISTRO-rosbag2-storage-mcap (crossym bags are MCAP)")
    r.check("USER" in {ins for _, ins, _ in dockerfile_instructions(DOCKERFILE)}, "no USER: the image would run as root")
    size = sum((REPO / f).stat().st_size for f in files)
    return r.done(
        f"{len(stages)} stages ({', '.join(str(n) for n in names)}); {ncopy} COPY, every one of "
        f"{nsrc} context sources exists and passes the dockerignore; context after the filter: "
        f"{len(files)} files, {size / 1e6:.1f} MB"
    )


def copy_into(src: Path, dest: Path) -> None:
    if src.is_dir():
        for root, _, fnames in os.walk(src):
            for f in fnames:
                s = Path(root) / f
                t = dest / s.relative_to(src)
                t.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(s, t)
    else:
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest)


def stage_build_context(out: Path) -> int:
    """Reproduce the `build` stage's COPYs into `out` (as its WORKDIR), context filtered."""
    r = Report("stage")
    stages, _, errs = parse_stages()
    for e in errs:
        r.check(False, e)
    build = next((s for s in stages if s["name"] == "build"), None)
    if not r.check(build is not None, "no `build` stage"):
        return r.done("")
    ignore = DockerIgnore(DOCKERIGNORE)
    files = context_files(ignore)
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    n = 0
    for c in build["copies"]:
        if "from" in c["flags"]:
            continue
        dest = c["dest"]
        dest_abs = dest if dest.startswith("/") else os.path.join(c["workdir"], dest)
        rel_dest = os.path.relpath(dest_abs, build["workdir"])
        if rel_dest.startswith(".."):
            continue  # outside the WORKDIR: not part of the crate
        as_dir = dest.endswith("/") or len(c["src"]) > 1 or dest in (".", "./")
        for src in c["src"]:
            p = os.path.normpath(src).replace(os.sep, "/")
            picked = [f for f in files if f == p or f.startswith(p + "/") or fnmatch.fnmatch(f, p)]
            for f in picked:
                if f == p or fnmatch.fnmatch(f, p):
                    target = out / rel_dest / Path(f).name if as_dir else out / rel_dest
                else:
                    target = out / rel_dest / os.path.relpath(f, p)
                copy_into(REPO / f, Path(os.path.normpath(target)))
                n += 1
    return r.done(f"{n} files of the `build` stage's COPYs staged in {out}")


def check_embeds(root: Path) -> int:
    """include_str!/include_bytes! paths of root/src and root/crates/*/src resolve inside
    root (the staged workspace)."""
    r = Report("embeds")
    pat = re.compile(r'include_(?:str|bytes)!\(\s*"([^"]+)"\s*\)')
    n = 0
    files = list((root / "src").rglob("*.rs")) + list(root.glob("crates/*/src/**/*.rs"))
    for f in sorted(files):
        for m in pat.finditer(f.read_text()):
            n += 1
            target = (f.parent / m.group(1)).resolve()
            inside = str(target).startswith(str(root.resolve()) + os.sep)
            r.check(inside and target.is_file(),
                    f"{f.relative_to(root)} embeds {m.group(1)}, absent from the staged build context")
    return r.done(f"{n} include_str!/include_bytes! targets are in the staged context")


# --------------------------------------------------------------------------------------
# compose.yaml

VAR = re.compile(r"\$\{([A-Za-z_][A-Za-z0-9_]*)(?:(:?[-?])([^}]*))?\}|\$([A-Za-z_][A-Za-z0-9_]*)")


def interpolate(s: str, r: Report, where: str) -> str:
    def sub(m: re.Match[str]) -> str:
        name = m.group(1) or m.group(4)
        op, arg = m.group(2), m.group(3)
        val = os.environ.get(name)
        if op in (":-", "-"):
            if val is None or (op == ":-" and val == ""):
                return arg
            return val
        if op in (":?", "?"):
            if val is None or (op == ":?" and val == ""):
                r.check(False, f"{where}: ${{{name}}} is required and unset ({arg})")
                return ""
            return val
        if val is None:
            r.check(False, f"{where}: ${{{name}}} has no default and is unset")
            return ""
        return val
    return VAR.sub(sub, s)


def check_compose() -> int:
    r = Report("compose")
    try:
        import yaml  # type: ignore
    except ImportError:
        print("  skip compose: PyYAML is not installed (pip install pyyaml; CI gets it from tests/bags/install.sh)")
        return SKIP
    try:
        doc = yaml.safe_load(COMPOSE.read_text())
    except yaml.YAMLError as e:
        r.check(False, f"compose.yaml is not valid YAML: {e}")
        return r.done("")
    if not r.check(isinstance(doc, dict) and isinstance(doc.get("services"), dict), "no services mapping"):
        return r.done("")
    services = doc["services"]
    header = COMPOSE.read_text().split("\nname:", 1)[0]
    stages = [s["name"] for s in parse_stages()[0]]
    for need in ("crossym", "rby1-driver", "tools"):
        r.check(need in services, f"no service `{need}`")
    node = services.get("crossym", {})
    r.check(not node.get("profiles"), "service crossym has a profile: `docker compose up crossym` must work alone")
    r.check(services.get("rby1-driver", {}).get("profiles") == ["driver"], "rby1-driver is not under the `driver` profile")
    r.check("RBY1_DRIVER_IMAGE" in str(services.get("rby1-driver", {}).get("image", "")),
            "rby1-driver's image is not ${RBY1_DRIVER_IMAGE...}")
    named_volumes = set((doc.get("volumes") or {}).keys())
    mounts_checked = mounts_present = 0
    host_config = None
    for sname, svc in services.items():
        r.check(svc.get("network_mode") == "host", f"{sname}: network_mode is not host (DDS discovery)")
        env = svc.get("environment") or {}
        if isinstance(env, list):
            env = dict(e.split("=", 1) if "=" in e else (e, "") for e in env)
        r.check("ROS_DOMAIN_ID" in env, f"{sname}: no ROS_DOMAIN_ID in environment")
        if "ROS_DOMAIN_ID" in env:
            dom = interpolate(str(env["ROS_DOMAIN_ID"]), r, f"{sname}.ROS_DOMAIN_ID")
            r.check(dom.isdigit() and int(dom) <= 232, f"{sname}: ROS_DOMAIN_ID `{dom}` is not in 0..=232")
        if "build" in svc:
            b = svc["build"]
            ctx = (HERE / interpolate(str(b.get("context", ".")), r, f"{sname}.build")).resolve()
            df = ctx / b.get("dockerfile", "Dockerfile")
            r.check(ctx == REPO, f"{sname}: build context {ctx} is not the repository root")
            r.check(df.resolve() == DOCKERFILE, f"{sname}: build.dockerfile {df} is not docker/Dockerfile")
            r.check(b.get("target") in stages, f"{sname}: build.target {b.get('target')} is not a stage")
        for v in svc.get("volumes") or []:
            if isinstance(v, str):
                parts = v.split(":")
                v = {"type": "bind" if parts[0].startswith((".", "/", "$", "~")) else "volume",
                     "source": parts[0], "target": parts[1] if len(parts) > 1 else "",
                     "read_only": len(parts) > 2 and "ro" in parts[2].split(",")}
            where = f"{sname}: volume {v.get('source')} -> {v.get('target')}"
            if v.get("type") == "volume":
                r.check(v.get("source") in named_volumes, f"{where}: named volume not declared at top level")
                continue
            raw = str(v.get("source", ""))
            src = interpolate(raw, r, where)
            p = Path(src) if os.path.isabs(src) else (HERE / src)
            mounts_checked += 1
            mounts_present += p.exists()
            for var in re.findall(r"\$\{([A-Za-z_][A-Za-z0-9_]*)", raw):
                r.check(var in header, f"{where}: ${{{var}}} is not documented in compose.yaml's header")
            if sname == "crossym":
                r.check(bool(v.get("read_only")), f"{where}: bind mount is not read-only")
            if p.exists():
                if v.get("target") == "/config":
                    host_config = p
            else:
                # Only the vendor URDF may be absent (a partial checkout; RBY1_URDF is documented),
                # and only at its default path: a RBY1_URDF that was set must exist.
                documented = "RBY1_URDF" in raw and not os.environ.get("RBY1_URDF")
                msg = f"{where}: host path {p} does not exist"
                if documented:
                    print(f"  note compose: {msg} (vendor URDF: set RBY1_URDF)")
                else:
                    r.check(False, msg)
    cmd = node.get("command") or []
    if isinstance(cmd, str):
        cmd = cmd.split()
    r.check(cmd[:1] == ["node"] and "--config" in cmd, f"crossym command is {cmd}, want node --config ...")
    if "--config" in cmd and cmd.index("--config") + 1 < len(cmd):
        cpath = cmd[cmd.index("--config") + 1]
        r.check(cpath.startswith("/config/"), f"--config {cpath} is not under the /config mount")
        if host_config is not None and cpath.startswith("/config/"):
            hc = host_config / cpath[len("/config/"):]
            r.check(hc.is_file(), f"--config {cpath}: {hc} does not exist on the host side of the mount")
    # compose-spec bindings (PyPI compose-spec: a typed parser of the Compose
    # specification that rejects unknown keys and ill-typed values), when installed. It
    # does not interpolate or merge `<<:` keys: feed it what PyYAML made of the
    # interpolated text, without the x- extension fields.
    try:
        import compose_spec  # type: ignore
    except ImportError:
        typed = "; compose_spec not installed (typed validation skipped)"
    else:
        import json
        scratch = Report("compose")
        interp = yaml.safe_load(interpolate(COMPOSE.read_text(), scratch, "compose.yaml"))
        interp = {k: v for k, v in interp.items() if not str(k).startswith("x-")}
        try:
            compose_spec.PyCompose.from_json(json.dumps(interp))
            typed = "; compose_spec (typed Compose-spec parser) accepts it"
        except ValueError as e:
            r.check(False, f"compose_spec rejects it: {e}")
            typed = ""
    return r.done(
        f"YAML parses{typed}; services {', '.join(services)}; host network and ROS_DOMAIN_ID everywhere; "
        f"crossym has no profile, driver/tools are profiled; build target/context/dockerfile "
        f"consistent; {mounts_present} of {mounts_checked} bind-mount sources exist "
        f"(variables as set, else their defaults, relative to docker/)"
    )


# --------------------------------------------------------------------------------------
# docker/config/rby1.toml

def load_toml(path: Path):
    try:
        import tomllib  # Python 3.11+
    except ImportError:
        return None
    with open(path, "rb") as f:
        return tomllib.load(f)


def check_config() -> int:
    r = Report("config")
    ex = HERE / "config" / "rby1.toml"
    if not r.check(ex.is_file(), "docker/config/rby1.toml is missing"):
        return r.done("")
    d = load_toml(ex)
    if d is None:
        print("  skip config: needs Python 3.11 (tomllib)")
        return SKIP
    robot, node = dict(d.get("robot", {})), dict(d.get("node", {}))
    r.check(robot.get("urdf") == "/urdf/model.urdf",
            f"[robot] urdf is {robot.get('urdf')}, want /urdf/model.urdf (the compose mount)")
    r.check(node.get("output") == "trajectory"
            and node.get("topics", {}).get("command") == "/both_arms_controller/joint_trajectory",
            f"[node] output is {node.get('output')} on {node.get('topics', {}).get('command')}, want "
            "trajectory on /both_arms_controller/joint_trajectory (the vendor's JointTrajectoryController)")
    pol = str(node.get("policy", ""))
    r.check(pol.startswith("/policies/") or pol.startswith("/opt/crossym/"),
            f"[node] policy {pol} is neither under the /policies mount nor in the image")
    r.check(set(d) <= {"robot", "kinematics", "node"},
            f"sections {sorted(set(d) - {'robot', 'kinematics', 'node'})} are not used by the node")
    repo_cfg = REPO / "config" / "rby1.toml"
    note = ""
    if repo_cfg.is_file():
        rc = load_toml(repo_cfg)
        rrobot, rnode = dict(rc.get("robot", {})), dict(rc.get("node") or {})
        r.check(bool(rnode), "config/rby1.toml has no [node]")
        # Equal but for the in-container paths.
        robot.pop("urdf", None)
        rrobot.pop("urdf", None)
        r.check(robot == rrobot, "[robot] (but urdf) differs from config/rby1.toml's")
        r.check(d.get("kinematics") == rc.get("kinematics"), "[kinematics] differs from config/rby1.toml's")
        rpol = str(rnode.pop("policy", ""))
        node.pop("policy", None)
        r.check(Path(rpol).name == Path(pol).name,
                f"[node] policy file {Path(pol).name} is not config/rby1.toml's {Path(rpol).name}")
        r.check(node == rnode, "[node] (but policy) differs from config/rby1.toml's: "
                + ", ".join(sorted(k for k in set(node) | set(rnode) if node.get(k) != rnode.get(k))))
        note = "; [robot], [kinematics], [node] equal config/rby1.toml's but for the paths"
        shipped = REPO / "data" / "policies" / Path(pol).name
        if not shipped.exists():
            print(f"  note config: the policy {Path(pol).name} is not in data/policies/ "
                  "(mount your own at /policies)")
    return r.done(f"urdf /urdf/model.urdf, output position, policy {pol}{note}")


def config_for_host(out: Path, urdf: str) -> int:
    """The example config with the URDF at its host path (to load it with `crossym info`)."""
    text = (HERE / "config" / "rby1.toml").read_text()
    new = re.sub(r'(?m)^urdf\s*=\s*"/urdf/model\.urdf"', f'urdf = "{urdf}"', text)
    if new == text:
        print("  FAIL config: no `urdf = \"/urdf/model.urdf\"` line to rewrite")
        return 1
    out.write_text(new)
    return 0


def list_subcommands(help_file: Path) -> int:
    """Prints the subcommands of `crossym --help` (for build.sh to try through the entrypoint)."""
    m = re.search(r"^Commands:\n((?:  \S.*\n?)+)", help_file.read_text(), re.M)
    if m is None:
        print("  FAIL entrypoint: no Commands: section in `crossym --help`", file=sys.stderr)
        return 1
    for line in m.group(1).splitlines():
        if line.strip():
            print(line.split()[0])
    return 0


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    cmd, rest = argv[0], argv[1:]
    if cmd == "msgs":
        return check_msgs()
    if cmd == "dockerfile":
        return check_dockerfile()
    if cmd == "stage":
        return stage_build_context(Path(rest[0]))
    if cmd == "embeds":
        return check_embeds(Path(rest[0]))
    if cmd == "compose":
        return check_compose()
    if cmd == "config":
        return check_config()
    if cmd == "config-for-host":
        return config_for_host(Path(rest[0]), rest[1])
    if cmd == "subcommands":
        return list_subcommands(Path(rest[0]))
    print(f"unknown check {cmd}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
