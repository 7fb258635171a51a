#!/usr/bin/python3
"""Scene L4 (Liu, Sun, Fish 2016 Sec. 3.4) from a finished run directory.

Reads the FEM snapshots (block.h5: node displacements, element Cauchy stress
in Voigt order xx yy zz xy yz xz) and the coupler series (pool means of the
unit cells' porosity and coordination), and prints:

* the response against the nominal shear strain gamma = u_x(top) / H: mean
  shear stress sigma_xy and mean stress p = -tr(sigma) / 3 over all elements,
  pool-mean porosity and coordination number;
* the peak shear stress and where it occurs, and the softening after it;
* the shear band at a chosen nominal strain (default 12 %): per element row
  its shear strain du_x/dy (from the row's bottom and top node layers), the
  row with the largest, and the band thickness, taken as the height of the
  rows whose shear strain exceeds the midpoint between the smallest and the
  largest row strain (a full width at half maximum over the background).

Usage: l4_shear_band.py RUN_DIR [--at 0.12] [--weak-row 9] [--every 10]
"""
import argparse
import sys

import numpy as np

from gmh_run_files import open_h5, series_row, snapshots


def node_layers(coords):
    ys = np.unique(np.round(coords[:, 1], 9))
    return ys, [np.where(np.abs(coords[:, 1] - y) < 1e-9)[0] for y in ys]


def row_shear(disp, ys, layers):
    ux = np.array([disp[idx, 0].mean() for idx in layers])
    return np.diff(ux) / np.diff(ys)


def response(run):
    """Per snapshot of RUN_DIR/block.h5: (step, gamma, tau, p, porosity, Z, row shear
    profile), with the node layers' heights."""
    block = open_h5(f"{run}/block.h5")
    coords = block["mesh/coordinates"][()]
    ys, layers = node_layers(coords)
    height = ys[-1] - ys[0]
    steps, snaps = snapshots(block)
    series = open_h5(f"{run}/coupler.h5")["series"]
    porosity = series["cells/mean_porosity"][()]
    coordination = series["cells/mean_coordination"][()]
    rows = []
    for s, g in zip(steps, snaps):
        disp = g["displacement"][()]
        stress = g["stress"][()]
        gamma = disp[layers[-1], 0].mean() / height
        tau = stress[:, 3].mean()
        p = -stress[:, :3].sum(axis=1).mean() / 3.0
        k = series_row(s, len(porosity))
        rows.append((s, gamma, tau, p, porosity[k], coordination[k], row_shear(disp, ys, layers)))
    return rows, ys


def band(rows, ys, at):
    """The snapshot nearest nominal strain `at`, its row profile, the rows above
    the half maximum and the band's thickness [m]."""
    gammas = np.array([r[1] for r in rows])
    k = int(np.argmin(np.abs(gammas - at)))
    prof = rows[k][6]
    inside = prof > 0.5 * (prof.min() + prof.max())
    return k, prof, inside, float(np.diff(ys)[inside].sum())


def figures(run, at=0.12):
    """The scene's figures of one run (validation/extract.py, `l4`): nominal shear
    strain at the peak [%], softening from the peak to the end [%], dilation
    (porosity change), band thickness at `at` [mm] (absent when the run ended
    before it), the band's row and the height of its middle [mm]."""
    rows, ys = response(run)
    if not rows:
        return {}
    taus = np.array([r[2] for r in rows])
    gammas = np.array([r[1] for r in rows])
    peak = int(np.argmax(taus))
    out = {"peak_gamma_pct": float(100 * gammas[peak]), "peak_tau_kPa": float(taus[peak] / 1e3),
           "softening_pct": float(100 * (taus[-1] - taus[peak]) / taus[peak]),
           "dilation": float(rows[-1][4] - rows[0][4]), "end_gamma_pct": float(100 * gammas[-1])}
    if gammas[-1] >= at - 0.005:
        _, prof, _, thickness = band(rows, ys, at)
        out["band_mm"] = 1e3 * thickness
        top = int(np.argmax(prof))
        out["band_row"] = float(top)
        out["band_height_mm"] = float(1e3 * 0.5 * (ys[top] + ys[top + 1]))
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("run")
    ap.add_argument("--at", type=float, default=0.12)
    ap.add_argument("--weak-row", type=int, default=9)
    ap.add_argument("--every", type=int, default=10, help="print every N-th snapshot")
    a = ap.parse_args()
    rows, ys = response(a.run)
    if not rows:
        sys.exit(f"{a.run}/block.h5 has no snapshots")

    print(f"{'step':>6} {'gamma':>8} {'tau [kPa]':>10} {'p [kPa]':>9} {'porosity':>9} {'Z':>6}")
    for r in rows[:: max(1, a.every)] + ([rows[-1]] if (len(rows) - 1) % max(1, a.every) else []):
        print(f"{r[0]:>6} {r[1]:>8.4f} {r[2] / 1e3:>10.1f} {r[3] / 1e3:>9.1f} {r[4]:>9.4f} {r[5]:>6.3f}")

    taus = np.array([r[2] for r in rows])
    gammas = np.array([r[1] for r in rows])
    peak = int(np.argmax(taus))
    print(f"\npeak shear stress {taus[peak] / 1e3:.1f} kPa at gamma = {gammas[peak]:.4f}; "
          f"final {taus[-1] / 1e3:.1f} kPa at gamma = {gammas[-1]:.4f} "
          f"({100 * (taus[-1] - taus[peak]) / taus[peak]:+.1f} % from the peak)")
    print(f"porosity {rows[0][4]:.4f} -> {rows[-1][4]:.4f} (dilation {rows[-1][4] - rows[0][4]:+.4f}); "
          f"coordination {rows[0][5]:.3f} -> min {min(r[5] for r in rows):.3f} -> {rows[-1][5]:.3f}")

    if gammas[-1] < a.at:
        print(f"\nthe run ended at gamma = {gammas[-1]:.4f}, before {a.at}: band at the last snapshot")
    at, prof, inside, thickness = band(rows, ys, a.at)
    print(f"\nshear strain du_x/dy per element row at gamma = {gammas[at]:.4f} (step {rows[at][0]}), bottom row first:")
    for j, (g, hit) in enumerate(zip(prof, inside)):
        mark = " <- weakened cell's row" if j == a.weak_row else ""
        print(f"  row {j:>2} y = {1e3 * ys[j]:6.1f}-{1e3 * ys[j + 1]:6.1f} mm  {g:8.4f} {'#' if hit else ' '}{mark}")
    top = int(np.argmax(prof))
    print(f"band: largest in row {top} (y = {1e3 * 0.5 * (ys[top] + ys[top + 1]):.1f} mm, weakened row "
          f"{a.weak_row}); thickness (rows above the half maximum) {1e3 * thickness:.1f} mm "
          f"({int(inside.sum())} rows); row strain max / mean {prof.max() / max(prof.mean(), 1e-30):.2f}")


if __name__ == "__main__":
    main()
