#!/usr/bin/env bash
# Installs ROS 2's rclpy with Fast DDS (rmw_fastrtps_cpp, ROS 2's default middleware) and the
# rosidl/colcon toolchain that builds crossym_msgs, from PyPI wheels, into one venv per
# distribution: target/ros2/venv-jazzy, target/ros2/venv-kilted. No ROS installation and no
# network once it has finished.
#
#   bash tests/ros2/install.sh [jazzy] [kilted]     (default: both)
#
# Idempotent: a venv whose stamp matches the requirements file and this script is left
# alone (a fast no-op); otherwise it is made again from scratch. Then:
#   - the pinned, complete tests/ros2/requirements-DISTRO.txt is installed with --no-deps;
#   - the wheels' CMake configs name include directories of their build machine
#     (/opt/python/cp311-cp311/include/python3.11 and its numpy include); they are
#     rewritten, inside the venv only, to this Python's and the venv's numpy's;
#   - a self-check (tests/ros2/selfcheck.py) runs inside a private network namespace
#     ($NETNS_RUN, default tools/netns-run): rclpy initialises with
#     rmw_fastrtps_cpp and a node receives its own message.
# Environment: CROSSYM_ROS2_DIR (default target/ros2), NETNS_RUN, PIP_* as usual.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
base="${CROSSYM_ROS2_DIR:-$root/target/ros2}"
netns="${NETNS_RUN:-$root/tools/netns-run}"
export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore

distros=("$@")
[ "${#distros[@]}" -gt 0 ] || distros=(jazzy kilted)
for d in "${distros[@]}"; do
    case "$d" in
        jazzy | kilted) ;;
        *) echo "install.sh: unknown distribution \`$d\` (jazzy, kilted)" >&2; exit 2 ;;
    esac
done

mkdir -p "$base"
# One install at a time (CI may start it twice; tests read the venvs).
exec 9>"$base/.install.lock"
flock 9

for d in "${distros[@]}"; do
    venv="$base/venv-$d"
    req="$here/requirements-$d.txt"
    stamp="$venv/.crossym-install"
    want="$(cat "$req" "$here/install.sh" "$here/selfcheck.py" | sha256sum | cut -d' ' -f1)"
    if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ] && [ -x "$venv/bin/python" ]; then
        echo "ros2 $d: $venv is up to date"
        continue
    fi
    t0=$SECONDS
    echo "ros2 $d: installing into $venv"
    rm -rf "$venv"
    python3 -m venv "$venv"
    py="$venv/bin/python"
    "$py" -m pip install -q --no-deps -r "$req"
    "$py" -m pip check >/dev/null || { "$py" -m pip check >&2; exit 1; }

    # The wheels were built in a manylinux container whose Python lived in
    # /opt/python/cp311-cp311; their exported CMake targets (rosidl_generator_py) name its
    # include directories. Point them at this Python's headers and the venv's numpy.
    pyinc="$("$py" -c 'import sysconfig; print(sysconfig.get_paths()["include"])')"
    npinc="$("$py" -c 'import numpy; print(numpy.get_include())')"
    if [ ! -f "$pyinc/Python.h" ]; then
        echo "install.sh: $pyinc/Python.h is missing: the Python development headers are needed to build crossym_msgs" >&2
        exit 1
    fi
    [ -f "$npinc/numpy/arrayobject.h" ] || { echo "install.sh: no numpy headers in $npinc" >&2; exit 1; }
    mapfile -t files < <(grep -rlF --include='*.cmake' '/opt/python/' "$venv/share" "$venv/lib" 2>/dev/null || true)
    if [ "${#files[@]}" -gt 0 ]; then
        sed -i -E \
            -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/lib/python3\.[0-9]+/site-packages/numpy/_core/include#$npinc#g" \
            -e "s#/opt/python/cp3[0-9]+-cp3[0-9]+/include/python3\.[0-9]+#$pyinc#g" \
            "${files[@]}"
    fi
    if left="$(grep -rlF --include='*.cmake' '/opt/python/' "$venv/share" "$venv/lib" 2>/dev/null)"; then
        echo "install.sh: CMake files still naming /opt/python after the rewrite:" >&2
        echo "$left" >&2
        exit 1
    fi
    echo "ros2 $d: ${#files[@]} CMake files rewritten to $pyinc and $npinc"

    if [ ! -x "$netns" ]; then
        echo "install.sh: $netns is missing (set NETNS_RUN): the self-check opens a DDS participant and runs only in a private network namespace" >&2
        exit 1
    fi
    "$netns" "$py" "$here/selfcheck.py" "$d"
    echo "$want" >"$stamp"
    echo "ros2 $d: installed in $((SECONDS - t0)) s"
done
