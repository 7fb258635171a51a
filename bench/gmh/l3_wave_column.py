#!/usr/bin/python3
"""Scene L3 (Liu, Sun, Fish 2016 Sec. 3.3, Fig. 8) from a finished run directory.

Follows one element's quadrature point ("Element 9": paper numbering from the
fixed end, 1-based, i.e. element and cell id 8 of configs/gmh/l3_wave_column.yaml):

* strain: from the element's node displacements in the FEM snapshots (the
  one-point gradient H, small strain eps = (H + H^T) / 2; with the periodic
  ties the cross-sections stay rigid, so eps12 = du_y/dx / 2 exactly);
* stress: the cell's returned corotational Cauchy stress (coupler series
  cells/cell_stress, row k: the answer to the strain of snapshot k), rotated
  to the lab frame with R of the polar decomposition of F = I + H (Liu Eq. 62),
  tension positive;
* porosity and coordination number of the cell (cells/cell_porosity,
  cells/cell_coordination).

Prints a table every N coarse steps, per loading cycle the sigma12-eps12 loop
(ranges and its area, oint sigma12 d eps12, and the work of all components
oint sigma : d eps), the porosity and coordination ranges, and writes a PNG
like the paper's Fig. 8: (a) the shear and the compressive stress-strain
loops, (b) porosity and coordination number against time.

Usage: l3_wave_column.py RUN_DIR [--element 8] [--fem column.h5] [--coupling cells]
                         [--frequency 1e4] [--every 50] [--png FILE]
"""
import argparse
import sys

import numpy as np

from gmh_run_files import cell_series, element_gradient, open_h5, rotation, series_row, snapshots


def loop_integral(stress, strain):
    """oint stress d strain by the trapezoidal rule along the path (positive: work done on the cell)."""
    return float(np.sum(0.5 * (stress[1:] + stress[:-1]) * np.diff(strain)))


def cycle_loops(d, frequency):
    """Per load cycle of the followed element: (cycle, rows, complete, loop area, work).

    The rows of a cycle are closed with the first row of the next one where
    there is one; the loop area is oint sigma12 d eps12, the work oint sigma : d eps
    over all components [J/m^3]. A cycle is complete when its rows reach its end.
    """
    period = 1.0 / frequency
    t = d["time"]
    n = len(t)
    cycle = np.floor((t - 1e-12) / period).astype(int)
    out = []
    for cy in range(int(cycle.max()) + 1):
        idx = np.where(cycle == cy)[0]
        if len(idx) < 2:
            continue
        idx = np.append(idx, idx[-1] + 1) if idx[-1] + 1 < n else idx
        complete = t[idx[-1]] >= (cy + 1) * period - 1e-9
        area = loop_integral(d["sigma"][idx, 0, 1], d["eps"][idx, 0, 1])
        work = sum(loop_integral(d["sigma"][idx, i, j], d["eps"][idx, i, j]) for i in range(3) for j in range(3))
        out.append((cy, idx, complete, area, work))
    return out


def figures(run, element=8, fem_file="column.h5", coupling="cells", frequency=1.0e4):
    """The scene's figures of one run (validation/extract.py, `l3`): mean loop
    area per complete cycle [J/m^3], the cell's porosity and coordination at
    setup, their ranges over the run and the number of complete cycles."""
    d, first = follow(run, fem_file, coupling, element)
    if len(d["step"]) == 0:
        return {}
    areas = [area for _, _, complete, area, _ in cycle_loops(d, frequency) if complete]
    out = {"complete_cycles": float(len(areas)),
           "coordination_start": float(first["coordination"]), "porosity_start": float(first["porosity"]),
           "coordination_min": float(d["coordination"].min()), "coordination_max": float(d["coordination"].max()),
           "porosity_range": float(np.ptp(d["porosity"]))}
    if areas:
        out["loop_area_mean"] = float(np.mean(areas))
        out["loop_area_min"] = float(min(areas))
    return out


def follow(run, fem_file, coupling, element):
    fem = open_h5(f"{run}/{fem_file}")
    coords = fem["mesh/coordinates"][()]
    topology = fem["mesh/topology"][()].astype(int)
    if not 0 <= element < len(topology):
        raise ValueError(f"element {element} is not in the mesh ({len(topology)} elements)")
    steps, snaps = snapshots(fem)
    if not steps:
        raise ValueError(f"{run}/{fem_file} has no snapshots")
    series = open_h5(f"{run}/coupler.h5")["series"]
    cells = cell_series(series, coupling)
    where = np.where(cells["ids"] == element)[0]
    if len(where) != 1:
        raise ValueError(f"cell {element} is not in the coupler series (cells {cells['ids'].tolist()})")
    c = int(where[0])
    rows = cells["stress"].shape[0]
    out = {k: [] for k in ("step", "time", "eps", "sigma", "porosity", "coordination", "fem_sigma")}
    for s, g in zip(steps, snaps):
        if s >= rows:
            break  # the run stopped: no cell answer for this snapshot
        k = series_row(s, rows)
        H = element_gradient(coords, topology, g["displacement"][()], element)
        R = rotation(np.eye(3) + H)
        out["step"].append(s)
        out["time"].append(float(g.attrs["time"]))
        out["eps"].append(0.5 * (H + H.T))
        out["sigma"].append(R @ cells["stress"][k, c] @ R.T)
        out["porosity"].append(cells["porosity"][k, c])
        out["coordination"].append(cells["coordination"][k, c])
        out["fem_sigma"].append(g["stress"][element])
    eps12 = np.array([[element_gradient(coords, topology, g["displacement"][()], e)[1, 0] / 2.0
                       for e in range(len(topology))] for g in snaps])
    out["eps12_all"] = np.stack([eps12.min(axis=0), eps12.max(axis=0)], axis=1)
    first = {"porosity": cells["porosity"][0, c], "coordination": cells["coordination"][0, c],
             "sigma": cells["stress"][0, c]}
    return {k: np.array(v) for k, v in out.items()}, first


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("--element", type=int, default=8, help="element id (= cell id); 8 is the paper's Element 9")
    ap.add_argument("--fem", default="column.h5", help="the FEM snapshot file in the run directory")
    ap.add_argument("--coupling", default="cells")
    ap.add_argument("--frequency", type=float, default=1.0e4, help="load frequency [Hz]: the cycles of the loop table")
    ap.add_argument("--every", type=int, default=50, help="print every N-th coarse step")
    ap.add_argument("--png", default=None, help="figure file (default RUN_DIR/l3_element<id>.png)")
    a = ap.parse_args()
    try:
        d, first = follow(a.run, a.fem, a.coupling, a.element)
    except ValueError as e:
        sys.exit(str(e))
    n = len(d["step"])
    if n == 0:
        sys.exit("no coarse step with both a snapshot and a cell answer")
    s12, e12 = d["sigma"][:, 0, 1], d["eps"][:, 0, 1]
    s11, e11 = d["sigma"][:, 0, 0], d["eps"][:, 0, 0]
    t = d["time"]

    print(f"element {a.element} (cell {a.element}): {n} coarse steps, t = {t[0] * 1e6:.1f}-{t[-1] * 1e6:.1f} us; "
          f"at setup porosity {first['porosity']:.4f}, Z {first['coordination']:.3f}, "
          f"sigma11 {first['sigma'][0, 0] / 1e3:.1f} kPa, sigma12 {first['sigma'][0, 1] / 1e3:.1f} kPa")
    print(f"{'step':>5} {'t [us]':>7} {'sigma12 [kPa]':>13} {'eps12':>10} {'sigma11 [kPa]':>13} {'eps11':>10} "
          f"{'porosity':>9} {'Z':>6}")
    pick = list(range(0, n, max(1, a.every)))
    if pick[-1] != n - 1:
        pick.append(n - 1)
    for i in pick:
        print(f"{d['step'][i]:>5} {t[i] * 1e6:>7.1f} {s12[i] / 1e3:>13.2f} {e12[i]:>10.3e} {s11[i] / 1e3:>13.2f} "
              f"{e11[i]:>10.3e} {d['porosity'][i]:>9.4f} {d['coordination'][i]:>6.3f}")

    # Per cycle of the load: loop ranges and the work per unit volume. The
    # sigma12-eps12 loop area counts one of the two shear terms of sigma : d eps
    # (the dissipated shear work is twice it, oint sigma12 d gamma12).
    period = 1.0 / a.frequency
    print(f"\nper load cycle ({period * 1e6:.0f} us; loop area = oint sigma12 d eps12, "
          f"all = oint sigma : d eps over all components) [J/m^3 = Pa]:")
    print(f"{'cycle':>5} {'eps12 range':>22} {'sigma12 range [kPa]':>22} {'sigma11 range [kPa]':>22} "
          f"{'loop area':>10} {'2 x area':>10} {'all':>10}")
    loops = cycle_loops(d, a.frequency)
    for cy, idx, complete, area, work in loops:
        print(f"{cy:>5} {e12[idx].min():>10.3e} {e12[idx].max():>10.3e} {s12[idx].min() / 1e3:>10.2f} "
              f"{s12[idx].max() / 1e3:>10.2f} {s11[idx].min() / 1e3:>10.2f} {s11[idx].max() / 1e3:>10.2f} "
              f"{area:>10.2f} {2 * area:>10.2f} {work:>10.2f}{'' if complete else '  (incomplete)'}")
    areas = [area for _, _, complete, area, _ in loops if complete]
    if areas:
        print(f"loop area per complete cycle: mean {np.mean(areas):.2f} J/m^3 over {len(areas)} cycles "
              f"(min {min(areas):.2f}, max {max(areas):.2f}); shear work dissipated 2 x area = {2 * np.mean(areas):.2f} J/m^3")
    # The loops do not close (the response is not periodic), so one cycle's
    # integral also holds the change of stored energy over it; their mean is the
    # whole run's integral over the cycles, where that change enters once.
    print(f"sigma12 {s12.min() / 1e3:.2f} .. {s12.max() / 1e3:.2f} kPa, eps12 {e12.min():.3e} .. {e12.max():.3e}; "
          f"sigma11 {s11.min() / 1e3:.2f} .. {s11.max() / 1e3:.2f} kPa, eps11 {e11.min():.3e} .. {e11.max():.3e}")
    print(f"porosity {d['porosity'].min():.4f} .. {d['porosity'].max():.4f} (start {first['porosity']:.4f}, "
          f"end {d['porosity'][-1]:.4f}); Z {d['coordination'].min():.3f} .. {d['coordination'].max():.3f} "
          f"(start {first['coordination']:.3f}, end {d['coordination'][-1]:.3f})")
    print("every element over the run (id 0 at the fixed end): eps12 min .. max [1e-3]:")
    print("  " + ", ".join(f"{e}: {1e3 * lo:.2f} .. {1e3 * hi:.2f}" for e, (lo, hi) in enumerate(d["eps12_all"])))
    # Pairing check: FEM's element stress in snapshot k + 1 is the cell's answer
    # of row k rotated with R(F_{k+1}); with R(F_k) here they differ by the
    # rotation over one step only.
    if n > 1:
        lag = np.abs(d["fem_sigma"][1:, 3] - s12[:-1]).max()
        print(f"pairing check: max |FEM sigma_xy(snapshot k+1) - cell sigma12(row k)| = {lag / 1e3:.3f} kPa")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(15, 4.5))
    ax[0].plot(1e3 * e12, s12 / 1e3, lw=0.8)
    ax[0].set(xlabel="eps12 [1e-3]", ylabel="sigma12 [kPa]", title=f"(a) shear, element {a.element + 1} (id {a.element})")
    ax[1].plot(1e3 * e11, s11 / 1e3, lw=0.8, color="C3")
    ax[1].set(xlabel="eps11 [1e-3]", ylabel="sigma11 [kPa] (tension positive)", title="(a) compression")
    ax[2].plot(t * 1e3, d["porosity"], color="C0")
    ax[2].set(xlabel="t [ms]", ylabel="porosity", title="(b) porosity and coordination number")
    z = ax[2].twinx()
    z.plot(t * 1e3, d["coordination"], color="C1")
    z.set_ylabel("coordination number Z", color="C1")
    for x in ax:
        x.grid(alpha=0.3)
    fig.tight_layout()
    png = a.png or f"{a.run}/l3_element{a.element}.png"
    fig.savefig(png, dpi=120)
    print(f"figure: {png}")


if __name__ == "__main__":
    main()
