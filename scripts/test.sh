#!/usr/bin/env bash
# Sets everything up (warnings are errors) and runs every test with CTest.
set -euo pipefail
cd "$(dirname "$0")/.."
export COSIM_WERROR=ON
./scripts/setup.sh
ctest --test-dir build --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" --timeout 600 "$@"
