#!/usr/bin/python3
"""Scene L5 (Liu, Sun, Fish 2016 Sec. 3.5, Figs. 16-19) from finished run directories.

Each run is given as MODE:MESH=DIR (e.g. local:8x16=/tmp/l5/local-8x16).
For every run it reads the FEM snapshots (block.h5) and computes

* the global response against the nominal axial strain eps = -u_y(top) / H:
  the compressive stress -sigma_yy averaged over the elements (equal volumes;
  in equilibrium the volume average of the stress is the mean boundary
  traction, so this is the top force over the width);
* the peak and the softening after it;
* the band at a chosen nominal strain (default 6 %, Liu's Figs. 17 and 19):
  each element's maximum in-plane shear strain
  gamma = sqrt(((H_xx - H_yy) / 2)^2 + ((H_xy + H_yx) / 2)^2) from its
  displacement gradient H, the elements above the half maximum (midpoint
  between the smallest and the largest gamma), and the band width
  w = (area of those elements) / (their extent along the band), the extent
  measured along the principal axis of their centroids plus one element size.

The share of the external work stored in the hourglass springs at the end of
the run (coupler.h5, the block's energy series): a large share means the
hourglass stiffness, not the cells, carries part of the load.

The scatter of the element stresses at that strain: the standard deviation of
-sigma_yy over the elements / its mean, and the correlation of face neighbours
(negative when neighbours alternate; one-point elements do not see such a
checkerboard in their nodal forces, so nothing in the coarse problem resists it).

Mesh objectivity, per mode: the spread of the curves, (max over meshes - min
over meshes) / mean peak stress, at every strain from the latest peak to the
end of the shortest of all runs (RMS and maximum), and the same over the whole
common strain range (the curves of noisy cells have no single clear peak).

Usage: l5_biaxial.py MODE:MESH=DIR ... [--at 0.06] [--every 0.005] [--png FILE]
"""
import argparse
import sys

import numpy as np

from gmh_run_files import element_gradient, open_h5, snapshots


def load(run):
    block = open_h5(f"{run}/block.h5")
    coords = block["mesh/coordinates"][()]
    topo = block["mesh/topology"][()]
    height = coords[:, 1].max() - coords[:, 1].min()
    top = np.where(np.abs(coords[:, 1] - coords[:, 1].max()) < 1e-9)[0]
    steps, snaps = snapshots(block)
    eps, sig, disps, syy = [], [], [], []
    for s, g in zip(steps, snaps):
        if s == 0:
            continue  # written before the cells' first answer: no stress yet
        d = g["displacement"][()]
        eps.append(-d[top, 1].mean() / height)
        syy.append(-g["stress"][()][:, 1])
        sig.append(syy[-1].mean())
        disps.append(d)
    if not eps:
        raise ValueError(f"{run}/block.h5 has no snapshots after step 0")
    return {"coords": coords, "topo": topo, "eps": np.array(eps), "sig": np.array(sig), "disp": disps, "syy": syy,
            "hourglass_share": hourglass_share(run)}


def hourglass_share(run):
    """Hourglass energy / external work of the block at the last exchange (nan without the series)."""
    try:
        energy = open_h5(f"{run}/coupler.h5")["series/block/energy"]
        work = energy["external_work"][-1]
        return float(energy["hourglass"][-1] / work) if work > 0 else float("nan")
    except (OSError, KeyError):
        return float("nan")


def element_shear(run, k):
    """Maximum in-plane shear strain and centroid of every element at snapshot k."""
    X, topo, d = run["coords"], run["topo"], run["disp"][k]
    out = np.empty(len(topo))
    for e in range(len(topo)):
        H = element_gradient(X, topo, d, e)
        out[e] = np.hypot(0.5 * (H[0, 0] - H[1, 1]), 0.5 * (H[0, 1] + H[1, 0]))
    return out, X[topo].mean(axis=1)


def band_width(gamma, centroids, X, topo):
    """Half-maximum band: its elements, width [m] and inclination [deg from horizontal]."""
    inside = gamma > 0.5 * (gamma.min() + gamma.max())
    c = centroids[inside][:, :2]
    ex = X[topo[0]]
    dx, dy = np.ptp(ex[:, 0]), np.ptp(ex[:, 1])
    area = inside.sum() * dx * dy
    if inside.sum() < 2:
        return inside, np.sqrt(area), float("nan")
    w, v = np.linalg.eigh(np.cov((c - c.mean(axis=0)).T))
    axis = v[:, np.argmax(w)]
    proj = c @ axis
    length = np.ptp(proj) + np.hypot(dx * axis[0], dy * axis[1])
    angle = np.degrees(np.arctan2(abs(axis[1]), abs(axis[0])))
    return inside, area / length, angle


def face_neighbours(topo):
    """Pairs of elements that share a face (four nodes)."""
    owner, pairs = {}, []
    for e, nodes in enumerate(topo):
        for face in ((0, 1, 2, 3), (4, 5, 6, 7), (0, 1, 5, 4), (1, 2, 6, 5), (2, 3, 7, 6), (3, 0, 4, 7)):
            key = tuple(sorted(nodes[list(face)]))
            if key in owner:
                pairs.append((owner[key], e))
            else:
                owner[key] = e
    return np.array(pairs, dtype=int).reshape(-1, 2)


def stress_heterogeneity(syy, pairs):
    """Element-to-element scatter of -sigma_yy: standard deviation / mean, and the
    correlation of face neighbours (negative: neighbours alternate, a checkerboard
    that one-point elements do not see in their nodal forces)."""
    cv = syy.std() / syy.mean()
    a, b = syy[pairs[:, 0]] - syy.mean(), syy[pairs[:, 1]] - syy.mean()
    corr = float(np.mean(a * b) / syy.var()) if syy.var() > 0 and len(pairs) else float("nan")
    return cv, corr


def spread(runs, start, end):
    """Spread of one mode's curves over [start, end] (fraction of the mean peak)."""
    grid = np.linspace(start, end, 50) if end > start else np.array([])
    if grid.size == 0:
        return float("nan"), float("nan")
    curves = np.array([np.interp(grid, r["eps"], r["sig"]) for r in runs])
    mean_peak = np.mean([r["sig"].max() for r in runs])
    s = (curves.max(axis=0) - curves.min(axis=0)) / mean_peak
    return float(np.sqrt(np.mean(s ** 2))), float(s.max())


def mode_spread(group, end):
    """The latest peak strain of one mode's runs, and the spread (RMS, max) from it
    to `end` and over the whole common range."""
    for r in group:
        r["peak_eps"] = r["eps"][int(np.argmax(r["sig"]))]
    start = max(r["peak_eps"] for r in group)
    return start, spread(group, start, end), spread(group, max(r["eps"][0] for r in group), end)


def figures(dirs):
    """The scene's figures of one mode on several meshes (validation/extract.py, `l5`):
    the spread of the curves from the latest peak to the shortest run's end and over
    the whole range [% of the mean peak], and the first run's peak stress [kPa],
    peak strain and softening to its end [%]."""
    group = [load(d) for d in dirs]
    end = min(r["eps"][-1] for r in group)
    start, post, whole = mode_spread(group, end)
    first = group[0]
    p = int(np.argmax(first["sig"]))
    out = {"peak_kPa": float(first["sig"][p] / 1e3), "peak_eps_pct": float(100 * first["eps"][p]),
           "softening_pct": float(100 * (first["sig"][-1] - first["sig"][p]) / first["sig"][p]),
           "end_eps_pct": float(100 * end), "meshes": float(len(group))}
    if len(group) > 1 and end > start:
        out.update(post_peak_spread_pct=100 * post[1], post_peak_spread_rms_pct=100 * post[0],
                   whole_spread_pct=100 * whole[1])
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("runs", nargs="+", help="MODE:MESH=DIR")
    ap.add_argument("--at", type=float, default=0.06)
    ap.add_argument("--every", type=float, default=0.005, help="strain between printed rows")
    ap.add_argument("--png", default=None)
    a = ap.parse_args()
    runs = {}
    for spec in a.runs:
        label, _, path = spec.partition("=")
        mode, _, mesh = label.partition(":")
        if not path or not mesh:
            sys.exit(f"bad run '{spec}': expected MODE:MESH=DIR")
        try:
            r = load(path)
        except ValueError as e:
            sys.exit(str(e))
        r.update(mode=mode, mesh=mesh)
        runs[label] = r

    labels = list(runs)
    grid = np.arange(0.0, max(r["eps"][-1] for r in runs.values()) + 1e-12, a.every)
    print("compressive stress -sigma_yy [kPa] against the nominal axial strain")
    print(f"{'eps':>7} " + " ".join(f"{lab:>15}" for lab in labels))
    for e in grid:
        vals = [f"{np.interp(e, r['eps'], r['sig']) / 1e3:>15.1f}" if e <= r["eps"][-1] + 1e-9 else f"{'-':>15}"
                for r in runs.values()]
        print(f"{e:>7.4f} " + " ".join(vals))

    print(f"\n{'run':>15} {'peak [kPa]':>11} {'at eps':>7} {'end eps':>8} {'end [kPa]':>10} {'softening':>10} "
          f"{'band w [mm]':>12} {'angle':>6} {'at eps':>7} {'std/mean':>9} {'nb corr':>8} {'hg/W':>6}")
    bands = {}
    for lab, r in runs.items():
        p = int(np.argmax(r["sig"]))
        k = int(np.argmin(np.abs(r["eps"] - a.at)))
        gamma, cent = element_shear(r, k)
        inside, width, angle = band_width(gamma, cent, r["coords"], r["topo"])
        cv, corr = stress_heterogeneity(r["syy"][k], face_neighbours(r["topo"]))
        bands[lab] = (gamma, inside, k)
        r["peak_eps"] = r["eps"][p]
        print(f"{lab:>15} {r['sig'][p] / 1e3:>11.1f} {r['eps'][p]:>7.4f} {r['eps'][-1]:>8.4f} "
              f"{r['sig'][-1] / 1e3:>10.1f} {100 * (r['sig'][-1] - r['sig'][p]) / r['sig'][p]:>+9.1f}% "
              f"{1e3 * width:>12.2f} {angle:>6.1f} {r['eps'][k]:>7.4f} {cv:>9.3f} {corr:>+8.2f} {r['hourglass_share']:>6.3f}")

    end = min(r["eps"][-1] for r in runs.values())
    print(f"\nspread over the meshes, (max - min) / mean peak, up to the shortest run's end (eps {end:.4f}):")
    result = {}
    for mode in sorted({r["mode"] for r in runs.values()}):
        group = [r for r in runs.values() if r["mode"] == mode]
        if len(group) < 2:
            continue
        start, post, whole = mode_spread(group, end)
        result[mode] = (post[1], whole[1])
        print(f"  {mode:>9}: from the latest peak (eps {start:.4f}) RMS {100 * post[0]:.2f} %, max {100 * post[1]:.2f} %;"
              f" whole range RMS {100 * whole[0]:.2f} %, max {100 * whole[1]:.2f} % ({len(group)} meshes)")
    for mode in sorted(set(result) - {"local"}) if "local" in result else []:
        ratios = [float("nan") if np.isnan(lo) or np.isnan(nl) else (lo / nl if nl > 0 else float("inf"))
                  for lo, nl in zip(result["local"], result[mode])]
        print(f"  local / {mode} max spread: {ratios[0]:.2f} past the peak, {ratios[1]:.2f} over the whole range"
              " (issue: nonlocal within 5 %, local at least 2 x)")

    if a.png:
        plot(runs, bands, a.png)
        print(f"wrote {a.png}")


def plot(runs, bands, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    modes = sorted({r["mode"] for r in runs.values()})
    meshes = list(dict.fromkeys(r["mesh"] for r in runs.values()))
    fig = plt.figure(figsize=(4 + 2.2 * len(meshes) * len(modes), 6))
    gs = fig.add_gridspec(len(modes), 1 + len(meshes), width_ratios=[3] + [1] * len(meshes))
    for i, mode in enumerate(modes):
        ax = fig.add_subplot(gs[i, 0])
        for lab, r in runs.items():
            if r["mode"] == mode:
                ax.plot(100 * r["eps"], r["sig"] / 1e3, label=r["mesh"])
        ax.set_title(f"{mode}")
        ax.set_xlabel("axial strain [%]")
        ax.set_ylabel("-sigma_yy [kPa]")
        ax.legend()
        for j, mesh in enumerate(meshes):
            lab = f"{mode}:{mesh}"
            if lab not in runs:
                continue
            r, (gamma, inside, k) = runs[lab], bands[lab]
            X = r["coords"] + r["disp"][k]
            quads = [X[t][[0, 1, 2, 3]][:, :2] for t in r["topo"]]
            axm = fig.add_subplot(gs[i, 1 + j])
            pc = PolyCollection(quads, array=gamma, cmap="viridis", edgecolors="none")
            axm.add_collection(pc)
            axm.autoscale()
            axm.set_aspect("equal")
            axm.set_title(f"{mesh}, eps {100 * r['eps'][k]:.1f} %", fontsize=8)
            axm.set_xticks([])
            axm.set_yticks([])
            fig.colorbar(pc, ax=axm, fraction=0.08)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
