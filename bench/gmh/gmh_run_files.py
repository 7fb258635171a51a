"""Readers shared by the GMH scene analyses (bench/gmh/l3_*.py, l4_*.py, l5_*.py).

A finished (or stopped) GMH run directory holds the FEM snapshots (the file
the scene's `output.file` names: /mesh/{coordinates, topology}, and per
written step /snapshots/<step>/{displacement, stress, strain, ...} with the
attribute time) and the coupler series (coupler.h5: /series/time and, under
the gmh coupling's name, the pool means and the per-cell arrays cell_ids,
cell_porosity, cell_coordination, cell_stress).

Pairing: fem_solver writes snapshot k after predicting the positions of
coarse step k and sends the increments to them; the cells' answers to those
increments are series row k (row 0: the prepared cells at setup). So series
row k holds the cells' response to the strain of snapshot k.
"""
import os

os.environ.setdefault("HDF5_USE_FILE_LOCKING", "FALSE")  # the files may still be written by a running scene
import h5py  # noqa: E402
import numpy as np  # noqa: E402


def open_h5(path):
    return h5py.File(path, "r")


def snapshots(fem):
    """Sorted snapshot steps and their groups."""
    steps = sorted(int(k) for k in fem["snapshots"].keys())
    return steps, [fem["snapshots"][str(s)] for s in steps]


def series_row(step, rows):
    """The coupler series row of coarse step `step` (the last row if the run stopped before it)."""
    return min(step, rows - 1)


def cell_series(series, coupling="cells"):
    """Per-cell results of a gmh coupling: ids (columns), porosity and
    coordination [rows x cells], stress [rows x cells x 3 x 3] (corotational
    Cauchy, tension positive)."""
    g = series[coupling]
    ids = g["cell_ids"][()]
    porosity = g["cell_porosity"][()]
    stress = g["cell_stress"][()]
    return {
        "ids": ids[0].astype(int),
        "porosity": porosity,
        "coordination": g["cell_coordination"][()],
        "stress": stress.reshape(stress.shape[0], -1, 3, 3),
    }


def element_gradient(coords, topology, disp, e):
    """Displacement gradient H = du/dX of element e from its eight nodes: the
    least-squares affine fit u = H X + c, which for a box (parallelepiped)
    element is exactly the one-point (centroid) gradient."""
    nodes = topology[e]
    X = np.hstack([coords[nodes], np.ones((8, 1))])
    sol, *_ = np.linalg.lstsq(X, disp[nodes], rcond=None)
    return sol[:3].T


def rotation(F):
    """R of the polar decomposition F = R U (Liu Eq. 62 rotates the cell's corotational stress with it)."""
    w, _, vt = np.linalg.svd(F)
    return w @ vt
