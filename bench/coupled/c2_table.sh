#!/usr/bin/env bash
# Scene C2, case 1P, loading (a) (Cheng 2022 Sec. 6.2.2, Fig. 21): runs
# configs/c2/wave_volume_1p.yaml for the CG widths of Table 5 with
# `coupler run` and prints the dissipation ratio dE/E at the end next to the
# paper's. E0 is the initial kinetic energy of the loaded layer (4 particles,
# v = 0.1 m/s, w = 1); E_end the weighted solver energies of the final reply
# (run_report.json; the penalty energy is left out).
# Until `coupler sweep --set` exists, each width is a sed-edited copy.
# Usage: bench/coupled/c2_table.sh [build dir] [widths in m ...]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
shift || true
widths=${*:-"0.0 0.2 0.4 0.6 0.8 1.0"}
# dt as in the scene file unless C2_DT is set
work=$(mktemp -d /tmp/c2-table.XXXXXX)
declare -A paper=([0.0]="33.5" [0.6]="29.5")
printf "%-8s %-8s %-14s %-12s %-10s %s\n" "c [m]" "c/dX" "dE/E [%]" "paper [%]" "wall [s]" "status"
for c in $widths; do
  scene=$work/c$c.yaml
  sed -e "s/^    width: .*/    width: $c/" -e "s|dir: runs/c2-wave-volume-1p|dir: $work/out$c|" "$root/configs/c2/wave_volume_1p.yaml" > "$scene"
  if [ -n "${C2_DT:-}" ]; then sed -i "s/3.2e-5/$C2_DT/g" "$scene"; fi
  start=$(date +%s.%N)
  "$build/bin/coupler" run "$scene" --out "$work/out$c" --no-progress > "$work/c$c.log" 2>&1 || true
  wall=$(echo "$(date +%s.%N) - $start" | bc)
  python3 - "$work/out$c/run_report.json" "$c" "${paper[$c]:--}" "$wall" <<'PY'
import json, math, sys
r = json.load(open(sys.argv[1]))
e = r.get("final_energies_J", {})
m = 2500 * 4.0 / 3.0 * math.pi * 0.2 ** 3
e0 = 0.5 * 4 * m * 0.1 ** 2
end = sum(e.get(k, 0.0) for k in ("dem.kinetic", "dem.elastic", "fem.kinetic", "fem.strain", "fem.hourglass"))
status = r.get("status", "?")
ratio = "%.1f" % (100 * (e0 - end) / e0) if status == "completed" else "-"
c = float(sys.argv[2])
print("%-8s %-8.1f %-14s %-12s %-10.1f %s" % (sys.argv[2], c / 0.4, ratio, sys.argv[3], float(sys.argv[4]), status))
PY
done
echo "runs kept in $work"
