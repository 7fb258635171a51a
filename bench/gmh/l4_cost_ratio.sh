#!/usr/bin/env bash
# GMH against direct DEM for scene L4 reduced (Liu, Sun, Fish 2016 Sec. 3.4:
# 22 h multiscale against about a month of direct DEM, about 33 x). Both runs
# on this machine's cores, over the same shear strain at the same nominal rate
# (5 1/s: the L4 scene's 0.59 m/s over 0.118 m):
#   GMH: bench/gmh/l4_simple_shear.sh stopped after N coarse steps (1e-4 shear
#        strain each): coupler + fem_solver + two dem_solver workers of 30 cells
#        (one thread each); its exchange loop's wall time;
#   direct DEM: bench/gmh/l4_direct_dem, the same 60 cells' spheres (the cell
#        tiled 5 x 12 x 1, the weakened one in its element) as one periodic
#        sample sheared over the same strain at the cells' fine step, on as many
#        OpenMP threads as the GMH run has workers.
# Prints both wall times per 1 % shear strain and their ratio.
# Usage: bench/gmh/l4_cost_ratio.sh [coarse steps (100 = 1 % shear)] [spheres per cell (500)]
# Environment: COSIM_BIN (default build/bin), L4_WORK (default a fresh /tmp dir;
# cells already prepared there are prepared again).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin=${COSIM_BIN:-$root/build/bin}
steps=${1:-100}
count=${2:-500}
work=${L4_WORK:-$(mktemp -d /tmp/gmh-l4-cost.XXXXXX)}
mkdir -p "$work"
export L4_WORK=$work COSIM_BIN=$bin
"$root/bench/gmh/l4_simple_shear.sh" "$count" 2000 0.12 "$steps" > "$work/gmh.log" 2>&1 || true
source "$root/bench/gmh/gmh_scene.sh"
loop=$(gmh_exchange_loop "$work/run")
strain=$(/usr/bin/python3 -c "import sys; print(int(sys.argv[1]) * 1e-4)" "$steps")
OMP_NUM_THREADS=2 "$bin/l4_direct_dem" --cell "$work/cell.ckpt" --weak "$work/cell_weak.ckpt" --strain "$strain" \
  > "$work/direct.log" 2>&1
cat "$work/direct.log"
/usr/bin/python3 - "$loop" "$strain" "$work/direct.log" <<'PY'
import sys
gmh_loop, strain = float(sys.argv[1]), float(sys.argv[2])
direct = next(float(l.split()[1]) for l in open(sys.argv[3]) if l.startswith("direct_dem_wall_per_percent"))
gmh = gmh_loop / (strain / 0.01)
print(f"GMH (60 cells, 2 workers): {gmh_loop:.1f} s exchange loop over shear strain {strain:.4g}: {gmh:.2f} s per 1 %")
print(f"direct DEM (same spheres, 2 threads): {direct:.2f} s per 1 %")
print(f"cost ratio direct / GMH: {direct / gmh:.2f} (paper: about 33, 22 h against about a month)")
PY
echo "(files in $work)"
