#!/usr/bin/python3
"""Statistics of the Hartmann 2022 scenes H3-H5 from a `coupler run` directory.

Reads the run's PD snapshots (pd.h5: /snapshots/<pd step>/{reference,
displacement, position, strain (xx yy zz xy yz zx), von_mises, body} with the
attribute `time`), the DEM snapshots (dem.h5: /snapshots/<dem step>/{positions,
radii}) and run_report.json, picks the snapshot nearest each evaluation time and
prints the scene's numbers next to the paper's (Sec. 5.2-5.4).

  pd_scene_stats.py h3|h4|h5|h5-all-pd|h5-all-dem RUN_DIR [--time-scale S] [--label TEXT]

--time-scale S: the run was loaded S times faster than the paper (wall or
sphere speed x S, end time / S); the paper's times t are evaluated at t / S.
Needs numpy and h5py (Debian's /usr/bin/python3 here).
"""
import argparse
import json
import os
import re
import sys

import h5py
import numpy as np

try:
    import yaml
except ImportError:  # only for the time step; the snapshots give it too
    yaml = None


def snapshots(path):
    """[(time, step, group)] sorted by time."""
    f = h5py.File(path, "r")
    out = []
    for k, g in f["snapshots"].items():
        out.append((float(g.attrs["time"]), int(k), g))
    out.sort(key=lambda s: s[0])
    return f, out


def nearest(snaps, t):
    return min(snaps, key=lambda s: abs(s[0] - t))


def report(run):
    p = os.path.join(run, "run_report.json")
    if not os.path.exists(p):
        return {}
    with open(p) as f:
        return json.load(f)


def pd_dt(run, snaps, r):
    """PD step from the snapshots (time / step of the last one), else the schedule's dt."""
    for t, step, _ in reversed(snaps):
        if step > 0:
            return t / step
    m = re.search(r"dt = ([0-9.eE+-]+) s", r.get("schedule", ""))
    return float(m.group(1)) if m else float("nan")


def run_summary(run, label):
    r = report(run)
    wall = r.get("wall_s", {}).get("total", float("nan"))
    peers = ", ".join("%s %s compute %.1f s comm %.1f s" % (p["name"], p["kind"], p.get("compute_s", 0.0),
                                                             p.get("communication_s", 0.0))
                      for p in r.get("peers", []))
    print("run %s: status %s, simulated %.4g of %.4g s, %s exchanges, wall %.1f s (%s)%s" % (
        label, r.get("status", "missing run_report.json"), r.get("simulated_time_s", float("nan")),
        r.get("end_time_s", float("nan")), r.get("exchanges", "-"), wall, peers,
        (" message: " + r["message"]) if r.get("message") else ""))
    return r, wall


def node_rate(run, snaps, wall, r):
    pd_path = os.path.join(run, "pd.h5")
    if not snaps:
        return
    n = snaps[0][2]["reference"].shape[0]
    dt = pd_dt(run, snaps, r)
    sim = r.get("simulated_time_s", snaps[-1][0])
    steps = sim / dt
    print("PD particles %d, dt_PD %.6g s, PD steps %.0f, node-steps/s (PD particles x PD steps / wall) %.3g" % (
        n, dt, steps, n * steps / wall if wall > 0 else float("nan")))


def edge_mask(ref, h):
    """Particles in the outermost layer of at least two axes of their box body."""
    lo, hi = ref.min(axis=0), ref.max(axis=0)
    out = (np.abs(ref - lo) < 0.25 * h) | (np.abs(ref - hi) < 0.25 * h)
    return out.sum(axis=1) >= 2


def h3(run, scale):
    f, snaps = snapshots(os.path.join(run, "pd.h5"))
    t_paper = 12.0
    t, step, g = nearest(snaps, t_paper / scale)
    ref = g["reference"][:]
    E = g["strain"][:]
    vm = g["von_mises"][:]
    h = 0.015
    edges = edge_mask(ref, h)
    print("H3 at t = %.4g s (snapshot step %d; paper time %.4g s), %d particles, %d on the cube's edges" % (
        t, step, t * scale, len(ref), edges.sum()))
    print("%-34s %-14s %-14s %s" % ("quantity", "all", "edges excluded", "paper"))

    def row(name, fn, paper, fmt="%-14.4g"):
        a, b = fn(slice(None)), fn(~edges)
        print(("%-34s " + fmt + " " + fmt + " %s") % (name, a, b, paper))

    row("max E_zz", lambda m: E[m, 2].max(), "0.134 (sign not given)")
    row("min E_zz", lambda m: E[m, 2].min(), "")
    row("max |E_zz|", lambda m: np.abs(E[m, 2]).max(), "0.134")
    row("max E_xx", lambda m: E[m, 0].max(), "(Fig. 10b, no value)")
    row("min E_xx", lambda m: E[m, 0].min(), "")
    row("max von Mises [Pa]", lambda m: vm[m].max(), "12920 (as printed: 1.292 N/cm^2)")
    row("max von Mises [N/cm^2]", lambda m: vm[m].max() * 1e-4, "1.292")
    i = int(np.argmax(np.where(edges, -np.inf, np.abs(E[:, 2]))))
    j = int(np.argmax(np.where(edges, -np.inf, vm)))
    print("max |E_zz| (edges excluded) at reference %s; max von Mises at %s" % (
        np.round(ref[i], 4).tolist(), np.round(ref[j], 4).tolist()))
    # the deformed cube: height along z at the middle column and the top's lowest point
    u = g["displacement"][:]
    x = ref + u
    mid = (np.abs(ref[:, 0] - 0.15) < 0.01) & (np.abs(ref[:, 1] - 0.15) < 0.01)
    print("cube at the middle: top z %.4f, bottom z %.4f (reference 0.2925, 0.0075); width x %.4f..%.4f (ref 0.0075..0.2925)"
          % (x[mid, 2].max(), x[mid, 2].min(), x[:, 0].min(), x[:, 0].max()))
    # consistency of the paper's numbers with E = 1e8: a uniaxial Green strain of 0.134
    lam = np.sqrt(1 - 2 * 0.134)
    print("for scale: E = 1e8 Pa x 0.134 = %.3g Pa = %.3g N/cm^2 (stretch %.3f in compression); the paper's "
          "1.292 N/cm^2 = 1.292e4 Pa is a strain of about 1.3e-4" % (1e8 * 0.134, 1e4 * 0.134, lam))
    dem = os.path.join(run, "dem.h5")
    if os.path.exists(dem):
        fd, ds = snapshots(dem)
        td, _, gd = nearest(ds, t_paper / scale)
        r = gd["radii"][:]
        pc = gd["positions"][:][np.abs(r - 0.15) < 1e-9]
        print("DEM spheres at t = %.4g s: centres %s (start [0.15, 0.15, 0.45155], [0.15, 0.15, -0.15155])" % (
            td, np.round(pc, 4).tolist()))


def h4(run, scale):
    f, snaps = snapshots(os.path.join(run, "pd.h5"))
    paper = {7.5: ("4.6", "-"), 17.5: ("17.6", "7.6"), 22.15: ("24.6", "-")}
    print("%-10s %-10s %-12s %-12s %-12s %-12s %-12s %-10s %-22s %s" % (
        "paper t", "run t", "max|u_x| cm", "paper", "max u_z cm", "paper", "min u_z cm", "max|u_y|", "body x range [m]",
        "body z range [m]"))
    for tp in (7.5, 17.5, 22.15):
        t, step, g = nearest(snaps, tp / scale)
        u = g["displacement"][:]
        x = g["reference"][:] + u
        print("%-10.4g %-10.4g %-12.2f %-12s %-12.2f %-12s %-12.2f %-10.2f %-22s %s" % (
            tp, t, 100 * np.abs(u[:, 0]).max(), paper[tp][0], 100 * u[:, 2].max(), paper[tp][1], 100 * u[:, 2].min(),
            100 * np.abs(u[:, 1]).max(), "%.3f..%.3f" % (x[:, 0].min(), x[:, 0].max()),
            "%.3f..%.3f" % (x[:, 2].min(), x[:, 2].max())))
    # max u_z over the whole run (the paper's 7.6 cm is the maximum, reached at 17.5 s)
    best = max(((s[0], g["displacement"][:, 2].max()) for s in snaps for g in [s[2]]), key=lambda a: a[1])
    print("largest max u_z over all snapshots: %.2f cm at t = %.4g s (paper time %.4g s)" % (
        100 * best[1], best[0], best[0] * scale))
    # slip-through: the supports are at x = 0.12 and 0.48, centres z = -0.05095, R = 0.05
    t, step, g = snaps[-1]
    x = g["reference"][:] + g["displacement"][:]
    between = np.mean((x[:, 0] > 0.12) & (x[:, 0] < 0.48))
    below = np.mean(x[:, 2] < -0.05095)
    slipped = x[:, 0].min() > 0.12 and x[:, 0].max() < 0.48
    print("last snapshot t = %.4g s: %.1f %% of the particles between the supports' centres in x, %.1f %% below their "
          "centres in z; body %s" % (t, 100 * between, 100 * below,
                                     "entirely between the supports (slipped in/through)" if slipped
                                     else "not entirely between the supports"))


def h5(run, scale, variant):
    paper = {"mixed": {1.0: ("2.35", "6.07"), 2.0: ("8.32", "34.26"), 3.0: ("11.21", "33.79")},
             "all-pd": {1.0: ("-", "-"), 2.0: ("-", "-"), 3.0: ("8.64", "32.21")},
             "all-dem": {1.0: ("0", "0"), 2.0: ("0", "0"), 3.0: ("0 (no sideways motion)", "0")}}[variant]
    pdp = os.path.join(run, "pd.h5")
    demp = os.path.join(run, "dem.h5")
    snaps = snapshots(pdp)[1] if os.path.exists(pdp) else []
    dsnaps = snapshots(demp)[1] if os.path.exists(demp) else []
    print("%-8s %-8s %-14s %-10s %-14s %-10s %-14s %-14s %-14s %s" % (
        "paper t", "run t", "PD mean xy cm", "paper", "PD max xy cm", "paper", "PD mean |u_z|", "PD max |v| m/s",
        "DEM max xy cm", "DEM mean xy cm"))
    last = max([s[0] for s in snaps] + [s[0] for s in dsnaps] + [0.0])
    # A time is reached when a snapshot lies within half a snapshot interval of
    # it (a step that does not divide 0.25 s puts the last one just before 3 s).
    times = sorted(s[0] for s in snaps)
    slack = 0.5 * (times[-1] - times[-2]) if len(times) > 1 else 1e-9
    for tp in (1.0, 2.0, 3.0):
        cols = []
        if snaps and tp / scale <= last + slack:
            t, step, g = nearest(snaps, tp / scale)
            u = g["displacement"][:]
            lat = np.hypot(u[:, 0], u[:, 1])
            speed = np.linalg.norm(g["velocity"][:], axis=1).max()
            cols = [t, "%.2f" % (100 * lat.mean()), "%.2f" % (100 * lat.max()), "%.2f" % (100 * np.abs(u[:, 2]).mean()),
                    "%.3g" % speed]
        dem_cols = ["-", "-"]
        if dsnaps and tp / scale <= last + slack:
            td, _, gd = nearest(dsnaps, tp / scale)
            r0 = dsnaps[0][2]["radii"][:]
            sel0 = np.abs(r0 - 0.15) < 1e-9
            p0 = dsnaps[0][2]["positions"][:][sel0]
            r = gd["radii"][:]
            p = gd["positions"][:][np.abs(r - 0.15) < 1e-9]
            if len(p) and len(p) == len(p0):
                d = np.hypot(p[:, 0] - p0[:, 0], p[:, 1] - p0[:, 1])
                dem_cols = ["%.2f" % (100 * d.max()), "%.2f" % (100 * d.mean())]
            if not cols:
                cols = [td, "-", "-", "-", "-"]
        if not cols:
            print("%-8.4g (not reached; last snapshot t = %.4g s)" % (tp, last))
            continue
        print("%-8.4g %-8.4g %-14s %-10s %-14s %-10s %-14s %-14s %-14s %s" % (
            tp, cols[0], cols[1], paper[tp][0], cols[2], paper[tp][1], cols[3], cols[4], dem_cols[0], dem_cols[1]))
    cpl = os.path.join(run, "coupler.h5")
    if snaps and os.path.exists(cpl):
        # energy check: PD kinetic energy and the work done on PD (a blow-up shows as work >> strain energy)
        with h5py.File(cpl, "r") as f:
            t = f["/series/time"][:]
            names = [k for k in f["series"] if "energy" in f["series"][k]]
            pd_name = [k for k in names if "strain" in f["series"][k]["energy"]]
            if pd_name:
                e = f["series"][pd_name[0]]["energy"]
                ke, se, w = e["kinetic"][:], e["strain"][:], e["external_work"][:]
                for tp in (0.5, 1.0, 1.5, 2.0, 2.5, 3.0):
                    if tp / scale <= t[-1] + 1e-9:
                        i = int(np.argmin(np.abs(t - tp / scale)))
                        print("  paper t = %.2f s (run t = %.4g s): PD kinetic %.3g J, strain %.3g J, "
                              "work done on PD %.3g J" % (tp, t[i], ke[i], se[i], w[i]))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene", choices=["h3", "h4", "h5", "h5-all-pd", "h5-all-dem"])
    ap.add_argument("run")
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--label", default=None)
    a = ap.parse_args()
    label = a.label or os.path.basename(os.path.normpath(a.run))
    r, wall = run_summary(a.run, label)
    pd_path = os.path.join(a.run, "pd.h5")
    if os.path.exists(pd_path):
        node_rate(a.run, snapshots(pd_path)[1], wall, r)
    try:
        if a.scene == "h3":
            h3(a.run, a.time_scale)
        elif a.scene == "h4":
            h4(a.run, a.time_scale)
        else:
            h5(a.run, a.time_scale, {"h5": "mixed", "h5-all-pd": "all-pd", "h5-all-dem": "all-dem"}[a.scene])
    except (OSError, KeyError, ValueError) as e:
        print("no statistics: %s" % e)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
