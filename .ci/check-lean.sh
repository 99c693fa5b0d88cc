#!/usr/bin/env bash
# The real-time node links only what it runs (docs/ARCHITECTURE.md): the control floor's
# dependency tree holds no training stack (candle), figures (plotters, image) or dataset
# readers (Parquet, SQLite), and the default `crossym` binary (the node, the demo, every
# robot-side command; what `cargo run --release -- demo` builds) no training stack or
# dataset reader. The check first shows it can fail: with `--features teach` the same
# search must find them.
set -euo pipefail
cd "$(dirname "$0")/.."

# Packages found in a dependency tree (normal edges, the target's own platform).
found() { # <banned regex> <cargo tree args...>
  local banned=$1
  shift
  cargo tree -q --offline -e normal --prefix none "$@" | awk '{print $1}' | sort -u | grep -E "^($banned)$" || true
}

control_banned='candle-core|candle-nn|gemm|plotters|image|parquet|rusqlite|libsqlite3-sys'
binary_banned='candle-core|candle-nn|gemm|parquet|rusqlite|libsqlite3-sys'

# Self-test: the teaching build has them (else this check could not see them come back).
if [ -z "$(found "$binary_banned" -p crossym --features teach)" ]; then
  echo "error: check-lean self-test: cargo tree -p crossym --features teach shows none of $binary_banned" >&2
  exit 1
fi

rc=0
bad=$(found "$control_banned" -p crossym-control)
if [ -n "$bad" ]; then
  echo "error: crossym-control (the node's control floor) depends on: $(echo "$bad" | tr '\n' ' ')" >&2
  echo "       (cargo tree -p crossym-control -e normal -i <crate> shows the path)" >&2
  rc=1
fi
bad=$(found "$binary_banned" -p crossym)
if [ -n "$bad" ]; then
  echo "error: the default crossym binary depends on: $(echo "$bad" | tr '\n' ' ') (only --features teach may)" >&2
  echo "       (cargo tree -p crossym -e normal -i <crate> shows the path)" >&2
  rc=1
fi
[ "$rc" -eq 0 ] && echo "lean: crossym-control has none of $control_banned; the default crossym binary none of $binary_banned"
exit "$rc"
