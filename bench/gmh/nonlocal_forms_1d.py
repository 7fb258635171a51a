#!/usr/bin/python3
"""Which nonlocal form bounds the softening zone: a 1D bar (numpy).

A bar of length L under slow displacement control, explicit central
differences with mass damping, cells replaced by an elastic-softening law
(secant unloading) with a 2 % weaker element at 0.3 L. Three forms, each on
three meshes:

  local      sigma_I = f(eps_I)
  strain     sigma_I = f(e_I), e = [(1 - beta) A + beta I] eps      (Liu Eq. 58 with
             the local fraction beta of gmh's `local_fraction`)
  inelastic  sigma*_I = sigma_I + m (s_I - <s>_I), s = E eps - sigma   (gmh's
             `averages: inelastic_stress`, InelasticStressAveraging)

A is the bell operator of Liu Eq. A.3-A.4 over radius R. Prints the mean
stress against the nominal strain and the length of the zone strained past
twice the peak strain. What it shows (docs/gmh_unit_cells.md, "Averaging the
inelastic stress"): the strain form localises into a zone that shrinks with
the mesh, as the local one does; the inelastic form's zone and curve do not
change with the mesh once h <= R / 2.

Usage: nonlocal_forms_1d.py [--length 0.24] [--radius 0.0135] [--over-nonlocal 1]
       [--beta 0.15] [--forms local strain inelastic] [--elements 36 72 144]
"""
import argparse

import numpy as np

E, PEAK_STRESS, SOFTENING = 756e6, 1.5e6, -0.03 * 756e6  # Pa; the softening tangent
PEAK_STRAIN = PEAK_STRESS / E
SAMPLES = [19, 29, 39, 49, 59, 79, 99, 149, 199]  # 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1, 1.5, 2 % nominal strain


def law(e, emax):
    """Elastic to the peak, linear softening (floored at 5 % of the peak), secant unloading."""
    emax = np.maximum(emax, e)
    envelope = np.where(emax <= PEAK_STRAIN, E * emax,
                        np.maximum(PEAK_STRESS + SOFTENING * (emax - PEAK_STRAIN), 0.05 * PEAK_STRESS))
    secant = envelope / np.maximum(emax, 1e-30)
    return np.where(e >= emax, envelope, secant * e), emax


def bell_operator(x, radius):
    """Liu Eqs. A.3-A.4."""
    r = np.abs(x[:, None] - x[None, :])
    w = np.where(r <= radius, (1 - (r / radius) ** 2) ** 2, 0.0)
    return w / w.sum(axis=1, keepdims=True)


def run(n, form, a):
    h = a.length / n
    x = (np.arange(n) + 0.5) * h
    avg = bell_operator(x, a.radius)
    blend = (1 - a.beta) * avg + a.beta * np.eye(n)
    strength = np.ones(n)
    strength[np.argmin(abs(x - 0.3 * a.length))] = 0.98
    rho = 2e6
    mass = np.full(n + 1, rho * h)
    mass[[0, -1]] /= 2
    steps = 40000
    dt = 0.25 * h / np.sqrt(E / rho)
    damping = 6 * np.sqrt(E / rho) / a.length
    u, v, emax = np.zeros(n + 1), np.zeros(n + 1), np.zeros(n)
    end = 0.02 * a.length
    curve = []
    for s in range(steps):
        u[0], u[-1] = 0.0, end * (s + 1) / steps
        eps = np.diff(u) / h
        e = blend @ eps if form == "strain" else eps
        sigma, emax = law(e, emax)
        sigma = sigma * strength
        if form == "inelastic":
            inelastic = a.cell_stiffness * E * e - sigma
            sigma = sigma + a.over_nonlocal * (inelastic - avg @ inelastic)
        f = np.zeros(n + 1)
        f[:-1] += sigma
        f[1:] -= sigma
        v += dt * (f / mass - damping * v)
        v[0], v[-1] = 0.0, end / steps / dt
        u += dt * v
        if (s + 1) % (steps // 200) == 0:
            curve.append(sigma.mean())
    zone = (np.diff(u) / h > 2 * PEAK_STRAIN).sum() * h
    return [curve[k] for k in SAMPLES], zone


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--length", type=float, default=0.24)
    p.add_argument("--radius", type=float, default=0.0135)
    p.add_argument("--over-nonlocal", type=float, default=1.0)
    p.add_argument("--beta", type=float, default=0.15)
    p.add_argument("--cell-stiffness", type=float, default=1.0,
                   help="C of the inelastic form as a fraction of the law's elastic E (cell_elasticity)")
    p.add_argument("--forms", nargs="+", default=["local", "strain", "inelastic"])
    p.add_argument("--elements", nargs="+", type=int, default=[36, 72, 144])
    a = p.parse_args()
    print(f"bar {1e3 * a.length:.0f} mm, R {1e3 * a.radius:.2f} mm, beta {a.beta}, m {a.over_nonlocal}, "
          f"C {a.cell_stiffness} E; "
          f"mean stress [kPa] at 0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1, 1.5, 2 % nominal strain; zone strained past 2 x the peak strain")
    for form in a.forms:
        for n in a.elements:
            curve, zone = run(n, form, a)
            print(f"{form:>9} h/R {a.length / n / a.radius:5.2f} " + " ".join(f"{s / 1e3:6.0f}" for s in curve)
                  + f"   zone {1e3 * zone:6.1f} mm")


if __name__ == "__main__":
    main()
