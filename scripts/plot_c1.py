#!/usr/bin/python3
"""Plots of a scene C1 run (Cheng 2022 Sec. 6.1) from its coupler.h5:
trajectories z(y) of the particles against the beam-theory reference, their
lateral drift x(t) - x(0), and the energies of FEM, DEM and their sum.

usage: plot_c1.py RUN_DIR [RUN_DIR ...]   (several runs: overlaid, labelled by directory)
Writes c1_trajectories.png and c1_energy.png into the first RUN_DIR.
"""
import os
import sys

try:
    import h5py
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
except ImportError as e:  # Debian: apt-get install python3-h5py python3-matplotlib
    sys.exit(f"plot_c1.py: {e} (install python3-h5py and python3-matplotlib)")


def load(run):
    path = os.path.join(run, "coupler.h5")
    if not os.path.exists(path):
        sys.exit(f"plot_c1.py: {path}: no such file (is {run} a run directory?)")
    with h5py.File(path, "r") as f:
        s = f["series"]
        if "analysis" not in s:
            sys.exit(f"plot_c1.py: {path}: no /series/analysis (the scene has no cantilever-point-load analysis)")
        out = {"t": s["time"][:], "x": s["analysis/positions"][:], "zref": s["analysis/reference_z"][:],
               "total": s["analysis/total_energy"][:]}
        for solver in ("beam", "particles"):
            e = 0.0
            for name in ("kinetic", "strain", "hourglass", "elastic"):
                key = f"{solver}/energy/{name}"
                if key in s:
                    e = e + s[key][:]
            out[solver] = e
    n = min(len(v) for v in out.values() if hasattr(v, "__len__"))
    return {k: (v[:n] if hasattr(v, "__len__") else v) for k, v in out.items()}


def main(runs):
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 8))
    efig, eax = plt.subplots(figsize=(8, 5))
    for run in runs:
        d = load(run)
        label = os.path.basename(os.path.normpath(run))
        n = d["x"].shape[1] // 3
        for p in range(n):
            y, x, z = d["x"][:, 3 * p + 1], d["x"][:, 3 * p], d["x"][:, 3 * p + 2]
            ax1.plot(y, z, label=f"{label} particle {p}")
            ax2.plot(d["t"], x - x[0], label=f"{label} particle {p}")
        ax1.plot(d["x"][:, 1], d["zref"][:, 0], "k--", lw=1, label=f"{label} reference")
        eax.plot(d["t"], d["total"], label=f"{label} total")
        eax.plot(d["t"], d["beam"], ":", label=f"{label} FEM kinetic + strain")
        eax.plot(d["t"], d["particles"], ":", label=f"{label} DEM kinetic + elastic")
    ax1.set_xlabel("y [m]"), ax1.set_ylabel("z [m]"), ax1.set_title("particle trajectories against P y^3 / (3 E I)")
    ax2.set_xlabel("t [s]"), ax2.set_ylabel("x - x0 [m]"), ax2.set_title("lateral drift")
    ax1.legend(fontsize=7), ax2.legend(fontsize=7)
    fig.tight_layout()
    eax.set_xlabel("t [s]"), eax.set_ylabel("energy [J]"), eax.set_yscale("symlog", linthresh=1e-2)
    eax.legend(fontsize=7)
    eax.set_title("energy (DEM potential relative to t = 0 in the total)")
    out1 = os.path.join(runs[0], "c1_trajectories.png")
    out2 = os.path.join(runs[0], "c1_energy.png")
    fig.savefig(out1, dpi=120)
    efig.savefig(out2, dpi=120)
    print(out1)
    print(out2)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
