#!/usr/bin/python3
"""Converts a real-time 4DGS checkpoint (Yang et al., ICLR 2024;
fudan-zvg/4d-gaussian-splatting, read at 63725f21) into a PLY refrender reads.

usage: convert_4dgs.py CHECKPOINT.pth -o OUT.ply
           --rotation-convention {before-900c592,after-900c592}
           --time_duration START END --prefilter_var V --force_sh_3d {false,true}
           [--drop-env-map]

The checkpoint is what 4DGS's training saves: torch.save((gaussians.capture(),
iteration)) (scene/__init__.py:92, train.py:224), a torch zip archive read by
torch_checkpoint.py: a restricted unpickler that may name only
torch._utils._rebuild_tensor_v2, torch._utils._rebuild_parameter(_with_state),
collections.OrderedDict and torch's typed storage classes (as storage tags);
every other global is refused naming module.name, and nothing in the pickle is
called but those, the rebuilders implemented there in numpy. No torch needed.
Only a regular file is read; every tensor is bounded by its storage and every
member by its declared size and the archive's size before it is inflated, so
no checkpoint can make the converter hang or ask for much memory.

The model (file:line at 63725f21)
  capture() (scene/gaussian_model.py:116-136), gaussian_dim 4: [0]
  active_sh_degree, [1] _xyz, [2] _features_dc, [3] _features_rest, [4]
  _scaling, [5] _rotation, [6] _opacity, [7] max_radii2D, [8]
  xyz_gradient_accum, [9] t_gradient_accum, [10] denom, [11] optimizer state,
  [12] spatial_lr_scale, [13] _t, [14] _scaling_t, [15] _rotation_r, [16]
  rot_4d, [17] env_map, [18] active_sh_degree_t.
  Activations (gaussian_model.py:49-60, 179-219): scales exp(_scaling),
  exp(_scaling_t); opacity sigmoid(_opacity); quaternions normalised
  (F.normalize; also utils/general_utils.py:113-118).
  4D rotation (utils/general_utils.py:113-145): q_l = (a,b,c,d) = rotation,
  q_r = (p,q,r,s) = rotation_r, rows
    M_l = [[a,-b,-c,-d],[b,a,-d,c],[c,d,a,-b],[d,-c,b,a]]
    M_r = [[p,q,r,s],[-q,p,-s,r],[-r,s,p,-q],[-s,-r,q,p]]
    before 900c592: R = M_l M_r
    after 900c592 (2024-09-15): R = flip(M_l M_r) = J M_l M_r J, J the 4x4
    exchange matrix (rows and columns reversed; general_utils.py:132; the CUDA
    forward.cu:315-331 literals give the same J M_l J J M_r J)
  and Sigma = R diag(s)^2 R^T, s = (exp(_scaling), exp(_scaling_t)),
  coordinates (x, y, z, t) (general_utils.py:135-145, gaussian_model.py:
  34-36). Checkpoints carry no tag saying which R they were trained with.
  At time t (forward.cu:279-352, the path every config takes:
  compute_cov3D_python False): dt = t - t0; cov_t = Sigma_tt;
  marginal = exp(-0.5 dt^2 / (cov_t + prefilter_var if prefilter_var > 0
  else cov_t)); the Gaussian is dropped unless marginal > 0.05, else its
  opacity is sigmoid(_opacity) * marginal; its mean is _xyz + Sigma_xt /
  Sigma_tt dt; its covariance Sigma_3 - Sigma_xt Sigma_xt^T / Sigma_tt,
  the same at every t.
  Colour (forward.cu:73-195, 476-483): 4D SH with the rasterizer's degrees
  D = active_sh_degree, D_t = active_sh_degree_t (gaussian_renderer/
  __init__.py:46-47); the view direction is the *canonical* mean _xyz minus
  the camera centre (forward.cu:79-81, 480-482: orig_points, not the moved
  mean); the time terms, nested inside D > 2 (forward.cu:142), add for k =
  1..D_t cos(2 pi k (t0 - t) / T) sum_j Y_j(dir) sh[16 k + j] (forward.cu:83,
  143, 163), T = time_duration[1] - time_duration[0] (gaussian_renderer/
  __init__.py:50); RGB = max(result + 0.5, 0). With force_sh_3d the plain 3D
  SH is used (forward.cu:479-480).

The PLY (binary little endian, one `vertex` element, every property float32,
in this order; the header's comments repeat the provenance)
  x y z            the mean at t0 (_xyz)
  t_center         t0 (_t), in 4DGS's time units (the cameras' timestamps)
  vel_0 vel_1 vel_2  Sigma_xt / Sigma_tt: mean(t) = (x, y, z) + vel (t - t_center)
  t_var            the variance in the temporal marginal: Sigma_tt, plus
                   prefilter_var when prefilter_var > 0 (not its square root):
                   marginal(t) = exp(-0.5 (t - t_center)^2 / t_var), the
                   Gaussian drawn only where marginal > 0.05
  opacity          _opacity as stored (a logit): alpha = sigmoid(opacity) * marginal(t)
  scale_0..2       log of the square roots of the conditional covariance's
                   eigenvalues (as 3DGS stores scales)
  rot_0..3         the quaternion (w first, as 3DGS) of the eigenvectors: the
                   conditional covariance is R diag(exp(scale))^2 R^T with R the
                   3DGS matrix of rot (utils/general_utils.py:79-100)
  time_duration    T (the same in every vertex)
  sh_degree        D, the spatial degree the rasterizer uses (same everywhere)
  sh_degree_t      the time degree that takes effect: D_t if D = 3 and not
                   force_sh_3d, else 0 (same everywhere)
  sh4d_0 ..        3 S (sh_degree_t + 1) coefficients, S = (sh_degree + 1)^2:
                   sh4d_<3 (S k + j) + c> is time harmonic k (0: constant),
                   spatial coefficient j (3DGS's order), colour channel c (RGB);
                   it is 4DGS's coefficient 16 k + j of channel c (S = 16 when
                   k > 0)
The names are none of SpacetimeGaussians' (trbf_*, motion_*, omega_*, f_t_*)
nor 3DGS's f_dc_*/f_rest_* (a reader of static models refuses the file
rather than drawing it still); `t_center` with `vel_0` marks the kind.

The conditional covariance is computed in float64 as the inverse of the
precision block (R diag(s)^-2 R^T)_xyz, equal in exact arithmetic to the
Schur complement above and positive definite in floating point.

Refused, besides what is not a 4DGS rot_4d checkpoint: an empty model;
scales (_scaling, _scaling_t) beyond +-100 (exp of them is no float32, and the
float64 conversion would lose the other axes); whatever refrender's reader
(src/formats/gaussian_fdgs_ply.c) then refuses: a value beyond float32, t_var or T
that is not above 0 as a float32, a mean beyond 1e15 from the origin, exp(scale)
beyond 1e15; --force_sh_3d true with a checkpoint whose SH count per channel
is no (d + 1)^2 (a force_sh_3d model holds (max_sh_degree + 1)^2,
gaussian_model.py:222-224: 48 are time harmonics, trained without it); and a
model with an env_map (env_map_res > 0: gaussian_renderer/__init__.py:165-178
composites that background behind the Gaussians, refrender does not) unless
--drop-env-map says to convert the Gaussians alone.

Errors are one line naming the file and the entry (capture() index and name,
Gaussian index), exit 1; usage errors exit 2. The output is written to a
temporary beside it and renamed when complete (mode 0666 less the umask); an
output that is the checkpoint (however named: a symbolic or hard link too) or
an existing FIFO, device or directory is refused (scripts/safefiles.py).
"""
import argparse
import os
import sys

import pydeps

pydeps.require("numpy")
import numpy as np  # noqa: E402

import safefiles  # noqa: E402
from torch_checkpoint import CheckpointError as ConvertError, LazyTensor, describe, clip  # noqa: E402
import torch_checkpoint  # noqa: E402

CONVENTIONS = {
    "before-900c592": "checkpoints trained before fudan-zvg/4d-gaussian-splatting commit 900c592 "
                      "(2024-09-15): R = M_l M_r",
    "after-900c592": "checkpoints trained at or after 900c592 (2024-09-15), e.g. at 63725f21: "
                     "R = flip(M_l M_r), rows and columns reversed",
}
CONVENTION_HELP = ("which 4D rotation the checkpoint was trained with; checkpoints carry no tag, so it must be "
                   "said: " + "; ".join(f"{k}: {v}" for k, v in CONVENTIONS.items()))

CAPTURE_NAMES = ["active_sh_degree", "_xyz", "_features_dc", "_features_rest", "_scaling", "_rotation", "_opacity",
                 "max_radii2D", "xyz_gradient_accum", "t_gradient_accum", "denom", "optimizer.state_dict()",
                 "spatial_lr_scale", "_t", "_scaling_t", "_rotation_r", "rot_4d", "env_map", "active_sh_degree_t"]
MARGINAL_CUT = 0.05  # forward.cu:334, gaussian_renderer/__init__.py:123: kept where marginal > 0.05
MAX_LOG_SCALE = 100.0  # |_scaling|, |_scaling_t|: e^100 > FLT_MAX; the float64 products stay far from overflow
MAX_ABS = 1e15  # refrender's RR_MAX_REACH (src/core/common.h): means and exp(scale)
MAX_MESSAGE = 600  # a message's reason, in characters


# ---- the model -------------------------------------------------------------

def entry(capture, index, n=None, shape=None):
    """capture()[index] as a float64 array, checked against shape (None: N)."""
    name = f"capture()[{index}] {CAPTURE_NAMES[index]}"
    value = capture[index]
    if not isinstance(value, LazyTensor):
        raise ConvertError(f"{name} is {type(value).__name__}, not a tensor")
    try:
        a = value.numpy()
    except ConvertError as e:
        raise ConvertError(f"{name}: {e}") from None
    if shape is not None:
        n = a.shape[0] if n is None and a.ndim == len(shape) else n
        want = tuple(n if d is None else d for d in shape)
        if a.shape != want and not (len(want) == 2 and want[1] == 1 and a.shape == want[:1]):
            raise ConvertError(f"{name} has shape {a.shape}, expected {want} (N = {n} from _xyz)")
        a = a.reshape(want)
    bad = np.argwhere(~np.isfinite(np.atleast_1d(a)))
    if len(bad):
        raise ConvertError(f"{name} is not finite at Gaussian {bad[0][0]}: {np.atleast_1d(a)[tuple(bad[0])]}")
    return a


def small_int(capture, index, low, high):
    v = capture[index]
    if type(v) is not int or not low <= v <= high:
        raise ConvertError(f"capture()[{index}] {CAPTURE_NAMES[index]} is {describe(v)}, expected an int in "
                           f"{low}..{high}")
    return v


def read_capture(top):
    if not (isinstance(top, tuple) and len(top) == 2 and isinstance(top[0], tuple)):
        raise ConvertError("not a 4DGS checkpoint: expected (gaussians.capture(), iteration) "
                           "(scene/__init__.py:92)")
    capture = top[0]
    if len(capture) == 12:
        raise ConvertError("capture() has 12 entries: a gaussian_dim 3 (static 3DGS) checkpoint, not 4DGS")
    if len(capture) != 19:
        raise ConvertError(f"capture() has {len(capture)} entries, a gaussian_dim 4 one has 19 "
                           "(scene/gaussian_model.py:116-136)")
    if capture[16] is not True:
        raise ConvertError(f"capture()[16] rot_4d is {describe(capture[16])}: only rot_4d models (every 4DGS config) "
                           "are supported")
    if type(top[1]) is not int:
        raise ConvertError(f"the iteration saved with capture() is {describe(top[1])}, not an int (train.py:224)")
    return capture, top[1]


def log_scales(capture, index, n, width):
    """_scaling (N x 3) or _scaling_t (N x 1), within +-MAX_LOG_SCALE (module docstring)."""
    s = entry(capture, index, n, (None, width))
    bad = np.argwhere(np.abs(s) > MAX_LOG_SCALE)
    if len(bad):
        raise ConvertError(f"capture()[{index}] {CAPTURE_NAMES[index]} is {s[tuple(bad[0])]:g} at Gaussian "
                           f"{bad[0][0]}: beyond +-{MAX_LOG_SCALE:g}, exp() of it is no float32 scale")
    return s


def unit_quaternions(q, index):
    norm = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(norm == 0)
    if len(bad):
        raise ConvertError(f"capture()[{index}] {CAPTURE_NAMES[index]} is zero at Gaussian {bad[0]}: "
                           "no rotation (4DGS would divide by zero)")
    return q / norm[:, None]


def rotation_4d(l, r, convention):
    """R per Gaussian (utils/general_utils.py:113-133)."""
    a, b, c, d = l.T
    p, q, r_, s = r.T
    m_l = np.stack([a, -b, -c, -d, b, a, -d, c, c, d, a, -b, d, -c, b, a], axis=1).reshape(-1, 4, 4)
    m_r = np.stack([p, q, r_, s, -q, p, -s, r_, -r_, s, p, -q, -s, -r_, q, p], axis=1).reshape(-1, 4, 4)
    rot = m_l @ m_r
    return rot[:, ::-1, ::-1] if convention == "after-900c592" else rot


def quaternion_of(rot):
    """w-first unit quaternions of proper rotation matrices (3DGS's build_rotation inverted), w >= 0."""
    m = rot
    tr = m[:, 0, 0] + m[:, 1, 1] + m[:, 2, 2]
    cand = np.stack([tr, m[:, 0, 0], m[:, 1, 1], m[:, 2, 2]], axis=1)
    pick = np.argmax(cand, axis=1)
    q = np.empty((len(m), 4))
    for k in range(4):
        sel = pick == k
        mm = m[sel]
        if k == 0:
            w = 0.5 * np.sqrt(1 + tr[sel])
            q[sel] = np.stack([w, (mm[:, 2, 1] - mm[:, 1, 2]) / (4 * w), (mm[:, 0, 2] - mm[:, 2, 0]) / (4 * w),
                               (mm[:, 1, 0] - mm[:, 0, 1]) / (4 * w)], axis=1)
            continue
        i, j, h = k - 1, k % 3, (k + 1) % 3
        big = 0.5 * np.sqrt(1 + mm[:, i, i] - mm[:, j, j] - mm[:, h, h])
        qq = np.empty((len(mm), 4))
        qq[:, 0] = (mm[:, h, j] - mm[:, j, h]) / (4 * big)
        qq[:, 1 + i] = big
        qq[:, 1 + j] = (mm[:, j, i] + mm[:, i, j]) / (4 * big)
        qq[:, 1 + h] = (mm[:, h, i] + mm[:, i, h]) / (4 * big)
        q[sel] = qq
    q *= np.where(q[:, :1] < 0, -1.0, 1.0)
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def conditional_form(scaling, scaling_t, rot_l, rot_r, convention, prefilter_var):
    """velocity, t_var, log scales and quaternions of the conditional 3D Gaussian (a value that
    overflows or vanishes is refused afterwards, by refrender_rules)."""
    s2 = np.exp(2 * np.concatenate([scaling, scaling_t], axis=1))
    rot = rotation_4d(rot_l, rot_r, convention)
    sigma = np.einsum("nik,nk,njk->nij", rot, s2, rot)
    cov_t = sigma[:, 3, 3]
    velocity = sigma[:, :3, 3] / cov_t[:, None]
    t_var = cov_t + prefilter_var if prefilter_var > 0 else cov_t  # forward.cu:333
    precision_xx = np.einsum("nik,nk,njk->nij", rot[:, :3, :], 1 / s2, rot[:, :3, :])
    try:
        mu, vec = np.linalg.eigh(precision_xx)
    except np.linalg.LinAlgError as e:  # not expected with scales within MAX_LOG_SCALE
        raise ConvertError(f"a Gaussian's conditional covariance has no eigen decomposition: {clip(e)}") from None
    if not np.all(mu > 0):
        i = int(np.flatnonzero(~(mu > 0).all(axis=1))[0])
        raise ConvertError(f"Gaussian {i}: its conditional covariance is not positive definite (scales "
                           f"{scaling[i]}, {scaling_t[i]})")
    vec[:, :, 2] *= np.sign(np.linalg.det(vec))[:, None]
    return velocity, t_var, -0.5 * np.log(mu), quaternion_of(vec)


def sh_columns(features, degree, degree_t, force_sh_3d):
    """The coefficients used, as sh4d_<3 (S k + j) + c> (features: N x M x 3, 4DGS's order)."""
    m, s = features.shape[1], (degree + 1) ** 2
    if force_sh_3d and m not in (1, 4, 9, 16):
        raise ConvertError(f"--force_sh_3d true, but capture()[2..3] _features_dc/_features_rest hold {m} "
                           "coefficients per channel: a force_sh_3d model holds (max_sh_degree + 1)^2 "
                           "(gaussian_model.py:222-224), so this one has time harmonics and was trained with "
                           "force_sh_3d false")
    used = [16 * k + j for k in range(degree_t + 1) for j in range(s)]
    if used[-1] >= m:
        raise ConvertError(f"capture()[3] _features_dc/_features_rest hold {m} coefficients per channel, SH degree "
                           f"{degree} x time degree {degree_t} needs {used[-1] + 1} (a force_sh_3d model? then say "
                           "--force_sh_3d true)")
    return features[:, used, :].reshape(len(features), -1)


def features_of(capture, n):
    """get_features (gaussian_model.py:212-215): _features_dc and _features_rest, N x M x 3."""
    dc = entry(capture, 2, n, (None, 1, 3))
    rest = capture[3]
    rest = entry(capture, 3) if isinstance(rest, LazyTensor) else rest
    if not isinstance(rest, np.ndarray) or rest.ndim != 3 or rest.shape[0] != n or rest.shape[2] != 3:
        raise ConvertError(f"capture()[3] _features_rest has shape {getattr(rest, 'shape', None)}, expected "
                           f"(N, M - 1, 3) with N = {n}")
    return np.concatenate([dc, rest], axis=1)


def has_env_map(capture):
    """capture()[17]: None or an empty tensor without env_map_res (train.py:71-77), else 3 x res x res."""
    env = capture[17]
    return env is not None and not (isinstance(env, LazyTensor) and 0 in env.shape)


FDGS_NAMES = ["x", "y", "z", "t_center", "vel_0", "vel_1", "vel_2", "t_var", "opacity", "scale_0", "scale_1",
              "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "time_duration", "sh_degree", "sh_degree_t"]


def first_bad(ok, columns, names, rule):
    bad = np.argwhere(~ok)
    if len(bad):
        i, k = bad[0]
        raise ConvertError(f"Gaussian {i}: '{names[k]}' = {columns[i, k]:.9g} {rule}")


def refrender_rules(columns, values, names):
    """Refuses what refrender's reader would (src/formats/gaussian_fdgs_ply.c store_motion, check_degrees;
    gaussian_ply_common.c): each value within float32, t_var above 0 as the float32 it reads, a mean
    within RR_MAX_REACH and exp(scale) within RR_MAX_REACH of the float32 scales."""
    first_bad(np.isfinite(values), columns, names, "is beyond float32")
    first_bad(values[:, 7:8] > 0, columns[:, 7:8], names[7:8], "is 0 as a float32: refrender refuses a temporal "
              "marginal whose variance is not above 0")
    first_bad(np.abs(values[:, 0:3]) <= MAX_ABS, columns[:, 0:3], names[0:3], "is beyond 1e15 from the origin, "
              "which refrender refuses (RR_MAX_REACH)")
    with np.errstate(over="ignore"):
        first_bad(np.exp(values[:, 9:12].astype(np.float64)) <= MAX_ABS, columns[:, 9:12], names[9:12],
                  "is a log scale whose exp() is beyond 1e15, which refrender refuses (RR_MAX_REACH)")


def convert(capture, args):
    """(property names, N x P float32 values, whether an env_map was dropped)."""
    n_deg, n_deg_t = small_int(capture, 0, 0, 3), small_int(capture, 18, 0, 2)
    if has_env_map(capture) and not args.drop_env_map:
        raise ConvertError("capture()[17] env_map is not empty: the model was trained with env_map_res > 0 and "
                           "4DGS composites that background behind the Gaussians (gaussian_renderer/__init__.py:"
                           "165-178); refrender draws no env_map: --drop-env-map converts the Gaussians alone")
    xyz = entry(capture, 1, shape=(None, 3))
    n = len(xyz)
    if n == 0:
        raise ConvertError("capture()[1] _xyz holds no Gaussians: the model is empty (refrender refuses an empty "
                           "model)")
    degree_t = n_deg_t if n_deg == 3 and not args.force_sh_3d else 0  # forward.cu:142, 479
    sh = sh_columns(features_of(capture, n), n_deg, degree_t, args.force_sh_3d)
    scaling, opacity = log_scales(capture, 4, n, 3), entry(capture, 6, n, (None, 1))
    rot_l = unit_quaternions(entry(capture, 5, n, (None, 4)), 5)
    t0, scaling_t = entry(capture, 13, n, (None, 1)), log_scales(capture, 14, n, 1)
    rot_r = unit_quaternions(entry(capture, 15, n, (None, 4)), 15)
    with np.errstate(over="ignore", under="ignore", invalid="ignore", divide="ignore"):
        velocity, t_var, log_scale, quat = conditional_form(scaling, scaling_t, rot_l, rot_r,
                                                            args.rotation_convention, args.prefilter_var)
        duration = args.time_duration[1] - args.time_duration[0]
        const = np.broadcast_to(np.array([duration, n_deg, degree_t], dtype=np.float64), (n, 3))
        columns = np.concatenate([xyz, t0, velocity, t_var[:, None], opacity, log_scale, quat, const, sh], axis=1)
        values = columns.astype("<f4")
    names = FDGS_NAMES + [f"sh4d_{i}" for i in range(sh.shape[1])]
    refrender_rules(columns, values, names)
    return names, values, has_env_map(capture)


def write_ply(path, names, values, comments, source=None):
    """The PLY, whole or not at all, never over the checkpoint source (scripts/safefiles.py)."""
    head = ["ply", "format binary_little_endian 1.0"] + [f"comment {c}" for c in comments]
    head += [f"element vertex {len(values)}"] + [f"property float {p}" for p in names] + ["end_header"]
    head = ("\n".join(head) + "\n").encode()
    body = np.ascontiguousarray(values, dtype="<f4")

    def put(tmp):
        with open(tmp, "wb") as f:
            f.write(head)
            body.tofile(f)

    def complete(tmp):
        if os.path.getsize(tmp) != len(head) + body.nbytes:
            raise OSError(f"{os.path.getsize(tmp)} of {len(head) + body.nbytes} bytes written (disk full?)")
    safefiles.write_file(path, put, safefiles.Inputs([source] if source else []), complete)


class Parser(argparse.ArgumentParser):
    def error(self, message):
        if "--rotation-convention" in message:
            message += "\n  " + CONVENTION_HELP
        super().error(message)


def parse_args(argv):
    p = Parser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter,
               epilog=__doc__.split("\n\n", 1)[1])
    p.add_argument("checkpoint", help="a 4DGS checkpoint: chkpnt<iteration>.pth or chkpnt_best.pth")
    p.add_argument("-o", "--output", required=True, help="the PLY to write (written whole or not at all)")
    p.add_argument("--rotation-convention", required=True, choices=sorted(CONVENTIONS), help=CONVENTION_HELP)
    p.add_argument("--time_duration", "--time-duration", nargs=2, type=float, required=True, metavar=("START", "END"),
                   help="the model's time_duration (its config's key, e.g. [0.0, 10.0] for dynerf, [0.0, 1.0] for "
                        "dnerf; divided by frame_ratio when that is > 1, train.py:40-41): T = END - START")
    p.add_argument("--prefilter_var", "--prefilter-var", type=float, required=True, metavar="V",
                   help="ModelParams.prefilter_var (arguments/__init__.py:62; -1.0, off, unless the model was "
                        "rendered with it): added to Sigma_tt in the temporal marginal when > 0")
    p.add_argument("--force_sh_3d", "--force-sh-3d", required=True, choices=["false", "true"],
                   help="the config's force_sh_3d (False in every 4DGS config): true uses 3D SH only")
    p.add_argument("--drop-env-map", action="store_true",
                   help="convert a model trained with an env_map (env_map_res > 0) without it: refrender draws the "
                        "scene's <background> behind the Gaussians, not the env_map 4DGS composites")
    args = p.parse_args(argv)
    args.force_sh_3d = args.force_sh_3d == "true"
    start, end = args.time_duration
    if not np.isfinite(args.time_duration).all() or not end > start:
        p.error(f"--time_duration {start} {end}: END must exceed START")
    with np.errstate(over="ignore"):
        duration = np.float32(end - start)
    if not (0 < duration < np.inf):
        p.error(f"--time_duration {start} {end}: T = END - START = {end - start:g} is {float(duration):g} as the "
                "float32 the PLY holds, and refrender refuses a T that is not above 0 or not finite")
    if not np.isfinite(args.prefilter_var):
        p.error(f"--prefilter_var {args.prefilter_var} is not finite")
    return args


def printable(text):
    """A file name for a PLY comment line: one line, bounded."""
    return clip("".join(c if c.isprintable() else "?" for c in text))


def convert_file(args):
    """Reads, converts and writes; returns (Gaussians, SH degree, time degree, env_map dropped)."""
    safefiles.Inputs([args.checkpoint]).check_output(args.output, "-o")  # before any work, again at the rename
    top, archive = torch_checkpoint.load(args.checkpoint)
    with archive.file:
        capture, iteration = read_capture(top)
        names, values, dropped_env = convert(capture, args)
    comments = ["4DGS model (fudan-zvg/4d-gaussian-splatting, rules read at 63725f21) converted by "
                "refrender scripts/convert_4dgs.py",
                f"source {printable(os.path.basename(args.checkpoint))} iteration {iteration}",
                f"rotation_convention {args.rotation_convention}",
                f"time_duration {args.time_duration[0]!r} {args.time_duration[1]!r}",
                f"prefilter_var {args.prefilter_var!r}", f"force_sh_3d {str(args.force_sh_3d).lower()}"]
    if dropped_env:
        comments.append("env_map dropped (--drop-env-map): the model's background is not in this file")
    write_ply(args.output, names, values, comments, args.checkpoint)
    return len(values), int(values[0, 17]), int(values[0, 18]), dropped_env



# what a conversion may fail with, each said in one line by failure_line
CONVERSION_FAILURES = (safefiles.FileRefused, ConvertError, OSError, MemoryError, RecursionError)


def failure_line(prog, checkpoint, e):
    """The one line a checkpoint converter prints for a failure (this one's
    and convert_checkpoint.py's): a refused file names itself; otherwise the
    checkpoint, then the reason, clipped."""
    if isinstance(e, safefiles.FileRefused):
        return f"{prog}: {clip(e, MAX_MESSAGE + 2000)}\n"
    reason = e.strerror if isinstance(e, OSError) and e.strerror else e
    if isinstance(e, (MemoryError, RecursionError)):
        reason = f"{type(e).__name__} while reading it: {e}"
    return f"{prog}: {checkpoint}: {clip(reason, MAX_MESSAGE)}\n"


def main(argv=None):
    args = parse_args(argv)
    try:
        count, degree, degree_t, dropped_env = convert_file(args)
    except CONVERSION_FAILURES as e:
        sys.stderr.write(failure_line("convert_4dgs.py", args.checkpoint, e))
        return 1
    print(f"{args.output}: {count} Gaussians, SH degree {degree} x time degree {degree_t}"
          + (", env_map dropped" if dropped_env else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
