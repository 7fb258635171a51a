#!/usr/bin/python3
"""Where a PD body's kinetic energy sits, and whether its lattice is crushed.

Reads the PD snapshots of a run (RUN_DIR/pd.h5, written by pd_solver with
`output: {file: pd.h5, every: N}`) and prints, per snapshot and body:

* the kinetic energy and the largest and rms particle speed;
* the mean cosine between the velocities of lattice neighbours (the particle
  one spacing further along x, y or z in the reference lattice): near +1 for
  a smooth, continuum-like motion, near 0 when the energy sits in modes at
  the lattice scale, which no continuum vibration of the body has;
* how many particles have a smallest principal Green-Lagrange strain below
  -0.40 (stretch below 0.45: the lattice crushed far outside the small-strain
  range of the bond models), and how far the worst one lies from the body's
  centre relative to the body's radius (1 = on the surface).

Usage: /usr/bin/python3 bench/coupled/pd_lattice_check.py RUN_DIR [--spacing DX] [--density RHO] [--every K]
  --spacing: the lattice spacing of the bodies (default 0.015 m, H5's);
  --density: for the kinetic energy, m = rho dx^3 (default 1100 kg/m^3);
  --every: every K-th snapshot (default 1).
"""
import argparse
import sys

import h5py
import numpy as np


def smallest_principal_strain(s):
    """Smallest eigenvalue of each symmetric strain given as xx yy zz xy yz zx."""
    e = np.zeros((s.shape[0], 3, 3))
    e[:, 0, 0], e[:, 1, 1], e[:, 2, 2] = s[:, 0], s[:, 1], s[:, 2]
    e[:, 0, 1] = e[:, 1, 0] = s[:, 3]
    e[:, 1, 2] = e[:, 2, 1] = s[:, 4]
    e[:, 0, 2] = e[:, 2, 0] = s[:, 5]
    return np.linalg.eigvalsh(e)[:, 0]


def neighbour_cosine(ref, v, dx):
    """Mean cosine of the velocities of particles one spacing apart along x, y, z."""
    cells = np.round(ref / dx).astype(np.int64)
    index = {tuple(c): k for k, c in enumerate(cells)}
    speed = np.linalg.norm(v, axis=1)
    cosines = []
    for axis in range(3):
        step = np.zeros(3, dtype=np.int64)
        step[axis] = 1
        for k, c in enumerate(cells):
            j = index.get(tuple(c + step))
            if j is not None and speed[k] > 0.0 and speed[j] > 0.0:
                cosines.append(v[k] @ v[j] / (speed[k] * speed[j]))
    return float(np.mean(cosines)) if cosines else float("nan")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run")
    parser.add_argument("--spacing", type=float, default=0.015)
    parser.add_argument("--density", type=float, default=1100.0)
    parser.add_argument("--every", type=int, default=1)
    args = parser.parse_args()
    try:
        pd = h5py.File(f"{args.run}/pd.h5", "r")
    except OSError as e:
        sys.exit(f"pd_lattice_check: cannot open {args.run}/pd.h5: {e}")
    if "snapshots" not in pd:
        sys.exit(f"pd_lattice_check: {args.run}/pd.h5 holds no /snapshots")
    steps = sorted(int(k) for k in pd["snapshots"].keys())[:: args.every]
    mass = args.density * args.spacing**3
    print(f"{'step':>8} {'body':>4} {'KE [J]':>10} {'max|v|':>8} {'rms|v|':>8} {'nbr cos':>8} {'E<-0.40':>8} {'worst r/R':>9}")
    for step in steps:
        snap = pd[f"snapshots/{step}"]
        body, ref, v = snap["body"][()], snap["reference"][()], snap["velocity"][()]
        crushed = smallest_principal_strain(snap["strain"][()]) if "strain" in snap else None
        for b in np.unique(body):
            sel = body == b
            speed = np.linalg.norm(v[sel], axis=1)
            radius = np.linalg.norm(ref[sel] - ref[sel].mean(axis=0), axis=1)
            count, worst = "-", "-"
            if crushed is not None:
                count = int((crushed[sel] < -0.40).sum())
                worst = f"{radius[np.argmin(crushed[sel])] / radius.max():.2f}"
            print(f"{step:>8} {b:>4} {0.5 * mass * (speed**2).sum():>10.3g} {speed.max():>8.3g} "
                  f"{np.sqrt((speed**2).mean()):>8.3g} {neighbour_cosine(ref[sel], v[sel], args.spacing):>8.3f} "
                  f"{count:>8} {worst:>9}")


if __name__ == "__main__":
    main()
