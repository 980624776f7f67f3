"""Error estimates, samplers, split-and-merge and checkpoint/resume, end to
end: a ground truth must say how far to trust it and survive being split."""
import os
import signal
import subprocess
import time

import numpy as np
import pytest

from conftest import BIN, ROOT, read_exr, read_full, run, wait_for_handlers

SCENE = ROOT / "scenes" / "default.xml"
DISK = """<scene>
 <camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="32" height="24"/>
 <object><pointModel><splat center="-1 0 -10" normal="0 0 1" radius="1.2" color="1 0.5 0.25"/></pointModel>
 <material shading="unlit"/><animation><linear velocity="2 0 0"/></animation></object>
</scene>"""


def render_disk(tmp_path, name, *args):
    scene = tmp_path / "disk.xml"
    scene.write_text(DISK)
    out = tmp_path / name
    proc = run([scene, "-o", out, "--quiet", *args])
    assert proc.returncode == 0, proc.stderr
    return read_full(out)


def test_reported_variance_matches_the_spread_over_seeds(tmp_path):
    # The stderr^2 channel estimates the variance of a pixel's value. Over 16
    # independent seeds the empirical variance of each pixel measures the
    # same thing; summed over the noisy pixels the two agree. The ratio of two
    # averages of many chi-square-like terms is within 25% of 1 here (each
    # side has hundreds of degrees of freedom).
    values, reported = [], []
    for seed in range(16):
        ch, _ = render_disk(tmp_path, f"s{seed}.exr", "--spp", 1, "--tspp", 4, "--batches", 4, "--seed", seed + 1)
        values.append(ch["R"])
        reported.append(ch["variance.R"])
    values, reported = np.array(values), np.array(reported)
    observed = values.var(axis=0, ddof=1)
    noisy = observed > 0
    assert noisy.sum() > 50
    ratio = observed[noisy].sum() / reported.mean(axis=0)[noisy].sum()
    assert 0.8 < ratio < 1.25, ratio
    ch, header = render_disk(tmp_path, "one.exr", "--batches", 3)
    assert np.allclose(ch["stderr.G"] ** 2, ch["variance.G"], rtol=1e-5)
    assert np.all(ch["samples"] == 3 * 4 * 100) and header["refrender:batches"] == 3


def test_single_batch_has_no_error_channels(tmp_path):
    ch, _ = render_disk(tmp_path, "b1.exr", "--tspp", 4)
    assert "stderr.R" not in ch and np.all(ch["samples"] == 16)


def test_target_error_adds_batches_where_needed(tmp_path):
    proc_args = ["--spp", 1, "--tspp", 4, "--batches", 2, "--target-error", 0.02, "--max-batches", 12]
    ch, header = render_disk(tmp_path, "target.exr", *proc_args)
    batches = ch["samples"] / 4
    assert batches.min() == 2  # empty background: zero error after 2 batches
    assert batches.max() > 2
    se = np.maximum.reduce([ch["stderr.R"], ch["stderr.G"], ch["stderr.B"]])
    # every pixel either reached the target or used the whole cap
    assert np.all((se <= 0.02) | (batches == 12))
    reached = int(np.count_nonzero(se <= 0.02))
    assert header["refrender:targetReached"] == f"{reached} of {se.size} pixels"


def test_target_error_alone_takes_four_batches(tmp_path):
    # an error estimate needs batches: without --batches a target means B = 4 (the cap 8 B = 32)
    ch, header = render_disk(tmp_path, "t4.exr", "--spp", 1, "--tspp", 4, "--target-error", 1e-9)
    assert header["refrender:batches"] == 4 and (ch["samples"] / 4).min() == 4 and (ch["samples"] / 4).max() == 32


@pytest.mark.parametrize("sampler", ["thesis", "jittered3d", "sobol"])
def test_every_sampler_is_unbiased_for_the_moving_disk(tmp_path, sampler):
    # Reference: the same scene with many samples; each sampler's mean over
    # the image must agree within 5 standard errors (from its own batches).
    ch, _ = render_disk(tmp_path, f"{sampler}.exr", "--sampler", sampler, "--spp", 4, "--tspp", 16, "--batches", 4)
    ref, _ = render_disk(tmp_path, "ref.exr", "--sampler", "jittered3d", "--spp", 16, "--tspp", 64, "--batches", 4,
                         "--seed", 99)
    diff = ch["A"].sum() - ref["A"].sum()
    se = np.sqrt((ch["variance.A"]).sum() + ref["variance.A"].sum())
    assert abs(diff) <= 5 * se + 1e-6, (sampler, diff, se)


def test_unknown_sampler_and_bad_combinations_are_usage_errors():
    assert run(["--sampler", "halton"]).returncode == 2
    assert run(["--pass", "1/4", "--batches", 2]).returncode == 2
    assert run(["--pass", "4/4", "--batches", 4]).returncode == 2
    assert run(["--target-error", "0.1", "--batches", 1]).returncode == 2  # no error estimate from one batch


COMMON = ["--res", "40x32", "--spp", 4, "--tspp", 8, "--batches", 4, "--sampler", "sobol", "--seed", 5]


def test_parallel_passes_merge_to_the_single_render_bit_for_bit(tmp_path):
    single = tmp_path / "single.exr"
    assert run([SCENE, *COMMON, "-o", single, "--quiet"]).returncode == 0
    merged = tmp_path / "merged.exr"
    env = dict(os.environ, REFRENDER=BIN)
    proc = subprocess.run([str(ROOT / "scripts" / "render-parallel.sh"), "4", str(merged), "--", str(SCENE),
                           *map(str, COMMON)], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    a, _ = read_full(single)
    b, header = read_full(merged)
    assert a.keys() == b.keys()
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    assert header["refrender:sampler"] == "sobol"
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".passes")] == []


def test_merge_refuses_mismatched_missing_and_overlapping_states(tmp_path):
    def state(name, *extra):
        path = tmp_path / name
        assert run([SCENE, *COMMON, *extra, "-o", path, "--quiet"]).returncode == 0
        return path
    p0, p1 = state("p0.exr", "--pass", "0/2"), state("p1.exr", "--pass", "1/2")
    other_seed = state("q1.exr", "--pass", "1/2", "--seed", 6)
    bad = run(["merge", p0, other_seed, "-o", tmp_path / "x.exr"])
    assert bad.returncode == 1 and "refrender:seed" in bad.stderr
    missing = run(["merge", p0, "-o", tmp_path / "x.exr"])
    assert missing.returncode == 1 and "batches 2-4 are missing" in missing.stderr
    overlap = run(["merge", p0, p0, p1, "-o", tmp_path / "x.exr"])
    assert overlap.returncode == 1 and "overlaps" in overlap.stderr
    final = tmp_path / "final.exr"
    assert run([SCENE, *COMMON, "-o", final, "--quiet"]).returncode == 0
    not_state = run(["merge", final, "-o", tmp_path / "x.exr"])
    assert not_state.returncode == 1 and "not a render state" in not_state.stderr
    assert not (tmp_path / "x.exr").exists()


SLOW = [SCENE, "--res", "64x64", "--spp", 4, "--tspp", 48, "--batches", 6, "--threads", 2, "--quiet"]


def wait_for(path, timeout=60):
    end = time.time() + timeout
    while not path.exists() and time.time() < end:
        time.sleep(0.05)
    assert path.exists()


def test_killed_render_resumes_to_the_uninterrupted_image(tmp_path):
    full = tmp_path / "full.exr"
    assert run([*SLOW, "-o", full]).returncode == 0
    ck = tmp_path / "ck.exr"
    proc = subprocess.Popen([BIN, *map(str, SLOW), "-o", str(tmp_path / "never.exr"), "--checkpoint", str(ck),
                             "--checkpoint-every", "0.2"])
    wait_for(ck)
    time.sleep(0.5)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert not (tmp_path / "never.exr").exists()
    _, header = read_full(ck)
    assert header["refrender:state"] == "batches 0-6"
    resumed = tmp_path / "resumed.exr"
    proc = run([*SLOW, "-o", resumed, "--resume", ck, "--checkpoint", ck])
    assert proc.returncode == 0, proc.stderr
    a, _ = read_full(full)
    b, _ = read_full(resumed)
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name


def test_sigterm_writes_a_final_checkpoint(tmp_path):
    ck = tmp_path / "ck.exr"
    longer = [*SLOW, "--max-batches", 60]  # same identity, ~20 s of work: still running at 1.5 s
    proc = subprocess.Popen([BIN, *map(str, longer), "--batches", "60", "-o", str(tmp_path / "out.exr"),
                             "--checkpoint", str(ck), "--checkpoint-every", "1000"], stderr=subprocess.PIPE, text=True)
    wait_for_handlers(proc)
    time.sleep(1.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err
    assert ck.exists() and not (tmp_path / "out.exr").exists()
    wrong = run([*SLOW, "--batches", 60, "--seed", 2, "-o", tmp_path / "out.exr", "--resume", ck])
    assert wrong.returncode == 1 and "refrender:seed" in wrong.stderr


# One tile of 4x1 pixels, each batch 16 x 32768 samples (jittered3d: their
# drawing is a third of a batch, sobol's half): about 1 s of one core, so a
# signal sent 0.12 s after a periodic checkpoint holds a pixel's batch lands
# inside the tile, and most likely inside the tracing of the next batch.
MID_TILE = [SCENE, "--res", "4x1", "--spp", 16, "--tspp", 32768, "--sampler", "jittered3d", "--threads", 2, "--quiet"]


def test_checkpoints_are_taken_between_pixels_and_resume_to_the_uninterrupted_image(tmp_path):
    # Issue 56.7: the periodic and the SIGTERM checkpoints waited for whole
    # tiles. Taken between pixels, the one tile's pixels are split between
    # 0 and 1 batches (old: all 4 had their batch, the tile ended first), the
    # batch interrupted is left out whole, and a resume from there gives the
    # uninterrupted render bit for bit.
    full = tmp_path / "full.exr"
    assert run([*MID_TILE, "-o", full]).returncode == 0
    ck = tmp_path / "ck.exr"
    proc = subprocess.Popen([BIN, *map(str, MID_TILE), "-o", str(tmp_path / "never.exr"), "--checkpoint", str(ck),
                             "--checkpoint-every", "0.05"], stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and not (ck.exists() and read_full(ck)[0]["state.batches"].any()):
        time.sleep(0.02)  # until a periodic checkpoint holds a pixel's batch (old: the whole tile's)
    time.sleep(0.12)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err
    state, _ = read_full(ck)  # (OpenImageIO gives the uint channel as a fraction of 2^32 - 1)
    batches = np.rint(state["state.batches"].astype(np.float64) * 4294967295.0)
    done = int(np.count_nonzero(batches == 1))
    assert 0 < done < 4 and np.count_nonzero(batches > 1) == 0, batches
    resumed = tmp_path / "resumed.exr"
    assert run([*MID_TILE, "-o", resumed, "--resume", ck]).returncode == 0
    a, full_header = read_full(full)
    b, resumed_header = read_full(resumed)
    for name in a:
        assert np.array_equal(a[name], b[name], equal_nan=True), name
    # the batch cut short counts no rays: the resumed render reports those of one render
    assert resumed_header["refrender:rays"] == full_header["refrender:rays"] == 4 * 16 * 32768


def test_sigterm_stops_a_render_within_one_batch_of_a_million_samples(tmp_path):
    # Issue 56.7: cancellation was checked between tiles only: a tile of 256
    # pixels of 2^20 samples each (the most a batch takes) is 2.5 minutes of
    # one core, one pixel's batch 0.57 s, most of it drawing the Sobol'
    # points, which the stop waits for. Checked between sample groups, the
    # stop and the final checkpoint take about that; 10 s bounds a stop on a
    # loaded machine, it is no speed claim (measured 0.1-2.1 s at load 13).
    ck = tmp_path / "ck.exr"
    (tmp_path / "disk.xml").write_text(DISK)
    heavy = [tmp_path / "disk.xml", "--res", "16x16", "--spp", 64, "--tspp", 16384, "--threads", 2,
             "--progress-every", 0.05]
    proc = subprocess.Popen([BIN, *map(str, heavy), "-o", str(tmp_path / "never.exr"), "--checkpoint", str(ck)],
                            stderr=subprocess.PIPE, text=True)
    try:
        while "% after" not in proc.stderr.readline():  # a progress line: the render is under way
            assert proc.poll() is None
        sent = time.monotonic()
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=10)
        stopped = time.monotonic() - sent
    finally:
        proc.kill()
    assert proc.returncode == 130 and "interrupted" in err, err
    assert ck.exists() and not (tmp_path / "never.exr").exists()
    print(f"stopped {stopped:.2f} s after SIGTERM")


def test_convergence_script_writes_csv_plot_and_slopes(tmp_path):
    env = dict(os.environ, REFRENDER=BIN)
    scene = tmp_path / "disk.xml"
    scene.write_text(DISK)
    proc = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / "convergence.py"), str(scene), "--res", "16x12",
                           "--counts", "25,100,400", "--baseline", "100", "--reference-count", "3200",
                           "--out", str(tmp_path / "conv")], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    import csv
    rows = list(csv.DictReader(open(tmp_path / "conv" / "convergence.csv")))
    assert len(rows) == 9 and {r["sampler"] for r in rows} == {"thesis", "jittered3d", "sobol"}
    assert (tmp_path / "conv" / "convergence.png").stat().st_size > 1000
    for sampler in ("thesis", "jittered3d", "sobol"):
        rmse = [float(r["rmse"]) for r in rows if r["sampler"] == sampler]
        assert rmse[-1] < rmse[0]  # more samples, less error
        assert any(line.startswith(sampler) for line in proc.stdout.splitlines())


def test_states_of_changed_model_or_animation_files_do_not_merge_or_resume(tmp_path):
    """The identity covers every input file's content, not only
    the scene file: a pass rendered after the PLY or .anim changed is refused."""
    (tmp_path / "m.ply").write_text("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n"
                                    "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                                    "property float radius\nend_header\n0 0 -10 0 0 1 1.2\n")
    anim = (ROOT / "scenes" / "animations" / "rolling.anim").read_text()
    (tmp_path / "a.anim").write_text(anim)
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="16" height="12"/>'
                     '<object><pointModel>m.ply</pointModel><material shading="unlit"/></object>'
                     '<object position="0 0 -12"><sphere radius="0.5"/><animation>a.anim</animation></object></scene>')
    args = [scene, "--spp", 1, "--tspp", 4, "--batches", 2, "--quiet"]

    def state(name, k):
        assert run([*args, "--pass", f"{k}/2", "-o", tmp_path / name]).returncode == 0
        return tmp_path / name
    p0 = state("p0.exr", 0)
    (tmp_path / "m.ply").write_text((tmp_path / "m.ply").read_text().replace("1.2", "1.3"))
    changed_model = state("p1.exr", 1)
    bad = run(["merge", p0, changed_model, "-o", tmp_path / "x.exr"])
    assert bad.returncode == 1 and "refrender:inputsHash" in bad.stderr, bad.stderr
    resumed = run([*args, "--pass", "0/2", "-o", tmp_path / "y.exr", "--resume", p0])
    assert resumed.returncode == 1 and "refrender:inputsHash" in resumed.stderr
    q0 = state("q0.exr", 0)
    (tmp_path / "a.anim").write_text(anim.replace("timeUnit film;", "timeUnit pal;"))
    changed_anim = state("q1.exr", 1)
    bad = run(["merge", q0, changed_anim, "-o", tmp_path / "x.exr"])
    assert bad.returncode == 1 and "refrender:inputsHash" in bad.stderr, bad.stderr
    assert not (tmp_path / "x.exr").exists() and not (tmp_path / "y.exr").exists()


def test_convergence_script_reports_progress_while_it_runs(tmp_path):
    """A render that takes longer than --progress-every is announced at that
    interval; every render ends with a line counting it and the time left.
    The renders are slowed by a wrapper (0.3 s each) so that the interval
    (0.05 s) is certainly crossed, however fast the machine."""
    slow = tmp_path / "slow-refrender"
    slow.write_text(f'#!/bin/sh\nsleep 0.3\nexec "{BIN}" "$@"\n')
    slow.chmod(0o755)
    scene = tmp_path / "disk.xml"
    scene.write_text(DISK)
    proc = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / "convergence.py"), str(scene), "--res", "8x6",
                           "--counts", "4,16", "--samplers", "thesis", "--baseline", "4", "--reference-count", "64",
                           "--progress-every", "0.05", "--out", str(tmp_path / "conv")],
                          capture_output=True, text=True, env=dict(os.environ, REFRENDER=str(slow)))
    assert proc.returncode == 0, proc.stderr
    lines = proc.stderr.splitlines()
    done = [line for line in lines if ": done" in line]
    assert [line.split("]")[0] for line in done] == ["convergence.py: [1/3", "convergence.py: [2/3",
                                                     "convergence.py: [3/3"]
    assert "reference" in done[0] and all("s left" in line for line in done)
    assert done[-1].endswith("about 0 s left")
    assert any("still rendering after" in line for line in lines)


def test_convergence_help_describes_every_option_and_writes_where_cost_error_reads():
    """Each option of convergence.py --help has a description, and its
    default output directory is the one scripts/README.md's cost_error.py
    example reads convergence.csv from."""
    import re
    import convergence
    parser = convergence.build_parser()
    undocumented = [a.option_strings or a.dest for a in parser._actions if not (a.help or "").strip()]
    assert not undocumented
    defaults = parser.parse_args(["scene.xml"])
    readme = (ROOT / "scripts" / "README.md").read_text()
    (curves,) = re.findall(r"--refrender-curves (\S+)", readme)
    assert os.path.join(defaults.out, "convergence.csv") == curves


def test_clamped_estimates_are_warned_of_under_quiet_and_recorded(tmp_path):
    """A batch estimate beyond +-2^20 is clamped (README, sums are exact):
    every one of a 3x2 image's 2 batches over a background of red 3e6 that
    the camera sees everywhere (a sphere far behind it) is, 12 in all. That
    is said on stderr also with --quiet (a warning is no progress output) and
    kept in the header as refrender:clampedEstimates, summed over merged
    passes (under --quiet it once left no trace)."""
    scene = tmp_path / "big.xml"
    scene.write_text('<scene><camera position="0 0 0" lookat="0 0 -1" up="0 1 0" width="3" height="2"/>'
                     '<background color="3e6 0 0"/><object position="0 0 10"><sphere radius="0.1"/></object></scene>')
    args = [scene, "--spp", 1, "--tspp", 1, "--batches", 2, "--quiet"]
    proc = run([*args, "-o", tmp_path / "one.exr"])
    assert proc.returncode == 0, proc.stderr
    assert "warning: 12 batch estimates exceeded" in proc.stderr, proc.stderr
    assert read_full(tmp_path / "one.exr")[1]["refrender:clampedEstimates"] == 12
    parts = [tmp_path / f"p{k}.exr" for k in range(2)]
    for k, part in enumerate(parts):
        assert run([*args, "--pass", f"{k}/2", "-o", part]).returncode == 0
        assert read_full(part)[1]["refrender:clampedEstimates"] == 6
    assert run(["merge", *parts, "-o", tmp_path / "m.exr", "--quiet"]).returncode == 0
    assert read_full(tmp_path / "m.exr")[1]["refrender:clampedEstimates"] == 12
