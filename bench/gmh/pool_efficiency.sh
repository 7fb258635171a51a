#!/usr/bin/env bash
# Parallel efficiency of the GMH worker pool (issue: at least 90 % with 2
# workers against 1). The same run twice: a 2 x 2 x 1 block of one-point
# elements (4 unit cells, prepared by dem_prepare_cell) compressed for N
# coarse steps, the 4 cells held by one dem_solver worker, then by two (2 each).
# efficiency = T_1 / (2 T_2) over the exchange loops.
# Usage: bench/gmh/pool_efficiency.sh [coarse steps (200)] [spheres per cell (100)]
#                                     [axial strain per coarse step (2e-6)] [load steps per job (20)] [repeats (3)]
# Each run is repeated and the shortest exchange loop kept (best of N): on a
# shared machine other users' load only ever adds time.
# Job size grows with the spheres (cost per cell step) and with the strain
# increment (more relaxation steps per job); the round trip per exchange does not.
set -euo pipefail
# One OpenMP thread per worker unless told otherwise: the efficiency compares one
# worker with two, and two workers of N threads each would share the cores of one.
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-1}
root=$(cd "$(dirname "$0")/../.." && pwd)
steps=${1:-200}
count=${2:-100}
strain=${3:-2e-6}
load=${4:-20}
repeats=${5:-3}
# The top face moves at v = strain x height / dt (height 0.01 m, dt 2e-5 s).
velocity=$(python3 -c "import sys; print(-float(sys.argv[1]) * 0.01 / 2.0e-5)" "$strain")
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
        - {set: top, dofs: [z], value: $velocity, kind: velocity}
      integrator: {type: central-difference}
$1
couplings:
  - {name: cells, kind: gmh, fem: block, workers: [$2]}
YAML
}
worker() {  # name first count
  printf "  - name: %s\n    kind: dem\n    params:\n      unit_cells: {file: %s, first_id: %s, count: %s, max_steps: 100000, load_steps: %s}\n" \
    "$1" "$work/cell.ckpt" "$2" "$3" "$load"
}
scene "$(worker w0 0 4)" "w0" > "$work/one.yaml"
scene "$(worker w0 0 2; worker w1 2 2)" "w0, w1" > "$work/two.yaml"
source "$root/bench/gmh/gmh_scene.sh"
t1=; t2=
for r in $(seq "$repeats"); do  # alternate, so a burst of outside load hits both alike
  "$root/build/bin/coupler" run "$work/one.yaml" --out "$work/one$r" --no-progress > "$work/one$r.log" 2>&1
  "$root/build/bin/coupler" run "$work/two.yaml" --out "$work/two$r" --no-progress > "$work/two$r.log" 2>&1
  t1="$t1 $(gmh_exchange_loop "$work/one$r")"; t2="$t2 $(gmh_exchange_loop "$work/two$r")"
done
best() { python3 -c "import sys; print(min(map(float, sys.argv[1:])))" $1; }
t1=$(best "$t1"); t2=$(best "$t2")
# Machine ceiling: the same CPU-bound program (a 100-sphere preparation), once
# alone and twice at once. On two free cores the pair takes as long as one; on
# a shared machine it does not, and no pool can beat t_alone / t_pair.
now() { date +%s.%N; }
ctl() { "$root/build/bin/dem_prepare_cell" --out "$work/ctl$1" --count 100 --seed 3 > /dev/null; }
since() { python3 -c "import sys,time; print(time.time() - float(sys.argv[1]))" "$1"; }
ta=; tp=
for r in $(seq "$(( repeats < 2 ? repeats : 2 ))"); do
  s=$(now); ctl a; ta="$ta $(since "$s")"
  s=$(now); ctl b & ctl c; wait; tp="$tp $(since "$s")"
done
ta=$(best "$ta"); tp=$(best "$tp")
echo "GMH pool, 4 cells of $count spheres, $steps coarse steps of axial strain $strain, $load load steps per job, $OMP_NUM_THREADS thread(s) per worker:"
echo "  1 worker : exchange loop $t1 s (best of $repeats) ($(python3 -c "import sys; print(f'{1e3 * float(sys.argv[1]) / (4 * int(sys.argv[2])):.2f}')" "$t1" "$steps") ms per job)"
echo "  2 workers: exchange loop $t2 s"
python3 -c "import sys; t1, t2, ta, tp = map(float, sys.argv[1:]); e = t1 / (2 * t2); c = ta / tp
print(f'  parallel efficiency T1 / (2 T2) = {e:.1%} (target >= 90 %)')
print(f'  machine ceiling: one CPU-bound process {ta:.2f} s alone, two at once {tp:.2f} s: {c:.1%}; efficiency / ceiling = {e / c:.1%}')" "$t1" "$t2" "$ta" "$tp"
echo "  (runs in $work)"
