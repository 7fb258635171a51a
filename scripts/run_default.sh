#!/usr/bin/env bash
# Sets everything up and runs the default scene through the coupler.
# The default is still configs/demo/two_mocks.yaml: two scripted mock solvers
# (no physics) that exercise launch, handshake, lockstep exchange, output and
# the run report. The DEM solver issue replaces it with a real DEM scene.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
scene=${1:-configs/demo/two_mocks.yaml}
echo "running $scene (the default scene is a two-mock demo: no physics yet)"
./build/bin/coupler run "$scene" --out runs/default
echo "output: runs/default/coupler.h5 and runs/default/run_report.json"
