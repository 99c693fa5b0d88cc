#!/usr/bin/env bash
# Install PyPI example-robot-data (URDFs of Baxter, TIAGo, Talos, G1, Solo12, ANYmal C, Go2, …)
# for tests/integration/morpho_robots.rs. Idempotent; --no-deps: only the robot files are
# needed (the package's Python loader wants pinocchio, which the tests do not use).
# Usage: bash tests/robots/install.sh   (exit 0 when the robots directory exists)
set -euo pipefail
PY="${PYTHON:-python3}"
want=6.0.0
have=$("$PY" -c "from importlib.metadata import version; print(version('example-robot-data'))" 2>/dev/null || true)
if [ "$have" != "$want" ]; then
    echo "tests/robots: installing example-robot-data==$want (have: ${have:-none})" >&2
    "$PY" -m pip install -q --disable-pip-version-check --root-user-action=ignore --no-deps \
        "example-robot-data==$want"
fi
dir="$("$PY" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")/cmeel.prefix/share/example-robot-data/robots"
if [ ! -f "$dir/solo_description/robots/solo12.urdf" ]; then
    echo "tests/robots/install.sh: FAILED: $dir has no robots" >&2
    exit 1
fi
