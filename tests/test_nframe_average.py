"""scripts/nframe_average.py: the N-frame averages deblurring benchmarks
use, measured against refrender's time integral. Expectations from the
quadrature they are: a still scene's average is the reference for every N
(only the reference's noise differs); a Gaussian crossing the image is a
smooth integrand in time, whose midpoint-rule error falls as N^-2, so 4
times the frames must cut the error by more than 8 (a left-endpoint rule,
times k / N, falls only as N^-1: a ratio near 4); non-box a(t) and bad
inputs are refused by name.

The blur-synthesis procedures are checked against their sources'
formulas as written, on 8-bit frames the tests make: Deblur-NeRF's
scripts/synthe2poses.py and BlenderCV's scripts/images_avg.py byte for byte
(commits and lines in nframe_average.py's docstring), the sample-time rule of
each preset against the source's own expression, and truncation's darkening of
still regions from the float arithmetic that causes it."""
import dataclasses
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import gsply
import nframe_average as nf
from conftest import BIN, ROOT

SCRIPT = ROOT / "scripts" / "nframe_average.py"


def write_scene(tmp_path, velocity, weight="box"):
    ply = tmp_path / "g.ply"
    colour = np.array([0.9, 0.6, 0.2])
    gsply.write(ply, {"mean": np.zeros((1, 3)), "scale": np.array([[0.08, 0.05]]), "rot": np.array([[1.0, 0, 0, 0]]),
                      "opacity": np.array([0.8]), "sh": ((colour - 0.5) / 0.28209479177387814).reshape(1, 1, 3),
                      "degree": 0})
    scene = tmp_path / "s.xml"
    scene.write_text(f'<scene><camera position="0 0 0" lookat="0 0 1" up="0 1 0" fov="30" width="24" height="12"/>'
                     f'<shutter open="0" close="1" weight="{weight}"/><background color="0.1 0.2 0.3"/>'
                     f'<object name="g" position="-0.5 0 3"><gaussianModel file="{ply}"/>'
                     f'<animation><linear velocity="{velocity} 0 0"/></animation></object></scene>')
    return scene


def nframe(tmp_path, scene, counts, *extra, tspp=1024):
    """The script's float averages of the scene; its reference rendered at tspp times a pixel (a test
    the script refuses before it compares anything needs no converged reference)."""
    out = tmp_path / "rows.json"
    args = [scene, "--n", counts, "--out", tmp_path / "nf", "--json", out, "--", "--pixel-filter", "point",
            "--spp", 1, "--tspp", tspp, "--sampler", "sobol", *extra]
    proc = subprocess.run([sys.executable, str(SCRIPT), *map(str, args)],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    return proc, (json.loads(out.read_text())["rows"] if proc.returncode == 0 else None)


def test_a_still_scene_averages_to_the_reference_for_every_n(tmp_path):
    proc, rows = nframe(tmp_path, write_scene(tmp_path, 0.0), "1,3")
    assert proc.returncode == 0, proc.stderr
    for r in rows:
        assert r["RMSE*"] < 1e-6 and r["within 3 SE"] == 1.0, r
    assert "| 3 |" in proc.stdout  # the table


def test_the_midpoint_rule_error_falls_as_n_squared(tmp_path):
    """The reference at 256 Sobol' times a pixel in each of its 16 batches: its noise (RMS standard
    error, about 4e-6) is under a tenth of the 16-frame error (5e-5) and RMSE* takes it out, so the
    ratio measured (near 24) is that of 1024 times (a quarter of the work); a left-endpoint rule
    planted in nframe_average.frame_times gives near 4 and fails."""
    proc, rows = nframe(tmp_path, write_scene(tmp_path, 1.0), "4,16", tspp=256)
    assert proc.returncode == 0, proc.stderr
    e4, e16 = rows[0]["RMSE*"], rows[1]["RMSE*"]
    assert e4 > 1e-3  # the motion matters at 4 frames
    assert e4 / e16 > 8, (e4, e16)


def test_what_it_cannot_compare_is_refused_by_name(tmp_path):
    proc, _ = nframe(tmp_path, write_scene(tmp_path, 1.0, weight="linear"), "4", tspp=1)
    assert proc.returncode == 1 and "approximates a box a(t) only" in proc.stderr
    proc, _ = nframe(tmp_path, tmp_path / "missing.xml", "4")
    assert proc.returncode == 1 and "missing.xml: no such scene file" in proc.stderr
    sharp = tmp_path / "sharp.exr"
    assert subprocess.run([BIN, str(write_scene(tmp_path, 1.0)), "--time", "0.5", "-o", str(sharp), "--quiet"]).returncode == 0
    proc = subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "s.xml"), "--reference", str(sharp)],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 1 and "no standard errors" in proc.stderr


def _reference(tmp_path, scene, name, *args):
    ref = tmp_path / name
    proc = subprocess.run([BIN, str(scene), "--batches", "2", "--spp", "1", "--tspp", "8", "--quiet", "-o", str(ref),
                           *map(str, args)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return ref


def _against(tmp_path, scene, ref, *extra):
    return subprocess.run([sys.executable, str(SCRIPT), str(scene), "--n", "2", "--reference", str(ref), "--out",
                           str(tmp_path / "nf"), *map(str, extra)], capture_output=True, text=True,
                          env={**os.environ, "REFRENDER": BIN})


def _refused_after_parsing(monkeypatch, tmp_path, scene, ref, *extra):
    """The script's main on a reference (in this process: each Python start-up of the script cost more
    than its tiny renders): the message of the Failure it raises, which its __main__ prints as one
    line with exit status 1; any other exception (a traceback) fails the test."""
    monkeypatch.setenv("REFRENDER", BIN)
    with pytest.raises(nf.Failure) as refusal:
        nf.main([str(scene), "--n", "2", "--reference", str(ref), "--out", str(tmp_path / "nf"), *map(str, extra)])
    return str(refusal.value)


def test_a_reference_of_another_scene_size_or_crop_is_refused_by_name(tmp_path, monkeypatch):
    """A reference must be of the scene the frames are rendered from: another scene, -D
    parameters, a crop window or another --res once gave a plausible table or a traceback. The first case
    runs the whole command (exit status, stderr); the others call the script's main."""
    scene = write_scene(tmp_path, 1.0)
    other = tmp_path / "other"
    other.mkdir()
    other_ref = _reference(tmp_path, write_scene(other, 0.5), "other.exr")
    proc = _against(tmp_path, scene, other_ref)
    assert proc.returncode == 1 and "refrender:sceneHash" in proc.stderr and "another scene" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    with_param = _reference(tmp_path, scene, "param.exr", "-D", "unused=1")
    assert "refrender:parametersHash" in _refused_after_parsing(monkeypatch, tmp_path, scene, with_param)
    cropped = _reference(tmp_path, scene, "crop.exr", "--crop-window", "0,0.5,0,1")
    assert "crop window" in _refused_after_parsing(monkeypatch, tmp_path, scene, cropped)
    whole = _reference(tmp_path, scene, "whole.exr")
    assert "12x6" in _refused_after_parsing(monkeypatch, tmp_path, scene, whole, "--", "--res", "12x6")
    (tmp_path / "file").write_text("x")
    with pytest.raises(nf.Failure, match="not a directory"):
        nf.main([str(scene), "--out", str(tmp_path / "file")])


def _frames(n, seed=30):
    """n 8-bit frames, 24x32 RGB: random values below, two still bands (white 255, grey 200) on top."""
    rng = np.random.default_rng(seed)
    frames = [rng.integers(0, 256, (24, 32, 3), dtype=np.uint8) for _ in range(n)]
    for f in frames:
        f[:4], f[4:8] = 255, 200
    return frames


def test_deblur_nerf_byte_for_byte():
    """limacv/Deblur-NeRF scripts/synthe2poses.py:55-62 (aa9d6ce), its formula as written: /255,
    ** 2.2, weights ones * (1/N) summed over axis 0, ** (1/2.2), clip, * 255, astype(uint8)."""
    frames = _frames(10)
    imgs = np.array([f / 255 for f in frames])
    imgs = imgs ** 2.2
    weight = np.ones_like(imgs) * (1 / len(imgs))
    img = np.sum(imgs * weight, axis=0)
    img = img ** (1 / 2.2)
    expected = (np.clip(img, 0, 1) * 255).astype(np.uint8)
    p = nf.PRESETS["deblur-nerf"]
    assert p.n == 10 and len(frames) == p.n
    got = nf.synthesize(frames, p)
    assert got.dtype == np.uint8 and np.array_equal(got, expected)
    # the frames tell truncation from rounding and 2.2 from another gamma: a planted change fails
    assert (np.floor(np.clip(img, 0, 1) * 255 + 0.5) != expected).any()
    assert ((np.mean(imgs ** (2.0 / 2.2), axis=0) ** 0.5 * 255).astype(np.uint8) != expected).any()


def test_bad_gaussians_blendercv_byte_for_byte():
    """LingzheZhao/BlenderCV scripts/images_avg.py (9e0b92b) as written: :29 each PNG / 255.0, :32-33
    float32, :59 summed in frame order, :62 / blur_num, :12 (255 * clip).astype(uint8); :107 N = 31."""
    frames = _frames(31, seed=31)
    imgs = np.moveaxis(np.stack([f / 255.0 for f in frames], -1), -1, 0).astype(np.float32)
    imgs_ = 0
    for i in range(len(imgs)):
        imgs_ += imgs[i]
    img_blur = imgs_ / len(imgs)
    expected = (255 * np.clip(img_blur, 0, 1)).astype(np.uint8)
    p = nf.PRESETS["bad-gaussians"]
    assert p.n == 31 and p.space == "gamma1"
    got = nf.synthesize(frames, p)
    assert got.dtype == np.uint8 and np.array_equal(got, expected)
    # a float64 sum or a rounded result would differ: the test can tell
    assert ((255 * np.mean(np.array(frames) / 255.0, axis=0)).astype(np.uint8) != expected).any()
    assert (np.floor(255 * np.clip(img_blur, 0, 1) + 0.5).astype(np.uint8) != expected).any()


def test_truncation_darkens_still_regions():
    """A still region's frames are all equal, so its exact mean is its value. Seven weights 1/7
    sum to 1 - 2^-52 in float64 (Python's own sum says so), whose 1/2.2 power rounds to 1 - 2^-53,
    and 255 (1 - 2^-53) truncates to 254: Deblur-NeRF's formula makes white 254 at N = 7. Rounding
    instead gives every still value back (the float error is far below half a level), and
    truncation never brightens."""
    assert sum([1 / 7] * 7) == 1 - 2 ** -52
    white = [np.full((2, 2, 3), 255, np.uint8)] * 7
    assert (nf.synthesize(white, nf.parse_procedure("deblur-nerf:n=7")) == 254).all()
    assert (nf.synthesize(white, nf.parse_procedure("deblur-nerf:n=7,result=round")) == 255).all()
    still = np.arange(256, dtype=np.uint8).reshape(16, 16, 1)
    for spec in ("deblur-nerf", "bad-gaussians", "deblur-nerf:n=31", "bad-gaussians:n=10"):
        p = nf.parse_procedure(spec)
        out = nf.synthesize([still] * p.n, p).astype(int)
        assert (out <= still).all() and (out >= still.astype(int) - 1).all(), spec
        assert (out < still).sum() > 0, spec  # some still values lose a level
        rounded = nf.synthesize([still] * p.n, dataclasses.replace(p, result="round"))
        assert np.array_equal(rounded, still), spec
    # the 200 band of BAD-Gaussians' data (N = 31, float32 sums) comes out 199
    assert nf.synthesize([np.full((1, 1, 3), 200, np.uint8)] * 31, nf.PRESETS["bad-gaussians"])[0, 0, 0] == 199


def test_each_preset_samples_the_times_its_source_does():
    """Times over a shutter [0.2, 1.2], each from its source's own expression."""
    o, c = 0.2, 1.2
    t = nf.procedure_times(nf.PRESETS["deblur-nerf"], o, c)  # endpoints, N = 10 (assumed: see the docstring)
    assert np.allclose(t, [o + k / 9 for k in range(10)], rtol=0, atol=1e-15) and t[0] == o and t[-1] == c
    # BlenderCV generate_blur_trajectory_from_tum.py:38-44: start + i * T / (N - 1 + 1e-8), T = 1
    t = nf.procedure_times(nf.PRESETS["bad-gaussians"], o, c)
    assert len(t) == 31 and np.allclose(t, [(o + c) / 2 - 0.5 + i * 1.0 / (31 - 1 + 1e-8) for i in range(31)],
                                        rtol=0, atol=1e-8)
    # 3dgs-deblur's gsplat forward.cu:363: mid + (k / (n - 1) - 1/2) T_e, n = 10
    t = nf.procedure_times(nf.PRESETS["3dgs-deblur"], o, c)
    assert np.allclose(t, [0.7 + (k / 9 - 0.5) * 1.0 for k in range(10)], rtol=0, atol=1e-15)
    t = nf.procedure_times(nf.PRESETS["midpoint"], o, c)
    assert np.allclose(t, [o + (k + 0.5) / 10 for k in range(10)], rtol=0, atol=1e-15)
    r1, r2 = (nf.procedure_times(nf.parse_procedure(f"custom:times=random,n=16,seed={s}"), o, c) for s in (1, 2))
    assert r1 == nf.procedure_times(nf.parse_procedure("custom:times=random,n=16,seed=1"), o, c) and r1 != r2
    assert r1 == sorted(r1) and o <= r1[0] and r1[-1] < c and len(set(r1)) == 16


def test_3dgs_deblur_averages_gamma_2_2_floats():
    """splatfacto.py:880 clamp(max=1) ** (1/2.2) of forward.cu's 1/n-weighted sum of colours that are
    display ** 2.2 (splatfacto.py:222): float frames, float result, nothing quantized."""
    frames = [f / 255 for f in _frames(10)]
    expected = np.minimum(sum(f ** 2.2 / 10 for f in frames), 1) ** (1 / 2.2)
    got = nf.synthesize(frames, nf.PRESETS["3dgs-deblur"])
    assert got.dtype == np.float64 and np.allclose(got, expected, rtol=0, atol=1e-14)


def test_procedures_measure_a_still_scene_in_both_spaces(tmp_path):
    """A still scene: every frame is the reference (a still scene's reference has no noise), so the
    float midpoint procedure is exact; 8-bit frames are the truth rounded (within half a level) and
    their mean is that again up to float error, so a rounded result is within half a level, and a
    truncated one (Deblur-NeRF) the rounded value or one level below it: within [-1.5, +0.5] levels.
    Both comparison spaces are stated."""
    scene = write_scene(tmp_path, 0.0)
    ref = _reference(tmp_path, scene, "lin.exr", "--blur-space", "linear", "--pixel-filter", "point")
    out = tmp_path / "rows.json"
    proc = subprocess.run([sys.executable, str(SCRIPT), str(scene), "--reference", str(ref),
                           "--out", str(tmp_path / "nf"), "--procedure", "midpoint,deblur-nerf",
                           "--procedure", "bad-gaussians:result=round,n=4",
                           "--json", str(out), "--", "--spp", "1"],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 0, proc.stderr
    assert "comparison: display:" in proc.stdout and "linear:" in proc.stdout and "| deblur-nerf |" in proc.stdout
    result = json.loads(out.read_text())
    assert result["display"] == "srgb" and result["blur_space"] == "linear"
    rows = {r["procedure"]["name"]: r for r in result["rows"]}
    assert rows["midpoint"]["display"]["max"] < 1e-3 and rows["midpoint"]["linear"]["max"] < 1e-5
    assert rows["bad-gaussians:result=round,n=4"]["display"]["max"] <= 0.5 + 1e-3
    dn = rows["deblur-nerf"]["display"]
    assert -1.5 <= dn["bias"] <= 0.5 and dn["max"] <= 1.5 + 1e-3 and dn["RMSE*"] > 0


def test_bad_procedures_are_refused_by_name(tmp_path, capsys):
    """Each refused when the arguments are read (nf.parse, in this process: a Python start-up a case
    was most of this test's time); the whole command once, for its exit status and clean stderr."""
    scene = write_scene(tmp_path, 1.0)
    for args, message in ((["--procedure", "deblurnerf"], "unknown procedure 'deblurnerf'"),
                          (["--procedure", "deblur-nerf:gamma=2"], "'gamma=2' is not key=value"),
                          (["--procedure", "custom:space=model,frames=round"], "space=model averages"),
                          (["--procedure", "custom:times=endpoints,n=1"], "too few frames"),
                          (["--procedure", "deblur-nerf", "--n", "4"], "--n is for float averages"),
                          (["--procedure", "custom:seed=3"], "seed=3 has no meaning with times=midpoint"),
                          (["--procedure", "deblur-nerf:n=16,n=31"], "n is given twice")):
        assert message in _refused(capsys, scene, "--out", tmp_path / "nf", *args), args
    proc = subprocess.run([sys.executable, str(SCRIPT), str(scene), "--out", str(tmp_path / "nf"), "--procedure",
                           "deblurnerf"], capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
    assert proc.returncode == 2 and "unknown procedure 'deblurnerf'" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "nf").exists(), proc.stderr


def test_frames_round_half_up_as_blender():
    """Blender writes 8-bit PNGs with unit_float_to_uchar_clamp (blenlib math_base_inline.c), in
    float32: v <= 0 -> 0, v > 1 - 0.5/255 -> 255, else (uchar)(255 v + 0.5). Random values and the
    float32 values whose 255 v is an exact tie k + 1/2 (where half-to-even rounding would differ)."""
    rng = np.random.default_rng(7)
    ties = np.float32((np.arange(255) + 0.5) / 255)
    ties = ties[np.float32(255) * ties == np.arange(255) + np.float32(0.5)]
    assert len(ties) > 50
    v = np.concatenate([rng.random(200000, dtype=np.float32), ties, np.float32([0, 1, -0.1, 1.2, 1 - 0.5 / 255])])
    one, half = np.float32(1), np.float32(0.5)
    top = one - half / np.float32(255)
    blender = [0 if x <= 0 else 255 if x > top else int(np.float32(255) * x + half) for x in v]
    assert np.array_equal(nf.to_8bit(v, "round"), np.array(blender, np.uint8))


def _refused(capsys, *argv):
    """The script's argparse-style refusal of argv: exit 2 with one error line, its message."""
    with pytest.raises(SystemExit) as stop:
        nf.parse(list(map(str, argv)))
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert stop.value.code == 2 and len(errors) == 1, errors
    return errors[0]


def test_empty_names_negative_seeds_and_endless_runs_are_refused_by_name(tmp_path, capsys):
    """An empty --procedure ('' or ' , ') named nothing and ended in a traceback after rendering the
    reference; seed=-1 in numpy's traceback (its generators take seeds >= 0); n = 1e12 rendered
    frames until killed. Each is refused by value when the arguments are read, and an N is bounded
    by MAX_FRAMES (named in the message and in --help); N = MAX_FRAMES itself is accepted. The whole
    command once: exit 2, no traceback, nothing rendered or written."""
    scene = write_scene(tmp_path, 1.0)
    assert "--procedure '':" in _refused(capsys, scene, "--procedure", "")
    assert "--procedure ' , ':" in _refused(capsys, scene, "--procedure", " , ")
    assert "--procedure 'midpoint,,deblur-nerf':" in _refused(capsys, scene, "--procedure", "midpoint,,deblur-nerf")
    line = _refused(capsys, scene, "--procedure", "custom:times=random,seed=-1")
    assert "custom:times=random,seed=-1" in line and "seed must be an integer >= 0, not -1" in line
    bound = f"more than {nf.MAX_FRAMES} frames"
    line = _refused(capsys, scene, "--procedure", "custom:n=1000000000000")
    assert "n = 1000000000000" in line and bound in line
    line = _refused(capsys, scene, "--n", f"4,{nf.MAX_FRAMES + 1}")
    assert f"{nf.MAX_FRAMES + 1} is {bound}" in line
    for argv in (["--procedure", f"custom:n={nf.MAX_FRAMES}"], ["--n", str(nf.MAX_FRAMES)]):
        assert nf.parse([str(scene), *argv])[0].scene == str(scene)
    proc = subprocess.run([sys.executable, str(SCRIPT), str(scene), "--procedure", "", "--out", str(tmp_path / "nf")],
                          capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN}, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr and not (tmp_path / "nf").exists(), proc.stderr
    in_process = _refused(capsys, scene, "--procedure", "").split("error:")[1]
    assert [line.split("error:")[1] for line in proc.stderr.splitlines() if "error:" in line] == [in_process]
    helptext = subprocess.run([sys.executable, str(SCRIPT), "--help"], capture_output=True, text=True).stdout
    assert f"at most {nf.MAX_FRAMES}" in " ".join(helptext.split())


def _srgb(linear):
    """The sRGB curve (IEC 61966-2-1), written here apart from the script's."""
    x = np.clip(linear, 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def test_one_or_two_frames_still_see_the_motion(tmp_path):
    """A procedure of one frame reported 0 % moving pixels (one frame has no spread) and one of two
    frames 11 %, for a scene whose splat sweeps 15 % of the image. The truth here: the pixels whose
    sharp frames at 33 times k/32, spanning the shutter, differ by more than half a level (this
    test's own sRGB curve and spread). The script's times (0.5; 0.25 and 0.75; its probes at
    (k + 1/2)/16) are rendered here too, so it can only find fewer. It may miss only what the splat
    changes in the first or last 1/32 of the shutter, before or after every probe: it moves 7.5 px
    over the shutter (1 unit at depth 3, f = 6 / tan 15 deg = 22.4 px), so 0.23 px in 1/32, which
    brings at most one more column into reach at each end of a row: at most two pixels a row."""
    scene = write_scene(tmp_path, 1.0)
    ref = _reference(tmp_path, scene, "lin.exr", "--blur-space", "linear", "--pixel-filter", "point")
    found = {}
    for n in (1, 2):
        out = tmp_path / f"n{n}.json"
        proc = subprocess.run([sys.executable, str(SCRIPT), str(scene), "--reference", str(ref), "--out",
                               str(tmp_path / "nf"), "--procedure", f"midpoint:n={n}", "--json", str(out)],
                              capture_output=True, text=True, env={**os.environ, "REFRENDER": BIN})
        assert proc.returncode == 0, proc.stderr
        found[n] = json.loads(out.read_text())["moving_fraction"]
    times = sorted({k / 32 for k in range(33)} | {(k + 0.5) / 16 for k in range(16)} | {0.25, 0.5, 0.75})
    shown = []
    for t in times:
        frame = tmp_path / "sharp.exr"
        assert subprocess.run([BIN, str(scene), "--pixel-filter", "point", "--blur-space", "linear", "--time", repr(t),
                               "--tspp", "1", "--batches", "1", "--quiet", "-o", str(frame)]).returncode == 0
        shown.append(_srgb(nf.read_rgba(frame)[0][..., :3]))
    shown = np.array(shown)
    truth = ((shown.max(axis=0) - shown.min(axis=0)) > 0.5 / 255).any(axis=-1)
    rows_touched = int(truth.any(axis=1).sum())
    assert truth.mean() > 0.1 and rows_touched >= 1
    for n, fraction in found.items():
        pixels = round(fraction * truth.size)
        assert truth.sum() - 2 * rows_touched <= pixels <= truth.sum(), (n, pixels, int(truth.sum()), rows_touched)


def test_help_shows_the_refrender_pass_through():
    """The docs run `nframe_average.py SCENE -- --res 128x128 ...`; --help's
    usage and its own section say what follows -- (before: neither did)."""
    helptext = subprocess.run([sys.executable, str(SCRIPT), "--help"], capture_output=True, text=True).stdout
    usage = helptext.split("\n\n", 1)[0]
    assert usage.rstrip().endswith("scene [-- REFRENDER-ARGS ...]"), usage
    assert "REFRENDER-ARGS: refrender options for every render" in helptext
