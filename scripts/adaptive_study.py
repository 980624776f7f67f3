#!/usr/bin/python3
"""What adaptive allocation by sequence length (issue 58, lever 1) would
gain, measured by emulating it from fixed-length renders (src/bench/BENCH.md,
Time to error: the levers measured).

usage: adaptive_study.py SCENE.xml --tag NAME [--pilot 32] [--counts 32,64,...]
                         [--targets 0.1,0.01] [--rate 1.4] [--background-cost 1]
                         [--dir DIR] [-- REFRENDER OPTIONS...]

With sobol one batch of N samples gives a pixel the first N points of its
own scrambled sequence, so a render that gave pixel p one sequence of N_p
samples would hold, pixel for pixel, the value of the uniform render with
--tspp N_p and the same seed. So the adaptive image is assembled from
uniform renders with --tspp 32, 64, ... (seeds 21 and 22: two independent
adaptive images; error RMS(Y21 - Y22) / sqrt 2 over RGB, in 8-bit levels,
no reference and not the render's own error bars), its lengths chosen from
a pilot of two other seeds (11 and 12, --tspp PILOT), independent of the
final renders: the lengths cannot bias the values.

The allocation: per-pixel squared error e_p^2 at the pilot's length from
the pilot pair (|X11 - X12|^2 / 2, mean over RGB, averaged over 3x3
pixels, then the largest over 3x3: a pixel beside error whose pilots agreed
gets its neighbours' length; without it the 512x512 default scene's pixels
left at the pilot's 8 samples held 75% of the squared error and 0.05
came out 0.104), modelled as e_p^2 (N / PILOT)^(-2 rate); a sample of pixel p
costs c_p (1, or --background-cost where the longest render's alpha is 0).
Minimising sum c_p N_p at the target mean squared error gives N_p
proportional to (e_p^2 / c_p)^(1 / (2 rate + 1)); the constant is the
smallest that meets the target as predicted, each N_p rounded up to a count
rendered (powers of two: sobol's nets) and at least the pilot's (a pixel
whose 16-sample pilot pair agreed can still be wrong at 8: allowed shorter,
the default scene missed 0.03 by 2.8x). Cost: the CPU seconds (user + sys,
of the render process) a pixel-sample of the longest uniform render took,
times sum c_p N_p, plus the pilot's two renders' samples at that cost (in
one process the scene would be loaded once). Against it: the uniform
count with the same measured error (from the fit of the last four uniform
errors) at the same cost a pixel-sample.

Renders go to DIR (default out/adaptive), named TAG_p<N>_s<seed>.exr and
TAG_n<N>_s<seed>.exr, with their CPU seconds in DIR/times.txt; ones there
already are reused. REFRENDER (environment) names the binary (default
build/refrender). Prints one block a target."""
import argparse
import math
import os
import resource
import subprocess
import sys

import pydeps

pydeps.require(*pydeps.IMAGE_MODULES)  # a missing package: one line, not a traceback

import numpy as np
import OpenImageIO as oiio

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.environ.get("REFRENDER", os.path.join(ROOT, "build", "refrender"))
PILOT_SEEDS, FINAL_SEEDS = (11, 12), (21, 22)


def read_times(path):
    times = {}
    if os.path.exists(path):
        for line in open(path):
            f = line.split()
            if len(f) == 4:
                times[f[0]] = float(f[1]) + float(f[2])
    return times


def render(args, name, tspp, seed, times):
    """One render into DIR/name.exr, unless there; its CPU seconds."""
    out = os.path.join(args.dir, name + ".exr")
    if name in times and os.path.exists(out):
        return times[name]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [BIN, args.scene, "--spp", "1", "--tspp", str(tspp), "--seed", str(seed), "--quiet", "-o", out] + args.extra
    subprocess.run(cmd, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    with open(os.path.join(args.dir, "times.txt"), "a") as f:
        f.write(f"{name} {cpu:.3f} 0 0\n")
    times[name] = cpu
    print(f"{name}: {cpu:.1f} CPU s", file=sys.stderr)
    return cpu


def channels(path):
    image = oiio.ImageInput.open(path)
    if not image:
        sys.exit(f"adaptive_study.py: cannot read {path}: {oiio.geterror()}")
    pixels = np.asarray(image.read_image(format="float"), dtype=np.float64)
    image.close()
    return pixels[..., :3] * 255.0, pixels[..., 3]


def blur3(x):
    p = np.pad(x, 1, mode="edge")
    return sum(p[i:i + x.shape[0], j:j + x.shape[1]] for i in range(3) for j in range(3)) / 9.0


def dilate1(x):
    """Each pixel's largest value over its 3x3 neighbourhood."""
    p = np.pad(x, 1, mode="edge")
    return np.max([p[i:i + x.shape[0], j:j + x.shape[1]] for i in range(3) for j in range(3)], axis=0)


def rms_pair(a, b):
    return math.sqrt(float(np.mean((a - b) ** 2)) / 2)


def allocate(e2, cost, args):
    """The lengths (powers of two in the counts) meeting the target as predicted, least cost."""
    with np.errstate(divide="ignore"):  # a free pixel (cost 0) with error takes the longest length
        weight = np.where(e2 > 0, (e2 / cost) ** (1.0 / (2 * args.rate + 1)), 0.0)
    counts = np.array(args.counts)
    for k in np.exp(np.linspace(math.log(1e-4), math.log(1e7), 1200)):
        wanted = np.maximum(k * weight, max(counts[0], args.pilot))  # the pilot says nothing of shorter ones
        lengths = counts[np.minimum(np.searchsorted(counts, wanted), len(counts) - 1)]
        if math.sqrt(float(np.mean(e2 * (lengths / args.pilot) ** (-2 * args.rate)))) <= args.target:
            return lengths
    return np.full(e2.shape, counts[-1])


def study(args, pilot, uniform, per_sample, cost, pilot_cpu, fit):
    e2 = dilate1(blur3(np.mean((pilot[0] - pilot[1]) ** 2, axis=2) / 2))
    lengths = allocate(e2, cost, args)
    ya, yb = np.zeros_like(pilot[0]), np.zeros_like(pilot[0])
    for n in args.counts:
        mask = lengths == n
        ya[mask], yb[mask] = uniform[n][0][mask], uniform[n][1][mask]
    error = rms_pair(ya, yb)
    final_cpu = per_sample * float((cost * lengths).sum())
    slope, icpt = fit
    n_same = math.exp((math.log(error) - icpt) / slope)
    uniform_cpu = per_sample * float(cost.sum()) * n_same
    spread = {int(n): int((lengths == n).sum()) for n in args.counts if (lengths == n).any()}
    print(f"\ntarget {args.target} levels: adaptive measured {error:.4g} levels, mean length {lengths.mean():.0f} "
          f"(pixels a length: {spread})\n  CPU s: final {final_cpu:.1f} + pilot {pilot_cpu:.1f}; uniform at the same "
          f"error N = {n_same:.0f}, {uniform_cpu:.1f}: factor {uniform_cpu / (final_cpu + pilot_cpu):.2f}x "
          f"({uniform_cpu / final_cpu:.2f}x without the pilot)")


def parse():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                usage=__doc__.split("\n\n")[1].removeprefix("usage: "))
    p.add_argument("scene")
    p.add_argument("--tag", required=True, help="name prefix of the renders")
    p.add_argument("--pilot", type=int, default=32, help="the pilot's samples a pixel (default 32)")
    p.add_argument("--counts", default="32,64,128,256,512,1024,2048", help="the uniform renders' counts")
    p.add_argument("--targets", default="0.1,0.01", help="image RMS targets, 8-bit levels")
    p.add_argument("--rate", type=float, default=1.4, help="error ~ N^-rate in the allocation (default 1.4)")
    p.add_argument("--background-cost", type=float, default=1.0,
                   help="a background pixel-sample's cost against a foreground one's (default 1)")
    p.add_argument("--dir", default=os.path.join(ROOT, "out", "adaptive"))
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    args = p.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    args.extra, args.counts = extra, sorted(int(c) for c in args.counts.split(","))
    return args


def main():
    args = parse()
    os.makedirs(args.dir, exist_ok=True)
    times = read_times(os.path.join(args.dir, "times.txt"))
    name = lambda kind, n, s: f"{args.tag}_{kind}{n}_s{s}"
    for s in PILOT_SEEDS:
        render(args, name("p", args.pilot, s), args.pilot, s, times)
    cpu = {n: [render(args, name("n", n, s), n, s, times) for s in FINAL_SEEDS] for n in args.counts}
    path = lambda kind, n, s: os.path.join(args.dir, name(kind, n, s) + ".exr")
    pilot = [channels(path("p", args.pilot, s))[0] for s in PILOT_SEEDS]
    uniform = {n: [channels(path("n", n, s))[0] for s in FINAL_SEEDS] for n in args.counts}
    top = args.counts[-1]
    cost = np.where(channels(path("n", top, FINAL_SEEDS[0]))[1] > 0, 1.0, args.background_cost)
    per_sample = float(np.mean(cpu[top])) / (float(cost.sum()) * top)
    # the pilot's samples at the same cost a sample (one process would load the scene once)
    pilot_cpu = per_sample * float(cost.sum()) * args.pilot * len(PILOT_SEEDS)
    errors = {n: rms_pair(*uniform[n]) for n in args.counts}
    fit = np.polyfit(np.log(args.counts[-4:]), np.log([errors[n] for n in args.counts[-4:]]), 1)
    print("uniform: " + ", ".join(f"{n}: {errors[n]:.4g} lv, {np.mean(cpu[n]):.1f} CPU s" for n in args.counts))
    print(f"fit of the last four: error ~ N^{fit[0]:.2f}")
    for target in (float(t) for t in args.targets.split(",")):
        args.target = target
        study(args, pilot, uniform, per_sample, cost, pilot_cpu, fit)


if __name__ == "__main__":
    main()
