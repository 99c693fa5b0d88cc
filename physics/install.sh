#!/usr/bin/env bash
# Install the physics robot's requirements (idempotent; quiet). Fails loudly if mujoco,
# cyclonedds or numpy do not import afterwards.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
req="$here/requirements.txt"
ok=1
while read -r pkg want; do
  have="$(python3 -c "import importlib.metadata as m; print(m.version('$pkg'))" 2>/dev/null || true)"
  [ "$have" = "$want" ] || ok=0
done < <(sed -n 's/^\([A-Za-z0-9_.-]*\)==\([^[:space:]]*\).*/\1 \2/p' "$req")
if [ "$ok" = 1 ] && python3 -c 'import mujoco, numpy, cyclonedds.domain' 2>/dev/null; then
  exit 0
fi
PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore \
  python3 -m pip install -q -r "$req"
# fail loudly if a wheel (MuJoCo's engine, Cyclone's bundled libddsc) does not load
python3 -c 'import mujoco; import numpy; import cyclonedds.domain; print("physics: mujoco", mujoco.__version__)'
