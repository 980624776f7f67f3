#!/usr/bin/python3
"""Sampler convergence and time to error, measured (`make bench-samplers`;
src/bench/BENCH.md, Sampler convergence and Time to error).

usage: sampler_study.py convergence [--views NAME,...] [--counts 16,64,256]
                        [--samplers sobol,jittered3d,thesis] [--out DIR]
       sampler_study.py time-to-error [--counts 32,128,512] [--out DIR] [--from-csv CSV]
       sampler_study.py table CSV...

Errors are RMS over the RGB of every pixel, in 8-bit levels (1/255), of a
render against the truth, measured without a reference and without the
render's own standard errors: two renders of the same settings with other
seeds are independent and unbiased, so E|X1 - X2|^2 = 2 E|X1 - truth|^2 and
a render's error is RMS(X1 - X2) / sqrt 2.

convergence: for each view (a scene, its filter, its resolution or crop
window) and sampler, that error at each count of samples per pixel (one
batch: spp x tspp, box-filter views split 4 x N/4, point-filter views 1 x N),
the fitted rate (slope of log error against log samples) and the seconds of
the largest count. Writes DIR/convergence.csv and DIR/convergence.md (the
table BENCH.md quotes).

time-to-error: the benchmark-scale view (scenes/bench/scale.xml, made by
`make scale-models`; --pixel-filter point) with the default sampler, one
batch of each of --counts samples per pixel: its error (two seeds), its
wall-clock and CPU seconds; then, from the fitted error line and the CPU
seconds' line, the samples and 2-core seconds that reach 1, 0.1 and 0.01 of
an 8-bit level. Writes DIR/time_to_error.csv and prints the table.

Progress goes to stderr, a line per render."""
import argparse
import csv
import math
import os
import resource
import subprocess
import sys
import time

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import numpy as np

import imagecompare
import safefiles

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))
SCALE = os.path.join(ROOT, "scenes", "bench", "scale.xml")

# name: (scene relative to ROOT, extra arguments); point-filter views take
# all samples at the pixel centre (spp 1)
VIEWS = {
    "default-box": ("scenes/default.xml", ["--res", "128x128"]),
    "default-point": ("scenes/default.xml", ["--res", "128x128", "--pixel-filter", "point"]),
    "diagonal": ("scenes/diagonal.xml", ["--res", "128x96"]),
    "rotation": ("scenes/rotation.xml", ["--res", "128x96"]),
    "towards_camera": ("scenes/towards_camera.xml", ["--res", "128x96"]),
    "camera_pan": ("scenes/camera_pan.xml", ["--res", "128x96"]),
    "gaussians-2dgs": ("scenes/examples/training_views_2dgs.xml", ["--res", "128x96", "--pixel-filter", "point"]),
    "stg": ("scenes/examples/stg_lite.xml", ["--res", "128x128", "--pixel-filter", "point", "--frame", 25]),
    "scale-crop": ("scenes/bench/scale.xml", ["--pixel-filter", "point", "--crop-window", "0.3,0.5,0.3,0.5"]),
}


class StudyError(Exception):
    """A bad input, reported as one line (no traceback)."""


def positive_counts(text):
    """--counts: a comma-separated list of positive integers (argparse type)."""
    try:
        counts = [int(c) for c in text.split(",")]
    except ValueError:
        counts = []
    if not counts or min(counts) < 1:
        raise argparse.ArgumentTypeError(f"'{text}' is not a comma-separated list of positive integers")
    return counts


def names(text):
    """--views, --samplers: a comma-separated list of non-empty names (argparse type)."""
    items = text.split(",")
    if not all(items):
        raise argparse.ArgumentTypeError(f"'{text}' has an empty name")
    return items


def positive_integer(text):
    value = int(text)
    if value < 1:
        raise ValueError(text)
    return value


def finite_non_negative(text):
    value = float(text)
    if not 0 <= value < math.inf:
        raise ValueError(text)
    return value


# a CSV's columns and how each is read (a count of 0 has no logarithm for the fits)
COLUMN_KINDS = {"samples": positive_integer, "seconds": finite_non_negative, "cpu_seconds": finite_non_negative,
                "error_levels": finite_non_negative, "view": str, "sampler": str}


def read_rows(path, columns):
    """A CSV's rows with `columns` read as COLUMN_KINDS says, refused with one line naming the
    file (and the line) when it is not a regular file (a FIFO would block), is empty, has only
    a header, lacks a column or holds a value that is not one."""
    try:
        safefiles.require_regular(path)
    except safefiles.FileRefused as e:
        raise StudyError(str(e)) from None
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None:
            raise StudyError(f"{path}: empty: expected a CSV with the columns {', '.join(columns)}")
        missing = [c for c in columns if c not in reader.fieldnames]
        if missing:
            raise StudyError(f"{path}: no column {', '.join(missing)} (it has {', '.join(reader.fieldnames)})")
        rows = []
        for r in reader:
            row = dict(r)
            for c in columns:
                try:
                    row[c] = COLUMN_KINDS[c](r[c] or "")
                except (ValueError, OverflowError):
                    kind = "a positive integer" if c == "samples" else "a finite number >= 0"
                    raise StudyError(f"{path}:{reader.line_num}: {c} '{r[c]}' is not {kind}") from None
            rows.append(row)
    if not rows:
        raise StudyError(f"{path}: no rows, only a header")
    return rows


def progress(text):
    print(f"sampler_study.py: {text}", file=sys.stderr, flush=True)


def cpu_seconds():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def render(scene, out, args, cpu=None):
    """Renders; returns (RGB planes of the data window, wall-clock seconds, header); adds the
    render's CPU seconds (all threads) to cpu[0] when given."""
    cmd = [BIN, scene, "-o", out, "--quiet", *map(str, args)]
    start, start_cpu = time.monotonic(), cpu_seconds()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.monotonic() - start
    if cpu is not None:
        cpu[0] += cpu_seconds() - start_cpu
    if proc.returncode:
        sys.exit(f"sampler_study.py: {' '.join(cmd)} failed:\n{proc.stderr.strip()}")
    ch, _, header = imagecompare.read_channels(out, unassociated_alpha=False)  # a crop: its data window
    return np.stack([ch[c] for c in "RGB"], axis=-1).astype(np.float64), seconds, header


def pair_error(scene, out, args, cpu=None):
    """Error in 8-bit levels of one render, from two seeds; seconds of one (its CPU seconds
    into cpu[0] when given)."""
    a, seconds, header = render(scene, out, [*args, "--seed", 11], cpu)
    b, _, _ = render(scene, out, [*args, "--seed", 12])
    return 255 * math.sqrt(float(np.mean((a - b) ** 2)) / 2), seconds, header


def split(view_args, n):
    return (1, n) if "point" in view_args else (4, max(1, n // 4))


def samples_for(level, line):
    """Samples per pixel the fitted line reaches `level` at (rounded; '' without a fit)."""
    slope, intercept = line
    if not slope < 0:
        return ""
    n = math.exp((math.log(level) - intercept) / slope)
    return f"{n:.3g}"


def convergence(opts):
    os.makedirs(opts.out, exist_ok=True)
    rows = []
    out = os.path.join(opts.out, "render.exr")
    for view in opts.views:
        scene, args = VIEWS[view]
        for sampler in opts.samplers:
            for n in opts.counts:
                spp, tspp = split(args, n)
                err, seconds, _ = pair_error(os.path.join(ROOT, scene), out,
                                             [*args, "--sampler", sampler, "--spp", spp, "--tspp", tspp])
                rows.append({"view": view, "sampler": sampler, "samples": spp * tspp, "spp": spp, "tspp": tspp,
                             "seconds": round(seconds, 3), "error_levels": err})
                progress(f"{view} {sampler} {spp}x{tspp}: {err:.4g} levels, {seconds:.1f} s")
    with open(os.path.join(opts.out, "convergence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    table = convergence_table(rows)
    with open(os.path.join(opts.out, "convergence.md"), "w") as f:
        f.write(table)
    print(table)


def convergence_table(rows):
    counts = sorted({r["samples"] for r in rows})
    head = ("| view | sampler | " + " | ".join(f"{c}" for c in counts) + " | rate | s at " + str(counts[-1]) +
            " | samples to 1 / 0.1 level |")
    lines = [head, "|" + "---|" * (len(counts) + 5)]
    for view in dict.fromkeys(r["view"] for r in rows):
        best = {c: min(r["error_levels"] for r in rows if r["view"] == view and r["samples"] == c) for c in counts}
        for sampler in dict.fromkeys(r["sampler"] for r in rows):
            sel = {r["samples"]: r for r in rows if r["view"] == view and r["sampler"] == sampler}
            if not sel:
                continue
            cells = [cell(sel[c]["error_levels"], best[c]) if c in sel else "" for c in counts]
            line = imagecompare.loglog_fit(list(sel), [r["error_levels"] for r in sel.values()])
            lines.append(f"| {view} | {sampler} | " + " | ".join(cells) +
                         f" | {line[0]:.2f} | {sel[counts[-1]]['seconds'] if counts[-1] in sel else ''} | "
                         f"{samples_for(1, line)} / {samples_for(0.1, line)} |")
    return "\n".join(lines) + "\n"


def cell(error, best):
    """An error and its ratio to the best sampler's at the same count."""
    return f"{error:.3g} ({error / best:.2f}x)" if best > 0 else f"{error:.3g}"


def table_from_csv(opts):
    """One table of the files' rows; a view, sampler and count given again (in a later file or
    line) replaces the earlier row, said on stderr, so that no cell's ratio is to a best that
    was dropped."""
    rows = {}
    for path in opts.csv:
        for r in read_rows(path, ["view", "sampler", "samples", "seconds", "error_levels"]):
            key = (r["view"], r["sampler"], r["samples"])
            if key in rows:
                progress(f"{path}: {' '.join(map(str, key))} given again: replaces the earlier row")
            rows[key] = r
    print(convergence_table(list(rows.values())))


def time_to_error(opts):
    if not os.path.exists(os.path.join(ROOT, "scenes", "models", "scale_layer0.ply")):
        sys.exit("sampler_study.py: scenes/models/scale_layer*.ply are missing: run make scale-models")
    os.makedirs(opts.out, exist_ok=True)
    out = os.path.join(opts.out, "render.exr")
    rows = []
    for n in opts.counts:
        cpu = [0.0]
        err, seconds, _ = pair_error(SCALE, out, ["--pixel-filter", "point", "--spp", 1, "--tspp", n], cpu)
        rows.append({"samples": n, "seconds": round(seconds, 1), "cpu_seconds": round(cpu[0], 1),
                     "error_levels": err})
        progress(f"{n} samples: {err:.4g} levels, {seconds:.1f} s ({cpu[0]:.1f} CPU s)")
    with open(os.path.join(opts.out, "time_to_error.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(time_table(rows))


def time_table(rows):
    """Each level's samples and 2-core seconds, from the fitted error line and CPU seconds
    growing linearly with the samples (also fitted): a shared machine's wall clock is no
    measure, its CPU seconds over 2 are an idle 2-core machine's to within the threads'
    1.8-2.0x (BENCH.md, Measurements)."""
    counts = [r["samples"] for r in rows]
    line = imagecompare.loglog_fit(counts, [r["error_levels"] for r in rows])
    cost = np.polyfit(counts, [r["cpu_seconds"] for r in rows], 1)
    lines = ["| samples per pixel | error (8-bit levels) | CPU seconds | 2-core seconds |", "|---|---|---|---|"]
    lines += [f"| {r['samples']} | {r['error_levels']:.3g} | {r['cpu_seconds']} | {r['cpu_seconds'] / 2:.0f} |"
              for r in rows]
    lines += ["", f"rate {line[0]:.2f}; CPU seconds = {cost[1]:.1f} + {cost[0]:.3f} x samples", "",
              "| target (levels) | samples (fit) | 2-core seconds (fit) |", "|---|---|---|"]
    for level in (1, 0.1, 0.01):
        n = float(samples_for(level, line) or "nan")
        lines.append(f"| {level:g} | {n:.0f} | {(cost[1] + cost[0] * n) / 2:.0f} |")
    return "\n".join(lines) + "\n"


def time_table_from_csv(path):
    rows = read_rows(path, ["samples", "seconds", "cpu_seconds", "error_levels"])
    if len({r["samples"] for r in rows}) < 2:
        raise StudyError(f"{path}: the fits need two sample counts or more")
    print(time_table(rows))


def main():
    p = argparse.ArgumentParser(prog="sampler_study.py", description=__doc__.split("\n\n")[0],
                                epilog=__doc__.split("\n\n", 2)[2], formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="what", required=True)
    c = sub.add_parser("convergence", help="error against samples for each view and sampler")
    c.add_argument("--views", type=names, default=",".join(VIEWS), help="views to measure (default: all: %(default)s)")
    c.add_argument("--counts", type=positive_counts, default="16,64,256",
                   help="samples per pixel (default: %(default)s)")
    c.add_argument("--samplers", type=names, default="sobol,jittered3d,thesis", help="(default: %(default)s)")
    c.add_argument("--out", default="out/samplers", help="output directory (default: %(default)s)")
    t = sub.add_parser("time-to-error", help="seconds to each error level on the benchmark-scale view")
    t.add_argument("--counts", type=positive_counts, default="32,128,512",
                   help="samples per pixel, one batch, two or more (default: %(default)s)")
    t.add_argument("--out", default="out/samplers", help="output directory (default: %(default)s)")
    t.add_argument("--from-csv", metavar="CSV", help="only print the table of an earlier run's time_to_error.csv")
    tab = sub.add_parser("table", help="the convergence table of one or more convergence.csv files")
    tab.add_argument("csv", nargs="+")
    opts = p.parse_args()
    for view in opts.views if opts.what == "convergence" else []:
        if view not in VIEWS:
            p.error(f"--views: unknown view '{view}' (known: {', '.join(VIEWS)})")
    if opts.what == "time-to-error" and not opts.from_csv and len(set(opts.counts)) < 2:
        p.error("--counts: the fits need two sample counts or more")
    try:
        if opts.what == "table":
            table_from_csv(opts)
        elif opts.what == "time-to-error" and opts.from_csv:
            time_table_from_csv(opts.from_csv)
        else:
            convergence(opts) if opts.what == "convergence" else time_to_error(opts)
    except StudyError as e:
        sys.exit(f"sampler_study.py: {e}")


if __name__ == "__main__":
    main()
