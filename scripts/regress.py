#!/usr/bin/python3
"""Statistical regression check: is a fast render consistent with a
reference of the same scene? Both must carry refrender's stderr.R/G/B
channels (render with --batches >= 2; the fast one with >= 8 batches).

For every pixel and RGB channel, z = (test - ref) / sqrt(se_test^2 + se_ref^2).
Two renders of the same integral with independent seeds have z close to a
Student t with (test batches - 1) degrees of freedom; a bug that moves the
image (blending, a(t), visibility, ...) moves many pixels by many sigma. The
per-pixel z is skewed where estimates are skewed (a pixel's error and its
estimated spread are correlated near edges), so shifts are judged on
averages, whose errors are nearly normal:
  - pixels: at most 1% of the values have |z| > 5 (t with 7 degrees of
    freedom: 0.16%); values that differ where both standard errors are 0
    (both constant over their batches) count as beyond;
  - blocks: the mean difference over each 8x8 block and channel, divided by
    its standard error sqrt(sum se^2) / 64, is beyond 4 for at most 1% of
    the blocks (normal: 0.006%);
  - image: the mean difference lies within 5 of its standard errors, taking
    the three channels of a pixel as fully correlated (conservative).

usage: regress.py REFERENCE.exr TEST.exr [--json]   (exit 1 when inconsistent)
"""
import argparse
import json
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import numpy as np

import imagecompare

OUTLIER_Z, MAX_OUTLIERS, BLOCK, BLOCK_Z, MAX_BLOCKS, MEAN_SIGMAS = 5.0, 0.01, 8, 4.0, 0.01, 5.0


def block_z(diff, se):
    """Mean difference over BLOCK x BLOCK blocks (per channel) over its
    standard error; edge blocks use the pixels they have."""
    h, w, _ = diff.shape
    zs = []
    for y in range(0, h, BLOCK):
        for x in range(0, w, BLOCK):
            d, s = diff[y:y + BLOCK, x:x + BLOCK], se[y:y + BLOCK, x:x + BLOCK]
            n = d.shape[0] * d.shape[1]
            mean, err = d.sum(axis=(0, 1)) / n, np.sqrt((s ** 2).sum(axis=(0, 1))) / n
            for c in range(3):
                zs.append(mean[c] / err[c] if err[c] > 0 else (0.0 if abs(mean[c]) <= 1e-6 else np.inf))
    return np.array(zs)


def check(ref_path, test_path):
    ref = imagecompare.read_image(ref_path, "linear")
    test = imagecompare.read_image(test_path, "linear")
    if ref.rgb.shape != test.rgb.shape:
        raise imagecompare.CompareError(f"sizes differ: {ref.rgb.shape[:2]} vs {test.rgb.shape[:2]}")
    for img in (ref, test):
        if img.stderr is None:
            raise imagecompare.CompareError(f"{img.path}: no stderr channels (render with --batches >= 2)")
    diff = test.rgb - ref.rgb
    se = np.sqrt(test.stderr ** 2 + ref.stderr ** 2)
    known = se > 0
    z = np.zeros_like(diff)
    z[known] = diff[known] / se[known]
    constant_mismatch = ~known & (np.abs(diff) > 1e-6)
    outliers = float(np.mean((np.abs(z) > OUTLIER_Z) | constant_mismatch))
    blocks = float(np.mean(np.abs(block_z(diff, se)) > BLOCK_Z))
    pixel_se = se.mean(axis=-1)  # channels fully correlated: se of the channel mean <= mean se
    mean_diff = float(diff.mean())
    mean_se = float(np.sqrt(np.sum(pixel_se ** 2)) / pixel_se.size)
    result = {
        "reference": str(ref_path), "test": str(test_path),
        "outlier_fraction": outliers, "block_fraction": blocks,
        "mean_difference": mean_diff, "mean_difference_se": mean_se,
    }
    result["ok"] = (outliers <= MAX_OUTLIERS and blocks <= MAX_BLOCKS
                    and abs(mean_diff) <= MEAN_SIGMAS * mean_se + 1e-7)
    return result


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("reference")
    ap.add_argument("test")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    args = ap.parse_args(argv)
    try:
        r = check(args.reference, args.test)
    except imagecompare.CompareError as e:
        print(f"regress.py: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(r, indent=1))
    else:
        print(f"{'consistent' if r['ok'] else 'INCONSISTENT'}: pixels {r['outlier_fraction']:.3%} beyond "
              f"{OUTLIER_Z:g} sigma (max {MAX_OUTLIERS:.0%}), blocks {r['block_fraction']:.3%} beyond "
              f"{BLOCK_Z:g} sigma (max {MAX_BLOCKS:.0%}), "
              f"mean difference {r['mean_difference']:+.2e} = {r['mean_difference'] / max(r['mean_difference_se'], 1e-30):+.2f} se")
    return 0 if r["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
