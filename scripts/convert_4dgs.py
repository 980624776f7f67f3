#!/usr/bin/python3
"""Converts a real-time 4DGS checkpoint (Yang et al., ICLR 2024;
fudan-zvg/4d-gaussian-splatting, read at 63725f21) into a PLY refrender reads.

usage: convert_4dgs.py CHECKPOINT.pth -o OUT.ply
           --rotation-convention {before-900c592,after-900c592}
           --time_duration START END --prefilter_var V --force_sh_3d {false,true}

The checkpoint is what 4DGS's training saves: torch.save((gaussians.capture(),
iteration)) (scene/__init__.py:92, train.py:224), a torch zip archive whose
pickle is read by a restricted unpickler: it may name only
torch._utils._rebuild_tensor_v2, torch._utils._rebuild_parameter(_with_state),
collections.OrderedDict and torch's typed storage classes (as storage tags);
every other global is refused naming module.name, and nothing in the pickle is
called but those, the rebuilders implemented here in numpy. No torch needed.

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

Errors name the file and the entry (capture() index and name, Gaussian index)
and exit 1; usage errors exit 2; the output appears only when complete.
"""
import argparse
import collections
import io
import os
import pickle
import sys
import tempfile
import zipfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pydeps  # noqa: E402

pydeps.require("numpy")
import numpy as np  # noqa: E402

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


class ConvertError(Exception):
    pass


# ---- reading the checkpoint without torch ---------------------------------

class StorageTag:
    """torch.<T>Storage as a persistent id names it: a dtype, never called."""
    __slots__ = ("name", "dtype")

    def __init__(self, name, dtype):
        self.name, self.dtype = name, dtype

    def __call__(self, *args, **kwargs):
        raise ConvertError(f"the pickle calls torch.{self.name}, which is allowed only as a storage tag")

    def __setstate__(self, state):
        raise ConvertError(f"the pickle sets the state of torch.{self.name}")


STORAGE_DTYPES = {"DoubleStorage": "f8", "FloatStorage": "f4", "HalfStorage": "f2", "LongStorage": "i8",
                  "IntStorage": "i4", "ShortStorage": "i2", "CharStorage": "i1", "ByteStorage": "u1",
                  "BoolStorage": "?", "BFloat16Storage": "bf16"}


class LazyStorage:
    """One storage of the archive (data/<key>), read when a tensor needs it."""
    __slots__ = ("archive", "member", "dtype", "numel", "_data")

    def __init__(self, archive, member, dtype, numel):
        self.archive, self.member, self.dtype, self.numel, self._data = archive, member, dtype, numel, None

    def __setstate__(self, state):
        raise ConvertError("the pickle sets the state of a storage")

    def array(self):
        if self._data is None:
            try:
                raw = self.archive.zip.read(self.member)
            except (KeyError, zipfile.BadZipFile, OSError, EOFError) as e:
                raise ConvertError(f"storage '{self.member}' cannot be read: {e}") from None
            if self.dtype == "bf16":  # bfloat16: the high half of a float32
                u16 = np.frombuffer(raw[:len(raw) // 2 * 2], dtype=self.archive.order + "u2")
                data = (u16.astype(np.uint32) << 16).view(np.float32)
            else:
                data = np.frombuffer(raw, dtype=np.dtype(self.dtype).newbyteorder(self.archive.order))
            if data.size < self.numel:
                raise ConvertError(f"storage '{self.member}' holds {data.size} elements, the pickle says "
                                   f"{self.numel} (truncated archive?)")
            self._data = data[:self.numel]
        return self._data


class LazyTensor:
    """torch._utils._rebuild_tensor_v2's tensor: a strided view of a storage, read on demand."""
    __slots__ = ("storage", "offset", "shape", "stride")

    def __init__(self, storage, offset, shape, stride):
        self.storage, self.offset, self.shape, self.stride = storage, offset, shape, stride

    def __setstate__(self, state):
        raise ConvertError("the pickle sets the state of a tensor")

    def numpy(self):
        data = self.storage.array()
        if 0 in self.shape:
            return np.zeros(self.shape, dtype=data.dtype)
        last = self.offset + sum((n - 1) * s for n, s in zip(self.shape, self.stride))
        if self.offset < 0 or min(self.stride, default=0) < 0 or last >= data.size:
            raise ConvertError(f"tensor of shape {self.shape} stride {self.stride} offset {self.offset} "
                               f"reaches past its storage '{self.storage.member}' of {data.size}")
        view = np.lib.stride_tricks.as_strided(data[self.offset:], shape=self.shape,
                                               strides=[s * data.itemsize for s in self.stride], writeable=False)
        return np.array(view, dtype=np.float64 if data.dtype.kind == "f" else data.dtype)


def _ints(value, what):
    if not isinstance(value, tuple) or not all(type(v) is int for v in value):
        raise ConvertError(f"_rebuild_tensor_v2: {what} {value!r} is not a tuple of ints")
    return value


def rebuild_tensor_v2(storage, storage_offset, size, stride, requires_grad=False, backward_hooks=None,
                      metadata=None):
    if not isinstance(storage, LazyStorage) or type(storage_offset) is not int:
        raise ConvertError("_rebuild_tensor_v2: its storage is no archive storage")
    size, stride = _ints(size, "size"), _ints(stride, "stride")
    if len(size) != len(stride):
        raise ConvertError(f"_rebuild_tensor_v2: size {size} and stride {stride} differ in length")
    return LazyTensor(storage, storage_offset, size, stride)


def rebuild_parameter(data, requires_grad=False, backward_hooks=None, state=None):
    if not isinstance(data, LazyTensor):
        raise ConvertError("_rebuild_parameter: its data is no tensor")
    return data


ALLOWED = {("torch._utils", "_rebuild_tensor_v2"): rebuild_tensor_v2,
           ("torch._utils", "_rebuild_parameter"): rebuild_parameter,
           ("torch._utils", "_rebuild_parameter_with_state"): rebuild_parameter,
           ("collections", "OrderedDict"): collections.OrderedDict}
ALLOWED.update({("torch", name): StorageTag(name, dtype) for name, dtype in STORAGE_DTYPES.items()})


class RestrictedUnpickler(pickle.Unpickler):
    def __init__(self, data, archive):
        super().__init__(io.BytesIO(data))
        self.archive = archive

    def find_class(self, module, name):
        found = ALLOWED.get((module, name))
        if found is None:
            raise ConvertError(f"the pickle references {module}.{name}, which is not on the allow-list "
                               "(torch tensor rebuilders, storage tags, collections.OrderedDict): refused, "
                               "nothing was run")
        return found

    def persistent_load(self, pid):
        if not (isinstance(pid, tuple) and len(pid) == 5 and pid[0] == "storage" and
                isinstance(pid[1], StorageTag) and isinstance(pid[2], str) and type(pid[4]) is int and pid[4] >= 0):
            raise ConvertError(f"unknown persistent id {pid!r:.200} (expected ('storage', torch.<T>Storage, key, "
                               "location, numel))")
        return LazyStorage(self.archive, f"{self.archive.prefix}data/{pid[2]}", pid[1].dtype, pid[4])


class Archive:
    def __init__(self, path):
        with open(path, "rb") as f:
            head = f.read(4)
        if head[:1] == b"\x80":
            raise ConvertError("the legacy torch.save format (torch < 1.6, or _use_new_zipfile_serialization="
                               "False) is not supported: load and save it again with torch >= 1.6")
        try:
            self.zip = zipfile.ZipFile(path)
            names = self.zip.namelist()
        except (zipfile.BadZipFile, OSError, EOFError) as e:
            raise ConvertError(f"not a complete torch zip archive (truncated or damaged?): {e}") from None
        pickles = [n for n in names if n.endswith("/data.pkl") and n.count("/") == 1]
        if len(pickles) != 1:
            raise ConvertError(f"not a torch checkpoint: expected one <name>/data.pkl, found {len(pickles)}")
        self.prefix = pickles[0][:-len("data.pkl")]
        self.order = "<"
        if self.prefix + "byteorder" in names:
            order = self.zip.read(self.prefix + "byteorder").decode(errors="replace").strip()
            if order not in ("little", "big"):
                raise ConvertError(f"byteorder '{order}' is neither little nor big")
            self.order = "<" if order == "little" else ">"

    def load(self):
        try:
            data = self.zip.read(self.prefix + "data.pkl")
        except (zipfile.BadZipFile, OSError, EOFError) as e:
            raise ConvertError(f"data.pkl cannot be read (truncated or damaged?): {e}") from None
        try:
            return RestrictedUnpickler(data, self).load()
        except ConvertError:
            raise
        except Exception as e:  # a malformed pickle: anything the unpickler raises is the file's fault
            raise ConvertError(f"data.pkl is not a valid pickle: {type(e).__name__}: {e}") from None


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
    bad = np.argwhere(~np.isfinite(a))
    if len(bad):
        raise ConvertError(f"{name} is not finite at Gaussian {bad[0][0]}: {a[tuple(bad[0])]}")
    return a


def small_int(capture, index, low, high):
    v = capture[index]
    if type(v) is not int or not low <= v <= high:
        raise ConvertError(f"capture()[{index}] {CAPTURE_NAMES[index]} is {v!r}, expected an int in {low}..{high}")
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
        raise ConvertError(f"capture()[16] rot_4d is {capture[16]!r}: only rot_4d models (every 4DGS config) are "
                           "supported")
    return capture, top[1]


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
    """velocity, t_var, log scales and quaternions of the conditional 3D Gaussian."""
    s2 = np.exp(2 * np.concatenate([scaling, scaling_t], axis=1))
    rot = rotation_4d(rot_l, rot_r, convention)
    sigma = np.einsum("nik,nk,njk->nij", rot, s2, rot)
    cov_t = sigma[:, 3, 3]
    velocity = sigma[:, :3, 3] / cov_t[:, None]
    t_var = cov_t + prefilter_var if prefilter_var > 0 else cov_t  # forward.cu:333
    precision_xx = np.einsum("nik,nk,njk->nij", rot[:, :3, :], 1 / s2, rot[:, :3, :])
    mu, vec = np.linalg.eigh(precision_xx)
    if not np.all(mu > 0):
        i = int(np.flatnonzero(~(mu > 0).all(axis=1))[0])
        raise ConvertError(f"Gaussian {i}: its conditional covariance is not positive definite (scales "
                           f"{scaling[i]}, {scaling_t[i]})")
    vec[:, :, 2] *= np.sign(np.linalg.det(vec))[:, None]
    return velocity, t_var, -0.5 * np.log(mu), quaternion_of(vec)


def sh_columns(features, degree, degree_t, index):
    """The coefficients used, as sh4d_<3 (S k + j) + c> (features: N x M x 3, 4DGS's order)."""
    s = (degree + 1) ** 2
    used = [16 * k + j for k in range(degree_t + 1) for j in range(s)]
    if used[-1] >= features.shape[1]:
        raise ConvertError(f"capture()[{index}] _features_dc/_features_rest hold {features.shape[1]} coefficients "
                           f"per channel, SH degree {degree} x time degree {degree_t} needs {used[-1] + 1} "
                           "(a force_sh_3d model? then say --force_sh_3d true)")
    return features[:, used, :].reshape(len(features), -1)


def convert(capture, args):
    n_deg, n_deg_t = small_int(capture, 0, 0, 3), small_int(capture, 18, 0, 2)
    xyz = entry(capture, 1, shape=(None, 3))
    n = len(xyz)
    dc = entry(capture, 2, n, (None, 1, 3))
    rest = capture[3]
    rest = entry(capture, 3) if isinstance(rest, LazyTensor) else rest
    if not isinstance(rest, np.ndarray) or rest.ndim != 3 or rest.shape[0] != n or rest.shape[2] != 3:
        raise ConvertError(f"capture()[3] _features_rest has shape {getattr(rest, 'shape', None)}, expected "
                           f"(N, M - 1, 3) with N = {n}")
    features = np.concatenate([dc, rest], axis=1)  # get_features (gaussian_model.py:212-215)
    degree_t = n_deg_t if n_deg == 3 and not args.force_sh_3d else 0  # forward.cu:142, 479
    sh = sh_columns(features, n_deg, degree_t, 3)
    scaling, opacity = entry(capture, 4, n, (None, 3)), entry(capture, 6, n, (None, 1))
    rot_l = unit_quaternions(entry(capture, 5, n, (None, 4)), 5)
    t0, scaling_t = entry(capture, 13, n, (None, 1)), entry(capture, 14, n, (None, 1))
    rot_r = unit_quaternions(entry(capture, 15, n, (None, 4)), 15)
    velocity, t_var, log_scale, quat = conditional_form(scaling, scaling_t, rot_l, rot_r, args.rotation_convention,
                                                        args.prefilter_var)
    duration = args.time_duration[1] - args.time_duration[0]
    const = np.broadcast_to(np.array([duration, n_deg, degree_t], dtype=np.float64), (n, 3))
    columns = np.concatenate([xyz, t0, velocity, t_var[:, None], opacity, log_scale, quat, const, sh], axis=1)
    names = (["x", "y", "z", "t_center", "vel_0", "vel_1", "vel_2", "t_var", "opacity", "scale_0", "scale_1",
              "scale_2", "rot_0", "rot_1", "rot_2", "rot_3", "time_duration", "sh_degree", "sh_degree_t"] +
             [f"sh4d_{i}" for i in range(sh.shape[1])])
    values = columns.astype("<f4")
    bad = np.argwhere(~np.isfinite(values))
    if len(bad):
        raise ConvertError(f"Gaussian {bad[0][0]}: '{names[bad[0][1]]}' = {columns[tuple(bad[0])]} is beyond float32")
    env = capture[17]
    has_env = isinstance(env, LazyTensor) and all(env.shape) and len(env.shape) > 0
    return names, values, has_env


def write_ply(path, names, values, comments):
    head = ["ply", "format binary_little_endian 1.0"] + [f"comment {c}" for c in comments]
    head += [f"element vertex {len(values)}"] + [f"property float {p}" for p in names] + ["end_header"]
    directory = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".convert_4dgs.", dir=directory)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(("\n".join(head) + "\n").encode())
            f.write(np.ascontiguousarray(values).tobytes())
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


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
    args = p.parse_args(argv)
    args.force_sh_3d = args.force_sh_3d == "true"
    if not np.isfinite(args.time_duration).all() or not args.time_duration[1] > args.time_duration[0]:
        p.error(f"--time_duration {args.time_duration[0]} {args.time_duration[1]}: END must exceed START")
    if not np.isfinite(args.prefilter_var):
        p.error(f"--prefilter_var {args.prefilter_var} is not finite")
    return args


def main(argv=None):
    args = parse_args(argv)
    try:
        capture, iteration = read_capture(Archive(args.checkpoint).load())
        names, values, has_env = convert(capture, args)
    except ConvertError as e:
        sys.stderr.write(f"convert_4dgs.py: {args.checkpoint}: {e}\n")
        return 1
    except OSError as e:
        sys.stderr.write(f"convert_4dgs.py: {args.checkpoint}: {e.strerror or e}\n")
        return 1
    comments = ["4DGS model (fudan-zvg/4d-gaussian-splatting, rules read at 63725f21) converted by "
                "refrender scripts/convert_4dgs.py",
                f"source {os.path.basename(args.checkpoint)} iteration {iteration}",
                f"rotation_convention {args.rotation_convention}",
                f"time_duration {args.time_duration[0]!r} {args.time_duration[1]!r}",
                f"prefilter_var {args.prefilter_var!r}", f"force_sh_3d {str(args.force_sh_3d).lower()}"]
    try:
        write_ply(args.output, names, values, comments)
    except OSError as e:
        sys.stderr.write(f"convert_4dgs.py: {args.output}: {e.strerror or e}\n")
        return 1
    if has_env:
        sys.stderr.write(f"convert_4dgs.py: {args.checkpoint}: capture()[17] env_map is not empty: 4DGS draws "
                         "its background from it when env_map_res > 0; the PLY holds the Gaussians only\n")
    print(f"{args.output}: {len(values)} Gaussians, SH degree {int(values[0, 17]) if len(values) else 0} x time "
          f"degree {int(values[0, 18]) if len(values) else 0}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
