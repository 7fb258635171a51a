#!/usr/bin/python3
"""Scene C2, loading (b) (Cheng 2022 Sec. 6.2.3-6.2.4, Table 4 and 6): the
wave bar driven by a cosine pulse v_y = v0 (cos(omega t) - 1), v0 = 0.05 m/s,
for M_c cycles, then held; nP = n^3 particles per element (d = 0.4 / n m).

For every case it writes the scene pair from configs/c2/wave_full_dem_1p_pulse.yaml
and configs/c2/wave_volume_1p_pulse.yaml (lattice, spring stiffness E d,
penalty n^2 1e10 Pa/m^2, dt = 1.6e-5 / n s, end 0.12 s after the pulse),
runs the full-DEM reference once per (n, omega, M_c) and the coupled scene per
CG width, and prints the dissipation ratio dE/E = (W - E_end) / W (W the
drive's work, E the weighted solver energies), the reference's own dE/E (0 up
to the time integration: it checks the work accounting), and the station
waveform error against the reference, next to the paper's numbers.

Usage: bench/coupled/c2_pulse_table.py [--build DIR] [--work DIR] [--cases A,B,C]
  A: 1P, one cycle, omega = 1.95e3, 0.98e3, 0.49e3 rad/s, c = 0 and 0.6 m
     (paper: about 34 % at 1.95e3 falling to 31 % at 0.49e3)
  M: 1P, omega = 1.95e3, M_c = 1, 3, 5, c = 0 (paper: three cycles dissipate
     3-8 % more than five)
  B: 2P, 3P, 4P, one cycle at 1.95e3, c = 0, 0.6, 1.0 m (paper: 4P up to 55 %,
     with CG 50 % (4P), 43 % (3P), 35 % (2P))
  C: 4P, five cycles at 1.95e3, c = 0.6 and 1.0 m (paper: 36 % -> 26 %)
A run the coupling's guard stops as diverged (c = 0 on 3P and 4P) is rerun
with `dt: auto`, which adds the penalty's stiffness to the step limit, and
printed again with that step.
"""
import argparse
import copy
import json
import math
import os
import subprocess
import tempfile
import time

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PAPER = {("A", 1950.0, 0.0): "~34", ("A", 490.0, 0.0): "~31", ("B", 4, 0.0): "55", ("B", 4, "cg"): "50",
         ("B", 3, "cg"): "43", ("B", 2, "cg"): "35", ("C", 0.6): "36", ("C", 1.0): "26"}


def scene_for(base, n, omega, cycles, coupled):
    s = copy.deepcopy(base)
    d = 0.4 / n
    dt = 1.6e-5 / n
    end = 0.12 + 2 * math.pi * cycles / omega
    s["schedule"]["dt"] = dt
    s["schedule"]["end_time"] = round(end, 7)
    dem = next(x for x in s["solvers"] if x["name"] == "dem")["params"]
    dem["dt"] = dt
    dem["materials"][0]["kn"] = 1.0e8 * d
    dem["bonds"]["stiffness"] = 1.0e8 * d
    layers = (30 if coupled else 50) * n
    dem["particles"] = [{"lattice": {"origin": [d / 2] * 3, "spacing": d, "counts": [2 * n, layers, 2 * n],
                                     "radius": d / 2, "material": "grain"}}]
    for z in dem["zones"]:
        if z["name"] == "left":
            z["box"]["max"][1] = d
        if z["name"] == "right":
            z["box"]["min"][1] = 20.0 - d
    for drv in dem["drives"]:
        if drv["velocity"]["kind"] == "cosine-pulse":
            drv["velocity"]["omega"] = omega
            drv["velocity"]["cycles"] = cycles
    if coupled:
        s["couplings"][0]["penalty"] = n * n * 1.0e10
    return s


def run(build, scene, path, out, sets=()):
    with open(path, "w") as f:
        yaml.safe_dump(scene, f, sort_keys=False)
    start = time.time()
    cmd = [os.path.join(build, "bin", "coupler"), "run", path, "--out", out, "--no-progress"]
    for s in sets:
        cmd += ["--set", s]
    with open(out + ".log", "w") as log:
        subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT, check=False)
    wall = time.time() - start
    try:
        with open(os.path.join(out, "run_report.json")) as f:
            report = json.load(f)
    except (OSError, ValueError):
        report = {"status": "no report", "message": "see " + out + ".log", "figures": {}, "errors": []}
    return report, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--work", default=None)
    ap.add_argument("--cases", default="A,M,B,C")
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="c2-pulse.")
    os.makedirs(work, exist_ok=True)
    with open(os.path.join(ROOT, "configs/c2/wave_full_dem_1p_pulse.yaml")) as f:
        ref_base = yaml.safe_load(f)
    with open(os.path.join(ROOT, "configs/c2/wave_volume_1p_pulse.yaml")) as f:
        cpl_base = yaml.safe_load(f)
    grid = []
    cases = a.cases.split(",")
    if "A" in cases:
        grid += [("A", 1, om, 1, c) for om in (1950.0, 980.0, 490.0) for c in (0.0, 0.6)]
    if "M" in cases:
        grid += [("M", 1, 1950.0, m, 0.0) for m in (1, 3, 5)]
    if "B" in cases:
        grid += [("B", n, 1950.0, 1, c) for n in (2, 3, 4) for c in (0.0, 0.6, 1.0)]
    if "C" in cases:
        grid += [("C", 4, 1950.0, 5, c) for c in (0.6, 1.0)]
    print("%-4s %-3s %-9s %-3s %-6s %-5s %-10s %-10s %-12s %-7s %-9s %-9s %s" %
          ("case", "n", "omega", "M", "c [m]", "c/dX", "dE/E [%]", "paper [%]", "ref dE/E [%]", "e_st [%]",
           "wall [s]", "ref [s]", "status"), flush=True)
    refs = {}
    for case, n, omega, cycles, c in grid:
        key = (n, omega, cycles)
        tag = "n%d_w%d_m%d" % key
        if key not in refs:
            out = os.path.join(work, "ref_" + tag)
            refs[key] = (out,) + run(a.build, scene_for(ref_base, n, omega, cycles, False), out + ".yaml", out)
        ref_out, ref_report, ref_wall = refs[key]
        out = os.path.join(work, "cpl_%s_c%g" % (tag, c))
        sets = ["couplings.volume.width=%g" % c, "analysis.reference_run=" + os.path.join(ref_out, "coupler.h5")]
        report, wall = run(a.build, scene_for(cpl_base, n, omega, cycles, True), out + ".yaml", out, sets)
        print_row(case, n, omega, cycles, c, report, wall, ref_report, ref_wall, "")
        if "diverged" in report.get("message", ""):
            # The point form with several particles per element needs a smaller
            # step than the other widths (docs/arlequin.md): rerun it at the step
            # dt: auto derives with the penalty's stiffness.
            report, wall = run(a.build, scene_for(cpl_base, n, omega, cycles, True), out + "_auto.yaml", out + "_auto",
                               sets + ["schedule.dt=auto"])
            print_row(case, n, omega, cycles, c, report, wall, ref_report, ref_wall, " (dt: auto, %s s)" %
                      report.get("schedule", "").split("dt = ")[-1].split(" s")[0])
    print("runs kept in " + work)


def print_row(case, n, omega, cycles, c, report, wall, ref_report, ref_wall, note):
    fig = report.get("figures", {})
    ok = report.get("status") == "completed"
    err = next((e["value"] for e in report.get("errors", []) if e["name"] == "station_velocity_rms_error"), None)
    paper = PAPER.get((case, omega, c)) or PAPER.get((case, n, c)) or PAPER.get((case, c)) or \
        (PAPER.get((case, n, "cg")) if c > 0 else None) or "-"
    status = report.get("status", "?") if ok else "%s: %s" % (report.get("status"), report.get("message", "")[:120])
    print("%-4s %-3d %-9g %-3d %-6g %-5.1f %-10s %-10s %-12s %-7s %-9.1f %-9.1f %s" %
          (case, n, omega, cycles, c, c / 0.4, "%.1f" % (100 * fig["dissipation_ratio"]) if ok else "-", paper,
           "%.4f" % (100 * ref_report.get("figures", {}).get("dissipation_ratio", float("nan"))),
           "%.1f" % (100 * err) if err is not None and ok else "-", wall, ref_wall, status + note), flush=True)


if __name__ == "__main__":
    main()
