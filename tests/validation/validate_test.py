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
import render  # noqa: E402

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

    def test_a_failed_run_deviates_with_its_message(self):
        with tempfile.TemporaryDirectory() as work:
            bad = SCENE.replace("TOL", "0").replace("set: [schedule.end_time=0.01]",
                                                     "set: [schedule.end_time=0.01, schedule.dt=-1]")
            p, rows = run_validate(bad, work)
            self.assertEqual(p.returncode, 1, p.stdout + p.stderr)
            self.assertEqual(rows[1]["status"], "deviates")  # the exit code figure itself
            self.assertEqual(rows[0]["status"], "deviates")
            self.assertIn("exit 2", rows[0]["note"])

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
