#!/usr/bin/python3
"""How far an N-frame average is from the motion-blurred ground truth.

Deblurring benchmarks make a blurred image by averaging N sharp renders at
times spread over the exposure (N = 10 Deblur-NeRF, 16 splat-transform, 51
BAD-Gaussians) and call it ground truth. This script renders those N sharp
frames of a scene with refrender (`--time t`, the same pixel filter, blur
space and size as the reference) at the uniform times a benchmark would use,
averages them, and measures each average against refrender's converged time
integral (the reference, with its per-pixel standard errors): RMSE, the
RMSE with the reference's own noise taken out, PSNR, the largest error, the
RMSE in units of the reference's noise (near 1: the difference is the
reference's noise), and the share of pixels within 3 standard errors.

usage: nframe_average.py SCENE.xml [--reference GT.exr] [--n 10,16,51]
           [--times midpoint|endpoints] [--out DIR] [--json F] [--plot F.png] [--figure F.png]
           [-- refrender options for every render, e.g. --res 128x128 -D name=v]

Without --reference the reference is rendered first (--batches 16, the
scene's own pixel filter unless given after --). The frames' times are
open + (k + 0.5) / N (close - open) (midpoint: the midpoint rule, what a
box a(t) integrates) or open + k / (N - 1) (close - open) (endpoints, as
datasets that include the shutter's ends). Only a box a(t) is compared: an
unweighted average of frames approximates nothing else."""
import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import imagecompare

ROOT = Path(__file__).resolve().parent.parent


class Failure(Exception):
    pass


def refrender():
    return os.environ.get("REFRENDER", str(ROOT / "build" / "refrender"))


def run(args, what):
    proc = subprocess.run([refrender(), *map(str, args)], capture_output=True, text=True)
    if proc.returncode:
        raise Failure(f"{what}: refrender failed: {proc.stderr.strip()}")


def frame_times(open_, close, n, kind):
    if kind == "endpoints":
        if n < 2:
            raise Failure("--times endpoints needs N >= 2")
        return [open_ + (close - open_) * k / (n - 1) for k in range(n)]
    return [open_ + (close - open_) * (k + 0.5) / n for k in range(n)]


def reference_settings(path):
    """The shutter, pixel filter, blur space and size of a refrender reference."""
    ch, _, header = imagecompare.read_channels(path, unassociated_alpha=False)
    for key in ("refrender:shutterOpen", "refrender:shutterClose", "refrender:weightFunction"):
        if key not in header:
            raise Failure(f"{path}: not a refrender render (no {key})")
    if str(header["refrender:weightFunction"]).split()[0] != "box":
        raise Failure(f"{path}: its a(t) is '{header['refrender:weightFunction']}': an unweighted N-frame average "
                      "approximates a box a(t) only")
    if "stderr.R" not in ch:
        raise Failure(f"{path}: no standard errors (render the reference with --batches >= 2)")
    return {"open": float(header["refrender:shutterOpen"]), "close": float(header["refrender:shutterClose"]),
            "filter": header.get("refrender:pixelFilter", "box"), "blur": header.get("refrender:blurSpace", "model"),
            "res": header["refrender:resolution"], "header": header, "path": path}


# What must agree between the reference and a frame for the comparison to
# mean anything: the same scene file, inputs (models, cameras), -D
# parameters and Gaussian semantics, at the same size.
SAME_SCENE = ("refrender:sceneHash", "refrender:inputsHash", "refrender:parametersHash", "refrender:gaussiansHash",
              "refrender:resolution", "refrender:pixelFilter", "refrender:blurSpace")


def check_same_scene(settings, frame_path, frame_header, frame_shape, ref_shape):
    """A reference of another scene, model, parameters or size gives a plausible table: refuse it."""
    for key in SAME_SCENE:
        want, got = settings["header"].get(key), frame_header.get(key)
        if want is not None and got is not None and str(want) != str(got):
            raise Failure(f"{settings['path']}: its {key} is '{want}' but this scene renders '{got}' "
                          f"({frame_path}): the reference is of another scene, model, parameters or settings")
    if frame_shape != ref_shape:
        raise Failure(f"{settings['path']}: {ref_shape[1]}x{ref_shape[0]} pixels (a crop window?) but the frames are "
                      f"{frame_shape[1]}x{frame_shape[0]}: render the reference whole, at the frames' --res")


def read_rgba(path):
    ch, _, _ = imagecompare.read_channels(path, unassociated_alpha=False)
    return np.stack([ch[c] for c in "RGBA"], axis=-1).astype(np.float64), ch


def render_frames(scene, times, settings, extra, out_dir, cache, ref_shape):
    """The sharp frames at `times`, each rendered once (cache: time -> RGBA);
    the first checked to be of the reference's scene."""
    for i, t in enumerate(times):
        if t in cache:
            continue
        path = out_dir / f"frame_{t:.9f}.exr"
        print(f"nframe_average: frame {i + 1}/{len(times)} at t = {t:.6g}", file=sys.stderr)
        run([scene, "--pixel-filter", settings["filter"], "--blur-space", settings["blur"], "--res", settings["res"],
             "--quiet", *extra, "--time", repr(t), "--tspp", 1, "--batches", 1, "-o", path], f"frame at t = {t}")
        cache[t] = read_rgba(path)[0]
        if len(cache) == 1:
            check_same_scene(settings, path, imagecompare.read_channels(path, unassociated_alpha=False)[2],
                             cache[t].shape, ref_shape)
    return np.mean([cache[t] for t in times], axis=0)


def write_exr(path, rgba):
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(rgba.astype(np.float32))
    buf.specmod().channelnames = ["R", "G", "B", "A"]
    if not buf.write(str(path)):
        raise Failure(f"{path}: cannot write: {oiio.geterror()}")


def measure(avg, ref, se):
    """The average against the reference. The reference's own noise adds its
    variance se^2 to the expected squared difference (the frames do not
    depend on it), so sqrt(MSE - mean se^2) estimates the average's own
    error (RMSE*, 0 when the difference is all the reference's noise)."""
    d = avg[..., :3] - ref[..., :3]
    mse = float(np.mean(d ** 2))
    rmse, noise = math.sqrt(mse), float(np.sqrt(np.mean(se ** 2)))
    return {"RMSE": rmse, "RMSE*": math.sqrt(max(0.0, mse - noise ** 2)),
            "PSNR": math.inf if rmse == 0 else float(-20 * math.log10(rmse)), "max": float(np.abs(d).max()),
            "RMSE/noise": rmse / noise if noise > 0 else math.inf,
            "within 3 SE": float(np.mean(np.all(np.abs(d) <= 3 * se, axis=-1)))}


def table(rows, noise):
    lines = [f"reference noise (RMS standard error): {noise:.3g}", "",
             "| frames averaged | RMSE | RMSE without the reference's noise | PSNR dB | max error | RMSE / noise "
             "| pixels within 3 SE |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        lines.append(f"| {r['N']} | {r['RMSE']:.3g} | {r['RMSE*']:.3g} | {r['PSNR']:.1f} | {r['max']:.3g} | "
                     f"{r['RMSE/noise']:.1f} | {100 * r['within 3 SE']:.0f}% |")
    return "\n".join(lines)


def plot(rows, ref_se, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(4.5, 3.2), dpi=120)
    ax.loglog([r["N"] for r in rows], [r["RMSE"] for r in rows], "o-", label="N-frame average: RMSE")
    ax.loglog([r["N"] for r in rows], [max(r["RMSE*"], 1e-12) for r in rows], "s:",
              label="without the reference's noise")
    ax.axhline(ref_se, color="grey", ls="--", label="reference noise (RMS standard error)")
    ax.set_xlabel("frames averaged (N)")
    ax.set_ylabel("RMSE against the time integral")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)


def figure(ref, avg, n, path):
    """The reference, the N-frame average and the error map between them."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import flip
    err = np.abs(avg[..., :3] - ref[..., :3]).max(axis=-1)
    fig, axes = plt.subplots(1, 3, figsize=(9, 3.3), dpi=110)
    for ax, img, title in ((axes[0], ref, "time integral (refrender)"), (axes[1], avg, f"{n}-frame average")):
        ax.imshow(flip.linear_to_srgb(np.clip(img[..., :3], 0, 1)))
        ax.set_title(title, fontsize=9)
    shown = axes[2].imshow(err, cmap="inferno", vmin=0, vmax=max(float(np.percentile(err, 99.5)), 1e-12))
    axes[2].set_title(f"|{n}-frame average - integral|", fontsize=9)
    fig.colorbar(shown, ax=axes[2], fraction=0.046, pad=0.04)
    for ax in axes:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path)


def parse(argv):
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene")
    p.add_argument("--reference", help="the converged render (with standard errors); default: render one")
    p.add_argument("--n", default="10,16,51", help="frame counts, comma-separated (default 10,16,51)")
    p.add_argument("--times", choices=("midpoint", "endpoints"), default="midpoint")
    p.add_argument("--out", default="nframe", help="directory for the frames and averages (average_N.exr; "
                   "default nframe/)")
    p.add_argument("--json")
    p.add_argument("--plot", help="error against N, log-log (PNG)")
    p.add_argument("--figure", help="the reference, the first N's average and its error map (PNG)")
    args = p.parse_args(argv)
    try:
        args.counts = [int(v) for v in args.n.split(",")]
    except ValueError:
        p.error(f"--n: expected counts such as 10,16,51, got '{args.n}'")
    if any(n < 1 for n in args.counts):
        p.error("--n: counts must be >= 1")
    return args, extra


def main(argv):
    args, extra = parse(argv)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise Failure(f"--out {out}: exists and is not a directory (the frames and averages go into a directory)")
    out.mkdir(parents=True, exist_ok=True)
    if not Path(args.scene).is_file():
        raise Failure(f"{args.scene}: no such scene file")
    reference = args.reference
    if not reference:
        reference = out / "reference.exr"
        print("nframe_average: rendering the reference", file=sys.stderr)
        run([args.scene, "--batches", 16, "--quiet", *extra, "-o", reference], "reference")
    settings = reference_settings(reference)
    ref, ch = read_rgba(reference)
    se = np.stack([ch[f"stderr.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    cache, rows = {}, []
    for n in args.counts:
        times = frame_times(settings["open"], settings["close"], n, args.times)
        avg = render_frames(args.scene, times, settings, extra, out, cache, ref.shape)
        write_exr(out / f"average_{n}.exr", avg)
        rows.append({"N": n, **measure(avg, ref, se)})
        if args.figure and n == args.counts[0]:
            figure(ref, avg, n, args.figure)
    noise = float(np.sqrt(np.mean(se ** 2)))
    print(table(rows, noise))
    if args.json:
        Path(args.json).write_text(json.dumps({"reference": str(reference), "times": args.times,
                                               "reference_noise": noise, "rows": rows}, indent=1))
    if args.plot:
        plot(rows, noise, args.plot)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (Failure, imagecompare.CompareError) as e:
        print(f"nframe_average: {e}", file=sys.stderr)
        sys.exit(1)
