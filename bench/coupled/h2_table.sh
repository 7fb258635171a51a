#!/usr/bin/env bash
# Scene H2 cost table (Hartmann 2022 Sec. 4.2, Table 2): runs
# configs/h2/pd_dem_multirate.yaml with dt_PD = 2.5e-5 s (the scene's) and dt_DEM = m dt_PD for
# m = 1, 2, 4, 6 (multirate, PD fine, DEM first each coarse step) and prints
# the wall time of each run, normalised by m = 1, next to the paper's times
# normalised by its monolithic run (1.27, 1.00, 0.84, 0.79 for m = 1, 2, 4, 6;
# its m = 1 staggered run over monolithic is 1.27, so its m-ratios are /1.27).
# Per-peer compute and communication come from run_report.json.
# Usage: bench/coupled/h2_table.sh [build dir] [ratios ...]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
shift || true
ratios=${*:-"1 2 4 6"}
work=$(mktemp -d /tmp/h2-table.XXXXXX)
declare -A paper=([1]="1.27" [2]="1.00" [4]="0.84" [6]="0.79")
printf "%-4s %-10s %-10s %-12s %-12s %-12s %-14s %s\n" "m" "wall [s]" "wall/m=1" "paper/1.27" "PD comp [s]" "DEM comp [s]" "comm+map [%]" "status"
base=""
for m in $ratios; do
  out=$work/m$m
  start=$(date +%s.%N)
  "$build/bin/coupler" run "$root/configs/h2/pd_dem_multirate.yaml" --set "schedule.ratio=$m" --out "$out" \
    --no-progress > "$work/m$m.log" 2>&1 || true
  wall=$(echo "$(date +%s.%N) - $start" | bc)
  [ -z "$base" ] && base=$wall
  python3 - "$out/run_report.json" "$m" "$wall" "$base" "${paper[$m]:-}" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
peers = {p["name"]: p for p in r.get("peers", [])}
comp = lambda n: peers.get(n, {}).get("compute_s", float("nan"))
m, wall, base, paper = sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
rel = "%.2f" % (float(paper) / 1.27) if paper else "-"
share = 100 * r.get("coupling_overhead_share", float("nan"))
print("%-4s %-10.2f %-10.2f %-12s %-12.2f %-12.2f %-14.1f %s" % (m, wall, wall / base, rel, comp("plate"), comp("spheres"),
      share, r.get("status")))
PY
done
echo "runs kept in $work"
