#!/usr/bin/python3
"""Scaling of the GMH worker pool: what the coupler costs per unit-cell job,
what a job costs a worker, the pool efficiency measured here, and a model of
the efficiency to 1000 workers built from those costs (docs/cluster.md).

  pool_scaling.py [--bin DIR] [--quick] [--docs]

Measured, each from the run report of real runs (coupler, FEM block and
dem_solver workers over ipc on this machine):

  1. Coupler overhead per coarse step: the coupler's own mapping work (jobs
     assembled from FEM's strain increments and sent out, results gathered and
     handed back) plus the rounds' communication outside every solver's
     compute, for C cells on W workers with jobs that cost the workers almost
     nothing (60-sphere cells, one load step, a tolerance every cell meets at
     once). Fitted as a + b C + c W: b is the cost per job dispatched and
     result gathered, c per worker message. With W workers on this machine's
     cores the wake-ups of W processes are in c: on a cluster, with a core per
     worker, c is smaller.
  2. Cost of a job to a worker: compute seconds per job of cells of n spheres
     (100, 250, 500) under an axial strain of 1e-4 per coarse step (the
     nominal shear strain rate of L4), fitted as t_job = t_0 (n / 500)^p, and
     the worker's memory per cell (peak resident size against cells held).
  3. Pool efficiency here: the same 4 cells of 500 spheres on one worker and
     on two, E = T_1 / (2 T_2) over the exchange loops (best of repeats).

Model (one core per worker, the coupler serial):
  T(W) = t_fem + ceil(C / W) t_job + a + b C + c W  per coarse step,
  E(W) = T(1) / (W T(W)), the measured efficiency's definition.
The coupler is the bottleneck where a + b C + c W exceeds ceil(C / W) t_job.
It prints the table, writes bench/cluster/out/pool_scaling.{json,png} and with
--docs the table into docs/cluster.md (between its bench markers) and the plot
to docs/figures/pool_scaling.png.

Needs numpy and matplotlib (Debian's /usr/bin/python3).
"""
import argparse
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "bench", "reliability"))
from gmh_pool_scale import scene  # noqa: E402

PAPER_SPHERES = 4096
# Paper-size scenes (Liu, Sun, Fish 2016; shared/scenes/README.md): cells
# (one per one-point element) and coarse steps at the reduced configs' rate.
# Each scene's job cost at 500 spheres is its standard-tier validation run's
# (validation/report.json: the figure named, its cells, coarse steps and two
# workers on two cores; wall x workers / jobs, so FEM and coupler time are in
# it), scaled to 4096 spheres with the measured exponent.
PAPER_SCENES = [
    ("L4 simple shear, 5 x 12 x 1, to 20 %", 60, 2000, ("L4", "shear strain at the peak", 60, 2000)),
    ("L5 biaxial, 6 x 12 mesh, to 5 %", 72, 4000, ("L5", "local peak strain, 8x16", 128, 4000)),
    ("L5 biaxial, 10 x 20 mesh, to 5 %", 200, 4000, ("L5", "local peak strain, 8x16", 128, 4000)),
]
REDUCED_WORKERS = 2


def reduced_job_cost(calibration):
    """A scene's job cost at 500 spheres from its standard-tier run, or None when the report lacks it."""
    scene_name, figure, cells, steps = calibration
    try:
        with open(os.path.join(ROOT, "validation", "report.json")) as f:
            rows = json.load(f)
    except OSError:
        return None
    wall = next((r["wall_s"] for r in rows if r["scene"] == scene_name and r["figure"].startswith(figure)), None)
    return wall * REDUCED_WORKERS / (cells * steps) if wall else None


def prepare(binaries, work, spheres, seed=3):
    base = os.path.join(work, "cell%d" % spheres)
    if not os.path.exists(base + ".ckpt"):
        subprocess.run([os.path.join(binaries, "dem_prepare_cell"), "--out", base, "--count", str(spheres),
                        "--seed", str(seed)], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return base + ".ckpt"


def pool_text(cell, cells, workers, steps, strain_per_step, relaxation="load_steps: 20"):
    text = scene(cell, cells, workers, steps, as_pool=True)
    # The top face at v = strain per step x height / dt (height 0.01 m, dt 2e-5 s).
    text = text.replace("value: -1.0e-3, kind: velocity", "value: %.6g, kind: velocity" % (-strain_per_step * 0.01 / 2e-5))
    text = text.replace("load_steps: 20}", relaxation + "}")
    return text.replace("output:\n  checkpoint_interval: 10\n", "")


def peak_rss_mb(pattern):
    """The largest VmHWM of the processes whose command line holds `pattern`."""
    best = 0.0
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                if pattern not in f.read().replace(b"\0", b" ").decode(errors="replace"):
                    continue
            with open("/proc/%s/status" % pid) as f:
                for line in f:
                    if line.startswith("VmHWM:"):
                        best = max(best, float(line.split()[1]) / 1024.0)
        except OSError:
            pass
    return best


def run(binaries, work, name, text, watch=None):
    """Runs the scene; returns its run report (and the peak RSS of `watch` processes, MB)."""
    path = os.path.join(work, name + ".yaml")
    with open(path, "w") as f:
        f.write(text)
    out = os.path.join(work, name)
    env = dict(os.environ, OMP_NUM_THREADS="1")
    p = subprocess.Popen([os.path.join(binaries, "coupler"), "run", path, "--out", out, "--no-progress"],
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env, text=True)
    rss = 0.0
    while p.poll() is None:
        if watch:
            rss = max(rss, peak_rss_mb(watch))
        time.sleep(0.02)
    err = p.stderr.read()
    if p.returncode != 0:
        raise RuntimeError("%s: coupler run exited %d:\n%s" % (name, p.returncode, err[-2000:]))
    with open(os.path.join(out, "run_report.json")) as f:
        return json.load(f), rss


def coupler_overhead(binaries, work, quick):
    cell = prepare(binaries, work, 60)
    grid_cells = [50, 200] if quick else [50, 200, 800]
    grid_workers = [1, 8, 32] if quick else [1, 8, 32, 64]
    steps = 40
    rows = []
    for cells in grid_cells:
        for workers in grid_workers:
            if workers > cells:
                continue
            report, _ = run(binaries, work, "overhead-%d-%d" % (cells, workers),
                            pool_text(cell, cells, workers, steps, 1e-7, "load_steps: 1, tolerance: 1.0e9"))
            wall = report["wall_s"]
            exchanges = report["exchanges"] / 2.0  # coarse-first: FEM's exchange, then the pool's
            rows.append({"cells": cells, "workers": workers, "coarse_steps": exchanges,
                         "overhead_s": (wall["coupler_mapping"] + wall["communication"]) / exchanges,
                         "mapping_s": wall["coupler_mapping"] / exchanges,
                         "communication_s": wall["communication"] / exchanges,
                         "jobs": report["figures"]["answered_cell_jobs"]})
            print("  overhead: %4d cells on %2d workers: %.3f ms per coarse step (mapping %.3f, communication %.3f)"
                  % (cells, workers, 1e3 * rows[-1]["overhead_s"], 1e3 * rows[-1]["mapping_s"],
                     1e3 * rows[-1]["communication_s"]))
    A = np.array([[1.0, r["cells"], r["workers"]] for r in rows])
    y = np.array([r["overhead_s"] for r in rows])
    (a, b, c), *_ = np.linalg.lstsq(A, y, rcond=None)
    mapping = np.linalg.lstsq(A, np.array([r["mapping_s"] for r in rows]), rcond=None)[0]
    return {"rows": rows, "a_s": a, "b_s_per_job": b, "c_s_per_worker": c, "mapping_b_s_per_job": mapping[1]}


def job_cost(binaries, work, quick):
    sizes = [100, 250] if quick else [100, 250, 500]
    rows = []
    for n in sizes:
        cell = prepare(binaries, work, n)
        for cells in (2, 4):
            report, rss = run(binaries, work, "job-%d-%d" % (n, cells), pool_text(cell, cells, 1, 10, 1e-4),
                              watch="dem_solver --endpoint")
            worker = next(p for p in report["peers"] if p["name"] == "cells-0")
            fem = next(p for p in report["peers"] if p["name"] == "block")
            jobs = report["figures"]["answered_cell_jobs"]
            rows.append({"spheres": n, "cells": cells, "t_job_s": worker["compute_s"] / jobs,
                         "t_fem_s": fem["compute_s"] / (report["exchanges"] / 2.0), "peak_rss_mb": rss})
            print("  job: %4d spheres, %d cells: %.2f ms per job, worker peak %.1f MB"
                  % (n, cells, 1e3 * rows[-1]["t_job_s"], rss))
    per_size = {}
    for r in rows:
        per_size.setdefault(r["spheres"], []).append(r)
    ns = np.array(sorted(per_size))
    t = np.array([np.mean([r["t_job_s"] for r in per_size[n]]) for n in ns])
    p, logt0 = np.polyfit(np.log(ns / 500.0), np.log(t), 1)
    # Memory per cell: the slope of the peak RSS against the cells held, per sphere.
    per_sphere = [(max(per_size[n], key=lambda r: r["cells"])["peak_rss_mb"] -
                   min(per_size[n], key=lambda r: r["cells"])["peak_rss_mb"]) / 2.0 / n for n in ns]
    return {"rows": rows, "t0_s": math.exp(logt0), "exponent": p, "mb_per_sphere": max(0.0, float(np.median(per_sphere))),
            "t_fem_s": float(np.median([r["t_fem_s"] for r in rows]))}


def measured_efficiency(binaries, work, quick):
    cell = prepare(binaries, work, 250 if quick else 500)
    best = {}
    for workers in (1, 2):
        for _ in range(1 if quick else 3):
            report, _ = run(binaries, work, "efficiency-%d" % workers, pool_text(cell, 4, workers, 20, 1e-4))
            loop = report["wall_s"]["exchange_loop"]
            best[workers] = min(best.get(workers, loop), loop)
    return {"t1_s": best[1], "t2_s": best[2], "efficiency": best[1] / (2.0 * best[2])}


def job_at(jc, spheres, t500=None):
    """A job's cost for cells of `spheres`, from t500 (default: the bench's own) with the fitted exponent."""
    return (t500 or jc["t0_s"]) * (spheres / 500.0) ** jc["exponent"]


def step_time(ov, jc, cells, workers, t_job):
    """The model's wall time of one coarse step, and the coupler's overhead in it."""
    overhead = ov["a_s"] + ov["b_s_per_job"] * cells + ov["c_s_per_worker"] * workers
    return jc["t_fem_s"] + math.ceil(cells / workers) * t_job + overhead, overhead


def model(ov, jc, cells, workers, t_job):
    """Parallel efficiency T(1) / (W T(W)), the step time and the coupler's overhead at W workers."""
    step, overhead = step_time(ov, jc, cells, workers, t_job)
    return step_time(ov, jc, cells, 1, t_job)[0] / (workers * step), step, t_job, overhead


def bottleneck(ov, t_job):
    """One cell per worker, the pool size from which the coupler's overhead
    a + (b + c) C exceeds the job: the coupler is then the bottleneck."""
    per = ov["b_s_per_job"] + ov["c_s_per_worker"]
    return int((t_job - ov["a_s"]) / per) if per > 0 and t_job > ov["a_s"] else None


def table(ov, jc, eff):
    lines = ["| figure | value |", "|---|---|",
             "| coupler overhead per coarse step, fixed (a) | %.3f ms |" % (1e3 * ov["a_s"]),
             "| coupler cost per unit-cell job dispatched and result gathered (b) | %.2f us (mapping alone %.2f us) |"
             % (1e6 * ov["b_s_per_job"], 1e6 * ov["mapping_b_s_per_job"]),
             "| coupler cost per worker message (c, W processes on %d cores) | %.1f us |"
             % (os.cpu_count() or 2, 1e6 * ov["c_s_per_worker"]),
             "| worker cost per job, 500-sphere cell, 1e-4 strain per step (t_0) | %.1f ms |" % (1e3 * jc["t0_s"]),
             "| job cost exponent p (t_job ~ n^p, 100-500 spheres) | %.2f |" % jc["exponent"],
             "| job cost of a 4096-sphere cell (extrapolated) | %.2f s |" % job_at(jc, PAPER_SPHERES),
             "| worker memory per sphere held | %.1f kB |" % (1024 * jc["mb_per_sphere"]),
             "| FEM block compute per coarse step | %.3f ms |" % (1e3 * jc["t_fem_s"]),
             "| pool efficiency here, 4 cells, 1 -> 2 workers (T_1 / 2 T_2) | %.1f %% (T_1 %.2f s, T_2 %.2f s) |"
             % (100 * eff["efficiency"], eff["t1_s"], eff["t2_s"])]
    lines += ["", "| scene at paper size (4096-sphere cells) | cells | coarse steps | job [s] (500-sphere run) | workers | "
              "efficiency (model) | hours | core-hours | memory | coupler bottleneck from (one cell per worker) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for name, cells, steps, calibration in PAPER_SCENES:
        t500 = reduced_job_cost(calibration)
        t_job = job_at(jc, PAPER_SPHERES, t500)
        where = ("%.1f ms" % (1e3 * t500)) if t500 else "the bench's"
        for workers in sorted({1, cells // 4, cells // 2, cells}):
            e, step, _, _ = model(ov, jc, cells, workers, t_job)
            memory_gb = jc["mb_per_sphere"] * PAPER_SPHERES * cells / 1024.0
            lines.append("| %s | %d | %d | %.2f (%s) | %d | %.0f %% | %.2f | %.0f | %.1f GB | %s cells |"
                         % (name, cells, steps, t_job, where, workers, 100 * e, steps * step / 3600.0,
                            steps * step * (workers + 1) / 3600.0, memory_gb, bottleneck(ov, t_job) or "-"))
    return "\n".join(lines) + "\n"


def plot(ov, jc, eff, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(7, 4.5))
    workers = np.unique(np.logspace(0, 3, 200).astype(int))
    t_paper = job_at(jc, PAPER_SPHERES)
    for cells, style in ((60, "-"), (200, "--"), (1000, ":")):
        ax.plot(workers, [100 * model(ov, jc, cells, w, t_paper)[0] for w in workers], style,
                label="model, %d cells of %d spheres" % (cells, PAPER_SPHERES))
    small = [w for w in workers if w <= 4]
    ax.plot(small, [100 * model(ov, jc, 4, w, job_at(jc, 500))[0] for w in small], color="grey", lw=0.8,
            label="model, 4 cells of 500 spheres")
    ax.plot([1, 2], [100.0, 100 * eff["efficiency"]], "ko", label="measured here, 4 cells of 500 spheres")
    ax.set_xscale("log")
    ax.set_xlabel("workers (one core each)")
    ax.set_ylabel("pool efficiency T(1) / (W T(W)) [%]")
    ax.set_ylim(0, 105)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def write_docs(text):
    path = os.path.join(ROOT, "docs", "cluster.md")
    with open(path) as f:
        doc = f.read()
    begin, end = "<!-- bench: pool_scaling -->\n", "<!-- /bench -->\n"
    if begin not in doc or end not in doc:
        raise RuntimeError("%s has no %s ... %s markers" % (path, begin.strip(), end.strip()))
    doc = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda _: begin + text + end, doc, flags=re.S)
    with open(path, "w") as f:
        f.write(doc)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--quick", action="store_true", help="fewer sizes and repeats (a check that it runs)")
    ap.add_argument("--docs", action="store_true", help="write the table and plot into docs/")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="cosim-pool-scaling.")
    try:
        print("coupler overhead (trivial jobs):")
        ov = coupler_overhead(a.bin, work, a.quick)
        print("job cost:")
        jc = job_cost(a.bin, work, a.quick)
        print("pool efficiency here:")
        eff = measured_efficiency(a.bin, work, a.quick)
        text = table(ov, jc, eff)
        print(text)
        out = os.path.join(HERE, "out")
        os.makedirs(out, exist_ok=True)
        with open(os.path.join(out, "pool_scaling.json"), "w") as f:
            json.dump({"overhead": ov, "job_cost": jc, "efficiency": eff}, f, indent=1, default=float)
        plot(ov, jc, eff, os.path.join(out, "pool_scaling.png"))
        if a.docs:
            write_docs(text)
            os.makedirs(os.path.join(ROOT, "docs", "figures"), exist_ok=True)
            shutil.copy(os.path.join(out, "pool_scaling.png"), os.path.join(ROOT, "docs", "figures", "pool_scaling.png"))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
