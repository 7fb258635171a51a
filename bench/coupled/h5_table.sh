#!/usr/bin/env bash
# Scene H5 (Hartmann 2022 Sec. 5.4, pd-sphere-pack): runs the mixed pack
# configs/h5/pd_sphere_pack.yaml and its all-PD and all-DEM variants
# (pd_sphere_pack_all_pd.yaml, pd_sphere_pack_all_dem.yaml) with `coupler run`
# and prints the mean and max norm of the PD particles' displacement in the x-y
# plane (sideways to the loading along z) at t = 1, 2, 3 s next to the paper's
# (mixed: mean 2.35, 8.32, 11.21 cm, max 6.07, 34.26, 33.79 cm; all-PD at 3 s:
# max 32.21, mean 8.64 cm; all-DEM: no sideways motion), the DEM spheres'
# sideways displacement, each run's wall time and status and the PD
# node-steps/s (PD particles x PD steps / wall seconds; the issue's target is
# t = 3 s within 20 minutes).
#
# Usage: bench/coupled/h5_table.sh [BIN] [VARIANTS] [--coarse] [--time-scale S] [coupler run options ...]
#   BIN: a directory holding coupler, pd_solver and dem_solver, or a build
#   directory with them in bin/ (default: <repo>/build/bin); e.g. /work/hbin.
#   VARIANTS: comma-separated subset of mixed,all-pd,all-dem (default: all three).
#   --coarse: PD spheres at dx = 0.03 m (552 particles each, 8x fewer), both
#   solvers at 0.25 / 8400 s (0.985 of the coarse critical step 3.02e-5 s),
#   in the mixed and the all-PD pack; the geometry is unchanged (its gaps
#   allow dx 0.03 too).
#   --time-scale S: the walls move S times faster (S x 0.1 m/s) for 3 / S s,
#   snapshots every 0.25 / S s, and the paper's times are read at t / S. With
#   rate-independent contacts (Hertz-Mindlin, Coulomb), no damping and no
#   gravity this is the paper's scene with every density S^2 times larger
#   (mass scaling), as H3 and H4 run at 10x. S must divide the variant's
#   exchanges per 0.25 s: 12000 (mixed, all-PD), 8400 (--coarse), 8000 (all-DEM).
#   PD runs with OMP_NUM_THREADS threads (default 2: the pack's bodies are
#   shared out body by body).
#   Extra options go to every `coupler run`, e.g. a short rate measurement:
#     bench/coupled/h5_table.sh /work/hbin mixed --set schedule.end_time=0.05
#   WORK=<dir> keeps the runs there (default: a new /tmp/h5-table.XXXXXX).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
source "$root/bench/coupled/scene_run.sh"
bin=$(solver_bin "${1:-$root/build/bin}") || exit 2
shift || true
variants=mixed,all-pd,all-dem
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then variants=$1; shift; fi
coarse=0
scale=1
while [ $# -gt 0 ]; do
  case $1 in
    --coarse) coarse=1; shift ;;
    --time-scale)
      scale=${2:-}
      if ! [[ "$scale" =~ ^[1-9][0-9]*$ ]]; then
        echo "h5_table.sh: --time-scale needs a whole number (got '$scale')" >&2
        exit 2
      fi
      shift 2 ;;
    *) break ;;
  esac
done
work=${WORK:-$(mktemp -d /tmp/h5-table.XXXXXX)}
mkdir -p "$work"
for v in ${variants//,/ }; do
  case $v in
    mixed) scene=pd_sphere_pack.yaml; stats=h5 ;;
    all-pd) scene=pd_sphere_pack_all_pd.yaml; stats=h5-all-pd ;;
    all-dem) scene=pd_sphere_pack_all_dem.yaml; stats=h5-all-dem ;;
    *) echo "unknown variant '$v' (mixed, all-pd, all-dem)" >&2; exit 2 ;;
  esac
  out=$work/$v
  sets=()
  # Exchanges (steps) per 0.25 s: the PD packs run both solvers at
  # 0.25 / 12000 s, the all-DEM pack at 3.125e-5 s.
  quarter=$([ $v = all-dem ] && echo 8000 || echo 12000)
  if [ $coarse = 1 ] && [ $v != all-dem ]; then
    nb=$([ $v = mixed ] && echo 8 || echo 16)
    for ((b = 0; b < nb; ++b)); do sets+=(--set "solvers.pack.params.bodies[$b].spacing=0.03"); done
    # The scene's update at 0.25 / 8400 s (0.985 of the coarse rule's step)
    quarter=8400
    sets+=(--set schedule.dt=2.976190476190476e-5 --set schedule.ratio=1
           --set solvers.pack.params.output.every=$quarter --set solvers.dem.params.snapshots.every=$quarter)
  fi
  if [ $((quarter % scale)) != 0 ]; then
    echo "h5_table.sh: --time-scale $scale does not divide the $v run's $quarter exchanges per 0.25 s" >&2
    exit 2
  fi
  if [ "$scale" != 1 ]; then
    every=$((quarter / scale))
    speed=$(awk -v s="$scale" 'BEGIN { printf "%.10g", 0.1 * s }')
    sets+=(--set "solvers.dem.params.walls[0].velocity=[0, 0, $speed]"
           --set "solvers.dem.params.walls[1].velocity=[0, 0, -$speed]"
           --set "schedule.end_time=$(awk -v s="$scale" 'BEGIN { printf "%.10g", 3.0 / s }')"
           --set "solvers.dem.params.snapshots.every=$every")
    if [ $v != all-dem ]; then sets+=(--set "solvers.pack.params.output.every=$every"); fi
  fi
  OMP_NUM_THREADS=${OMP_NUM_THREADS:-2} "$bin/coupler" run "$root/configs/h5/$scene" --out "$out" --no-progress "${sets[@]}" "$@" \
    > "$work/$v.log" 2>&1 || echo "coupler run exited with $? (see $work/$v.log)"
  echo "== $v"
  /usr/bin/python3 "$root/bench/coupled/pd_scene_stats.py" "$stats" "$out" --label "h5 $v" --time-scale "$scale"
done
echo "runs kept in $work"
