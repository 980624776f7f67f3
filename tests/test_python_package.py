"""`import refrender` from a Python environment of its own (issue 59 item 4):
the package (python/) installs with `pip install --no-build-isolation
--no-deps` into a fresh venv that sees numpy alone (a .pth naming a folder
that holds only numpy: no OpenImageIO, scipy or Debian's site-packages), and
there renders the same pixels, bit for bit, as the command line's EXR of the
same options, with the same header; a bad scene or option raises with the
line the command line prints; Ctrl-C stops a long render with
KeyboardInterrupt and no output. The expectations are the command line's
own outputs (its EXR read by OpenImageIO, its stderr), not the library's."""
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import imagecompare
from conftest import BIN, ROOT, run

LIB = Path(os.environ.get("REFRENDER_LIB", ROOT / "build" / "librefrender.so")).resolve()
SCENE = ROOT / "scenes" / "default.xml"  # procedural: no model files needed
# the attributes every EXR file has (OpenEXR's required header), not refrender's
EXR_REQUIRED = {"channels", "compression", "dataWindow", "displayWindow", "lineOrder", "pixelAspectRatio",
                "screenWindowCenter", "screenWindowWidth", "name", "type"}  # (OpenEXRCore writes name and type)
# describe the run, not the image: the command line differs, the time is measured
PER_RUN = {"refrender:command", "refrender:renderSeconds"}


def lib_env():
    """The library's environment; a sanitizer build's library needs its runtime first in the process."""
    env = dict(os.environ, REFRENDER_LIB=str(LIB))
    asan = [w for w in subprocess.run(["ldd", str(LIB)], capture_output=True, text=True).stdout.split()
            if "libasan.so" in w and w.startswith("/")]
    if asan:
        env.update(LD_PRELOAD=asan[0], ASAN_OPTIONS="detect_leaks=0")
    return env


def make_venv(base):
    """A fresh venv, numpy its only package, with refrender installed as the README says (pip: Debian's,
    run for the venv's python with --python; a venv's own pip bootstrap costs 15 s a test run)."""
    subprocess.run(["/usr/bin/python3", "-m", "venv", "--without-pip", str(base / "env")], check=True)
    python = base / "env" / "bin" / "python"
    only_numpy = base / "only_numpy"
    only_numpy.mkdir()
    import numpy
    (only_numpy / "numpy").symlink_to(Path(numpy.__file__).parent)
    site = subprocess.run([python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    Path(site, "only_numpy.pth").write_text(f"{only_numpy}\n")
    proc = subprocess.run(["/usr/bin/python3", "-m", "pip", "--python", python, "install", "--no-build-isolation",
                           "--no-deps", "--no-index", "--disable-pip-version-check", str(ROOT / "python")],
                          capture_output=True, text=True, env=lib_env(), cwd=base)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    isolated = subprocess.run([python, "-c", "import OpenImageIO"], capture_output=True)
    assert isolated.returncode != 0  # Debian's site-packages are not seen: numpy alone is
    return python


def in_venv(python, code, tmp_path, *args):
    """Runs code in the venv, from a directory without the clone's python/ (the installed package is used)."""
    env = lib_env()
    env.pop("REFRENDER_LIB")  # the wheel's own copy of the library
    return subprocess.run([python, "-c", code, *args], capture_output=True, text=True, cwd=tmp_path, env=env)


RENDER_TO_FILES = """
import json, numpy as np, refrender
r = refrender.render(%r, **%r)
np.savez('out.npz', rgba=r.rgba, stderr=r.stderr, variance=r.variance, samples=r.samples)
json.dump({k: (v.tolist() if hasattr(v, 'tolist') else v) for k, v in r.header.items()}, open('header.json', 'w'))
json.dump(r.window, open('window.json', 'w'))
print(refrender.library_path())
"""


def cli_flags(options):
    return [f"--{k.replace('_', '-')}={v}" for k, v in options.items()]


def check_render_is_the_cli_exr_bit_for_bit(venv, tmp_path, options):
    proc = in_venv(venv, RENDER_TO_FILES % (str(SCENE), {**options, "quiet": True}), tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert Path(proc.stdout.strip()).parent.name == "refrender" and "site-packages" in proc.stdout
    exr = tmp_path / "cli.exr"
    cli = run([SCENE, *cli_flags(options), "--quiet", "-o", exr])
    assert cli.returncode == 0, cli.stderr
    channels, spec, oiio_header = imagecompare.read_channels(exr, unassociated_alpha=False)
    arrays = np.load(tmp_path / "out.npz", allow_pickle=True)
    planes = {"": arrays["rgba"], "stderr.": arrays["stderr"], "variance.": arrays["variance"]}
    for prefix, stack in planes.items():
        if prefix + "R" not in channels:
            assert stack.ndim == 0 and stack.item() is None  # none without batches, as the EXR has none
            continue
        for i, c in enumerate("RGBA"):  # bit patterns: -0.0, NaN and every last bit count
            assert np.array_equal(stack[..., i].view(np.uint32), channels[prefix + c].view(np.uint32)), prefix + c
    assert np.array_equal(arrays["samples"].view(np.uint32), channels["samples"].view(np.uint32))
    window = json.loads((tmp_path / "window.json").read_text())
    assert (window["x0"], window["y0"], window["width"], window["height"]) == \
        (spec.x, spec.y, spec.width, spec.height)
    assert (window["full_width"], window["full_height"]) == (spec.full_width, spec.full_height)
    header = json.loads((tmp_path / "header.json").read_text())
    assert set(header) == imagecompare.exr_header_names(exr) - EXR_REQUIRED
    shared = (set(header) & set(oiio_header)) - PER_RUN
    assert len(shared) > 30, sorted(shared)
    for key in shared:
        assert np.array_equal(np.asarray(header[key], dtype=object if isinstance(header[key], str) else None)
                              .ravel(), np.asarray(oiio_header[key]).ravel()), key


BAD_SCENE = "<scene>\n  <camera width=\"8\" height=\"8\"/>\n  <nonsense/>\n</scene>\n"


def cli_message(args):
    """The command line's failure: its exit status and the text after 'refrender: ' on its last line."""
    proc = run(args)
    line = proc.stderr.strip().splitlines()[-1]
    assert line.startswith("refrender: "), proc.stderr
    return proc.returncode, line[len("refrender: "):]


def check_errors_raise_with_the_cli_message(venv, tmp_path):
    bad = tmp_path / "bad.xml"
    bad.write_text(BAD_SCENE)
    cases = [(str(bad), {}), (str(SCENE), {"spp": 0}), (str(SCENE), {"time": 0, "shutter": "0,1"}),
             (str(tmp_path / "missing.xml"), {})]
    code = """
import json, sys, refrender
for scene, opts in json.loads(sys.argv[1]):
    try:
        refrender.render(scene, **opts)
        print(json.dumps(None))
    except refrender.RenderError as e:
        print(json.dumps([e.status, str(e)]))
"""
    proc = in_venv(venv, code, tmp_path, json.dumps(cases))
    assert proc.returncode == 0, proc.stderr
    got = [json.loads(line) for line in proc.stdout.splitlines()]
    for (scene, opts), raised in zip(cases, got):
        assert raised == list(cli_message([scene, *cli_flags(opts), "-o", tmp_path / "x.exr"])), (scene, opts)
    assert "bad.xml:3:" in got[0][1] and "nonsense" in got[0][1]  # the file and line, as the CLI names them


def test_venv_install_renders_the_cli_exr_bit_for_bit_and_raises_its_messages(tmp_path):
    venv = make_venv(tmp_path)
    for i, options in enumerate([{"res": "24x16", "spp": 4, "tspp": 4, "batches": 3, "seed": 5},  # stderr too
                                 {"res": "20x12", "spp": 1, "tspp": 2, "crop_window": "0.25,0.75,0.1,0.6",
                                  "sampler": "jittered3d"}]):  # a data window inside the image
        work = tmp_path / f"render{i}"
        work.mkdir()
        check_render_is_the_cli_exr_bit_for_bit(venv, work, options)
    check_errors_raise_with_the_cli_message(venv, tmp_path)


def test_outputs_and_unknown_options_are_refused_in_process(tmp_path):
    """Run from the clone (python/ on the path, REFRENDER_LIB): what the command line writes to files
    is refused with a message saying so, an unknown option with one saying what is wrong."""
    code = f"""
import sys; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
for opts in ({{'output': 'x.exr'}}, {{'preview': 'x.png'}}, {{'pass': '0/2', 'batches': 2}}, {{'no_such_option': 1}}):
    try:
        refrender.render({str(SCENE)!r}, **opts)
        print('rendered')
    except refrender.RenderError as e:
        print(e.status, e)
"""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                          env=lib_env())
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert all(line.startswith("2 a library render returns one image in memory") for line in lines[:3]), lines
    assert lines[3].startswith("2 unrecognized option"), lines
    assert not list(tmp_path.iterdir())  # nothing written


def test_missing_library_says_what_to_do(tmp_path):
    code = f"""
import sys; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
try:
    refrender.render('scene.xml')
except refrender.LibraryMissing as e:
    print(e)
"""
    env = dict(os.environ, REFRENDER_LIB=str(tmp_path / "nowhere" / "librefrender.so"))
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert proc.returncode == 0, proc.stderr
    assert "nowhere/librefrender.so" in proc.stdout and "make python" in proc.stdout


LONG_RENDER = f"""
import sys, time; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
try:
    r = refrender.render({str(SCENE)!r}, res=(640, 360), spp=64, tspp=100, progress_every=0.1, threads=1)
    open('rendered.npy', 'wb').write(r.rgba.tobytes())
except KeyboardInterrupt:
    start = time.time()  # the next render waits for the interrupted one to end: it must have stopped
    refrender.render({str(SCENE)!r}, res=(8, 8), spp=1, tspp=1, quiet=True)
    print(f"next render after {{time.time() - start:.2f}} s", flush=True)
    raise
"""


def test_ctrl_c_stops_a_render_promptly_with_keyboard_interrupt(tmp_path):
    """SIGINT while the library renders (its progress lines show it is inside the render; about 40 minutes
    of work at one thread): KeyboardInterrupt is raised, the render stops (the next one, which must wait for
    it, runs at once), the process ends within seconds and nothing is written."""
    proc = subprocess.Popen([sys.executable, "-c", LONG_RENDER], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=tmp_path, env=lib_env())
    first = proc.stderr.readline()  # the first progress line: rendering has begun
    assert "refrender:" in first and "%" in first, first
    sent = time.time()
    proc.send_signal(signal.SIGINT)
    try:
        out, rest = proc.communicate(timeout=30)
    except subprocess.TimeoutExpired:
        proc.kill()
        pytest.fail("the render went on after SIGINT")
    assert time.time() - sent < 30
    assert "next render after" in out, out + rest
    assert "KeyboardInterrupt" in rest, rest
    assert proc.returncode != 0
    assert not (tmp_path / "rendered.npy").exists()


# A KeyboardInterrupt raised inside Thread.start once the render thread runs (where a Ctrl-C landed before
# render() took SIGINT for the render's time; planted here, since a signal's moment cannot be chosen)
INTERRUPTED_START = f"""
import sys, threading, time; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
real_start = threading.Thread.start
def start_then_interrupt(self):
    real_start(self)
    raise KeyboardInterrupt
threading.Thread.start = start_then_interrupt
try:
    refrender.render({str(SCENE)!r}, res=(640, 360), spp=64, tspp=100, threads=1, quiet=True)
except KeyboardInterrupt:
    threading.Thread.start = real_start
    alive = [t.name for t in threading.enumerate() if t.name == "refrender"]
    print(f"render threads alive: {{len(alive)}}", flush=True)
"""


def test_an_interrupt_inside_the_thread_start_stops_the_render(tmp_path):
    """The render stops before KeyboardInterrupt reaches the caller, wherever in render() it was raised:
    no render thread is left running (about 40 minutes of work at one thread) and the process ends."""
    proc = subprocess.run([sys.executable, "-c", INTERRUPTED_START], capture_output=True, text=True, cwd=tmp_path,
                          env=lib_env(), timeout=60)
    assert "render threads alive: 0" in proc.stdout, proc.stdout + proc.stderr


# A Ctrl-C after the C's last look at the interrupt flag (planted: SIGINT sent as the render call returns)
LATE_CTRL_C = f"""
import os, signal, sys; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
from refrender import _library
lib = _library.load()

class Late:
    def __getattr__(self, name):
        return getattr(lib, name)

    def refrender_render(self, *args):
        status = lib.refrender_render(*args)
        os.kill(os.getpid(), signal.SIGINT)
        return status

_library._lib = Late()
try:
    refrender.render({str(SCENE)!r}, res=(8, 8), spp=1, tspp=1, quiet=True)
    print("returned an image")
except KeyboardInterrupt:
    print("KeyboardInterrupt")
"""


def test_a_ctrl_c_as_the_render_ends_is_still_keyboard_interrupt():
    """A SIGINT that reaches the process after the render stopped watching its flag (while it returns)
    raises KeyboardInterrupt as Ctrl-C did before render() took SIGINT for the render's time; it is not
    swallowed with the image returned."""
    proc = subprocess.run([sys.executable, "-c", LATE_CTRL_C], capture_output=True, text=True, env=lib_env(),
                          timeout=60)
    assert proc.stdout.strip() == "KeyboardInterrupt", proc.stdout + proc.stderr


def test_compare_returns_the_rows_compare_py_writes(tmp_path):
    """refrender.compare is compare.py --json without the file: the same rows, value for value (two renders
    of other seeds, the whole image and a crop), and its file outputs are refused."""
    ref, test = tmp_path / "ref.exr", tmp_path / "test.exr"
    for path, seed in ((ref, 1), (test, 2)):
        proc = run([SCENE, "--res", "32x24", "--spp", 1, "--tspp", 4, "--batches", 2, "--seed", seed, "--quiet",
                    "-o", path])
        assert proc.returncode == 0, proc.stderr
    written = tmp_path / "rows.json"
    proc = subprocess.run(["/usr/bin/python3", str(ROOT / "scripts" / "compare.py"), ref, test, "--crop", "4,4,12,12",
                           "--json", written], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    code = f"""
import json, sys; sys.path.insert(0, {str(ROOT / 'python')!r})
import refrender
print(json.dumps(refrender.compare({str(ref)!r}, {str(test)!r}, crop=["4,4,12,12"])))
try:
    refrender.compare({str(ref)!r}, {str(test)!r}, json="x.json")
except refrender.CompareError as e:
    print(e)
"""
    got = subprocess.run(["/usr/bin/python3", "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert got.returncode == 0, got.stderr
    rows, refusal = got.stdout.splitlines()
    expected = json.loads(written.read_text())
    assert len(expected) == 2 and json.loads(rows) == expected
    assert "--json" in refusal and "compare.py's" in refusal and not (tmp_path / "x.json").exists()
