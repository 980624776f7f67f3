"""scripts/slurm-render.sbatch against a real Slurm, not a mock (`make test-cluster`; not part of `make test`).

The test starts a throwaway single-node cluster of its own: munged, slurmctld and slurmd as child processes, with
configuration, key, sockets, state and spool in a temporary directory (AuthInfo=socket= points Slurm at that munged;
nothing of the machine's own configuration is used or changed). It submits the documented array for 2 frames x 3
passes, SIGKILLs one task's render mid-way, requeues the task, and checks that the task resumed from its own
checkpoint (its log says how many pixel batches it kept, the count the checkpoint holds), that the tasks merged
every frame, that the dependent --merge job held by the failure runs after the documented recovery, and that each
frame is one process's, bit for bit and attribute for attribute. Every daemon is stopped by PID, whatever happens.
Needs Debian's slurm-wlm and munge (scripts/install-deps.sh --cluster); without them the test is skipped, except
under CI (CI=true), where it fails."""
import getpass
import os
import re
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import ROOT, read_full

REFRENDER = ROOT / "build" / "refrender"  # what the script finds beside itself: nothing tells it where
SBATCH = ROOT / "scripts" / "slurm-render.sbatch"
PROGRAMS = ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol", "scancel")
W, H, FRAMES, PASSES, BATCHES = 64, 48, (0, 1), 3, 6
# about 5 s a pass on one busy core: time to catch a task mid-render
RENDER_ARGS = ["--res", f"{W}x{H}", "--spp", 4, "--tspp", 800, "--batches", BATCHES, "--seed", 3,
               "--checkpoint-every", 0.5]
SCENE = """<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="32" height="24"/>
 <frames rate="24"/>
 <shutter fraction="0.5"/>
 <object><pointModel><splat center="-1 0 -10" normal="0 0 1" radius="1.2" color="1 0.5 0.25"/></pointModel>
 <material shading="unlit"/><animation><linear velocity="2 0 0"/></animation></object>
 <object><pointModel><splat center="0.5 0.2 -9" normal="0 0 1" radius="0.8" color="0.2 0.6 0.9"/></pointModel>
 <material shading="unlit"/><animation><linear velocity="-1 0.5 0"/></animation></object>
</scene>"""


def which(program):
    return shutil.which(program) or shutil.which(program, path="/usr/sbin:/sbin")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    """A single-node Slurm in directory `root`; stop() ends every process it started."""

    def __init__(self, root):
        self.root, self.daemons = root, []
        self.node = socket.gethostname().split(".")[0]
        self.conf = root / "slurm.conf"
        self.env = dict(os.environ, SLURM_CONF=str(self.conf))

    def start(self):
        munge = self.root / "munge"
        munge.mkdir(mode=0o711)
        key = munge / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o400)
        self.socket = munge / "munge.socket"
        self.spawn([which("munged"), "--foreground", "--force", f"--socket={self.socket}", f"--key-file={key}",
                    f"--pid-file={munge / 'munged.pid'}", f"--log-file={munge / 'munged.log'}",
                    f"--seed-file={munge / 'munged.seed'}"], "munged")
        self.wait_for(self.socket.exists, "munged's socket")
        self.write_conf()
        self.spawn([which("slurmctld"), "-D", "-f", str(self.conf)], "slurmctld")
        self.spawn([which("slurmd"), "-D", "-f", str(self.conf)], "slurmd")
        self.wait_for(lambda: self.run("sinfo", "-h", "-o", "%T", check=False).stdout.strip() == "idle",
                      "the node to be idle", timeout=60)

    def write_conf(self):
        """Addresses are 127.0.0.1, so the machine's name need not resolve."""
        user, r = getpass.getuser(), self.root
        for d in ("state", "spool", "log"):
            (r / d).mkdir()
        self.conf.write_text(f"""ClusterName=rrtest
SlurmctldHost={self.node}(127.0.0.1)
SlurmctldPort={free_port()}
SlurmdPort={free_port()}
SlurmUser={user}
SlurmdUser={user}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={self.socket}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU_Memory
SchedulerType=sched/builtin
JobRequeue=1
ReturnToService=2
MpiDefault=none
KillWait=5
MinJobAge=3600
StateSaveLocation={r}/state
SlurmdSpoolDir={r}/spool
SlurmctldPidFile={r}/slurmctld.pid
SlurmdPidFile={r}/slurmd.pid
SlurmctldLogFile={r}/log/slurmctld.log
SlurmdLogFile={r}/log/slurmd.log
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
NodeName={self.node} NodeAddr=127.0.0.1 CPUs=2 RealMemory=2000 State=UNKNOWN
PartitionName=test Nodes={self.node} Default=YES MaxTime=INFINITE State=UP
""")

    def spawn(self, argv, name):
        log = open(self.root / f"{name}.out", "w")
        self.daemons.append((name, subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT, cwd=self.root,
                                                    env=self.env, start_new_session=True)))
        log.close()

    def wait_for(self, condition, what, timeout=30):
        deadline = time.time() + timeout
        while time.time() < deadline:
            for name, proc in self.daemons:
                assert proc.poll() is None, f"{name} exited: {(self.root / f'{name}.out').read_text()[-2000:]}"
            if condition():
                return
            time.sleep(0.2)
        raise AssertionError(f"timed out waiting for {what}\n{self.logs()}")

    def run(self, *argv, check=True):
        proc = subprocess.run([which(argv[0]), *map(str, argv[1:])], capture_output=True, text=True, env=self.env,
                              cwd=self.root, timeout=120)
        assert not check or proc.returncode == 0, f"{argv}: {proc.stderr}"
        return proc

    def logs(self):
        files = sorted((self.root / "log").glob("*.log")) + sorted(self.root.glob("shared/logs/*.out"))
        return "\n".join(f"--- {p.name}\n{p.read_text()[-3000:]}" for p in files)

    def stop(self):
        """Cancels the jobs (their slurmstepd leave slurmd's process tree), stops the daemons by PID,
        then ends by PID any process still inside this cluster's directory (a job step left behind)."""
        if self.daemons and all(p.poll() is None for _, p in self.daemons):
            self.run("scancel", "--user", getpass.getuser(), check=False)
            deadline = time.time() + 30
            while time.time() < deadline and self.run("squeue", "-h", check=False).stdout.strip():
                time.sleep(0.3)
        for _, proc in reversed(self.daemons):
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout=15)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
        for pid in self.processes_inside():
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass

    def processes_inside(self):
        """PIDs whose working directory, open files or command line lie in this cluster's directory."""
        root, found = str(self.root), []
        for entry in Path("/proc").iterdir():
            if not entry.name.isdigit() or int(entry.name) == os.getpid():
                continue
            try:
                places = [os.readlink(entry / "cwd")] + [os.readlink(fd) for fd in (entry / "fd").iterdir()]
                places.append((entry / "cmdline").read_bytes().decode(errors="replace"))
            except OSError:
                continue
            if any(root in p for p in places):
                found.append(int(entry.name))
        return found


@pytest.fixture
def cluster():
    missing = [p for p in PROGRAMS if not which(p)]
    if missing:
        message = f"Slurm is not installed (no {', '.join(missing)}): scripts/install-deps.sh --cluster"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    assert REFRENDER.exists(), f"{REFRENDER} is not built: make test-cluster builds it"
    # a short path: munge's socket path must fit a sockaddr_un (108 bytes)
    root = Path(tempfile.mkdtemp(prefix="rr-slurm-"))
    c = Cluster(root)

    def stop_and_exit(signum, frame):  # a SIGTERM (a timeout) skips finally: stop the daemons first
        c.stop()
        shutil.rmtree(root, ignore_errors=True)
        os._exit(128 + signum)

    previous = signal.signal(signal.SIGTERM, stop_and_exit)
    try:
        c.start()
        yield c
    finally:
        c.stop()
        shutil.rmtree(root, ignore_errors=True)
        signal.signal(signal.SIGTERM, previous)


def job_state(c, jobid):
    out = c.run("scontrol", "show", "job", jobid, check=False).stdout
    m = re.search(r"JobState=(\S+)", out)
    return m.group(1) if m else "GONE"


def task_state(c, jobid, task):
    return job_state(c, f"{jobid}_{task}")


def render_pid(checkpoint):
    """The refrender process writing `checkpoint` (it is named on its command line)."""
    for entry in Path("/proc").iterdir():
        try:
            argv = (entry / "cmdline").read_bytes().split(b"\0")
        except OSError:
            continue
        if entry.name.isdigit() and argv[0].endswith(b"refrender") and str(checkpoint).encode() in argv:
            return int(entry.name)
    return None


def wait(c, condition, what, timeout=240):
    deadline = time.time() + timeout
    while time.time() < deadline:
        if condition():
            return
        time.sleep(0.05)
    raise AssertionError(f"timed out waiting for {what}\n{c.run('squeue', check=False).stdout}\n{c.logs()}")


def test_slurm_array_renders_frames_resumes_a_killed_task_and_merges_bit_for_bit(cluster, tmp_path):
    c = cluster
    shared = c.root / "shared"  # what the nodes share; here the one node's disk
    (shared / "logs").mkdir(parents=True)
    scene, out = shared / "scene.xml", shared / "out"
    scene.write_text(SCENE)
    tasks = len(FRAMES) * PASSES
    frames = f"{FRAMES[0]}-{FRAMES[-1]}"
    args = ["--passes", PASSES, "--frames", frames, out, "--", scene, *RENDER_ARGS]
    # submitted as README shows, from a directory with no build/ in it
    env_cwd = dict(cwd=shared)
    submit = subprocess.run([which("sbatch"), "--parsable", f"--array=0-{tasks - 1}", "--cpus-per-task=1",
                             "--mem=200M", "--time=10", "-o", "logs/%A_%a.out", str(SBATCH), *map(str, args)],
                            capture_output=True, text=True, env=dict(c.env, REFRENDER_PROGRESS_EVERY="1"), **env_cwd)
    assert submit.returncode == 0, submit.stderr
    jobid = submit.stdout.strip().split(";")[0]
    merge_job = c.run("sbatch", "--parsable", f"--dependency=afterok:{jobid}", "--mem=100M", "-o",
                      shared / "logs" / "merge.out", SBATCH, "--merge", *args).stdout.strip()

    # kill task 4 (frame 1, pass 1) mid-render, after it has checkpointed
    victim = 4
    wait(c, lambda: any(out.glob(f"run-*/f{FRAMES[victim // PASSES]:04d}.p{victim % PASSES}of{PASSES}.ckpt.exr"))
         or task_state(c, jobid, victim) in ("COMPLETED", "FAILED"), "task 4's first checkpoint")
    assert task_state(c, jobid, victim) == "RUNNING", f"task 4 ended before it could be killed\n{c.logs()}"
    run_dir = next(out.glob("run-*"))
    checkpoint = run_dir / f"f{FRAMES[victim // PASSES]:04d}.p{victim % PASSES}of{PASSES}.ckpt.exr"
    pid = render_pid(checkpoint)
    assert pid, "task 4's render ended before it could be killed"
    os.kill(pid, signal.SIGKILL)
    wait(c, lambda: task_state(c, jobid, victim) == "FAILED", "task 4 to fail")
    header_batches = pixel_batches(checkpoint)
    assert 0 < header_batches < W * H * BATCHES // PASSES, header_batches

    # the documented recovery: requeue the task and let it start now (a
    # requeued job is otherwise held for 2 minutes: Reason=BeginTime)
    c.run("scontrol", "requeue", f"{jobid}_{victim}")
    c.run("scontrol", "update", f"JobId={jobid}_{victim}", "StartTime=now")
    wait(c, lambda: all(task_state(c, jobid, t) == "COMPLETED" for t in range(tasks)), "all tasks to complete")
    # Slurm's own behaviour: the merge job held on afterok never runs now
    wait(c, lambda: "DependencyNeverSatisfied" in c.run("scontrol", "show", "job", merge_job).stdout,
         "the merge job's dependency to be marked never satisfied", timeout=90)
    # the documented recovery: every task has now succeeded, so the hold goes
    # (naming the array again, afterok:JOB, is not enough: it stays failed)
    c.run("scontrol", "update", f"JobId={merge_job}", "Dependency=")
    wait(c, lambda: job_state(c, merge_job) in ("COMPLETED", "FAILED"), "the merge job")

    log = (shared / "logs" / f"{jobid}_{victim}.out").read_text()
    assert f"task {victim} (restart 0)" in log and f"task {victim} (restart 1)" in log, log
    total = W * H * BATCHES // PASSES
    assert f"resuming {checkpoint}: {header_batches} of {total} pixel batches already done" in log, log
    assert "batches 2-4 of 6" in log and "% after" in log and "done in" in log, log
    for i, frame in enumerate(FRAMES):  # the task that completed a frame merged it
        logs = [(shared / "logs" / f"{jobid}_{i * PASSES + k}.out").read_text() for k in range(PASSES)]
        assert any(f"frame {frame} merged" in text for text in logs), logs
    assert job_state(c, merge_job) == "COMPLETED", (shared / "logs" / "merge.out").read_text()

    one = c.root / "one"
    one.mkdir()
    proc = subprocess.run([str(REFRENDER), scene, "--frames", frames, *map(str, RENDER_ARGS), "--quiet",
                           "-o", one / "one.%04d.exr"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    for frame in FRAMES:
        a, ha = read_full(one / f"one.{frame:04d}.exr")
        b, hb = read_full(out / f"render.{frame:04d}.exr")
        assert a.keys() == b.keys()
        for name in a:
            assert np.array_equal(a[name], b[name], equal_nan=True), (frame, name)
        differ = {k for k in set(ha) | set(hb) if k not in ("refrender:command", "refrender:renderSeconds")
                  and not np.array_equal(np.asarray(ha.get(k)), np.asarray(hb.get(k)))}
        assert differ == set(), (frame, differ)
        assert hb["refrender:frame"] == frame
        seconds = [read_full(run_dir / f"f{frame:04d}.p{k}of{PASSES}.exr")[1]["refrender:renderSeconds"]
                   for k in range(PASSES)]
        assert hb["refrender:renderSeconds"] == pytest.approx(sum(seconds), abs=1e-3 * PASSES)


def pixel_batches(state):
    """The batches a render state holds over all pixels (OpenImageIO gives the uint channel as a
    fraction of 2^32 - 1)."""
    fractions = read_full(state)[0]["state.batches"].astype(np.float64)
    return int(np.rint(fractions * 4294967295.0).sum())
