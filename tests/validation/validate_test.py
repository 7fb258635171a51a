#!/usr/bin/python3
"""Tests of the validation runner (validation/validate.py) on the mock scene.

A figure inside its tolerance is `reproduced`, one outside it `deviates` and
makes the runner exit 1, a figure of another tier is `not-run`; a broken scene
file is refused with exit 2 naming its key; the doc tables are filled from the
rows. Run by CTest with the build's bin directory as argument.
"""
import json
import os
import subprocess
import sys
import tempfile
import textwrap
import unittest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BIN = sys.argv.pop(1) if len(sys.argv) > 1 else os.path.join(ROOT, "build", "bin")
sys.path.insert(0, os.path.join(ROOT, "validation"))
sys.path.insert(0, os.path.join(ROOT, "bench", "gmh"))
import extract  # noqa: E402
import render  # noqa: E402
import spec  # noqa: E402
import validate  # noqa: E402

SCENE = """
scene: C1
title: mock pair
paper: none (a test of the runner)
runs:
  pair:
    config: configs/demo/two_mocks.yaml
    set: [schedule.end_time=0.01]
    tiers: [quick, standard]
    conditions: [a mock]
  later:
    config: configs/demo/two_mocks.yaml
    tiers: [full]
figures:
  - figure: exchanges
    run: pair
    value: report:exchanges
    unit: "-"
    paper: 10
    source: the schedule (0.01 s at dt 1e-3)
    definition: exchanges of the run.
    tolerance: {abs: TOL}
  - figure: exit code
    run: pair
    value: run:exit_code
    unit: "-"
    paper: 0
    source: the runner
    definition: the exit code.
    tolerance: {abs: 0}
  - figure: full only
    run: later
    value: run:exit_code
    unit: "-"
    paper: 0
    source: the runner
    definition: the exit code.
    tolerance: {abs: 0}
"""


def run_validate(scene_text, work, tier="standard"):
    scenes = os.path.join(work, "scenes")
    os.makedirs(scenes, exist_ok=True)
    with open(os.path.join(scenes, "c1.yaml"), "w") as f:
        f.write(scene_text)
    out = os.path.join(work, "report")
    p = subprocess.run([sys.executable, os.path.join(ROOT, "validation", "validate.py"), "--tier", tier,
                        "--bin", BIN, "--scenes", scenes, "--out", out, "--runs", os.path.join(work, "runs")],
                       capture_output=True, text=True, timeout=120)
    rows = None
    if os.path.exists(os.path.join(out, "report.json")):
        with open(os.path.join(out, "report.json")) as f:
            rows = json.load(f)
    return p, rows


class ValidateRunner(unittest.TestCase):
    def test_inside_the_tolerance_is_reproduced(self):
        with tempfile.TemporaryDirectory() as work:
            p, rows = run_validate(SCENE.replace("TOL", "0"), work)
            self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
            status = {r["figure"]: r["status"] for r in rows}
            self.assertEqual(status, {"exchanges": "reproduced", "exit code": "reproduced", "full only": "not-run"})
            keys = {"scene", "figure", "unit", "paper", "ours", "tolerance", "status", "wall_s", "config",
                    "conditions", "note"}
            for r in rows:
                self.assertTrue(keys <= set(r), r)
            self.assertEqual(rows[0]["ours"], 10)
            self.assertIn("run later is in the full tier", rows[2]["note"])
            self.assertTrue(os.path.exists(os.path.join(work, "report", "report.md")))
            # the quick tier reports the figures of its own runs only
            p, rows = run_validate(SCENE.replace("TOL", "0"), os.path.join(work, "q"), tier="quick")
            self.assertEqual(p.returncode, 0, p.stdout + p.stderr)
            self.assertEqual([r["figure"] for r in rows], ["exchanges", "exit code"])

    def test_a_figure_outside_its_tolerance_fails_the_run(self):
        # 10 exchanges against a paper value of 10 with the tolerance moved off it
        with tempfile.TemporaryDirectory() as work:
            p, rows = run_validate(SCENE.replace("TOL", "0").replace("paper: 10", "paper: 11"), work)
            self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
            self.assertEqual(rows[0]["status"], "deviates")
            self.assertIn("1 deviate", p.stdout)

    def test_a_broken_scene_file_is_named_with_its_key(self):
        with tempfile.TemporaryDirectory() as work:
            p, _ = run_validate(SCENE.replace("TOL", "0").replace("value: report:exchanges", "value: nowhere"), work)
            self.assertEqual(p.returncode, 2)
            self.assertIn("c1.yaml: figures[0].value:", p.stderr)
            p, _ = run_validate(SCENE.replace("TOL", "0").replace("tiers: [quick, standard]", "tiers: [fast]"), work)
            self.assertEqual(p.returncode, 2)
            self.assertIn("runs.pair.tiers: unknown tier 'fast'", p.stderr)
            # only the build's bench programs may stand in for a coupler run
            p, _ = run_validate(SCENE.replace("TOL", "0").replace("config: configs/demo/two_mocks.yaml\n    set",
                                                                   "tool: rm\n    args: [-rf, /]\n    set"), work)
            self.assertEqual(p.returncode, 2)
            self.assertIn("runs.pair.tool: one of l1_elastic_constants", p.stderr)
            # `with` belongs to the extractors over several runs
            p, _ = run_validate(SCENE.replace("TOL", "0").replace("    value: report:exchanges",
                                                                   "    with: [later]\n    value: report:exchanges"), work)
            self.assertEqual(p.returncode, 2)
            self.assertIn("figures[0].with: only the extractors over several runs take it", p.stderr)

    def test_a_failed_run_deviates_with_its_message(self):
        with tempfile.TemporaryDirectory() as work:
            bad = SCENE.replace("TOL", "0").replace("set: [schedule.end_time=0.01]",
                                                     "set: [schedule.end_time=0.01, schedule.dt=-1]")
            p, rows = run_validate(bad, work)
            self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
            self.assertEqual(rows[1]["status"], "deviates")  # the exit code figure itself
            self.assertEqual(rows[0]["status"], "deviates")
            self.assertIn("exit 2", rows[0]["note"])

    def test_a_figure_over_several_runs_reads_each_of_them(self):
        # `with` hands the other runs' directories to an extractor over several runs
        seen = []

        def over(runs, scale):
            seen.append(tuple(runs))
            return {"count": float(len(runs))}
        extract.OVER_RUNS["test_over"] = over
        try:
            sc = {"scene": "C1", "runs": {"a": {"tiers": ["standard"], "config": "c", "set": [], "conditions": []},
                                          "b": {"tiers": ["standard"], "config": "c", "set": [], "conditions": []}},
                  "figures": [{"figure": "f", "run": "a", "with": ["b"], "value": "test_over:count", "unit": "-",
                               "paper": 2, "source": "s", "definition": "d", "tolerance": {"abs": 0}}]}
            results = {("C1", r): {"out": "/runs/" + r, "exit_code": 0, "wall_s": 1.0, "log": "/runs/%s.log" % r}
                       for r in ("a", "b")}
            rows = validate.rows_for(sc, "standard", results)
            self.assertEqual(seen, [("/runs/a", "/runs/b")])
            self.assertEqual((rows[0]["ours"], rows[0]["status"], rows[0]["wall_s"]), (2.0, "reproduced", 2.0))
            del results[("C1", "b")]
            rows = validate.rows_for(sc, "standard", results)
            self.assertEqual(rows[0]["status"], "deviates")
            self.assertIn("run b of this figure did not run", rows[0]["note"])
        finally:
            del extract.OVER_RUNS["test_over"]

    def test_lists_of_overrides_are_joined(self):
        # runs share override lists through YAML anchors: a list of lists is one list
        with tempfile.TemporaryDirectory() as work:
            path = os.path.join(work, "c1.yaml")
            with open(path, "w") as f:
                f.write(SCENE.replace("TOL", "0").replace("set: [schedule.end_time=0.01]",
                                                          "set: [[schedule.end_time=0.01, schedule.dt=1.0e-3], a=1]"))
            sc = spec.load(path, ROOT)
            self.assertEqual(sc["runs"]["pair"]["set"], ["schedule.end_time=0.01", "schedule.dt=1.0e-3", "a=1"])

    def test_the_energy_balance_is_read_from_the_final_energies(self):
        energies = {"pd.external_work": 100.0, "pd.kinetic": 10.0, "pd.strain": 89.0,
                    "dem.external_work": 50.0, "dem.elastic": 40.0, "dem.kinetic": 10.0, "dem.translational": 10.0,
                    "dem.drive_work": -99.5}
        with tempfile.TemporaryDirectory() as run:
            with open(os.path.join(run, "run_report.json"), "w") as f:
                json.dump({"final_energies_J": energies}, f)
            got = extract.energy_figures(run, 1.0)
        self.assertAlmostEqual(got["balance.pd"], 0.01)   # 1 J of 100 J missing
        self.assertAlmostEqual(got["balance.dem"], 0.0)   # translational is part of kinetic, not counted twice
        self.assertAlmostEqual(got["interface.pd.dem"], 0.005)
        self.assertNotIn("interface.dem.pd", got)         # PD has no driven particles

    def test_the_mesh_spread_of_curves(self):
        import numpy as np
        import l5_biaxial
        eps = np.linspace(0, 0.03, 31)
        curve = 1e6 * (1 + 10 * eps - 300 * eps ** 2)   # a peak at 1.67 %
        runs = [{"eps": eps, "sig": curve}, {"eps": eps, "sig": 0.9 * curve}]
        start, post, whole = l5_biaxial.mode_spread(runs, 0.03)
        self.assertAlmostEqual(start, 0.017, places=3)
        mean_peak = 0.95 * curve.max()
        self.assertAlmostEqual(post[1], 0.1 * np.interp(start, eps, curve) / mean_peak, places=3)
        self.assertAlmostEqual(whole[1], 0.1 * curve.max() / mean_peak, places=2)
        _, same, _ = l5_biaxial.mode_spread([runs[0], dict(runs[0])], 0.03)
        self.assertEqual(same, (0.0, 0.0))

    def test_doc_tables_are_filled_from_the_rows(self):
        rows = [{"scene": "C1", "figure": "err", "unit": "m", "paper": 0.01, "ours": 0.008, "tolerance": "at most 0.01",
                 "status": "reproduced", "wall_s": 3.0, "config": "c", "conditions": "the paper's", "note": "",
                 "tier": "standard", "run": "r"}]
        with tempfile.TemporaryDirectory() as work:
            doc = os.path.join(work, "doc.md")
            with open(doc, "w") as f:
                f.write(textwrap.dedent("""\
                    text
                    <!-- validation: C1 -->
                    old
                    <!-- /validation -->
                    <!-- validation: summary -->
                    <!-- /validation -->
                    """))
            self.assertEqual(render.docs(rows, [doc]), [doc])
            text = open(doc).read()
            self.assertNotIn("old", text)
            self.assertIn("| err | 0.008 | 0.01 | m | at most 0.01 | reproduced |", text)
            self.assertIn("| C1 | 1 of 1 | err |", text)


if __name__ == "__main__":
    unittest.main(verbosity=2)
