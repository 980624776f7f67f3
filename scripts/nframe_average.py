#!/usr/bin/python3
"""How far an N-frame average is from the motion-blurred ground truth.

Deblurring benchmarks make a blurred image by averaging N sharp renders at
times spread over the exposure (N = 10 Deblur-NeRF, 16 splat-transform, 31
BAD-Gaussians' data) and call it ground truth. This script renders those N
sharp frames of a scene with refrender (`--time t`, the same pixel filter,
blur space and size as the reference) and measures what a benchmark makes of
them against refrender's converged time integral (the reference, with its
per-pixel standard errors).

usage: nframe_average.py SCENE.xml [--reference GT.exr] [--n 10,16,51]
           [--times midpoint|endpoints] [--procedure P[,P...] ...] [--display srgb|identity]
           [--out DIR] [--json F] [--plot F.png] [--figure F.png]
           [-- refrender options for every render, e.g. --res 128x128 -D name=v]

Without --reference the reference is rendered first (--batches 16, the
scene's own pixel filter unless given after --). Only a box a(t) is
compared: an unweighted average of frames approximates nothing else.

Float averages (without --procedure)
  For each N of --n, the frames at open + (k + 0.5) / N (close - open)
  (midpoint: the midpoint rule, what a box a(t) integrates) or open + k /
  (N - 1) (close - open) (endpoints, as datasets that include the shutter's
  ends), averaged as floats in the reference's blur space: RMSE, the RMSE with
  the reference's own noise taken out, PSNR, the largest error, the RMSE in
  units of the reference's noise (near 1: the difference is the reference's
  noise) and the share of pixels within 3 standard errors.

Blur-synthesis procedures (--procedure)
  A procedure is the whole recipe by which a dataset turns sharp frames into
  its blurred image. Its parts:
    times   midpoint (k + 1/2)/N, endpoints k/(N-1) (both shutter ends
            included), or random (uniform, seeded by seed=S, an integer >= 0,
            sorted);
    n       the number of frames N, at most 256: each frame is a refrender
            run and stays in memory (32 bytes a pixel), and at 256 the
            midpoint rule's error is 1/650 of its error at 10;
    frames  how the renderer that made the dataset wrote each sharp frame as
            8-bit: round, floor, or none (float frames);
    space   what is averaged: model (the renderer's own float values, in the
            reference's blur space: no encoding), srgb (the 8-bit values decoded
            with the sRGB curve), gamma2.2 (value^2.2), gamma1 (the encoded
            values themselves); the mean is encoded back with the inverse;
    sum     how the mean is accumulated: weighted (x_k * (1/N) summed by np.sum
            over the frame axis, float64: in frame order for image-sized
            stacks), float32 (float32 sum of x_k in frame order, then / N,
            float32), mean (numpy's float64 mean);
    result  the blurred image's 8-bit quantization after clipping to [0, 1]:
            floor (numpy astype(uint8): truncation), round, or none.
  Named presets (write NAME or NAME:key=value,... to change parts by hand, e.g.
  deblur-nerf:result=round or custom:times=random,seed=3,n=16,space=srgb):

  deblur-nerf   endpoints, n 10, frames round, space gamma2.2, sum weighted,
                result floor. limacv/Deblur-NeRF aa9d6ce5ca4416f5c6cd371aecda9561e39e2007
                scripts/synthe2poses.py (unchanged since 5a1b084):
                  :53-55 the frames are 8-bit PNGs (cv2.imread), each / 255 (float64);
                  :57-58 np.array of them, ** 2.2;
                  :59-60 weight np.ones_like * (1 / N), np.sum(imgs * weight, axis=0):
                         x_k * (1/N) summed in frame order;
                  :61 ** (1 / 2.2); :62 (np.clip(img, 0, 1) * 255).astype(np.uint8):
                         truncation.
                N is the dataset's transforms.json "blurcount" (:53): 10 in the
                released synthetic scenes. The frames' times and PNG writing are in
                the script inside the dataset's .blend files (README.md:69-72), not
                in the repository: endpoints and Blender's rounding are assumed.
  bad-gaussians BAD-NeRF's and BAD-Gaussians' synthetic data (BlenderCV):
                endpoints, n 31, frames round, space gamma1, sum float32, result
                floor. LingzheZhao/BlenderCV 9e0b92b4520ebd5512561e1699f7f04290a65508
                  scripts/generate_blur_trajectory_from_tum.py:38-44 virtual frame i at
                    capture - T/2 + i T / (N - 1 + 1e-8) (endpoints; the 1e-8 moves the
                    last frame 3e-10 T early, far below any reference's resolution: the
                    emulation uses k / (N - 1)); :78 N = 31 by default;
                  scripts/render_by_tum_pose.py:158 dither_intensity 0, :161 PNG: Blender
                    writes each frame rounded, without dither;
                  scripts/images_avg.py:17 PNG values read as stored (ignoregamma), :29
                    / 255.0 (float64), :32-33 cast to float32; :59 imgs_ += frame
                    (float32, frame order); :62 / blur_num (float32); :12, :65
                    (255 * np.clip(x, 0, 1)).astype(np.uint8): truncation; :107
                    blur_num = 31 (README.md:72: it must equal N_VIRT_CAMS).
  3dgs-deblur   endpoints, n 10, frames none, space gamma2.2, sum weighted, result
                none. Its own re-render of Deblur-NeRF's scenes "uses gamma = 2.2"
                (SpectacularAI/3dgs-deblur f7df8e0b82874a2bf68bf39e8d1db55e8e0ebd5e
                README.md:152); process_synthetic_inputs.py:152,167 copies those
                blurred PNGs as they come, so the script that averaged them is not
                public, and :157 (velocity = (last blur pose - first) / exposure) has
                the frames span the exposure, both ends included. What is public is
                the blur its model fits, emulated here: the gsplat fork (pinned
                64154bb463039919cbdff27daa57fa31849763a8) gsplat/cuda/csrc/forward.cu:363
                sample k at (k/(n-1) - 1/2) T_e, :361,:430 each weighted 1/n in the
                float sum; the nerfstudio fork (pinned e64a8844576d20fd9c46c9e894ae47ab22f0e08e)
                nerfstudio/models/splatfacto.py:169 n = 10, :173 gamma 2.2, :880
                clamp(max=1) ** (1/gamma); colours are linear = display^2.2 (:222).
                Float frames, float result; its float32 GPU sums are emulated in
                float64 (no byte depends on it: nothing is quantized).
  midpoint      midpoint, n 10, frames none, space model, sum mean, result none:
                refrender's own quadrature, the float averages above.

  Blender's 8-bit rounding (frames round): blender/blender
  source/blender/blenlib/intern/math_base_inline.c unit_float_to_uchar_clamp (read
  in a 3.x-era copy whose commit the code index does not record),
  (uchar)(255 v + 0.5) with v <= 0 -> 0 and v > 1 - 0.5/255 -> 255, in float32
  as Blender (the display values are cast to float32 first; tested to agree
  with that formula on 2e6 values and the ties). The sharp frames' 8-bit
  values are encoded with --display: srgb (the render is linear light; the
  sRGB curve, as Blender's Standard view transform) or identity (the render's
  values are already display values, as a Gaussian model's colours, which are
  the training images' values). Default: srgb for a --blur-space linear
  reference, identity for model.

  pow: the gamma-2.2 rules use numpy's float64 power (x ** 2.2, y ** (1 /
  2.2)) on arrays, the very call synthe2poses.py:58,61 makes, so the emulation
  matches the source on any one machine. numpy's vectorized pow may differ from
  C's pow() by an ulp (numpy builds using AVX512 SVML), which truncation can turn
  into a whole level; on the machine that measured src/TRAJECTORIES.md's table (numpy 1.24.2, no
  AVX512) numpy's power equals C's pow for all 256 8-bit values and 1e5 points of
  [0, 1]. 3dgs-deblur's torch float32 pow on the GPU is not emulated bit for bit.

  Measurement. Each procedure's result is an encoded (display) image E. The
  truth is the reference integral encoded the same way, without quantization:
  T = display(clip(R, 0, 1)). Reported in two spaces, both said in the output:
    display  E - T in 8-bit levels (x 255): mean (the bias, with the 1-sigma the
             reference's noise puts on it), the mean over pixels that move (some
             two sharp frames differ by more than half a level: the run's frames
             and 16 at the midpoint times (k + 1/2)/16, rendered for this, as a
             procedure's own few frames miss what moves between them, and one
             frame sees no motion), RMSE, RMSE without the reference's noise,
             max; the reference's
             standard error carried through the encoding's slope;
    linear   decode(E) - clip(R, 0, 1) (decode: the sRGB curve for --display
             srgb): the RMSE, the bias and RMSE / the reference's noise.
  Render the reference with --blur-space linear: a sensor integrates linear
  light, so that reference is the true blur of a scene whose model colours are
  sRGB-encoded, and the frames follow its blur space."""
import argparse
import dataclasses
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import flip
import imagecompare
import safefiles

ROOT = Path(__file__).resolve().parent.parent


class Failure(Exception):
    pass


def refrender():
    return os.environ.get("REFRENDER", str(ROOT / "build" / "refrender"))


def run(args, what):
    try:
        proc = subprocess.run([refrender(), *map(str, args)], capture_output=True, text=True)
    except OSError as e:
        raise Failure(f"{what}: cannot run {refrender()}: {e.strerror} (set REFRENDER to the binary)") from None
    if proc.returncode:
        raise Failure(f"{what}: refrender failed: {proc.stderr.strip()}")


def frame_times(open_, close, n, kind):
    if kind == "endpoints":
        if n < 2:
            raise Failure("--times endpoints needs N >= 2")
        return [open_ + (close - open_) * k / (n - 1) for k in range(n)]
    return [open_ + (close - open_) * (k + 0.5) / n for k in range(n)]


# ---- blur-synthesis procedures (the module docstring cites each rule's source) ----

TIMES = ("midpoint", "endpoints", "random")
SPACES = ("model", "srgb", "gamma2.2", "gamma1")
SUMS = ("weighted", "float32", "mean")
QUANTIZATIONS = ("floor", "round", "none")


@dataclasses.dataclass(frozen=True)
class Procedure:
    name: str
    times: str
    n: int
    frames: str  # 8-bit quantization of each sharp frame
    space: str   # what is averaged
    sum: str     # how the mean is accumulated
    result: str  # 8-bit quantization of the blurred image
    seed: int = 1  # times=random only


PRESETS = {
    "deblur-nerf": Procedure("deblur-nerf", "endpoints", 10, "round", "gamma2.2", "weighted", "floor"),
    "bad-gaussians": Procedure("bad-gaussians", "endpoints", 31, "round", "gamma1", "float32", "floor"),
    "3dgs-deblur": Procedure("3dgs-deblur", "endpoints", 10, "none", "gamma2.2", "weighted", "none"),
    "midpoint": Procedure("midpoint", "midpoint", 10, "none", "model", "mean", "none"),
}
CUSTOM = Procedure("custom", "midpoint", 10, "none", "model", "mean", "none")
# The most frames one N may have. Each frame is a refrender run (about a second for the 128x128
# Gaussian bunnies: loading the model and building its BVH) and stays in memory as float64 RGBA until
# the run ends. 256 is 8 times the largest N of the procedures emulated (31, BlenderCV), and there the
# midpoint rule's error (falling as N^-2 where the motion is smooth) is 1/650 of its error at N = 10:
# below the noise of the references in src/TRAJECTORIES.md, so more frames would measure nothing.
MAX_FRAMES = 256
FRAME_COST = "each frame is a refrender run and stays in memory, 32 bytes a pixel"
CHOICES = {"times": TIMES, "space": SPACES, "sum": SUMS, "frames": QUANTIZATIONS, "result": QUANTIZATIONS}


def parse_procedure(spec):
    """NAME or NAME:key=value,...: a preset (or custom) with parts changed by hand."""
    name, _, changes = spec.partition(":")
    if name != "custom" and name not in PRESETS:
        raise Failure(f"--procedure {spec}: unknown procedure '{name}' (known: {', '.join(PRESETS)}, custom)")
    base, parts = PRESETS.get(name, CUSTOM), {}
    for item in filter(None, changes.split(",")):
        key, eq, value = item.partition("=")
        if not eq or key not in ("n", "seed", *CHOICES):
            raise Failure(f"--procedure {spec}: '{item}' is not key=value with key one of "
                          f"times, n, frames, space, sum, result, seed")
        if key in parts:
            raise Failure(f"--procedure {spec}: {key} is given twice")
        if key in CHOICES and value not in CHOICES[key]:
            raise Failure(f"--procedure {spec}: {key} must be one of {', '.join(CHOICES[key])}, not '{value}'")
        if key in ("n", "seed"):
            try:
                value = int(value)
            except ValueError:
                raise Failure(f"--procedure {spec}: {key} must be an integer, not '{value}'") from None
        parts[key] = value
    p = dataclasses.replace(base, name=spec if parts else name, **parts)
    if p.n < (2 if p.times == "endpoints" else 1):
        raise Failure(f"--procedure {spec}: n = {p.n} is too few frames for times={p.times}")
    if p.n > MAX_FRAMES:
        raise Failure(f"--procedure {spec}: n = {p.n} is more than {MAX_FRAMES} frames, the most one N may have "
                      f"({FRAME_COST})")
    if "seed" in parts and p.times != "random":
        raise Failure(f"--procedure {spec}: seed={p.seed} has no meaning with times={p.times} (it seeds "
                      "times=random only)")
    if p.seed < 0:  # numpy's generators take seeds >= 0 only
        raise Failure(f"--procedure {spec}: seed must be an integer >= 0, not {p.seed}")
    if p.space == "model" and p.frames != "none":
        raise Failure(f"--procedure {spec}: space=model averages the renderer's floats, so frames={p.frames} "
                      "(8-bit frames) has no meaning: use space=srgb, gamma2.2 or gamma1")
    return p


def procedure_times(p, open_, close):
    if p.times == "random":
        return [open_ + (close - open_) * float(u) for u in np.sort(np.random.default_rng(p.seed).random(p.n))]
    return frame_times(open_, close, p.n, p.times)


def to_8bit(x, rule):
    """Display values to 8 bits, in x's own precision: clip to [0, 1], x 255, then truncate (numpy's
    astype(uint8), which both datasets' scripts use) or round half up (Blender)."""
    v = np.clip(x, 0, 1) * 255
    return (v if rule == "floor" else np.floor(v + 0.5)).astype(np.uint8)


# the averaging spaces: decode before the mean, encode after it (numpy's float64 power for gamma 2.2)
DECODE = {"srgb": flip.srgb_to_linear, "gamma2.2": lambda x: x ** 2.2, "gamma1": lambda x: x}
ENCODE = {"srgb": flip.linear_to_srgb, "gamma2.2": lambda y: y ** (1 / 2.2), "gamma1": lambda y: y}


def accumulate(stack, rule):
    """The mean over axis 0 (the frames, in order)."""
    n = len(stack)
    if rule == "weighted":  # each frame times 1/N, then np.sum over the frames (float64)
        return np.sum(stack * (1 / n), axis=0)
    if rule == "float32":  # summed in float32 in frame order, then divided by N in float32
        total = np.zeros(stack.shape[1:], np.float32)
        for frame in stack.astype(np.float32):
            total = total + frame
        return total / n
    return np.mean(stack, axis=0, dtype=np.float64)


def synthesize(frames, p):
    """A procedure's blurred image from the sharp frames as its dataset stored them (uint8 arrays,
    or display floats when p.frames is none), in frame order: uint8 if p.result quantizes, else
    display floats."""
    if p.space == "model":
        raise Failure("synthesize: space=model averages the renderer's floats, not stored frames")
    stack = np.array([f / 255 if f.dtype == np.uint8 else np.asarray(f, np.float64) for f in frames])
    if p.sum == "float32":
        stack = stack.astype(np.float32)
    out = ENCODE[p.space](accumulate(DECODE[p.space](stack), p.sum))
    return out if p.result == "none" else to_8bit(out, p.result)


def to_display(values, display):
    """A render's values (its blur space) as the display values an 8-bit PNG of it would hold."""
    return flip.linear_to_srgb(values) if display == "srgb" else np.clip(values, 0, 1)


def display_slope(values, display):
    """d display / d value, 0 where the value is clipped: carries the reference's noise."""
    inside = (values > 0) & (values < 1)
    if display == "identity":
        return inside.astype(np.float64)
    v = np.clip(values, 1e-12, 1)
    return np.where(inside, np.where(v <= 0.0031308, 12.92, 1.055 / 2.4 * v ** (1 / 2.4 - 1)), 0.0)


def emulate(p, renders, display):
    """The procedure applied to refrender's sharp frames (RGB, the reference's blur space): its
    blurred image as display floats (multiples of 1/255 when p.result quantizes)."""
    if p.space == "model":
        out = to_display(accumulate(np.array(renders), p.sum), display)
        return out if p.result == "none" else to_8bit(out, p.result) / 255
    stored = [to_display(r, display) for r in renders]
    if p.frames != "none":  # in float32, as Blender converts its float buffer
        stored = [to_8bit(s.astype(np.float32), p.frames) for s in stored]
    out = synthesize(stored, p)
    return out / 255 if out.dtype == np.uint8 else np.clip(np.asarray(out, np.float64), 0, 1)


def error_stats(d, se):
    """Signed differences d against a reference with standard errors se (same units)."""
    mse, noise2 = float(np.mean(d ** 2)), float(np.mean(se ** 2))
    return {"bias": float(np.mean(d)), "bias_se": math.sqrt(float(np.sum(se ** 2))) / d.size,
            "RMSE": math.sqrt(mse), "RMSE*": math.sqrt(max(0.0, mse - noise2)), "max": float(np.abs(d).max()),
            "noise": math.sqrt(noise2), "RMSE/noise": math.sqrt(mse / noise2) if noise2 > 0 else math.inf}


def measure_procedure(out, ref, se, display, moving):
    """out (display floats) against the reference integral ref encoded the same way, unquantized:
    in 8-bit levels, over all pixels and where the scene moves; and decoded to linear."""
    d = (out - to_display(ref, display)) * 255
    s = display_slope(ref, display) * se * 255
    row = {"display": error_stats(d, s)}
    row["display"]["bias_moving"] = float(np.mean(d[moving])) if moving.any() else 0.0
    linear = flip.srgb_to_linear(out) if display == "srgb" else out
    inside = (ref > 0) & (ref < 1)
    row["linear"] = error_stats(linear - np.clip(ref, 0, 1), np.where(inside, se, 0.0))
    return row


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
            "res": header["refrender:resolution"], "header": header, "path": path,
            "color_space": "sRGB" if imagecompare.read_image(path).colorspace == "srgb" else "Linear"}


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
    """The sharp frames at `times` (RGBA), each rendered once (cache: time -> RGBA); the first
    checked to be of the reference's scene."""
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
    return [cache[t] for t in times]


def write_exr(path, rgba, inputs, color_space, blur_space):
    """A float EXR, whole or not at all (safefiles), checked by reading it back; its header says
    what its RGB holds (oiio:ColorSpace "sRGB": display values, or "Linear") and in which space
    its time average was taken (refrender:blurSpace), as refrender's own images do."""
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(rgba.astype(np.float32))
    buf.specmod().channelnames = ["R", "G", "B", "A"][:rgba.shape[-1]]

    def write(tmp):
        if not buf.write(tmp):
            raise OSError(oiio.geterror() or "OpenImageIO cannot write it")
        imagecompare.tag_exr(tmp, {"oiio:ColorSpace": color_space, "refrender:blurSpace": blur_space})
    safefiles.write_file(path, write, inputs, imagecompare.check_written)


# The refrender blur space a procedure's average matches: model averages the renderer's floats (the
# reference's own space); srgb averages decoded values (linear light); gamma1 the encoded values
# clamped to [0, 1] (refrender's clamped); gamma2.2 has no refrender counterpart and is named as is.
PROCEDURE_BLUR = {"srgb": "linear", "gamma1": "clamped", "gamma2.2": "gamma2.2"}


def save_figure(fig, path, inputs, **kw):
    """A matplotlib figure, whole or not at all (safefiles), checked by reading it back."""
    safefiles.write_file(path, lambda tmp: fig.savefig(tmp, **kw), inputs, imagecompare.check_written)


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


COMPARISON = ("display: the procedure's image against the reference integral encoded the same way ({curve}), "
              "unquantized, in 8-bit levels (x 255); linear: both decoded ({decode}), against the reference "
              "as rendered (blur space {blur}), clipped to [0, 1]")


def procedure_table(rows, display, blur):
    curve = "the sRGB curve" if display == "srgb" else "identity: the render's values are display values"
    lines = ["comparison: " + COMPARISON.format(curve=curve, decode="sRGB curve" if display == "srgb" else "identity",
                                                blur=blur),
             f"reference noise (RMS standard error): display {rows[0]['display']['noise']:.3g} levels, "
             f"linear {rows[0]['linear']['noise']:.3g}", "",
             "| procedure | times | N | frames | space | sum | result | bias, levels (+- 1 sigma) "
             "| bias where it moves | RMSE, levels | RMSE without the reference's noise | max, levels | linear bias "
             "| linear RMSE | linear RMSE / noise |", "| --- " * 15 + "|"]
    for r in rows:
        p, dsp, lin = r["procedure"], r["display"], r["linear"]
        lines.append(f"| {p['name']} | {p['times']} | {p['n']} | {p['frames']} | {p['space']} | {p['sum']} | "
                     f"{p['result']} | {dsp['bias']:+.3f} +- {dsp['bias_se']:.0e} | {dsp['bias_moving']:+.3f} | "
                     f"{dsp['RMSE']:.3f} | {dsp['RMSE*']:.3f} | {dsp['max']:.2f} | {lin['bias']:+.2e} | "
                     f"{lin['RMSE']:.2e} | {lin['RMSE/noise']:.0f} |")
    return "\n".join(lines)


def plot(rows, ref_se, path, inputs):
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
    save_figure(fig, path, inputs)


def figure(ref, avg, n, path, inputs):
    """The reference, the N-frame average and the error map between them."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
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
    save_figure(fig, path, inputs)


def procedure_figure(truth, outs, path, inputs):
    """The true blur (display) and each procedure's signed error in 8-bit levels (channel mean)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import textwrap
    errs = [((out - truth) * 255).mean(axis=-1) for _, out in outs]
    lim = max(max(float(np.percentile(np.abs(e), 99.5)) for e in errs), 0.5)
    cols = min(len(outs) + 1, 5)
    rows = -(-(len(outs) + 1) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(2.1 * cols, 2.4 * rows), dpi=90, squeeze=False)
    axes = axes.ravel()
    axes[0].imshow(np.clip(truth, 0, 1))
    axes[0].set_title("true blur (the integral)", fontsize=8)
    for ax, (name, _), e in zip(axes[1:], outs, errs):
        shown = ax.imshow(e, cmap="RdBu_r", vmin=-lim, vmax=lim)
        ax.set_title("\n".join(textwrap.wrap(f"{name} - truth", 24)), fontsize=8)
    fig.colorbar(shown, ax=list(axes), fraction=0.02, pad=0.01, label="8-bit levels (mean of R, G, B)")
    for ax in axes:
        ax.axis("off")
    save_figure(fig, path, inputs, bbox_inches="tight")


def check_names(value):
    """One --procedure value names at least one procedure, and no name between its commas is empty."""
    names = [value] if ":" in value else value.split(",")
    if any(not name.strip() for name in names):
        raise Failure(f"--procedure '{value}': an empty procedure name (write NAME or NAME,NAME,... with NAME "
                      f"one of {', '.join(PRESETS)}, custom)")


def parse(argv):
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog="Float averages" + __doc__.split("\nFloat averages", 1)[1])
    p.add_argument("scene")
    p.add_argument("--reference", help="the converged render (with standard errors); default: render one")
    p.add_argument("--n", help=f"frame counts, comma-separated, each at most {MAX_FRAMES} (default 10,16,51; not "
                   "with --procedure)")
    p.add_argument("--times", choices=("midpoint", "endpoints"), help="default midpoint; not with --procedure")
    p.add_argument("--procedure", action="append", help="blur-synthesis procedures (repeatable): "
                   f"{', '.join(PRESETS)}, custom, comma-separated; NAME:key=value,... changes parts of one "
                   "(see the module docstring)")
    p.add_argument("--display", choices=("srgb", "identity"), help="how a render's values become a sharp frame's "
                   "display values (default: srgb for a --blur-space linear reference, identity for model)")
    p.add_argument("--out", default="nframe", help="directory for the frames and averages (average_N.exr; "
                   "default nframe/)")
    p.add_argument("--json")
    p.add_argument("--plot", help="error against N, log-log (PNG; not with --procedure)")
    p.add_argument("--figure", help="the reference, the first N's average and its error map; with --procedure the "
                   "true blur and each procedure's signed error (PNG)")
    p.add_argument_group("after --", "REFRENDER-ARGS: refrender options for every render, the reference's too "
                         "(e.g. -- --res 128x128 -D name=v)")
    p.usage = p.format_usage().split(" ", 1)[1].rstrip() + " [-- REFRENDER-ARGS ...]"  # argparse's own, and --
    args = p.parse_args(argv)
    if args.procedure:
        for option in ("n", "times", "plot"):
            if getattr(args, option) is not None:
                p.error(f"--{option} is for float averages: with --procedure each procedure states its own "
                        "(e.g. deblur-nerf:n=16,times=midpoint)")
        specs = [s.strip() for v in args.procedure for s in ([v] if ":" in v else v.split(","))]
        try:
            for v in args.procedure:
                check_names(v)
            args.procedures = [parse_procedure(s) for s in specs]
        except Failure as e:
            p.error(str(e))
        return args, extra
    args.times = args.times or "midpoint"
    args.n = args.n or "10,16,51"
    try:
        args.counts = [int(v) for v in args.n.split(",")]
    except ValueError:
        p.error(f"--n: expected counts such as 10,16,51, got '{args.n}'")
    if any(n < 1 for n in args.counts):
        p.error("--n: counts must be >= 1")
    if max(args.counts) > MAX_FRAMES:
        p.error(f"--n {args.n}: {max(args.counts)} is more than {MAX_FRAMES} frames, the most one N may have "
                f"({FRAME_COST})")
    return args, extra


def float_averages(args, settings, ref, se, frames, out):
    rows = []
    for n in args.counts:
        avg = np.mean(frames(frame_times(settings["open"], settings["close"], n, args.times)), axis=0)
        write_exr(out / f"average_{n}.exr", avg, args.inputs, settings["color_space"], settings["blur"])
        rows.append({"N": n, **measure(avg, ref, se)})
        if args.figure and n == args.counts[0]:
            figure(ref, avg, n, args.figure, args.inputs)
    noise = float(np.sqrt(np.mean(se ** 2)))
    print(table(rows, noise))
    if args.json:
        safefiles.write_text(args.json, json.dumps({"reference": str(args.reference), "times": args.times,
                                                    "reference_noise": noise, "rows": rows}, indent=1), args.inputs)
    if args.plot:
        plot(rows, noise, args.plot, args.inputs)


# Where the scene moves is measured on sharp frames at the midpoint times of this many, as well as the
# procedures' own: a procedure's frames alone see no motion with one frame, and between two or three
# they miss what an object sweeps over in the meantime (tests/test_nframe_average.py's splat, which
# sweeps 7.5 px: 0 % of the image with one frame, 11 % with two, 15 % from 8 midpoint frames up to
# 256). On the bunnies of src/TRAJECTORIES.md they add no pixel to what its 47 frames find.
MOTION_PROBES = 16


def moving_pixels(renders, display, shape):
    """The pixels that move: some two of the sharp frames (RGBA, any order) differ by more than half an
    8-bit level in some channel, as a mask of `shape` (the same for every channel)."""
    shown = np.array([to_display(f[..., :3], display) for f in renders])
    spread = (shown.max(axis=0) - shown.min(axis=0) > 0.5 / 255).any(axis=-1, keepdims=True)
    return np.broadcast_to(spread, shape)


def procedures(args, settings, ref, se, frames, cache, out):
    display = args.display or ("srgb" if settings["blur"] == "linear" else "identity")
    ref_rgb, outs = ref[..., :3], []
    for p in args.procedures:
        renders = [f[..., :3] for f in frames(procedure_times(p, settings["open"], settings["close"]))]
        outs.append((p, emulate(p, renders, display)))
        write_exr(out / f"procedure_{p.name.replace(':', '_').replace(',', '_').replace('=', '')}.exr", outs[-1][1],
                  args.inputs, "sRGB" if display == "srgb" else settings["color_space"],  # identity: as rendered
                  PROCEDURE_BLUR.get(p.space, settings["blur"]))
    frames(frame_times(settings["open"], settings["close"], MOTION_PROBES, "midpoint"))
    moving = moving_pixels(cache.values(), display, ref_rgb.shape)
    rows = [{"procedure": dataclasses.asdict(p), **measure_procedure(o, ref_rgb, se, display, moving)}
            for p, o in outs]
    print(procedure_table(rows, display, settings["blur"]))
    print(f"moving pixels: {100 * float(moving[..., 0].mean()):.1f}% of the image (some two of the {len(cache)} "
          f"sharp frames, {MOTION_PROBES} of them evenly spaced over the shutter, differ by more than half a level)")
    if args.json:
        curve = "the sRGB curve" if display == "srgb" else "identity"
        safefiles.write_text(args.json, json.dumps({
            "reference": str(args.reference), "display": display, "blur_space": settings["blur"],
            "comparison": COMPARISON.format(curve=curve, decode=curve, blur=settings["blur"]),
            "moving_fraction": float(moving[..., 0].mean()), "rows": rows}, indent=1), args.inputs)
    if args.figure:
        procedure_figure(to_display(ref_rgb, display), [(p.name, o) for p, o in outs], args.figure, args.inputs)


def check_outputs(args):
    """The inputs (the scene, the reference when given) that no output may
    overwrite, however spelled; each output refused now, before any render."""
    inputs = safefiles.Inputs([args.scene] + ([args.reference] if args.reference else []))
    for option in ("json", "plot", "figure"):
        if getattr(args, option):
            inputs.check_output(getattr(args, option), f"--{option}")
    return inputs


def main(argv):
    args, extra = parse(argv)
    args.inputs = check_outputs(args)
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise Failure(f"--out {out}: exists and is not a directory (the frames and averages go into a directory)")
    out.mkdir(parents=True, exist_ok=True)
    if not Path(args.scene).is_file():
        raise Failure(f"{args.scene}: no such scene file")
    if not args.reference:
        args.reference = out / "reference.exr"
        print("nframe_average: rendering the reference", file=sys.stderr)
        run([args.scene, "--batches", 16, "--quiet", *extra, "-o", args.reference], "reference")
    settings = reference_settings(args.reference)
    ref, ch = read_rgba(args.reference)
    se = np.stack([ch[f"stderr.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    cache = {}

    def frames(times):
        return render_frames(args.scene, times, settings, extra, out, cache, ref.shape)

    if args.procedure:
        procedures(args, settings, ref, se, frames, cache, out)
    else:
        float_averages(args, settings, ref, se, frames, out)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv[1:]))
    except (Failure, imagecompare.CompareError, safefiles.FileRefused) as e:
        print(f"nframe_average: {e}", file=sys.stderr)
        sys.exit(1)
