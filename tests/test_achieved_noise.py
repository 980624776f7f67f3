"""Achieved noise, said (issue 55.4): what a render with standard errors
reached is in its header and summary line, and those figures are the ones
the EXR's own stderr.* and samples channels give when recomputed here (each
pixel's largest RGB standard error: mean, nearest-rank 99th percentile,
max; the batches a pixel holds = samples / (spp tspp)); --target-error takes
8-bit levels; a merge of passes and a resumed render write what a single
render writes; no sobol note for the mission's --spp 4 --tspp 100."""
import math
import re
import signal
import subprocess

import numpy as np

from conftest import BIN, ROOT, read_full, run, wait_for_handlers
from test_batches import DISK

NOISE_ATTRS = ["refrender:batchesMin", "refrender:batchesMax", "refrender:stderrMean", "refrender:stderrP99",
               "refrender:stderrMax", "refrender:stderrReached"]


def disk_scene(tmp_path):
    scene = tmp_path / "disk.xml"
    scene.write_text(DISK)
    return scene


def figures(ch):
    """(mean, nearest-rank 99th percentile, max) of each pixel's largest RGB standard error."""
    se = np.maximum.reduce([ch["stderr.R"], ch["stderr.G"], ch["stderr.B"]]).astype(np.float64).ravel()
    return se.mean(), np.sort(se)[math.ceil(0.99 * se.size) - 1], se.max()


def test_target_error_render_says_the_noise_it_reached(tmp_path):
    out = tmp_path / "t.exr"
    proc = run([disk_scene(tmp_path), "-o", out, "--spp", 1, "--tspp", 4, "--batches", 2, "--target-error", "5lv",
                "--max-batches", 12])
    assert proc.returncode == 0, proc.stderr
    ch, header = read_full(out)
    mean, p99, most = figures(ch)
    assert 0 < mean < p99 < most  # a noisy image: the three figures differ
    for key, value in zip(["Mean", "P99", "Max"], [mean, p99, most]):
        assert math.isclose(header[f"refrender:stderr{key}"], value, rel_tol=1e-6), (key, header, value)
    batches = ch["samples"] / 4
    assert header["refrender:batchesMin"] == batches.min() == 2
    assert header["refrender:batchesMax"] == batches.max() and 2 < batches.max() <= 12
    assert math.isclose(header["refrender:targetError"], 5 / 255, rel_tol=1e-15)
    # the summary line: the same three figures in 8-bit levels and in value units, and the batch range
    said = re.search(r"standard error reached .*: mean (\S+), 99th percentile (\S+), max (\S+) 8-bit levels "
                     r"\((\S+), (\S+), (\S+)\); (\d+) to (\d+) batches a pixel", proc.stderr)
    assert said, proc.stderr
    levels, units = [float(said[i]) for i in (1, 2, 3)], [float(said[i].rstrip(",")) for i in (4, 5, 6)]
    for level, unit, value in zip(levels, units, [mean, p99, most]):
        assert math.isclose(level, 255 * value, rel_tol=5e-3) and math.isclose(unit, value, rel_tol=5e-3)  # 3 digits
    assert (int(said[7]), int(said[8])) == (batches.min(), batches.max())
    assert "reached standard error <= 5 8-bit levels" in proc.stderr
    assert header["refrender:stderrReached"].startswith(said[0].split(": ", 1)[1].split(";")[0])


def test_levels_and_value_units_give_the_same_render(tmp_path):
    scene = disk_scene(tmp_path)
    common = [scene, "--spp", 1, "--tspp", 4, "--batches", 2, "--max-batches", 8, "--quiet"]
    assert run([*common, "--target-error", "2.55lv", "-o", tmp_path / "lv.exr"]).returncode == 0
    assert run([*common, "--target-error", "0.01", "-o", tmp_path / "v.exr"]).returncode == 0
    a, ha = read_full(tmp_path / "lv.exr")
    b, hb = read_full(tmp_path / "v.exr")
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert math.isclose(ha["refrender:targetError"], hb["refrender:targetError"], rel_tol=1e-15)
    for bad in ["0.5lvl", "lv", "-1lv", "0lv", "0.5 lv"]:
        proc = run([*common, "--target-error", bad, "-o", tmp_path / "x.exr"])
        assert proc.returncode == 2 and "8-bit levels (0.5lv)" in proc.stderr, (bad, proc.stderr)


def test_every_render_with_error_bars_says_its_noise_and_one_batch_none(tmp_path):
    scene = disk_scene(tmp_path)
    proc = run([scene, "--spp", 1, "--tspp", 4, "--batches", 3, "-o", tmp_path / "b3.exr"])
    assert proc.returncode == 0 and "standard error reached" in proc.stderr, proc.stderr
    ch, header = read_full(tmp_path / "b3.exr")
    assert header["refrender:batchesMin"] == header["refrender:batchesMax"] == 3
    assert math.isclose(header["refrender:stderrMax"], figures(ch)[2], rel_tol=1e-6)
    proc = run([scene, "--spp", 1, "--tspp", 4, "-o", tmp_path / "b1.exr"])
    assert proc.returncode == 0 and "standard error reached" not in proc.stderr, proc.stderr
    assert not set(NOISE_ATTRS) & set(read_full(tmp_path / "b1.exr")[1])


# large enough that a progress line comes out before the end (one every 0.2 s at most)
COMMON = ["--res", "64x48", "--spp", 4, "--tspp", 16, "--batches", 4, "--seed", 3, "--threads", 1]


def test_merged_passes_and_a_resumed_render_write_the_single_renders_noise(tmp_path):
    scene = ROOT / "scenes" / "default.xml"
    assert run([scene, *COMMON, "-o", tmp_path / "single.exr"]).returncode == 0
    single = read_full(tmp_path / "single.exr")[1]
    assert set(NOISE_ATTRS) <= set(single)
    for k in range(2):
        assert run([scene, *COMMON, "--pass", f"{k}/2", "-o", tmp_path / f"p{k}.exr"]).returncode == 0
    proc = run(["merge", tmp_path / "p0.exr", tmp_path / "p1.exr", "-o", tmp_path / "merged.exr"])
    assert proc.returncode == 0, proc.stderr
    merged = read_full(tmp_path / "merged.exr")[1]
    # interrupted once its first progress line is out, the state written on the signal, then resumed
    ck = tmp_path / "ck.exr"
    p = subprocess.Popen([BIN, *map(str, [scene, *COMMON, "-o", tmp_path / "never.exr", "--checkpoint", ck,
                                          "--checkpoint-every", 0, "--progress-every", 1e-3])],
                         stderr=subprocess.PIPE, text=True)
    for line in p.stderr:
        if "%" in line:
            p.send_signal(signal.SIGINT)
            break
    p.communicate(timeout=60)
    if p.returncode != 0:  # 0: a machine fast enough to finish before its first progress line
        assert p.returncode == 130 and ck.exists()
        proc = run([scene, *COMMON, "-o", tmp_path / "resumed.exr", "--resume", ck])
        assert proc.returncode == 0 and "resuming" in proc.stderr, proc.stderr
        resumed = read_full(tmp_path / "resumed.exr")[1]
        assert all(resumed[k] == single[k] for k in NOISE_ATTRS), resumed
    assert all(merged[k] == single[k] for k in NOISE_ATTRS), (merged, single)


def test_the_missions_command_prints_no_sobol_note(tmp_path):
    # README's first command, --spp 4 --tspp 100 (400 samples, no power of two), once said
    # "note: sobol works best with a power-of-two spp*tspp"; any count is first-class now
    proc = run(["--spp", 4, "--tspp", 100, "--res", "8x8", "-o", tmp_path / "m.exr"])
    assert proc.returncode == 0 and "note" not in proc.stderr, proc.stderr
