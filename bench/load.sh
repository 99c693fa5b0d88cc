#!/usr/bin/env bash
# The node on a loaded computer: the RB-Y1 drawing against the MuJoCo robot (`crossym demo
# --plant mujoco`, the vendor model, position servos, gravity) with the CPUs free and under
# `stress-ng --cpu N` (N busy threads, default one per CPU: perception and logging at their
# worst), each with and without `[node] realtime` (SCHED_FIFO 80, memory locked, DDS threads
# at 79). Prints, per run: the node's tick start after its time (median / p99 / max), its
# late and missed ticks, the tick's own duration, the physics robot's limit violations,
# torque-limit time and late physics steps, and the demo's verdict.
#
#   bash bench/load.sh [SECONDS] [CPU_HOGS]          (defaults 20, nproc)
#   ONLY_RTT=1 bash bench/load.sh                    (the round trips only)
#
# Then the joint state → command round trip under the same load against Cyclone DDS's own
# ddsperf in the same window (bench/latency-vs-ddsperf.sh at 100 Hz, the RB-Y1's rate).
# Needs: a release build, stress-ng (Debian), the physics robot (bash physics/install.sh),
# ddsperf (Debian's cyclonedds-tools), root or CAP_SYS_NICE for the real-time runs. Every
# DDS process runs in its own private network namespace (tools/netns-run).
set -euo pipefail
cd "$(dirname "$0")/.."
SECS=${1:-20}
HOGS=${2:-$(nproc)}
BIN=${BIN:-target/release/crossym}
NETNS_RUN=${NETNS_RUN:-tools/netns-run}
command -v stress-ng >/dev/null || { echo "error: stress-ng not found (apt install stress-ng)" >&2; exit 2; }
[ -x "$BIN" ] || { echo "error: $BIN missing: cargo build --release" >&2; exit 2; }
out=$(mktemp -d)
hog=""
trap '[ -n "$hog" ] && kill "$hog" 2>/dev/null; true' EXIT

echo "== $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg); $SECS s of the letter per run; $(git rev-parse --short HEAD 2>/dev/null || echo '?')"

# config/rby1-letters.toml with absolute paths, and `realtime` in [node] when asked.
config() {
  local rt=$1 cfg="$out/rby1-$1.toml"
  sed -e "s#\"\\.\\./robots/#\"$PWD/robots/#g" -e "s#\"\\.\\./data/#\"$PWD/data/#g" config/rby1-letters.toml >"$cfg"
  if [ "$rt" = rt ]; then
    python3 - "$cfg" <<'EOF'
import sys
p = sys.argv[1]
s = open(p).read()
assert "[node]\n" in s
s = s.replace("[node]\n", "[node]\nrealtime = { priority = 80, lock_memory = true, dds_priority = 79 }\n", 1)
open(p, "w").write(s)
EOF
  fi
  echo "$cfg"
}

start_load() {
  if [ "$1" = load ]; then
    stress-ng --cpu "$HOGS" --timeout 0 --quiet &
    hog=$!
    sleep 1
  fi
}

stop_load() {
  if [ -n "$hog" ]; then
    kill "$hog" 2>/dev/null || true
    wait "$hog" 2>/dev/null || true
    hog=""
  fi
}

if [ -z "${ONLY_RTT:-}" ]; then
printf '\n| load | realtime | tick start after its time (median / p99 / max) | late / missed ticks (of all) | tick median / p99 / max (µs) | limit violations | torque-limit time (s) | late physics steps | demo |\n|---|---|---|---|---|---|---|---|---|\n'
for load in free load; do
  for rt in plain rt; do
    cfg=$(config "$rt")
    dir="$out/$load-$rt"
    start_load "$load"
    set +e
    "$NETNS_RUN" "$BIN" demo --no-isolation --plant mujoco --config "$cfg" --out "$dir" \
      --duration-s "$SECS" --condition 0.5235987755982988:1:1 >"$dir.txt" 2>&1
    set -e
    stop_load
    python3 - "$dir" "$load" "$rt" "$HOGS" <<'EOF'
import json, re, sys
d, load, rt, hogs = sys.argv[1:]
log = open(f"{d}/node.log").read()
late = re.search(r"tick start after its time: median (\d+) µs, p99 (\d+) µs, max (\d+) µs \((\d+) samples\); (\d+) tick\(s\) more than half a period late, (\d+) never ran", log)
tick = re.search(r"stopped: (\d+) ticks.*tick median ([\d.]+) µs, p99 ([\d.]+) µs, max ([\d.]+) µs", log)
s = json.load(open(f"{d}/mock_hw_summary.json"))
torque = max((v for v in (s.get("torque_limit_time_s") or {}).values() if isinstance(v, (int, float))), default=0.0)
verdict = "OK" if "demo: OK" in open(d + ".txt").read() else "FAILED"
print(f"| {'stress-ng --cpu ' + hogs if load == 'load' else 'none'} | {'SCHED_FIFO 80' if rt == 'rt' else 'no'} | "
      + (f"{late[1]} / {late[2]} / {late[3]} µs | {late[5]} / {late[6]} (of {late[4]}) | " if late else "– | – | ")
      + (f"{tick[2]} / {tick[3]} / {tick[4]} | " if tick else "– | ")
      + f"{s['violation_count']} | {torque:.3f} | {s.get('late_iterations', '–')} | {verdict} |")
EOF
  done
done
echo "(runs in $out)"
fi

rtt() {
  bash bench/latency-vs-ddsperf.sh 100 2000 | grep -E '^ddsperf|^ping:|^ratio'
}
echo
echo "== round trip at 100 Hz: without stress-ng; under stress-ng --cpu $HOGS; under it with realtime"
rtt
start_load load
rtt
CONFIG=bench/letters-realtime.toml PING_ARGS="--realtime 90" rtt
stop_load
