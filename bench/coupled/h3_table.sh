#!/usr/bin/env bash
# Scene H3 (Hartmann 2022 Sec. 5.2, pd-cube): runs configs/h3/pd_cube.yaml with
# `coupler run` and prints, at the paper's t = 12 s, max / min Green-Lagrange
# E_zz and E_xx and the max von Mises stress of the PD cube, with and without the
# particles on the cube's edges (the paper does not show those), next to the
# paper's 0.134 and 1.292 N/cm^2; then the run's wall time, status and PD
# node-steps/s (bench/coupled/pd_scene_stats.py, /usr/bin/python3 with h5py).
#
# The scene loads 10x faster than the paper (walls at -+0.1 m/s for 1.2 s, the
# same 0.12 m per side); --paper-speed runs the paper's -+0.01 m/s for 12 s.
# --free removes the scene's two departures that hold the column in line: the
# frictionless sleeves round the spheres and the pin at the cube's centre
# (without them the spheres, or the cube, are squeezed out sideways).
#
# Usage: bench/coupled/h3_table.sh [BIN] [--paper-speed] [--free] [coupler run options ...]
#   BIN: a directory holding coupler, pd_solver and dem_solver, or a build
#   directory with them in bin/ (default: <repo>/build/bin); e.g. /work/hbin.
#   Extra options go to `coupler run`, e.g. --set schedule.end_time=0.1.
#   WORK=<dir> keeps the run there (default: a new /tmp/h3-table.XXXXXX).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/bench/coupled/scene_run.sh"
bin=$(solver_bin "${1:-$root/build/bin}") || exit 2
shift || true
scale=10
v=0.1
guides=1
sets=()
while [ $# -gt 0 ]; do
  case $1 in
    --paper-speed)
      scale=1
      v=0.01
      # walls at the paper's 0.01 m/s for 12 s; snapshots every 66800 steps of 0.1 / 6680 s = 1 s
      sets+=(--set "solvers.spheres.params.walls[0].velocity=[0, 0, -0.01]"
             --set "solvers.spheres.params.walls[1].velocity=[0, 0, 0.01]"
             --set schedule.end_time=12.0
             --set solvers.cube.params.output.every=66800
             --set solvers.spheres.params.snapshots.every=66800)
      shift ;;
    --free) guides=0; shift ;;
    *) break ;;
  esac
done
if [ $guides = 0 ]; then
  sets+=(--set "solvers.cube.params.boundary=[]"
         --set "solvers.spheres.params.walls=[
    {type: plane, name: top, point: [0.15, 0.15, 0.60165], normal: [0, 0, -1], velocity: [0, 0, -$v], material: sphere},
    {type: plane, name: bottom, point: [0.15, 0.15, -0.30165], normal: [0, 0, 1], velocity: [0, 0, $v], material: sphere}]")
fi
work=${WORK:-$(mktemp -d /tmp/h3-table.XXXXXX)}
mkdir -p "$work"
run_pd_scene h3 "$root/configs/h3/pd_cube.yaml" "$scale" "${sets[@]}" "$@"
