#!/usr/bin/python3
"""A GMH worker pool started by a real Slurm (docs/cluster.md).

Brings up a one-node cluster on this machine: installs Debian's slurm-wlm and
munge when they are missing, writes a cluster configuration into a scratch
directory (its own munge socket and key, its own ports), starts munged,
slurmctld and slurmd, and then:

  (a) runs a GMH scene whose four workers are `launch: srun` job steps, inside
      salloc, and checks its pool and FEM series identical to the bit to the
      same scene with the workers spawned locally;
  (c) submits it with the batch script `coupler sbatch` writes (sbatch
      --wait) and checks the same series;
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
    """munged, slurmctld and slurmd of a one-node cluster, all under `root`."""

    def __init__(self, root):
        self.root = root
        self.conf = os.path.join(root, "slurm.conf")
        self.env = dict(os.environ, SLURM_CONF=self.conf)
        self.daemons = []

    def write(self):
        host = socket.gethostname()
        for d in ("state", "spool", "log", "munge"):
            os.makedirs(os.path.join(self.root, d), exist_ok=True)
        os.chmod(os.path.join(self.root, "munge"), 0o700)
        self.key = os.path.join(self.root, "munge", "munge.key")
        with open(self.key, "wb") as f:
            f.write(os.urandom(1024))
        os.chmod(self.key, 0o400)
        self.socket = os.path.join(self.root, "munge", "munge.socket")
        cpus = max(16, os.cpu_count() or 2)
        lines = {
            "ClusterName": "cosimtest", "SlurmctldHost": host, "SlurmUser": "root", "SlurmdUser": "root",
            "AuthType": "auth/munge", "CredType": "cred/munge", "AuthInfo": "socket=" + self.socket,
            "StateSaveLocation": self.path("state"), "SlurmdSpoolDir": self.path("spool"),
            "SlurmctldPidFile": self.path("slurmctld.pid"), "SlurmdPidFile": self.path("slurmd.pid"),
            "SlurmctldLogFile": self.path("log/slurmctld.log"), "SlurmdLogFile": self.path("log/slurmd.log"),
            "SlurmctldPort": str(free_port()), "SlurmdPort": str(free_port()),
            # No cgroups: process tracking through /proc, no task containment.
            "ProctrackType": "proctrack/linuxproc", "TaskPlugin": "task/none", "MpiDefault": "none",
            "SelectType": "select/cons_tres", "SelectTypeParameters": "CR_CPU", "SchedulerType": "sched/builtin",
            "ReturnToService": "2", "JobAcctGatherType": "jobacct_gather/none",
            # The node offers more cores than the machine has, so a batch job's
            # components fit beside each other whatever this machine's size.
            "SlurmdParameters": "config_overrides",
            "AccountingStorageType": "accounting_storage/none",
        }
        with open(self.conf, "w") as f:
            for k, v in lines.items():
                f.write("%s=%s\n" % (k, v))
            f.write("NodeName=%s CPUs=%d RealMemory=4000 State=UNKNOWN\n" % (host, cpus))
            f.write("PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP OverSubscribe=FORCE:64\n")

    def path(self, name):
        return os.path.join(self.root, name)

    def up(self):
        os.makedirs(self.root, exist_ok=True)
        self.write()
        munged = shutil.which("munged") or "/usr/sbin/munged"
        self.spawn([munged, "--foreground", "--force", "--socket=" + self.socket, "--key-file=" + self.key,
                    "--pid-file=" + self.path("munge/munged.pid"), "--log-file=" + self.path("log/munged.log"),
                    "--seed-file=" + self.path("munge/munged.seed")])
        self.until(lambda: os.path.exists(self.socket), "munged's socket")
        for daemon in ("slurmctld", "slurmd"):
            exe = shutil.which(daemon) or "/usr/sbin/" + daemon
            self.spawn([exe, "-D", "-f", self.conf])
        self.until(lambda: "idle" in subprocess.run(["sinfo", "-h", "-o", "%T"], env=self.env, capture_output=True,
                                                   text=True).stdout, "the node to be idle")
        log("one-node cluster up (%s)" % self.conf)

    def spawn(self, cmd):
        out = open(self.path("log/" + os.path.basename(cmd[0]) + ".out"), "w")
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
        r = subprocess.run(["squeue", "-s", "-h", "-o", "%i %j"], env=self.env, capture_output=True, text=True)
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


def pool_scene(cell, steps, srun, on_loss, out_dir):
    text = scene(cell, 8, 4, steps, on_loss)
    text = text.replace("heartbeat_timeout: 20", "heartbeat_timeout: 5")
    if srun:
        text = text.replace("    kind: dem\n", "    kind: dem\n    launch: srun\n    resources: {cpus_per_task: 1, overlap: true}\n")
    path = os.path.join(out_dir, "%s-%s.yaml" % ("srun" if srun else "local", on_loss))
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

    # (a) srun workers against local ones.
    local, srun = pool_scene(cell, 60, False, "stop", work), pool_scene(cell, 60, True, "stop", work)
    code, _ = wait(run([coupler, "run", local, "--out", os.path.join(work, "local"), "--no-progress"],
                       os.path.join(work, "local"), env), 300)
    CHECKS(code == 0, "the local run completes (exit %s)" % code)
    salloc = ["salloc", "--quiet", "-n", "5", "--overcommit"]
    code, _ = wait(run(salloc + [coupler, "run", srun, "--out", os.path.join(work, "srun"), "--no-progress"],
                       os.path.join(work, "srun"), env), 300)
    with open(os.path.join(work, "srun.log")) as f:
        text = f.read()
    CHECKS(code == 0 and text.count("as a job step of Slurm job") == 4,
          "the run with four srun workers completes, each started as a job step (exit %s)" % code)
    if code == 0:
        CHECKS(same(pool(physics(os.path.join(work, "srun"))), pool(physics(os.path.join(work, "local")))),
              "its pool and FEM series are identical to the bit to the local run's")

    # (c) the same scene submitted with the batch script coupler sbatch writes.
    batch = os.path.join(work, "batch")
    made = subprocess.run([coupler, "sbatch", srun, "--out", batch, "--time", "00:10:00"], env=env, capture_output=True,
                          text=True)
    script = os.path.join(batch, "gmh-pool-scale.sbatch")
    CHECKS(made.returncode == 0 and ("submit it with: sbatch " + script) in made.stdout,
          "coupler sbatch writes the batch script (exit %s)" % made.returncode)
    if made.returncode == 0:
        submitted = subprocess.run(["sbatch", "--wait", "--quiet", script], env=env, capture_output=True, text=True,
                                   timeout=300)
        outputs = [f for f in os.listdir(batch) if f.startswith("slurm-") and f.endswith(".out")]
        text = open(os.path.join(batch, outputs[0])).read() if outputs else ""
        CHECKS(submitted.returncode == 0 and text.count("as a job step of Slurm job") == 4,
              "the batch job completes, its four workers started as job steps (exit %s%s)"
              % (submitted.returncode, "" if outputs else ", no output file"))
        if submitted.returncode == 0:
            CHECKS(same(pool(physics(batch)), pool(physics(os.path.join(work, "local")))),
                  "the batch job's pool and FEM series are identical to the bit to the local run's")

    # (b) a worker's step cancelled mid-run: its cells move, the run completes.
    steps = 1500
    local_move = pool_scene(cell, steps, False, "move", work)
    srun_move = pool_scene(cell, steps, True, "move", work)
    code, _ = wait(run([coupler, "run", local_move, "--out", os.path.join(work, "local-move"), "--no-progress"],
                       os.path.join(work, "local-move"), env), 600)
    CHECKS(code == 0, "the long local run completes (exit %s)" % code)
    out = os.path.join(work, "srun-move")
    p = run(salloc + [coupler, "run", srun_move, "--out", out, "--no-progress"], out, env)
    deadline = time.time() + 120
    while time.time() < deadline and p.poll() is None:
        if os.path.isdir(os.path.join(out, "checkpoints")) and any(
                d.startswith("exchange-") for d in os.listdir(os.path.join(out, "checkpoints"))):
            break
        time.sleep(0.05)
    step = next((s for s, name in cluster.steps() if name == "w01"), None)
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
