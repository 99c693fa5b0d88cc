#!/usr/bin/env bash
# The vendored RustDDS (vendor/README.md) is the crates.io release plus vendor/rustdds.patch,
# nothing else: applies the patch to the pristine source in Cargo's registry (fetched by
# any build) and compares the result with vendor/rustdds/src.
set -euo pipefail
cd "$(dirname "$0")/.."
VERSION=0.15.1
registry="${CARGO_HOME:-$HOME/.cargo}/registry/src"
find_pristine() { find "$registry" -mindepth 2 -maxdepth 2 -type d -name "rustdds-$VERSION" 2>/dev/null | head -1; }
pristine=$(find_pristine)
if [ -z "$pristine" ]; then
  # Not in the registry yet: fetch it (the crate is a dependency of nothing else here, so
  # download it through a throw-away manifest).
  tmp=$(mktemp -d)
  mkdir -p "$tmp/src" && touch "$tmp/src/lib.rs"
  printf '[package]\nname = "fetch"\nversion = "0.0.0"\nedition = "2021"\n[dependencies]\nrustdds = "=%s"\n' "$VERSION" > "$tmp/Cargo.toml"
  (cd "$tmp" && cargo fetch -q)
  pristine=$(find_pristine)
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp -r "$pristine/src" "$work/src"
(cd "$work" && patch -p1 -s --no-backup-if-mismatch < "$OLDPWD/vendor/rustdds.patch")
if ! diff -r "$work/src" vendor/rustdds/src; then
  echo "error: vendor/rustdds/src differs from RustDDS $VERSION + vendor/rustdds.patch" >&2
  exit 1
fi
echo "vendor/rustdds = RustDDS $VERSION + vendor/rustdds.patch ($(grep -c '^+[^+]' vendor/rustdds.patch) added lines)"
