"""Independent numpy reference of real-time 4DGS (Yang et al., ICLR 2024): native 4D Gaussians
conditioned on time, as the official code draws them. Written from the official source only,
without reading refrender's C or its converter (scripts/convert_4dgs.py).

SRC = fudan-zvg/4d-gaussian-splatting at 63725f21 (rules below cite SRC file:line); FWD = its
rasterizer, SRC diff-gaussian-rasterization/cuda_rasterizer/forward.cu.

Checkpoint: train.py:224 saves `torch.save((gaussians.capture(), iteration), path)`; for a 4D
model capture() is the 19-tuple of scene/gaussian_model.py:116-136 (CAPTURE_FIELDS, same order
in restore() :153-171). Tensors are stored pre-activation:
  xyz (N, 3) the mean at the Gaussian's own time t (N, 1), both as is (:200-209);
  scaling (N, 3) and scaling_t (N, 1): exp (:49, :180-189);
  rotation (N, 4) the left quaternion (a, b, c, d), rotation_r (N, 4) the right one (p, q, r, s):
    F.normalize, i.e. q / max(|q|, 1e-12) (:60, :191-197);
  opacity (N, 1): sigmoid (:57, :217-219);
  features = cat(features_dc (N, 1, 3), features_rest (N, K-1, 3)) along dim 1 (:211-215); K is
    (max_sh_degree + 1)^2 (max_sh_degree_t + 1) when sh_degree_t > 0 (:227-228); train.py:45
    sets sh_degree_t = 2 when the pipeline's eval_shfs_4d is on (every shipped config, e.g.
    configs/dnerf/lego.yaml:32), else 0;
  active_sh_degree, active_sh_degree_t (entries 0 and 18) are the degrees the renderer hands the
    rasterizer (gaussian_renderer/__init__.py:46-47).
Not in the checkpoint (config values): time_duration (configs/*.yaml:2, divided by frame_ratio
in train.py:40-41; the rasterizer gets only T = time_duration[1] - time_duration[0],
gaussian_renderer/__init__.py:50), force_sh_3d (False in every config), prefilter_var
(ModelParams, default -1: off, arguments/__init__.py:62).

Which path: the pipeline defaults compute_cov3D_python = convert_SHs_python = False
(arguments/__init__.py:72-73, and every config), so the renderer hands the CUDA the normalised
quaternions, exp scales, t and the features (gaussian_renderer/__init__.py:82-91, :112-115) and
the CUDA forms everything below (FWD:415-426, :476-483). That is the path this reference draws.

4D rotation (SRC utils/general_utils.py:113-133): with the unit quaternions,
  M_l = [[a,-b,-c,-d], [b,a,-d,c], [c,d,a,-b], [d,-c,b,a]]           (:123-126)
  M_r = [[p,q,r,s], [-q,p,-s,r], [-r,s,p,-q], [-s,-r,q,p]]           (:127-130)
  A = M_l M_r                                                        (:131)
  convention "before-900c592": R = A (general_utils.py:131-132 at 5094ca8, the parent of 900c592;
    FWD at 5094ca8 :301-315 forms the transpose in glm's column-major storage, R = M_r * M_l of
    the matrices written row by row as above, and uses R^T S^2 R: the same covariance);
  convention "after-900c592": R = A.flip(1, 2), i.e. R[i][j] = A[3-i][3-j], rows AND columns
    reversed (general_utils.py:131-132 at 63725f21; FWD:315-329 writes the flipped M_l, M_r).
  Checkpoints carry no tag for it, hence the `convention` argument everywhere.
4D covariance: L = R diag(s_x, s_y, s_z, s_t) (general_utils.py:135-145), Sigma = L L^T
(gaussian_model.py:34-36; FWD:330-331 M = S R, Sigma = M^T M in glm's storage: the same).
Conditioning on timestamp t (dt = t - t_0; gaussian_model.py:247-251, FWD:284):
  cov3 = Sigma_xx - Sigma_xt Sigma_xt^T / Sigma_tt                 (gaussian_model.py:37-40, FWD:337-339)
  mean = xyz + Sigma_xt / Sigma_tt * dt                             (gaussian_model.py:43-46, FWD:348-351)
  marginal = exp(-0.5 dt^2 / Sigma_tt) (Sigma_tt + prefilter_var when that is > 0)
                                                                    (gaussian_model.py:238-242, FWD:332-333)
  cut: drawn only if marginal > 0.05 (FWD:334-335, :421 returns before anything is drawn: a
  Gaussian at exactly 0.05 is dropped; the Python path's mask is the same `> 0.05`,
  gaussian_renderer/__init__.py:123); opacity = sigmoid(opacity) * marginal (FWD:336).
The shifted mean is what is culled and projected (FWD:423-425, :442-451).
Colour (FWD:73-195, called at :482 with orig_points, the CANONICAL xyz, not the shifted mean;
the Python path, convert_SHs_python, uses the shifted mean, gaussian_renderer/__init__.py:
100-104): d = normalise(xyz - campos) (FWD:79-81); dir_t = t_0 - timestamp (FWD:83); the 3DGS real
SH up to degree 3 (FWD:87-140), then, ONLY inside `deg > 2` (FWD:123, :142), the time harmonics
cos(2 pi dir_t / T) times the same 16 basis values on sh[16:32] if deg_t > 0 (FWD:142-160) and
cos(2 pi 2 dir_t / T) on sh[32:48] if deg_t > 1 (FWD:162-180); the coefficient stride is K =
features.shape[1] (rasterize_points.cu:99-102); + 0.5 (FWD:187), clamped below at 0 (FWD:194).
(SRC utils/sh_utils.py:181-203, the Python path's eval_shfs_4d, adds the time terms at any
spatial degree: it differs from the CUDA when active_sh_degree < 3.)
The rest is Inria's rasterizer without antialiasing (FWD:198-236 adds 0.3 in computeCov2D;
blending FWD renderCUDA: alpha = min(0.99, .), < 1/255 skipped, T < 1e-4 stops):
tests/gs3d_raster_reference.py's "inria" variant with precomputed covariances and colours.
Scale modifier 1 (the renderer's default). Time: `t` is the model's timestamp (the dataset's
camera timestamps lie in time_duration)."""
import math

import numpy as np

import gs3d_raster_reference as raster

CAPTURE_FIELDS = ("active_sh_degree", "xyz", "features_dc", "features_rest", "scaling", "rotation", "opacity",
                  "max_radii2D", "xyz_gradient_accum", "t_gradient_accum", "denom", "optimizer_state",
                  "spatial_lr_scale", "t", "scaling_t", "rotation_r", "rot_4d", "env_map", "active_sh_degree_t")
CONVENTIONS = ("before-900c592", "after-900c592")
MARGINAL_CUT = 0.05       # FWD:334, drawn only if marginal > 0.05
NORMALIZE_EPS = 1e-12     # torch.nn.functional.normalize's default eps (gaussian_model.py:60)
SH_C0 = raster.SH_C0
SH_C1 = raster.SH_C1
SH_C2 = raster.SH_C2
SH_C3 = raster.SH_C3


def unpack(capture):
    """The capture() tuple (or a dict by CAPTURE_FIELDS) as a dict of float64 arrays (shapes as
    stored: t, scaling_t, opacity (N, 1))."""
    if not isinstance(capture, dict):
        if len(capture) != len(CAPTURE_FIELDS):
            raise ValueError("a 4D capture() has %d entries, got %d" % (len(CAPTURE_FIELDS), len(capture)))
        capture = dict(zip(CAPTURE_FIELDS, capture))
    raw = dict(capture)
    for k in ("xyz", "features_dc", "features_rest", "scaling", "rotation", "opacity", "t", "scaling_t",
              "rotation_r"):
        v = capture[k]
        v = v.detach().cpu().numpy() if hasattr(v, "detach") else v
        raw[k] = np.asarray(v, np.float64)
    if not raw["rot_4d"]:
        raise ValueError("rot_4d is False: this reference draws the rot_4d models of every shipped config")
    return raw


def normalize(q):
    """torch.nn.functional.normalize (gaussian_model.py:60): q / max(|q|, 1e-12)."""
    q = np.asarray(q, np.float64)
    return q / max(np.linalg.norm(q), NORMALIZE_EPS)


def left_matrix(ql):
    """M_l of the unit left quaternion (a, b, c, d), general_utils.py:123-126, row by row."""
    a, b, c, d = ql
    return np.array([[a, -b, -c, -d], [b, a, -d, c], [c, d, a, -b], [d, -c, b, a]])


def right_matrix(qr):
    """M_r of the unit right quaternion (p, q, r, s), general_utils.py:127-130, row by row."""
    p, q, r, s = qr
    return np.array([[p, q, r, s], [-q, p, -s, r], [-r, s, p, -q], [-s, -r, q, p]])


def rotation_4d(rotation, rotation_r, convention):
    """The 4D rotation of the stored quaternions (normalised first) under the convention
    (module docstring): A = M_l M_r, or A with rows and columns reversed after 900c592."""
    if convention not in CONVENTIONS:
        raise ValueError("convention must be one of %s, got %r" % (CONVENTIONS, convention))
    A = left_matrix(normalize(rotation)) @ right_matrix(normalize(rotation_r))
    return A[::-1, ::-1].copy() if convention == "after-900c592" else A


def covariance_4d(scaling, scaling_t, rotation, rotation_r, convention):
    """Sigma = R diag(s)^2 R^T from the raw (log) scales, s = exp(scaling, scaling_t)."""
    s = np.exp(np.append(np.asarray(scaling, np.float64), scaling_t))
    L = rotation_4d(rotation, rotation_r, convention) @ np.diag(s)
    return L @ L.T


def condition(sigma4, dt, prefilter_var=-1.0):
    """(mean offset (3,), conditional covariance (3, 3), marginal) of a 4D covariance at dt = t - t_0."""
    s_tt = sigma4[3, 3]
    s_xt = sigma4[:3, 3]
    cov3 = sigma4[:3, :3] - np.outer(s_xt, s_xt) / s_tt
    var_t = s_tt + prefilter_var if prefilter_var > 0.0 else s_tt
    return s_xt / s_tt * dt, cov3, math.exp(-0.5 * dt * dt / var_t)


def sh_basis(d):
    """The 16 real SH basis values of FWD:87-131 at unit direction d (signs as the CUDA's)."""
    x, y, z = d
    xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
    return np.array([SH_C0, -SH_C1 * y, SH_C1 * z, -SH_C1 * x,
                     SH_C2[0] * xy, SH_C2[1] * yz, SH_C2[2] * (2 * zz - xx - yy), SH_C2[3] * xz,
                     SH_C2[4] * (xx - yy),
                     SH_C3[0] * y * (3 * xx - yy), SH_C3[1] * xy * z, SH_C3[2] * y * (4 * zz - xx - yy),
                     SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy), SH_C3[4] * x * (4 * zz - xx - yy),
                     SH_C3[5] * z * (xx - yy), SH_C3[6] * x * (xx - 3 * yy)])


def sh4d_colour(sh, degree, degree_t, d, dir_t, duration, time_terms_at_any_degree=False):
    """RGB of the 4D SH coefficients sh (K, 3) (FWD:73-195): spatial degree `degree` at unit
    direction d, time harmonics cos(2 pi k dir_t / duration), k = 1..degree_t, only when
    degree > 2 (FWD:123, :142) unless time_terms_at_any_degree (the Python path's rule, a planted
    variant); + 0.5, clamped below at 0."""
    sh = np.asarray(sh, np.float64)
    basis = sh_basis(d)
    n = (degree + 1) ** 2
    result = basis[:n] @ sh[:n]
    if degree > 2 or time_terms_at_any_degree:
        for k in range(1, min(degree_t, 2) + 1):
            harmonic = math.cos(2 * math.pi * k * dir_t / duration)
            result = result + harmonic * (basis[:n] @ sh[16 * k:16 * k + n])
    return np.maximum(result + 0.5, 0.0)


def fdgs_at(capture, t, convention, time_duration, campos, sh_degree=None, sh_degree_t=None,
            prefilter_var=-1.0, view_direction="cuda", cut=True, time_terms_at_any_degree=False):
    """What the rasterizer receives at timestamp t, as a tests/gs3d_raster_reference.py model dict
    (mean, cov3d_precomp, opacity, colors_precomp, index: the Gaussian's row in the capture) of
    the Gaussians drawn (marginal > 0.05). time_duration: (t_begin, t_end) of the config, or T as a
    number. sh_degree, sh_degree_t: the active degrees, the capture's own when None. campos: the
    camera centre. Planted variants for the self-tests: view_direction="python" (the shifted
    mean's), cut=False (no 0.05 cut), time_terms_at_any_degree."""
    raw = unpack(capture)
    duration = (time_duration[1] - time_duration[0]) if np.ndim(time_duration) else float(time_duration)
    degree = int(raw["active_sh_degree"] if sh_degree is None else sh_degree)
    degree_t = int(raw["active_sh_degree_t"] if sh_degree_t is None else sh_degree_t)
    features = np.concatenate([raw["features_dc"], raw["features_rest"]], axis=1)
    campos = np.asarray(campos, np.float64)
    model = {"mean": [], "cov3d_precomp": [], "opacity": [], "colors_precomp": [], "index": [], "marginal": []}
    for n in range(len(raw["xyz"])):
        t0 = raw["t"][n, 0]
        sigma4 = covariance_4d(raw["scaling"][n], raw["scaling_t"][n, 0], raw["rotation"][n], raw["rotation_r"][n],
                               convention)
        offset, cov3, marginal = condition(sigma4, t - t0, prefilter_var)
        if cut and not marginal > MARGINAL_CUT:
            continue
        canonical = raw["xyz"][n]
        mean = canonical + offset
        d = (canonical if view_direction == "cuda" else mean) - campos
        colour = sh4d_colour(features[n], degree, degree_t, d / np.linalg.norm(d), t0 - t, duration,
                             time_terms_at_any_degree)
        opacity = 1.0 / (1.0 + math.exp(-raw["opacity"][n, 0])) * marginal
        for key, v in (("mean", mean), ("cov3d_precomp", cov3), ("opacity", opacity), ("colors_precomp", colour),
                       ("index", n), ("marginal", marginal)):
            model[key].append(v)
    return {k: np.array(v, np.float64) if k != "index" else np.array(v, int) for k, v in model.items()}


def render_instant(capture, t, convention, time_duration, R_c2w, C, fx, fy, W, H, background=(0.0, 0.0, 0.0),
                   rasterizer_tan_fov=None, **variant):
    """The sharp image at timestamp t (pixel centres, Inria's rasterizer without tiles): (image
    (H, W, 3), final T (H, W)). variant: fdgs_at's keyword arguments (degrees, planted errors).
    rasterizer_tan_fov: the (tanfovx, tanfovy) the rasterizer is handed, (tan(-0.5), tan(-0.5)) for
    a transforms.json camera with fl_x (gs3d_raster_reference.py); None: the camera's own."""
    model = fdgs_at(capture, t, convention, time_duration, C, **variant)
    if len(model["opacity"]) == 0:
        return np.broadcast_to(np.asarray(background, np.float64), (H, W, 3)).copy(), np.ones((H, W))
    return raster.render(model, R_c2w, C, fx, fy, W, H, background, "inria", rasterizer_tan_fov=rasterizer_tan_fov)


def cut_crossings(capture, convention, t0, t1, prefilter_var=-1.0):
    """The times in (t0, t1) where a Gaussian's marginal crosses the 0.05 cut:
    t_0 +- sqrt(2 var_t ln 20)."""
    raw = unpack(capture)
    out = []
    for n in range(len(raw["xyz"])):
        sigma4 = covariance_4d(raw["scaling"][n], raw["scaling_t"][n, 0], raw["rotation"][n], raw["rotation_r"][n],
                               convention)
        var_t = sigma4[3, 3] + (prefilter_var if prefilter_var > 0.0 else 0.0)
        half = math.sqrt(2.0 * var_t * math.log(1.0 / MARGINAL_CUT))
        out += [c for c in (raw["t"][n, 0] - half, raw["t"][n, 0] + half) if t0 < c < t1]
    return sorted(out)


def fine_average(capture, convention, time_duration, t0, t1, n, R_c2w, C, fx, fy, W, H,
                 background=(0.0, 0.0, 0.0), **variant):
    """The box-shutter average over [t0, t1]: the midpoint rule on each piece between the cut's
    crossings (so the cut's jumps fall between pieces, not inside a midpoint cell), n instants
    shared by length, at least 2 a piece. Returns (mean image, mean alpha 1 - T)."""
    edges = [t0] + cut_crossings(capture, convention, t0, t1, variant.get("prefilter_var", -1.0)) + [t1]
    image, alpha = np.zeros((H, W, 3)), np.zeros((H, W))
    for a, b in zip(edges[:-1], edges[1:]):
        m = max(2, int(round(n * (b - a) / (t1 - t0))))
        for k in range(m):
            img, T = render_instant(capture, a + (b - a) * (k + 0.5) / m, convention, time_duration, R_c2w, C,
                                    fx, fy, W, H, background, **variant)
            w = (b - a) / m / (t1 - t0)
            image += w * img
            alpha += w * (1.0 - T)
    return image, alpha


def make_capture(xyz, features, scaling, rotation, opacity, t, scaling_t, rotation_r, active_sh_degree=3,
                 active_sh_degree_t=2, spatial_lr_scale=1.0):
    """A 4D capture() tuple (gaussian_model.py:116-136) of float32 numpy arrays from raw
    (pre-activation) values: features (N, K, 3) is split into features_dc (N, 1, 3) and
    features_rest (N, K-1, 3); opacity, t, scaling_t become (N, 1); the training-only entries
    (max_radii2D, gradient accumulators, denom, the optimizer's state) are zeros / empty."""
    f32 = lambda v: np.ascontiguousarray(np.asarray(v, np.float32))
    n = len(xyz)
    features = f32(features)
    col = lambda v: f32(v).reshape(n, 1)
    optimizer_state = {"state": {}, "param_groups": []}
    return (int(active_sh_degree), f32(xyz).reshape(n, 3), features[:, :1], features[:, 1:],
            f32(scaling).reshape(n, 3), f32(rotation).reshape(n, 4), col(opacity),
            np.zeros(n, np.float32), np.zeros((n, 1), np.float32), np.zeros((n, 1), np.float32),
            np.zeros((n, 1), np.float32), optimizer_state, float(spatial_lr_scale),
            col(t), col(scaling_t), f32(rotation_r).reshape(n, 4), True, np.zeros(0, np.float32),
            int(active_sh_degree_t))


def torch_or_none():
    try:
        import torch
    except ImportError:
        return None
    return torch


def save_checkpoint_with_torch(path, capture, iteration):
    """Write the checkpoint as train.py:224 does, torch.save((capture(), iteration), path): the
    learnable tensors as torch.nn.Parameter (as the model holds them, gaussian_model.py create_from_pcd),
    the rest as tensors or as given. On CPU: the official ones are CUDA tensors (a reader maps them
    with map_location). Needs torch (raises ImportError without it)."""
    import torch
    params = {"xyz", "features_dc", "features_rest", "scaling", "rotation", "opacity", "t", "scaling_t",
              "rotation_r"}
    out = []
    for name, v in zip(CAPTURE_FIELDS, capture):
        if isinstance(v, np.ndarray):
            v = torch.from_numpy(np.ascontiguousarray(v))
            if name in params:
                v = torch.nn.Parameter(v.requires_grad_(True))
        out.append(v)
    torch.save((tuple(out), int(iteration)), str(path))
