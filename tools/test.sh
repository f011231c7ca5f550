#!/usr/bin/env bash
# The whole test suite (GoogleTest through CTest); exits non-zero when a test fails.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
nonholo_build
ctest --test-dir "$NONHOLO_BUILD" --output-on-failure -j "$(nproc)"
