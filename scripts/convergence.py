#!/usr/bin/python3
"""Convergence study: RMSE against a high-sample reference as the sample
count grows, for each sampler.

usage: convergence.py SCENE [--res WxH] [--counts 25,100,400,1600]
                      [--samplers thesis,jittered3d,sobol] [--reference-count 25600]
                      [--baseline 400] [--out DIR] [--progress-every SECONDS]

A count N of samples per pixel is split as refrender's default 4 x 100 is:
spp : tspp = 1 : 25, i.e. spp = K*K with K = max(1, round(sqrt(0.2 sqrt N)))
and tspp = N / (K*K) (N = 400 gives exactly --spp 4 --tspp 100); every
sampler gets the same split. The reference is a jittered3d render with
--reference-count samples and another seed. Writes DIR/convergence.csv
(sampler, samples, spp, tspp, seconds, rmse), DIR/convergence.png (RMSE vs
samples and vs render time, log-log), and prints each sampler's fitted slope
of log RMSE against log samples and the samples it needs (from its fitted
line) to reach the thesis sampler's measured RMSE at --baseline samples.
The default DIR, out/convergence, is where scripts/cost_error.py's example
reads the CSV from. Progress goes to stderr: a line per render (with an
estimate of the time left, from the seconds per sample so far) and, while a
render runs, a line every --progress-every seconds."""
import argparse
import csv
import os
import subprocess
import sys
import time

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


def progress(text):
    print(f"convergence.py: {text}", file=sys.stderr, flush=True)


def run_render(cmd, what, every):
    """Runs one render, saying on stderr every `every` seconds (0: never)
    that it still runs: the reference alone can take minutes."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    while True:
        try:
            _, err = proc.communicate(timeout=every if every > 0 else None)
            return proc.returncode, err
        except subprocess.TimeoutExpired:
            progress(f"{what}: still rendering after {time.monotonic() - start:.1f} s")


def render(scene, out, res, spp, tspp, sampler, seed, what, every):
    cmd = [BIN, scene, "--res", res, "--spp", str(spp), "--tspp", str(tspp), "--sampler", sampler,
           "--seed", str(seed), "-o", out, "--quiet"]
    returncode, err = run_render(cmd, what, every)
    if returncode:
        sys.exit(f"convergence.py: render failed: {' '.join(cmd)}\n{err}")
    channels, _, header = imagecompare.read_channels(out)
    rgb = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
    return rgb, float(header.get("refrender:renderSeconds", "0"))


class Progress:
    """Counts renders and samples done; estimates the time left from the
    wall-clock seconds per sample so far (a render's cost grows with its
    samples per pixel, whatever the sampler)."""

    def __init__(self, jobs):
        self.jobs, self.done, self.samples_done = jobs, 0, 0
        self.samples_total = sum(spp * tspp for _, spp, tspp in jobs)
        self.start = time.monotonic()

    def label(self):
        name, spp, tspp = self.jobs[self.done]
        return f"[{self.done + 1}/{len(self.jobs)}] {name}, {spp * tspp} samples ({spp} x {tspp})"

    def finished(self, label, rmse=None):
        _, spp, tspp = self.jobs[self.done]
        self.done += 1
        self.samples_done += spp * tspp
        elapsed = time.monotonic() - self.start
        left = elapsed / self.samples_done * (self.samples_total - self.samples_done)
        error = "" if rmse is None else f", RMSE {rmse:.4g}"
        progress(f"{label}: done{error}; {elapsed:.0f} s elapsed, about {left:.0f} s left")


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


def build_parser():
    p = argparse.ArgumentParser(prog="convergence.py", description=__doc__.split("\n\n")[0],
                                epilog=__doc__.split("\n\n", 2)[2], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("scene", help="the scene file to render (e.g. scenes/default.xml)")
    p.add_argument("--res", default="128x128", metavar="WxH", help="image size of every render (default: %(default)s)")
    p.add_argument("--counts", default="25,100,400,1600", metavar="N,N,...",
                   help="samples per pixel of the measured renders, each split as spp x tspp as described below "
                        "(default: %(default)s)")
    p.add_argument("--samplers", default="thesis,jittered3d,sobol", metavar="NAME,...",
                   help="refrender --sampler values to measure (default: %(default)s)")
    p.add_argument("--reference-count", type=int, default=25600, metavar="N",
                   help="samples per pixel of the jittered3d reference, rendered first with another seed "
                        "(default: %(default)s)")
    p.add_argument("--baseline", type=int, default=400, metavar="N",
                   help="one of --counts: each sampler is reported with the samples it needs to reach the "
                        "thesis sampler's RMSE at this count (default: %(default)s)")
    p.add_argument("--out", default="out/convergence", metavar="DIR",
                   help="directory for convergence.csv, convergence.png and the renders (default: %(default)s, "
                        "where scripts/cost_error.py's example reads the CSV)")
    p.add_argument("--progress-every", type=float, default=30.0, metavar="SECONDS",
                   help="while a render runs, say so on stderr every SECONDS (0: only a line per render; "
                        "default: %(default)g)")
    return p


def main(argv=None):
    a = build_parser().parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    counts = [int(c) for c in a.counts.split(",")]
    if a.baseline not in counts:
        sys.exit("convergence.py: --baseline must be one of --counts")
    samplers = a.samplers.split(",")
    jobs = [("reference jittered3d", *split(a.reference_count))] + [(s, *split(c)) for s in samplers for c in counts]
    status = Progress(jobs)
    label = status.label()
    ref, _ = render(a.scene, os.path.join(a.out, "reference.exr"), a.res, *split(a.reference_count),
                    "jittered3d", 1000003, label, a.progress_every)
    status.finished(label)
    rows = []
    for sampler in samplers:
        for count in counts:
            spp, tspp = split(count)
            label = status.label()
            img, seconds = render(a.scene, os.path.join(a.out, f"{sampler}_{count}.exr"), a.res, spp, tspp,
                                  sampler, 7, label, a.progress_every)
            rows.append({"sampler": sampler, "samples": spp * tspp, "spp": spp, "tspp": tspp,
                         "seconds": seconds, "rmse": float(np.sqrt(np.mean((img - ref) ** 2)))})
            status.finished(label, rows[-1]["rmse"])
    with open(os.path.join(a.out, "convergence.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["sampler", "samples", "spp", "tspp", "seconds", "rmse"])
        w.writeheader()
        w.writerows(rows)
    plot(rows, os.path.join(a.out, "convergence.png"))
    fits = {s: imagecompare.loglog_fit([r["samples"] for r in rows if r["sampler"] == s], [r["rmse"] for r in rows if r["sampler"] == s])
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
