#!/usr/bin/env bash
# Scene C2, case 1P, loading (a) (Cheng 2022 Sec. 6.2.2, Fig. 21): runs
# configs/c2/wave_volume_1p.yaml for the CG widths of Table 5 with
# `coupler run` and prints the dissipation ratio dE/E at the end (the
# wave-stations analysis: E the weighted solver energies, the penalty's
# left out, E_0 the kicked layer's kinetic energy) next to the paper's, and
# the station waveform error when the full-DEM reference
# (configs/c2/wave_full_dem_1p.yaml) is run first, which this script does.
# Usage: bench/coupled/c2_table.sh [build dir] [widths in m ...]
#   C2_DT=<s> runs both solvers at another step (the scene's is 1.6e-5 s);
#   C2_PENALTY=<Pa/m^2> another penalty (the scene's is 1e10, Table 6).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
shift || true
widths=${*:-"0.0 0.2 0.4 0.6 0.8 1.0"}
work=$(mktemp -d /tmp/c2-table.XXXXXX)
sets=()
if [ -n "${C2_DT:-}" ]; then sets+=(--set "schedule.dt=$C2_DT" --set "solvers.dem.params.dt=$C2_DT"); fi
if [ -n "${C2_PENALTY:-}" ]; then sets+=(--set "couplings.volume.penalty=$C2_PENALTY"); fi
"$build/bin/coupler" run "$root/configs/c2/wave_full_dem_1p.yaml" --out "$work/reference" --no-progress \
  ${C2_DT:+--set "schedule.dt=$C2_DT" --set "solvers.dem.params.dt=$C2_DT"} > "$work/reference.log" 2>&1 ||
  { echo "c2_table.sh: the full-DEM reference failed (see $work/reference.log)" >&2; exit 1; }
declare -A paper=([0.0]="33.5" [0.6]="29.5")
printf "%-8s %-8s %-14s %-12s %-14s %-10s %s\n" "c [m]" "c/dX" "dE/E [%]" "paper [%]" "stations [%]" "wall [s]" "status"
for c in $widths; do
  out=$work/out$c
  start=$(date +%s.%N)
  "$build/bin/coupler" run "$root/configs/c2/wave_volume_1p.yaml" --out "$out" --no-progress \
    --set "couplings.volume.width=$c" --set "analysis.reference_run=$work/reference/coupler.h5" "${sets[@]}" \
    > "$out.log" 2>&1 || true
  wall=$(echo "$(date +%s.%N) - $start" | bc)
  /usr/bin/python3 - "$out/run_report.json" "$c" "${paper[$c]:--}" "$wall" <<'PY'
import json, sys
try:
    r = json.load(open(sys.argv[1]))
except (OSError, ValueError):
    r = {"status": "no report"}
ok = r.get("status") == "completed"
fig = r.get("figures", {})
err = next((e["value"] for e in r.get("errors", []) if e["name"] == "station_velocity_rms_error"), None)
c = float(sys.argv[2])
print("%-8s %-8.1f %-14s %-12s %-14s %-10.1f %s" % (
    sys.argv[2], c / 0.4, "%.1f" % (100 * fig["dissipation_ratio"]) if ok else "-", sys.argv[3],
    "%.1f" % (100 * err) if ok and err is not None else "-", float(sys.argv[4]),
    r.get("status", "?") if ok else "%s: %s" % (r.get("status"), r.get("message", "")[:100])))
PY
done
echo "runs kept in $work"
