"""Write faults. Every output (final EXR, render state, merge and its
preview, preview, frames, gen and surfels PLY, scene export, refrender
splat's EXR) either completes or leaves the previous
file untouched, and the exit status says which: the LD_PRELOAD shim
tests/faultinject.c makes the Nth write to a regular file (and every later
one: a disk that stays full) or the Nth rename fail, for every N until a run
meets no fault. A periodic checkpoint that fails is a warning: the render
goes on and the previous checkpoint stays. The same shim counts and fails
the render threads refrender starts: one pool for the whole render, and a
pthread_create that fails is an error or fewer threads, never a hang."""
import os
from pathlib import Path
import subprocess

import numpy as np
import pytest

from conftest import BIN, read_exr, run

SHIM = os.environ.get("FAULTINJECT", "")
pytestmark = pytest.mark.skipif(not os.path.exists(SHIM), reason="needs FAULTINJECT (make test builds it)")
SCENE = """<scene><frames rate="24"/><camera position="0 0 0" lookat="0 0 -1" up="0 1 0" fov="30" width="12" height="8"/>
<object><pointModel><splat center="-1 0 -10" normal="0 0 1" radius="1.2" color="1 0.5 0.25"/></pointModel>
<material shading="unlit"/><animation><linear velocity="2 0 0"/></animation></object></scene>"""
FAST = ["--spp", 1, "--tspp", 4, "--quiet"]
PREVIOUS = b"the previous good file"


def faulty_run(args, at, op, log, sticky=True):
    """Runs refrender under the shim; returns the process, whether a fault
    was injected, and the (writes, renames, threads started) it saw."""
    env = dict(os.environ, LD_PRELOAD=SHIM, RR_FAULT_OP=op, RR_FAULT_LOG=str(log),
               ASAN_OPTIONS="verify_asan_link_order=0")
    if at:
        env["RR_FAULT_AT"] = str(at)
    if sticky:
        env["RR_FAULT_STICKY"] = "1"
    if log.exists():
        log.unlink()
    proc = subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, env=env, timeout=120)
    lines = log.read_text().split("\n") if log.exists() else []
    calls = [tuple(map(int, line.split()[1:])) for line in lines if line.startswith("calls")]
    faulted = any(line.startswith(("write", "rename", "pthread_create")) for line in lines)
    return proc, faulted, calls[-1] if calls else (0, 0, 0)


def same_pixels(a, b):
    return np.array_equal(read_exr(a)[0], read_exr(b)[0], equal_nan=True)


def fault_points(total):
    """Every one of the first and last calls, and a spread in between."""
    points = set(range(1, min(total, 8) + 1)) | set(range(max(1, total - 3), total + 1))
    points |= {1 + (total - 1) * k // 12 for k in range(13)}
    return sorted(p for p in points if 1 <= p <= total)


def check_every_fault(tmp_path, args, outputs, complete, op, all_or_none=False):
    """Runs args with a fault at calls spread over all the run's writes (or
    renames); outputs are pre-filled with PREVIOUS, complete(path) says
    whether a file is the full result; all_or_none: a failed run leaves every
    output as it was. Returns how many runs met a fault."""
    log = tmp_path / "faults.log"
    for out in outputs:
        out.write_bytes(PREVIOUS)
    proc, _, calls = faulty_run(args, 0, op, log)
    assert proc.returncode == 0 and all(complete(out) for out in outputs), proc.stderr
    total = calls[1 if op == "rename" else 0]
    assert total >= len(outputs)
    for n in fault_points(total):
        for out in outputs:
            out.write_bytes(PREVIOUS)
        proc, faulted, _ = faulty_run(args, n, op, log)
        assert faulted, n
        for out in outputs:
            assert out.read_bytes() == PREVIOUS or complete(out), (n, out)
        leftovers = [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name]
        assert leftovers == [], (n, leftovers)
        assert proc.returncode == 1 and proc.stderr.strip(), (n, proc.returncode, proc.stderr)
        assert any(out.read_bytes() == PREVIOUS for out in outputs), (n, "a fault but every output written")
        if all_or_none:
            assert all(out.read_bytes() == PREVIOUS for out in outputs), (n, "a fault left some outputs new")
    return len(fault_points(total))


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "s.xml"
    path.write_text(SCENE)
    return path


@pytest.mark.parametrize("op", ["write", "rename"])
def test_final_image_and_preview(tmp_path, scene, op):
    good = tmp_path / "good"
    good.mkdir()
    assert run([scene, *FAST, "-o", good / "o.exr", "--preview", good / "p.png"]).returncode == 0
    out, preview = tmp_path / "o.exr", tmp_path / "p.png"

    def complete(path):
        return path.read_bytes() != PREVIOUS and (same_pixels(path, good / "o.exr") if path == out else
                                                  path.read_bytes() == (good / "p.png").read_bytes())
    # the image and its preview are one result: a fault in either, or in the second rename, left
    # a new image beside an old preview
    assert check_every_fault(tmp_path, [scene, *FAST, "-o", out, "--preview", preview], [out, preview], complete,
                             op, all_or_none=True) >= 2


@pytest.mark.parametrize("op", ["write", "rename"])
def test_splat_image_and_preview(tmp_path, scene, op):
    """refrender splat's EXR and preview: one result, all or none."""
    good = tmp_path / "good"
    good.mkdir()
    args = ["splat", "accum", scene, "--samples", 3, "--quiet"]
    assert run([*args, "-o", good / "o.exr", "--preview", good / "p.png"]).returncode == 0
    out, preview = tmp_path / "o.exr", tmp_path / "p.png"

    def complete(path):
        return path.read_bytes() != PREVIOUS and (same_pixels(path, good / "o.exr") if path == out else
                                                  path.read_bytes() == (good / "p.png").read_bytes())
    assert check_every_fault(tmp_path, [*args, "-o", out, "--preview", preview], [out, preview], complete, op,
                             all_or_none=True) >= 2


@pytest.mark.parametrize("op", ["write", "rename"])
def test_merge_image_and_preview(tmp_path, scene, op):
    """refrender merge --preview: the merged EXR and its preview are one
    result, all or none, as a render's (the preview is the one a single
    render of all batches writes)."""
    good = tmp_path / "good"
    good.mkdir()
    states = [good / "p0.exr", good / "p1.exr"]
    for k, st in enumerate(states):
        assert run([scene, *FAST, "--batches", 2, "--pass", f"{k}/2", "-o", st]).returncode == 0
    assert run([scene, *FAST, "--batches", 2, "-o", good / "o.exr", "--preview", good / "p.png"]).returncode == 0
    out, preview = tmp_path / "o.exr", tmp_path / "p.png"

    def complete(path):
        return path.read_bytes() != PREVIOUS and (same_pixels(path, good / "o.exr") if path == out else
                                                  path.read_bytes() == (good / "p.png").read_bytes())
    assert check_every_fault(tmp_path, ["merge", *states, "-o", out, "--preview", preview, "--quiet"], [out, preview],
                             complete, op, all_or_none=True) >= 2


@pytest.mark.parametrize("op", ["write", "rename"])
def test_states_merge_and_frames(tmp_path, scene, op):
    good = tmp_path / "good"
    good.mkdir()
    states = [good / "p0.exr", good / "p1.exr"]
    for k, st in enumerate(states):
        assert run([scene, *FAST, "--batches", 2, "--pass", f"{k}/2", "-o", st]).returncode == 0
    assert run(["merge", *states, "-o", good / "m.exr", "--quiet"]).returncode == 0
    assert run([scene, *FAST, "--frames", "0-2", "-o", good / "f%d.exr"]).returncode == 0

    state = tmp_path / "p0.exr"
    check_every_fault(tmp_path, [scene, *FAST, "--batches", 2, "--pass", "0/2", "-o", state], [state],
                      lambda p: p.read_bytes() != PREVIOUS and same_pixels(p, states[0]), op)
    merged = tmp_path / "m.exr"
    check_every_fault(tmp_path, ["merge", *states, "-o", merged, "--quiet"], [merged],
                      lambda p: p.read_bytes() != PREVIOUS and same_pixels(p, good / "m.exr"), op)
    frames = [tmp_path / f"f{i}.exr" for i in range(3)]
    check_every_fault(tmp_path, [scene, *FAST, "--frames", "0-2", "-o", tmp_path / "f%d.exr"], frames,
                      lambda p: p.read_bytes() != PREVIOUS and same_pixels(p, good / p.name), op)


@pytest.mark.parametrize("op", ["write", "rename"])
def test_gen_and_surfels_models(tmp_path, op):
    good = tmp_path / "good"
    good.mkdir()
    xyz = good / "cloud.xyz"
    xyz.write_text("".join(f"{i % 4} {i // 4} 0 0 0 1\n" for i in range(16)))
    assert run(["gen", "torus", "--count", 300, "-o", good / "g.ply"]).returncode == 0
    assert run(["surfels", xyz, "-o", good / "c.ply"]).returncode == 0
    for name, args in (("g.ply", ["gen", "torus", "--count", 300]), ("c.ply", ["surfels", xyz])):
        out = tmp_path / name
        check_every_fault(tmp_path, [*args, "-o", out], [out],
                          lambda p: p.read_bytes() == (good / p.name).read_bytes(), op)


def test_failed_periodic_checkpoint_keeps_the_previous_and_the_render_goes_on(tmp_path, scene):
    ck, out, log = tmp_path / "ck.exr", tmp_path / "o.exr", tmp_path / "faults.log"
    ck.write_bytes(PREVIOUS)
    args = [scene, "--spp", 4, "--tspp", 64, "--batches", 40, "--res", "48x32", "--threads", 1,
            "-o", out, "--checkpoint", ck, "--checkpoint-every", "0.01"]
    proc, faulted, _ = faulty_run(args, 1, "write", log, sticky=False)  # the first checkpoint's first write
    assert faulted and proc.returncode == 0, proc.stderr
    assert "checkpoint not written, the previous one is kept" in proc.stderr
    assert out.exists()
    assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name] == []


@pytest.mark.parametrize("op", ["write", "rename"])
def test_scene_export(tmp_path, scene, op):
    good = tmp_path / "good"
    good.mkdir()
    assert run(["export", scene, "--frames", "0-2", "-o", good / "s.json"]).returncode == 0
    out = tmp_path / "s.json"

    def complete(path):
        return path.read_bytes() == (good / "s.json").read_bytes()
    assert check_every_fault(tmp_path, ["export", scene, "--frames", "0-2", "-o", out], [out], complete, op) >= 1


# a write fault is sticky (a disk that stays full): the shim's one failing fwrite does not set the
# stream's error flag, as a real one does, so alone it could go unseen
@pytest.mark.parametrize("op,sticky", [("write", True), ("rename", False), ("rename", True)])
def test_scene_export_writes_its_three_outputs_or_none(tmp_path, scene, op, sticky):
    """export -o, --tum and --transforms are one result: after a write or a rename fails at any point,
    either every output is complete or every one holds its previous bytes. The JSON was put in place
    before the TUM file was written, so a fault in the TUM's writes, or in the second rename, left a new
    JSON beside an old TUM file. A rename failing after others succeeded puts their previous files back,
    also when every later rename fails too (sticky)."""
    good = tmp_path / "good"
    good.mkdir()
    names = ["s.json", "s.tum", "t.json"]

    def export_args(folder):
        return ["export", scene, "--frames", "0-2", "-o", folder / names[0], "--tum", folder / names[1],
                "--transforms", folder / names[2]]
    assert run(export_args(good)).returncode == 0
    outputs = [tmp_path / name for name in names]
    log = tmp_path / "faults.log"
    proc, _, calls = faulty_run(export_args(tmp_path), 0, op, log)
    total = calls[1 if op == "rename" else 0]
    assert proc.returncode == 0 and total >= 3, proc.stderr
    for n in fault_points(total):
        for out in outputs:
            out.write_bytes(PREVIOUS)
        proc, faulted, _ = faulty_run(export_args(tmp_path), n, op, log, sticky)
        assert faulted and proc.returncode == 1 and proc.stderr.strip(), (n, proc.returncode, proc.stderr)
        states = ["previous" if out.read_bytes() == PREVIOUS else
                  "complete" if out.read_bytes() == (good / out.name).read_bytes() else "other" for out in outputs]
        assert states == ["previous"] * 3, (n, states)  # a fault in any of them: none is put in place
        assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name] == [], n
        for out in outputs:  # and where there was no file, none is left
            out.unlink()
        proc, faulted, _ = faulty_run(export_args(tmp_path), n, op, log, sticky)
        assert faulted and proc.returncode == 1 and not any(out.exists() for out in outputs), n
        assert [p.name for p in tmp_path.iterdir() if ".tmp-" in p.name] == [], n


@pytest.mark.parametrize("output", [[], ["--batches", 2, "--pass", "0/2"]])
def test_a_gaussian_render_short_of_memory_fails_and_full_kbuffers_only_warn(tmp_path, output):
    # Every sample meets 70 coplanar splats (more than the k-buffer's 64
    # within epsilon) in front of a Gaussian plane. The k-buffer keeps the
    # nearest 64 and warns (the farthest, behind 64 opaque splats, change
    # nothing). With every realloc of the render's worker threads failing,
    # and every chunk of their arenas (where the Gaussian integrator's rays,
    # candidates and hits' heap grow), a sample's Gaussians find no memory:
    # drawn without them a pixel can be off by its whole colour (issue 56.1:
    # a ball of 407 pixels came out as background, exit 0, and its short
    # --pass merged). The render fails, naming a pixel, and writes nothing:
    # neither the image nor a render state.
    if b"__asan_init" in Path(BIN).read_bytes():
        pytest.skip("under AddressSanitizer realloc is ASan's own allocator, which the shim cannot fail")
    ply = tmp_path / "g.ply"
    assert run(["gen", "plane", "--count", 100, "--gaussians", "3dgs", "-o", ply]).returncode == 0
    splats = '<splat center="0 0 -10" normal="0 0 1" radius="30"/>' * 70
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" up="0 1 0" fov="30" width="4" height="3"/>'
                     f'<object><pointModel>{splats}</pointModel></object>'
                     f'<object><gaussianModel file="{ply}"/></object></scene>')
    out = tmp_path / "o.exr"
    args = [BIN, *map(str, [scene, "--spp", 1, "--tspp", 2, "--quiet", *output, "-o", out])]
    clean = subprocess.run(args, capture_output=True, text=True, timeout=120)
    samples = 4 * 3 * 1 * 2
    assert clean.returncode == 0, clean.stderr
    assert f"warning: {samples} samples had more than 64 hits within epsilon" in clean.stderr, clean.stderr
    out.unlink()
    env = dict(os.environ, LD_PRELOAD=SHIM, RR_FAULT_OP="memory-in-threads", ASAN_OPTIONS="verify_asan_link_order=0")
    proc = subprocess.run(args, capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 1, proc.stderr
    assert "sampled Gaussians at pixel (" in proc.stderr and "out of memory for a sample's Gaussians" in proc.stderr
    assert list(tmp_path.glob("o.exr*")) == [], proc.stderr


@pytest.mark.parametrize("rounds", [["--batches", 6], ["--batches", 2, "--target-error", 1e-9, "--max-batches", 6]])
def test_render_threads_are_started_once_per_render_not_per_round(tmp_path, rounds):
    # A render of B rounds (batches, or --target-error's extra ones up to
    # its cap) with --threads 2 starts 2 threads: a pool that works every
    # round. Threads made each round were 2 per round (12 here).
    (tmp_path / "s.xml").write_text(SCENE)
    log = tmp_path / "log"
    args = [tmp_path / "s.xml", *FAST, "--threads", 2, *rounds, "-o", tmp_path / "o.exr"]
    proc, _, calls = faulty_run(args, 0, "pthread_create", log)
    assert proc.returncode == 0, proc.stderr
    assert calls[2] == 2, calls


def test_a_render_thread_that_cannot_start_is_an_error_or_one_thread_fewer(tmp_path):
    # The first thread failing to start leaves none: a one-line error and
    # exit 1, at once (no wait for workers that do not exist). The second
    # failing leaves one: the render goes on with it, and a seed's image is
    # the same for any thread count (README's --seed).
    (tmp_path / "s.xml").write_text(SCENE)
    log = tmp_path / "log"
    args = [tmp_path / "s.xml", *FAST, "--threads", 3, "--batches", 3]
    proc = run([*args, "-o", tmp_path / "good.exr"])
    assert proc.returncode == 0, proc.stderr
    proc, faulted, _ = faulty_run([*args, "-o", tmp_path / "none.exr"], 1, "pthread_create", log)
    assert faulted and proc.returncode == 1, proc.stderr
    assert proc.stderr.strip() == "refrender: could not start render threads", proc.stderr
    assert not (tmp_path / "none.exr").exists()
    proc, faulted, calls = faulty_run([*args, "-o", tmp_path / "one.exr"], 2, "pthread_create", log)
    assert faulted and proc.returncode == 0 and calls[2] == 2, (proc.stderr, calls)  # one started, one failed
    assert same_pixels(tmp_path / "one.exr", tmp_path / "good.exr")
