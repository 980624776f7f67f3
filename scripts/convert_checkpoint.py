#!/usr/bin/python3
"""Converts a gsplat or nerfstudio (splatfacto) checkpoint into the Inria PLY
layout refrender reads, and prints the `semantics` to render it with.

usage: convert_checkpoint.py CKPT -o OUT.ply

The checkpoint is read by torch_checkpoint.py, as convert_4dgs.py reads its
own: a restricted unpickler that may name only torch's tensor rebuilders,
storage tags and collections.OrderedDict (anything else, os.system say, is
refused by name and nothing is run), every tensor bounded by its storage and
every member by its declared size and the archive's size. No torch needed.
The kind is recognised by its top-level key.

gsplat (examples/simple_trainer.py at v1.5.3, 937e299)
  torch.save({"step": step, "splats": self.splats.state_dict(), ...},
  ckpt_<step>_rank<r>.pt) (simple_trainer.py:768-781). splats: means [N,3];
  scales [N,3], log (exp'd at 497); quats [N,4], w first (cuda/_torch_impl.py:
  14), normalised by rasterization (494-496); opacities [N], logit (sigmoid
  at 498); sh0 [N,1,3] and shN [N,K-1,3], coefficient-major (concatenated to
  [N,K,3] at 511; colour = SH + 0.5 clamped at 0, rendering.py:525).
  A run on several GPUs saves each rank's share (points[world_rank::
  world_size], 249-251) in its own file: each converts to its part alone.
  Models with an appearance module (app_opt: "features"/"colors", 272-276)
  are refused: their colour is a network's, per image.
  examples/simple_trainer_2dgs.py saves the same keys (scales [N,3] too,
  simple_trainer_2dgs.py:212, 724-730) as ckpt_<step>.pt, with no _rank:
  a 2DGS model for gsplat's rasterization_2dgs, which refrender does not
  model. Nothing in the file tells it apart, so a gsplat checkpoint whose
  name has that form is converted with a warning on stderr.
nerfstudio splatfacto (v1.1.5, 6b60855, the current release)
  torch.save({"step", "pipeline": pipeline.state_dict(), "optimizers", ...})
  (engine/trainer.py:467-476); the model's parameters are
  "_model.gauss_params.<name>" (models/splatfacto.py:275-284), "_model.module."
  under DDP (pipelines/base_pipeline.py:104-113), "_model.<name>" in old
  checkpoints (splatfacto.py:383-387). means [N,3], scales [N,3] log,
  quats [N,4] w first, opacities [N,1] logit (exp / sigmoid at 602-603),
  features_dc [N,3], features_rest [N,K-1,3] (concatenated at 574). With
  sh_degree 0 (features_rest [N,0,3]) features_dc is a logit and the colour
  sigmoid(features_dc) (splatfacto.py:262-266, 593-597).

The PLY (binary little endian float32, as graphdeco-inria's save_ply):
  x y z nx ny nz f_dc_0..2 f_rest_0..3(K-1)-1 opacity scale_0..2 rot_0..3
  with f_dc = sh0 / features_dc, f_rest channel-major: f_rest_<c (K-1) + k-1>
  = coefficient k of channel c (gsplat's export_splats, exporter.py:513,
  shN.permute(0, 2, 1); nerfstudio's scripts/exporter.py:606, transpose(1, 2)),
  opacity, scales and quaternions as stored; normals 0. A sh_degree 0
  splatfacto model gets f_dc = (sigmoid(features_dc) - 0.5) / C0 (its shs_0,
  splatfacto.py:342-346, as ns-export writes), which refrender's SH draws as
  sigmoid(features_dc).

Frames: the means are where training put them, in the trainer's normalised
world, not the dataset's: gsplat's COLMAP parser re-centres, scales and
turns the world (normalize_world_space, default True, simple_trainer.py:67;
datasets/colmap.py:218-243) and saves no record of it; nerfstudio orients,
centres and scales the poses (data/dataparsers/nerfstudio_dataparser.py:
237-249) and saves the map as dataparser_transforms.json (`transform` 3x4,
`scale`: c2w' = transform c2w, its translation times scale; data/
dataparsers/base_dataparser.py:77-86, engine/trainer.py:237-238). Cameras
must be given in that frame; the converter changes no coordinate.

Semantics: both render through gsplat's rasterization (nerfstudio v1.1.5 pins
gsplat 1.4.0, pyproject.toml:67, with the same 0.999 alpha cap and SH offset
as 1.5.3): semantics="gsplat" for rasterize_mode "classic" (the default:
simple_trainer.py:125 antialiased False; splatfacto.py:203), and
"gsplat-antialiased" for a model trained with --antialiased / rasterize_mode
"antialiased" (the run's cfg.yml / config.yml says; the checkpoint does not).
Neither draws a gsplat model trained with --with_ut / --with_eval3d (3DGUT,
simple_trainer.py:184-185) or a camera_model other than pinhole (69) as
trained.

Refused, one line naming the file and the entry: what is neither layout, a
missing or misshapen parameter, Gaussian counts that differ, an SH count
that is no (d+1)^2 for d <= 3, a non-finite value (unless --drop-nonfinite
drops those Gaussians, as both exporters do: gsplat exporter.py:516-539,
nerfstudio scripts/exporter.py:631-640) or a zero quaternion (with the
Gaussian's index), an empty model. Exit 1; usage errors exit 2. The
output is written whole or not at all, never over the checkpoint
(scripts/safefiles.py).
"""
import argparse
import os
import re
import sys
from xml.sax.saxutils import quoteattr

import pydeps

pydeps.require("numpy")
import numpy as np  # noqa: E402

import safefiles  # noqa: E402
from torch_checkpoint import CheckpointError as ConvertError, LazyTensor, describe, clip  # noqa: E402
import torch_checkpoint  # noqa: E402
from convert_4dgs import write_ply, printable, CONVERSION_FAILURES, failure_line  # noqa: E402

SH_C0 = 0.28209479177387814  # nerfstudio splatfacto.py:99, 107 (RGB2SH / SH2RGB)
SEMANTICS_NOTE = ('semantics="gsplat" (rasterize_mode classic, the default); "gsplat-antialiased" if it was trained '
                  'with antialiasing ({where})')
FRAME_NOTE = {  # where the trained frame comes from (module docstring, "Frames")
    "gsplat": "the means are in the frame simple_trainer normalised the COLMAP model to (normalize_world_space, "
              "datasets/colmap.py:218-243; not saved): give the cameras in that frame",
    "nerfstudio splatfacto": "the means are in nerfstudio's dataparser frame: the run's dataparser_transforms.json "
                             "(transform, scale) maps the dataset's cameras into it",
}
NS_PREFIXES = ("_model.gauss_params.", "_model.module.gauss_params.", "_model.")


def tensor(source, key, what, shape):
    """source[key] as float32 (what the PLY holds; the trainers' parameters are float32) of shape
    (None: any N, else the size)."""
    value = source.get(key) if isinstance(source, dict) else None
    if not isinstance(value, LazyTensor):
        raise ConvertError(f"{what} is {describe(value)}, not a tensor")
    if len(value.shape) != len(shape) or any(w is not None and w != s for w, s in zip(shape, value.shape)):
        want = "(" + ", ".join("N" if w is None else str(w) for w in shape) + ")"
        raise ConvertError(f"{what} has shape {clip(value.shape, 80)}, expected {want}")
    with np.errstate(over="ignore"):  # a float64 beyond float32 becomes inf, refused in columns_of
        array = value.numpy(np.float32)
    if array.dtype.kind != "f":
        raise ConvertError(f"{what} holds {array.dtype} values, not floating point")
    return array


def sh_degree(k, what):
    for d in range(4):
        if (d + 1) ** 2 == k:
            return d
    raise ConvertError(f"{what} holds {k - 1} coefficients per channel besides the DC: no SH degree 0-3 "
                       "((d + 1)^2 - 1: 0, 3, 8 or 15)")


def gsplat_model(top):
    splats = top["splats"]
    if not isinstance(splats, dict):
        raise ConvertError(f"'splats' is {describe(splats)}, not a state dict")
    if "features" in splats or "colors" in splats:
        raise ConvertError("'splats' holds 'features'/'colors': a model trained with an appearance module (app_opt, "
                           "simple_trainer.py:272-276) colours each image by a network; refused")
    means = tensor(splats, "means", "splats['means']", (None, 3))
    n = len(means)
    shn = tensor(splats, "shN", "splats['shN']", (n, None, 3))
    return {"means": means, "scales": tensor(splats, "scales", "splats['scales']", (n, 3)),
            "quats": tensor(splats, "quats", "splats['quats']", (n, 4)),
            "opacities": tensor(splats, "opacities", "splats['opacities']", (n,)),
            "sh": np.concatenate([tensor(splats, "sh0", "splats['sh0']", (n, 1, 3)), shn], axis=1),
            "kind": "gsplat", "step": top.get("step"), "where": "--antialiased, the run's cfg.yml"}


def nerfstudio_params(pipeline):
    for prefix in NS_PREFIXES:
        if f"{prefix}means" in pipeline:
            return prefix
    raise ConvertError("'pipeline' holds no '_model.gauss_params.means' (nor '_model.means'): not a splatfacto "
                       f"model (its first keys: {clip(', '.join(map(str, list(pipeline)[:6])), 160)})")


def nerfstudio_model(top):
    pipeline = top["pipeline"]
    if not isinstance(pipeline, dict):
        raise ConvertError(f"'pipeline' is {describe(pipeline)}, not a state dict")
    p = nerfstudio_params(pipeline)
    means = tensor(pipeline, p + "means", f"'{p}means'", (None, 3))
    n = len(means)
    dc = tensor(pipeline, p + "features_dc", f"'{p}features_dc'", (n, 3))
    rest = tensor(pipeline, p + "features_rest", f"'{p}features_rest'", (n, None, 3))
    if rest.shape[1] == 0:  # sh_degree 0: a logit, drawn as sigmoid (splatfacto.py:342-346, 593-597)
        with np.errstate(over="ignore"):  # exp(1000) is inf: sigmoid 0, as torch.sigmoid gives
            dc = ((1 / (1 + np.exp(-dc.astype(np.float64))) - 0.5) / SH_C0).astype(np.float32)
    return {"means": means, "scales": tensor(pipeline, p + "scales", f"'{p}scales'", (n, 3)),
            "quats": tensor(pipeline, p + "quats", f"'{p}quats'", (n, 4)),
            "opacities": tensor(pipeline, p + "opacities", f"'{p}opacities'", (n, 1))[:, 0],
            "sh": np.concatenate([dc[:, None, :], rest], axis=1),
            "kind": "nerfstudio splatfacto", "step": top.get("step"),
            "where": "rasterize_mode antialiased, the run's config.yml"}


def read_model(top):
    if not isinstance(top, dict):
        raise ConvertError(f"the checkpoint holds {describe(top)}, not a dict with 'splats' (gsplat) or 'pipeline' "
                           "(nerfstudio)")
    if "splats" in top:
        return gsplat_model(top)
    if "pipeline" in top:
        return nerfstudio_model(top)
    raise ConvertError("the checkpoint has neither 'splats' (gsplat's simple_trainer) nor 'pipeline' (nerfstudio): "
                       f"its keys are {clip(', '.join(map(str, list(top)[:10])), 160)}")


def columns_of(model, drop_nonfinite=False):
    """(names, N x P float32, Gaussians dropped) in the Inria layout; refuses what refrender's reader
    would, or with drop_nonfinite drops the Gaussians holding a non-finite value, as both
    exporters do (gsplat exporter.py:516-539, nerfstudio scripts/exporter.py:631-640)."""
    means, sh = model["means"], model["sh"]
    n, k = sh.shape[0], sh.shape[1]
    if n == 0:
        raise ConvertError("the model holds no Gaussians (refrender refuses an empty model)")
    sh_degree(k, "the SH")
    names = (["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"] +
             [f"f_rest_{i}" for i in range(3 * (k - 1))] +
             ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"])
    values = np.zeros((n, len(names)), "<f4")  # filled in place: one copy of the model
    values[:, 0:3], values[:, 6:9] = means, sh[:, 0, :]
    values[:, 9:9 + 3 * (k - 1)] = sh[:, 1:, :].transpose(0, 2, 1).reshape(n, 3 * (k - 1))  # channel-major
    values[:, -8], values[:, -7:-4], values[:, -4:] = model["opacities"], model["scales"], model["quats"]
    finite = np.isfinite(values)
    kept = finite.all(axis=1)
    if not kept.all() and not drop_nonfinite:
        i, c = np.argwhere(~finite)[0]
        raise ConvertError(f"Gaussian {i}: '{names[c]}' = {values[i, c]:.9g} is not a finite float32 "
                           f"({np.count_nonzero(~kept)} Gaussians hold one; --drop-nonfinite drops them, as "
                           "ns-export and gsplat's export_splats do)")
    if not kept.all():
        values = values[kept]
    if len(values) == 0:
        raise ConvertError("every Gaussian holds a non-finite value: nothing is left to write")
    zero = np.flatnonzero(~np.any(values[:, -4:] != 0, axis=1))
    if len(zero):
        raise ConvertError(f"Gaussian {np.flatnonzero(kept)[zero[0]]}: its quaternion is zero (no rotation)")
    return names, values, n - len(values)


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter,
                                epilog=__doc__.split("\n\n", 1)[1])
    p.add_argument("checkpoint", help="gsplat's ckpt_<step>_rank<r>.pt or nerfstudio's step-<step>.ckpt")
    p.add_argument("-o", "--output", required=True, help="the PLY to write (written whole or not at all)")
    p.add_argument("--drop-nonfinite", action="store_true",
                   help="drop the Gaussians holding a NaN or infinite value (as float32), as ns-export and gsplat's "
                        "export_splats do, instead of refusing the checkpoint; the count dropped is printed")
    return p.parse_args(argv)


def convert_file(args):
    safefiles.Inputs([args.checkpoint]).check_output(args.output, "-o")
    top, archive = torch_checkpoint.load(args.checkpoint)
    with archive.file:
        model = read_model(top)
        names, values, dropped = columns_of(model, args.drop_nonfinite)
    step = model["step"] if type(model["step"]) is int else "unknown"
    comments = [f"{model['kind']} checkpoint converted by refrender scripts/convert_checkpoint.py",
                f"source {printable(os.path.basename(args.checkpoint))} step {step}"]
    write_ply(args.output, names, values, comments, args.checkpoint)
    return model, len(values), sh_degree(model["sh"].shape[1], "the SH"), dropped


def main(argv=None):
    args = parse_args(argv)
    try:
        model, count, degree, dropped = convert_file(args)
    except CONVERSION_FAILURES as e:
        sys.stderr.write(failure_line("convert_checkpoint.py", args.checkpoint, e))
        return 1
    print(f"{args.output}: {count} Gaussians, SH degree {degree} ({model['kind']} checkpoint)"
          + (f", {dropped} holding a non-finite value dropped" if dropped else ""))
    print("render with " + SEMANTICS_NOTE.format(where=model["where"]))
    print(f"  <gaussianModel file={quoteattr(args.output)} semantics=\"gsplat\"/>")
    print("note: " + FRAME_NOTE[model["kind"]])
    if model["kind"] == "gsplat" and re.fullmatch(r"ckpt_\d+\.pt", os.path.basename(args.checkpoint)):
        sys.stderr.write(f"convert_checkpoint.py: warning: {args.checkpoint}: ckpt_<step>.pt is how gsplat's "
                         "simple_trainer_2dgs.py names its 2DGS checkpoints (simple_trainer.py adds _rank<r>); a "
                         "2DGS model is drawn by rasterization_2dgs, which refrender does not model\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
