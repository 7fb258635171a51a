#!/usr/bin/env bash
# Sets everything up and runs the default scene through the coupler: scene C1
# (Cheng 2022 Sec. 6.1), two particles sliding on an elastic cantilever with
# the CG-enriched surface coupling at c = 10 d (configs/c1/cantilever_surface.yaml;
# fem_solver + dem_solver, about 2 minutes on 2 cores), then plots it.
# Another scene can be given as the first argument (no plot then).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
scene=${1:-configs/c1/cantilever_surface.yaml}
echo "running $scene"
./build/bin/coupler run "$scene" --out runs/default
if [ "$scene" = configs/c1/cantilever_surface.yaml ]; then
  echo "plots:"
  /usr/bin/python3 scripts/plot_c1.py runs/default || echo "(plotting needs python3-h5py and python3-matplotlib)"
fi
echo "output in runs/default: coupler.h5 (series), run_report.json, and each solver's own HDF5 + XDMF output"
for x in runs/default/*.xmf; do
  [ -e "$x" ] && echo "  ParaView: paraview $x   (File > Open; Apply, then play the time steps)"
done
true
