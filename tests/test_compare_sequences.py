"""compare.py on frame sequences, with labels, in sRGB metric space:
frames pair by number (patterns or directories) and a frame that names
another frame in its header is refused; the summary's mean and worst frame
are the per-frame values' mean and maximum; labels name rows and pictures
so two inputs with the same file name never overwrite each other. The
LaTeX table of a sequence has a frame column, labelled mean and worst rows,
and a bold best per frame and window (RMSEs from the closed form of offsets
inside and outside a crop window), or only the summary rows."""
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


# The LaTeX table of a sequence. Each method's frame has offset A inside the
# crop window (0,0,12,12) and B outside it, on a 16x16 image of 0.5: the
# window's RMSE is A, the full image's sqrt((144 A^2 + 112 B^2) / 256).
LATEX_OFFSETS = {"ours": {0: (0.1, 0.5), 1: (0.4, 0.4), 2: (0.2, 0.2)},
                 "theirs": {0: (0.2, 0.2), 1: (0.3, 0.3), 2: (0.25, 0.25)}}
CROP = "0,0,12,12"


def window_sequence(directory, offsets):
    os.makedirs(directory, exist_ok=True)
    for frame, (inside, outside) in offsets.items():
        img = np.full((16, 16, 3), 0.5 + outside, np.float32)
        img[:12, :12] = 0.5 + inside
        write_image(directory / f"img.{frame:04d}.exr", img)


def latex_sequence(tmp_path, *extra):
    offset_sequence(tmp_path / "gt", {0: 0, 1: 0, 2: 0}, size=(16, 16))
    for label, offsets in LATEX_OFFSETS.items():
        window_sequence(tmp_path / label, offsets)
    tex = tmp_path / "t.tex"
    proc = compare(tmp_path / "gt" / "img.%04d.exr", tmp_path / "ours" / "img.%04d.exr",
                   tmp_path / "theirs" / "img.%04d.exr", "--frames", "0-2", "--crop", CROP,
                   "--label", "ours", "--label", "theirs", "--latex", tex, *extra)
    assert proc.returncode == 0, proc.stderr
    lines = [line.rstrip("\\ ").split("&") for line in tex.read_text().splitlines() if "&" in line]
    header = [c.strip() for c in lines[0]]
    return header, [[c.strip() for c in line] for line in lines[1:]]


def expected_rmse():
    """(label, frame, window) -> RMSE from the offsets' closed form."""
    out = {}
    for label, offsets in LATEX_OFFSETS.items():
        for frame, (a, b) in offsets.items():
            out[label, frame, CROP] = a
            out[label, frame, "full"] = np.sqrt((144 * a * a + 112 * b * b) / 256)
    return out


def expected_bold(rmse):
    """Per (frame or summary, window), the method with the lowest RMSE: a
    bold value compares methods on the same frame and window, never across
    frames or windows."""
    best = {}
    for window in ("full", CROP):
        per_label = {lab: [rmse[lab, f, window] for f in range(3)] for lab in LATEX_OFFSETS}
        for f in range(3):
            best[str(f), window] = min(LATEX_OFFSETS, key=lambda lab: per_label[lab][f])
        best["mean", window] = min(LATEX_OFFSETS, key=lambda lab: np.mean(per_label[lab]))
        best["worst", window] = min(LATEX_OFFSETS, key=lambda lab: max(per_label[lab]))
    return best


def test_latex_of_a_sequence_has_frames_labelled_summaries_and_bold_per_frame_and_window(tmp_path):
    header, rows = latex_sequence(tmp_path)
    assert header[:3] == ["Method", "Frame", "Window"]
    rmse_col = header.index("RMSE")
    rmse = expected_rmse()
    per_frame = [r for r in rows if r[1].isdigit()]
    assert sorted((r[0], int(r[1]), r[2]) for r in per_frame) == sorted(rmse)
    for r in per_frame:
        assert float(r[rmse_col].replace("\\textbf{", "").rstrip("}")) == pytest.approx(
            rmse[r[0], int(r[1]), r[2]], rel=1e-4)
    summaries = [r for r in rows if not r[1].isdigit()]
    worst_frames = {(lab, w): max(range(3), key=lambda f: rmse[lab, f, w]) for lab in LATEX_OFFSETS
                    for w in ("full", CROP)}
    assert sorted((r[0], r[1], r[2]) for r in summaries) == sorted(
        [(lab, "mean", w) for lab, w in worst_frames] +
        [(lab, f"worst ({f})", w) for (lab, w), f in worst_frames.items()])
    bold = {(r[1].split(" ")[0], r[2]): r[0] for r in rows if r[rmse_col].startswith("\\textbf")}
    assert bold == expected_bold(rmse)


def test_latex_summary_only(tmp_path):
    header, rows = latex_sequence(tmp_path, "--latex-summary")
    assert header[:3] == ["Method", "Frame", "Window"]
    assert len(rows) == 8 and all(r[1] == "mean" or r[1].startswith("worst (") for r in rows)
    rmse_col = header.index("RMSE")
    bold = {(r[1].split(" ")[0], r[2]): r[0] for r in rows if r[rmse_col].startswith("\\textbf")}
    assert bold == {k: v for k, v in expected_bold(expected_rmse()).items() if k[0] in ("mean", "worst")}
    single = compare(tmp_path / "gt" / "img.0000.exr", tmp_path / "ours" / "img.0000.exr", "--latex",
                     tmp_path / "s.tex", "--latex-summary")
    assert single.returncode == 2 and "--latex-summary" in single.stderr and "sequence" in single.stderr
    assert not (tmp_path / "s.tex").exists()
