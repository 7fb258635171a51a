#!/usr/bin/env bash
# Sets everything up and runs the default scene through the coupler: a Hertz
# collision of two spheres in dem_solver (configs/dem/hertz_collision.yaml).
# Another scene can be given as the first argument.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
scene=${1:-configs/dem/hertz_collision.yaml}
echo "running $scene"
./build/bin/coupler run "$scene" --out runs/default
echo "output in runs/default: coupler.h5 (series), run_report.json, and each solver's own HDF5 + XDMF snapshots"
