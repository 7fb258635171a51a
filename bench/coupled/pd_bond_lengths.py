#!/usr/bin/python3
"""How far a PD run's bonds are from their reference length, snapshot by snapshot.

Reads pd.h5 (/snapshots/<pd step>/{reference, position, velocity, body}) and,
for every pair of particles of one body whose reference distance is within the
horizon, the ratio current / reference length. Prints per snapshot: the
shortest and longest ratio, how many bonds are shorter than 1/2 and 1/5 of
their length, and the fastest particle. LPS and PMB are small-strain models:
bonds compressed by half or more (H5's contact zones) are outside them.

  pd_bond_lengths.py PD_H5 --horizon DELTA

DELTA in metres (horizon x spacing, e.g. 0.03 for dx 0.015 and horizon 2).
Needs numpy and h5py (Debian's /usr/bin/python3 here).
"""
import argparse
import sys
from collections import defaultdict

import h5py
import numpy as np


def bond_ratios(reference, position, body, horizon):
    """Current / reference length of every bond, each counted twice."""
    cells = np.floor(reference / horizon).astype(np.int64)
    grid = defaultdict(list)
    for i, (c, b) in enumerate(zip(map(tuple, cells), body)):
        grid[(int(b),) + c].append(i)
    reach = horizon * (1.0 + 1e-9)
    out = []
    for key, members in grid.items():
        b, c = key[0], key[1:]
        near = [j for dx in (-1, 0, 1) for dy in (-1, 0, 1) for dz in (-1, 0, 1)
                for j in grid.get((b, c[0] + dx, c[1] + dy, c[2] + dz), [])]
        mine, near = np.array(members), np.array(near)
        d0 = np.linalg.norm(reference[mine][:, None, :] - reference[near][None, :, :], axis=2)
        d = np.linalg.norm(position[mine][:, None, :] - position[near][None, :, :], axis=2)
        bonded = (d0 > 0.0) & (d0 <= reach)
        out.append(d[bonded] / d0[bonded])
    return np.concatenate(out) if out else np.zeros(0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("pd_h5")
    ap.add_argument("--horizon", type=float, required=True, help="horizon in metres")
    a = ap.parse_args()
    if not a.horizon > 0.0:
        sys.exit("--horizon must be a positive length in metres")
    with h5py.File(a.pd_h5, "r") as f:
        if "snapshots" not in f:
            sys.exit(f"{a.pd_h5}: no /snapshots group (is it a pd_solver output file?)")
        print(f"{'step':>8} {'t [s]':>10} {'bonds':>9} {'min':>6} {'max':>6} {'< 1/2':>7} {'< 1/5':>7} {'max |v| m/s':>12}")
        for step in sorted(f["snapshots"].keys(), key=int):
            s = f["snapshots"][step]
            x0 = s["reference"][:].reshape(-1, 3)
            x = s["position"][:].reshape(-1, 3)
            v = s["velocity"][:].reshape(-1, 3)
            r = bond_ratios(x0, x, s["body"][:], a.horizon)
            t = s.attrs.get("time", float("nan"))
            print(f"{step:>8} {t:>10.4g} {r.size // 2:>9} {r.min() if r.size else 1.0:>6.3f} "
                  f"{r.max() if r.size else 1.0:>6.2f} {(r < 0.5).sum() // 2:>7} {(r < 0.2).sum() // 2:>7} "
                  f"{np.linalg.norm(v, axis=1).max():>12.1f}")


if __name__ == "__main__":
    main()
