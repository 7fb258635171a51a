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
source "$root/bench/coupled/scene_run.sh"
bin=$(solver_bin "${1:-$root/build/bin}") || exit 2
shift || true
scale=10
sets=()
if [ "${1:-}" = "--paper-speed" ]; then
  shift
  scale=1
  # pusher at the paper's 0.01 m/s for 22.15 s; snapshots every 3340 steps of 0.005 / 334 s = 0.05 s
  sets=(--set "solvers.spheres.params.particles[0].sphere.velocity=[0, 0, -0.01]"
        --set schedule.end_time=22.15
        --set solvers.body.params.output.every=3340)
fi
work=${WORK:-$(mktemp -d /tmp/h4-table.XXXXXX)}
mkdir -p "$work"
run_pd_scene h4 "$root/configs/h4/pd_squeeze.yaml" "$scale" "${sets[@]}" "$@"
