#!/usr/bin/env bash
# Scene H2 (Hartmann 2022 Sec. 4.2, Table 2): runs configs/h2/pd_dem_multirate.yaml
#   * once monolithic-equivalent (equal steps, DEM first, PD Verlet: the
#     reference curve), then
#   * with dt_PD = 2.5e-5 s (the scene's) and dt_DEM = m dt_PD for m = 1, 2, 4, 6
#     (staggered multi-rate: PD fine with its staggered integrator, DEM first
#     each coarse step; m = 1 is the staggered scheme of Eqs. 46-47),
# and prints for each run its force-displacement error against the
# monolithic curve (RMS of the force over the run, relative to the peak; the
# paper asks for 2 %), the final force at 2 mm, the wall time normalised by
# m = 1 next to the paper's times normalised by its monolithic run
# (1.27, 1.00, 0.84, 0.79 for m = 1, 2, 4, 6; its m = 1 staggered run over
# monolithic is 1.27, so its m-ratios are /1.27), and each peer's compute.
# Each m runs twice: with the contact forces held over PD's sub-steps (the
# paper's Alg. 2) and linearised (pd-dem-contact `forces: linearised`: PD
# follows each force with the contact stiffness DEM sends). The cost column
# the issue judges is wall / monolithic (targets: m = 1 at most 1.05, m = 6
# at most 0.5).
# Usage: bench/coupled/h2_table.sh [build dir] [ratios ...]
#   FORCES="held linearised" (default both) picks the force treatments.
#   REPEAT=N (default 1) runs each case N times and reports the least wall
#   time: on a shared machine single runs of these 10-20 s jobs spread by
#   +-30 %, and the least is the one other processes disturbed least.
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
shift || true
ratios=${*:-"1 2 4 6"}
forces=${FORCES:-"held linearised"}
repeat=${REPEAT:-1}
[[ "$repeat" =~ ^[1-9][0-9]*$ ]] || { echo "h2_table.sh: REPEAT must be a positive whole number (got '$repeat')" >&2; exit 2; }
work=$(mktemp -d /tmp/h2-table.XXXXXX)
scene=$root/configs/h2/pd_dem_multirate.yaml
declare -A paper=([1]="1.27" [2]="1.00" [4]="0.84" [6]="0.79")

run() {  # run NAME [--set ...]: the least wall seconds of $repeat runs on stdout
  # Each try runs into its own folder; the fastest one becomes $work/NAME, so
  # the compute columns and the error come from the run whose wall is shown.
  local name=$1
  shift
  local start wall best="" try
  for ((k = 0; k < repeat; ++k)); do
    try=$work/$name.try$k
    start=$(date +%s.%N)
    "$build/bin/coupler" run "$scene" --out "$try" --no-progress "$@" > "$try.log" 2>&1 || true
    wall=$(echo "$(date +%s.%N) - $start" | bc)
    if [ -z "$best" ] || [ "$(echo "$wall < $best" | bc)" = 1 ]; then
      best=$wall
      rm -rf "${work:?}/$name" && mv "$try" "$work/$name" && mv "$try.log" "$work/$name.log"
    else
      rm -rf "$try" "$try.log"
    fi
  done
  echo "$best"
}

mono_wall=$(run mono --set schedule.fine=spheres --set schedule.order=fine-first --set "solvers[0].params.integrator=verlet")
printf "%-11s %-4s %-10s %-10s %-9s %-9s %-9s %-10s %-10s %-11s %-12s %s\n" "forces" "m" "F err [%]" "F(2mm) [N]" \
  "wall [s]" "/mono" "/m=1" "paper" "paper/1.27" "PD comp [s]" "DEM comp [s]" "status"
report() {  # report FORCES LABEL RUN WALL BASE PAPER
  /usr/bin/python3 - "$work/$3/run_report.json" "$1" "$2" "$4" "$5" "$6" "$mono_wall" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
forces, label, wall, base, paper, mono = sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]), sys.argv[6], float(sys.argv[7])
peers = {p["name"]: p for p in r.get("peers", [])}
comp = lambda n: peers.get(n, {}).get("compute_s", float("nan"))
err = {e["name"]: e["value"] for e in r.get("errors", [])}.get("force_rms_error")
rel = "%.2f" % (float(paper) / 1.27) if paper else "-"
print("%-11s %-4s %-10s %-10.0f %-9.2f %-9.2f %-9.2f %-10s %-10s %-11.2f %-12.2f %s" % (
    forces, label, "%.2f" % (100 * err) if err is not None else "-", r["figures"].get("final_force_N", float("nan")),
    wall, wall / mono, wall / base, paper or "-", rel, comp("plate"), comp("spheres"), r.get("status")))
PY
}
for f in $forces; do
  base=""
  for m in $ratios; do
    wall=$(run "$f-m$m" --set "schedule.ratio=$m" --set "couplings.contact.forces=$f" \
      --set "analysis.reference_run=$work/mono/coupler.h5")
    [ -z "$base" ] && base=$wall
    report "$f" "$m" "$f-m$m" "$wall" "$base" "${paper[$m]:-}"
  done
done
report held mono mono "$mono_wall" "$mono_wall" ""
echo "(mono: the reference itself, monolithic-equivalent; runs kept in $work)"
