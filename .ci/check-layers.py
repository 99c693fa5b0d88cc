#!/usr/bin/env python3
"""The workspace's floors, checked (docs/ARCHITECTURE.md).

1. Crates: every dependency of a crossym crate (normal, build or dev) is on a lower floor
   (`cargo metadata`); a crate missing from FLOORS is an error too.
2. Files: no import cycle between the files of one crate. A file imports another when it
   names it by path (`crate::a::b`, `super::b`, `self::b`, and `use` groups of those); a
   module's `mod.rs` / `lib.rs` declaring its children is not an import. Cycles are
   reported as the files on them.

3. Re-exports: no crate but the application package `crossym` re-exports another crossym
   crate's items (`pub use crossym_x::…`): a type is named where it is defined.
4. Dependencies: every normal dependency of a crate is named by its non-test code
   (`src/`, `build.rs`; inline `#[cfg(test)]` modules and `tests.rs` files are test code,
   whose dependencies belong in [dev-dependencies]).

Exits 1 with the offending edges or cycles; prints the floors and file counts otherwise.
`python3 .ci/check-layers.py --selftest` runs the checker on deliberately broken inputs.
"""

import json
import re
import subprocess
import sys
from pathlib import Path

# Floor of each crate: a crate may depend only on crates of a strictly lower floor.
FLOORS = {
    "crossym-math": 1,
    "crossym-io": 1,
    "crossym-policy": 2,
    # Siblings: the training stack and the real-time control floor never depend on each
    # other (the node links policy inference, not training).
    "crossym-learn": 3,
    "crossym-control": 3,
    "crossym-ros": 4,
    "crossym": 5,
}


def crate_edges(metadata):
    """(crate, dependency, kind) for every dependency between workspace crates."""
    names = {p["name"] for p in metadata["packages"]}
    for p in metadata["packages"]:
        for d in p["dependencies"]:
            if d["name"] in names:
                yield p["name"], d["name"], d["kind"] or "normal"


def check_crates(metadata):
    errors = []
    for p in metadata["packages"]:
        if p["name"] not in FLOORS:
            errors.append(f"crate {p['name']} has no floor in .ci/check-layers.py FLOORS")
    for a, b, kind in crate_edges(metadata):
        fa, fb = FLOORS.get(a), FLOORS.get(b)
        if fa is not None and fb is not None and fb >= fa:
            errors.append(f"{a} (floor {fa}) depends on {b} (floor {fb}) [{kind}]: "
                          "dependencies must point down")
    return errors


# --- files -----------------------------------------------------------------------------

def module_path(src, f):
    """Module path of file f under the crate's src/ directory, as a tuple."""
    rel = f.relative_to(src).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return tuple(parts)


def expand_use(tree):
    """Paths of a `use` tree (`a::{b, c::{d, e}}` → a::b, a::c::d, a::c::e)."""
    tree = re.sub(r"\s+as\s+\w+", "", tree)
    tree = re.sub(r"\s+", "", tree)
    i = tree.find("{")
    if i < 0:
        return [tree]
    prefix, body = tree[:i], tree[i + 1:tree.rfind("}")]
    items, depth, cur = [], 0, ""
    for ch in body:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            items.append(cur)
            cur = ""
        else:
            cur += ch
    if cur:
        items.append(cur)
    out = []
    for it in items:
        out += [prefix + p for p in expand_use(it)]
    return out


def referenced_paths(text):
    text = code_only(text)
    paths = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        paths += expand_use(m.group(1))
    paths += re.findall(r"\b((?:crate|super|self)(?:::[A-Za-z_][A-Za-z0-9_]*)+)", text)
    # bare paths (`child::Item` names a child module since Rust 2018); `resolve` keeps
    # those whose first segment is a child of the file's module
    paths += re.findall(r"(?<![:\w])([a-z_][a-z0-9_]*(?:::[A-Za-z_][A-Za-z0-9_]*)+)", text)
    return paths


def reexports(text, here, modules):
    """{item: module} for the `pub use` items of a file that come from a module of its crate
    (`pub use child::Item;`), so that a path naming the item through its parent resolves to
    the file that defines it."""
    out = {}
    for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+([^;]+);", code_only(text)):
        for path in expand_use(m.group(1)):
            parts = path.split("::")
            if parts[0] not in ("crate", "super", "self"):
                parts = ["self"] + parts
            t = resolve("::".join(parts), here, modules, {})
            if t is not None and t != here:
                out[parts[-1]] = t
    return out


def resolve(path, here, modules, exported):
    """The module (file) a path names, from the module `here`; None if outside the crate.
    `exported` maps a module to its re-exported items ([`reexports`])."""
    parts = [p for p in path.split("::") if p]
    if not parts:
        return None
    if parts[0] == "crate":
        cur, parts = (), parts[1:]
    elif parts[0] in ("super", "self"):
        cur = here
        while parts and parts[0] in ("super", "self"):
            if parts[0] == "super":
                cur = cur[:-1]
            parts = parts[1:]
    elif here + (parts[0],) in modules:
        cur = here
    else:
        return None
    best = cur if cur in modules else None
    for p in parts:
        nxt = cur + (p,)
        if nxt in modules:
            best = cur = nxt
        else:
            if best is not None and p in exported.get(best, {}):
                best = exported[best][p]
            break
    return best


def file_graph(src):
    files = {module_path(src, f): f for f in src.rglob("*.rs")}
    exported = {m: reexports(f.read_text(), m, files) for m, f in files.items()}
    graph = {m: set() for m in files}
    for m, f in files.items():
        # A parent's declarations (`mod child;`) and re-exports (`pub use child::Item;`)
        # are its structure, not imports; anything else it names of a child is an import,
        # so a child that names its parent's own items back makes a cycle. Test modules
        # inside a file (`#[cfg(test)] mod tests { use super::*; … }`) are left out: their
        # `super` is the file itself.
        text = strip_test_modules(code_only(f.read_text()))
        text = re.sub(r"\bpub(?:\([^)]*\))?\s+use\s+[^;]+;", "", text)
        for path in referenced_paths(text):
            t = resolve(path, m, files, exported)
            # a file naming itself is not an import
            if t is None or t == m:
                continue
            graph[m].add(t)
    return files, graph


def cycles(graph):
    """Strongly connected components with more than one file (Tarjan)."""
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def check_files(crate, src):
    files, graph = file_graph(src)
    errors = []
    for comp in cycles(graph):
        names = [str(files[m].relative_to(src)) for m in comp]
        edges = [f"{'::'.join(a) or 'lib'} → {'::'.join(b) or 'lib'}"
                 for a in comp for b in sorted(graph[a]) if b in comp]
        errors.append(f"{crate}: import cycle between {', '.join(names)} ({'; '.join(edges)})")
    return len(files), errors


def strip_test_modules(text):
    """The text without its inline `#[cfg(test)] mod name { … }` blocks."""
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+\w+\s*\{", text):
        if m.start() < i:
            continue
        depth, j = 1, m.end()
        while j < len(text) and depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        out.append(text[i:m.start()])
        i = j
    out.append(text[i:])
    return "".join(out)


def code_only(text):
    """Rust source without comments and with every string and char literal emptied, so
    that braces and names inside them (`"/**"`, `'{'`) count for nothing."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
        elif c == "r" and re.match(r'r(#*)"', text[i:i + 260]) and not (i and (text[i - 1].isalnum() or text[i - 1] == "_")):
            hashes = re.match(r'r(#*)"', text[i:]).group(1)
            end = text.find('"' + hashes, i + 2 + len(hashes))
            out.append('""')
            i = n if end < 0 else end + 1 + len(hashes)
        elif c == '"':
            i += 1
            while i < n and text[i] != '"':
                i += 2 if text[i] == "\\" else 1
            out.append('""')
            i += 1
        elif c == "'" and re.match(r"'(\\.[^']*|[^\\'])'", text[i:i + 12]):
            m = re.match(r"'(\\.[^']*|[^\\'])'", text[i:])
            out.append("' '")
            i += m.end()
        else:
            out.append(c)
            i += 1
    return "".join(out)


def unused_dependencies(package):
    """Normal dependencies of a package that its non-test code never names."""
    root = Path(package["manifest_path"]).parent
    code = ""
    for f in sorted((root / "src").rglob("*.rs")):
        if f.name != "tests.rs":
            code += strip_test_modules(code_only(f.read_text()))
    if (root / "build.rs").exists():
        code += code_only((root / "build.rs").read_text())
    return unused_in(package, code)


def unused_in(package, code):
    out = []
    for d in package["dependencies"]:
        if d["kind"] is not None:
            continue
        name = (d.get("rename") or d["name"]).replace("-", "_")
        if not re.search(r"\b" + re.escape(name) + r"\b", code):
            out.append(f"{package['name']}: dependency {d['name']} is not used by its code "
                       "(remove it, or move it to [dev-dependencies] if only tests use it)")
    return out


def cross_floor_reexports(package):
    """`pub use` of another crossym crate's items, outside the application package."""
    if package["name"] == "crossym":
        return []
    root = Path(package["manifest_path"]).parent / "src"
    out = []
    for f in sorted(root.rglob("*.rs")):
        for m in re.finditer(r"\bpub(?:\([^)]*\))?\s+use\s+(::)?(crossym_\w+)", code_only(f.read_text())):
            if m.group(2).replace("_", "-") != package["name"]:
                out.append(f"{package['name']}: {f.relative_to(root.parent)} re-exports "
                           f"{m.group(2)} (a crate of another floor): import it where it is used")
    return out


def run(root):
    meta = json.loads(subprocess.check_output(
        ["cargo", "metadata", "--format-version", "1", "--no-deps", "--offline"], cwd=root))
    errors = check_crates(meta)
    counts = []
    for p in meta["packages"]:
        src = Path(p["manifest_path"]).parent / "src"
        n, errs = check_files(p["name"], src)
        errors += errs + unused_dependencies(p) + cross_floor_reexports(p)
        counts.append(f"{p['name']} (floor {FLOORS.get(p['name'], '?')}, {n} files)")
    if errors:
        print("\n".join(f"error: {e}" for e in errors), file=sys.stderr)
        return 1
    print("floors ok, no import cycle between files: " + "; ".join(sorted(counts)))
    return 0


def selftest():
    """The checker fails on an upward crate edge, a file cycle and an unused dependency,
    passes on none."""
    import tempfile
    pkg = {"name": "crossym-x", "dependencies": [
        {"name": "rand", "kind": None}, {"name": "toml", "kind": None},
        {"name": "approx", "kind": "dev"}]}
    assert code_only('let s = "/**"; let c = \'{\'; // toml::x\n/* toml */ r#"toml"#') == \
        'let s = ""; let c = \' \'; \n ""', "comments or literals survived"
    code = strip_test_modules(
        "use rand::Rng;\n#[cfg(test)]\nmod tests {\n    fn f() { toml::from_str(\"\"); { } }\n}\n")
    assert unused_in(pkg, code) == [
        "crossym-x: dependency toml is not used by its code (remove it, or move it to "
        "[dev-dependencies] if only tests use it)"], "a test-only normal dependency passed"
    assert unused_in(pkg, code + "fn g() { toml::x() }") == [], "a used dependency was refused"
    meta = {"packages": [
        {"name": "crossym-math", "dependencies": [{"name": "crossym-learn", "kind": None}]},
        {"name": "crossym-learn", "dependencies": [{"name": "crossym-math", "kind": None}]},
    ]}
    assert any("crossym-math (floor 1) depends on crossym-learn" in e
               for e in check_crates(meta)), "upward edge not caught"
    meta["packages"][0]["dependencies"] = []
    assert check_crates(meta) == [], "a downward edge was refused"
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "c" / "src"
        (src / "a").mkdir(parents=True)
        (src / "lib.rs").write_text("pub mod a;\npub mod b;\n")
        (src / "a" / "mod.rs").write_text("pub mod x;\npub mod y;\n")
        (src / "a" / "x.rs").write_text("use super::y::Y;\npub struct X;\n")
        (src / "a" / "y.rs").write_text("// use super::x::X; (a comment)\npub struct Y;\n")
        (src / "b.rs").write_text("use crate::a::{x::X, y::{self, Y}};\n")
        assert check_files("c", src)[1] == [], "a cycle where there is none"
        (src / "a" / "y.rs").write_text("pub fn f() -> crate::a::x::X { super::x::X }\n")
        errs = check_files("c", src)[1]
        assert len(errs) == 1 and "x.rs" in errs[0] and "y.rs" in errs[0], errs
        # the same cycle through the parent's re-export of X
        (src / "a" / "mod.rs").write_text("pub mod x;\npub mod y;\npub use x::X;\n")
        (src / "a" / "y.rs").write_text("use super::X;\npub struct Y;\n")
        errs = check_files("c", src)[1]
        assert len(errs) == 1 and "x.rs" in errs[0] and "y.rs" in errs[0], errs
    with tempfile.TemporaryDirectory() as d:
        # parent ↔ child: a parent that re-exports its child and whose items the child uses
        # is fine; a parent that also uses the child in its own code is a cycle
        src = Path(d) / "src"
        (src / "p").mkdir(parents=True)
        (src / "lib.rs").write_text("pub mod p;\n")
        (src / "p" / "mod.rs").write_text("mod x;\npub use x::X;\npub struct P;\n"
                                          "#[cfg(test)]\nmod tests {\n    use super::x::X;\n}\n")
        (src / "p" / "x.rs").write_text("use super::P;\npub struct X(P);\n"
                                        "#[cfg(test)]\nmod tests {\n    use super::*;\n}\n")
        assert check_files("c", src)[1] == [], "a re-export or a test module taken for an import"
        (src / "p" / "mod.rs").write_text("mod x;\npub struct P;\npub fn f() -> x::X { x::X(P) }\n")
        errs = check_files("c", src)[1]
        assert len(errs) == 1 and "p/mod.rs" in errs[0] and "p/x.rs" in errs[0], errs
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "src"
        src.mkdir()
        (src / "lib.rs").write_text("pub use crossym_control::Severity;\npub use self::a::A;\n")
        pkg = {"name": "crossym-ros", "manifest_path": str(Path(d) / "Cargo.toml")}
        errs = cross_floor_reexports(pkg)
        assert len(errs) == 1 and "re-exports crossym_control" in errs[0], errs
        (src / "lib.rs").write_text("use crossym_control::Severity;\n// pub use crossym_io::msg;\n")
        assert cross_floor_reexports(pkg) == [], "an import was taken for a re-export"
    print("selftest ok: an upward crate edge, a file cycle (direct, through a re-export, "
          "or between a parent and its child), "
          "an unused dependency and a cross-floor re-export are caught")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--selftest"]:
        sys.exit(selftest())
    sys.exit(run(Path(__file__).resolve().parent.parent))
