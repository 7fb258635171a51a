#!/usr/bin/python3
"""A GMH worker pool started by a real Slurm (docs/cluster.md).

Brings up a two-node cluster on this machine: installs Debian's slurm-wlm and
munge when they are missing, writes a cluster configuration into a scratch
directory (its own munge socket and key, its own ports), starts munged,
slurmctld and one slurmd per node (n1, n2), and then:

  (a) runs a GMH scene whose four workers, one pool entry (`pool: {workers:
      4, workers_per_node: 2}`), are `launch: srun` job steps, inside an
      salloc of both nodes, checks that the first two run on n1 and the
      others on n2, and that its pool and FEM series are identical to the bit
      to the same scene with the workers declared one by one and spawned
      locally;
  (c) submits it with the batch script `coupler sbatch` writes (sbatch
      --wait) and checks the same series;
  (d) submits it (workers_per_node: 4) with the heterogeneous script
      `coupler sbatch --heterogeneous` writes: the coupler's component on one
      node, the pool's on the other, where all four workers run; same series;
  (b) runs it again with `on_worker_loss: move`, cancels one worker's job step
      (scancel JOB.STEP) once the run is past its first checkpoint, and checks
      that the coupler named the lost worker, moved its cells, completed the
      run with the same series, and that no step or process outlives it.

Every daemon it started is stopped and the scratch directory removed, also
when a check fails. Exit 0: passed; 1: a check failed; 77: this machine
cannot host the cluster (not root and no sudo, or the packages cannot be
installed), with the reason.

  slurm_cluster_test.py [--bin DIR] [--keep]

Needs numpy and h5py (Debian's /usr/bin/python3).
"""
import argparse
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "support"))
from checks import ROOT, SKIP, Checks, in_scratch  # noqa: E402
from gmh_pool_scale import pool, scene  # noqa: E402
from kill_resume import physics, run_dir_processes, same, wait  # noqa: E402

PACKAGES = ["slurm-wlm", "munge"]


CHECKS = Checks("slurm test")
log = CHECKS.log


def as_root(cmd):
    return cmd if os.geteuid() == 0 else ["sudo", "-n"] + cmd


def ensure_packages():
    missing = [p for p in PACKAGES if subprocess.run(["dpkg-query", "-W", "-f=${Status}", p], capture_output=True,
                                                     text=True).stdout.find("install ok installed") < 0]
    if not missing:
        return None
    log("installing " + " ".join(missing))
    env = dict(os.environ, DEBIAN_FRONTEND="noninteractive")
    for cmd in (["apt-get", "update", "-qq"], ["apt-get", "install", "-y", "-qq", "--no-install-recommends"] + missing):
        r = subprocess.run(as_root(cmd), env=env, capture_output=True, text=True, timeout=300)
        if r.returncode != 0:
            return "cannot install %s: %s" % (" ".join(missing), (r.stderr or r.stdout).strip()[-400:])
    return None


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """munged, slurmctld and the slurmd of two nodes, n1 and n2, all on this
    host under `root`: each slurmd has its own port and spool (`slurmd -N`),
    so an allocation can span two nodes and a heterogeneous job can put its
    components on different nodes (the backfill scheduler, which schedules
    heterogeneous jobs, reserves whole nodes for a pending component)."""

    NODES = ("n1", "n2")

    def __init__(self, root):
        self.root = root
        self.conf = os.path.join(root, "slurm.conf")
        self.env = dict(os.environ, SLURM_CONF=self.conf)
        self.daemons = []

    def write(self):
        host = socket.gethostname()
        for d in ("state", "log", "munge") + tuple("spool/" + n for n in self.NODES):
            os.makedirs(os.path.join(self.root, d), exist_ok=True)
        os.chmod(os.path.join(self.root, "munge"), 0o700)
        self.key = os.path.join(self.root, "munge", "munge.key")
        with open(self.key, "wb") as f:
            f.write(os.urandom(1024))
        os.chmod(self.key, 0o400)
        self.socket = os.path.join(self.root, "munge", "munge.socket")
        lines = {
            "ClusterName": "cosimtest", "SlurmctldHost": host, "SlurmUser": "root", "SlurmdUser": "root",
            "AuthType": "auth/munge", "CredType": "cred/munge", "AuthInfo": "socket=" + self.socket,
            "StateSaveLocation": self.path("state"), "SlurmdSpoolDir": self.path("spool/%n"),
            "SlurmctldPidFile": self.path("slurmctld.pid"), "SlurmdPidFile": self.path("slurmd-%n.pid"),
            "SlurmctldLogFile": self.path("log/slurmctld.log"), "SlurmdLogFile": self.path("log/slurmd-%n.log"),
            "SlurmctldPort": str(free_port()),
            # No cgroups: process tracking through /proc, no task containment.
            "ProctrackType": "proctrack/linuxproc", "TaskPlugin": "task/none", "MpiDefault": "none",
            "SelectType": "select/cons_tres", "SelectTypeParameters": "CR_CPU",
            "SchedulerType": "sched/backfill", "SchedulerParameters": "bf_interval=1",
            "ReturnToService": "2", "JobAcctGatherType": "jobacct_gather/none",
            # The nodes offer more cores than the machine has, so a job's
            # tasks fit whatever this machine's size.
            "SlurmdParameters": "config_overrides",
            "AccountingStorageType": "accounting_storage/none",
        }
        with open(self.conf, "w") as f:
            for k, v in lines.items():
                f.write("%s=%s\n" % (k, v))
            for node in self.NODES:
                f.write("NodeName=%s NodeHostname=%s NodeAddr=127.0.0.1 Port=%d CPUs=8 RealMemory=2000 State=UNKNOWN\n"
                        % (node, host, free_port()))
            f.write("PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:64\n")

    def path(self, name):
        return os.path.join(self.root, name)

    def up(self):
        os.makedirs(self.root, exist_ok=True)
        self.write()
        munged = shutil.which("munged") or "/usr/sbin/munged"
        self.spawn("munged", [munged, "--foreground", "--force", "--socket=" + self.socket, "--key-file=" + self.key,
                              "--pid-file=" + self.path("munge/munged.pid"), "--log-file=" + self.path("log/munged.log"),
                              "--seed-file=" + self.path("munge/munged.seed")])
        self.until(lambda: os.path.exists(self.socket), "munged's socket")
        self.spawn("slurmctld", [shutil.which("slurmctld") or "/usr/sbin/slurmctld", "-D", "-f", self.conf])
        for node in self.NODES:
            self.spawn("slurmd-" + node, [shutil.which("slurmd") or "/usr/sbin/slurmd", "-D", "-f", self.conf, "-N", node])
        self.until(lambda: subprocess.run(["sinfo", "-h", "-o", "%T %D"], env=self.env, capture_output=True,
                                          text=True).stdout.split() == ["idle", str(len(self.NODES))],
                   "both nodes to be idle")
        log("two-node cluster up (%s)" % self.conf)

    def spawn(self, name, cmd):
        out = open(self.path("log/" + name + ".out"), "w")
        self.daemons.append(subprocess.Popen(as_root(cmd), stdout=out, stderr=subprocess.STDOUT, env=self.env,
                                             start_new_session=True))

    def until(self, ready, what, limit=60):
        deadline = time.time() + limit
        while time.time() < deadline:
            if any(d.poll() is not None for d in self.daemons):
                raise RuntimeError("a daemon exited while waiting for %s; see %s" % (what, self.path("log")))
            if ready():
                return
            time.sleep(0.2)
        raise RuntimeError("no %s within %d s; see %s" % (what, limit, self.path("log")))

    def steps(self):
        """[step id, name, node] of every running job step."""
        r = subprocess.run(["squeue", "-s", "-h", "-o", "%i %j %N"], env=self.env, capture_output=True, text=True)
        return [line.split() for line in r.stdout.splitlines() if line.strip()]

    def down(self):
        subprocess.run(["scancel", "--full", "--user", "root"], env=self.env, capture_output=True)
        for d in reversed(self.daemons):
            if d.poll() is None:
                os.killpg(d.pid, signal.SIGTERM)
        for d in reversed(self.daemons):
            try:
                d.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(d.pid, signal.SIGKILL)
                d.wait()


def nodes_of_steps(cluster, process, names):
    """The node of each named job step, watched while `process` runs."""
    seen = {}
    while process.poll() is None and len(seen) < len(names):
        for step in cluster.steps():
            if len(step) == 3 and step[1] in names:
                seen[step[1]] = step[2]
        time.sleep(0.05)
    return seen


def pool_scene(cell, steps, srun, on_loss, out_dir, per_node=None):
    """The pool scene, its four workers spawned here or srun job steps; with
    per_node one entry `cells` (cells-0 .. cells-3), workers_per_node: per_node."""
    text = scene(cell, 8, 4, steps, on_loss, as_pool=per_node is not None)
    text = text.replace("heartbeat_timeout: 20", "heartbeat_timeout: 5")
    if srun:
        text = text.replace("    kind: dem\n", "    kind: dem\n    launch: srun\n    resources: {cpus_per_task: 1, overlap: true}\n")
        text = text.replace("pool: {workers: 4}", "pool: {workers: 4, workers_per_node: %s}" % per_node)
    path = os.path.join(out_dir, "%s-%s%s.yaml" % ("srun" if srun else "local", on_loss,
                                                   "-pool%s" % per_node if per_node else ""))
    with open(path, "w") as f:
        f.write(text)
    return path



def run(cmd, out, env, limit=300):
    with open(out + ".log", "w") as f:
        p = subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT, env=env, start_new_session=True)
    return p



def scenario(cluster, binaries, work):
    env = dict(cluster.env, OMP_NUM_THREADS="1")
    coupler = os.path.join(binaries, "coupler")
    subprocess.run([os.path.join(binaries, "dem_prepare_cell"), "--out", os.path.join(work, "cell"), "--count", "60",
                    "--seed", "3"], check=True, stdout=subprocess.DEVNULL, env=env)
    cell = os.path.join(work, "cell.ckpt")

    # (a) srun workers against local ones: one pool entry of four workers,
    # two per node, in an allocation of both nodes; the local ones declared
    # one by one.
    local = pool_scene(cell, 60, False, "stop", work)
    code, _ = wait(run([coupler, "run", local, "--out", os.path.join(work, "local"), "--no-progress"],
                       os.path.join(work, "local"), env), 300)
    CHECKS(code == 0, "the local run completes (exit %s)" % code)
    workers = ["cells-%d" % k for k in range(4)]
    srun = pool_scene(cell, 60, True, "stop", work, per_node=2)
    p = run(["salloc", "--quiet", "-N", "2", "-n", "5", "--overcommit", coupler, "run", srun, "--out",
             os.path.join(work, "srun"), "--no-progress"], os.path.join(work, "srun"), env)
    placed = nodes_of_steps(cluster, p, workers)
    code, _ = wait(p, 300)
    with open(os.path.join(work, "srun.log")) as f:
        text = f.read()
    CHECKS(code == 0 and text.count("as a job step of Slurm job") == 4,
          "the run with four srun workers completes, each started as a job step (exit %s)" % code)
    CHECKS(placed == {"cells-0": "n1", "cells-1": "n1", "cells-2": "n2", "cells-3": "n2"},
          "workers_per_node: 2 puts cells-0, cells-1 on the first node and cells-2, cells-3 on the second (%s)" % placed)
    if code == 0:
        CHECKS(same(pool(physics(os.path.join(work, "srun"))), pool(physics(os.path.join(work, "local")))),
              "its pool and FEM series are identical to the bit to the local run's")

    # (c) the same scene submitted with the batch script coupler sbatch writes,
    # and (d) as a heterogeneous job: the coupler's component on one node, the
    # pool's (workers_per_node: 4) on the other.
    for form, scene_file, extra, where in (
            ("batch", srun, [], None),
            ("heterogeneous", pool_scene(cell, 60, True, "stop", work, per_node=4), ["--heterogeneous"], "n2")):
        batch = os.path.join(work, form)
        made = subprocess.run([coupler, "sbatch", scene_file, "--out", batch, "--time", "00:10:00"] + extra, env=env,
                              capture_output=True, text=True)
        script = os.path.join(batch, "gmh-pool-scale.sbatch")
        CHECKS(made.returncode == 0 and ("submit it with: sbatch " + script) in made.stdout,
              "coupler sbatch%s writes the batch script (exit %s)" % ("".join(" " + e for e in extra), made.returncode))
        if made.returncode != 0:
            continue
        submitted = subprocess.Popen(["sbatch", "--wait", "--quiet", script], env=env, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, start_new_session=True)
        placed = nodes_of_steps(cluster, submitted, workers)
        code, hung = wait(submitted, 300)
        outputs = [f for f in os.listdir(batch) if f.startswith("slurm-") and f.endswith(".out")]
        text = "".join(open(os.path.join(batch, f)).read() for f in outputs)
        CHECKS(code == 0 and text.count("as a job step of Slurm job") == 4,
              "the %s job completes, its four workers started as job steps (exit %s%s)"
              % (form, code, "" if outputs else ", no output file"))
        if where:
            CHECKS(set(placed.values()) == {where} and len(placed) == 4,
                  "its workers run in the pool's component, on %s (%s)" % (where, placed))
        if code == 0:
            CHECKS(same(pool(physics(batch)), pool(physics(os.path.join(work, "local")))),
                  "the %s job's pool and FEM series are identical to the bit to the local run's" % form)

    # (b) a worker's step cancelled mid-run: its cells move, the run completes.
    steps = 1500
    local_move = pool_scene(cell, steps, False, "move", work)
    srun_move = pool_scene(cell, steps, True, "move", work)
    code, _ = wait(run([coupler, "run", local_move, "--out", os.path.join(work, "local-move"), "--no-progress"],
                       os.path.join(work, "local-move"), env), 600)
    CHECKS(code == 0, "the long local run completes (exit %s)" % code)
    out = os.path.join(work, "srun-move")
    p = run(["salloc", "--quiet", "-n", "5", "--overcommit", coupler, "run", srun_move, "--out", out, "--no-progress"],
            out, env)
    deadline = time.time() + 120
    while time.time() < deadline and p.poll() is None:
        if os.path.isdir(os.path.join(out, "checkpoints")) and any(
                d.startswith("exchange-") for d in os.listdir(os.path.join(out, "checkpoints"))):
            break
        time.sleep(0.05)
    step = next((s[0] for s in cluster.steps() if s[1] == "w01"), None)
    CHECKS(step is not None, "worker w01 runs as a job step once the run is past its first checkpoint")
    if step:
        subprocess.run(["scancel", step], env=cluster.env, check=True)
    code, hung = wait(p, 600)
    with open(out + ".log") as f:
        text = f.read()
    CHECKS(code == 0 and not hung, "the run goes on to its end after the step is cancelled (exit %s)" % code)
    CHECKS("worker 'w01' lost" in text and "unit cells moved from the checkpoint" in text,
          "the coupler names the lost worker and moves its cells")
    if code == 0:
        CHECKS(same(pool(physics(out)), pool(physics(os.path.join(work, "local-move")))),
              "the pool and FEM series are identical to the bit to the undisturbed local run's")
    time.sleep(1.0)
    left = cluster.steps()
    CHECKS(not left, "no job step outlives the run (%s)" % left)
    CHECKS(not run_dir_processes(out), "no process outlives the run")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    ap.add_argument("--keep", action="store_true", help="keep the scratch directory")
    a = ap.parse_args()
    if os.geteuid() != 0 and subprocess.run(["sudo", "-n", "true"], capture_output=True).returncode != 0:
        log("skipped: the daemons need root (not root, and no password-less sudo)")
        return SKIP
    why = ensure_packages()
    if why:
        log("skipped: " + why)
        return SKIP
    return in_scratch(CHECKS, "cosim-slurm.", lambda work: Cluster(os.path.join(work, "cluster")),
                      lambda cluster, work: scenario(cluster, a.bin, work), a.keep)

if __name__ == "__main__":
    sys.exit(main())
