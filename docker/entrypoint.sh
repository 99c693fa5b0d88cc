#!/usr/bin/env bash
# Entry point of the crossym image: sources ROS 2 and the crossym_msgs overlay, then
#   - runs `crossym ARGS...` when the first argument is one of crossym's subcommands or an
#     option (`node --config /config/rby1.toml`, `bag info /runs/x`, `--help`, ...): the
#     binary itself decides (`crossym help SUBCOMMAND` succeeds only for its subcommands);
#   - otherwise runs the command as given (`ros2 topic pub ...`, `ros2 bag play ...`, `bash`).

# The setup scripts read unset variables: no `set -u` before sourcing them.
set -e
ROS_DISTRO="${ROS_DISTRO:-humble}"
# (CROSSYM_ROS_PREFIX only lets docker/build.sh try this script outside the image.)
# shellcheck disable=SC1090,SC1091
source "${CROSSYM_ROS_PREFIX:-/opt/ros/${ROS_DISTRO}}/setup.bash"
# shellcheck disable=SC1091
source "${CROSSYM_MSGS_PREFIX:-/opt/crossym_msgs}/setup.bash"
mkdir -p "${ROS_LOG_DIR:-/tmp/ros_log}" 2>/dev/null || true

if [ "$#" -eq 0 ]; then
    exec crossym --help
fi
case "$1" in
    -*) exec crossym "$@" ;;
esac
if crossym help "$1" >/dev/null 2>&1; then
    exec crossym "$@"
fi
exec "$@"
