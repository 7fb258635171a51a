#!/usr/bin/python3
"""The GMH worker pool at scale on loopback: many dem_solver workers holding
the unit cells of one FEM block (one-point elements, one cell per element,
the ids interleaved over the workers with `stride`), compressed for a number
of coarse steps; every coarse step is one job per cell.

Four runs of the same scene:
  undisturbed  all workers, no fault;
  few workers  the same cells on 4 workers (results must not depend on
               which worker holds a cell);
  disturbed    a random worker SIGKILLed at a random time, the run stopped
               by the coupler naming the worker's cells (exit 4), resumed with
               `coupler run --resume` (every worker restores its cells from
               the last checkpoint), again and again until it completes;
  moved        `on_worker_loss: move`: random workers SIGKILLed at random
               times during one run, which goes on: each lost worker's cells
               move to the workers with the fewest cells, loaded from the
               latest checkpoint with their jobs since replayed.

Prints the jobs dispatched and answered (the run report's
`answered_cell_jobs` against cells x coarse steps: a lost job shows as a
shortfall; a job answered twice, or by the wrong worker, stops a run, which
is counted), the kills, the faults detected and named, the resumes, hangs and
orphans, and whether the series and report figures of the few-worker and the
disturbed run are identical to the bit to the undisturbed run's. Exit status
1 when anything is lost, doubled, different, hung or left behind.

  gmh_pool_scale.py [--workers 64] [--cells 200] [--steps 50] [--kills 5] [--moves 8]
                    [--spheres 60] [--seed S] [--bin DIR] [--work DIR]

Needs numpy and h5py (Debian's /usr/bin/python3).
"""
import argparse
import math
import os
import random
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from kill_resume import children, physics, run_dir_processes, same, wait  # noqa: E402


def scene(cell, cells, workers, steps, on_loss="stop", as_pool=False):
    """A ny x nx x 1 block of one-point elements (one cell each) under axial compression.
    The workers are declared one by one (w00, w01, ...), or with as_pool as one
    entry `cells` with pool: {workers} (cells-0, cells-1, ...): the same cells each."""
    nx = max(1, int(math.sqrt(cells / 2.0)))
    ny = cells // nx
    assert nx * ny == cells, "cells must factor as nx x 2nx-ish: choose e.g. 8, 50, 200, 512, 800"
    names = ["cells"] if as_pool else ["w%02d" % k for k in range(workers)]
    lines = [
        "scene: gmh-pool-scale",
        "schedule: {kind: multirate, fine: [%s], dt: 2.0e-5, ratio: 1, order: coarse-first, coarse_steps: %d}"
        % (", ".join(names), steps),
        "transport: {heartbeat_interval: 0.5, heartbeat_timeout: 20, connect_timeout: 120}",
        "solvers:",
        "  - name: block",
        "    kind: fem",
        "    params:",
        "      mesh: {box: {min: [0, 0, 0], max: [%g, %g, 0.01], divisions: [%d, %d, 1]}}" % (0.01 * nx, 0.01 * ny, nx, ny),
        "      material: {model: external, E: 1.0e8, nu: 0.2, density: 1600}",
        "      formulation: one-point",
        "      sets:",
        "        everything: {box: {min: [-1, -1, -1], max: [100, 100, 1]}}",
        "        bottom: {box: {min: [-1, -1, -0.0001], max: [100, 100, 0.0001]}}",
        "        top: {box: {min: [-1, -1, 0.0099], max: [100, 100, 0.0101]}}",
        "      boundary:",
        "        - {set: everything, dofs: [x, y], value: 0.0}",
        "        - {set: bottom, dofs: [z], value: 0.0}",
        "        - {set: top, dofs: [z], value: -1.0e-3, kind: velocity}",
        "      integrator: {type: central-difference}",
    ]
    if as_pool:
        lines += ["  - name: cells", "    kind: dem", "    pool: {workers: %d}" % workers, "    params:",
                  "      unit_cells: {file: %s, count: %d, load_steps: 20}" % (cell, cells)]
    else:
        for k, name in enumerate(names):
            lines += ["  - name: %s" % name, "    kind: dem", "    params:",
                      "      unit_cells: {file: %s, first_id: %d, count: %d, stride: %d, load_steps: 20}"
                      % (cell, k, len(range(k, cells, workers)), workers)]
    lines += ["couplings:", "  - {name: cells, kind: gmh, fem: block, workers: [%s], on_worker_loss: %s}"
              % (", ".join(names), on_loss),
              "output:", "  checkpoint_interval: 10"]
    return "\n".join(lines) + "\n"


def pool(series):
    """The pool's and FEM's series: the workers' own (energies, timings) name the
    worker, and a lost worker's end where it was lost."""
    return {k: v for k, v in series.items() if k.startswith(("cells/", "block/", "time", "exchange"))}


def start(binaries, scene_file, out, extra=()):
    with open(out + ".log", "a") as log:
        return subprocess.Popen([os.path.join(binaries, "coupler"), "run", scene_file, "--out", out, "--no-progress"]
                                + list(extra), stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def complete(binaries, scene_file, out, limit):
    t = time.time()
    code, hung = wait(start(binaries, scene_file, out), limit)
    if code != 0:
        sys.exit("%s: run failed (exit %s, hung %s); see %s.log" % (scene_file, code, hung, out))
    return time.time() - t


def answered(out):
    import json
    with open(os.path.join(out, "run_report.json")) as f:
        return int(json.load(f)["figures"]["answered_cell_jobs"])


def running_workers(p, limit):
    """The pool's worker processes, once all have started (the solver checks before are not)."""
    deadline = time.time() + limit
    while time.time() < deadline and p.poll() is None:
        found = []
        for c in children(p.pid):
            try:
                with open("/proc/%d/cmdline" % c, "rb") as f:
                    if b"--name\0w" in f.read():
                        found.append(c)
            except OSError:
                pass
        if found and os.path.exists(os.path.join(run_dir_of(p), "checkpoints")):
            return found
        time.sleep(0.05)
    return []


def run_dir_of(p):
    return p.args[p.args.index("--out") + 1]


def exchange_loop_s(out):
    import json
    with open(os.path.join(out, "run_report.json")) as f:
        return json.load(f)["wall_s"]["exchange_loop"]


def settle(p, out, limit, tally, seen=0):
    """Waits for the run; counts a hang and what it left behind (killed);
    returns its exit code and its part of the log (from byte `seen`)."""
    code, hung = wait(p, limit)
    tally["hangs"] += hung
    time.sleep(1.0)
    left = run_dir_processes(out)
    tally["orphans"] += len(left)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    with open(out + ".log") as f:
        f.seek(seen)
        return code, f.read()


def disturbed(rng, binaries, scene_file, out, kills, wall, limit):
    """Kills a random worker at a random time, resumes; until the run completes."""
    tally = {"kills": 0, "detected": 0, "resumes": 0, "hangs": 0, "orphans": 0, "doubled": 0, "failed": 0}
    extra = []
    while True:
        seen = os.path.getsize(out + ".log") if os.path.exists(out + ".log") else 0
        p = start(binaries, scene_file, out, extra)
        if tally["kills"] < kills:
            workers = running_workers(p, 120)
            time.sleep(rng.uniform(0.0, 1.0) * wall)  # somewhere in the exchange loop
            if workers and p.poll() is None:
                os.kill(rng.choice(workers), signal.SIGKILL)
                tally["kills"] += 1
        code, log = settle(p, out, limit, tally, seen)
        if code == 0:
            return tally
        if "answered unit cell" in log or "unanswered" in log:
            tally["doubled"] += 1
        if code == 3 and "no complete checkpoint" in log:
            extra = []  # killed before the first checkpoint: start afresh
            continue
        # exit 4 during the run (the message names the cells the worker held),
        # exit 3 when the kill landed before time zero (setup or restore)
        if (code == 4 and "held unit cells" in log) or (code == 3 and "peer 'w" in log):
            tally["detected"] += 1
        else:
            tally["failed"] += 1
            return tally
        extra = ["--resume"]
        tally["resumes"] += 1


def moved(rng, binaries, scene_file, out, kills, wall, limit):
    """One run with on_worker_loss: move: `kills` random workers SIGKILLed at
    random times after the first checkpoint; the run must go on to its end."""
    tally = {"kills": 0, "detected": 0, "hangs": 0, "orphans": 0, "failed": 0, "moved": 0}
    p = start(binaries, scene_file, out)
    workers = running_workers(p, 120)
    times = sorted(rng.uniform(0.1, 0.8) * wall for _ in range(kills))
    t0 = time.time()
    for at in times:
        time.sleep(max(0.0, at - (time.time() - t0)))
        alive = [w for w in workers if os.path.exists("/proc/%d" % w)]
        if not alive or p.poll() is not None:
            break
        victim = rng.choice(alive)
        os.kill(victim, signal.SIGKILL)
        workers.remove(victim)
        tally["kills"] += 1
    code, log = settle(p, out, limit, tally)
    tally["detected"] = sum(1 for line in log.splitlines()
                            if line.startswith("[coupler] warning: worker") and "unit cells moved" in line)
    tally["failed"] = int(code != 0)
    if code == 0:
        import json
        with open(os.path.join(out, "run_report.json")) as f:
            tally["moved"] = int(json.load(f)["figures"].get("moved_unit_cells", 0))
    return tally


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--workers", type=int, default=64)
    ap.add_argument("--cells", type=int, default=200)
    ap.add_argument("--steps", type=int, default=50)
    ap.add_argument("--kills", type=int, default=5)
    ap.add_argument("--moves", type=int, default=8, help="workers killed in the moved run")
    ap.add_argument("--spheres", type=int, default=60)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))), "build", "bin"))
    ap.add_argument("--work", default=None)
    a = ap.parse_args()
    work = a.work or tempfile.mkdtemp(prefix="gmh-pool-scale.")
    os.makedirs(work, exist_ok=True)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    subprocess.run([os.path.join(a.bin, "dem_prepare_cell"), "--out", os.path.join(work, "cell"),
                    "--count", str(a.spheres), "--seed", "3"], check=True, stdout=subprocess.DEVNULL)
    cell = os.path.join(work, "cell.ckpt")
    files = {}
    for label, workers, on_loss in (("many", a.workers, "stop"), ("few", min(4, a.workers), "stop"),
                                    ("move", a.workers, "move")):
        files[label] = os.path.join(work, "%s.yaml" % label)
        with open(files[label], "w") as f:
            f.write(scene(cell, a.cells, workers, a.steps, on_loss))
    wall = complete(a.bin, files["many"], os.path.join(work, "undisturbed"), 3600)
    wall_few = complete(a.bin, files["few"], os.path.join(work, "few"), 3600)
    rng = random.Random(a.seed)
    t = time.time()
    loop = exchange_loop_s(os.path.join(work, "undisturbed"))
    tally = disturbed(rng, a.bin, files["many"], os.path.join(work, "disturbed"), a.kills, loop, 6 * wall + 120)
    wall_disturbed = time.time() - t
    t = time.time()
    tally_moved = moved(rng, a.bin, files["move"], os.path.join(work, "moved"), min(a.moves, a.workers - 1), loop,
                        6 * wall + 120)
    wall_moved = time.time() - t
    ok_moved = tally_moved["failed"] == 0
    jobs = a.cells * a.steps
    reference = physics(os.path.join(work, "undisturbed"))
    ok_disturbed = tally["failed"] == 0 and os.path.exists(os.path.join(work, "disturbed", "run_report.json"))
    got = {"undisturbed": answered(os.path.join(work, "undisturbed")), "few": answered(os.path.join(work, "few")),
           "disturbed": answered(os.path.join(work, "disturbed")) if ok_disturbed else 0,
           "moved": answered(os.path.join(work, "moved")) if ok_moved else 0}
    same_few = same(pool(physics(os.path.join(work, "few"))), pool(reference))
    same_disturbed = ok_disturbed and same(physics(os.path.join(work, "disturbed")), reference)
    # A lost worker's own series end where it was lost: the pool's and FEM's must not change.
    same_moved = ok_moved and same(pool(physics(os.path.join(work, "moved"))), pool(reference))
    print("GMH pool at scale: %d workers, %d cells of %d spheres, %d coarse steps, %d unit-cell jobs" %
          (a.workers, a.cells, a.spheres, a.steps, jobs))
    print("%-12s %8s %9s %6s %6s %9s %8s %7s %6s %8s %10s" %
          ("run", "workers", "answered", "lost", "kills", "detected", "resumes", "hangs", "orph.", "wall s", "identical"))
    print("%-12s %8d %9d %6d %6s %9s %8s %7s %6s %8.1f %10s" %
          ("undisturbed", a.workers, got["undisturbed"], jobs - got["undisturbed"], "-", "-", "-", "-", "-", wall, "(ref.)"))
    print("%-12s %8d %9d %6d %6s %9s %8s %7s %6s %8.1f %10s" %
          ("few workers", min(4, a.workers), got["few"], jobs - got["few"], "-", "-", "-", "-", "-", wall_few,
           "yes" if same_few else "NO"))
    print("%-12s %8d %9d %6d %6d %9d %8d %7d %6d %8.1f %10s" %
          ("disturbed", a.workers, got["disturbed"], jobs - got["disturbed"], tally["kills"], tally["detected"],
           tally["resumes"], tally["hangs"], tally["orphans"], wall_disturbed, "yes" if same_disturbed else "NO"))
    print("%-12s %8d %9d %6d %6d %9d %8s %7d %6d %8.1f %10s" %
          ("moved", a.workers, got["moved"], jobs - got["moved"], tally_moved["kills"], tally_moved["detected"],
           "-", tally_moved["hangs"], tally_moved["orphans"], wall_moved, "yes" if same_moved else "NO"))
    print("moved run: %d unit cells moved within the run, %s" %
          (tally_moved["moved"], "completed" if ok_moved else "FAILED (see %s.log)" % os.path.join(work, "moved")))
    print("runs stopped by a doubled or misrouted answer: %d; runs that failed otherwise: %d" %
          (tally["doubled"], tally["failed"]))
    print("(runs in %s)" % work)
    bad = (any(v != jobs for v in got.values()) or not same_few or not same_disturbed or tally["hangs"]
           or tally["orphans"] or tally["doubled"] or tally["detected"] != tally["kills"]
           or not same_moved or tally_moved["hangs"] or tally_moved["orphans"]
           or tally_moved["detected"] != tally_moved["kills"])
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
