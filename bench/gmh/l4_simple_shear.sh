#!/usr/bin/env bash
# Scene L4, reduced (Liu, Sun, Fish 2016 Sec. 3.4): prepares a unit cell and
# its weakened variant (dem_prepare_cell --remove 25, or $L4_REMOVE), runs
# configs/gmh/l4_simple_shear.yaml on them (coupler + fem_solver + two
# dem_solver workers, one OpenMP thread each) and prints the shear response,
# the pool-mean porosity and coordination against the nominal shear strain,
# and the shear band (bench/gmh/l4_shear_band.py, /usr/bin/python3 with h5py).
# Usage: bench/gmh/l4_simple_shear.sh [spheres per cell (500)] [coarse steps (2000)] [band at gamma (0.12)]
#                                     [stop after (coarse steps)]
# The top's speed gives 20 % over the coarse steps; "stop after" ends the run
# sooner at that same speed (bench/gmh/l4_cost_ratio.sh times the first 1 %).
# A run that stops early (a cell over its relaxation budget) is still analysed up to where it got.
# Environment: COSIM_BIN (default build/bin), L4_WORK (default a fresh /tmp dir),
# L4_REMOVE (default 25, Liu's count) spheres taken out of the weakened cell:
# 25 of Liu's 4096 is 0.6 %, of a 500-sphere cell 5 %; 3 keeps Liu's share;
# L4_NONLOCAL (none) the gmh coupling's nonlocal map, e.g.
# "{radius: 0.0135, local_fraction: 0.15}" (Liu Eqs. 58-59);
# L4_ON_FAILURE (the scene's continue) the workers' on_failure: stop ends the
# run at the first cell that cannot relax (e.g. one that lost its skeleton).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${COSIM_BIN:-$root/build/bin}
count=${1:-500}
steps=${2:-2000}
at=${3:-0.12}
stop=${4:-$steps}
work=${L4_WORK:-$(mktemp -d /tmp/gmh-l4.XXXXXX)}
mkdir -p "$work"
source "$root/bench/gmh/gmh_scene.sh"
t0=$(date +%s)
remove=${L4_REMOVE:-25}
[[ "$remove" =~ ^[1-9][0-9]*$ ]] || { echo "l4_simple_shear.sh: L4_REMOVE must be a positive whole number (got '$remove')" >&2; exit 2; }
gmh_prepare_cell "$count" --remove "$remove"
t1=$(date +%s)
# 20 % nominal shear strain over the run whatever the step count (0.59 m/s at 2000 steps).
speed=$(python3 -c "import sys; print(0.2 * 0.118 / (int(sys.argv[1]) * 2e-5))" "$steps")
gmh_run "$root/configs/gmh/l4_simple_shear.yaml" --set "schedule.coarse_steps=$stop" \
  --set "solvers.block.params.boundary[1].value=$speed" \
  --set "solvers.block.params.initial_velocity={gradient: {x: [0, $(python3 -c "import sys; print(float(sys.argv[1]) / 0.118)" "$speed"), 0]}}" \
  --set "solvers.cells_a.params.unit_cells.file=$work/cell.ckpt" \
  --set "solvers.cells_b.params.unit_cells.file=$work/cell.ckpt" \
  --set "solvers.cells_b.params.unit_cells.weakened.file=$work/cell_weak.ckpt" \
  ${L4_NONLOCAL:+--set "couplings.cells.nonlocal=$L4_NONLOCAL"} \
  ${L4_ON_FAILURE:+--set "solvers.cells_a.params.unit_cells.on_failure=$L4_ON_FAILURE"} \
  ${L4_ON_FAILURE:+--set "solvers.cells_b.params.unit_cells.on_failure=$L4_ON_FAILURE"}
t2=$(date +%s)
/usr/bin/python3 "$root/bench/gmh/l4_shear_band.py" "$work/run" --at "$at"
echo "(preparation $((t1 - t0)) s, GMH run $((t2 - t1)) s; files in $work)"
