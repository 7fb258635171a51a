#!/usr/bin/env bash
# Scene L3, reduced (Liu, Sun, Fish 2016 Sec. 3.3): prepares a unit cell
# (dem_prepare_cell, seed 1, 416 kPa), runs configs/gmh/l3_wave_column.yaml on
# it (coupler + fem_solver + two dem_solver workers of 5 cells each, one
# OpenMP thread each) and prints the stress-strain loops, porosity and
# coordination number of element 9's cell and writes the figure
# (bench/gmh/l3_wave_column.py, /usr/bin/python3 with h5py and matplotlib).
# Usage: bench/gmh/l3_wave_column.sh [spheres per cell (500)] [coarse steps of 1 us (1000)] [element (8)]
# Fewer coarse steps run the first part of the 1 ms only. A run that stops
# early (a cell over its relaxation budget) is still analysed up to where it got.
# Environment: COSIM_BIN (default build/bin), L3_WORK (default a fresh /tmp dir).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${COSIM_BIN:-$root/build/bin}
count=${1:-500}
steps=${2:-1000}
element=${3:-8}
work=${L3_WORK:-$(mktemp -d /tmp/gmh-l3.XXXXXX)}
mkdir -p "$work"
source "$root/bench/gmh/gmh_scene.sh"
t0=$(date +%s)
gmh_prepare_cell "$count"
t1=$(date +%s)
gmh_run "$root/configs/gmh/l3_wave_column.yaml" --set "schedule.coarse_steps=$steps" \
  --set "solvers.cells_a.params.unit_cells.file=$work/cell.ckpt" \
  --set "solvers.cells_b.params.unit_cells.file=$work/cell.ckpt"
t2=$(date +%s)
/usr/bin/python3 "$root/bench/gmh/l3_wave_column.py" "$work/run" --element "$element"
echo "(preparation $((t1 - t0)) s, GMH run $((t2 - t1)) s; files in $work)"
