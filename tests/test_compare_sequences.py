"""compare.py on frame sequences, with labels, in sRGB metric space (issue
15): frames pair by number (patterns or directories) and a frame that names
another frame in its header is refused; the summary's mean and worst frame
are the per-frame values' mean and maximum; labels name rows and pictures
so two inputs with the same file name never overwrite each other."""
import os

import numpy as np
import pytest

import flip
from conftest import run
from test_compare import compare, compare_json, write_image


def offset_sequence(directory, offsets, pattern="img.%04d.exr", size=(12, 12)):
    os.makedirs(directory, exist_ok=True)
    for frame, off in offsets.items():
        write_image(directory / (pattern % frame), np.full((*size, 3), 0.5 + off, np.float32))


def test_patterns_pair_by_frame_and_summarize(tmp_path):
    offset_sequence(tmp_path / "gt", {0: 0, 1: 0, 2: 0})
    offset_sequence(tmp_path / "m", {0: 0.1, 1: 0.2, 2: 0.3})
    rows = compare_json(tmp_path / "gt" / "img.%04d.exr", tmp_path / "m" / "img.%04d.exr", "--frames", "0-2",
                        "--label", "method")
    per_frame = {r["frame"]: r for r in rows if isinstance(r["frame"], int)}
    assert sorted(per_frame) == [0, 1, 2]
    for f, off in [(0, 0.1), (1, 0.2), (2, 0.3)]:
        assert per_frame[f]["RMSE"] == pytest.approx(off, rel=1e-5) and per_frame[f]["image"] == "method"
    mean = next(r for r in rows if r["frame"] == "mean")
    worst = next(r for r in rows if str(r["frame"]).startswith("worst"))
    assert mean["RMSE"] == pytest.approx(0.2, rel=1e-5) and worst["frame"] == "worst (2)"
    # directories pair the same way
    rows2 = compare_json(tmp_path / "gt", tmp_path / "m", "--label", "method")
    assert [r["RMSE"] for r in rows2] == pytest.approx([r["RMSE"] for r in rows])


def test_missing_and_mislabelled_frames_are_refused(tmp_path):
    offset_sequence(tmp_path / "gt", {0: 0, 1: 0})
    offset_sequence(tmp_path / "m", {0: 0.1})
    missing = compare(tmp_path / "gt", tmp_path / "m")
    assert missing.returncode == 2 and "no image for frame 1" in missing.stderr
    scene = tmp_path / "s.xml"
    scene.write_text('<scene><camera width="8" height="8"/><frames rate="24"/>'
                     '<object><sphere radius="1"/></object></scene>')
    os.makedirs(tmp_path / "r")
    for f in (3, 4):
        assert run([scene, "--frame", f, "-o", tmp_path / "r" / f"r.{f}.exr", "--spp", 1, "--tspp", 1,
                    "--quiet"]).returncode == 0
    os.rename(tmp_path / "r" / "r.4.exr", tmp_path / "r" / "r.5.exr")  # frame 4's image named as frame 5
    os.rename(tmp_path / "r" / "r.3.exr", tmp_path / "r" / "r.4.exr")
    bad = compare(tmp_path / "r" / "r.%d.exr", tmp_path / "r" / "r.%d.exr", "--frames", "4-5")
    assert bad.returncode == 2 and "header says frame 3" in bad.stderr


def test_same_file_names_get_distinct_labels_and_pictures(tmp_path):
    ref = write_image(tmp_path / "ref.exr", np.full((16, 16, 3), 0.5, np.float32))
    os.makedirs(tmp_path / "a"), os.makedirs(tmp_path / "b")
    a = write_image(tmp_path / "a" / "out.exr", np.full((16, 16, 3), 0.6, np.float32))
    b = write_image(tmp_path / "b" / "out.exr", np.full((16, 16, 3), 0.7, np.float32))
    rows = compare_json(ref, a, b, "--heatmaps", tmp_path / "maps")
    assert rows[0]["image"] != rows[1]["image"]
    assert len(list((tmp_path / "maps").glob("*.png"))) == 6  # flip, diff, sheet each: none overwritten
    named = compare_json(ref, a, b, "--label", "ours", "--label", "theirs", "--heatmaps", tmp_path / "named")
    assert [r["image"] for r in named] == ["ours", "theirs"]
    assert (tmp_path / "named" / "ours_full_flip.png").exists() and (tmp_path / "named" / "theirs_full_sheet.png").exists()
    same = compare(ref, a, b, "--label", "x", "--label", "x")
    assert same.returncode == 2 and "same label" in same.stderr


def test_srgb_metrics_space_and_separate_ssim_peak(tmp_path):
    ref_v, test_v = 0.2, 0.25
    ref = write_image(tmp_path / "r.exr", np.full((16, 16, 3), ref_v, np.float32))
    test = write_image(tmp_path / "t.exr", np.full((16, 16, 3), test_v, np.float32))
    lin = compare_json(ref, test)[0]
    srgb = compare_json(ref, test, "--metrics-space", "srgb")[0]
    assert lin["MAE"] == pytest.approx(0.05, rel=1e-5)
    assert srgb["MAE"] == pytest.approx(float(flip.linear_to_srgb(test_v) - flip.linear_to_srgb(ref_v)), rel=1e-5)
    assert srgb["FLIP"] == lin["FLIP"]  # FLIP takes linear input either way
    peak = compare_json(ref, test, "--psnr-peak", 2)[0]
    assert peak["SSIM"] == lin["SSIM"] and peak["PSNR"] == pytest.approx(lin["PSNR"] + 20 * np.log10(2), rel=1e-6)
