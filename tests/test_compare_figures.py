"""compare.py's figure-ready outputs: maps at native resolution
(one map pixel per image pixel, integer upscale by nearest neighbour) as PNG
and float EXR, one difference range shared by all methods, crop windows
outlined with zoomed insets, a stable CSV schema, and a LaTeX table with
the best value per column in bold."""
import csv

import numpy as np
import OpenImageIO as oiio

import figures
from test_compare import compare, write_image


def read(path):
    inp = oiio.ImageInput.open(str(path))
    assert inp, oiio.geterror()
    px = inp.read_image(oiio.FLOAT)
    inp.close()
    return px


def three_images(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((20, 30, 3), 0.5, np.float32))
    a = write_image(tmp_path / "a.exr", np.full((20, 30, 3), 0.6, np.float32))
    b = write_image(tmp_path / "b.exr", np.full((20, 30, 3), 0.7, np.float32))
    return ref, a, b


def test_native_maps_share_one_range_and_upscale_by_integers(tmp_path):
    ref, a, b = three_images(tmp_path)
    proc = compare(ref, a, b, "--maps", tmp_path / "m", "--map-scale", 3, "--label", "A", "--label", "B")
    assert proc.returncode == 0, proc.stderr
    png, exr = read(tmp_path / "m" / "A_full_diff.png"), read(tmp_path / "m" / "A_full_diff.exr")
    assert png.shape[:2] == (60, 90) and exr.shape[:2] == (20, 30)
    assert np.allclose(exr, 0.1, atol=1e-6)  # the float map is the difference itself
    # one range for both: B's 0.2 is the top of it, A's 0.1 three quarters up
    expect_a = figures.colorize(np.array([[0.1]]), "RdBu_r", -0.2, 0.2)[0, 0] / 255.0
    expect_b = figures.colorize(np.array([[0.2]]), "RdBu_r", -0.2, 0.2)[0, 0] / 255.0
    assert np.allclose(png[0, 0, :3], expect_a, atol=1 / 255)
    assert np.allclose(read(tmp_path / "m" / "B_full_diff.png")[0, 0, :3], expect_b, atol=1 / 255)
    fixed = compare(ref, a, "--maps", tmp_path / "f", "--diff-range", 0.4)
    assert fixed.returncode == 0
    expect = figures.colorize(np.array([[0.1]]), "RdBu_r", -0.4, 0.4)[0, 0] / 255.0
    assert np.allclose(read(tmp_path / "f" / "a_full_diff.png")[0, 0, :3], expect, atol=1 / 255)
    assert (tmp_path / "m" / "A_full_flip.exr").exists() and (tmp_path / "m" / "A_full_hdrflip.png").exists()


def test_a_non_finite_pixel_does_not_set_the_shared_range(tmp_path):
    """The shared range is over finite differences: an Inf pixel (which the
    metrics mask out) used to stretch it to the largest float, leaving every
    difference map mid-grey. Here the finite 0.1 is the top of the range."""
    ref = write_image(tmp_path / "ref.exr", np.full((20, 30, 3), 0.5, np.float32))
    pixels = np.full((20, 30, 3), 0.6, np.float32)
    pixels[5, 5] = np.inf
    a = write_image(tmp_path / "a.exr", pixels)
    assert compare(ref, a, "--maps", tmp_path / "m").returncode == 0
    top = figures.colorize(np.array([[0.1]]), "RdBu_r", -0.1, 0.1)[0, 0] / 255.0
    assert np.allclose(read(tmp_path / "m" / "a_full_diff.png")[0, 0, :3], top, atol=1 / 255)


def test_crops_are_outlined_and_zoomed(tmp_path):
    ref, a, _ = three_images(tmp_path)
    assert compare(ref, a, "--maps", tmp_path / "m", "--crop", "2,3,14,12", "--inset-scale", 2).returncode == 0
    full = read(tmp_path / "m" / "a_crops.png")
    assert full.shape[:2] == (20, 30)
    red = np.array([255, 64, 32]) / 255.0
    assert np.allclose(full[3, 2, :3], red, atol=1 / 255) and np.allclose(full[14, 15, :3], red, atol=1 / 255)
    assert not np.allclose(full[8, 8, :3], red, atol=0.05)  # inside the window: the image
    assert read(tmp_path / "m" / "a_2_3_14_12_inset.png").shape[:2] == (24, 28)


def test_csv_schema_is_stable_and_latex_bolds_the_best(tmp_path):
    ref, a, b = three_images(tmp_path)
    assert compare(ref, a, "--csv", tmp_path / "1.csv").returncode == 0
    assert compare(ref, a, b, "--crop", "0,0,12,12", "--csv", tmp_path / "2.csv").returncode == 0
    h1 = next(csv.reader(open(tmp_path / "1.csv")))
    h2 = next(csv.reader(open(tmp_path / "2.csv")))
    assert h1 == h2 and "notes" in h1 and ">3SE" in h1
    row = next(csv.DictReader(open(tmp_path / "1.csv")))
    assert row[">3SE"] == "" and row["frame"] == ""  # not applicable: empty, the column still there
    assert compare(ref, a, b, "--latex", tmp_path / "t.tex", "--label", "ours", "--label", "theirs").returncode == 0
    tex = (tmp_path / "t.tex").read_text()
    assert "\\toprule" in tex and "\\bottomrule" in tex
    ours = next(line for line in tex.splitlines() if line.startswith("ours"))
    theirs = next(line for line in tex.splitlines() if line.startswith("theirs"))
    assert "\\textbf{0.1}" in ours and "\\textbf" not in theirs.split("&")[4]  # RMSE: ours is best


def test_colorize_puts_infinities_at_the_ends_without_overflow():
    """+-inf and values beyond [lo, hi] take the range's end colours, NaN
    the colour of 0; with warnings as errors (before: the RuntimeWarning
    'overflow encountered in subtract' at the end of the suite, from +-inf
    turned into +-1.8e308 less a lo of the other sign)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = figures.colorize(np.array([[np.inf, -np.inf, np.nan, 5.0, -5.0]]), "RdBu_r", -0.2, 0.2)
    ends = figures.colorize(np.array([[0.2, -0.2, 0.0]]), "RdBu_r", -0.2, 0.2)
    assert (got[0, 0] == ends[0, 0]).all() and (got[0, 3] == ends[0, 0]).all()
    assert (got[0, 1] == ends[0, 1]).all() and (got[0, 4] == ends[0, 1]).all() and (got[0, 2] == ends[0, 2]).all()
