#!/usr/bin/env bash
# Install the linters docker/build.sh runs (idempotent; quiet): shellcheck and hadolint,
# from PyPI wheels that carry the upstream binaries (no Docker, no apt). Called by .ci/run.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
req="$here/requirements-lint.txt"
if command -v shellcheck >/dev/null 2>&1 && command -v hadolint >/dev/null 2>&1; then
  exit 0
fi
PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_ROOT_USER_ACTION=ignore \
  python3 -m pip install -q -r "$req"
shellcheck --version >/dev/null
hadolint --version >/dev/null
