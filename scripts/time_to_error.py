#!/usr/bin/python3
"""Time to equal error: --time-integration exact against sampled time
(Owen-scrambled Sobol' at several spp x tspp splits), measured in one run
on the same machine (`make bench` runs it; src/bench/BENCH.md).

usage: time_to_error.py [--scenes default,diagonal,...] [--res WxH] [--out DIR]
                        [--targets 0.01,0.002] [--threads N] [--max-seconds S]

For each scene: a reference (sobol 256 x 64, another seed), then renders of
increasing cost with each method; RMSE over RGB against the reference and
wall-clock seconds. For each target RMSE it prints the seconds each method
needs to reach it (log-log interpolation between the two renders around
it; '>' the largest render's time when none reached it) and the ratio
sampled / exact (above 1: exact is faster). Writes DIR/time_to_error.csv
(scene, method, spp, tspp, seconds, rmse)."""
import argparse
import csv
import math
import os
import subprocess
import sys
import time

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import numpy as np

import imagecompare

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))
SCENES = "default,diagonal,rotation,towards_camera,crossing,camera_pan,large"
# (spp, tspp) ladders: sampled splits chosen to include the best of each cost
SAMPLED = [(4, 4), (16, 4), (16, 16), (64, 16), (16, 64), (64, 64)]
EXACT = [1, 4, 16]


# refrender's words when exact time refuses a scene beyond its bounds
# (src/EXACT.md, Bounds): a measurement (exact cannot do it), not a failure.
REFUSED = "exact time cannot finish this scene"


def render(scene, out, args, res, threads):
    """Wall-clock seconds of the render; None when exact time refused it."""
    cmd = [BIN, scene, "--res", res, "--threads", str(threads), "-o", out, "--quiet", *map(str, args)]
    start = time.monotonic()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.monotonic() - start
    if proc.returncode and REFUSED in proc.stderr:
        return None
    if proc.returncode:
        sys.exit(f"time_to_error: {' '.join(cmd)} failed:\n{proc.stderr}")
    return seconds


def rgb(path):
    ch, _, _ = imagecompare.read_channels(path, unassociated_alpha=False)
    return np.stack([ch[c] for c in "RGB"], axis=-1).astype(np.float64)


def time_to(points, target):
    """Seconds to reach target RMSE from (seconds, rmse) points, log-log;
    (None, None) without any point."""
    if not points:
        return None, None
    pts = sorted(points)
    best = min(pts, key=lambda p: p[1])
    if best[1] > target:
        return None, pts[-1][0]
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 > target >= e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), None
    reached = [p for p in pts if p[1] <= target]
    return reached[0][0], None


def measure_scene(name, args, writer):
    scene = os.path.join(ROOT, "scenes", name + ".xml")
    ref = os.path.join(args.out, f"{name}_ref.exr")
    render(scene, ref, ["--sampler", "sobol", "--spp", 256, "--tspp", 64, "--seed", 1000], args.res, args.threads)
    reference = rgb(ref)
    results = {"sampled": [], "exact": []}
    runs = [("sampled", s, t, ["--sampler", "sobol", "--spp", s, "--tspp", t]) for s, t in SAMPLED]
    runs += [("exact", s, 1, ["--time-integration", "exact", "--spp", s]) for s in EXACT]
    for method, spp, tspp, extra in runs:
        slowest = max((r[0] for r in results[method]), default=0.0)
        if slowest * 4 > args.max_seconds:  # the next render costs about 4x: skip, say so
            print(f"time_to_error: {name}: {method} {spp}x{tspp} skipped (the previous took {slowest:.0f} s)",
                  file=sys.stderr)
            continue
        out = os.path.join(args.out, f"{name}_{method}_{spp}x{tspp}.exr")
        seconds = render(scene, out, extra, args.res, args.threads)
        if seconds is None:  # more positions cannot make it finish either
            print(f"time_to_error: {name}: exact time refused the scene (beyond its bounds)", file=sys.stderr)
            break
        rmse = float(np.sqrt(np.mean((rgb(out) - reference) ** 2)))
        results[method].append((seconds, rmse))
        writer.writerow([name, method, spp, tspp, f"{seconds:.3f}", f"{rmse:.6g}"])
        args.csv_file.flush()  # a run cut short keeps what it measured
    return results


def cell(t, floor):
    if t is None and floor is None:
        return "refused"
    return f"{t:.2f}" if t is not None else f"> {floor:.2f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenes", default=SCENES, help="comma-separated names in scenes/ (default: %(default)s)")
    ap.add_argument("--res", default="48x36", help="image size of every render (default: %(default)s)")
    ap.add_argument("--targets", default="0.01,0.002", help="target RMSEs (default: %(default)s)")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1, help="render threads (default: all cores)")
    ap.add_argument("--max-seconds", type=float, default=120.0,
                    help="skip a method's costlier renders once the next would take longer (default: %(default)s)")
    ap.add_argument("--out", default="out/time_to_error", help="directory for renders and CSV (default: %(default)s)")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    targets = [float(t) for t in args.targets.split(",")]
    rows = []
    with open(os.path.join(args.out, "time_to_error.csv"), "w", newline="") as f:
        args.csv_file = f
        writer = csv.writer(f)
        writer.writerow(["scene", "method", "spp", "tspp", "seconds", "rmse"])
        for name in args.scenes.split(","):
            if not os.path.exists(os.path.join(ROOT, "scenes", name + ".xml")):
                sys.exit(f"time_to_error: no scene scenes/{name}.xml")
            res = measure_scene(name, args, writer)
            for target in targets:
                ts, fs = time_to(res["sampled"], target)
                te, fe = time_to(res["exact"], target)
                ratio = f"{ts / te:.2f}" if ts is not None and te is not None else "n/a"
                rows.append(f"| {name} | {target:g} | {cell(ts, fs)} | {cell(te, fe)} | {ratio} |")
            best = lambda m: min((r[1] for r in res[m]), default=math.nan)  # noqa: E731
            print(f"time_to_error: {name}: lowest RMSE sampled {best('sampled'):.5f}, exact {best('exact'):.5f}",
                  file=sys.stderr)
            print("\n".join(rows[-len(targets):]), file=sys.stderr)
    print(f"\nTime to equal error at {args.res} ({args.threads} threads; seconds, sobol sampled vs exact)\n")
    print("| scene | target RMSE | sampled s | exact s | sampled / exact |")
    print("| --- | --- | --- | --- | --- |")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
