#!/usr/bin/env bash
# The transport anchor: Cyclone DDS's own ddsperf ping/pong and crossym's joint state →
# command round trip (`crossym ping` + `crossym node --trigger joint_states`), in the same
# window, at the same rate, one after the other, each pair in its own private network
# namespace; prints both and their ratio.
#
#   bash bench/latency-vs-ddsperf.sh [RATE_HZ] [COUNT]        (defaults 100, 3000)
#
# What ddsperf reports (src/tools/ddsperf/ddsperf.c, process_pong): the ping stamps each
# sample with its send time, pong writes it back with that stamp, and ping records
# (t_receive − t_send) / 2 — HALF the round trip. Its lines are per second (the statistics
# reset after each print): "mean, min, 50 %, 90 %, 99 %, max" of that second's samples.
# Here: ddsperf's round trip = 2 × its figures; its median = the median of the per-second
# medians, its p99 = the largest per-second 99 %, its max = the largest per-second max. At
# 100 Hz a second holds 100 samples and ddsperf's "99 %" of them is their maximum: its p99
# is then the run's maximum, and only the medians and maxima compare (1 kHz: all three).
# crossym ping reports whole round trips over all probes (nearest rank).
#
# Payload and QoS matched to the order of magnitude: ddsperf's default keyed topic (KS,
# sequence of octets) at 256 bytes, reliable, keep last 1 (ping/pong's own setting);
# crossym's JointState of the config's joints (≈ 250 bytes for 8 joints) best effort in,
# Float64MultiArray reliable out. Needs: ddsperf (Debian's cyclonedds-tools), a release
# build (cargo build --release), tools/netns-run.
set -euo pipefail
cd "$(dirname "$0")/.."
RATE=${1:-100}
COUNT=${2:-3000}
CONFIG=${CONFIG:-config/letters.toml}   # e.g. a copy with [node] realtime = { … }
PING_ARGS=${PING_ARGS:-}                 # e.g. --realtime 90
NETNS_RUN=${NETNS_RUN:-tools/netns-run}
BIN=${BIN:-target/release/crossym}
command -v ddsperf >/dev/null || { echo "error: ddsperf not found (apt install cyclonedds-tools)" >&2; exit 2; }
[ -x "$BIN" ] || { echo "error: $BIN missing: cargo build --release" >&2; exit 2; }
DUR=$(python3 -c "import math; print(math.ceil($COUNT / $RATE) + 2)")
out=$(mktemp -d)

echo "== $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg); $RATE Hz, $COUNT round trips each; $CONFIG $PING_ARGS"

# 1. ddsperf: pong in the background, ping for DUR s.
"$NETNS_RUN" bash -c "ddsperf pong > '$out/pong.txt' 2>&1 & p=\$!; sleep 1; \
  ddsperf -D $DUR ping ${RATE}Hz size 256 > '$out/ping.txt' 2>&1; kill \$p" || true
python3 - "$out/ping.txt" "$RATE" > "$out/ddsperf.txt" <<'PY'
import re, statistics, sys
lines = [l for l in open(sys.argv[1]) if " mean " in l and "us" in l]
pat = re.compile(r"mean ([\d.]+)us min ([\d.]+)us 50% ([\d.]+)us 90% ([\d.]+)us 99% ([\d.]+)us max ([\d.]+)us cnt (\d+)")
rows = [tuple(map(float, m.groups())) for m in map(pat.search, lines) if m]
# The first second includes discovery: dropped.
rows = rows[1:]
if not rows:
    print("ddsperf: no statistics"); sys.exit(1)
med = statistics.median(r[2] for r in rows)
p99 = max(r[4] for r in rows)
mx = max(r[5] for r in rows)
cnt = int(sum(r[6] for r in rows))
print(f"ddsperf {cnt} round trips: as printed (half round trips) median {med:.1f} us, p99 {p99:.1f} us, max {mx:.1f} us; "
      f"round trip median {2*med:.1f} us, p99 {2*p99:.1f} us, max {2*mx:.1f} us")
print(f"RTT {2*med:.3f} {2*p99:.3f} {2*mx:.3f}")
PY
grep -v '^RTT' "$out/ddsperf.txt"

# 2. crossym: the node triggered by joint states, ping as the robot's driver.
"$NETNS_RUN" bash -c "'$BIN' node --config '$CONFIG' --trigger joint_states > '$out/node.txt' 2>&1 & p=\$!; \
  '$BIN' ping --config '$CONFIG' --rate $RATE --count $COUNT $PING_ARGS > '$out/crossym.txt' 2>&1; kill -INT \$p; wait \$p" || true
grep -E '^ping:|^  ' "$out/crossym.txt" || { cat "$out/crossym.txt"; exit 1; }
grep -E 'joint state → command hops' "$out/node.txt" | sed 's/^.*\]: /node: /' || true

python3 - "$out/ddsperf.txt" "$out/crossym.txt" <<'PY'
import re, sys
d = [l for l in open(sys.argv[1]) if l.startswith("RTT ")][0].split()[1:]
dm, dp, dx = map(float, d)
c = open(sys.argv[2]).read()
m = re.search(r"median (\d+) µs, p99 (\d+) µs, p99.9 (\d+) µs, max (\d+) µs; (\d+) lost", c)
cm, cp, cx, lost = float(m.group(1)), float(m.group(2)), float(m.group(4)), int(m.group(5))
print(f"ratio crossym / ddsperf round trip: median {cm/dm:.2f}x, p99 {cp/dp:.2f}x, max {cx/dx:.2f}x; crossym lost {lost}")
PY
rm -rf "$out"
