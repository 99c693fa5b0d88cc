#!/usr/bin/env bash
# Clone → `demo: OK` as a newcomer runs it (README): a fresh clone of REPO (default: this
# checkout's HEAD) into a new directory, then `cargo run --release -- demo` there, timed
# per step with the wall clock. Crates come from cargo's local registry cache (a first
# download is not timed: it depends on the network). Prints the breakdown and, with
# --timings, leaves cargo's per-unit report in <clone>/target/cargo-timings/.
#
#   bash bench/clone-to-demo.sh [REPO] [EXTRA CARGO FLAGS...]   (e.g. --features teach)
#
# The demo opens DDS participants: run this inside a private network namespace
# (tools/netns-run) or let the demo isolate itself (it does as root or in a user namespace).
set -euo pipefail
repo=${1:-$(cd "$(dirname "$0")/.." && pwd)}
shift || true
dir=$(mktemp -d /tmp/crossym-clone-XXXXXX)
now() { date +%s.%N; }
t0=$(now)
git clone -q "$repo" "$dir/crossym"
t1=$(now)
cd "$dir/crossym"
# The build, then the run, separately timed (cargo run would build first).
/usr/bin/time -f '%U %S' -o "$dir/cpu" cargo build --release --timings "$@" 2>"$dir/build.log"
t2=$(now)
cargo run --release -q "$@" -- demo >"$dir/demo.log" 2>&1 || true
t3=$(now)
ok=no
grep -q '^demo: OK$' "$dir/demo.log" && ok=yes
read -r user sys <"$dir/cpu"
printf 'clone→demo: %s (commit %s, %s, %s cores, load %s at the end)\n' \
  "$(date -u +%FT%TZ)" "$(git rev-parse --short HEAD)" "${*:-default features}" "$(nproc)" \
  "$(cut -d' ' -f1 /proc/loadavg)"
printf '  git clone            %6.1f s\n' "$(echo "$t1 - $t0" | bc)"
printf '  cargo build --release %6.1f s  (CPU: %.0f s user + %.0f s system)\n' \
  "$(echo "$t2 - $t1" | bc)" "$user" "$sys"
printf '  crossym demo         %6.1f s  (demo: OK: %s)\n' "$(echo "$t3 - $t2" | bc)" "$ok"
printf '  total                %6.1f s\n' "$(echo "$t3 - $t0" | bc)"
echo "  logs and timings: $dir"
[ "$ok" = yes ]
