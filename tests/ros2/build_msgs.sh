#!/usr/bin/env bash
# Builds the interface package crossym_msgs (msgs/) with rosidl and colcon from the PyPI
# wheels of a venv made by tests/ros2/install.sh, together with tests/ros2/tf2_msgs (the
# one tf2_msgs message the rclpy peer publishes; PyPI has no tf2_msgs wheel), into
# target/ros2/ws-DISTRO/{build,install,log} (merged install; nothing is written in msgs/).
#
#   bash tests/ros2/build_msgs.sh jazzy|kilted
#
# Up to date (a no-op) while the .msg/package files, the venv and this script are unchanged.
# Ends by importing the generated Python types in the venv. No network needed.
# Use the result without sourcing anything:
#   PYTHONPATH=target/ros2/ws-DISTRO/install/lib/python3.11/site-packages
#   LD_LIBRARY_PATH=target/ros2/ws-DISTRO/install/lib
#   AMENT_PREFIX_PATH=target/ros2/ws-DISTRO/install:target/ros2/venv-DISTRO
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
base="${CROSSYM_ROS2_DIR:-$root/target/ros2}"
d="${1:-}"
case "$d" in
    jazzy | kilted) ;;
    *) echo "usage: build_msgs.sh jazzy|kilted" >&2; exit 2 ;;
esac
venv="$base/venv-$d"
ws="$base/ws-$d"
if [ ! -f "$venv/.crossym-install" ] || [ ! -x "$venv/bin/colcon" ]; then
    echo "build_msgs.sh: no ROS 2 $d venv at $venv: run \`bash tests/ros2/install.sh $d\`" >&2
    exit 1
fi
mkdir -p "$ws"
exec 9>"$ws/.build.lock"
flock 9

pysite="$(cd "$venv" && bin/python -c 'import sysconfig; print(sysconfig.get_paths()["purelib"].split("/lib/", 1)[1])')"
want="$( (cd "$root" && find msgs tests/ros2/tf2_msgs -type f \( -name '*.msg' -o -name package.xml -o -name CMakeLists.txt \) -print0 \
          | sort -z | xargs -0 sha256sum; cat "$venv/.crossym-install" "$here/build_msgs.sh") | sha256sum | cut -d' ' -f1)"
stamp="$ws/.crossym-build"
check() {
    PYTHONPATH="$ws/install/lib/$pysite${PYTHONPATH:+:$PYTHONPATH}" \
    LD_LIBRARY_PATH="$ws/install/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" \
    AMENT_PREFIX_PATH="$ws/install:$venv" \
        "$venv/bin/python" -c '
import sys
from crossym_msgs.msg import Status, SymmetryCondition
from tf2_msgs.msg import TFMessage
from rclpy.serialization import serialize_message, deserialize_message
s = Status(code=Status.PAUSED, message="PAUSED: x", paused=True)
s.condition = SymmetryCondition(theta=0.5236, scale=0.8, reflection=-1)
r = deserialize_message(serialize_message(s), Status)
assert r == s, (r, s)
assert deserialize_message(serialize_message(TFMessage()), TFMessage) == TFMessage()
print(f"build_msgs.sh {sys.argv[1]}: crossym_msgs.msg.Status, SymmetryCondition and tf2_msgs.msg.TFMessage import and round-trip through CDR "
      f"({len(serialize_message(s))} bytes), from {sys.modules[Status.__module__].__file__}")
' "$d"
}
if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && check; then
    exit 0
fi
rm -rf "$ws/build" "$ws/install" "$ws/log" "$stamp"
t0=$SECONDS
(
    cd "$ws"
    export PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
    colcon --log-base "$ws/log" build --merge-install \
        --build-base "$ws/build" --install-base "$ws/install" \
        --paths "$root/msgs" "$here/tf2_msgs" \
        --event-handlers console_direct- \
        --cmake-args -DBUILD_TESTING=OFF "-DPython3_EXECUTABLE=$venv/bin/python3" -Wno-dev -Wno-deprecated
) || { echo "build_msgs.sh: colcon build failed; logs in $ws/log/latest_build" >&2; exit 1; }
echo "build_msgs.sh $d: built in $((SECONDS - t0)) s into $ws/install"
check
echo "$want" >"$stamp"
