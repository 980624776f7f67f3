"""Compare images against a refrender ground truth.

usage: compare.py REFERENCE TEST [TEST ...] [options]
       compare.py 'gt.%04d.exr' 'method.%04d.exr' [...] --frames 0-23 [options]
       compare.py GT_DIR METHOD_DIR [...] [options]

Reads any format OpenImageIO reads, decodes each image to linear RGB as its
file says it is encoded (oiio:ColorSpace; a refrender EXR of a Gaussian model
holds its sRGB-encoded colours, 8-bit PNG and JPEG are sRGB; an encoding
assumed or two blur spaces that differ are warned of), and reports MAE,
MSE, RMSE, PSNR, relMSE, SSIM, LDR-FLIP and HDR-FLIP for the whole image and
for each --crop. Sequences (printf-style patterns or directories) are paired
by frame number and reported per frame, then as the mean and the worst frame
(by RMSE) of each test. Formulas and references: scripts/imagecompare.py,
flip.py and scripts/README.md. Exit status: 0 success, 2 bad input (message names the
file).
"""
import argparse
import csv
import html
import io
import json
import math
import os
import sys

import numpy as np

from . import flip, safefiles, sequences
from .imagecompare import (CompareError, basic_metrics, composite, encoding_warnings, read_channels, read_image,
                           ssim_map, stderr_fraction)

COLUMNS = ["MAE", "MSE", "RMSE", "PSNR", "relMSE", "SSIM", "FLIP", "HDR-FLIP"]


def parse_args(argv):
    p = argparse.ArgumentParser(prog="compare.py", description=__doc__.split("\n\n")[1],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("reference")
    p.add_argument("tests", nargs="+", metavar="TEST")
    p.add_argument("--ref-colorspace", choices=["auto", "srgb", "linear"], default="auto",
                   help="transfer function of the reference (auto: the file's oiio:ColorSpace, or a refrender "
                        "EXR's refrender:blurSpace, else sRGB for integer and linear for float formats, the "
                        "latter assumed and warned of)")
    p.add_argument("--test-colorspace", choices=["auto", "srgb", "linear"], default="auto",
                   help="transfer function of the test images (same rule)")
    p.add_argument("--alpha", choices=["ignore", "composite"], default="ignore",
                   help="ignore alpha (default) or composite over --background")
    p.add_argument("--background", default="0 0 0", help="background color for --alpha composite")
    p.add_argument("--exposure", type=float, default=0.0,
                   help="exposure in stops applied to both images before all metrics")
    p.add_argument("--crop", action="append", default=[], metavar="X,Y,W,H",
                   help="also report this pixel window (may be repeated)")
    p.add_argument("--mask", help="image whose first channel > 0.5 marks the pixels to evaluate")
    p.add_argument("--psnr-peak", type=float, default=1.0, help="peak value for PSNR only (default 1)")
    p.add_argument("--ssim-peak", type=float, default=1.0,
                   help="SSIM's data range: values are clamped to [0, peak] (default 1)")
    p.add_argument("--metrics-space", choices=["linear", "srgb"], default="linear",
                   help="compute MAE, MSE, RMSE, PSNR, relMSE and SSIM on linear values (default) or on "
                        "sRGB-encoded ones clamped to [0, 1], as most papers report; FLIP always takes linear")
    p.add_argument("--label", action="append", default=[], metavar="NAME",
                   help="a name for each TEST, in order, used in every table, picture and file name "
                        "(default: the file name, or the path when two share one)")
    p.add_argument("--frames", metavar="A-B", help="frames of a pattern sequence (with a directory: a selection)")
    p.add_argument("--ppd", type=float, default=flip.DEFAULT_PPD, help="FLIP pixels per degree (67.02)")
    p.add_argument("--hdr-exposures", metavar="START,STOP",
                   help="HDR-FLIP exposure range in stops (default: from the reference's luminance)")
    p.add_argument("--k-sigma", type=float, default=3.0,
                   help="report the fraction of pixels (>KSE) differing by more than K standard errors of the "
                        "difference: the reference's stderr.* channels combined with the test's own stderr.* "
                        "channels or --test-noise (default 3)")
    p.add_argument("--test-noise", metavar="A,B",
                   help="two renders of the test method with other seeds: their difference estimates the "
                        "test's per-pixel standard error as |A - B| / sqrt(2)")
    p.add_argument("--se-floor", type=float, default=1e-6,
                   help="smallest standard error used for >KSE, so pixels whose standard error is exactly 0 "
                        "(converged, or outside every object) are not flagged for float rounding (default 1e-6)")
    p.add_argument("--json", metavar="FILE", help="write results as JSON ('-' for stdout)")
    p.add_argument("--csv", metavar="FILE", help="write results as CSV ('-' for stdout)")
    p.add_argument("--heatmaps", metavar="DIR", help="write error maps and contact sheets as PNG")
    p.add_argument("--maps", metavar="DIR",
                   help="write figure-ready maps at native resolution: LDR-FLIP, signed difference and (when "
                        "computed) HDR-FLIP as coloured PNG and float EXR, and with --crop the test image with "
                        "the windows outlined plus a zoomed inset per window")
    p.add_argument("--map-scale", type=int, default=1, metavar="N",
                   help="upscale the PNG maps by the integer N, nearest neighbour (default 1)")
    p.add_argument("--inset-scale", type=int, default=4, metavar="N", help="zoom of the crop insets (default 4)")
    p.add_argument("--diff-range", type=float, metavar="X",
                   help="signed difference maps span [-X, X] (default: one range for all inputs, their "
                        "largest |difference|)")
    p.add_argument("--flip-range", default="0,1", metavar="LO,HI",
                   help="colour range of the FLIP maps, the same for all inputs (default 0,1)")
    p.add_argument("--latex", metavar="FILE",
                   help="write a booktabs LaTeX table, the best value of each column in bold among the methods "
                        "on the same frame and window; a sequence's table has a Frame column, one row per frame, "
                        "then each method's mean and worst frame")
    p.add_argument("--latex-summary", action="store_true",
                   help="with a sequence, the LaTeX table holds only each method's mean and worst-frame rows")
    p.add_argument("--report", metavar="DIR", help="write an offline HTML report with the images")
    return p.parse_args(argv)


def parse_crop(text, width, height):
    try:
        x, y, w, h = (int(v) for v in text.split(","))
    except ValueError:
        raise CompareError(f"--crop {text}: expected X,Y,W,H as four integers")
    if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > width or y + h > height:
        raise CompareError(f"--crop {text}: window outside the {width}x{height} image")
    return x, y, w, h


def parse_floats(text, n, what):
    try:
        vals = [float(v) for v in text.replace(",", " ").split()]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise CompareError(f"{what}: expected {n} numbers, got '{text}'")
    return vals


def load(path, colorspace, args, expect_shape=None):
    if not os.path.exists(path):
        raise CompareError(f"{path}: no such file")
    img = read_image(path, colorspace)
    if expect_shape and img.rgb.shape != expect_shape:
        h, w = expect_shape[:2]
        raise CompareError(f"{path}: size {img.rgb.shape[1]}x{img.rgb.shape[0]} differs from the "
                           f"reference's {w}x{h}")
    rgb = composite(img, parse_floats(args.background, 3, "--background")) if args.alpha == "composite" else img.rgb
    return img, rgb * 2.0 ** args.exposure


def evaluate(ref_img, ref, test, valid, window, args, test_se=None, test_se_source=None):
    """Metrics of one window (x, y, w, h) of the full-image arrays; test_se:
    the test's own per-pixel standard errors, if known."""
    x, y, w, h = window
    sl = (slice(y, y + h), slice(x, x + w))
    r, t, v = ref[sl], test[sl], valid[sl]
    if not v.any():
        raise CompareError("no valid pixels to compare (mask empty, or all pixels NaN/Inf)")
    r0, t0 = np.where(np.isfinite(r), r, 0.0), np.where(np.isfinite(t), t, 0.0)
    v3 = np.repeat(v[..., None], 3, axis=-1)
    rm, tm = (flip.linear_to_srgb(r0), flip.linear_to_srgb(t0)) if args.metrics_space == "srgb" else (r0, t0)
    res = basic_metrics(rm, tm, v3, args.psnr_peak)
    res["SSIM"] = float(ssim_map(rm, tm, args.ssim_peak)[v].mean())
    flip_map = flip.ldr_flip(r0, t0, args.ppd)
    res["FLIP"] = float(flip_map[v].mean())
    res["FLIP p50w"] = flip.weighted_percentile(flip_map[v], 50)
    res["FLIP p95w"] = flip.weighted_percentile(flip_map[v], 95)
    hdr_map = None
    try:
        exposures = parse_floats(args.hdr_exposures, 2, "--hdr-exposures") if args.hdr_exposures else None
        hdr_map = flip.hdr_flip(r0, t0, args.ppd, exposures)
        res["HDR-FLIP"] = float(hdr_map[v].mean())
    except ValueError as e:
        res["HDR-FLIP"], res["notes"] = None, f"HDR-FLIP n/a: {e}"
    res["pixels"] = int(v.sum())
    if ref_img.stderr is not None:
        se = ref_img.stderr[sl] ** 2
        if test_se is not None:
            se = se + test_se[sl] ** 2
        se = np.maximum(np.sqrt(se), args.se_floor)
        res[f">{args.k_sigma:g}SE"] = stderr_fraction(se, r0, t0, v, args.k_sigma)
        res["SE source"] = "reference" + ("" if test_se is None else f" and {test_se_source}")
    return res, flip_map, hdr_map


def format_value(v):
    if v is None:
        return "n/a"
    if isinstance(v, float):
        return "inf" if math.isinf(v) else f"{v:.6g}"
    return str(v)


def print_table(rows, out=None):
    out = out or sys.stdout  # looked up at the call, so that a caller's redirection of stdout holds
    extra = sorted({k for r in rows for k in r if k.startswith(">")})
    frame = ["frame"] if any("frame" in r for r in rows) else []
    cols = ["image"] + frame + ["window", "pixels", "nonfinite"] + COLUMNS + extra
    cells = [cols] + [[format_value(r.get(c)) for c in cols] for r in rows]
    widths = [max(len(row[i]) for row in cells) for i in range(len(cols))]
    for row in cells:
        left = 2 + len(frame)  # name columns left-aligned, numbers right-aligned
        print("  ".join(c.rjust(w) if i >= left else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths))),
              file=out)
    for r in rows:
        if r.get("notes"):
            print(f"note: {r['image']} [{r['window']}]: {r['notes']}", file=out)
            break
    print_encodings(rows, out)


def print_encodings(rows, out):
    """Each input's encoding and every warning, once each."""
    lines = {}
    for r in rows:
        if "reference encoding" in r:
            lines.setdefault(f"encoding: reference {r['reference encoding']}; {r['image']} {r['test encoding']}")
        for w in (r.get("warnings") or "").split("; "):
            if w:
                lines.setdefault(f"warning: {w}")
    for line in lines:
        print(line, file=out)


def schema(args):
    """The columns of the CSV and the keys of every JSON row, the same in every
    run: empty (CSV) or null (JSON) where a value does not apply; reasons in
    'notes'."""
    return (["image", "frame", "window", "pixels", "nonfinite"] + COLUMNS[:7] + ["FLIP p50w", "FLIP p95w",
            "HDR-FLIP", f">{args.k_sigma:g}SE", "SE source", "notes", "reference encoding", "test encoding",
            "warnings"])


def json_rows(rows, columns):
    """The rows as --json writes them: every column, null where a value does not apply; strict JSON has
    no Infinity, so an infinite PSNR (identical images) is "inf"."""
    return [{c: ("inf" if isinstance(r.get(c), float) and math.isinf(r.get(c)) else r.get(c)) for c in columns}
            for r in rows]


def write_machine_readable(rows, json_path, csv_path, columns, inputs):
    """--json and --csv: '-' is stdout, a file is written whole or not at all
    (safefiles), never over an input."""
    if json_path:
        text = json.dumps(json_rows(rows, columns), indent=2, allow_nan=False)
        if json_path == "-":
            print(text)
        else:
            safefiles.write_text(json_path, text + "\n", inputs)
    if csv_path:
        rows = [{c: r.get(c) for c in columns} for r in rows]
        out = io.StringIO(newline="")
        w = csv.DictWriter(out, fieldnames=columns)
        w.writeheader()
        w.writerows([{k: ("" if v is None else v) for k, v in r.items()} for r in rows])
        if csv_path == "-":
            sys.stdout.write(out.getvalue())
        else:
            safefiles.write_text(csv_path, out.getvalue(), inputs)


def test_noise(args, shape):
    """(per-pixel standard error, its description) from --test-noise, or (None, None)."""
    if not args.test_noise:
        return None, None
    paths = args.test_noise.split(",")
    if len(paths) != 2:
        raise CompareError(f"--test-noise {args.test_noise}: expected two images A,B")
    (_, a), (_, b) = (load(p, args.test_colorspace, args, shape) for p in paths)
    return np.abs(a - b) / math.sqrt(2.0), "--test-noise"


def labels_of(args, tests):
    """One unique label per test input (--label, else the file name, else
    the path): pictures and rows are named by it, so none overwrite another."""
    if args.label and len(args.label) != len(tests):
        raise CompareError(f"--label given {len(args.label)} times for {len(tests)} test inputs")
    if args.label:
        labels = list(args.label)
    else:
        stems = [os.path.basename(t.rstrip("/")) for t in tests]
        labels = stems if len(set(stems)) == len(stems) else list(tests)
    if len(set(labels)) != len(labels):
        raise CompareError("two test inputs have the same label: give --label for each")
    return labels


def compare_images(args, reference, tests, labels, frame=None):
    """Rows (one per test and window) and picture inputs for one reference."""
    ref_img, ref = load(reference, args.ref_colorspace, args)
    if frame is not None:
        sequences.check_frame(reference, ref_img.header, frame)
    height, width = ref.shape[:2]
    windows = [("full", (0, 0, width, height))] + [(c, parse_crop(c, width, height)) for c in args.crop]
    mask = np.ones((height, width), bool)
    if args.mask:
        channels, spec, _ = read_channels(args.mask)
        m = channels[spec.channelnames[0]]
        if m.shape != (height, width):
            raise CompareError(f"{args.mask}: size {m.shape[1]}x{m.shape[0]} differs from the reference's "
                               f"{width}x{height}")
        mask = m > 0.5
    rows, maps = [], []
    noise = test_noise(args, ref.shape)
    for path, label in zip(tests, labels):
        test_img, test = load(path, args.test_colorspace, args, ref.shape)
        if frame is not None:
            sequences.check_frame(path, test_img.header, frame)
        se, source = (test_img.stderr, "test stderr channels") if test_img.stderr is not None else noise
        finite = np.isfinite(ref).all(axis=-1) & np.isfinite(test).all(axis=-1)
        said = {"reference encoding": str(ref_img.encoding), "test encoding": str(test_img.encoding),
                "warnings": "; ".join(encoding_warnings(ref_img, test_img)) or None}
        for name, win in windows:
            x, y, w, h = win
            res, flip_map, hdr_map = evaluate(ref_img, ref, test, finite & mask, win, args, se, source)
            head = {"image": label, "window": name} if frame is None else {"image": label, "frame": frame,
                                                                           "window": name}
            res = {**head, "nonfinite": int((~finite[y:y + h, x:x + w]).sum()), **res, **said}
            rows.append(res)
            picture = label if frame is None else f"{label}_f{frame}"
            maps.append((picture, name, win, ref, test, flip_map, hdr_map))
    return rows, maps


def summarize(rows, labels):
    """Per test and window: the mean over frames and the worst frame (largest RMSE)."""
    out = []
    for label in labels:
        for window in dict.fromkeys(r["window"] for r in rows):
            mine = [r for r in rows if r["image"] == label and r["window"] == window]
            mean = {"image": label, "frame": "mean", "window": window}
            for k in mine[0]:
                vals = [r.get(k) for r in mine]
                if k not in mean and all(isinstance(v, (int, float)) and v is not None for v in vals):
                    mean[k] = float(np.mean(vals))
            worst = dict(max(mine, key=lambda r: r["RMSE"]))
            worst["frame"] = f"worst ({worst['frame']})"
            out += [mean, worst]
    return out


def latex_rows(rows, summary_only):
    """The LaTeX table's rows: the frames in order, then every mean, then
    every worst frame (each group compared within itself); only the last two
    groups when summary_only."""
    def kind(r):
        frame = str(r.get("frame", ""))
        return 1 if frame == "mean" else 2 if frame.startswith("worst") else 0
    return sorted((r for r in rows if kind(r) or not summary_only), key=kind)


def plan(args):
    """(labels, [(frame or None, reference path, [test paths])]): what will
    be read, known before any image is."""
    if args.latex_summary and not (args.latex and sequences.is_sequence(args.reference)):
        raise CompareError("--latex-summary needs --latex and a sequence (a pattern such as 'gt.%04d.exr' "
                           "or a directory): a single image has no mean or worst frame")
    labels = labels_of(args, args.tests)
    if not sequences.is_sequence(args.reference):
        if args.frames:
            raise CompareError("--frames needs a sequence: a pattern such as 'gt.%04d.exr' or a directory")
        return labels, [(None, args.reference, args.tests)]
    frames = sequences.parse_frames(args.frames) if args.frames else None
    return labels, sequences.pairs(args.reference, args.tests, frames)


def checked_inputs(args, work):
    """The input files (each refused unless a regular file, so that a FIFO
    cannot block the run), and every output checked against them before
    anything is computed: an output may not overwrite an input."""
    paths = [p for _, ref, tests in work for p in (ref, *tests)]
    paths += ([args.mask] if args.mask else []) + (args.test_noise.split(",") if args.test_noise else [])
    for p in paths:
        if not os.path.exists(p):
            raise CompareError(f"{p}: no such file")
        safefiles.require_regular(p)
    inputs = safefiles.Inputs(paths)
    for option, path in (("--json", args.json), ("--csv", args.csv), ("--latex", args.latex)):
        if path and (path != "-" or option == "--latex"):
            inputs.check_output(path, option)
    for option, path in (("--maps", args.maps), ("--heatmaps", args.heatmaps), ("--report", args.report)):
        if path:
            inputs.check_directory(path, option)
    return inputs


def compare(args, labels, work):
    rows, maps = [], []
    for frame, ref, tests in work:
        r, m = compare_images(args, ref, tests, labels, frame)
        rows += r
        maps += m
    return (rows if work[0][0] is None else rows + summarize(rows, labels)), maps


def rows_for(argv):
    """compare.py's results for its arguments argv, as --json holds them, nothing written (refrender.compare)."""
    args = parse_args(argv)
    labels, work = plan(args)
    checked_inputs(args, work)
    rows, _ = compare(args, labels, work)
    return json_rows(rows, schema(args))


def main(argv=None):
    args = parse_args(argv if argv is not None else sys.argv[1:])
    try:
        labels, work = plan(args)
        inputs = checked_inputs(args, work)
        rows, maps = compare(args, labels, work)
        print(f"metrics space: {args.metrics_space} (FLIP: linear)")
        print_table(rows)
        write_machine_readable(rows, args.json, args.csv, schema(args), inputs)
        if args.latex:
            from . import figures  # matplotlib only when figures are asked for
            figures.latex_table(latex_rows(rows, args.latex_summary), COLUMNS + [f">{args.k_sigma:g}SE"], args.latex,
                                inputs)
        write_pictures(args, rows, maps, inputs)
    except (CompareError, safefiles.FileRefused) as e:
        print(f"compare.py: {e}", file=sys.stderr)
        return 2
    except OSError as e:  # e.g. an output directory that cannot be made
        print(f"compare.py: {e.filename + ': ' if e.filename else ''}{e.strerror or e}", file=sys.stderr)
        return 2
    return 0


def window_diffs(maps):
    """Each map entry's signed difference, test - reference, mean of RGB over
    its window (NaN or Inf where either image is)."""
    return [(test[y:y + h, x:x + w] - ref[y:y + h, x:x + w]).mean(axis=-1)
            for _, _, (x, y, w, h), ref, test, _, _ in maps]


def shared_diff_range(args, diffs):
    """--diff-range, else the largest finite |mean RGB difference| over every
    input and window."""
    if args.diff_range:
        return args.diff_range
    lim = max((float(np.max(np.abs(d[np.isfinite(d)]), initial=0.0)) for d in diffs), default=0.0)
    return lim or 1.0


def write_native_maps(args, maps, diffs, diff_range, inputs):
    from . import figures
    flip_lo, flip_hi = parse_floats(args.flip_range, 2, "--flip-range")
    if args.map_scale < 1 or args.inset_scale < 1:
        raise CompareError("--map-scale and --inset-scale must be positive integers")
    os.makedirs(args.maps, exist_ok=True)
    crops = {}  # each picture's crop windows, as compare_images made them
    for label, window, win, *_ in maps:
        if window != "full":
            crops.setdefault(label, []).append((window, win))
    for (label, window, _, _, test, flip_map, hdr_map), diff in zip(maps, diffs):
        base = figures._name(label, window)
        figures.write_map(args.maps, base + "_flip", flip_map, "magma", flip_lo, flip_hi, args.map_scale, inputs)
        figures.write_map(args.maps, base + "_diff", diff, "RdBu_r", -diff_range, diff_range, args.map_scale,
                          inputs)
        if hdr_map is not None:
            figures.write_map(args.maps, base + "_hdrflip", hdr_map, "magma", flip_lo, flip_hi, args.map_scale,
                              inputs)
        if window == "full" and label in crops:
            figures.write_crops(args.maps, label, test, crops[label], args.inset_scale, inputs)


def write_pictures(args, rows, maps, inputs):
    """Each picture is written whole or not at all (safefiles), never over an input."""
    diffs = window_diffs(maps)
    diff_range = shared_diff_range(args, diffs)
    if args.maps:
        write_native_maps(args, maps, diffs, diff_range, inputs)
    if args.heatmaps or args.report:
        from . import heatmaps  # matplotlib only when pictures are asked for
        if args.heatmaps:
            heatmaps.write_all(maps, args.heatmaps, diff_range, inputs)
        if args.report:  # the report folder holds its own pictures, viewable offline
            heatmaps.write_report(rows, heatmaps.write_all(maps, args.report, diff_range, inputs), args.report,
                                  args.reference, args.metrics_space, inputs)
