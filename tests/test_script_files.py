"""The Python tools' files (scripts/safefiles.py): compare.py, gallery.py and
nframe_average.py never write over one of their inputs, however the output
names it (the same path, ./x, a/../x, a symbolic link, a hard link: one file
by device and inode), and refuse it with one line and a non-zero exit before
anything is computed; an input that is a FIFO is refused by name instead of
blocking the tool for ever, and so is a FIFO named as an output; compare.py's --frames range is bounded by the
frames that exist (a range of 1e11 frames is refused by its first missing
frame, within a memory limit that a list of its numbers would exceed).

Full disk: a 64 KiB tmpfs mounted in the test's directory (as root; skipped
elsewhere) and filled to the last byte. Each output (--json, --csv, --latex,
--maps, --report of compare.py, --json of nframe_average.py) must then fail
with one line naming the file and the reason, leave the file it would have
replaced as it was, and leave no empty or partial file or temporary behind:
the tools write a temporary beside the output and rename it only once it
is complete, as refrender does (README, Guarantees)."""
import errno
import os
import resource
import stat
import subprocess
import sys

import numpy as np
import pytest

from conftest import BIN, ROOT, run
from test_compare import compare, write_image

COMPARE, GALLERY, NFRAME = (ROOT / "scripts" / name for name in ("compare.py", "gallery.py", "nframe_average.py"))


def tool(script, *args, timeout=120, **kw):
    return subprocess.run([sys.executable, str(script), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, **kw)


def one_line(stderr):
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in stderr, stderr
    return lines[0]


def images(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((16, 16, 3), 0.5, np.float32))
    test = write_image(tmp_path / "test.exr", np.full((16, 16, 3), 0.6, np.float32))
    return ref, test


def spellings(tmp_path, target):
    """Five names of the file `target` (in tmp_path, the working directory):
    its path, ./name, sub/../name, a symbolic link and a hard link."""
    name = target.name
    (tmp_path / "sub").mkdir(exist_ok=True)
    link, hard = tmp_path / f"sym_{name}", tmp_path / f"hard_{name}"
    if not link.exists():
        link.symlink_to(target)
        os.link(target, hard)
    return [str(target), f"./{name}", f"sub/../{name}", link.name, hard.name]


@pytest.mark.parametrize("option", ["--json", "--csv", "--latex"])
def test_compare_never_writes_over_an_input(tmp_path, monkeypatch, option):
    monkeypatch.chdir(tmp_path)
    ref, test = images(tmp_path)
    before = {p: p.read_bytes() for p in (ref, test)}
    for target in (ref, test):
        for name in spellings(tmp_path, target):
            proc = compare(ref, test, option, name)
            assert proc.returncode == 2, (option, name)
            line = one_line(proc.stderr)
            assert f"{option} {name}: is an input" in line and "refusing to overwrite" in line, line
            assert {p: p.read_bytes() for p in (ref, test)} == before, (option, name)
    assert compare(ref, test, option, tmp_path / "out.txt").returncode == 0  # any other name is written


def test_gallery_refuses_an_input_or_a_float_image_as_out(tmp_path):
    ref, test = images(tmp_path)
    before = ref.read_bytes()
    forgotten = tool(GALLERY, ref, test)  # OUT left out: the first image would be the sheet
    assert forgotten.returncode == 1 and "was OUT left out?" in one_line(forgotten.stderr)
    assert ref.read_bytes() == before
    png = tmp_path / "a.png"
    assert tool(GALLERY, png, ref).returncode == 0
    png_before = png.read_bytes()
    link = tmp_path / "link.png"
    link.symlink_to(png)
    again = tool(GALLERY, link, png, ref)  # a PNG input named as OUT through a link
    assert again.returncode == 1 and "is an input" in one_line(again.stderr)
    assert png.read_bytes() == png_before


def nframe_inputs(tmp_path):
    """A still scene and its reference (with standard errors)."""
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera width="12" height="8"/><background color="0.1 0.2 0.3"/>'
                     '<object><sphere radius="1"/></object></scene>')
    ref = tmp_path / "ref.exr"
    assert run([scene, "--batches", 2, "--spp", 1, "--tspp", 2, "--quiet", "-o", ref]).returncode == 0
    return scene, ref


def test_nframe_average_never_writes_over_the_scene_or_the_reference(tmp_path):
    scene, ref = nframe_inputs(tmp_path)
    before = {p: p.read_bytes() for p in (scene, ref)}
    for target in (scene, tmp_path / "sub" / ".." / "ref.exr"):
        (tmp_path / "sub").mkdir(exist_ok=True)
        proc = tool(NFRAME, scene, "--reference", ref, "--n", 1, "--out", tmp_path / "nf", "--json", target,
                    env={**os.environ, "REFRENDER": BIN})
        assert proc.returncode == 1 and "is an input" in one_line(proc.stderr), proc.stderr
    assert {p: p.read_bytes() for p in (scene, ref)} == before


def test_a_fifo_input_is_refused_by_name(tmp_path):
    ref, _ = images(tmp_path)
    fifo = tmp_path / "fifo.exr"
    os.mkfifo(fifo)
    for script, args in ((COMPARE, (ref, fifo)), (COMPARE, (fifo, ref)), (GALLERY, (tmp_path / "g.png", fifo))):
        proc = tool(script, *args, timeout=60)  # before: blocked for ever in open()
        assert proc.returncode != 0 and f"{fifo}: is a FIFO" in one_line(proc.stderr), (script, proc.stderr)
    # a FIFO as an output: refused, not opened (that blocked) nor replaced by a regular file
    proc = tool(COMPARE, ref, ref, "--json", fifo, timeout=60)
    assert proc.returncode == 2 and f"--json {fifo}: is a FIFO" in one_line(proc.stderr), proc.stderr
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)


def limited_memory():
    resource.setrlimit(resource.RLIMIT_AS, (2 << 30, 2 << 30))


def test_a_frame_range_is_bounded_by_the_frames_that_exist(tmp_path):
    for d in ("gt", "m"):
        (tmp_path / d).mkdir()
        for f in (24, 25, 26):
            write_image(tmp_path / d / f"img.{f:04d}.exr", np.full((12, 12, 3), 0.5, np.float32))
    for ref, test in ((tmp_path / "gt" / "img.%04d.exr", tmp_path / "m" / "img.%04d.exr"),
                      (tmp_path / "gt", tmp_path / "m")):
        proc = tool(COMPARE, ref, test, "--frames", "24-99999999999", preexec_fn=limited_memory, timeout=60)
        assert proc.returncode == 2 and "frame 27" in one_line(proc.stderr), proc.stderr
    ok = tool(COMPARE, tmp_path / "gt", tmp_path / "m", "--frames", "24-26")
    assert ok.returncode == 0, ok.stderr


@pytest.fixture
def full_disk(tmp_path):
    """A 64 KiB tmpfs, filled: every further byte written to it fails with ENOSPC."""
    mount = tmp_path / "full"
    mount.mkdir()
    if os.geteuid() != 0 or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)],
                                           capture_output=True).returncode != 0:
        pytest.skip("cannot mount a small tmpfs (needs root): the full-disk case is not tested here")
    try:
        (mount / "old.json").write_text("old\n")  # the outputs that a failed write must leave as they were
        (mount / "old.csv").write_text("old\n")
        (mount / "old.tex").write_text("old\n")
        with open(mount / "filler", "wb", buffering=0) as f:
            try:
                while True:
                    f.write(b"\0" * 512)
            except OSError as e:
                assert e.errno == errno.ENOSPC
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def left_on(mount):
    return sorted(str(p.relative_to(mount)) for p in mount.rglob("*") if p.is_file())


def test_compare_on_a_full_disk_fails_with_one_line_and_leaves_no_partial_file(tmp_path, full_disk):
    ref, test = images(tmp_path)
    files = left_on(full_disk)
    for option, name in (("--json", "old.json"), ("--csv", "old.csv"), ("--latex", "old.tex")):
        proc = compare(ref, test, option, full_disk / name)
        assert proc.returncode == 2, (option, proc.stderr)
        line = one_line(proc.stderr)
        assert str(full_disk / name) in line and "No space left on device" in line, line
        assert (full_disk / name).read_text() == "old\n" and left_on(full_disk) == files
    for option in ("--maps", "--report"):  # before: --maps exited 0 with four empty maps
        proc = compare(ref, test, option, full_disk / option[2:])
        assert proc.returncode == 2, (option, proc.stderr)
        assert str(full_disk / option[2:]) in one_line(proc.stderr)
        assert left_on(full_disk) == files, option


def test_nframe_average_json_on_a_full_disk_fails_with_one_line(tmp_path, full_disk):
    scene, ref = nframe_inputs(tmp_path)
    files = left_on(full_disk)
    proc = tool(NFRAME, scene, "--reference", ref, "--n", 1, "--out", tmp_path / "nf", "--json",
                full_disk / "old.json", env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 1
    line = one_line(proc.stderr.replace("nframe_average: frame 1/1 at t = 0.5\n", ""))
    assert str(full_disk / "old.json") in line and "No space left on device" in line, line
    assert (full_disk / "old.json").read_text() == "old\n" and left_on(full_disk) == files


COST_ERROR, SAMPLER_STUDY = (ROOT / "scripts" / name for name in ("cost_error.py", "sampler_study.py"))


def test_cost_error_never_writes_over_its_entries_file_or_an_entry_image(tmp_path):
    """`--out ce` beside `--entries ce/cost_error.csv`, or an entry image named
    ce/cost_error.png, are the tool's own outputs' names: refused before
    anything is measured, the inputs as they were (before: both replaced)."""
    ref, test = images(tmp_path)
    out = tmp_path / "ce"
    out.mkdir()
    entries = out / "cost_error.csv"
    entries.write_text(f"label,image,cost\nours,{test},1\n")
    png = write_image(out / "cost_error.png", np.full((16, 16, 3), 0.55, np.float32))
    before = {p: p.read_bytes() for p in (entries, png)}
    for args in (("--entries", entries), ("--entry", f"ours,{png},2")):
        proc = tool(COST_ERROR, ref, *args, "--out", out)
        assert proc.returncode == 2 and "is an input" in one_line(proc.stderr), proc.stderr
        assert {p: p.read_bytes() for p in (entries, png)} == before
    assert tool(COST_ERROR, ref, "--entries", entries, "--out", tmp_path / "other").returncode == 0


def test_a_fifo_csv_is_refused_by_name(tmp_path):
    """cost_error.py's --entries and --refrender-curves, sampler_study.py's
    table and time-to-error --from-csv (before: each blocked for ever)."""
    ref, test = images(tmp_path)
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    for script, args in ((COST_ERROR, (ref, "--entries", fifo)),
                         (COST_ERROR, (ref, "--entry", f"x,{test},1", "--refrender-curves", fifo)),
                         (SAMPLER_STUDY, ("table", fifo)), (SAMPLER_STUDY, ("time-to-error", "--from-csv", fifo))):
        proc = tool(script, *args, "--out", tmp_path / "o", timeout=60) if script == COST_ERROR else \
            tool(script, *args, timeout=60)
        assert proc.returncode != 0 and f"{fifo}: is a FIFO" in one_line(proc.stderr), (args, proc.stderr)
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
