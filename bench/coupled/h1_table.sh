#!/usr/bin/env bash
# Scene H1 (Hartmann 2022 Sec. 4.1): runs configs/h1/pd_dem_hertz_{pmb,lps}.yaml
# with `coupler run` and prints the force on the sphere at d = 2, 5, 10 mm
# (mean over +-0.25 mm, the hertz-indentation reference) against Hertz
# F = 4/3 E* sqrt(R) d^1.5, E* = E / (1 - nu^2), with the relative error for d
# measured from the block's top face (the scene's origin: F and Hertz are
# shown for it), from first contact and from the top of the hybrid layer
# (docs/pd_dem_coupling.md, H1).
# Extra `--set key=value` overrides go to every run, e.g. a coarser block:
#   bench/coupled/h1_table.sh build --set solvers.block.params.bodies.0.spacing=0.0225
# (then the sphere's start height in the scene no longer sits 0.2 mm above contact:
# the reference measures d from first contact, so only the run gets longer).
# Usage: bench/coupled/h1_table.sh [build dir] [coupler run options ...]
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
build=${1:-$root/build}
shift || true
work=$(mktemp -d /tmp/h1-table.XXXXXX)
printf "%-6s %-8s %-10s %-10s %-11s %-15s %-10s %-10s %s\n" "model" "d [mm]" "F [N]" "Hertz [N]" \
  "error: face" "first contact" "hybrid top" "wall [s]" "status"
for model in pmb lps; do
  out=$work/$model
  start=$(date +%s.%N)
  "$build/bin/coupler" run "$root/configs/h1/pd_dem_hertz_$model.yaml" --out "$out" --no-progress "$@" \
    > "$work/$model.log" 2>&1 || true
  wall=$(echo "$(date +%s.%N) - $start" | bc)
  python3 - "$out/run_report.json" "$model" "$wall" <<'PY'
import json, sys
r = json.load(open(sys.argv[1]))
f = r.get("figures", {})
def err(mm, origin):
    v = f.get("relative_error_at_%smm_from_%s" % (mm, origin))
    return "-" if v is None else "%+.3f" % v
for mm in ("2", "5", "10"):
    force = f.get("force_at_%smm_N" % mm)
    hertz = f.get("hertz_at_%smm_N" % mm)
    print("%-6s %-8s %-10s %-10s %-11s %-15s %-10s %-10.1f %s" % (sys.argv[2], mm,
          "-" if force is None else "%.1f" % force, "-" if hertz is None else "%.1f" % hertz,
          err(mm, "surface"), err(mm, "first-contact"), err(mm, "hybrid-top"), float(sys.argv[3]), r.get("status")))
print("%-6s action-reaction residual %.2e" % (sys.argv[2], f.get("action_reaction_residual", float("nan"))))
PY
done
echo "runs kept in $work"
