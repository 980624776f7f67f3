"""scripts/compare.py: metrics on constructed images with hand-computed
values, FLIP's properties from the paper, colorspace handling, every bad
input, and the machine-readable and picture outputs."""
import contextlib
import csv
import io
import json
import subprocess
import types

import numpy as np
import OpenImageIO as oiio
import pytest

import flip
from conftest import BIN, ROOT
from imagecompare import basic_metrics, composite, read_image

import compare as compare_script  # noqa: E402 (scripts/, put on the path by conftest)

COMPARE = ROOT / "scripts" / "compare.py"


def write_image(path, pixels, channels=None, fmt=oiio.FLOAT):
    pixels = np.ascontiguousarray(pixels)
    spec = oiio.ImageSpec(pixels.shape[1], pixels.shape[0], pixels.shape[2], fmt)
    if channels:
        spec.channelnames = tuple(channels)
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), spec), oiio.geterror()
    assert out.write_image(pixels)
    out.close()
    return path


def compare_process(*args):
    """compare.py run as a command."""
    return subprocess.run(["/usr/bin/python3", str(COMPARE), *map(str, args)], capture_output=True, text=True)


def compare(*args):
    """compare.py's main in this process, with the exit status, stdout and stderr a run of the command
    gives (its __main__ is sys.exit(main())): a Python start-up importing numpy, OpenImageIO and
    matplotlib a call was most of these tests' time. compare_process runs the command itself
    (test_bad_inputs_give_clear_errors, test_crops_and_outputs); an exception main lets through (a
    traceback from the command) fails the test here."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            code = compare_script.main([str(a) for a in args])
        except SystemExit as stop:
            code = stop.code
    if isinstance(code, str):  # sys.exit(message): printed, status 1
        err.write(code + "\n")
        code = 1
    return types.SimpleNamespace(returncode=code or 0, stdout=out.getvalue(), stderr=err.getvalue())


def compare_json(*args):
    proc = compare(*args, "--json", "-")
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout[proc.stdout.index("\n[") + 1:])


def test_constant_offset_gives_hand_computed_metrics(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((32, 32, 3), 0.5, np.float32))
    test = write_image(tmp_path / "test.exr", np.full((32, 32, 3), 0.6, np.float32))
    row = compare_json(ref, test)[0]
    assert row["MAE"] == pytest.approx(0.1, abs=1e-6)
    assert row["MSE"] == pytest.approx(0.01, abs=1e-6)
    assert row["RMSE"] == pytest.approx(0.1, abs=1e-6)
    assert row["PSNR"] == pytest.approx(20.0, abs=1e-4)          # 10 log10(1 / 0.01)
    assert row["relMSE"] == pytest.approx(0.01 / (0.25 + 0.01), rel=1e-5)
    assert row["SSIM"] < 1.0


def test_identical_images_score_perfectly(tmp_path):
    img = np.random.default_rng(0).random((40, 48, 3)).astype(np.float32) * 3
    ref = write_image(tmp_path / "ref.exr", img)
    row = compare_json(ref, ref)[0]
    assert row["MSE"] == 0 and row["PSNR"] == "inf"
    assert row["SSIM"] == pytest.approx(1.0, abs=1e-9)
    assert row["FLIP"] == 0.0 and row["HDR-FLIP"] == 0.0


def test_flip_values_lie_in_unit_interval_and_grow_with_error():
    rng = np.random.default_rng(1)
    ref = rng.random((48, 48, 3))
    means = []
    for amplitude in (0.0, 0.02, 0.05, 0.1, 0.2, 0.4):
        test = ref + amplitude * rng.standard_normal(ref.shape)
        m = flip.ldr_flip(ref, test)
        assert m.min() >= 0.0 and m.max() <= 1.0
        means.append(m.mean())
    assert means[0] == 0.0
    assert all(a < b for a, b in zip(means, means[1:]))
    hdr = flip.hdr_flip(ref * 8, (ref + 0.3 * rng.standard_normal(ref.shape)) * 8)
    assert hdr.min() >= 0.0 and hdr.max() <= 1.0


def published_cmax():
    # CIELAB of the sRGB primaries (D65), as tabulated in colorimetry references:
    # green (87.73, -86.18, 83.18), blue (32.30, 79.19, -107.86). Hunt: a, b *= L/100.
    g = np.array([87.73, -86.18 * 0.8773, 83.18 * 0.8773])
    b = np.array([32.30, 79.19 * 0.3230, -107.86 * 0.3230])
    return (abs(g[0] - b[0]) + np.hypot(g[1] - b[1], g[2] - b[2])) ** 0.7


def test_flip_of_uniform_images_matches_the_paper_formula():
    # Uniform images have no features and are unchanged by the CSF filters,
    # so FLIP is the remapped color error: green vs blue is the maximal
    # error (exactly 1); black vs white has HyAB = 100 (L* 0 -> 100).
    green, blue = np.zeros((30, 30, 3)), np.zeros((30, 30, 3))
    green[..., 1] = blue[..., 2] = 1.0
    assert flip.ldr_flip(green, blue)[15, 15] == pytest.approx(1.0, abs=1e-3)
    cmax = published_cmax()
    delta = 100.0 ** 0.7
    expected = 0.95 + (delta - 0.4 * cmax) / (cmax - 0.4 * cmax) * 0.05
    black, white = np.zeros((30, 30, 3)), np.ones((30, 30, 3))
    assert flip.ldr_flip(black, white)[15, 15] == pytest.approx(expected, abs=1e-3)


def test_weighted_percentiles_weight_by_error():
    assert flip.weighted_percentile([0.0, 0.0, 0.0], 50) == 0.0
    # weights 0.1, 0.1, 0.8: half of the total weight lies in the 0.8 value
    assert flip.weighted_percentile([0.1, 0.1, 0.8], 50) == 0.8
    assert flip.weighted_percentile([0.2, 0.2, 0.2, 0.2], 95) == 0.2


def test_basic_metrics_respect_the_valid_mask():
    ref, test = np.zeros((4, 4, 3)), np.zeros((4, 4, 3))
    test[0, 0] = 1.0
    valid = np.ones((4, 4, 3), bool)
    valid[0, 0] = False
    assert basic_metrics(ref, test, valid)["MSE"] == 0.0


def test_srgb_png_of_a_linear_exr_compares_as_near_zero(tmp_path):
    ramp = np.linspace(0, 1, 64)
    lin = np.stack(np.meshgrid(ramp, ramp) + [np.full((64, 64), 0.3)], axis=-1)
    ref = write_image(tmp_path / "ref.exr", lin.astype(np.float32))
    png8 = np.round(flip.linear_to_srgb(lin) * 255).astype(np.uint8)
    png = write_image(tmp_path / "test.png", png8, fmt=oiio.UINT8)
    row = compare_json(ref, png)[0]  # auto: 8-bit PNG is sRGB
    assert row["RMSE"] < 0.004 and row["FLIP"] < 0.03  # 8-bit quantization only
    wrong = compare_json(ref, png, "--test-colorspace", "linear")[0]
    assert wrong["RMSE"] > 0.05 and wrong["FLIP"] > 0.1


def test_alpha_composite_and_exposure(tmp_path):
    black = write_image(tmp_path / "black.exr", np.zeros((16, 16, 3), np.float32))
    red = np.zeros((16, 16, 4), np.uint8)
    red[..., 0] = 255  # fully transparent red
    png = write_image(tmp_path / "red.png", red, fmt=oiio.UINT8)
    assert compare_json(black, png, "--alpha", "composite")[0]["MSE"] == 0.0
    assert compare_json(black, png)[0]["MSE"] > 0.3
    a = write_image(tmp_path / "a.exr", np.full((16, 16, 3), 0.1, np.float32))
    b = write_image(tmp_path / "b.exr", np.full((16, 16, 3), 0.2, np.float32))
    plain, bright = compare_json(a, b)[0], compare_json(a, b, "--exposure", 1)[0]
    assert bright["MSE"] == pytest.approx(4 * plain["MSE"], rel=1e-5)


def test_composite_swaps_refrender_background_for_the_new_one(tmp_path):
    """refrender's RGB already holds its background where coverage < 1:
    compositing over white must give white where nothing is covered and
    leave covered pixels alone (compositing the RGB again as premultiplied
    made an uncovered pixel background + white, e.g. 1.2 over white)."""
    scene = tmp_path / "s.xml"
    scene.write_text("""<scene><camera position="0 0 5" lookat="0 0 0" width="16" height="16" fov="30"/>
<background color="0.2 0.4 0.6"/><object><sphere radius="0.6" color="0.9 0.1 0.1"/>
<material shading="unlit"/></object></scene>""")
    out = tmp_path / "r.exr"
    proc = subprocess.run([BIN, str(scene), "-o", str(out), "--spp", "4", "--tspp", "1",
                           "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    img = read_image(out)
    assert img.header["refrender:background"] == "0.2 0.4 0.6"
    over_white = composite(img, [1, 1, 1])
    a = img.alpha
    assert (a == 0).any() and (a == 1).any() and ((a > 0) & (a < 1)).any()
    assert np.allclose(over_white[a == 0], 1.0, atol=1e-6)
    assert np.allclose(over_white[a == 1], img.rgb[a == 1], atol=1e-6)
    own = np.array([0.2, 0.4, 0.6])
    edge = (a > 0) & (a < 1)
    expected = img.rgb[edge] + (1 - own) * (1 - a[edge])[:, None]
    assert np.allclose(over_white[edge], expected, atol=1e-6)


def test_standard_error_channels_give_fraction_beyond_k_sigma(tmp_path):
    rgb = np.full((20, 20, 3), 0.5, np.float32)
    se = np.full((20, 20, 3), 0.01, np.float32)
    ref = write_image(tmp_path / "ref.exr", np.concatenate([rgb, np.ones((20, 20, 1), np.float32), se], -1),
                      ["R", "G", "B", "A", "stderr.R", "stderr.G", "stderr.B"])
    test_rgb = rgb.copy()
    test_rgb[:, :10] += 0.05  # 5 standard errors off on the left half
    test = write_image(tmp_path / "test.exr", test_rgb)
    assert compare_json(ref, test)[0][">3SE"] == pytest.approx(0.5)


def test_kse_counts_the_test_noise_and_floors_zero_errors(tmp_path):
    """A test 3.5 reference standard errors off is flagged at k = 3 on the
    reference's error alone, and not once the test's own equal error is
    counted (3.5 / sqrt(2) = 2.47), from its stderr channels or from two
    other seeds' difference; a reference with standard error exactly 0
    flags float-rounding differences only without the floor."""
    rgb = np.full((20, 20, 3), 0.5, np.float32)
    se = np.full((20, 20, 3), 0.01, np.float32)
    one = np.ones((20, 20, 1), np.float32)
    names = ["R", "G", "B", "A", "stderr.R", "stderr.G", "stderr.B"]
    ref = write_image(tmp_path / "ref.exr", np.concatenate([rgb, one, se], -1), names)
    off = rgb + 0.035
    plain = write_image(tmp_path / "plain.exr", off)
    with_se = write_image(tmp_path / "with_se.exr", np.concatenate([off, one, se], -1), names)
    seed_a = write_image(tmp_path / "a.exr", off + 0.005)
    seed_b = write_image(tmp_path / "b.exr", off - 0.005)  # |a - b| / sqrt(2) = 0.00707
    assert compare_json(ref, plain)[0][">3SE"] == 1.0
    row = compare_json(ref, with_se)[0]
    assert row[">3SE"] == 0.0 and "test stderr channels" in row["SE source"]
    # 0.035 / sqrt(0.01^2 + 0.00707^2) = 2.86 < 3
    assert compare_json(ref, plain, "--test-noise", f"{seed_a},{seed_b}")[0][">3SE"] == 0.0
    zero = write_image(tmp_path / "zero.exr", np.concatenate([rgb, one, np.zeros_like(se)], -1), names)
    rounding = write_image(tmp_path / "rounding.exr", rgb + np.float32(6e-8))
    assert compare_json(zero, rounding)[0][">3SE"] == 0.0
    assert compare_json(zero, rounding, "--se-floor", "0")[0][">3SE"] == 1.0


def test_crops_and_outputs(tmp_path):
    rng = np.random.default_rng(3)
    ref = write_image(tmp_path / "ref.exr", rng.random((40, 50, 3)).astype(np.float32))
    t1 = write_image(tmp_path / "t1.exr", rng.random((40, 50, 3)).astype(np.float32))
    t2 = write_image(tmp_path / "t2.exr", rng.random((40, 50, 3)).astype(np.float32))
    proc = compare_process(ref, t1, t2, "--crop", "0,0,20,20", "--crop", "10,5,30,30", "--csv", tmp_path / "r.csv",
                   "--heatmaps", tmp_path / "maps", "--report", tmp_path / "rep")
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[0] == "metrics space: linear (FLIP: linear)"
    assert proc.stdout.splitlines()[1].split()[:3] == ["image", "window", "pixels"]
    rows = list(csv.DictReader(open(tmp_path / "r.csv")))
    assert [(r["window"], r["pixels"]) for r in rows[:3]] == [("full", "2000"), ("0,0,20,20", "400"),
                                                                ("10,5,30,30", "900")]
    assert len(rows) == 6
    assert len(list((tmp_path / "maps").glob("*.png"))) == 18  # flip, diff, sheet per row
    page = (tmp_path / "rep" / "index.html").read_text()
    for name in ["t1_full_flip.png", "t2_10_5_30_30_sheet.png"]:
        assert name in page and (tmp_path / "rep" / name).exists()
    assert "<b>RMSE</b>" in page and "<b>FLIP</b>" in page  # every column has its legend
    assert "computed on linear values" in page


def test_bad_inputs_give_clear_errors(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.zeros((16, 16, 3), np.float32))
    small = write_image(tmp_path / "small.exr", np.zeros((8, 16, 3), np.float32))
    missing = compare_process(ref, tmp_path / "nope.exr")
    assert missing.returncode == 2 and "nope.exr: no such file" in missing.stderr
    size = compare(ref, small)
    assert size.returncode == 2 and "small.exr: size 16x8 differs" in size.stderr
    crop = compare(ref, ref, "--crop", "10,10,10,10")
    assert crop.returncode == 2 and "outside the 16x16 image" in crop.stderr
    assert compare(ref, ref, "--crop", "a,b").returncode == 2
    mask = compare(ref, ref, "--mask", small)
    assert mask.returncode == 2 and "small.exr" in mask.stderr
    garbage = tmp_path / "garbage.exr"
    garbage.write_text("not an image")
    bad = compare(ref, garbage)
    assert bad.returncode == 2 and "garbage.exr" in bad.stderr


def test_nonfinite_pixels_are_counted_not_averaged(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((16, 16, 3), 0.5, np.float32))
    bad = np.full((16, 16, 3), 0.5, np.float32)
    bad[3, 4, 1] = np.nan
    bad[7, 7, 0] = np.inf
    row = compare_json(ref, write_image(tmp_path / "bad.exr", bad))[0]
    assert row["nonfinite"] == 2 and row["pixels"] == 254 and row["MSE"] == 0.0
    all_nan = write_image(tmp_path / "nan.exr", np.full((16, 16, 3), np.nan, np.float32))
    proc = compare(ref, all_nan)
    assert proc.returncode == 2 and "no valid pixels" in proc.stderr
