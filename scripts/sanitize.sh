#!/usr/bin/env bash
# Builds everything with the address and undefined-behaviour sanitizers
# (build-asan/, RelWithDebInfo) and runs the tests of the given CTest labels
# (default: unit and integration).
# A finding stops its process, so its test fails and the script exits non-zero.
# Usage: scripts/sanitize.sh [LABEL-REGEX]   e.g. scripts/sanitize.sh 'unit|integration|coupled'
set -euo pipefail
cd "$(dirname "$0")/.."
labels=${1:-unit|integration}
COSIM_BUILD_DIR=build-asan COSIM_CMAKE_ARGS="-DCMAKE_BUILD_TYPE=RelWithDebInfo -DCOSIM_SANITIZE=address,undefined" \
  ./scripts/setup.sh
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
ctest --test-dir build-asan --output-on-failure -j "$(nproc 2>/dev/null || echo 2)" -L "$labels" --timeout 1800
