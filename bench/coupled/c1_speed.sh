#!/usr/bin/env bash
# Scene C1 at c = 10d: error against run time over the time step and the beam's
# Newmark parameters (issue: the fastest configuration whose error stays within
# 10 % of the lockstep-implicit error must finish in 60 s). Runs
# configs/c1/cantilever_surface.yaml to fall-off with `coupler sweep` for
#   dt    = t_c/100 (the paper's, the scene's), t_c/50, t_c/20, t_c/10, t_c/5
#           (t_c = pi sqrt(m / k_n) = 6.43e-3 s, the particle's contact time)
#   gamma = 1/2 (trapezoidal, energy-conserving) and 0.6 (beta = (gamma + 1/2)^2 / 4
#           by default: unconditionally stable, damps the beam's unresolved modes)
# and prints each run's error against the lockstep run (t_c/100, gamma 1/2),
# its wall time and energy, and the fastest run within 10 %.
# Usage: bench/coupled/c1_speed.sh [out dir] [extra coupler sweep arguments ...]
# About 10 minutes on 2 cores (the lockstep runs take 2.5 minutes each).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-$root/runs/c1-speed}
shift || true
"$root/build/bin/coupler" sweep "$root/configs/c1/cantilever_surface.yaml" \
  --set schedule.dt=6.43e-5,1.286e-4,3.215e-4,6.43e-4,1.286e-3 \
  --set solvers.beam.params.integrator.gamma=0.5,0.6 --out "$out" "$@" || true
/usr/bin/python3 - "$root/bench/coupled" "$out/sweep.csv" <<'PY'
import sys
sys.path.insert(0, sys.argv[1])
from sweep_table import cell, rows as sweep_rows
rows = sweep_rows(sys.argv[2])
dt_key, gamma_key = "schedule.dt", "solvers.beam.params.integrator.gamma"
ref = [r for r in rows if float(r[dt_key]) == 6.43e-5 and float(r[gamma_key]) == 0.5 and r["status"] == "completed"]
ref_err = float(ref[0]["error_value"]) if ref else None
print(f"{'dt [s]':>9} {'t_c/dt':>6} {'gamma':>5} {'err [m]':>9} {'vs lockstep':>11} {'max E [J]':>9} "
      f"{'coupled to [s]':>14} {'wall [s]':>8} {'overhead':>8} status")
best = None
for r in rows:
    dt, gamma = float(r[dt_key]), float(r[gamma_key])
    err = float(r["error_value"]) if r.get("error_value") else float("nan")
    rel = (err / ref_err - 1.0) if ref_err else float("nan")
    done = r["status"] == "completed" and r.get("all_left_beam") == "1"
    f = lambda key, fmt="{:.4g}": cell(r, key, fmt)
    print(f"{dt:>9.4g} {6.43e-3 / dt:>6.0f} {gamma:>5} {err:>9.5f} {rel:>+11.1%} {f('max_total_energy_J'):>9} "
          f"{f('coupled_until_s'):>14} {f('wall_s', '{:.1f}'):>8} {f('coupling_overhead_share', '{:.0%}'):>8} "
          f"{r['status']}")
    if done and ref_err and abs(rel) <= 0.10 and (best is None or float(r["wall_s"]) < float(best["wall_s"])):
        best = r
if ref_err is None:
    print("no completed lockstep run (dt = t_c/100, gamma = 1/2): no reference error")
elif best:
    print(f"fastest within 10 % of the lockstep error {ref_err:.5f} m: dt = {best[dt_key]}, gamma = {best[gamma_key]}, "
          f"{float(best['wall_s']):.1f} s wall (target 60 s)")
else:
    print("no run within 10 % of the lockstep error")
PY
