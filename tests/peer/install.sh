#!/usr/bin/env bash
# Install the Python DDS peer's requirements (idempotent; quiet). Called by .ci/run.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
want="$(sed -n 's/^cyclonedds==\([^[:space:]]*\).*/\1/p' "$here/requirements.txt")"
have="$(python3 -c 'import importlib.metadata as m; print(m.version("cyclonedds"))' 2>/dev/null || true)"
if [ -n "$want" ] && [ "$have" = "$want" ] && python3 -c 'import cyclonedds.domain' 2>/dev/null; then
  exit 0
fi
PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore \
  python3 -m pip install -q -r "$here/requirements.txt"
python3 -c 'import cyclonedds.domain' # fail loudly if the wheel (and its bundled libddsc) does not load
