#!/usr/bin/python3
"""Error against cost for any method: RMSE and LDR-FLIP of each image
against a reference, plotted against its cost (seconds or samples) on log
axes, one curve per method label, with refrender's own samplers as
reference curves (the CSV scripts/convergence.py writes).

usage: cost_error.py REFERENCE --entry LABEL,IMAGE,COST [--entry ...]
                     [--entries FILE.csv] [--cost-unit seconds|samples]
                     [--refrender-curves out/convergence/convergence.csv]
                     [--out DIR]

Writes DIR/cost_error.csv (label, image, cost, rmse, flip) and
DIR/cost_error.png; prints the table. Images are read as compare.py reads
them (scripts/imagecompare.py). Every input (the reference, each image, the
--entries and --refrender-curves files) must be a regular file, refused by
name otherwise (a FIFO would block the tool); each output is written whole
or not at all and never over an input (scripts/safefiles.py), both checked
before anything is measured."""
import argparse
import csv
import io
import os
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES, "matplotlib")  # a missing package: one line, not a traceback

import numpy as np

import flip
import safefiles
from imagecompare import CompareError, basic_metrics, check_written, encoding_warnings, read_image


def parse_args(argv):
    p = argparse.ArgumentParser(prog="cost_error.py", description=__doc__.split("\n\n")[0])
    p.add_argument("reference", help="the ground truth image (e.g. a long refrender render)")
    p.add_argument("--entry", action="append", default=[], metavar="LABEL,IMAGE,COST",
                   help="one image of a method and its cost (repeatable)")
    p.add_argument("--entries", metavar="FILE.csv",
                   help="more entries from a CSV file with columns label, image, cost")
    p.add_argument("--cost-unit", choices=["seconds", "samples"], default="seconds",
                   help="what COST counts, for the axis label (default seconds)")
    p.add_argument("--refrender-curves", metavar="CSV",
                   help="convergence.csv from scripts/convergence.py: its samplers are drawn as reference "
                        "curves (cost from its 'seconds' or 'samples' column, as --cost-unit says)")
    p.add_argument("--out", default="out/cost_error", help="output directory (default: %(default)s)")
    return p.parse_args(argv)


def entries_of(args):
    rows = []
    for e in args.entry:
        parts = e.rsplit(",", 2)
        if len(parts) != 3:
            raise CompareError(f"--entry {e}: expected LABEL,IMAGE,COST")
        rows.append(parts)
    if args.entries:
        with open(args.entries, newline="") as f:
            for r in csv.DictReader(f):
                rows.append([r["label"], r["image"], r["cost"]])
    out = []
    for label, image, cost in rows:
        try:
            c = float(cost)
        except ValueError:
            c = -1.0
        if not c > 0:
            raise CompareError(f"{image}: cost must be a positive number, got '{cost}'")
        out.append((label, image, c))
    if not out:
        raise CompareError("no entries: give --entry LABEL,IMAGE,COST or --entries FILE.csv")
    return out


def measure(reference, entries):
    """RMSE and FLIP of each entry, both sides decoded to linear light as their files say
    (imagecompare.read_image); an assumed encoding or differing blur spaces said on stderr."""
    ref_img = read_image(reference)
    ref = ref_img.rgb
    results = []
    for label, image, cost in entries:
        test_img = read_image(image)
        for warning in encoding_warnings(ref_img, test_img):
            print(f"cost_error.py: warning: {warning}", file=sys.stderr)
        test = test_img.rgb
        if test.shape != ref.shape:
            raise CompareError(f"{image}: size differs from the reference's")
        valid = np.isfinite(ref) & np.isfinite(test)
        rmse = basic_metrics(np.nan_to_num(ref), np.nan_to_num(test), valid)["RMSE"]
        fl = float(flip.ldr_flip(np.nan_to_num(ref), np.nan_to_num(test)).mean())
        results.append((label, image, cost, rmse, fl))
    return results


def reference_curves(path, unit):
    curves = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            curves.setdefault(f"refrender {r['sampler']}", []).append((float(r[unit]), float(r["rmse"])))
    return {k: sorted(v) for k, v in curves.items()}


# refrender's reference curves: grey, so the methods' coloured curves stand out, and told apart
# from each other by line style and marker (greys alone cannot be), none of them the methods' "o-"
REFERENCE_STYLES = [("--", "s", "0.25"), (":", "^", "0.45"), ("-.", "D", "0.6"), ((0, (5, 1, 1, 1)), "v", "0.35"),
                    ((0, (1, 3)), "x", "0.5")]


def plot(results, curves, unit, write):
    """Draws the figure and gives it to write(fig)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for k, (name, col) in enumerate([("RMSE", 3), ("LDR-FLIP", 4)]):
        ax = axes[k]
        for label in dict.fromkeys(r[0] for r in results):
            pts = sorted((r[2], r[col]) for r in results if r[0] == label)
            ax.loglog(*zip(*pts), "o-", label=label)
        if name == "RMSE":
            for k, (label, pts) in enumerate(curves.items()):
                style, marker, grey = REFERENCE_STYLES[k % len(REFERENCE_STYLES)]
                ax.loglog(*zip(*pts), linestyle=style, marker=marker, color=grey, markersize=4,
                          markerfacecolor="none", label=label)
        ax.set_xlabel(unit)
        ax.set_ylabel(name)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    try:
        write(fig)
    finally:
        plt.close(fig)


def outputs(args):
    return os.path.join(args.out, "cost_error.csv"), os.path.join(args.out, "cost_error.png")


def checked_inputs(args, entries):
    """The input files, each refused unless a regular file, and both outputs
    checked against them before anything is measured: `--out ce` beside
    `--entries ce/cost_error.csv` (or an entry image ce/cost_error.png) would
    otherwise be replaced by the tool's own results."""
    paths = [args.reference, *(image for _, image, _ in entries)]
    paths += [p for p in (args.entries, args.refrender_curves) if p]
    for p in paths:
        safefiles.require_regular(p)
    inputs = safefiles.Inputs(paths)
    inputs.check_directory(args.out, "--out")
    for path in outputs(args):
        inputs.check_output(path, "--out")
    return inputs


def write_outputs(args, results, curves, inputs):
    """The CSV and the plot, each whole or not at all (safefiles)."""
    table = io.StringIO()
    w = csv.writer(table)
    w.writerow(["label", "image", args.cost_unit, "rmse", "flip"])
    w.writerows(results)
    csv_path, png_path = outputs(args)
    os.makedirs(args.out, exist_ok=True)
    safefiles.write_text(csv_path, table.getvalue(), inputs)
    plot(results, curves, args.cost_unit,
         lambda fig: safefiles.write_file(png_path, lambda tmp: fig.savefig(tmp, dpi=110), inputs, check_written))


def main(argv=None):
    args = parse_args(argv if argv is not None else sys.argv[1:])
    try:
        for p in (args.entries, args.refrender_curves):  # read before the others: no FIFO may block them
            if p:
                safefiles.require_regular(p)
        entries = entries_of(args)
        inputs = checked_inputs(args, entries)
        results = measure(args.reference, entries)
        curves = reference_curves(args.refrender_curves, args.cost_unit) if args.refrender_curves else {}
        write_outputs(args, results, curves, inputs)
    except (CompareError, safefiles.FileRefused) as e:
        print(f"cost_error.py: {e}", file=sys.stderr)
        return 2
    except KeyError as e:
        print(f"cost_error.py: a CSV lacks the column {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"cost_error.py: {e.filename + ': ' if e.filename else ''}{e.strerror or e}", file=sys.stderr)
        return 2
    print(f"{'label':16s} {args.cost_unit:>10s} {'RMSE':>10s} {'FLIP':>8s}  image")
    for label, image, cost, rmse, fl in results:
        print(f"{label:16s} {cost:10.4g} {rmse:10.4g} {fl:8.4f}  {image}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
