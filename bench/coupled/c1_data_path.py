#!/usr/bin/env python3
"""Scene C1 (the default scene) over both data paths, one after the other on
the same binaries: transport.data = zmq (ipc sockets) and shm (shared
memory). Prints wall time, exchange loop, communication share and each
peer's round trip beside each other, and checks that every series of
coupler.h5 but the timings is identical to the bit.

Targets (docs/protocol.md, Shared-memory data path): the shm run's wall time
at most 0.6 of the zmq run's, its communication share at most 20 %.

Usage: /usr/bin/python3 bench/coupled/c1_data_path.py [--scene FILE] [--out DIR] [--set KEY=VALUE ...]
About 6 minutes on 2 cores with the default scene (about 4 of them the zmq run)."""
import argparse
import json
import os
import subprocess
import sys
import time

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
WALL_TARGET, SHARE_TARGET = 0.6, 0.20


def run(binaries, scene, out, data, sets):
    argv = [os.path.join(binaries, "coupler"), "run", scene, "--out", out, "--no-progress",
            "--set", f"transport={{data: {data}}}"]
    for s in sets:
        argv += ["--set", s]
    t0 = time.monotonic()
    p = subprocess.run(argv, capture_output=True, text=True)
    if p.returncode != 0:
        sys.exit(f"c1_data_path: the {data} run failed ({p.returncode}):\n{p.stderr[-3000:]}")
    with open(os.path.join(out, "run_report.json")) as f:
        report = json.load(f)
    report["measured_wall_s"] = time.monotonic() - t0
    return report


TIMINGS = ("compute_s", "communication_s")  # wall-clock series, never twice the same


def series(path):
    out = {}

    def keep(name, obj):
        if isinstance(obj, h5py.Dataset) and name.rsplit("/", 1)[-1] not in TIMINGS:
            out[name] = np.asarray(obj)

    with h5py.File(os.path.join(path, "coupler.h5"), "r") as f:
        f["/series"].visititems(keep)
    return out


def identical(a, b):
    if a.keys() != b.keys():
        return False, f"series differ in names: {sorted(a.keys() ^ b.keys())}"
    for name in a:
        if a[name].shape != b[name].shape or a[name].tobytes() != b[name].tobytes():
            return False, f"series {name} differs"
    return True, f"{len(a)} series identical to the bit"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default=os.path.join(ROOT, "configs", "c1", "cantilever_surface.yaml"))
    ap.add_argument("--out", default=os.path.join(ROOT, "bench", "coupled", "out", "c1_data_path"))
    ap.add_argument("--binaries", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--set", action="append", default=[], dest="sets")
    a = ap.parse_args()
    reports = {d: run(a.binaries, a.scene, os.path.join(a.out, d), d, a.sets) for d in ("zmq", "shm")}
    same, why = identical(series(os.path.join(a.out, "zmq")), series(os.path.join(a.out, "shm")))

    def share(r):
        return r["wall_s"]["communication"] / r["wall_s"]["exchange_loop"]

    print(f"scene {os.path.relpath(a.scene, ROOT)}; {reports['zmq']['exchanges']} exchanges; load average "
          f"{open('/proc/loadavg').read().split()[0]}")
    print(f"{'data path':<10}{'wall s':>9}{'loop s':>9}{'comm s':>9}{'comm %':>8}{'mapping s':>10}  per peer: compute s / comm s / us per request")
    for d, r in reports.items():
        peers = "; ".join(f"{p['name']} {p['compute_s']:.1f} / {p['communication_s']:.1f} / "
                          f"{1e6 * p['communication_s'] / max(1, p['messages_sent']):.1f}" for p in r["peers"])
        print(f"{d:<10}{r['wall_s']['total']:>9.1f}{r['wall_s']['exchange_loop']:>9.1f}"
              f"{r['wall_s']['communication']:>9.1f}{100 * share(r):>7.1f}%{r['wall_s']['coupler_mapping']:>10.1f}  {peers}")
    ratio = reports["shm"]["wall_s"]["total"] / reports["zmq"]["wall_s"]["total"]
    print(f"wall shm / zmq = {ratio:.2f} (target <= {WALL_TARGET}: {'met' if ratio <= WALL_TARGET else 'MISSED'}); "
          f"shm communication share {100 * share(reports['shm']):.1f} % (target <= {100 * SHARE_TARGET:.0f} %: "
          f"{'met' if share(reports['shm']) <= SHARE_TARGET else 'MISSED'}); {why}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
