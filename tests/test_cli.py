"""The command line as a user meets it: help, errors naming file and line,
atomic output, metadata, preview, generator, default scene, interruption."""
import os
import re
import signal
import subprocess
import time
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from conftest import BIN, ROOT, read_exr, run, wait_for_handlers

TINY = """<scene><camera width="24" height="16"/>
<object><sphere radius="1" color="0.5 0.6 0.7"/><material shading="unlit"/></object></scene>"""


def test_help_documents_every_option():
    proc = run(["--help"])
    assert proc.returncode == 0
    for opt in ["--spp", "--tspp", "-o", "--res", "--threads", "--seed", "--eps", "--sigma",
                "--time-factor", "--preview", "--quiet", "--version", "gen", "merge", "--sampler",
                "--batches", "--target-error", "--max-batches", "--pass", "--checkpoint",
                "--checkpoint-every", "--resume", "--no-static-reuse", "--frame ", "--frames", "surfels"]:
        assert opt in proc.stdout, opt
    gen = run(["gen", "--help"])
    assert gen.returncode == 0 and "--count" in gen.stdout


def test_version_and_usage_errors():
    assert run(["--version"]).stdout.startswith("refrender ")
    bad = run(["--spp", "lots"])
    assert bad.returncode == 2 and "--spp" in bad.stderr and "lots" in bad.stderr
    assert run(["--no-such-option"]).returncode == 2
    assert run(["a.xml", "b.xml"]).returncode == 2


def test_bad_scene_names_file_and_line_and_leaves_output_alone(tmp_path):
    scene = tmp_path / "bad.xml"
    scene.write_text("<scene>\n<camera width='64'/>\n<object>\n<sphere radius='oops'/>\n</object>\n</scene>\n")
    out = tmp_path / "out.exr"
    out.write_bytes(b"previous good image")
    proc = run([scene, "-o", out])
    assert proc.returncode == 1
    assert f"{scene}:4:" in proc.stderr and "radius" in proc.stderr
    assert out.read_bytes() == b"previous good image"
    assert list(tmp_path.iterdir()) == [scene, out] or set(tmp_path.iterdir()) == {scene, out}


def test_bad_point_model_error_names_the_ply(tmp_path):
    ply = tmp_path / "broken.ply"
    ply.write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                   "property float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
                   "property float radius\nend_header\n0 0 0 0 0 1 0.1\n")
    scene = tmp_path / "s.xml"
    scene.write_text("<scene><object>\n<pointModel>broken.ply</pointModel></object></scene>")
    proc = run([scene, "-o", tmp_path / "o.exr"])
    assert proc.returncode == 1
    assert "broken.ply" in proc.stderr and "truncated" in proc.stderr and "s.xml:2" in proc.stderr
    assert not (tmp_path / "o.exr").exists()


def test_unwritable_output_fails_before_rendering(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    proc = run([scene, "-o", tmp_path / "missing-dir" / "o.exr"])
    assert proc.returncode == 1 and "missing-dir" in proc.stderr


def test_metadata_records_the_settings(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    out = tmp_path / "o.exr"
    proc = run([scene, "-o", out, "--spp", 5, "--tspp", 3, "--seed", 99, "--eps", 0.25])
    assert proc.returncode == 0
    assert "rounded to a 2x2" in proc.stderr            # 5 -> nearest square 4
    assert "Mrays/s" in proc.stderr                      # summary line when not a terminal
    img, header = read_exr(out)
    assert img.shape == (16, 24, 4)
    assert header["refrender:spp"] == 4 and header["refrender:tspp"] == 3
    assert header["refrender:seed"] == "99" and float(header["refrender:epsilon"]) == 0.25
    assert header["refrender:sampler"] == "sobol" and header["refrender:weightFunction"] == "box"
    assert header["refrender:scene"] == str(scene) and header["refrender:shutter"] == "0 1"
    assert int(header["refrender:rays"]) == 24 * 16 * 4 * 3


def test_quiet_prints_nothing(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    proc = run([scene, "-o", tmp_path / "o.exr", "--quiet", "--spp", 3])
    assert proc.returncode == 0 and proc.stderr == ""


def test_preview_is_srgb_encoding_of_the_exr(tmp_path):
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    out, png = tmp_path / "o.exr", tmp_path / "p.png"
    assert run([scene, "-o", out, "--preview", png, "--quiet"]).returncode == 0
    img, _ = read_exr(out)
    inp = oiio.ImageInput.open(str(png))
    preview = inp.read_image(oiio.UINT8)
    inp.close()
    lin = np.clip(img[:, :, :3], 0, 1)
    srgb = np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * lin ** (1 / 2.4) - 0.055)
    assert preview.shape == (16, 24, 3)
    assert np.max(np.abs(preview.astype(float) - srgb * 255)) <= 0.5 + 1e-3


def test_gen_writes_a_model_that_renders(tmp_path):
    ply = tmp_path / "torus.ply"
    proc = run(["gen", "torus", "--count", 2000, "--radius", 1, "--minor-radius", 0.3, "--checker", 4, "-o", ply])
    assert proc.returncode == 0, proc.stderr
    assert ply.read_bytes().startswith(b"ply\nformat binary_little_endian 1.0")
    # it says what it wrote (before: nothing), the count the PLY's own header gives
    vertices = int(re.search(rb"element vertex (\d+)", ply.read_bytes()[:512]).group(1))
    assert proc.stderr == f"refrender gen: torus: {vertices} splats -> {ply}\n", proc.stderr
    quiet = run(["gen", "torus", "--count", 20, "-o", tmp_path / "q.ply", "--quiet"])
    assert quiet.returncode == 0 and quiet.stderr == ""
    scene = tmp_path / "s.xml"
    scene.write_text("<scene><camera position='0 0 4' width='32' height='32'/>"
                     "<object><pointModel file='torus.ply'/><material shading='unlit'/></object></scene>")
    out = tmp_path / "o.exr"
    assert run([scene, "-o", out, "--quiet", "--tspp", 1]).returncode == 0
    alpha = read_exr(out)[0][:, :, 3]
    assert alpha[16, 16] == 0.0 and alpha.max() == 1.0  # the hole of the torus, and its ring
    assert run(["gen", "cube", "-o", ply]).returncode == 1


def test_no_scene_renders_the_bundled_default(tmp_path):
    proc = subprocess.run([BIN, "--res", "24x24", "--spp", "1", "--tspp", "2", "-o", "x.exr", "--quiet"],
                          cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    _, header = read_exr(tmp_path / "x.exr")
    assert header["refrender:scene"].endswith("scenes/default.xml")


def test_interrupt_writes_nothing(tmp_path):
    out = tmp_path / "o.exr"
    proc = subprocess.Popen([BIN, ROOT / "scenes" / "default.xml", "--spp", "64", "--tspp", "400", "-o", out],
                            stderr=subprocess.PIPE, text=True)
    wait_for_handlers(proc)
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "interrupted" in err
    assert list(tmp_path.iterdir()) == []


def test_surfels_converts_meshes_and_point_clouds(tmp_path):
    obj = tmp_path / "quad.obj"
    obj.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n")
    out = tmp_path / "quad.ply"
    proc = run(["surfels", obj, "-o", out, "--overlap", 1])
    assert proc.returncode == 0, proc.stderr
    header = out.read_bytes().split(b"end_header")[0].decode()
    assert "element vertex 4" in header and "property float radius" in header
    xyz = tmp_path / "cloud.xyz"
    xyz.write_text("".join(f"{i % 4} {i // 4} 0 0 0 1\n" for i in range(16)))
    assert run(["surfels", xyz, "-o", tmp_path / "cloud.ply"]).returncode == 0
    bad = tmp_path / "bad.xyz"
    bad.write_text("0 0 0 0 0 1\n1 2 3\n")
    proc = run(["surfels", bad, "-o", tmp_path / "bad.ply"])
    assert proc.returncode == 1 and "bad.xyz:2" in proc.stderr
    assert not (tmp_path / "bad.ply").exists()
    proc = run(["surfels", tmp_path / "missing.obj", "-o", tmp_path / "m.ply"])
    assert proc.returncode == 1 and "missing.obj" in proc.stderr
    assert run(["surfels", "--help"]).returncode == 0


def test_sigterm_while_loading_a_large_model_exits_130(tmp_path):
    """Regression: the signal handlers were installed only after the BVH
    build, so SIGTERM while a large model loaded killed the process (exit
    143, -15 here) instead of the documented 130. The handlers now come
    first, the PLY reader polls the flag it is handed, and load and build
    stop with 130 and no output."""
    n = 600_000  # about 150 MB: a few seconds of reading and parsing
    names = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2", *[f"f_rest_{i}" for i in range(45)],
             "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]
    vals = np.zeros((n, len(names)), "<f4")
    vals[:, 0] = np.linspace(-1, 1, n)
    vals[:, -7:-4] = -3.0  # scales exp(-3)
    vals[:, -4] = 1.0  # identity rotation
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in names) + "end_header\n"
    (tmp_path / "big.ply").write_bytes(head.encode() + vals.tobytes())
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera position="0 0 5" lookat="0 0 0" width="4" height="4"/>'
                     '<object><gaussianModel file="big.ply"/></object></scene>')
    proc = subprocess.Popen([BIN, str(scene), "--spp", "1", "--tspp", "1", "-o", str(tmp_path / "o.exr")],
                            stderr=subprocess.PIPE, text=True)
    # start-up (shared libraries) can take longer than the load: signal once the model is open or
    # mapped (a model this large is read from a mapping, its descriptor closed at once)
    deadline, fds, maps = time.time() + 30, Path(f"/proc/{proc.pid}/fd"), Path(f"/proc/{proc.pid}/maps")
    while proc.poll() is None and time.time() < deadline:
        try:
            if "big.ply" in maps.read_text() or any(os.readlink(fd).endswith("big.ply") for fd in fds.iterdir()):
                break
        except OSError:  # an fd closed while listed
            pass
        time.sleep(0.001)
    assert proc.poll() is None, "the load ended before the signal: make the model larger"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, (proc.returncode, err)
    # the reader itself stopped (the flag it is handed through the scene loader, issue 57), not the
    # check after a load that ran to its end: the signal lands seconds before the read can end
    assert "interrupted while reading vertex" in err and not (tmp_path / "o.exr").exists(), err


def test_an_output_name_refrender_will_not_write_is_refused_before_rendering(tmp_path):
    """-o names the EXR refrender writes: an out.png used to exit 0 with an
    EXR under that name, which every viewer trusting the name fails to open.
    Refused before the scene is even read (a missing scene is not the error
    reported), naming the option and the extension, suggesting .exr and
    --preview; nothing is written. The same for merge's -o and for
    --checkpoint."""
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    for name in ["out.png", "out.PNG", "out.tif", "dir.exr/out.jpg"]:
        (tmp_path / "dir.exr").mkdir(exist_ok=True)
        proc = run([scene, "--spp", 1, "--tspp", 1, "-o", tmp_path / name])
        ext = name.rsplit(".", 1)[1]
        assert proc.returncode == 1, (name, proc.stderr)
        assert f"-o {tmp_path / name}: refrender writes OpenEXR only, not .{ext}" in proc.stderr
        stem = str(tmp_path / name)[:-len(ext) - 1]
        assert f"use -o {stem}.exr, and --preview {stem}.png" in proc.stderr
    proc = run([tmp_path / "missing.xml", "-o", tmp_path / "a.png"])
    assert proc.returncode == 1 and "OpenEXR only" in proc.stderr and "missing.xml" not in proc.stderr
    proc = run([scene, "--checkpoint", tmp_path / "c.png", "-o", tmp_path / "a.exr"])
    assert proc.returncode == 1 and "--checkpoint" in proc.stderr and ".png" in proc.stderr
    proc = run(["merge", tmp_path / "a.exr", "-o", tmp_path / "m.png"])
    assert proc.returncode == 1 and f"-o {tmp_path / 'm.png'}: refrender writes OpenEXR only" in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.exr", "s.xml"]
    assert not list((tmp_path / "dir.exr").iterdir())
    # what it does write: .exr in any case, or no extension at all
    for name in ["a.exr", "b.EXR", "c"]:
        assert run([scene, "--spp", 1, "--tspp", 1, "--quiet", "-o", tmp_path / name]).returncode == 0, name
        assert (tmp_path / name).read_bytes()[:4] == b"\x76\x2f\x31\x01"  # the OpenEXR magic number


def test_a_misspelt_option_gets_a_did_you_mean():
    """pbrt's --cropwindow and slips of the keyboard name the option meant
    (common.c's rr_nearest_name, the rule the scene file's names use); an
    option missing its value or an ambiguous abbreviation keeps getopt's own
    message, and a word near no option gets no guess."""
    for args, meant in [(["--cropwindow", "0,1,0,1"], "--crop-window"), (["--samplr", "sobol"], "--sampler"),
                        (["--previw=a.png"], "--preview"), (["gen", "sphere", "--cout", "5"], "--count"),
                        (["surfels", "m.obj", "--overlpa", "2"], "--overlap"), (["merge", "--ouptut", "x.exr"], "--output"),
                        (["export", "s.xml", "--tum-axis", "opencv"], "--tum-axes")]:
        proc = run(args)
        assert proc.returncode == 2 and f"did you mean '{meant}'?" in proc.stderr, (args, proc.stderr)
    for args in [["--spp"], ["--s", "1"], ["--no-such-option"]]:
        proc = run(args)
        assert proc.returncode == 2 and "did you mean" not in proc.stderr, (args, proc.stderr)


def test_the_bundled_animated_scene_renders_without_warnings(tmp_path):
    """scenes/animated.xml's rolling ball carries Maya's visibility curve,
    constant 1: it changes nothing refrender draws and is not warned about
    (a curve that hides the object is: tests/test_animfile.c)."""
    proc = run([ROOT / "scenes" / "animated.xml", "--res", "8x6", "--spp", 1, "--tspp", 1, "-o", tmp_path / "a.exr"])
    assert proc.returncode == 0 and "warning" not in proc.stderr, proc.stderr


def test_a_missing_suite_model_says_to_run_make_scenes(tmp_path):
    """A fresh clone that skipped `make scenes` is told to run it, by the
    scene that needs the model (a copy of a suite scene whose models are
    not made)."""
    (tmp_path / "scenes").mkdir()
    scene = tmp_path / "scenes" / "diagonal.xml"
    scene.write_text((ROOT / "scenes" / "diagonal.xml").read_text())
    proc = run([scene, "-o", tmp_path / "a.exr"])
    assert proc.returncode == 1
    assert "scenes/models/bunny.ply: cannot open" in proc.stderr and "run `make scenes`" in proc.stderr


def test_extensions_follow_one_rule_and_out_exr_png_suggests_out_exr(tmp_path):
    """-o's check and --preview's format read a name's extension by one rule
    (the base name's last dot, not a leading one: ".png" has none), where
    they once disagreed; and -o out.exr.png suggests -o out.exr and
    --preview out.png, not out.exr.exr."""
    scene = tmp_path / "s.xml"
    scene.write_text(TINY)
    proc = run([scene, "--spp", 1, "--tspp", 1, "-o", tmp_path / "out.exr.png"])
    assert proc.returncode == 1, proc.stderr
    stem = tmp_path / "out"
    assert f"use -o {stem}.exr, and --preview {stem}.png" in proc.stderr, proc.stderr
    proc = run([scene, "--spp", 1, "--tspp", 1, "-o", tmp_path / "a.exr", "--preview", tmp_path / ".png"])
    assert proc.returncode == 1 and "no image format for the extension ''" in proc.stderr, proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.xml"]


def test_refrender_bench_answers_help_and_refuses_what_it_does_not_know(tmp_path):
    """refrender-bench's arguments are positional ([OUT.csv [quick|full
    [SERIES]]]): --help prints its usage and exits 0, an unknown option, mode
    or series exits 2 naming it, and neither creates a file nor starts a
    benchmark (--help once became a CSV named "--help" and began the full
    run)."""
    bench = str(Path(BIN).parent / "refrender-bench")
    for args, status, said in [(["--help"], 0, "usage: refrender-bench"), (["-h"], 0, "usage: refrender-bench"),
                               (["out.csv", "--help"], 0, "usage: refrender-bench"),
                               (["--bogus"], 2, "unknown option '--bogus'"), (["out.csv", "fast"], 2, "quick|full"),
                               (["out.csv", "quick", "nosuch"], 2, "quick|full [SERIES]")]:
        proc = subprocess.run([bench, *args], capture_output=True, text=True, cwd=tmp_path, timeout=30)
        assert proc.returncode == status, (args, proc.stderr)
        assert said in (proc.stdout if status == 0 else proc.stderr), (args, proc.stdout, proc.stderr)
        assert list(tmp_path.iterdir()) == [], args


def test_a_subnormal_shutter_is_refused_with_its_line(tmp_path):
    """A shutter 1e-310 long (subnormal: fewer significant bits than a
    double) was rendered; it is refused as other bad shutters are, with the
    file and line, and on the command line too."""
    scene = tmp_path / "s.xml"
    scene.write_text('<scene>\n<camera width="8" height="8"/>\n<shutter open="0" close="1e-310"/>\n'
                     '<object><sphere radius="1"/></object></scene>')
    proc = run([scene, "-o", tmp_path / "o.exr", "--spp", 1, "--tspp", 2, "--quiet"])
    assert proc.returncode == 1 and f"{scene}:3: <shutter>: " in proc.stderr and "subnormal" in proc.stderr, proc.stderr
    assert not (tmp_path / "o.exr").exists()
    scene.write_text(TINY)
    proc = run([scene, "-o", tmp_path / "o.exr", "--shutter", "0,1e-310", "--quiet"])
    assert proc.returncode != 0 and "subnormal" in proc.stderr, proc.stderr
