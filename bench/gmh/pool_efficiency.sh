#!/usr/bin/env bash
# Parallel efficiency of the GMH worker pool (issue: at least 90 % with 2
# workers against 1). The same run twice: a 2 x 2 x 1 block of one-point
# elements (4 unit cells, prepared by dem_prepare_cell) compressed for N
# coarse steps, the 4 cells held by one dem_solver worker, then by two (2 each).
# efficiency = T_1 / (2 T_2) over the exchange loops.
# Usage: bench/gmh/pool_efficiency.sh [coarse steps (200)] [spheres per cell (100)]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
steps=${1:-200}
count=${2:-100}
work=$(mktemp -d /tmp/gmh-pool.XXXXXX)
"$root/build/bin/dem_prepare_cell" --out "$work/cell" --count "$count" --seed 3 > "$work/prepare.log"
scene() {  # $1 = workers spec lines, $2 = worker names
  cat <<YAML
scene: gmh-pool
schedule: {kind: multirate, fine: [$2], dt: 2.0e-5, ratio: 1, order: coarse-first, coarse_steps: $steps}
solvers:
  - name: block
    kind: fem
    params:
      mesh: {box: {min: [0, 0, 0], max: [0.02, 0.02, 0.01], divisions: [2, 2, 1]}}
      material: {model: external, E: 1.0e8, nu: 0.2, density: 1600}
      formulation: one-point
      sets:
        everything: {box: {min: [-1, -1, -1], max: [1, 1, 1]}}
        bottom: {box: {min: [-1, -1, -0.0001], max: [1, 1, 0.0001]}}
        top: {box: {min: [-1, -1, 0.0099], max: [1, 1, 0.0101]}}
      boundary:
        - {set: everything, dofs: [x, y], value: 0.0}
        - {set: bottom, dofs: [z], value: 0.0}
        - {set: top, dofs: [z], value: -1.0e-3, kind: velocity}
      integrator: {type: central-difference}
$1
couplings:
  - {name: cells, kind: gmh, fem: block, workers: [$2]}
YAML
}
worker() {  # name first count
  printf "  - name: %s\n    kind: dem\n    params:\n      unit_cells: {file: %s, first_id: %s, count: %s, max_steps: 100000, load_steps: 20}\n" \
    "$1" "$work/cell.ckpt" "$2" "$3"
}
scene "$(worker w0 0 4)" "w0" > "$work/one.yaml"
scene "$(worker w0 0 2; worker w1 2 2)" "w0, w1" > "$work/two.yaml"
loop() { python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['wall_s']['exchange_loop'])" "$1/run_report.json"; }
"$root/build/bin/coupler" run "$work/one.yaml" --out "$work/one" --no-progress > "$work/one.log" 2>&1
"$root/build/bin/coupler" run "$work/two.yaml" --out "$work/two" --no-progress > "$work/two.log" 2>&1
t1=$(loop "$work/one"); t2=$(loop "$work/two")
echo "GMH pool, 4 cells of $count spheres, $steps coarse steps:"
echo "  1 worker : exchange loop $t1 s"
echo "  2 workers: exchange loop $t2 s"
python3 -c "import sys; t1, t2 = map(float, sys.argv[1:]); print(f'  parallel efficiency T1 / (2 T2) = {t1 / (2 * t2):.1%} (target >= 90 %)')" "$t1" "$t2"
echo "  (runs in $work)"
