#!/usr/bin/python3
"""A GMH run across separate network hosts on one machine (docs/cluster.md).

Three network namespaces stand for three hosts: the coupler's (with FEM) and
two worker hosts, each joined to the coupler's by a veth pair with addresses
of its own (10.77.1.0/24, 10.77.2.0/24); nothing else is reachable from them.
The coupler listens on tcp with CurveZMQ; the four workers (`launch: attach`)
are started in the worker hosts and connect to the coupler's address on their
link with its public key. Then:

  (a) the run completes with pool and FEM series identical to the bit to the
      same scene run on one host (workers spawned by the coupler);
  (b) with `on_worker_loss: move`, the second worker host's link is set down
      after the first checkpoint: the coupler names both of its workers as
      lost within the heartbeat timeout (plus a second), moves their cells to
      the first host's workers, and the run completes with the same series.

The namespaces, and with them the links, are removed at the end, also when a
check fails. Exit 0: passed; 1: a check failed; 77: no root (namespaces and
links need CAP_NET_ADMIN), or `ip netns` is refused here, with the reason.

  separate_hosts_test.py [--bin DIR] [--keep]

Needs numpy and h5py (Debian's /usr/bin/python3).
"""
import argparse
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "support"))
from checks import ROOT, SKIP, Checks, in_scratch  # noqa: E402
from gmh_pool_scale import pool, scene  # noqa: E402
from kill_resume import physics, run_dir_processes, same, wait  # noqa: E402

PORT = 47311
HEARTBEAT_TIMEOUT = 3.0
WORKERS = {"w00": 1, "w01": 1, "w02": 2, "w03": 2}  # worker -> host


CHECKS = Checks("separate hosts test")
log = CHECKS.log


def ip(*args, check=True):
    return subprocess.run(["ip"] + list(args), capture_output=True, text=True, check=check)


class Hosts:
    """The coupler's namespace and two worker namespaces, linked by veth pairs."""

    def __init__(self):
        tag = str(os.getpid())
        self.coupler = "cosim-c" + tag
        self.workers = {1: "cosim-h1-" + tag, 2: "cosim-h2-" + tag}
        self.made = []

    def up(self):
        for ns in [self.coupler] + list(self.workers.values()):
            ip("netns", "add", ns)
            self.made.append(ns)
            ip("-n", ns, "link", "set", "lo", "up")
        for k, ns in self.workers.items():
            here, there = "c%d-%s" % (k, os.getpid() % 10000), "h%d-%s" % (k, os.getpid() % 10000)
            ip("link", "add", here, "netns", self.coupler, "type", "veth", "peer", "name", there, "netns", ns)
            ip("-n", self.coupler, "addr", "add", "10.77.%d.1/24" % k, "dev", here)
            ip("-n", ns, "addr", "add", "10.77.%d.2/24" % k, "dev", there)
            ip("-n", self.coupler, "link", "set", here, "up")
            ip("-n", ns, "link", "set", there, "up")
        self.links = {k: "c%d-%s" % (k, os.getpid() % 10000) for k in self.workers}
        log("hosts up: %s (10.77.1.1, 10.77.2.1), %s (10.77.1.2), %s (10.77.2.2)"
            % (self.coupler, self.workers[1], self.workers[2]))

    def run_in(self, ns, cmd):
        return ["ip", "netns", "exec", ns] + cmd

    def cut(self, host):
        ip("-n", self.coupler, "link", "set", self.links[host], "down")

    def down(self):
        for ns in self.made:
            # Whatever still runs in a namespace goes with it.
            pids = ip("netns", "pids", ns, check=False).stdout.split()
            for pid in pids:
                try:
                    os.kill(int(pid), 9)
                except (OSError, ValueError):
                    pass
            ip("netns", "del", ns, check=False)


def write_scene(path, cell, steps, on_loss, attach):
    text = scene(cell, 8, len(WORKERS), steps, on_loss)
    # data: zmq: the namespaces share this machine's host name and file
    # system, so the coupler would take them for its own host and move the
    # data through shared memory; the links are what is under test.
    transport = ("transport: {kind: tcp, interface: 0.0.0.0, port: %d, curve: true, heartbeat_interval: 0.5, "
                 "heartbeat_timeout: %g, connect_timeout: 60, data: zmq}\n" % (PORT, HEARTBEAT_TIMEOUT))
    text = re.sub(r"transport: \{[^}]*\}\n", transport if attach else
                  "transport: {heartbeat_interval: 0.5, heartbeat_timeout: %g, connect_timeout: 60}\n"
                  % HEARTBEAT_TIMEOUT, text)
    if attach:
        text = text.replace("    kind: dem\n", "    kind: dem\n    launch: attach\n")
    with open(path, "w") as f:
        f.write(text)
    return path




def start(cmd, logfile, env):
    with open(logfile, "a") as f:
        return subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, env=env, start_new_session=True)


def across_hosts(hosts, binaries, scene_file, out, env, disturb=None):
    """The coupler in its namespace, the workers in theirs; returns (exit, log, hung)."""
    coupler = start(hosts.run_in(hosts.coupler, [os.path.join(binaries, "coupler"), "run", scene_file, "--out", out,
                                                 "--no-progress"]), out + ".log", env)
    key = os.path.join(out, "coupler.pub")
    deadline = time.time() + 60
    while not os.path.exists(key) and time.time() < deadline and coupler.poll() is None:
        time.sleep(0.05)
    workers = []
    for name, host in WORKERS.items():
        cmd = [os.path.join(binaries, "dem_solver"), "--endpoint", "tcp://10.77.%d.1:%d" % (host, PORT), "--name", name,
               "--server-key-file", key]
        workers.append(start(hosts.run_in(hosts.workers[host], cmd), out + "." + name + ".log", env))
    detected = None
    if disturb:
        detected = disturb(coupler, out)
    code, hung = wait(coupler, 600)
    for w in workers:
        wait(w, 30)
    with open(out + ".log") as f:
        return code, f.read(), hung, detected


def cut_second_host(hosts):
    def disturb(coupler, out):
        deadline = time.time() + 120
        while time.time() < deadline and coupler.poll() is None:
            d = os.path.join(out, "checkpoints")
            if os.path.isdir(d) and any(e.startswith("exchange-") for e in os.listdir(d)):
                break
            time.sleep(0.05)
        hosts.cut(2)
        cut_at = time.time()
        # The coupler's log names the lost workers; when it does is the detection time.
        while time.time() - cut_at < 60 and coupler.poll() is None:
            with open(out + ".log") as f:
                text = f.read()
            if "worker 'w02' lost" in text or "worker 'w03' lost" in text:
                return time.time() - cut_at
            time.sleep(0.05)
        return None
    return disturb


def scenario(hosts, binaries, work):
    env = dict(os.environ, OMP_NUM_THREADS="1")
    subprocess.run([os.path.join(binaries, "dem_prepare_cell"), "--out", os.path.join(work, "cell"), "--count", "60",
                    "--seed", "3"], check=True, stdout=subprocess.DEVNULL, env=env)
    cell = os.path.join(work, "cell.ckpt")
    for label, steps, on_loss in (("whole", 60, "stop"), ("moved", 1500, "move")):
        local = write_scene(os.path.join(work, label + "-local.yaml"), cell, steps, on_loss, False)
        apart = write_scene(os.path.join(work, label + "-hosts.yaml"), cell, steps, on_loss, True)
        code, _ = wait(start([os.path.join(binaries, "coupler"), "run", local, "--out", os.path.join(work, label + "-local"),
                              "--no-progress"], os.path.join(work, label + "-local.log"), env), 600)
        CHECKS(code == 0, "%s: the one-host run completes (exit %s)" % (label, code))
        out = os.path.join(work, label + "-hosts")
        disturb = cut_second_host(hosts) if on_loss == "move" else None
        code, text, hung, detected = across_hosts(hosts, binaries, apart, out, env, disturb)
        CHECKS(code == 0 and not hung, "%s: the run across three hosts completes (exit %s)" % (label, code))
        if disturb:
            lost = [w for w in ("w02", "w03") if "worker '%s' lost" % w in text]
            CHECKS(lost == ["w02", "w03"], "moved: both workers of the cut host are named lost (%s)" % lost)
            CHECKS(detected is not None and detected <= HEARTBEAT_TIMEOUT + 1.0,
                  "moved: detected %s s after the link went down (heartbeat timeout %g s)"
                  % ("%.2f" % detected if detected is not None else "never", HEARTBEAT_TIMEOUT))
            CHECKS("silent for" in text, "moved: the coupler says they fell silent")
        if code == 0:
            CHECKS(same(pool(physics(out)), pool(physics(os.path.join(work, label + "-local")))),
                  "%s: the pool and FEM series are identical to the bit to the one-host run's" % label)
        CHECKS(not run_dir_processes(out), "%s: no process outlives the run" % label)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--keep", action="store_true", help="keep the scratch directory")
    a = ap.parse_args()
    if os.geteuid() != 0:
        log("skipped: network namespaces need root")
        return SKIP
    probe = ip("netns", "add", "cosim-probe-%d" % os.getpid(), check=False)
    if probe.returncode != 0:
        log("skipped: ip netns is refused here: " + probe.stderr.strip())
        return SKIP
    ip("netns", "del", "cosim-probe-%d" % os.getpid(), check=False)
    return in_scratch(CHECKS, "cosim-hosts.", lambda work: Hosts(), lambda hosts, work: scenario(hosts, a.bin, work),
                      a.keep)

if __name__ == "__main__":
    sys.exit(main())
