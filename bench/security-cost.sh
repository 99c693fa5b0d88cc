#!/usr/bin/env bash
# What DDS Security (SROS2) costs the joint state → command round trip: `crossym ping`
# (as the robot's driver) against `crossym node --trigger joint_states`, unsecured and
# secured (sros2's governance: every RTPS message signed, every topic's data encrypted,
# AES-GCM), alternated in the same window — off, on, off, on, … — RUNS times at each rate,
# each pair in its own private network namespace (tools/netns-run).
#
#   bash bench/security-cost.sh [RUNS] [COUNT_100HZ] [COUNT_1KHZ]     (defaults 3, 3000, 10000)
#
# Secured: a keystore of the shipped policy (config/security/policy.xml) made by
# `crossym security generate-artifacts` for domain 0, the node as /crossym/node and ping as
# /crossym/mock_hw (ping publishes /joint_states and reads the command, as the mock robot;
# ROS_SECURITY_ENCLAVE_OVERRIDE, ping has no --ros-args),
# ROS_SECURITY_STRATEGY=Enforce. Prints each run (ping's median / p99 / max, µs), then per
# rate and configuration the median over runs of each statistic and the ratio on / off;
# after each run the node's own hops (DDS in, receive → control, tick, publish call).
# Needs a release build with the feature: cargo build --release --features security.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-3}
COUNT_100=${2:-3000}
COUNT_1K=${3:-10000}
CONFIG=${CONFIG:-config/letters.toml}
NETNS_RUN=${NETNS_RUN:-tools/netns-run}
BIN=${BIN:-target/release/crossym}
[ -x "$BIN" ] || { echo "error: $BIN missing: cargo build --release --features security" >&2; exit 2; }
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
KS="$out/keystore"
ROS_DOMAIN_ID=0 "$BIN" security generate-artifacts -k "$KS" -p config/security/policy.xml > /dev/null \
  || { echo "error: $BIN security failed (built without --features security?)" >&2; exit 2; }

echo "== $(date -u '+%Y-%m-%d %H:%M:%S UTC'), $(nproc) CPUs, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg); $RUNS runs per configuration and rate, alternated; $CONFIG; $($BIN --version 2>/dev/null || true)"

# run RATE COUNT on|off I: one node + ping pair; appends "RATE CFG median p99 max lost" to results.
run() {
  local rate=$1 count=$2 cfg=$3 i=$4
  local env=(env -u ROS_SECURITY_ENCLAVE_OVERRIDE -u ROS_SECURITY_ENABLE -u ROS_SECURITY_STRATEGY -u ROS_SECURITY_KEYSTORE ROS_DOMAIN_ID=0)
  local node_enclave=() ping_enclave=()
  if [ "$cfg" = on ]; then
    env+=(ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce "ROS_SECURITY_KEYSTORE=$KS")
    node_enclave=(--ros-args --enclave /crossym/node)
    ping_enclave=(env ROS_SECURITY_ENCLAVE_OVERRIDE=/crossym/mock_hw)   # ping takes no --ros-args
  fi
  local tag="$out/$rate-$cfg-$i"
  # The node stops on SIGINT (its shutdown prints its hops); killed if it has not after 5 s
  # (a SIGINT before its handler is installed is ignored: a background job of a script).
  "$NETNS_RUN" "${env[@]}" bash -c "'$BIN' node --config '$CONFIG' --trigger joint_states ${node_enclave[*]} > '$tag.node' 2>&1 & p=\$!; \
    ${ping_enclave[*]} '$BIN' ping --config '$CONFIG' --rate $rate --count $count > '$tag.ping' 2>&1; kill -INT \$p; \
    for _ in \$(seq 50); do kill -0 \$p 2>/dev/null || break; sleep 0.1; done; kill -KILL \$p 2>/dev/null; wait \$p" || true
  local line
  line=$(grep -E '^ping:' "$tag.ping" || true)
  if ! [[ $line =~ median\ ([0-9]+)\ µs,\ p99\ ([0-9]+)\ µs,\ p99.9\ ([0-9]+)\ µs,\ max\ ([0-9]+)\ µs\;\ ([0-9]+)\ lost ]]; then
    echo "error: $rate Hz security $cfg run $i: no round trips" >&2
    tail -n 20 "$tag.ping" "$tag.node" >&2
    exit 1
  fi
  local m=${BASH_REMATCH[1]} p=${BASH_REMATCH[2]} x=${BASH_REMATCH[4]} lost=${BASH_REMATCH[5]}
  local secured
  secured=$(grep -c 'DDS Security on: secured as enclave /crossym/node' "$tag.node" || true)
  if [ "$cfg" = on ] && [ "$secured" -eq 0 ]; then
    echo "error: the node did not run secured" >&2; tail -n 20 "$tag.node" >&2; exit 1
  fi
  printf '%5s Hz  security %-3s run %d: median %5d µs, p99 %5d µs, max %6d µs; %d lost of %d\n' \
    "$rate" "$cfg" "$i" "$m" "$p" "$x" "$lost" "$count"
  echo "$rate $cfg $m $p $x $lost" >> "$out/results"
  # The node's own hops (its tick is the same code secured or not; crypto is in DDS's write and receive).
  grep -E 'joint state → command hops' "$tag.node" | sed "s/^.*\]: /    node ($cfg): /" || true
}

for spec in "100 $COUNT_100" "1000 $COUNT_1K"; do
  read -r rate count <<< "$spec"
  for i in $(seq 1 "$RUNS"); do
    # Alternate which configuration goes first, so a drift in load favours neither.
    if [ $((i % 2)) -eq 1 ]; then order=(off on); else order=(on off); fi
    for cfg in "${order[@]}"; do run "$rate" "$count" "$cfg" "$i"; done
  done
done

echo "== end $(date -u '+%H:%M:%S UTC'), load $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$out/results" <<'PY'
import statistics, sys
rows = [l.split() for l in open(sys.argv[1])]
print("median over runs, µs (median / p99 / max of each run's round trips); ratio = on / off")
print("| rate | security off | security on | ratio median / p99 / max | lost off / on |")
print("|---|---|---|---|---|")
for rate in sorted({int(r[0]) for r in rows}):
    def stats(cfg):
        rs = [r for r in rows if int(r[0]) == rate and r[1] == cfg]
        return [statistics.median(float(r[k]) for r in rs) for k in (2, 3, 4)], sum(int(r[5]) for r in rs)
    off, lost_off = stats("off")
    on, lost_on = stats("on")
    label = f"{rate // 1000} kHz" if rate >= 1000 else f"{rate} Hz"
    ratio = " / ".join(f"{b / a:.2f}×" for a, b in zip(off, on))
    fmt = lambda s: " / ".join(f"{v:.0f}" for v in s)
    print(f"| {label} | {fmt(off)} | {fmt(on)} | {ratio} | {lost_off} / {lost_on} |")
PY
