#!/usr/bin/python3
"""Convergence study: RMSE against a high-sample reference as the sample
count grows, for each sampler.

usage: convergence.py SCENE [--res WxH] [--counts 25,100,400,1600]
                      [--samplers thesis,jittered3d,sobol] [--reference-count 25600]
                      [--baseline 400] [--out DIR]

A count N of samples per pixel is split as refrender's default 4 x 100 is:
spp : tspp = 1 : 25, i.e. spp = K*K with K = max(1, round(sqrt(0.2 sqrt N)))
and tspp = N / (K*K) (N = 400 gives exactly --spp 4 --tspp 100); every
sampler gets the same split. The reference is a jittered3d render with
--reference-count samples and another seed. Writes DIR/convergence.csv
(sampler, samples, spp, tspp, seconds, rmse), DIR/convergence.png (RMSE vs
samples and vs render time, log-log), and prints each sampler's fitted slope
of log RMSE against log samples and the samples it needs (from its fitted
line) to reach the thesis sampler's measured RMSE at --baseline samples."""
import argparse
import csv
import os
import subprocess
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES, "matplotlib")  # a missing package: one line, not a traceback

import numpy as np

import imagecompare

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))


def split(count):
    """(spp, tspp) with the default 4:100 ratio."""
    k = max(1, round((0.2 * count ** 0.5) ** 0.5))
    return k * k, max(1, count // (k * k))


def render(scene, out, res, spp, tspp, sampler, seed):
    cmd = [BIN, scene, "--res", res, "--spp", str(spp), "--tspp", str(tspp), "--sampler", sampler,
           "--seed", str(seed), "-o", out, "--quiet"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode:
        sys.exit(f"convergence.py: render failed: {' '.join(cmd)}\n{proc.stderr}")
    channels, _, header = imagecompare.read_channels(out)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
    return rgb, float(header.get("refrender:renderSeconds", "0"))


def fit_slope(samples, rmse):
    slope, intercept = np.polyfit(np.log(samples), np.log(rmse), 1)
    return slope, intercept


def plot(rows, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for sampler in dict.fromkeys(r["sampler"] for r in rows):
        sel = [r for r in rows if r["sampler"] == sampler]
        axes[0].loglog([r["samples"] for r in sel], [r["rmse"] for r in sel], "o-", label=sampler)
        axes[1].loglog([r["seconds"] for r in sel], [r["rmse"] for r in sel], "o-", label=sampler)
    axes[0].set_xlabel("samples per pixel")
    axes[1].set_xlabel("render time (s)")
    for ax in axes:
        ax.set_ylabel("RMSE vs reference")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.savefig(path, dpi=100, bbox_inches="tight")
    plt.close(fig)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("--res", default="128x128")
    p.add_argument("--counts", default="25,100,400,1600")
    p.add_argument("--samplers", default="thesis,jittered3d,sobol")
    p.add_argument("--reference-count", type=int, default=25600)
    p.add_argument("--baseline", type=int, default=400)
    p.add_argument("--out", default="convergence")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    counts = [int(c) for c in a.counts.split(",")]
    if a.baseline not in counts:
        sys.exit("convergence.py: --baseline must be one of --counts")
    ref, _ = render(a.scene, os.path.join(a.out, "reference.exr"), a.res, *split(a.reference_count),
                    "jittered3d", 1000003)
    rows = []
    for sampler in a.samplers.split(","):
        for count in counts:
            spp, tspp = split(count)
            img, seconds = render(a.scene, os.path.join(a.out, f"{sampler}_{count}.exr"), a.res, spp, tspp,
                                  sampler, 7)
            rows.append({"sampler": sampler, "samples": spp * tspp, "spp": spp, "tspp": tspp,
                         "seconds": seconds, "rmse": float(np.sqrt(np.mean((img - ref) ** 2)))})
    with open(os.path.join(a.out, "convergence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["sampler", "samples", "spp", "tspp", "seconds", "rmse"])
        w.writeheader()
        w.writerows(rows)
    plot(rows, os.path.join(a.out, "convergence.png"))
    fits = {s: fit_slope([r["samples"] for r in rows if r["sampler"] == s], [r["rmse"] for r in rows if r["sampler"] == s])
            for s in dict.fromkeys(r["sampler"] for r in rows)}
    base = "thesis" if "thesis" in fits else next(iter(fits))
    spp, tspp = split(a.baseline)
    target = next(r["rmse"] for r in rows if r["sampler"] == base and r["samples"] == spp * tspp)
    print(f"baseline: {base} at {spp}x{tspp} samples, RMSE {target:.4g}")
    print(f"{'sampler':12} {'slope':>7} {'samples for that RMSE':>22} {'ratio':>8}")
    for s, (slope, icpt) in fits.items():
        needed = np.exp((np.log(target) - icpt) / slope)
        print(f"{s:12} {slope:7.3f} {needed:22.0f} {spp * tspp / needed:7.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
