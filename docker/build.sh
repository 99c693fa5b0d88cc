#!/usr/bin/env bash
# The build steps of docker/ as a script that runs with or without a Docker engine.
#
#   bash docker/build.sh                 # from any directory
#
# With a Docker engine: `docker build -f docker/Dockerfile .` plus smoke tests of the image.
# Without one (our machines and CI) it runs every step it can and says plainly what it
# skipped:
#   [a] cargo build --release --locked --bin crossym (the `build` stage's command; set
#       CROSSYM_DOCKER_PROFILE=debug for `cargo build --locked --bin crossym`, which reuses
#       CI's debug build), then the build stage's context staged exactly as the Dockerfile
#       COPYs it (after Dockerfile.dockerignore): manifest, lock file and embedded files
#       complete (cargo fetch --locked --offline), and the staged copy compiles (cargo
#       build sharing the target directory above: seconds when the copy is complete;
#       CROSSYM_DOCKER_STAGED_BUILD=0 skips it).
#   [b] msgs/ (crossym_msgs) layout: package.xml, CMakeLists.txt, every .msg parses;
#       colcon build when colcon and ROS 2 are installed, else `colcon list`, else skipped.
#   [c] Dockerfile: every COPY source exists and passes Dockerfile.dockerignore; stages.
#   [d] compose.yaml parses (PyYAML) and its mounts/defaults exist; docker/config/rby1.toml
#       matches config/rby1.toml and loads with the built binary (vendor URDF permitting);
#       entrypoint.sh dispatches as documented (run with the built binary, ROS faked).
#   [e] hadolint, shellcheck, `docker compose config` when installed, else skipped.
# Exit status: 0 when no check failed (skips are not failures), 1 otherwise.
#
# Environment: CROSSYM_DOCKER_PROFILE (release|debug, default release), CARGO_TARGET_DIR
# (as for cargo), ROS_DISTRO (humble|jazzy|kilted: the base image, default humble; the binary
# is the same for all), CROSSYM_IMAGE (tag, default crossym:humble), CROSSYM_DOCKER_BUILD=0 (never call docker build), RBY1_URDF, PYTHON.
set -uo pipefail

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
repo="$(cd "$here/.." && pwd)"
cd "$repo" || exit 1

PY="${PYTHON:-python3}"
PROFILE="${CROSSYM_DOCKER_PROFILE:-release}"
DISTRO="${ROS_DISTRO:-humble}"
IMAGE="${CROSSYM_IMAGE:-crossym:${DISTRO}}"
work="$(mktemp -d "${TMPDIR:-/tmp}/crossym-docker.XXXXXX")"
trap 'rm -rf "$work"' EXIT

n_pass=0 n_fail=0 n_skip=0
summary=()
pass() { n_pass=$((n_pass + 1)); summary+=("PASS  $1"); echo "  ok   $1${2:+: $2}"; }
fail() { n_fail=$((n_fail + 1)); summary+=("FAIL  $1"); echo "  FAIL $1${2:+: $2}"; }
skip() { n_skip=$((n_skip + 1)); summary+=("SKIP  $1"); echo "  skip $1${2:+: $2}"; }
# Runs a checks.py check: 0 pass, 3 skip, anything else fail.
pycheck() {
    local label="$1"; shift
    "$PY" "$here/checks.py" "$@"
    case $? in
        0) pass "$label" ;;
        3) skip "$label" ;;
        *) fail "$label" ;;
    esac
}

case "$PROFILE" in
    release) cargo_profile=(--release) ;;
    debug) cargo_profile=() ;;
    *) echo "CROSSYM_DOCKER_PROFILE must be release or debug, not $PROFILE" >&2; exit 2 ;;
esac
# The default feature set, or CROSSYM_DOCKER_FEATURES (CI: `teach,security`, the set of its test
# build, which is then reused as is). The image itself is built with --no-default-features:
# without `fault-injection`, the deliberately broken filters of `crossym stress --break` (on
# by default for the CLI and the tests), and without `teach`.
cargo_features=()
if [ -n "${CROSSYM_DOCKER_FEATURES:-}" ]; then
    cargo_features=(--features "$CROSSYM_DOCKER_FEATURES")
fi

echo "== docker/build.sh: repo $repo, profile $PROFILE, ROS $DISTRO"
if ! command -v "$PY" >/dev/null 2>&1; then
    echo "error: $PY not found: the checks need Python 3" >&2
    exit 1
fi

# --- The engine ---------------------------------------------------------------------
engine=0
if [ "${CROSSYM_DOCKER_BUILD:-1}" != 0 ] && command -v docker >/dev/null 2>&1 \
    && docker info >/dev/null 2>&1; then
    engine=1
fi
echo "== docker engine"
if [ "$engine" = 1 ]; then
    args=(build -f docker/Dockerfile -t "$IMAGE" --build-arg "ROS_DISTRO=$DISTRO")
    args+=(--build-arg "CROSSYM_GIT_HASH=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)")
    echo "  docker ${args[*]} ."
    if DOCKER_BUILDKIT=1 docker "${args[@]}" .; then
        pass "docker build (image $IMAGE)"
        if docker run --rm "$IMAGE" --version; then pass "image: crossym --version"; else fail "image: crossym --version"; fi
        if docker run --rm "$IMAGE" ros2 interface show crossym_msgs/msg/SymmetryCondition >/dev/null; then
            pass "image: ros2 interface show crossym_msgs/msg/SymmetryCondition"
        else
            fail "image: ros2 interface show crossym_msgs/msg/SymmetryCondition"
        fi
        if [ -f tests/data/golden_letters/metadata.yaml ]; then
            if docker run --rm -v "$repo/tests/data/golden_letters:/bag:ro" "$IMAGE" ros2 bag info /bag; then
                pass "image: ros2 bag info on the golden crossym bag (MCAP plugin)"
            else
                fail "image: ros2 bag info on the golden crossym bag (MCAP plugin)"
            fi
        fi
    else
        fail "docker build (image $IMAGE)"
    fi
else
    if command -v docker >/dev/null 2>&1; then
        why="docker CLI present, no engine reachable (docker info failed)"
    else
        why="no docker command"
    fi
    [ "${CROSSYM_DOCKER_BUILD:-1}" = 0 ] && why="CROSSYM_DOCKER_BUILD=0"
    skip "docker build / image smoke tests" "$why: the images were NOT built"
fi

# --- [a] cargo build -------------------------------------------------------------------
echo "== [a] cargo build --locked --bin crossym ${cargo_profile[*]} ${cargo_features[*]}"
bin=""
if cargo build --locked --bin crossym "${cargo_profile[@]}" "${cargo_features[@]}" \
    --message-format=json-render-diagnostics >"$work/cargo.json"; then
    bin="$("$PY" - "$work/cargo.json" <<'PYEOF'
import json, sys
exe = ""
for line in open(sys.argv[1]):
    try:
        m = json.loads(line)
    except ValueError:
        continue
    if m.get("reason") == "compiler-artifact" and m.get("executable") \
            and m["target"]["name"] == "crossym" and "bin" in m["target"]["kind"]:
        exe = m["executable"]
print(exe)
PYEOF
)"
fi
if [ -n "$bin" ] && [ -x "$bin" ] && "$bin" --version >"$work/version" 2>&1; then
    glibc="$(objdump -T "$bin" 2>/dev/null | grep -o 'GLIBC_[0-9.]*' | sort -uV | tail -1)"
    pass "[a] cargo build ($PROFILE)" "$bin ($(cat "$work/version"), $(du -h "$bin" | cut -f1)${glibc:+, needs $glibc})"
else
    fail "[a] cargo build ($PROFILE)" "no runnable crossym binary"
    bin=""
fi

stage="$work/stage"
if "$PY" "$here/checks.py" stage "$stage" && "$PY" "$here/checks.py" embeds "$stage"; then
    host="$(rustc -vV | sed -n 's/^host: //p')"
    if (cd "$stage" && cargo fetch --locked --offline --target "$host" -q); then
        pass "[a] staged build context" "Cargo.toml parses with every declared target present, Cargo.lock is complete (--locked), embedded .msg files present"
    else
        fail "[a] staged build context" "cargo rejects the crate as the build stage sees it"
    fi
    # The staged copy compiled into the same target directory: cargo finds the artifacts
    # of the build above fresh (same relative paths, same mtimes), so this costs seconds,
    # unless a file the build needs is missing from the stage, which then fails here.
    tdir="$(cargo metadata --format-version 1 --no-deps --offline 2>/dev/null \
        | "$PY" -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')"
    if [ "${CROSSYM_DOCKER_STAGED_BUILD:-1}" = 0 ]; then
        skip "[a] cargo build of the staged context" "CROSSYM_DOCKER_STAGED_BUILD=0"
    elif [ -z "$bin" ] || [ -z "$tdir" ]; then
        skip "[a] cargo build of the staged context" "no build above to share a target directory with"
    elif (cd "$stage" && CARGO_TARGET_DIR="$tdir" \
            CROSSYM_GIT_HASH="${CROSSYM_GIT_HASH:-$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)}" \
            cargo build --locked --offline --bin crossym \
            "${cargo_profile[@]}" "${cargo_features[@]}" -q); then
        pass "[a] cargo build of the staged context" "the crate as the build stage sees it compiles (target dir $tdir)"
    else
        fail "[a] cargo build of the staged context" "the crate as the build stage sees it does not compile"
    fi
else
    fail "[a] staged build context" "could not stage the build stage's COPYs"
fi

# --- [b] msgs/ ---------------------------------------------------------------------------
echo "== [b] msgs/ (crossym_msgs)"
pycheck "[b] msgs package layout and .msg files" msgs
if command -v colcon >/dev/null 2>&1; then
    ros_setup=""
    for d in ${ROS_DISTRO:+/opt/ros/$ROS_DISTRO} /opt/ros/humble /opt/ros/jazzy; do
        if [ -f "$d/setup.bash" ]; then ros_setup="$d/setup.bash"; break; fi
    done
    if [ -n "$ros_setup" ]; then
        mkdir -p "$work/ws/src" && cp -r msgs "$work/ws/src/crossym_msgs"
        # shellcheck disable=SC1090
        if (cd "$work/ws" && set +u && source "$ros_setup" \
            && colcon --log-base "$work/colcon-log" build --merge-install --event-handlers console_direct+ \
                --cmake-args -DBUILD_TESTING=OFF) >"$work/colcon.log" 2>&1 \
            && ls "$work/ws/install/share/crossym_msgs/msg/"*.msg >/dev/null 2>&1; then
            pass "[b] colcon build of crossym_msgs" "with $ros_setup"
        else
            tail -30 "$work/colcon.log"
            fail "[b] colcon build of crossym_msgs" "with $ros_setup"
        fi
    else
        listing="$(colcon --log-base "$work/colcon-log" list --base-paths msgs 2>&1)"
        if ! colcon --log-base "$work/colcon-log" list --help >/dev/null 2>&1; then
            skip "[b] colcon list" "colcon has no list verb (pip install colcon-package-information)"
        elif printf '%s\n' "$listing" | grep -q '^crossym_msgs[[:space:]].*ament_cmake'; then
            pass "[b] colcon list identifies crossym_msgs" "$(printf '%s' "$listing" | tr '\t' ' ')"
        else
            fail "[b] colcon list identifies crossym_msgs" "got: ${listing:-nothing}"
        fi
        skip "[b] colcon build" "no ROS 2 install (/opt/ros/*/setup.bash): ament_cmake and rosidl are missing"
    fi
else
    skip "[b] colcon build" "colcon is not installed (and no ROS 2 install)"
fi

# --- [c] Dockerfile ------------------------------------------------------------------------
echo "== [c] Dockerfile"
pycheck "[c] Dockerfile COPY sources, stages, dockerignore" dockerfile

# --- [d] compose.yaml, example config, entrypoint -------------------------------------------
echo "== [d] compose.yaml, docker/config/rby1.toml, entrypoint.sh"
pycheck "[d] compose.yaml" compose
pycheck "[d] docker/config/rby1.toml vs config/rby1.toml" config
urdf="${RBY1_URDF:-$repo/robots/rby1a/model.urdf}"
if [ -z "$bin" ]; then
    skip "[d] example config loads" "no binary (see [a])"
elif [ ! -f "$urdf" ]; then
    skip "[d] example config loads" "RB-Y1 URDF $urdf absent (set RBY1_URDF)"
elif "$PY" "$here/checks.py" config-for-host "$work/rby1.toml" "$(cd "$(dirname "$urdf")" && pwd)/$(basename "$urdf")" \
    && "$bin" info --config "$work/rby1.toml" >"$work/info.log" 2>&1; then
    pass "[d] example config loads" "crossym info parses it ([node] included) and builds both 7-joint chains from $urdf"
else
    tail -5 "$work/info.log" 2>/dev/null
    fail "[d] example config loads" "crossym info --config (URDF $urdf)"
fi

if [ -z "$bin" ]; then
    skip "[d] entrypoint.sh" "no binary (see [a])"
else
    fake="$work/fake"
    mkdir -p "$fake/ros" "$fake/msgs" "$fake/bin"
    echo 'export CROSSYM_TEST_ROS=1' >"$fake/ros/setup.bash"
    echo 'export CROSSYM_TEST_MSGS=1' >"$fake/msgs/setup.bash"
    ln -s "$bin" "$fake/bin/crossym"
    ep() {
        env CROSSYM_ROS_PREFIX="$fake/ros" CROSSYM_MSGS_PREFIX="$fake/msgs" \
            ROS_LOG_DIR="$fake/log" PATH="$fake/bin:$PATH" bash "$here/entrypoint.sh" "$@"
    }
    ok=1
    ep --version | grep -q '^crossym ' || { echo "    --version did not run crossym"; ok=0; }
    [ "$(ep 2>&1)" = "$("$bin" --help 2>&1)" ] || { echo "    no arguments: not crossym --help"; ok=0; }
    # shellcheck disable=SC2016  # expanded by the inner bash, after the entrypoint sourced
    [ "$(ep bash -c 'echo "$CROSSYM_TEST_ROS$CROSSYM_TEST_MSGS"')" = 11 ] \
        || { echo "    a non-crossym command did not run in the sourced environment"; ok=0; }
    "$bin" --help >"$work/help"
    nsub=0
    for s in $("$PY" "$here/checks.py" subcommands "$work/help"); do
        nsub=$((nsub + 1))
        [ "$(ep "$s" --help 2>&1)" = "$("$bin" "$s" --help 2>&1)" ] \
            || { echo "    \`$s\` did not go to crossym"; ok=0; }
    done
    [ "$nsub" -gt 0 ] || { echo "    no subcommands found in crossym --help"; ok=0; }
    if [ -f tests/data/golden_letters/metadata.yaml ]; then
        ep bag info tests/data/golden_letters | grep -q /crossym/symmetry_condition \
            || { echo "    bag info on the golden bag failed"; ok=0; }
    fi
    if [ "$ok" = 1 ]; then
        pass "[d] entrypoint.sh" "all $nsub subcommands of crossym --help go to crossym (bag info read the golden bag), other commands run with both setup files sourced"
    else
        fail "[d] entrypoint.sh"
    fi
fi

# --- [e] linters ------------------------------------------------------------------------------
echo "== [e] linters"
if command -v hadolint >/dev/null 2>&1; then
    if hadolint docker/Dockerfile; then pass "[e] hadolint"; else fail "[e] hadolint"; fi
else
    skip "[e] hadolint" "not installed"
fi
if command -v shellcheck >/dev/null 2>&1; then
    if shellcheck docker/build.sh docker/entrypoint.sh; then pass "[e] shellcheck"; else fail "[e] shellcheck"; fi
else
    skip "[e] shellcheck" "not installed"
fi
if command -v docker >/dev/null 2>&1 && docker compose version >/dev/null 2>&1; then
    if docker compose -f docker/compose.yaml config -q; then pass "[e] docker compose config"; else fail "[e] docker compose config"; fi
else
    skip "[e] docker compose config" "no compose plugin"
fi

echo "== docker/build.sh summary"
printf '  %s\n' "${summary[@]}"
[ "$engine" = 1 ] || echo "  No Docker engine: the images were not built; the steps above are what ran."
echo "docker/build.sh: $n_pass passed, $n_fail failed, $n_skip skipped"
[ "$n_fail" = 0 ]
