"""Reading and checking the scene files of validation/scenes/ (format: validation/README.md).

Every problem is reported as `file: key: message`, so a broken scene file is
named before anything runs.
"""
import os

import yaml

import extract

# The scenes of ../shared/scenes/README.md, in the report's order.
SCENE_ORDER = ["C1", "C2a", "C2b", "H1", "H2", "H3", "H4", "H5", "L1", "L2", "L3", "L4", "L5"]
TIER_NAMES = ("quick", "standard", "full")
TOLERANCE_KEYS = ("rel", "abs", "min", "max")
# bench programs a run may start in place of `coupler run` (their figures are read from their output)
TOOLS = ("l1_elastic_constants",)


class SceneError(Exception):
    pass


def runs_in(tier, run_tiers):
    """A run listed for `standard` also runs in `full`; `quick` runs are their own."""
    return tier in run_tiers or (tier == "full" and "standard" in run_tiers)


def _fail(path, key, message):
    raise SceneError("%s: %s: %s" % (os.path.relpath(path), key, message))


def _need(d, key, kind, path, where):
    if key not in d:
        _fail(path, where + key, "missing")
    if not isinstance(d[key], kind):
        _fail(path, where + key, "must be %s" % getattr(kind, "__name__", kind))
    return d[key]


def _check_run(path, name, run, root):
    where = "runs.%s." % name
    if not isinstance(run, dict):
        _fail(path, "runs." + name, "must be a map")
    unknown = set(run) - {"config", "set", "tiers", "conditions", "needs", "timeout_s", "threads", "note", "tool",
                          "args"}
    if unknown:
        _fail(path, where + sorted(unknown)[0], "unknown key")
    if "tool" in run:  # a bench program of the build in place of a coupler run
        if run["tool"] not in TOOLS or "config" in run or not isinstance(run.get("args", []), list):
            _fail(path, where + "tool", "one of %s, with args (a list) and no config" % ", ".join(TOOLS))
        run.setdefault("args", [])
        run["config"] = ""
    if run.get("tiers") == []:
        # declared, run by no tier of validate.sh: the note says what computes the figures today
        _need(run, "note", str, path, where)
        run.setdefault("config", "")
    config = _need(run, "config", str, path, where)
    if config or ("tool" not in run and run["tiers"] != []):  # a coupler run needs its scene
        if not config.startswith("configs/"):
            _fail(path, where + "config", "a validation run runs a scene of configs/")
        if not os.path.isfile(os.path.join(root, config)):
            _fail(path, where + "config", "no such file %s" % config)
    run.setdefault("set", [])
    run.setdefault("conditions", [])
    run.setdefault("needs", [])
    for key in ("set", "conditions"):  # lists of lists (YAML anchors shared by runs) are joined
        if isinstance(run[key], list):
            run[key] = [s for item in run[key] for s in (item if isinstance(item, list) else [item])]
    for key in ("set", "conditions", "needs"):
        if not isinstance(run[key], list) or not all(isinstance(s, str) for s in run[key]):
            _fail(path, where + key, "must be a list of strings")
    tiers = _need(run, "tiers", list, path, where)
    for t in tiers:
        if t not in TIER_NAMES:
            _fail(path, where + "tiers", "unknown tier '%s' (quick, standard, full)" % t)
    run.setdefault("timeout_s", 600)
    if not isinstance(run["timeout_s"], (int, float)) or run["timeout_s"] <= 0:
        _fail(path, where + "timeout_s", "must be a positive number of seconds")


def _check_figure(path, i, fig, runs):
    where = "figures[%d]." % i
    if not isinstance(fig, dict):
        _fail(path, "figures[%d]" % i, "must be a map")
    unknown = set(fig) - {"figure", "run", "value", "unit", "paper", "source", "definition", "tolerance", "scale",
                          "per", "with", "note", "headline"}
    if unknown:
        _fail(path, where + sorted(unknown)[0], "unknown key")
    for key in ("figure", "run", "unit", "source", "definition"):
        _need(fig, key, str, path, where)
    if fig["run"] not in runs:
        _fail(path, where + "run", "no run named '%s'" % fig["run"])
    if runs[fig["run"]]["tiers"] or "value" in fig:  # a run of no tier has no value to read yet
        _need(fig, "value", str, path, where)
        problem = extract.check(fig["value"])
        if problem:
            _fail(path, where + "value", problem)
    if "per" in fig:
        per = fig["per"]
        if not isinstance(per, dict) or set(per) != {"run", "value"} or per["run"] not in runs:
            _fail(path, where + "per", "takes run (a run of this scene) and value")
        problem = extract.check(per["value"])
        if problem:
            _fail(path, where + "per.value", problem)
    if "with" in fig:  # a figure of several runs: the extractor reads the others' outputs too
        others = fig["with"]
        if not isinstance(others, list) or not others or not all(o in runs for o in others):
            _fail(path, where + "with", "takes a list of runs of this scene")
        if fig.get("value", "").partition(":")[0].partition("@")[0] not in extract.OVER_RUNS:
            _fail(path, where + "with", "only the extractors over several runs take it (%s)"
                  % ", ".join(sorted(extract.OVER_RUNS)))
    if "paper" not in fig:
        _fail(path, where + "paper", "missing (a number, or a text where the paper gives no number)")
    tol = _need(fig, "tolerance", dict, path, where)
    if not tol or set(tol) - set(TOLERANCE_KEYS):
        _fail(path, where + "tolerance", "takes rel, abs (around the paper's number) or min and/or max")
    if not all(isinstance(v, (int, float)) for v in tol.values()):
        _fail(path, where + "tolerance", "values must be numbers")
    if ("rel" in tol or "abs" in tol) and not isinstance(fig["paper"], (int, float)):
        _fail(path, where + "tolerance", "rel and abs need a numeric paper value; use min/max")
    if ("rel" in tol or "abs" in tol) and ("min" in tol or "max" in tol):
        _fail(path, where + "tolerance", "either rel/abs or min/max")


def load(path, root):
    try:
        with open(path) as f:
            sc = yaml.safe_load(f)
    except (OSError, yaml.YAMLError) as e:
        raise SceneError("%s: %s" % (os.path.relpath(path), e))
    if not isinstance(sc, dict):
        _fail(path, "(top)", "must be a map")
    unknown = set(sc) - {"scene", "title", "paper", "runs", "figures", "plots", "notes", "prepare", "definitions"}
    if unknown:
        _fail(path, sorted(unknown)[0], "unknown key")
    if _need(sc, "scene", str, path, "") not in SCENE_ORDER:
        _fail(path, "scene", "'%s' is not a scene of shared/scenes/README.md (%s)" % (sc["scene"],
                                                                                     ", ".join(SCENE_ORDER)))
    _need(sc, "title", str, path, "")
    _need(sc, "paper", str, path, "")
    runs = _need(sc, "runs", dict, path, "")
    for name, run in runs.items():
        _check_run(path, name, run, root)
    for name, run in runs.items():
        for dep in run["needs"]:
            if dep not in runs:
                _fail(path, "runs.%s.needs" % name, "no run named '%s'" % dep)
            if not all(runs_in(t, runs[dep]["tiers"]) for t in run["tiers"]):
                _fail(path, "runs.%s.needs" % name, "run '%s' is not in every tier of this run" % dep)
    figs = _need(sc, "figures", list, path, "")
    for i, fig in enumerate(figs):
        _check_figure(path, i, fig, runs)
    prep = sc.setdefault("prepare", {})
    if not isinstance(prep, dict):
        _fail(path, "prepare", "must be a map of NAME: {tool, args}")
    for name, p in prep.items():
        if not isinstance(p, dict) or set(p) - {"tool", "args", "timeout_s"} or p.get("tool") != "dem_prepare_cell" \
                or not isinstance(p.get("args"), list):
            _fail(path, "prepare." + str(name), "takes tool (dem_prepare_cell) and args (a list)")
    sc.setdefault("plots", [])
    if not isinstance(sc["plots"], list):
        _fail(path, "plots", "must be a list")
    sc["file"] = os.path.relpath(path, root)
    return sc


def load_all(directory, wanted):
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    scenes = []
    for name in sorted(os.listdir(directory)):
        if name.endswith(".yaml"):
            scenes.append(load(os.path.join(directory, name), root))
    ids = [s["scene"] for s in scenes]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        raise SceneError("%s: scene %s is declared twice" % (directory, sorted(dup)[0]))
    for w in wanted:
        if w not in ids:
            raise SceneError("no scene '%s' in %s (there are %s)" % (w, os.path.relpath(directory), ", ".join(ids)))
    chosen = [s for s in scenes if not wanted or s["scene"] in wanted]
    order = {s: i for i, s in enumerate(SCENE_ORDER)}
    return sorted(chosen, key=lambda s: order[s["scene"]])
