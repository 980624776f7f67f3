#!/usr/bin/python3
"""Convergence study: RMSE against a high-sample reference as the sample
count grows, for each sampler.

usage: convergence.py SCENE [--res WxH] [--counts 16,64,256,1024]
                      [--samplers thesis,jittered3d,sobol] [--reference-count 16384]
                      [--spp 4] [--out DIR]

Every render uses --spp SPP spatial samples and tspp = count / SPP temporal
samples per spatial sample (counts should be multiples of SPP; powers of two
suit sobol). The reference is a jittered3d render with --reference-count
samples per pixel and another seed. Writes DIR/convergence.csv (sampler,
samples, seconds, rmse), DIR/convergence.png (RMSE vs samples and vs render
time, log-log) and prints the fitted slope of log RMSE against log samples
and, per sampler, the samples needed to match the thesis sampler's RMSE at
its largest count (from the fitted lines)."""
import argparse
import csv
import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))


def render(scene, out, res, spp, tspp, sampler, seed):
    cmd = [BIN, scene, "--res", res, "--spp", str(spp), "--tspp", str(tspp), "--sampler", sampler,
           "--seed", str(seed), "-o", out, "--quiet"]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode:
        sys.exit(f"convergence.py: render failed: {' '.join(cmd)}\n{proc.stderr}")
    inp = oiio.ImageInput.open(out)
    spec = inp.spec()
    pixels = inp.read_image(oiio.FLOAT)
    inp.close()
    names = list(spec.channelnames)
    rgb = np.stack([pixels[:, :, names.index(c)] for c in "RGB"], axis=-1).astype(np.float64)
    return rgb, float(spec.get_string_attribute("refrender:renderSeconds", "0"))


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
    p.add_argument("--counts", default="16,64,256,1024")
    p.add_argument("--samplers", default="thesis,jittered3d,sobol")
    p.add_argument("--reference-count", type=int, default=16384)
    p.add_argument("--spp", type=int, default=4)
    p.add_argument("--out", default="convergence")
    a = p.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    counts = [int(c) for c in a.counts.split(",")]
    ref, _ = render(a.scene, os.path.join(a.out, "reference.exr"), a.res, a.spp, a.reference_count // a.spp,
                    "jittered3d", 1000003)
    rows = []
    for sampler in a.samplers.split(","):
        for count in counts:
            img, seconds = render(a.scene, os.path.join(a.out, f"{sampler}_{count}.exr"), a.res, a.spp,
                                  max(1, count // a.spp), sampler, 7)
            rows.append({"sampler": sampler, "samples": count, "seconds": seconds,
                         "rmse": float(np.sqrt(np.mean((img - ref) ** 2)))})
    with open(os.path.join(a.out, "convergence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["sampler", "samples", "seconds", "rmse"])
        w.writeheader()
        w.writerows(rows)
    plot(rows, os.path.join(a.out, "convergence.png"))
    fits = {s: fit_slope([r["samples"] for r in rows if r["sampler"] == s], [r["rmse"] for r in rows if r["sampler"] == s])
            for s in dict.fromkeys(r["sampler"] for r in rows)}
    base = "thesis" if "thesis" in fits else next(iter(fits))
    target = np.exp(fits[base][1]) * counts[-1] ** fits[base][0]  # base's fitted RMSE at the largest count
    print(f"{'sampler':12} {'slope':>7} {'samples for thesis RMSE at ' + str(counts[-1]):>34}")
    for s, (slope, icpt) in fits.items():
        needed = np.exp((np.log(target) - icpt) / slope)
        print(f"{s:12} {slope:7.3f} {needed:20.0f} ({counts[-1] / needed:.2f}x fewer)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
