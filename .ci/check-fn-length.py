#!/usr/bin/env python3
"""No production function longer than MAX lines (docs/ARCHITECTURE.md, "Conventions"): every
`fn` of the workspace's crates and the application (src/, crates/*/src/), test modules,
test files and vendored crates excluded; a function's length runs from its `fn` line to
its closing brace. The exceptions are listed in ALLOWED with why.

    python3 .ci/check-fn-length.py [--selftest]
"""
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from importlib import import_module  # noqa: E402

layers = import_module("check-layers")
MAX = 80
# path suffix :: function → why it may be longer.
ALLOWED = {
    "crates/crossym-control/src/safety/active_set.rs::solve":
        "the active-set QP solver: one algorithm, its loop reads as the textbook's",
}


def functions(code):
    """(name, first line, line count) of every `fn` with a body in `code` (comments and
    literals already emptied)."""
    out = []
    for m in re.finditer(r"\bfn\s+(\w+)", code):
        # the body starts at the first `{` after the signature, unless a `;` comes first
        # (a trait method without a body)
        j = m.end()
        depth_paren = 0
        while j < len(code):
            c = code[j]
            if c in "(<[":
                depth_paren += 1
            elif c in ")>]":
                depth_paren -= 1
            elif c == ";" and depth_paren <= 0:
                j = -1
                break
            elif c == "{" and depth_paren <= 0:
                break
            j += 1
        if j < 0 or j >= len(code):
            continue
        depth, k = 1, j + 1
        while k < len(code) and depth:
            depth += {"{": 1, "}": -1}.get(code[k], 0)
            k += 1
        first = code.count("\n", 0, m.start()) + 1
        last = code.count("\n", 0, k) + 1
        out.append((m.group(1), first, last - first + 1))
    return out


def long_functions(root):
    files = sorted((root / "src").rglob("*.rs")) + sorted((root / "crates").glob("*/src/**/*.rs"))
    found, allowed_seen = [], set()
    for f in files:
        if f.name == "tests.rs" or f.name.endswith("_tests.rs"):
            continue
        code = layers.strip_test_modules(layers.code_only(f.read_text()))
        rel = f.relative_to(root).as_posix()
        for name, line, n in functions(code):
            if n > MAX and f"{rel}::{name}" in ALLOWED:
                allowed_seen.add(f"{rel}::{name}")
            elif n > MAX:
                found.append(f"{rel}:{line}: fn {name} is {n} lines (at most {MAX})")
    found += [f"{a}: allowed to be long but no longer is (or gone): drop it from ALLOWED"
              for a in sorted(set(ALLOWED) - allowed_seen)]
    return found


def selftest():
    code = layers.code_only("fn a() {\n    let s = \"}\";\n}\ntrait T { fn b(&self); }\n"
                            "fn c<T: Fn() -> u8>(f: T) -> Vec<u8> where T: Copy {\n" + "x;\n" * 90 + "}\n")
    fs = functions(code)
    assert [(n, c) for n, _, c in fs] == [("a", 3), ("c", 92)], fs
    print("selftest ok: a function's length counted from `fn` to its brace, bodiless trait "
          "methods and braces in strings skipped")
    return 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--selftest"]:
        sys.exit(selftest())
    errors = long_functions(Path(__file__).resolve().parent.parent)
    if errors:
        print("\n".join(f"error: {e}" for e in errors), file=sys.stderr)
        sys.exit(1)
    print(f"no production function over {MAX} lines (exceptions: {', '.join(ALLOWED)})")
