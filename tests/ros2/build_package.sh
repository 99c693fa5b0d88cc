#!/usr/bin/env bash
# Builds the ROS 2 packages crossym_msgs (msgs/) and crossym (ros/crossym/, the ament_cmake
# wrapper that runs cargo) with colcon from the PyPI wheels of a venv made by
# tests/ros2/install.sh, in a workspace target/ros2/pkg-DISTRO/ whose src/ holds symlinks
# to both (named with --paths: the venv's colcon has no --base-paths crawl), with build/,
# install/ and log/ inside it (isolated install, as a plain `colcon build` makes it),
# then checks the install:
#   - install/crossym/lib/crossym/crossym --version runs (where `ros2 run` looks);
#   - share/crossym/launch/rby1.launch.py is there and compiles;
#   - every installed config loads with its URDF (`crossym info --config`), and every relative
#     path in it (URDF, policies, MuJoCo model) resolves inside share/crossym/, except the
#     demonstrations ../data/lasa (offline training only, not installed);
#   - the ament index names crossym (share/ament_index/resource_index/packages/crossym);
#   - tests/ros2/launch_args.py (the launch file with stub launch/launch_ros modules) gives
#     the command launch_ros would run, with the defaults and with namespace:=robot1.
#
#   bash tests/ros2/build_package.sh jazzy|kilted
#
# cargo builds with CROSSYM_CARGO_PROFILE=dev into the repository's target/, so after the
# usual `cargo build` there is nothing to compile. CROSSYM_MSGS_UNDERLAY=DIR (a prefix holding
# crossym_msgs, e.g. build_msgs.sh's merged install target/ros2/ws-DISTRO/install):
# crossym_msgs is taken from there instead of being built again, and only crossym is built
# (it only exec-depends on crossym_msgs); .ci/run does this. No network needed; ros2 run / ros2 launch
# are not run (no ros2 CLI and no launch_ros on PyPI).
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/../.." && pwd)"
base="${CROSSYM_ROS2_DIR:-$root/target/ros2}"
d="${1:-}"
case "$d" in
    jazzy | kilted) ;;
    *) echo "usage: build_package.sh jazzy|kilted" >&2; exit 2 ;;
esac
venv="$base/venv-$d"
ws="$base/pkg-$d"
if [ ! -f "$venv/.crossym-install" ] || [ ! -x "$venv/bin/colcon" ]; then
    echo "build_package.sh: no ROS 2 $d venv at $venv: run \`bash tests/ros2/install.sh $d\`" >&2
    exit 1
fi
mkdir -p "$ws/src"
exec 9>"$ws/.build.lock"
flock 9
ln -sfn "$root/msgs" "$ws/src/crossym_msgs"
ln -sfn "$root/ros/crossym" "$ws/src/crossym"

paths=("$ws/src/crossym_msgs" "$ws/src/crossym")
msgs_install="$ws/install/crossym_msgs"
if [ -n "${CROSSYM_MSGS_UNDERLAY:-}" ]; then
    msgs_install="$CROSSYM_MSGS_UNDERLAY"
    [ -f "$msgs_install/share/ament_index/resource_index/packages/crossym_msgs" ] || {
        echo "build_package.sh: no crossym_msgs in CROSSYM_MSGS_UNDERLAY=$CROSSYM_MSGS_UNDERLAY: run \`bash tests/ros2/build_msgs.sh $d\`" >&2
        exit 1
    }
    paths=("$ws/src/crossym")
fi

t0=$SECONDS
(
    cd "$ws"
    export PATH="$venv/bin:$PATH" AMENT_PREFIX_PATH="$venv" CMAKE_PREFIX_PATH="$venv"
    colcon --log-base "$ws/log" build \
        --paths "${paths[@]}" --build-base "$ws/build" --install-base "$ws/install" \
        --event-handlers console_direct- \
        --cmake-args -DBUILD_TESTING=OFF "-DPython3_EXECUTABLE=$venv/bin/python3" \
            -DCROSSYM_CARGO_PROFILE=dev "-DCROSSYM_CARGO_FEATURES=${CROSSYM_CARGO_FEATURES:-}" --no-warn-unused-cli -Wno-dev -Wno-deprecated
) || { echo "build_package.sh: colcon build failed; logs in $ws/log/latest_build" >&2; exit 1; }
echo "build_package.sh $d: colcon built $(basename -a "${paths[@]}" | tr '\n' ' ')in $((SECONDS - t0)) s into $ws/install (crossym_msgs from $msgs_install)"

fail() { echo "build_package.sh $d: FAIL: $*" >&2; exit 1; }
prefix="$ws/install/crossym"
share="$prefix/share/crossym"
exe="$prefix/lib/crossym/crossym"

[ -x "$exe" ] || fail "$exe is missing"
version="$("$exe" --version)" || fail "$exe --version failed"
echo "ok: $exe --version: $version"

launch="$share/launch/rby1.launch.py"
[ -f "$launch" ] || fail "$launch is missing"
PYTHONPYCACHEPREFIX="$ws/pycache" "$venv/bin/python" -m py_compile "$launch" || fail "$launch does not compile"
echo "ok: $launch compiles"

marker="$prefix/share/ament_index/resource_index/packages/crossym"
[ -f "$marker" ] || fail "$marker is missing"
[ -f "$msgs_install/share/ament_index/resource_index/packages/crossym_msgs" ] ||
    fail "crossym_msgs is not in the ament index of $msgs_install"
echo "ok: the ament index names crossym and crossym_msgs"

[ -f "$share/config/ros/crossym.params.yaml" ] || fail "share/crossym/config/ros/crossym.params.yaml is missing"
shopt -s nullglob
configs=("$share"/config/*.toml)
[ "${#configs[@]}" -gt 0 ] || fail "no configs in $share/config"
for c in "${configs[@]}"; do
    "$exe" info --config "$c" >/dev/null || fail "crossym info --config $c"
    while IFS= read -r rel; do
        case "$rel" in ../data/lasa/*) continue ;; esac
        [ -e "$share/config/$rel" ] || fail "$c names $rel: not installed"
    done < <(grep -o '"\.\./[^"]*"' "$c" | tr -d '"' | sort -u)
done
echo "ok: ${#configs[@]} installed configs load (crossym info) and their relative paths resolve in $share"

# The launch file through stub launch/launch_ros modules: the command launch_ros would run.
launch_args() {
    AMENT_PREFIX_PATH="$prefix:$msgs_install" "$venv/bin/python" "$here/launch_args.py" "$@"
}
got="$(launch_args 2>"$ws/launch_args.err")" || { cat "$ws/launch_args.err" >&2; fail "launch_args.py"; }
[ ! -s "$ws/launch_args.err" ] || { cat "$ws/launch_args.err" >&2; fail "launch_args.py (defaults) warned or set an environment variable"; }
want="$("$venv/bin/python" -c 'import json, sys; print(json.dumps(sys.argv[1:]))' \
    "$exe" node --config "$share/config/rby1-letters.toml" \
    --ros-args -r __node:=crossym -r __ns:=/ --params-file "$share/config/ros/crossym.params.yaml")"
[ "$got" = "$want" ] || fail "launch command (defaults): $got, expected $want"
echo "ok: launch (defaults): $(launch_args --shell)"
got="$(launch_args namespace:=robot1 ros_distro:="$d" 2>"$ws/launch_args.err")" || fail "launch_args.py namespace:=robot1"
want="${want/__ns:=\//__ns:=/robot1}"
[ "$got" = "$want" ] || fail "launch command (namespace:=robot1): $got, expected $want"
grep -qx "env: ROS_DISTRO=$d" "$ws/launch_args.err" || fail "ros_distro:=$d does not set ROS_DISTRO"
echo "ok: launch namespace:=robot1 ros_distro:=$d gives __ns:=/robot1 and ROS_DISTRO=$d"
echo "build_package.sh $d: all checks passed in $((SECONDS - t0)) s"
