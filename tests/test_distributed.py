"""Distributed rendering without a cluster: what `refrender merge` writes into
the merged header, and the Slurm array script (scripts/slurm-render.sbatch)
and GNU parallel script run with their environments faked. The same script
against a real Slurm is tests/cluster_slurm.py (`make test-cluster`)."""
import os
import re
import shutil
from pathlib import Path
import struct
import subprocess

import numpy as np
import pytest

from conftest import BIN, ROOT, read_full, run

SBATCH = ROOT / "scripts" / "slurm-render.sbatch"
W, H, SPP, TSPP, BATCHES = 32, 24, 4, 8, 4
# a disc sliding across a 24 fps sequence with a 180-degree shutter
FRAMED = f"""<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="{W}" height="{H}"/>
 <frames rate="24"/>
 <shutter fraction="0.5"/>
 <object><pointModel><splat center="-1 0 -10" normal="0 0 1" radius="1.2" color="1 0.5 0.25"/></pointModel>
 <material shading="unlit"/><animation><linear velocity="2 0 0"/></animation></object>
</scene>"""
COMMON = ["--batches", BATCHES, "--spp", SPP, "--tspp", TSPP, "--seed", 5, "--quiet"]


def scene_file(tmp_path):
    scene = tmp_path / "framed.xml"
    scene.write_text(FRAMED)
    return scene


def render_ok(*args):
    proc = run(args)
    assert proc.returncode == 0, proc.stderr
    return proc


def passes_of_frame(tmp_path, frame, n=2, args=COMMON):
    scene = scene_file(tmp_path)
    paths = []
    for k in range(n):
        path = tmp_path / f"f{frame}.p{k}.exr"
        render_ok(scene, "--frame", frame, *args, "--pass", f"{k}/{n}", "-o", path)
        paths.append(path)
    return paths


def test_merged_header_is_one_renders_with_the_work_summed(tmp_path):
    # One render and the merge of its two passes: every attribute one render
    # writes is in the merged file; the frame, frame rate, shutter and camera
    # matrices equal (the passes render the same frame from the same camera);
    # rays are the work of both passes: each batch traces one primary ray per
    # sample here (one disc, nothing behind it), W*H*spp*tspp*B in all.
    single = tmp_path / "single.exr"
    render_ok(scene_file(tmp_path), "--frame", 3, *COMMON, "-o", single)
    parts = passes_of_frame(tmp_path, 3)
    merged = tmp_path / "merged.exr"
    render_ok("merge", *parts, "-o", merged)
    one, merged_header = read_full(single)[1], read_full(merged)[1]
    missing = sorted(set(one) - set(merged_header))
    assert missing == [], missing
    for key in ("refrender:frame", "refrender:frameRate", "refrender:shutterOpen", "refrender:shutterClose",
                "worldToCamera", "worldToNDC", "refrender:cameraTime", "refrender:worldToCameraOpen",
                "refrender:worldToCameraClose", "refrender:cameraTimeOpen", "refrender:cameraTimeClose"):
        assert np.array_equal(np.asarray(one[key]), np.asarray(merged_header[key])), key
    assert merged_header["refrender:frame"] == 3 and merged_header["refrender:frameRate"] == 24
    assert merged_header["refrender:rays"] == one["refrender:rays"] == W * H * SPP * TSPP * BATCHES
    seconds = [read_full(p)[1]["refrender:renderSeconds"] for p in parts]
    assert merged_header["refrender:renderSeconds"] == pytest.approx(sum(seconds), abs=1.5e-3)
    different = {k for k in one if k not in ("refrender:command", "refrender:renderSeconds")
                 and not np.array_equal(np.asarray(one[k]), np.asarray(merged_header[k]))}
    assert different == set(), different


def patch_attribute(path, name, type_name, value_bytes):
    """Rewrites one attribute's value in an EXR header in place (name, type,
    size, value: the OpenEXR file layout); the pixels stay as they are."""
    data = bytearray(path.read_bytes())
    tag = name.encode() + b"\0" + type_name.encode() + b"\0" + struct.pack("<i", len(value_bytes))
    at = data.index(tag) + len(tag)
    data[at:at + len(value_bytes)] = value_bytes
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("name,type_name,value", [
    ("refrender:frame", "int", struct.pack("<i", 4)),
    ("refrender:frameRate", "double", struct.pack("<d", 25.0)),
    ("refrender:shutterOpen", "double", struct.pack("<d", 0.1)),
    ("refrender:shutterClose", "double", struct.pack("<d", 0.2)),
    ("worldToCamera", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
    ("worldToNDC", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
    ("refrender:cameraTime", "double", struct.pack("<d", 0.7)),
    ("refrender:worldToCameraOpen", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
    ("refrender:worldToCameraClose", "m44f", struct.pack("<16f", *np.eye(4).ravel() * 2)),
], ids=lambda v: v if isinstance(v, str) and ":" in v or v in ("worldToCamera", "worldToNDC") else "")
def test_merge_refuses_passes_that_disagree_on(tmp_path, name, type_name, value):
    # A pass numbered as another frame, or seen from another camera, is not a
    # share of this image: the merge names the attribute and both files.
    p0, p1 = passes_of_frame(tmp_path, 3)
    patch_attribute(p1, name, type_name, value)
    out = tmp_path / "merged.exr"
    proc = run(["merge", p0, p1, "-o", out])
    assert proc.returncode == 1, proc.stderr
    assert name in proc.stderr and str(p0) in proc.stderr and str(p1) in proc.stderr, proc.stderr
    assert not out.exists()


def make_build_id(*variables):
    """`make print-build-id` for the build directory of the refrender under
    test (build, build-check with DCHECKS=1, build-san with SAN=1), with
    further make variables; None for a binary built elsewhere."""
    build_vars = {"build": [], "build-check": ["DCHECKS=1"], "build-san": ["SAN=1"]}.get(Path(BIN).parent.name)
    if build_vars is None:
        return None
    proc = subprocess.run(["make", "-s", "--no-print-directory", "-C", str(ROOT), "print-build-id", *build_vars,
                           *variables], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


def test_build_id_covers_the_compiler_its_flags_and_the_embree_and_tbb_versions(tmp_path):
    # Issue 56.9: the id hashed src/ only, so a state rendered with other
    # flags (-ffast-math, another -O), another compiler or another Embree
    # merged with this build's. Each input changes the id; the same inputs
    # give the same id, whichever directory asks.
    ours = make_build_id()
    if ours is None:
        pytest.skip("refrender was not built in build/, build-check/ or build-san/")
    assert re.fullmatch("[0-9a-f]{64}", ours) and ours == make_build_id()
    fake = tmp_path / "include" / "embree3"
    fake.mkdir(parents=True)
    (fake / "rtcore_config.h").write_text('#define RTC_VERSION_STRING "3.99.0"\n')
    includes = f"INCLUDES=-I{tmp_path / 'include'} -I/usr/include/embree3 -I/usr/include/OpenEXR -I/usr/include/libxml2"
    changed = {"flags": make_build_id("CFLAGS=-ffast-math"), "embree": make_build_id(includes)}
    if shutil.which("clang"):
        changed["compiler"] = make_build_id("CC=clang")
    assert all(v != ours for v in changed.values()), changed


def test_states_of_another_build_do_not_merge_or_resume(tmp_path):
    # A pass or checkpoint carries the build that rendered it (the id the
    # Makefile prints); one from another build is refused by name, as a
    # rebuilt shared tree under a running array job would otherwise mix two
    # renderers' pixels.
    p0, p1 = passes_of_frame(tmp_path, 3)
    ours = read_full(p0)[1]["refrender:build"]
    assert ours == make_build_id() or make_build_id() is None
    other = "0" * 64
    patch_attribute(p1, "refrender:build", "string", other.encode())
    out = tmp_path / "merged.exr"
    proc = run(["merge", p0, p1, "-o", out])
    assert proc.returncode == 1 and "different builds of refrender" in proc.stderr, proc.stderr
    assert ours in proc.stderr and other in proc.stderr and str(p1) in proc.stderr, proc.stderr
    assert not out.exists()
    resumed = tmp_path / "resumed.exr"
    proc = run([scene_file(tmp_path), "--frame", 3, *COMMON, "--pass", "1/2", "-o", resumed, "--resume", p1])
    assert proc.returncode == 1 and "different builds of refrender" in proc.stderr, proc.stderr
    assert not resumed.exists()


def test_a_state_from_before_the_build_id_is_called_one_from_an_older_build(tmp_path):
    # Issue 56.9: a state written before refrender:build existed was refused
    # as "not a refrender render state". Its header as such a build wrote it
    # (the attribute renamed in place: no refrender:build) is named a state
    # of an older build, for merge and for resume; a final image is still
    # "not a refrender render state" when it lacks an identity attribute.
    p0, p1 = passes_of_frame(tmp_path, 3)
    for p in (p0, p1):
        data = p.read_bytes()
        assert data.count(b"refrender:build\0") == 1
        p.write_bytes(data.replace(b"refrender:build\0", b"refrender:bxild\0"))
    out = tmp_path / "merged.exr"
    proc = run(["merge", p0, p1, "-o", out])
    assert proc.returncode == 1 and "a render state from an older build of refrender" in proc.stderr, proc.stderr
    assert str(p0) in proc.stderr and "no refrender:build" in proc.stderr and not out.exists()
    resumed = tmp_path / "resumed.exr"
    proc = run([scene_file(tmp_path), "--frame", 3, *COMMON, "--pass", "1/2", "-o", resumed, "--resume", p1])
    assert proc.returncode == 1 and "a render state from an older build of refrender" in proc.stderr, proc.stderr
    assert not resumed.exists()
    plain = tmp_path / "plain.exr"
    plain.write_bytes(p0.read_bytes().replace(b"refrender:state\0", b"refrender:sxate\0"))
    proc = run(["merge", plain, "-o", out])
    assert proc.returncode == 1 and "not a refrender render state (no refrender:build)" in proc.stderr, proc.stderr


def test_merge_refuses_a_pass_that_lacks_the_frame(tmp_path):
    # Frame 0's shutter rendered without --frame: the same pixels, but no
    # frame number to check the sequence by; mixed with numbered passes it is
    # refused, not merged into a header that half says which frame it is.
    (p0,) = passes_of_frame(tmp_path, 0, n=2)[:1]
    unnumbered = tmp_path / "unnumbered.exr"
    render_ok(scene_file(tmp_path), *COMMON, "--pass", "1/2", "-o", unnumbered)
    proc = run(["merge", p0, unnumbered, "-o", tmp_path / "m.exr"])
    assert proc.returncode == 1 and "refrender:frame" in proc.stderr, proc.stderr


def test_merge_of_exact_time_passes_weights_the_unresolved_share_by_rays(tmp_path):
    # The unresolved share is per traced ray: the merged share is the passes'
    # ray-weighted mean, which is one render's share up to the 6 digits the
    # passes store.
    exact = ["--time-integration", "exact", "--batches", BATCHES, "--spp", 1, "--quiet"]
    single = tmp_path / "single.exr"
    render_ok(scene_file(tmp_path), "--frame", 3, *exact, "-o", single)
    parts = passes_of_frame(tmp_path, 3, args=exact)
    merged = tmp_path / "merged.exr"
    render_ok("merge", *parts, "-o", merged)
    key = "refrender:exactUnresolvedShare"
    headers = [read_full(p)[1] for p in parts]
    rays = [h["refrender:rays"] for h in headers]
    weighted = sum(float(h[key]) * r for h, r in zip(headers, rays)) / sum(rays)
    got = float(read_full(merged)[1][key])
    assert got == pytest.approx(weighted, rel=1e-5, abs=1e-12)
    assert got == pytest.approx(float(read_full(single)[1][key]), rel=1e-4, abs=1e-9)


# ---- the Slurm array script, with the variables Slurm sets faked ----------

SLURM_VARS = ("SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT", "SLURM_ARRAY_TASK_MIN", "SLURM_ARRAY_TASK_MAX",
              "SLURM_CPUS_PER_TASK", "SLURM_RESTART_COUNT", "SLURM_JOB_ID", "SLURM_SUBMIT_DIR", "REFRENDER")


def task_env(task, array=(0, 3), **extra):
    """The environment of array task `task` of --array=LO-HI, as Slurm sets it."""
    env = {k: v for k, v in os.environ.items() if k not in SLURM_VARS}
    lo, hi = array
    env.update(REFRENDER=BIN, SLURM_ARRAY_TASK_ID=str(task), SLURM_ARRAY_TASK_MIN=str(lo),
               SLURM_ARRAY_TASK_MAX=str(hi), SLURM_ARRAY_TASK_COUNT=str(hi - lo + 1))
    env.update({k: str(v) for k, v in extra.items()})
    return {k: v for k, v in env.items() if v != "None"}


def sbatch_task(script_args, env, script=SBATCH, cwd=None, **kw):
    return subprocess.run(["sh", str(script), *map(str, script_args)], capture_output=True, text=True, env=env,
                          cwd=cwd, **kw)


def same_image_and_header(single, merged):
    a, ha = read_full(single)
    b, hb = read_full(merged)
    assert a.keys() == b.keys()
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    differ = {k for k in set(ha) | set(hb) if k not in ("refrender:command", "refrender:renderSeconds")
              and not np.array_equal(np.asarray(ha.get(k)), np.asarray(hb.get(k)))}
    assert differ == set(), differ


def test_slurm_array_renders_a_frame_range_as_passes_and_merges_each_frame(tmp_path):
    # 2 frames x 2 passes = array 0-3, the tasks in any order; the task that
    # completes a frame merges it, bit for bit and attribute for attribute
    # one process's frame (the merged header keeps the frame number).
    scene, out = scene_file(tmp_path), tmp_path / "out"
    args = ["--passes", 2, "--frames", "2-3", out, "--", scene, *COMMON]
    for task in (3, 1, 0, 2):
        proc = sbatch_task(args, task_env(task))
        assert proc.returncode == 0, proc.stderr
    render_ok(scene, "--frames", "2-3", *COMMON, "-o", tmp_path / "one.%04d.exr")
    for frame in (2, 3):
        same_image_and_header(tmp_path / f"one.{frame:04d}.exr", out / f"render.{frame:04d}.exr")
        assert read_full(out / f"render.{frame:04d}.exr")[1]["refrender:frame"] == frame


def test_one_slurm_task_reruns_alone_and_a_wrong_array_is_refused(tmp_path):
    # `sbatch --array=1` re-runs task 1 alone: Slurm then says COUNT=1, MIN=MAX=1,
    # and the pass count comes from --passes, not from the array.
    scene, out = scene_file(tmp_path), tmp_path / "out"
    args = ["--passes", 2, out, "--", scene, *COMMON]
    assert sbatch_task(args, task_env(0, array=(0, 1))).returncode == 0
    proc = sbatch_task(args, task_env(1, array=(1, 1)))
    assert proc.returncode == 0, proc.stderr
    render_ok(scene, *COMMON, "-o", tmp_path / "one.exr")
    same_image_and_header(tmp_path / "one.exr", out / "render.exr")
    # --array=1-8 for 8 passes: index 8 is no pass; without --passes it is refused
    beyond = sbatch_task(["--passes", 8, out, "--", scene, *COMMON], task_env(8, array=(1, 8)))
    assert beyond.returncode == 2 and "--array=0-7" in beyond.stderr, beyond.stderr
    implicit = sbatch_task([out, "--", scene, *COMMON], task_env(1, array=(1, 8)))
    assert implicit.returncode == 2 and "--passes N" in implicit.stderr, implicit.stderr


def pixel_batches(state):
    """The batches a render state holds, over all pixels: its uint channel
    state.batches, which OpenImageIO hands over as a fraction of 2^32 - 1."""
    fractions = read_full(state)[0]["state.batches"].astype(np.float64)
    return int(np.rint(fractions * 4294967295.0).sum())


def test_slurm_task_resumes_from_its_own_checkpoint(tmp_path):
    # Task 0 is stopped mid-render (SIGTERM, as Slurm's requeue and time limit
    # send): it leaves its checkpoint; run again (SLURM_RESTART_COUNT=1, same
    # index) it resumes from it, and the frame is still one process's image. The pass takes about
    # 0.3 s (64x48, tspp 512; 96x72 took 0.7 s and the test 33 s of a loaded suite): at tspp 64 it
    # took 0.1 s, often ending before the signal reached it; the first progress line comes at 0.05 s.
    import signal
    import time
    scene, out = scene_file(tmp_path), tmp_path / "out"
    slow = ["--res", "64x48", "--spp", 4, "--tspp", 512, "--batches", 4, "--seed", 5, "--checkpoint-every", 0]
    args = ["--passes", 2, out, "--", scene, *slow]
    log = tmp_path / "task0.log"
    with open(log, "w") as f:
        task = subprocess.Popen(["sh", str(SBATCH), *map(str, args)], stderr=f, text=True,
                                env=task_env(0, array=(0, 1), REFRENDER_PROGRESS_EVERY=0.05))
    deadline = time.time() + 60
    while "% after" not in log.read_text() and time.time() < deadline and task.poll() is None:  # rendering
        time.sleep(0.02)
    children = Path(f"/proc/{task.pid}/task/{task.pid}/children").read_text().split()
    assert len(children) == 1, children
    os.kill(int(children[0]), signal.SIGTERM)
    assert task.wait(timeout=60) != 0
    checkpoints = list(out.glob("run-*/still.p0of2.ckpt.exr"))
    assert len(checkpoints) == 1, log.read_text()
    kept = pixel_batches(checkpoints[0])
    assert 0 < kept < 64 * 48 * 2, (kept, log.read_text())
    again = sbatch_task(args, task_env(0, array=(0, 1), SLURM_RESTART_COUNT=1))
    assert again.returncode == 0, again.stderr
    assert f"resuming {checkpoints[0]}: {kept} of {64 * 48 * 2} pixel batches already done" in again.stderr
    assert not checkpoints[0].exists()  # done: a later re-run starts afresh
    assert sbatch_task(args, task_env(1, array=(0, 1))).returncode == 0
    render_ok(scene, *slow, "-o", tmp_path / "one.exr", "--quiet")
    one, merged = read_full(tmp_path / "one.exr")[0], read_full(out / "render.exr")[0]
    assert all(np.array_equal(one[c], merged[c]) for c in one)


def test_slurm_task_finds_refrender_when_submitted_from_elsewhere(tmp_path):
    # Under Slurm the script runs as a spooled copy, from a submit directory
    # with no build/: it finds refrender beside the script it was submitted
    # as (the job record's Command=, from scontrol).
    tree = tmp_path / "tree"
    (tree / "scripts").mkdir(parents=True)
    (tree / "build").mkdir()
    (tree / "scripts" / "slurm-render.sbatch").write_text(SBATCH.read_text())
    (tree / "build" / "refrender").symlink_to(BIN)
    spool = tmp_path / "spool" / "job00042"
    spool.mkdir(parents=True)
    (spool / "slurm_script").write_text(SBATCH.read_text())
    fake_bin = tmp_path / "bin"
    fake_bin.mkdir()
    scontrol = fake_bin / "scontrol"
    scontrol.write_text(f"#!/bin/sh\necho 'JobId=42 JobName=refrender'\n"
                        f"echo '   Command={tree}/scripts/slurm-render.sbatch'\n")
    scontrol.chmod(0o755)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = task_env(0, array=(0, 0), REFRENDER=None, SLURM_JOB_ID=42, SLURM_SUBMIT_DIR=elsewhere,
                   PATH=f"{fake_bin}:{os.environ['PATH']}")
    proc = sbatch_task(["--passes", 1, "out", "--", scene_file(tmp_path), *COMMON], env,
                       script=spool / "slurm_script", cwd=elsewhere)
    assert proc.returncode == 0, proc.stderr
    assert (elsewhere / "out" / "render.exr").exists()
    assert f"{tree}/build/refrender" in proc.stderr  # the log names the binary it ran


def recording_refrender(tmp_path):
    """A refrender that appends its arguments to a file, then runs the real one."""
    stub, record = tmp_path / "refrender-stub", tmp_path / "calls"
    stub.write_text(f'#!/bin/sh\necho "$*" >> {record}\nexec {BIN} "$@"\n')
    stub.chmod(0o755)
    return stub, record


def test_slurm_threads_follow_the_allocation_and_the_log_tells_the_task(tmp_path):
    # No CPU count is written into the script (a node with fewer CPUs would
    # leave the job pending forever); the render takes what the task was given.
    assert not [l for l in SBATCH.read_text().splitlines()
                if l.startswith("#SBATCH") and ("--cpus-per-task" in l or " -c" in l)]
    stub, record = recording_refrender(tmp_path)
    scene, out = scene_file(tmp_path), tmp_path / "out"
    args = ["--passes", 2, out, "--", scene, *[a for a in COMMON if a != "--quiet"]]
    with_three = sbatch_task(args, task_env(0, array=(0, 1), REFRENDER=stub, SLURM_CPUS_PER_TASK=3,
                                            REFRENDER_PROGRESS_EVERY=0.001))
    assert with_three.returncode == 0, with_three.stderr
    assert sbatch_task(args, task_env(1, array=(0, 1), REFRENDER=stub)).returncode == 0
    calls = record.read_text().splitlines()
    assert "--threads 3" in calls[0] and "--threads 1" in calls[1], calls
    log = with_three.stderr
    assert "task 0 (restart 0)" in log and "pass 0/2" in log  # which task, which share
    assert "batches 0-2 of 4" in log                         # its batch range
    assert "100.0% after" in log                             # progress lines, no terminal
    assert "rays in" in log and "done in" in log             # its timing


def test_reused_output_directory_keeps_runs_apart(tmp_path):
    # A second run with other settings into the same directory: its files
    # are its own (run-KEY/), so its merge never picks up the first run's
    # passes; a missing pass is reported by task, not filled from the old run.
    scene, out = scene_file(tmp_path), tmp_path / "out"
    first = ["--passes", 2, out, "--", scene, *COMMON]
    for task in (0, 1):
        assert sbatch_task(first, task_env(task, array=(0, 1))).returncode == 0
    second = ["--passes", 2, out, "--", scene, *COMMON, "--seed", 6]
    assert sbatch_task(second, task_env(0, array=(0, 1))).returncode == 0
    merge = sbatch_task(["--merge", *second], task_env(0, array=(0, 1)))
    assert merge.returncode == 2 and "no pass yet from array task(s) 1" in merge.stderr, merge.stderr
    assert sbatch_task(second, task_env(1, array=(0, 1))).returncode == 0
    render_ok(scene, *COMMON, "--seed", 6, "-o", tmp_path / "one.exr")
    same_image_and_header(tmp_path / "one.exr", out / "render.exr")
    assert len(list(out.glob("run-*/arguments"))) == 2


def test_render_parallel_never_runs_more_threads_than_cores(tmp_path):
    # GNU parallel starts a job a core by default; each pass then rendering
    # with every core ran cores^2 threads. Now at any moment the passes
    # running hold at most nproc threads together (their start and end times
    # and --threads recorded by a wrapper).
    wrapper, record = tmp_path / "wrapper", tmp_path / "calls"
    wrapper.write_text(f'#!/bin/sh\necho "$(date +%s.%N) start $*" >> {record}\n{BIN} "$@"; rc=$?\n'
                       f'echo "$(date +%s.%N) end $*" >> {record}\nexit $rc\n')
    wrapper.chmod(0o755)
    scene = scene_file(tmp_path)
    for per_host in ("1", "2"):
        record.unlink(missing_ok=True)
        proc = subprocess.run([str(ROOT / "scripts" / "render-parallel.sh"), "4", str(tmp_path / "m.exr"),
                               "--jobs-per-host", per_host, "--", str(scene), *map(str, COMMON)],
                              capture_output=True, text=True, env=dict(os.environ, REFRENDER=str(wrapper)))
        assert proc.returncode == 0, proc.stderr
        events = []
        for line in record.read_text().splitlines():
            when, what, args = line.split(" ", 2)
            if "--pass" in args:
                words = args.split()
                threads = int(words[words.index("--threads") + 1]) if "--threads" in words else os.cpu_count()
                events.append((float(when), threads if what == "start" else -threads))
        running = np.cumsum([d for _, d in sorted(events)])
        assert len(events) == 8 and running.max() <= os.cpu_count(), (per_host, record.read_text())


def test_slurm_logs_in_the_tree_are_ignored():
    # sbatch writes slurm-JOB_TASK.out into the submit directory
    proc = subprocess.run(["git", "check-ignore", "-q", "slurm-1234_5.out"], cwd=ROOT)
    if proc.returncode == 128:
        pytest.skip("not a git checkout")
    assert proc.returncode == 0


def test_resumed_render_reports_the_rays_of_the_whole_render(tmp_path):
    # Killed (SIGKILL: no last checkpoint) and resumed from its periodic
    # checkpoint, a pass reports the rays of all its batches, as if never
    # interrupted: one primary ray per sample here, W*H*spp*tspp*batches. So a
    # merge of requeued tasks still sums to one process's rays.
    import time
    scene = scene_file(tmp_path)
    w, h, tspp = 96, 72, 256
    args = [scene, "--res", f"{w}x{h}", "--spp", SPP, "--tspp", tspp, "--batches", 4, "--pass", "0/2",
            "--threads", 1, "--quiet", "--checkpoint-every", 0.2]
    state, out = tmp_path / "ckpt.exr", tmp_path / "pass.exr"
    proc = subprocess.Popen([BIN, *map(str, args), "--checkpoint", str(state), "-o", str(out)])
    deadline = time.time() + 60
    while not state.exists() and time.time() < deadline and proc.poll() is None:
        time.sleep(0.02)
    proc.kill()
    proc.wait()
    assert state.exists() and not out.exists(), "the render ended before its first checkpoint"
    assert 0 < read_full(state)[1]["refrender:rays"] < w * h * SPP * tspp * 2
    render_ok(*args, "--checkpoint", state, "--resume", state, "-o", out)
    assert read_full(out)[1]["refrender:rays"] == w * h * SPP * tspp * 2


def test_two_tasks_never_merge_one_frame_at_once(tmp_path):
    # Two tasks of a frame finishing together on two nodes would write its
    # image at once (and each one's stale-temporary sweep could remove the
    # other's file): a task merges only holding the frame's lock directory.
    scene, out = scene_file(tmp_path), tmp_path / "out"
    args = ["--passes", 2, out, "--", scene, *COMMON]
    assert sbatch_task(args, task_env(0, array=(0, 1))).returncode == 0
    (lock,) = [d / "still.merging" for d in out.glob("run-*")]
    lock.mkdir()  # another task is merging
    last = sbatch_task(args, task_env(1, array=(0, 1)))
    assert last.returncode == 0 and "another task is merging it" in last.stderr, last.stderr
    assert not (out / "render.exr").exists()
    lock.rmdir()
    by_hand = sbatch_task(["--merge", *args], task_env(0, array=(0, 1)))
    assert by_hand.returncode == 0 and (out / "render.exr").exists(), by_hand.stderr


def stub_refrender(tmp_path):
    """A refrender that records its arguments, one call a line, and creates the file its -o names (a
    pass, or a merged frame), so that the script's arithmetic is seen without rendering."""
    stub, record = tmp_path / "refrender-stub", tmp_path / "calls"
    stub.write_text(f'#!/bin/sh\necho "$*" >> {record}\n'
                    'while [ $# -gt 1 ]; do [ "$1" = -o ] && : > "$2"; shift; done\n')
    stub.chmod(0o755)
    return stub, record


@pytest.mark.parametrize("frames, task, frame", [("0010-0010", 0, 10), ("08-09", 0, 8), ("08-09", 1, 9),
                                                 ("007-012", 5, 12)])
def test_slurm_frame_numbers_are_decimal(tmp_path, frames, task, frame):
    # The shell reads 0010 as octal 8 and 08 as an error: the frame a task renders, its --frame and
    # the merged file's number are the decimal ones written (one pass a frame: task K is frame A + K).
    stub, record = stub_refrender(tmp_path)
    out = tmp_path / "out"
    proc = sbatch_task(["--passes", 1, "--frames", frames, out, "--", "s.xml"],
                       task_env(task, array=(0, 9), REFRENDER=stub))
    assert proc.returncode == 0, proc.stderr
    render, merge = record.read_text().splitlines()
    assert f"--frame {frame}" in render and "--pass 0/1" in render, render
    assert merge.startswith("merge ") and merge.endswith(f"render.{frame:04d}.exr"), merge


def test_slurm_pass_count_is_decimal_for_the_script_and_refrender(tmp_path):
    # --passes 010: ten passes (not 8 to the script and 10 to refrender), so task 9 is pass 9/10
    stub, record = stub_refrender(tmp_path)
    proc = sbatch_task(["--passes", "010", tmp_path / "out", "--", "s.xml"],
                       task_env(9, array=(0, 9), REFRENDER=stub))
    assert proc.returncode == 0, proc.stderr
    assert "--pass 9/10" in record.read_text().splitlines()[0]


@pytest.mark.parametrize("option, value", [("--passes", "0"), ("--passes", "-1"), ("--passes", ""),
                                           ("--passes", "abc"), ("--passes", "1e3"), ("--passes", "9999999999"),
                                           ("--frames", "1-x"), ("--frames", "3-2"), ("--frames", "0-99999999999")])
def test_slurm_numbers_that_are_not_decimal_counts_are_refused(tmp_path, option, value):
    stub, record = stub_refrender(tmp_path)
    args = ["--passes", 1, option, value, tmp_path / "out", "--", "s.xml"]
    proc = sbatch_task(args, task_env(0, array=(0, 0), REFRENDER=stub), timeout=60)  # before: 1e10 passes looped
    assert proc.returncode == 2 and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert proc.stderr.startswith("slurm-render: ") and option in proc.stderr and not record.exists(), proc.stderr


def render_parallel(args, cwd, **env):
    return subprocess.run([str(ROOT / "scripts" / "render-parallel.sh"), *map(str, args)], capture_output=True,
                          text=True, cwd=cwd, env={**os.environ, "REFRENDER": BIN, **env}, timeout=300)


def test_render_parallel_passes_arguments_word_for_word(tmp_path):
    # A scene path with a space and a -D value with spaces reach refrender as one word each: the merge
    # equals one process's render of the same arguments (bit for bit, README).
    scene = tmp_path / "my scene.xml"
    scene.write_text(FRAMED.replace('<frames rate="24"/>', '<frames rate="24"/><background color="$bg"/>'))
    args = [scene, "-D", "bg=0.5 0.25 0.125", *COMMON]
    proc = render_parallel([2, tmp_path / "m.exr", "--", *args], tmp_path)
    assert proc.returncode == 0, proc.stderr
    render_ok(*args, "-o", tmp_path / "one.exr")
    one, merged = read_full(tmp_path / "one.exr")[0], read_full(tmp_path / "m.exr")[0]
    assert all(np.array_equal(one[c], merged[c]) for c in one)
    assert np.allclose(merged["B"][merged["A"] == 0], 0.125)  # the background given by -D
    # nothing in an argument is run: not by a shell (;), not by GNU parallel's {= perl =}
    for hostile in ("x.xml;touch injected;:", "{= system('touch injected') =}", "$(touch injected)"):
        proc = render_parallel([2, tmp_path / "h.exr", "--", hostile, *COMMON], tmp_path)
        assert proc.returncode != 0 and f"refrender: {hostile}: cannot open" in proc.stderr, proc.stderr
        assert not (tmp_path / "injected").exists(), hostile


@pytest.mark.parametrize("n", ["0", "-1", "", "abc", "2x"])
def test_render_parallel_refuses_a_pass_count_that_is_no_count(tmp_path, n):
    proc = render_parallel([n, tmp_path / "m.exr", "--", scene_file(tmp_path), *COMMON], tmp_path)
    assert proc.returncode == 2 and len(proc.stderr.splitlines()) == 1, proc.stderr
    assert f"expected a count from 1 to 999999999, got '{n}'" in proc.stderr
    assert not (tmp_path / "m.exr").exists()


def test_render_parallel_reads_08_as_eight_passes(tmp_path):
    stub, record = recording_refrender(tmp_path)
    args = [scene_file(tmp_path), "--batches", 8, "--spp", 1, "--tspp", 2, "--quiet"]
    proc = render_parallel(["08", tmp_path / "m.exr", "--", *args], tmp_path, REFRENDER=str(stub))
    assert proc.returncode == 0, proc.stderr
    passes = sorted(l.split("--pass ")[1].split()[0] for l in record.read_text().splitlines() if "--pass" in l)
    assert passes == [f"{k}/8" for k in range(8)]


def test_slurm_passes_and_frames_are_bounded(tmp_path):
    """--passes beyond refrender's 524288 batches and a frame range beyond a
    Slurm array's 4000001 tasks are refused at once (before: --merge looped
    over 1e9 passes or frames, a subshell each, while a string grew); at the
    bound, --merge with no pass there names the first 20 missing tasks and
    the count of the rest within the timeout."""
    scene, out = scene_file(tmp_path), tmp_path / "out"
    env = {**os.environ, "REFRENDER": BIN}
    for args, says in ((["--passes", 999999999], "expected a count from 1 to 524288"),
                       (["--passes", 524289], "expected a count from 1 to 524288"),
                       (["--passes", 2, "--frames", "0-999999999"], "more than the 4000001 tasks"),
                       (["--passes", 8, "--frames", "0-500000"], "more than the 4000001 tasks")):
        proc = sbatch_task(["--merge", *args, out, "--", scene, *COMMON], env, timeout=30)
        assert proc.returncode == 2 and says in proc.stderr, (args, proc.stderr)
    proc = sbatch_task(["--merge", "--passes", 524288, out, "--", scene, *COMMON], env, timeout=120)
    assert proc.returncode == 2 and "task(s) 0 1 2 " in proc.stderr and " 19 and 524268 more" in proc.stderr, proc.stderr
