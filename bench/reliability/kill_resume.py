#!/usr/bin/python3
"""Kill-and-resume trials: a short scene of each coupling kind, SIGKILL of a
random process (the coupler or one of its solvers) at a random time, then
`coupler run --resume`, and every series of coupler.h5 (the wall-clock
timings aside) and the run report's errors and figures compared with the
uninterrupted run, bit for bit.

  kill_resume.py [--trials N] [--kinds surface,arlequin,pd-dem-contact,direct-transfer,gmh]
                 [--seed S] [--bin DIR] [--work DIR]

Prints per kind: trials, runs that ended before the kill landed (their
results are compared too), kills of a solver the coupler detected (exit 3 before
time zero or 4 during the run, the peer named), kills before the first checkpoint (the resume is refused, exit 3,
and the trial is not a resume), resumes identical to the uninterrupted run,
resumes that differ, hangs (a run that outlives its time limit) and orphans
(processes of the trial's run directory alive after it ended). Exit status 1
when a resume differs, a run hangs or a process is left behind.
Needs numpy and h5py (Debian's /usr/bin/python3).
"""
import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# Each kind: a shipped scene cut short, a checkpoint interval that leaves several checkpoints.
KINDS = {
    "surface": ("configs/c1/cantilever_surface.yaml",
                ["schedule.end_time=1.0", "output.checkpoint_interval=2000"]),
    "arlequin": ("configs/c2/wave_volume_1p.yaml",
                 ["output.checkpoint_interval=700", "analysis.reference_run={reference}"]),
    "pd-dem-contact": ("configs/h2/pd_dem_multirate.yaml",
                       ["schedule.end_time=0.05", "output.checkpoint_interval=400"]),
    "direct-transfer": ("configs/demo/two_mocks.yaml", ["output.checkpoint_interval=100"]),
    "gmh": ("configs/gmh/l2_compression.yaml",
            ["output={checkpoint_interval: 15}", "solvers.cells.params.unit_cells.file={cell}"]),
}


def run_dir_processes(run_dir):
    """PIDs of live processes whose command line names run_dir (the solvers get its socket)."""
    found = []
    for pid in os.listdir("/proc"):
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            with open("/proc/%s/cmdline" % pid, "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode(errors="replace")
            with open("/proc/%s/stat" % pid) as f:
                state = f.read().split(")")[-1].split()[0]
        except OSError:
            continue
        if run_dir in cmd and state != "Z":
            found.append(int(pid))
    return found


def children(pid):
    try:
        with open("/proc/%d/task/%d/children" % (pid, pid)) as f:
            return [int(c) for c in f.read().split()]
    except OSError:
        return []


def physics(run_dir):
    """Every series of coupler.h5 but the wall-clock ones, and the report's errors and figures."""
    out = {}
    with h5py.File(os.path.join(run_dir, "coupler.h5"), "r") as f:
        def visit(name, obj):
            if isinstance(obj, h5py.Dataset) and not name.endswith(("compute_s", "communication_s")):
                out[name] = obj[:]
        f["series"].visititems(visit)
    with open(os.path.join(run_dir, "run_report.json")) as f:
        r = json.load(f)
    out["report"] = json.dumps([r.get("errors"), r.get("figures")], sort_keys=True)
    return out


def same(a, b):
    return a.keys() == b.keys() and all(
        a[k] == b[k] if isinstance(a[k], str) else (a[k].shape == b[k].shape and np.array_equal(a[k], b[k]))
        for k in a)


def coupler_run(binaries, config, sets, out, extra=(), timeout=600):
    cmd = [os.path.join(binaries, "coupler"), "run", os.path.join(ROOT, config), "--out", out, "--no-progress"]
    for s in sets:
        cmd += ["--set", s]
    with open(out + ".log", "a") as log:
        return subprocess.Popen(cmd + list(extra), stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def wait(p, timeout):
    try:
        return p.wait(timeout=timeout), False
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        p.wait()
        return None, True


def trial(rng, binaries, config, sets, work, k, reference, full_wall):
    out = os.path.join(work, "trial%02d" % k)
    p = coupler_run(binaries, config, sets, out)
    time.sleep(rng.uniform(0.1, 0.9) * full_wall)
    targets = [p.pid] + children(p.pid)
    victim = rng.choice(targets)
    killed_solver = victim != p.pid
    try:
        os.kill(victim, signal.SIGKILL)
    except ProcessLookupError:
        pass
    code, hung = wait(p, 120)
    result = {"killed": "solver" if killed_solver else "coupler", "hung": hung, "detected": False,
              "before_checkpoint": False, "identical": None, "orphans": 0, "ended_first": code == 0}
    if killed_solver and code in (3, 4):  # refused before time zero (its params check too), or failed during the run
        with open(out + ".log") as f:
            text = f.read()
            result["detected"] = "peer '" in text or "while checking its params" in text
    if code == 0:  # the run ended before the kill landed
        result["identical"] = same(physics(out), reference)
        result["orphans"] = len(run_dir_processes(out))
        return result
    time.sleep(1.0)  # a killed coupler's solvers notice the lost socket and exit
    result["orphans"] += len(run_dir_processes(out))
    for pid in run_dir_processes(out):
        os.kill(pid, signal.SIGKILL)
    r = coupler_run(binaries, config, sets, out, ["--resume"])
    code, hung = wait(r, 6 * full_wall + 60)
    result["hung"] = result["hung"] or hung
    with open(out + ".log") as f:
        nothing = "no complete checkpoint" in f.read()
    if code == 3 and nothing:
        result["before_checkpoint"] = True
    elif code == 0:
        result["identical"] = same(physics(out), reference)
    else:
        result["identical"] = False
    result["orphans"] += len(run_dir_processes(out))
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=50)
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--work", default=None)
    a = ap.parse_args()
    kinds = a.kinds.split(",")
    for k in kinds:
        if k not in KINDS:
            print("kill_resume.py: unknown kind '%s' (%s)" % (k, ", ".join(KINDS)), file=sys.stderr)
            return 2
    work = a.work or tempfile.mkdtemp(prefix="kill-resume.")
    rng = random.Random(a.seed)
    print("%-16s %7s %11s %17s %18s %10s %8s %6s %8s" % (
        "kind", "trials", "ended first", "solver kills seen", "before checkpoint", "identical", "differ", "hangs",
        "orphans"), flush=True)
    bad = False
    for kind in kinds:
        config, sets = KINDS[kind]
        d = os.path.join(work, kind)
        os.makedirs(d, exist_ok=True)
        fill = {}
        if "{reference}" in " ".join(sets):
            ref = os.path.join(d, "full-dem")
            subprocess.run([os.path.join(a.bin, "coupler"), "run", os.path.join(ROOT, "configs/c2/wave_full_dem_1p.yaml"),
                            "--out", ref, "--no-progress"], stdout=subprocess.DEVNULL, check=True)
            fill["{reference}"] = os.path.join(ref, "coupler.h5")
        if "{cell}" in " ".join(sets):
            subprocess.run([os.path.join(a.bin, "dem_prepare_cell"), "--out", os.path.join(d, "cell"), "--count", "100",
                            "--seed", "1"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            fill["{cell}"] = os.path.join(d, "cell.ckpt")
        sets = [s for s in sets]
        for key, v in fill.items():
            sets = [s.replace(key, v) for s in sets]
        start = time.monotonic()
        p = coupler_run(a.bin, config, sets, os.path.join(d, "whole"))
        code, _ = wait(p, 600)
        full_wall = time.monotonic() - start
        if code != 0:
            print("%-16s the uninterrupted run failed (exit %s, see %s.log)" % (kind, code, os.path.join(d, "whole")))
            bad = True
            continue
        reference = physics(os.path.join(d, "whole"))
        results = [trial(rng, a.bin, config, sets, d, k, reference, full_wall) for k in range(a.trials)]
        solver_kills = [r for r in results if r["killed"] == "solver" and not r["ended_first"]]
        row = (kind, len(results), sum(r["ended_first"] for r in results),
               "%d of %d" % (sum(r["detected"] for r in solver_kills), len(solver_kills)),
               sum(r["before_checkpoint"] for r in results), sum(r["identical"] is True for r in results),
               sum(r["identical"] is False for r in results), sum(r["hung"] for r in results),
               sum(r["orphans"] for r in results))
        print("%-16s %7d %11d %17s %18d %10d %8d %6d %8d" % row, flush=True)
        bad = bad or row[6] > 0 or row[7] > 0 or row[8] > 0
    print("runs kept in " + work)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
