"""Where a validation figure's value is read (the `value` key of a figure).

  run:exit_code | run:wall_s                 the run itself (a `tool` run's output is output.txt)
  report:figures.NAME | report:errors.NAME   run_report.json (errors by name)
  report:KEY[.KEY...]                        any number in run_report.json
  hdf5:FILE:DATASET:REDUCTION                  a dataset of FILE in the run directory, reduced by
                                             max, min, absmax, last, first or mean
  energy:balance.SOLVER | energy:interface.PD.DEM   conservation of the final energies
  NAME:KEY, NAME@S:KEY                       a named extractor below (scene statistics computed
                                             from the snapshots), its figure KEY; @S: the run was
                                             loaded S times faster than the paper, so the paper's
                                             time t is read at t / S

An extractor is a function of the run directory that returns a dict of
figures; it is registered in EXTRACTORS under the name the scene files use.
"""
import json
import math
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "bench", "coupled"))
sys.path.insert(0, os.path.join(ROOT, "bench", "gmh"))


class Missing(Exception):
    """The value is not in the run's outputs (the run failed or stopped early)."""


def _report(res):
    path = os.path.join(res["out"], "run_report.json")
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise Missing("no run report (%s)" % e.__class__.__name__)


def _from_report(res, key):
    r = _report(res)
    parts = key.split(".")
    if parts[0] == "errors":
        for e in r.get("errors", []):
            if e["name"] == parts[1]:
                return float(e["value"])
        raise Missing("the run report has no error '%s' (status %s)" % (parts[1], r.get("status")))
    node = r
    for p in parts:
        if not isinstance(node, dict) or p not in node:
            raise Missing("the run report has no '%s' (status %s)" % (key, r.get("status")))
        node = node[p]
    return float(node)


REDUCTIONS = {
    "max": lambda a: float(a.max()),
    "min": lambda a: float(a.min()),
    "absmax": lambda a: float(abs(a).max()),
    "first": lambda a: float(a.flat[0]),
    "last": lambda a: float(a.flat[-1]),
    "mean": lambda a: float(a.mean()),
}


def _from_h5(res, key):
    import h5py
    name, dataset, reduction = key.split(":")
    path = os.path.join(res["out"], name)
    try:
        with h5py.File(path, "r") as f:
            data = f[dataset][:]
    except (OSError, KeyError) as e:
        raise Missing("%s has no %s (%s)" % (name, dataset, e.__class__.__name__))
    if data.size == 0:
        raise Missing("%s:%s is empty" % (name, dataset))
    return REDUCTIONS[reduction](data)


_cache = {}


def _from_extractor(res, source, key):
    name, _, scale = source.partition("@")
    others = tuple(res.get("with", ()))
    if (source, res["out"], others) not in _cache:
        try:
            if name in OVER_RUNS:
                figures = OVER_RUNS[name]((res["out"],) + others, float(scale or 1.0))
            else:
                figures = EXTRACTORS[name](res["out"], float(scale or 1.0))
        except (OSError, KeyError, ValueError, IndexError) as e:
            raise Missing("extractor %s found no data (%s: %s)" % (name, e.__class__.__name__, e))
        _cache[(source, res["out"], others)] = figures
    figures = _cache[(source, res["out"], others)]
    if key not in figures:
        raise Missing("extractor %s gave no %s (the run may have stopped before it)" % (name, key))
    return figures[key]


def value(where, res):
    """The number `where` names in the outputs of run result `res` ({out, exit_code, wall_s}; `with`:
    the output directories of the other runs an extractor over several runs reads)."""
    source, _, key = where.partition(":")
    if source == "run":
        return float(res[key])
    if source == "report":
        v = _from_report(res, key)
    elif source == "hdf5":
        v = _from_h5(res, key)
    else:
        v = _from_extractor(res, source, key)
    if not math.isfinite(v):
        raise Missing("%s is not finite (%r)" % (where, v))
    return v


def check(where):
    """The error message for a malformed `value`, or None."""
    source, sep, key = where.partition(":")
    if not sep or not key:
        return "must be SOURCE:KEY (run, report, hdf5 or an extractor: %s)" % ", ".join(sorted(EXTRACTORS))
    if source == "run" and key not in ("exit_code", "wall_s"):
        return "run: takes exit_code or wall_s"
    if source == "hdf5":
        parts = key.split(":")
        if len(parts) != 3 or parts[2] not in REDUCTIONS:
            return "hdf5:FILE:DATASET:REDUCTION with REDUCTION one of %s" % ", ".join(REDUCTIONS)
    name, at, scale = source.partition("@")
    if at and not scale.replace(".", "", 1).isdigit():
        return "the time scale after @ must be a positive number"
    if source not in ("run", "report", "hdf5") and name not in EXTRACTORS and name not in OVER_RUNS:
        return "unknown source '%s' (run, report, hdf5, %s)" % (source, ", ".join(sorted(set(EXTRACTORS) | set(OVER_RUNS))))
    return None


# --- conservation of the run's final energies (run_report.json final_energies_J) ---

# the terms a solver's work goes into; DEM's translational and rotational energies are parts of its kinetic
STORED = ("kinetic", "strain", "elastic", "potential", "dissipated", "viscous_dissipated", "hourglass")


def energy_figures(run, scale):
    """balance.SOLVER: |W_ext - sum of STORED| / |W_ext| for each solver that reports external work;
    interface.PD.DEM: |W_ext(PD) + drive work(DEM)| / |W_ext(PD)|, the work the contact forces do
    on the PD body against the work DEM's driven (hybrid) particles receive, for every such pair."""
    energies = _report({"out": run}).get("final_energies_J", {})
    solvers = {k.partition(".")[0] for k in energies}
    out = {}
    for a in solvers:
        work = energies.get(a + ".external_work")
        if not work:
            continue
        stored = sum(energies.get("%s.%s" % (a, term), 0.0) for term in STORED)
        out["balance." + a] = abs(work - stored) / abs(work)
        for b in solvers - {a}:
            if energies.get(b + ".drive_work"):
                out["interface.%s.%s" % (a, b)] = abs(work + energies[b + ".drive_work"]) / abs(work)
    return out


# --- named extractors: statistics of the H3-H5 snapshots (Hartmann 2022 Sec. 5) ---

def _pd_snapshots(run):
    from pd_scene_stats import snapshots
    return snapshots(os.path.join(run, "pd.h5"))[1]


def _at(snaps, t):
    """The snapshot at run time t, or None when the run did not reach it (half an interval of slack)."""
    times = [s[0] for s in snaps]
    slack = 0.5 * (times[-1] - times[-2]) if len(times) > 1 else 1e-9
    if t > times[-1] + slack:
        return None
    return min(snaps, key=lambda s: abs(s[0] - t))[2]


def h3_figures(run, scale):
    """Sec. 5.2, Figs. 10-11: Green-Lagrange E_zz and von Mises stress at paper time 12 s."""
    import numpy as np
    g = _at(_pd_snapshots(run), 12.0 / scale)
    if g is None:
        return {}
    e = g["strain"][:]
    vm = g["von_mises"][:]
    return {"max_abs_Ezz": float(np.abs(e[:, 2]).max()), "max_von_mises_Pa": float(vm.max())}


def _displacements_at(run, scale, times, figures_of):
    """figures_of(t, u) for the PD displacements u [m] at each paper time t the run reached."""
    snaps = _pd_snapshots(run)
    out = {}
    for t in times:
        g = _at(snaps, t / scale)
        if g is not None:
            out.update(figures_of(t, g["displacement"][:]))
    return out


def h4_figures(run, scale):
    """Sec. 5.3, Fig. 13: max |u_x| at 7.5, 17.5, 22.15 s and max u_z at 17.5 s, in cm."""
    import numpy as np

    def at(t, u):
        out = {"max_abs_ux_cm_t%g" % t: float(100 * np.abs(u[:, 0]).max())}
        if t == 17.5:
            out["max_uz_cm_t17.5"] = float(100 * u[:, 2].max())
        return out
    return _displacements_at(run, scale, (7.5, 17.5, 22.15), at)


def h5_figures(run, scale):
    """Sec. 5.4, Fig. 15: mean and max in-plane displacement of the PD particles at 1, 2, 3 s, in cm."""
    import numpy as np

    def at(t, u):
        lat = np.hypot(u[:, 0], u[:, 1])
        return {"mean_inplane_cm_t%g" % t: float(100 * lat.mean()), "max_inplane_cm_t%g" % t: float(100 * lat.max())}
    return _displacements_at(run, scale, (1.0, 2.0, 3.0), at)


# --- scene C2 (Cheng 2022 Sec. 6.2): the Arlequin coupling's weighted series ---

def c2_figures(run, scale):
    """Dissipation over the paper's window and the weighted mass drift, from coupler.h5.

    The paper's ratio (shared/reference/cheng2022/README.md) is (E(t1) - E(t2)) / E(t1) with
    E the weighted DEM (kinetic + elastic) plus FEM (kinetic + strain) energy, t1 = 19.3 ms
    (before the wave reaches the zone) and t2 = 60.8 ms (1P; 19.9 to 81.7 ms for 2P-4P), the penalty's energy left out:
    the coupling's series `energy` (increment form) is that sum.
    """
    import h5py
    import numpy as np
    with h5py.File(os.path.join(run, "coupler.h5"), "r") as f:
        t = f["series/time"][:]
        groups = [k for k in f["series"] if "mass" in f["series"][k] and "energy" in f["series"][k]]
        if not groups:
            return {}
        g = f["series"][groups[0]]
        e, m = g["energy"][:], g["mass"][:]
        dem, fem = g["dem_energy"][:], g["fem_energy"][:]
    out = {"mass_drift": float(np.abs(m - m[0]).max() / abs(m[0])), "initial_mass": float(m[0])}
    out.update(_against_published_c2(t, dem, fem))
    # 1P: rows 20 -> 63 of the published series; 2P-4P: rows 20 -> 82 (19.9 -> 81.7 ms)
    for t1, t2 in ((0.0193, 0.0608), (0.0199, 0.0817)):
        if t[-1] >= t2 / scale:
            e1, e2 = np.interp(t1 / scale, t, e), np.interp(t2 / scale, t, e)
            out["dissipation_%g_%g" % (1e3 * t1, 1e3 * t2)] = float((e1 - e2) / e1)
    return out


PUBLISHED_C2 = os.path.join(ROOT, "validation", "published", "cheng2022_pulsewave1p")


def published_c2():
    """The published 1P c = 0 run (units mm, ug, ms, nJ): t [s], weighted DEM and FEM energies [J], total mass [kg]."""
    import numpy as np
    ene = np.loadtxt(os.path.join(PUBLISHED_C2, "coupled_c0.ene"), skiprows=1)
    trace = np.loadtxt(os.path.join(PUBLISHED_C2, "coupled_c0_trace.dat"))
    n = min(len(ene), len(trace))
    ene, trace = ene[:n], trace[:n]
    # .ene: translational + rotational kinetic + elastic; Trace.dat: kinetic (11) + strain (13)
    return {"t": 1e-3 * ene[:, 0], "dem": 1e-9 * (ene[:, 9] + ene[:, 10] + ene[:, 11]),
            "fem": 1e-9 * (trace[:, 11] + trace[:, 13]), "mass": 1e-9 * (ene[0, 1] + trace[0, 4])}


def _against_published_c2(t, dem, fem):
    """RMS over the published rows within the run of ours minus the published run's weighted DEM and FEM energies, over E_0."""
    import numpy as np
    p = published_c2()
    rows = p["t"] <= t[-1] * (1 + 1e-9)
    e0 = p["dem"][0] + p["fem"][0]
    rms = lambda ours, theirs: float(np.sqrt(np.mean((np.interp(p["t"][rows], t, ours) - theirs[rows]) ** 2)) / e0)
    return {"published_rms_dem": rms(dem, p["dem"]), "published_rms_fem": rms(fem, p["fem"])}


# --- scene L2 (Liu 2016 Sec. 3.2): GMH against the direct DEM test of the same cell ---

def l2_figures(run, scale):
    """RMS(GMH - DEM) over the peak, from bench/gmh/l2_compare (the direct test along the run's strain path)."""
    import re
    import subprocess
    binaries = os.environ.get("COSIM_VALIDATION_BIN", os.path.join(ROOT, "build", "bin"))
    out = subprocess.run([os.path.join(binaries, "l2_compare"), "--run", run], capture_output=True, text=True,
                         timeout=3600)
    m = re.search(r"^RMS\(GMH - DEM\) \S+ = \S+ kPa = (\S+) % of peak", out.stdout, re.M)
    if not m:
        raise ValueError("l2_compare printed no RMS line (exit %d: %s)" % (out.returncode, out.stderr.strip()[-200:]))
    figures = {"rms_of_peak": float(m.group(1)) / 100.0}
    # the first stress component's RMS up to its peak, and the chaos floor: direct DEM
    # against itself with every increment perturbed by 1e-10
    peak = re.search(r"^  up to the peak of \S+ \(step \d+\): RMS\(GMH - DEM\) \S+ = (\S+) % of peak", out.stdout, re.M)
    floor = re.search(r"^  noise floor RMS\(DEM - DEM[^)]*\)\) \S+ = \S+ kPa = (\S+) % of peak", out.stdout, re.M)
    if peak:
        figures["rms_to_peak"] = float(peak.group(1)) / 100.0
    if floor and float(floor.group(1)) > 0:
        figures["noise_floor"] = float(floor.group(1)) / 100.0
        figures["rms_over_noise_floor"] = figures["rms_of_peak"] / figures["noise_floor"]
    return figures


# --- scene L1 (Liu 2016 Sec. 3.1, Table II): the cell's elastic constants ---

def l1_figures(run, scale):
    """E, nu, K, G [MPa] from bench/gmh/l1_elastic_constants' output (K isotropic, G shear)."""
    import re
    with open(os.path.join(run, "output.txt")) as f:
        text = f.read()
    m = re.search(r"^this cell: K isotropic, G shear\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)", text, re.M)
    if not m:
        raise ValueError("l1_elastic_constants printed no constants")
    e, nu, k, g = (float(v) for v in m.groups())
    out = {"E_MPa": e, "nu": nu, "K_MPa": k, "G_MPa": g}
    # the same moduli from the constrained-compression probes (an isotropic cell gives the same)
    m = re.search(r"^this cell: constrained compression\s+(\S+)\s+(\S+)", text, re.M)
    if m:
        out["K_constrained_MPa"], out["G_constrained_MPa"] = float(m.group(1)), float(m.group(2))
    return out


# --- scenes L3-L5 (Liu 2016 Secs. 3.3-3.5): the bench analyses' figures ---

def l3_figures(run, scale):
    """Element 9's loops, porosity and coordination (bench/gmh/l3_wave_column.py)."""
    import l3_wave_column
    return l3_wave_column.figures(run)


def l4_figures(run, scale):
    """Peak, softening, dilation and the band at 12 % (bench/gmh/l4_shear_band.py)."""
    import l4_shear_band
    return l4_shear_band.figures(run)


def l5_figures(runs, scale):
    """One mode's curves on several meshes: their spread, and the first run's peak (bench/gmh/l5_biaxial.py)."""
    import l5_biaxial
    return l5_biaxial.figures(list(runs))


# extractors of one run directory; OVER_RUNS: of the figure's run and its `with` runs
OVER_RUNS = {"l5": l5_figures}
EXTRACTORS = {"energy": energy_figures, "l3": l3_figures, "l4": l4_figures, "l1": l1_figures, "l2": l2_figures, "c2": c2_figures, "h3": h3_figures, "h4": h4_figures, "h5": h5_figures}
