#!/usr/bin/env bash
# Self-test of the bag tools: write bags with write_bag.py, check them with
# read_bag.py, and check that read_bag.py fails on a corrupted bag.
# Usage: bash tests/bags/selftest.sh   (prints one line per step; exit 0 = OK)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
PY="${PYTHON:-python3}"
MSGS="$here/../../msgs/msg"
tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT

run() {  # name, write_bag args...
    local name="$1"; shift
    "$PY" "$here/write_bag.py" "$tmp/$name" --msgs "$MSGS" "$@" >"$tmp/$name.write.json"
    if "$PY" "$here/read_bag.py" "$tmp/$name" --json "$tmp/$name.read.json" >"$tmp/$name.log"; then
        echo "selftest: $name OK ($(tail -1 "$tmp/$name.log"))"
    else
        cat "$tmp/$name.log"; echo "selftest: $name FAILED" >&2; exit 1
    fi
}
run default
run all_topics --all-topics
run v8_zstd --all-topics --version 8 --compress zstd
run no_qos --no-qos --seconds 0.5
run long --all-topics --seconds 30

# A corrupted bag must fail: one more message claimed in metadata.yaml. It must fail on
# that count (a FAIL line of read_bag's own checks), not because read_bag crashed.
cp -r "$tmp/all_topics" "$tmp/bad"
sed -i '0,/message_count: 200/s//message_count: 201/' "$tmp/bad/metadata.yaml"
if "$PY" "$here/read_bag.py" "$tmp/bad" >"$tmp/bad.log" 2>&1; then
    cat "$tmp/bad.log"; echo "selftest: corrupted bag was NOT detected" >&2; exit 1
fi
if ! grep -q '^FAIL  metadata.yaml per-topic message counts match the MCAP file' "$tmp/bad.log" \
    || ! tail -1 "$tmp/bad.log" | grep -q '^read_bag: [0-9]* of [0-9]* checks FAILED$'; then
    cat "$tmp/bad.log"; echo "selftest: corrupted bag failed, but not on its message count" >&2; exit 1
fi
echo "selftest: corrupted bag detected OK ($(tail -1 "$tmp/bad.log"))"
