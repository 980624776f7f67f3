"""Shared helpers for the end-to-end tests: run build/refrender on a scene
given as XML text and read the EXR back with OpenImageIO."""
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
BIN = str(Path(os.environ.get("REFRENDER", ROOT / "build" / "refrender")).resolve())
# the tests import the scripts' modules (imagecompare, regress, flip): one
# place puts scripts/ on the path, as running a script there does for it
sys.path.insert(0, str(ROOT / "scripts"))
import imagecompare  # noqa: E402


def wait_for_handlers(proc, timeout=60):
    """Waits until the process catches SIGINT and SIGTERM (its SigCgt mask in /proc), so that a
    signal sent next is handled, however long start-up takes on a loaded machine (a fixed sleep
    was not always enough)."""
    import time
    wanted = (1 << (2 - 1)) | (1 << (15 - 1))  # SIGINT, SIGTERM
    deadline = time.time() + timeout
    while time.time() < deadline and proc.poll() is None:
        try:
            status = Path(f"/proc/{proc.pid}/status").read_text()
        except OSError:
            break
        caught = int(next(l for l in status.splitlines() if l.startswith("SigCgt:")).split()[1], 16)
        if caught & wanted == wanted:
            return
        time.sleep(0.01)
    assert proc.poll() is None, "the process ended before it installed its signal handlers"


def run(args, **kw):
    return subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, **kw)


def read_exr(path):
    """Returns (H x W x 4 float32 array in R, G, B, A order, header dict)."""
    channels, _, header = imagecompare.read_channels(path, unassociated_alpha=False)
    return np.stack([channels[c] for c in "RGBA"], axis=-1), header


def sharp_gaussian_render(tmp_path, camera, ply, attrs="", name="scene", background="0.1 0.2 0.3"):
    """The sharp image (--time 0, one sample at each pixel centre: --pixel-filter point) of one
    Gaussian model, given its <camera> element and the gaussianModel's extra attributes, over the
    background colour given (by default the Gaussian tests' 0.1 0.2 0.3)."""
    scene = tmp_path / f"{name}.xml"
    scene.write_text(f'<scene>{camera}<background color="{background}"/>'
                     f'<object name="g"><gaussianModel file="{ply}"{attrs}/></object></scene>')
    out = tmp_path / f"{name}.exr"
    proc = run([scene, "--pixel-filter", "point", "--time", 0, "--spp", 1, "--tspp", 1, "-o", out, "--quiet"])
    assert proc.returncode == 0, proc.stderr
    return read_exr(out)[0]


def render_bit_identical_across_threads_and_passes(tmp_path, common, threads):
    """Renders refrender's arguments `common` with each --threads in `threads` and as --pass 0/2 and
    1/2 merged; asserts all are bit-identical (nothing may depend on thread count or pass split) and
    returns the first image."""
    outs = []
    for n in threads:
        out = tmp_path / f"t{n}.exr"
        assert run([*common, "--threads", n, "-o", out]).returncode == 0
        outs.append(read_exr(out)[0])
    parts = []
    for k in range(2):
        part = tmp_path / f"p{k}.exr"
        assert run([*common, "--pass", f"{k}/2", "-o", part]).returncode == 0
        parts.append(part)
    merged = tmp_path / "merged.exr"
    proc = run(["merge", *parts, "-o", merged])
    assert proc.returncode == 0, proc.stderr
    outs.append(read_exr(merged)[0])
    for other in outs[1:]:
        assert np.array_equal(outs[0], other)
    return outs[0]


def read_full(path):
    """All channels by name (float32 arrays) and the header."""
    channels, _, header = imagecompare.read_channels(path, unassociated_alpha=False)
    return channels, header


@pytest.fixture
def render(tmp_path):
    """render(xml, *args) writes the scene, renders it and returns the image."""
    counter = [0]

    def _render(xml, *args, check=True):
        counter[0] += 1
        scene = tmp_path / f"scene{counter[0]}.xml"
        scene.write_text(xml)
        out = tmp_path / f"out{counter[0]}.exr"
        proc = run([scene, "-o", out, "--quiet", *args])
        if check:
            assert proc.returncode == 0, proc.stderr
            return read_exr(out)[0]
        return proc

    return _render


def coverage_centroid(alpha):
    """Raster position (x, y) of the centroid of a coverage image (pixel
    centers at +0.5): where a small disc's center is rendered."""
    a = np.asarray(alpha, dtype=np.float64)
    rows, cols = np.indices(a.shape)
    assert a.sum() > 0
    return (a * (cols + 0.5)).sum() / a.sum(), (a * (rows + 0.5)).sum() / a.sum()


def focal_pixels(height, fov_degrees):
    """Pixels per unit of image-plane distance at depth 1 (square pixels)."""
    return (height / 2) / np.tan(np.radians(fov_degrees) / 2)


def c_tests_by_file():
    """{tests/test_*.c file name: its TEST() names, read from the source} (the C harness's
    registry is checked against them: test_harness.py; make test runs them: test_unit_tests.py)."""
    import re
    return {p.name: re.findall(r"^TEST\((\w+)\)", p.read_text(), re.M) for p in sorted(ROOT.glob("tests/test_*.c"))}
