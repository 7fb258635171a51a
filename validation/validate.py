#!/usr/bin/python3
"""Runs the validation scenes of validation/scenes/*.yaml and writes the report.

  validate.py [--tier quick|standard|full] [--jobs N] [--bin DIR] [--out DIR]
              [--runs DIR] [--list] [SCENE ...]

Each scene file declares its runs (a config of configs/ with --set overrides,
the tiers that run it, the departures from the paper's conditions) and its
figures (where each value is read, the paper's value and source, the
definition, the tolerance). Every run of the tier is started with `coupler
run`; every figure is then read from the run's outputs and judged:
`reproduced` (inside the tolerance), `deviates` (outside it, or its run
failed) or `not-run` (its run is not part of this tier, the note says which
tier has it). report.json keeps the rows of scenes not named on the command
line from its previous contents, so one scene can be rerun alone.

Exit status: 0 when no figure deviates, 1 when one does, 2 for bad usage or a
bad scene file (named with its key).
Needs PyYAML, numpy, h5py and matplotlib (Debian's /usr/bin/python3).
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import extract  # noqa: E402  (the named extractors of the figures)
import render  # noqa: E402   (report.md, figures, doc tables)
import spec  # noqa: E402     (scene files: reading and checking)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TIERS = ("quick", "standard", "full")


def prepare(sc, binaries, runs_root):
    """Builds the inputs a scene declares under `prepare` (unit cells), cached by their arguments.

    Returns {NAME: base path}; a cached input is reused when its arguments are the same.
    """
    paths = {}
    for name, p in sc.get("prepare", {}).items():
        key = hashlib.sha1(json.dumps([p["tool"], p["args"]]).encode()).hexdigest()[:12]
        d = os.path.join(runs_root, "cache", "%s-%s" % (name, key))
        base = os.path.join(d, name)
        paths[name] = base
        if os.path.exists(os.path.join(d, "done")):
            continue
        os.makedirs(d, exist_ok=True)
        cmd = [os.path.join(binaries, p["tool"]), "--out", base] + [str(a) for a in p["args"]]
        print("validate: prepare %s/%s: %s" % (sc["scene"], name, " ".join(cmd)), flush=True)
        with open(base + ".log", "w") as f:
            code = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=p.get("timeout_s", 3600)).returncode
        if code != 0:
            raise spec.SceneError("%s: prepare.%s: %s exited with %d (see %s)" % (sc["file"], name, p["tool"], code,
                                                                                 base + ".log"))
        open(os.path.join(d, "done"), "w").close()
    return paths


def command_for(run, binaries, out_dir, run_dirs):
    def fill(s):
        # {NAME} is the output directory of run NAME of the same scene, {prepare.NAME} a
        # prepared input, {root} the checkout
        for name, path in run_dirs.items():
            s = s.replace("{%s}" % name, path)
        return s.replace("{root}", ROOT)
    if "tool" in run:  # a bench program of the build (its stdout is the run's output)
        return [os.path.join(binaries, run["tool"])] + [fill(str(a)) for a in run["args"]]
    cmd = [os.path.join(binaries, "coupler"), "run", os.path.join(ROOT, run["config"]), "--out", out_dir,
           "--no-progress"]
    for s in run["set"]:
        cmd += ["--set", fill(s)]
    return cmd


def execute(run, binaries, out_dir, run_dirs):
    """Runs one scene run; returns {exit_code, wall_s, log}. Never raises for a failed run."""
    os.makedirs(os.path.dirname(out_dir), exist_ok=True)
    cmd = command_for(run, binaries, out_dir, run_dirs)
    env = dict(os.environ)
    env.setdefault("OMP_NUM_THREADS", str(run.get("threads", 1)))
    log = out_dir + ".log"
    if "tool" in run:
        os.makedirs(out_dir, exist_ok=True)
        log = os.path.join(out_dir, "output.txt")
    print("validate: start %s" % os.path.relpath(out_dir, os.path.dirname(os.path.dirname(os.path.dirname(out_dir)))),
          flush=True)
    start = time.monotonic()
    with open(log, "w") as f:
        f.write("$ " + " ".join(cmd) + "\n")
        f.flush()
        try:
            code = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, env=env,
                                  timeout=run["timeout_s"]).returncode
        except subprocess.TimeoutExpired:
            code = 124
            f.write("validate: the run passed its timeout_s of %g s and was stopped\n" % run["timeout_s"])
    res = {"exit_code": code, "wall_s": time.monotonic() - start, "log": log, "out": out_dir, "bin": binaries}
    if "tool" in run:
        with open(os.path.join(out_dir, "run.json"), "w") as f:
            json.dump({"exit_code": code, "wall_s": res["wall_s"]}, f)
    return res


def reused(out_dir, binaries):
    """The result of an earlier run in out_dir (its run report), or None."""
    try:
        if os.path.exists(os.path.join(out_dir, "run.json")):  # a tool's run
            with open(os.path.join(out_dir, "run.json")) as f:
                r = json.load(f)
            return {"exit_code": int(r["exit_code"]), "wall_s": float(r["wall_s"]),
                    "log": os.path.join(out_dir, "output.txt"), "out": out_dir, "bin": binaries}
        with open(os.path.join(out_dir, "run_report.json")) as f:
            r = json.load(f)
        return {"exit_code": int(r["exit_code"]), "wall_s": float(r["wall_s"]["total"]), "log": out_dir + ".log",
                "out": out_dir, "bin": binaries}
    except (OSError, ValueError, KeyError, TypeError):
        return None


def schedule_runs(scenes, tier, jobs, binaries, runs_root, reuse=False):
    """Runs every run of the tier, references before the runs that read them.

    reuse: a run whose directory holds a run report from an earlier call is read, not run again."""
    pending = {}
    done = {}
    prepared = {}
    for sc in scenes:
        for name, run in sc["runs"].items():
            if spec.runs_in(tier, run["tiers"]):
                pending[(sc["scene"], name)] = run
                if sc["scene"] not in prepared:
                    prepared[sc["scene"]] = prepare(sc, binaries, runs_root)
    dirs = {key: os.path.join(runs_root, tier, key[0], key[1]) for key in pending}
    if reuse:
        for key in list(pending):
            earlier = reused(dirs[key], binaries)
            if earlier is not None:
                done[key] = earlier
                del pending[key]
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs)) as pool:
        futures = {}
        while pending or futures:
            for key, run in list(pending.items()):
                deps = [(key[0], d) for d in run["needs"]]
                if any(d not in done for d in deps):
                    continue
                del pending[key]
                run_dirs = {d[1]: dirs[d] for d in deps}
                run_dirs.update({"prepare." + k: v for k, v in prepared[key[0]].items()})
                futures[pool.submit(execute, run, binaries, dirs[key], run_dirs)] = key
            if not futures:
                missing = ", ".join("%s/%s" % k for k in pending)
                raise spec.SceneError("runs wait on runs that are not in this tier: " + missing)
            finished, _ = concurrent.futures.wait(futures, return_when=concurrent.futures.FIRST_COMPLETED)
            for fut in finished:
                key = futures.pop(fut)
                done[key] = fut.result()
                r = done[key]
                print("validate: done  %s/%s: exit %d in %.1f s" % (key + (r["exit_code"], r["wall_s"])), flush=True)
    return done


def judge(value, tol):
    """True when value lies inside the tolerance (spec.check_tolerance lists the forms)."""
    if value is None or value != value:
        return False
    paper = tol.get("paper")
    if "rel" in tol:
        return abs(value - paper) <= tol["rel"] * abs(paper)
    if "abs" in tol:
        return abs(value - paper) <= tol["abs"]
    lo, hi = tol.get("min", -float("inf")), tol.get("max", float("inf"))
    return lo <= value <= hi


def tolerance_text(tol):
    if "rel" in tol:
        return "within %g %% of the paper" % (100 * tol["rel"])
    if "abs" in tol:
        return "within %g of the paper" % tol["abs"]
    if "min" in tol and "max" in tol:
        return "in [%g, %g]" % (tol["min"], tol["max"])
    if "max" in tol:
        return "at most %g" % tol["max"]
    return "at least %g" % tol["min"]


def stop_message(res):
    """The run report's message of a stopped run (its first 300 characters), or where its log is."""
    try:
        with open(os.path.join(res["out"], "run_report.json")) as f:
            message = json.load(f).get("message", "")
    except (OSError, ValueError):
        message = ""
    return message[:300] or "see " + os.path.relpath(res["log"], ROOT)


def _result_of(results, sc, run):
    res = results.get((sc["scene"], run))
    if res is None:
        raise extract.Missing("run %s of this figure did not run" % run)
    return res


def rows_for(sc, tier, results):
    rows = []
    for fig in sc["figures"]:
        run = sc["runs"][fig["run"]]
        # the quick tier reports the figures of its runs; the other tiers all the others
        reported = "quick" in run["tiers"] if tier == "quick" else (not run["tiers"] or set(run["tiers"]) - {"quick"})
        if not reported:
            continue
        tol = dict(fig["tolerance"])
        if isinstance(fig["paper"], (int, float)):
            tol.setdefault("paper", fig["paper"])
        row = {"scene": sc["scene"], "figure": fig["figure"], "unit": fig["unit"], "paper": fig["paper"],
               "ours": None, "tolerance": tolerance_text(tol), "status": "not-run", "wall_s": None,
               "config": (run["config"] + "".join(" --set " + s for s in run["set"]) if "tool" not in run
                          else "build/bin/" + " ".join([run["tool"]] + [str(a) for a in run["args"]])),
               "conditions": "; ".join(run["conditions"]) or "the paper's",
               "note": fig.get("note", ""), "source": fig["source"], "definition": fig["definition"],
               "tier": tier, "run": fig["run"], "headline": bool(fig.get("headline"))}
        res = results.get((sc["scene"], fig["run"]))
        if res is None:
            where = [t for t in TIERS if spec.runs_in(t, run["tiers"])]
            if where:
                why = "run %s is in the %s tier%s" % (fig["run"], " and ".join(where), "s" if len(where) > 1 else "")
            else:
                why = "not run by validate.sh: " + run["note"]
            row["note"] = why + ("; " + row["note"] if row["note"] else "")
            rows.append(row)
            continue
        row["wall_s"] = round(res["wall_s"], 2)
        try:
            if "with" in fig:  # a figure of several runs costs all of them
                others = [_result_of(results, sc, other) for other in fig["with"]]
                res = dict(res, **{"with": [o["out"] for o in others]})
                row["wall_s"] = round(res["wall_s"] + sum(o["wall_s"] for o in others), 2)
            value = extract.value(fig["value"], res)
            if "per" in fig:  # a ratio: this value over another run's (or another of this run's)
                other = results.get((sc["scene"], fig["per"]["run"]))
                if other is None:
                    raise extract.Missing("run %s of the ratio did not run" % fig["per"]["run"])
                value /= extract.value(fig["per"]["value"], other)
        except extract.Missing as e:
            value = None
            row["note"] = ("%s (exit %d, log %s)" % (e, res["exit_code"], os.path.relpath(res["log"], ROOT))
                           + ("; " + row["note"] if row["note"] else ""))
        if value is not None:
            value = value * fig.get("scale", 1.0)
            row["ours"] = float("%.6g" % value)
        row["status"] = "reproduced" if judge(value, tol) else "deviates"
        if res["exit_code"] != 0 and not fig["value"].startswith("run:exit_code"):
            # a figure of a run that stopped early is not the paper's quantity, whatever its value
            row["status"] = "deviates"
            row["note"] = "the run stopped with exit %d: %s%s" % (res["exit_code"], stop_message(res),
                                                                 "; " + row["note"] if row["note"] else "")
        rows.append(row)
    return rows


def merged(previous_path, rows, scenes_run):
    """The rows of this run, and those of other scenes from the previous report."""
    keep = []
    if os.path.exists(previous_path):
        try:
            with open(previous_path) as f:
                keep = [r for r in json.load(f) if r.get("scene") not in scenes_run]
        except (OSError, ValueError) as e:
            print("validate: %s is not a report (%s); writing it anew" % (previous_path, e), file=sys.stderr)
    order = {s: i for i, s in enumerate(spec.SCENE_ORDER)}
    return sorted(keep + rows, key=lambda r: order.get(r["scene"], len(order)))


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenes", nargs="*", help="scene ids (C1, C2a, H1 ...); default: all")
    ap.add_argument("--tier", choices=TIERS, default="standard")
    ap.add_argument("--jobs", type=int, default=1, help="runs at a time")
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"), help="directory with coupler and the solvers")
    ap.add_argument("--out", default=None, help="report directory (default validation/, quick: runs/validation/quick)")
    ap.add_argument("--runs", default=os.path.join(ROOT, "runs", "validation"), help="where the runs are written")
    ap.add_argument("--list", action="store_true", help="print the runs and figures of the tier; run nothing")
    ap.add_argument("--reuse", action="store_true",
                    help="read the runs that have a run report from an earlier call instead of running them again")
    ap.add_argument("--scenes", default=os.path.join(ROOT, "validation", "scenes"), dest="scene_dir",
                    help="the scene files' directory")
    a = ap.parse_args(argv)
    try:
        scenes = spec.load_all(a.scene_dir, a.scenes)
    except spec.SceneError as e:
        print("validate: %s" % e, file=sys.stderr)
        return 2
    if a.list:
        for sc in scenes:
            for name, run in sc["runs"].items():
                if spec.runs_in(a.tier, run["tiers"]):
                    print("%-4s %-22s %s" % (sc["scene"], name, " ".join(command_for(run, a.bin, "OUT", {}))[:200]))
        return 0
    if not os.access(os.path.join(a.bin, "coupler"), os.X_OK):
        print("validate: no coupler in %s (build first: scripts/setup.sh)" % a.bin, file=sys.stderr)
        return 2
    os.environ["COSIM_VALIDATION_BIN"] = os.path.abspath(a.bin)  # for the extractors that run bench tools
    out = a.out or (os.path.join(a.runs, "quick") if a.tier == "quick" else os.path.join(ROOT, "validation"))
    os.makedirs(out, exist_ok=True)
    start = time.monotonic()
    try:
        results = schedule_runs(scenes, a.tier, a.jobs, os.path.abspath(a.bin), os.path.abspath(a.runs), a.reuse)
    except spec.SceneError as e:
        print("validate: %s" % e, file=sys.stderr)
        return 2
    rows = [r for sc in scenes for r in rows_for(sc, a.tier, results)]
    report_path = os.path.join(out, "report.json")
    all_rows = merged(report_path, rows, {sc["scene"] for sc in scenes})
    with open(report_path, "w") as f:
        json.dump(all_rows, f, indent=1)
        f.write("\n")
    render.figures(scenes, rows, results, os.path.join(out, "figures"))
    render.report_md(all_rows, os.path.join(out, "report.md"), a.tier, time.monotonic() - start)
    if os.path.abspath(out) == os.path.join(ROOT, "validation"):
        for p in render.docs(all_rows, render.doc_files()):
            print("validate: updated the validation tables of %s" % os.path.relpath(p, ROOT))
    bad = [r for r in rows if r["status"] == "deviates"]
    for r in rows:
        print("%-10s %-4s %-44s ours %-12s paper %-12s %s" % (r["status"], r["scene"], r["figure"][:44],
                                                              "-" if r["ours"] is None else "%.6g" % r["ours"],
                                                              r["paper"], r["tolerance"]))
    print("validate: %d figures: %d reproduced, %d deviate, %d not run; %.0f s; report %s" % (
        len(rows), sum(r["status"] == "reproduced" for r in rows), len(bad),
        sum(r["status"] == "not-run" for r in rows), time.monotonic() - start, report_path))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
