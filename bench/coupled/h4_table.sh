#!/usr/bin/env bash
# Scene H4 (Hartmann 2022 Sec. 5.3, pd-squeeze): runs configs/h4/pd_squeeze.yaml
# with `coupler run` and prints max |u_x| at the paper's t = 7.5, 17.5, 22.15 s
# and max u_z (paper: 4.6, 17.6, 24.6 cm; 7.6 cm at 17.5 s), the body's extent
# and whether it ended up between (slipped through) the two supports; then the
# run's wall time, status and PD node-steps/s (bench/coupled/pd_scene_stats.py).
#
# The scene pushes 10x faster than the paper (0.1 m/s for 2.215 s, the same
# 0.2215 m); --paper-speed runs the paper's 0.01 m/s for 22.15 s.
#
# Usage: bench/coupled/h4_table.sh [BIN] [--paper-speed] [coupler run options ...]
#   BIN: a directory holding coupler, pd_solver and dem_solver, or a build
#   directory with them in bin/ (default: <repo>/build/bin); e.g. /work/hbin.
#   WORK=<dir> keeps the run there (default: a new /tmp/h4-table.XXXXXX).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${1:-$root/build/bin}
shift || true
[ -x "$bin/bin/coupler" ] && bin=$bin/bin
[ -x "$bin/coupler" ] || { echo "no coupler in $bin (nor $bin/bin)" >&2; exit 2; }
scale=10
sets=()
if [ "${1:-}" = "--paper-speed" ]; then
  shift
  scale=1
  # pusher at the paper's 0.01 m/s for 22.15 s; snapshots every 1600 coarse steps = 0.05 s
  sets=(--set "solvers.spheres.params.particles[0].sphere.velocity=[0, 0, -0.01]"
        --set schedule.end_time=22.15
        --set solvers.body.params.output.every=1600)
fi
work=${WORK:-$(mktemp -d /tmp/h4-table.XXXXXX)}
mkdir -p "$work"
out=$work/h4
OMP_NUM_THREADS=${OMP_NUM_THREADS:-1} "$bin/coupler" run "$root/configs/h4/pd_squeeze.yaml" --out "$out" --no-progress \
  "${sets[@]}" "$@" > "$work/h4.log" 2>&1 || echo "coupler run exited with $? (see $work/h4.log)"
/usr/bin/python3 "$root/bench/coupled/pd_scene_stats.py" h4 "$out" --time-scale "$scale" --label "h4 (x$scale speed)"
echo "run kept in $out"
