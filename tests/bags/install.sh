#!/usr/bin/env bash
# Install the Python tools of tests/bags (idempotent, quiet).
# Usage: bash tests/bags/install.sh   (exit 0 when every import works)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PY="${PYTHON:-python3}"

# Exit 0 when every pinned "name==version" in requirements.txt is installed.
have_all() {
    "$PY" - "$here/requirements.txt" <<'PYEOF'
import sys
from importlib.metadata import version, PackageNotFoundError
bad = []
for line in open(sys.argv[1]):
    line = line.split('#', 1)[0].strip()
    if not line:
        continue
    name, want = line.split('==')
    try:
        got = version(name)
    except PackageNotFoundError:
        got = None
    if got != want:
        bad.append(f'{name}: have {got}, want {want}')
if bad:
    print('tests/bags: installing: ' + '; '.join(bad), file=sys.stderr)
    sys.exit(1)
PYEOF
}

if ! have_all 2>/dev/null; then
    have_all || true   # say what is missing
    "$PY" -m pip install -q --disable-pip-version-check --root-user-action=ignore \
        -r "$here/requirements.txt"
fi

if ! "$PY" - <<'PYEOF'
import rosbags, mcap, mcap_ros2, yaml, numpy
from rosbags.rosbag2 import Writer, Reader, StoragePlugin, CompressionMode
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore, get_types_from_msg
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
import pyarrow, pyarrow.parquet
PYEOF
then
    echo "tests/bags/install.sh: FAILED: the bag tools do not import (see above)" >&2
    exit 1
fi
