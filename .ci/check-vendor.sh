#!/usr/bin/env bash
# The vendored crates (vendor/README.md) are the crates.io releases plus their patches,
# nothing else: applies each patch to the pristine source in Cargo's registry (fetched by
# any build, or here through a throw-away manifest) and compares the result with
# vendor/<crate>/src.
set -euo pipefail
cd "$(dirname "$0")/.."
registry="${CARGO_HOME:-$HOME/.cargo}/registry/src"

check() {
  local crate=$1 version=$2 pristine tmp work
  find_pristine() { find "$registry" -mindepth 2 -maxdepth 2 -type d -name "$crate-$version" 2>/dev/null | head -1; }
  pristine=$(find_pristine)
  if [ -z "$pristine" ]; then
    tmp=$(mktemp -d)
    mkdir -p "$tmp/src" && touch "$tmp/src/lib.rs"
    printf '[package]\nname = "fetch"\nversion = "0.0.0"\nedition = "2021"\n[dependencies]\n%s = { version = "=%s", default-features = false }\n' \
      "$crate" "$version" > "$tmp/Cargo.toml"
    (cd "$tmp" && cargo fetch -q)
    pristine=$(find_pristine)
  fi
  work=$(mktemp -d)
  cp -r "$pristine/src" "$work/src"
  (cd "$work" && patch -p1 -s --no-backup-if-mismatch < "$OLDPWD/vendor/$crate.patch")
  if ! diff -r "$work/src" "vendor/$crate/src"; then
    echo "error: vendor/$crate/src differs from $crate $version + vendor/$crate.patch" >&2
    rm -rf "$work"
    exit 1
  fi
  rm -rf "$work"
  echo "vendor/$crate = $crate $version + vendor/$crate.patch ($(grep -c '^+[^+]' "vendor/$crate.patch") added lines)"
}

check rustdds 0.15.1
check ros2-client 0.12.1
check clarabel 0.11.1
