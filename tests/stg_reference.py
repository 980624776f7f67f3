"""An independent numpy reference of SpacetimeGaussians "lite" models (Li et al., "Spacetime
Gaussian Feature Splatting for Real-Time Dynamic View Synthesis", CVPR 2024): their PLY, the
static 3D Gaussians the official renderer hands its rasterizer at a time t, a sharp image at t
through tests/gs3d_raster_reference.py (Inria's rasterizer, which STG's forward_lite copies), and a
closed form for one flat Gaussian's time average at a pixel. Written from the primary source below,
read for its rules (no code copied); refrender's own C was not read.

Source: STG = oppo-us-research/SpacetimeGaussians at 427abfc58309a4a5213843dd673fb22c4529306c
(2025-03-30). Paths below are relative to thirdparty/gaussian_splatting/ unless they start with
`/`; FWD = submodules/forward_lite/cuda_rasterizer/forward.cu, IMPL = the same directory's
rasterizer_impl.cu, LITE = scene/ourslite.py, RENDER = renderer/__init__.py.

The file (LITE save_ply :361-387, construct_list_of_attributes :335-359)
  One `vertex` element of 32 float32 properties, binary (plyfile's default, native = little
  endian here), in this order: x y z (:336), trbf_center trbf_scale (:336), nx ny nz (:336; zeros,
  :365), motion_0..8 (:342-343), f_dc_0..2 (:345-346; 3 = features_dc.shape[1], the RGB the
  point cloud starts from, :187, :204), opacity (:349), scale_0..2 (:350-351), rot_0..3
  (:352-353), omega_0..3 (:354-355); the values are the raw parameters (:364-384), no
  activation. load_ply (:762-837) reads each property by name.

The Gaussians at time t (test.py:118 takes RENDER test_ours_lite for "train_ours_lite" models;
  /helper_train.py:72-76 binds it to forward_lite's rasterizer)
  D = t - trbf_center                                RENDER:318 (rotation); FWD:186 (mean, opacity)
  mean = xyz + motion[0:3] D + motion[3:6] D^2 + motion[6:9] D^3
                                                     FWD:187-198 (the raw xyz and motion, RENDER:335-336)
    So motion_0..2 is the velocity, per axis. (LITE:221's comment "x1, x2, x3, y1, y2, y3, ..."
    suggests another order; the CUDA indexes motion[9 i + 0..2] with D, and the training path
    RENDER:413 agrees.)
  q = normalize(rot + D omega), once                 LITE:123-126, the activation torch's
    F.normalize (LITE:40): v / max(|v|, 1e-12) (p = 2, dim = 1, eps = 1e-12 by default), so
    q = 0 stays 0; the CUDA then uses q as given, not normalised again (FWD:127), and its
    matrix (FWD:134-138) of q = 0 is the identity. Gaussians added by error-guided sampling
    start with rot = 0 (LITE:1235-1236: zeros, then rot[:, 1] = 0 again) and omega = 0
    (LITE:1229). A non-unit q reaches the CUDA only when 0 < |rot + D omega| < 1e-12.
  scale = exp(scale)                                 LITE:837 (computedscales), RENDER:341;
                                                     scale_modifier 1 (test.py:129)
  opacity = sigmoid(opacity) exp(-(D / exp(trbf_scale))^2)
                                                     LITE:835-836 (computedtrbfscale = exp,
                                                     computedopacity = sigmoid), RENDER:334, 340,
                                                     FWD:202-204. No 1/2 in the exponent (the
                                                     training path: /helper_train.py:390-391
                                                     exp(-x^2), RENDER:400-404, the same), and no
                                                     temporal cut-off: only the rasterizer's
                                                     alpha < 1/255 skip (FWD:418-420).
  colour = f_dc as stored                            LITE:139-140 (get_features returns
                                                     _features_dc), RENDER:320, 339 as
                                                     colors_precomp; the SH step (+ 0.5, clamp
                                                     at 0, FWD:20-71) is skipped (FWD:316) and the
                                                     blend reads the given colours (IMPL:374):
                                                     no offset, no clamp per Gaussian.
  The rasterizer is Inria's (FWD differs from graphdeco-inria/diff-gaussian-rasterization
  59f5f77e's forward.cu only by prepreprocessCUDA, FWD:168-205, and constness): near cull
  z <= 0.2 on the moved mean (auxiliary.h:154, IMPL:302), EWA with the 0.3 dilation
  (FWD:74-113), alpha = min(0.99, o exp(power)) (FWD:418), the T < 1e-4 stop (FWD:421-426),
  background black in test.py (:218-219) -- tests/gs3d_raster_reference.py variant "inria".
  The image: test.py clamps each instant's composited image to [0, 1] (:131) before its
  metrics; the rasterizer itself does not (render_instant's `clamp`).

Time (scene/dataset_readers.py)
  One model per segment of `duration` frames (50 in every lite config, e.g.
  /configs/n3d_lite/cook_spinach.json); frame j of the segment starting at frame `startime` has
  timestamp (j - startime) / duration (:159-170 and the other readers, :248, :447). So t is in
  [0, 49/50] over the segment's frames.

Floats: the CUDA and torch work in float32; this reference in float64 from the stored float32
values (differences of order 1e-7 relative).
"""
import math

import numpy as np

import gs3d_raster_reference as raster

# LITE:336-355, in save_ply's order
PROPERTIES = (["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz"] + [f"motion_{i}" for i in range(9)]
              + [f"f_dc_{i}" for i in range(3)] + ["opacity"] + [f"scale_{i}" for i in range(3)]
              + [f"rot_{i}" for i in range(4)] + [f"omega_{i}" for i in range(4)])
# the raw dict's fields: name -> number of columns (in the file's order)
FIELDS = {"xyz": 3, "trbf_center": 1, "trbf_scale": 1, "motion": 9, "f_dc": 3, "opacity": 1, "scale": 3,
          "rot": 4, "omega": 4}
NORMALIZE_EPS = 1e-12   # torch.nn.functional.normalize's default eps (LITE:40, :126)


def _columns(raw):
    """The raw dict as float64 arrays of shape (N, width), checked."""
    n = len(np.asarray(raw["xyz"]))
    out = {}
    for name, width in FIELDS.items():
        a = np.asarray(raw[name], np.float64).reshape(n, width)
        out[name] = a
    return out


def write_stg_lite_ply(path, fields):
    """Writes the raw (pre-activation) parameters in save_ply's layout (LITE:361-387): the 32
    float32 properties of PROPERTIES, binary little endian, normals 0. fields: xyz (N,3),
    trbf_center (N,), trbf_scale (N,), motion (N,9), f_dc (N,3), opacity (N,), scale (N,3),
    rot (N,4) w first, omega (N,4)."""
    c = _columns(fields)
    n = len(c["xyz"])
    data = np.concatenate([c["xyz"], c["trbf_center"], c["trbf_scale"], np.zeros((n, 3)), c["motion"], c["f_dc"],
                           c["opacity"], c["scale"], c["rot"], c["omega"]], axis=1).astype("<f4")
    assert data.shape[1] == len(PROPERTIES)
    head = "ply\nformat binary_little_endian 1.0\nelement vertex %d\n" % n
    head += "".join(f"property float {p}\n" for p in PROPERTIES) + "end_header\n"
    with open(path, "wb") as f:
        f.write(head.encode("ascii") + data.tobytes())


def read_stg_lite_ply(path):
    """The raw parameters of a lite PLY (float64 from the stored float32), read by name as
    load_ply does (LITE:767-813); every property of PROPERTIES must be there, as float."""
    data = open(path, "rb").read()
    head, sep, body = data.partition(b"end_header\n")
    if not sep:
        raise ValueError(f"{path}: no end_header")
    lines = head.decode("ascii").splitlines()
    if lines[:2] != ["ply", "format binary_little_endian 1.0"]:
        raise ValueError(f"{path}: not a binary little-endian PLY: {lines[:2]}")
    count = int(next(l for l in lines if l.startswith("element vertex")).split()[2])
    props = [l.split() for l in lines if l.startswith("property")]
    if any(p[1] != "float" for p in props):
        raise ValueError(f"{path}: only float properties are read here")
    names = [p[2] for p in props]
    missing = [p for p in PROPERTIES if p not in names]
    if missing:
        raise ValueError(f"{path}: missing properties {missing}")
    v = np.frombuffer(body, dtype="<f4", count=count * len(names)).reshape(count, len(names)).astype(np.float64)
    col = {p: v[:, i] for i, p in enumerate(names)}
    stack = lambda prefix, k: np.stack([col[f"{prefix}{i}"] for i in range(k)], axis=1)
    return {"xyz": np.stack([col["x"], col["y"], col["z"]], axis=1), "trbf_center": col["trbf_center"],
            "trbf_scale": col["trbf_scale"], "motion": stack("motion_", 9), "f_dc": stack("f_dc_", 3),
            "opacity": col["opacity"], "scale": stack("scale_", 3), "rot": stack("rot_", 4),
            "omega": stack("omega_", 4)}


def time_offset(raw, t):
    """D = t - trbf_center, per Gaussian (N, 1) (RENDER:318, FWD:186)."""
    return float(t) - _columns(raw)["trbf_center"]


def means_at(raw, t):
    """xyz + motion[0:3] D + motion[3:6] D^2 + motion[6:9] D^3 (FWD:187-198)."""
    c, D = _columns(raw), time_offset(raw, t)
    m = c["motion"]
    return c["xyz"] + m[:, 0:3] * D + m[:, 3:6] * D * D + m[:, 6:9] * D * D * D


def quaternions_at(raw, t):
    """normalize(rot + D omega) with torch's eps (LITE:123-126, :40): the quaternion the CUDA
    uses as given (FWD:127)."""
    c, D = _columns(raw), time_offset(raw, t)
    v = c["rot"] + D * c["omega"]
    return v / np.maximum(np.linalg.norm(v, axis=1), NORMALIZE_EPS)[:, None]


def opacities_at(raw, t):
    """sigmoid(opacity) exp(-(D / exp(trbf_scale))^2) (LITE:835-836, FWD:202-204; no 1/2)."""
    c, D = _columns(raw), time_offset(raw, t)
    base = 1.0 / (1.0 + np.exp(-c["opacity"][:, 0]))
    return base * np.exp(-(D[:, 0] / np.exp(c["trbf_scale"][:, 0])) ** 2)


def stg_lite_at(raw, t):
    """The static Gaussians the rasterizer receives at time t, as a model dict for
    gs3d_raster_reference.render: mean, rot (the quaternion as the CUDA uses it, with
    quaternion_as_given), scale (exp, LITE:837), opacity, colors_precomp (f_dc as stored,
    RENDER:320, FWD:316, IMPL:374)."""
    c = _columns(raw)
    return {"mean": means_at(raw, t), "rot": quaternions_at(raw, t), "quaternion_as_given": True,
            "scale": np.exp(c["scale"]), "opacity": opacities_at(raw, t), "colors_precomp": c["f_dc"].copy(),
            "sh": np.zeros((len(c["xyz"]), 1, 3)), "degree": 0}


def render_instant(raw, t, R_c2w, C, fx, fy, W, H, background=(0.0, 0.0, 0.0), clamp=False, at=stg_lite_at):
    """The sharp image at t (pixel centres, Inria's rasterizer without tiles): (image (H, W, 3),
    final T (H, W)). clamp=True clamps the composited image to [0, 1] as test.py:131 does. `at`
    forms the Gaussians at t (tests plant errors through it)."""
    image, T = raster.render(at(raw, t), R_c2w, C, fx, fy, W, H, background, "inria")
    if clamp:
        image = np.clip(image, 0.0, 1.0)
    return image, T


def fine_average(raw, t0, t1, n, R_c2w, C, fx, fy, W, H, background=(0.0, 0.0, 0.0), clamp=False,
                 at=stg_lite_at):
    """The midpoint rule over [t0, t1] with n instants: (mean image, mean alpha 1 - T)."""
    image, alpha = np.zeros((H, W, 3)), np.zeros((H, W))
    for k in range(n):
        img, T = render_instant(raw, t0 + (t1 - t0) * (k + 0.5) / n, R_c2w, C, fx, fy, W, H, background, clamp, at)
        image += img / n
        alpha += (1.0 - T) / n
    return image, alpha


def single_gaussian_integral(raw, fx, fy, W, H, px, py, t0, t1):
    """The time average over the box shutter [t0, t1] of pixel (px, py) (integer pixel indices:
    Inria's pixf, the pixel's centre) for a model of ONE Gaussian, camera at the origin looking
    along +z (R_c2w = I, x right, y down), black background. Returns (rgb (3,), alpha).

    Preconditions (checked): flat and facing the camera, moving parallel to the image plane:
    exp(scale_2) <= 1e-6 min(exp(scale_0), exp(scale_1)); the quaternion constant (omega = 0)
    and a turn about z only (rot = (w, 0, 0, z), or 0: the identity, FWD:134-138); motion linear
    (motion_3..8 = 0) with motion_2 = 0 (constant depth Z = z > 0.2, the near cull); sigmoid
    (opacity) < 0.99, so min(0.99, .) never acts (FWD:418), and one Gaussian never drives T
    below 1e-4 (1 - alpha >= 0.01).

    Why the footprint is constant in t. The view covariance is Sigma = R_z diag(sx^2, sy^2,
    sz^2) R_z^T: its third row and column are (0, 0, sz^2). computeCov2D (FWD:74-113) forms
    J Sigma J^T with J = [[fx/Z, 0, -fx tx/Z^2], [0, fy/Z, -fy ty/Z^2]], (tx, ty) the clamped mean,
    which moves with t. The third column of J multiplies only Sigma's third row and column, whose
    only non-zero entry sz^2 enters as (fx tx/Z^2)^2 sz^2 <= (1.3 tan_fovx fx/Z)^2 sz^2: 1e-12 of
    the rest at most. The rest, (fx/Z, fy/Z) R_z diag(sx^2, sy^2) R_z^T (fx/Z, fy/Z) + 0.3 I, has
    Z constant: so the conic (A, B, C) is constant. The mean's image is linear in D:
    u = fx x(D) / (Z + 1e-7) + W/2 - 1/2 (FWD:273-275, ndc2Pix), x(D) = x0 + vx D, likewise v. With
    d = (u - px, v - py) = e + w D, the rasterizer's power (FWD:410) is -(p2 D^2 + p1 D + p0),
    p2 = A wx^2 / 2 + C wy^2 / 2 + B wx wy, p1 = A ex wx + C ey wy + B (ex wy + ey wx),
    p0 = A ex^2 / 2 + C ey^2 / 2 + B ex ey, never positive (the conic is positive definite), and
    the temporal factor adds D^2 / tau^2, tau = exp(trbf_scale). So
        alpha(D) = o exp(-(a2 D^2 + a1 D + a0)),  a2 = p2 + 1/tau^2 > 0, a1 = p1, a0 = p0,
    = o exp(-q_min) exp(-a2 (D - m)^2) with m = -a1 / (2 a2), q_min = a0 - a1^2 / (4 a2). The cut
    alpha >= 1/255 (FWD:419) is the quadratic inequality a2 (D - m)^2 <= ln(255 o) - q_min: the
    interval m +- h, h = sqrt((ln(255 o) - q_min) / a2) (empty if negative). On black, one
    Gaussian gives colour f_dc alpha and 1 - T = alpha (FWD:430-447). So the average is
        o exp(-q_min) sqrt(pi / a2) / 2 [erf(sqrt(a2) (hi - m)) - erf(sqrt(a2) (lo - m))] / (t1 - t0)
    over [lo, hi] = [t0 - c, t1 - c] intersected with [m - h, m + h] (c = trbf_center), times f_dc
    for the colour."""
    c = _columns(raw)
    if len(c["xyz"]) != 1:
        raise ValueError("single_gaussian_integral takes a model of one Gaussian")
    sx, sy, sz = np.exp(c["scale"][0])
    q = c["rot"][0]
    if sz > 1e-6 * min(sx, sy):
        raise ValueError(f"not flat: scale {sx, sy, sz}")
    if np.any(c["omega"][0] != 0) or q[1] != 0 or q[2] != 0:
        raise ValueError(f"the quaternion must be constant and turn about z only: rot {q}, omega {c['omega'][0]}")
    if np.any(c["motion"][0, 2:] != 0):
        raise ValueError(f"the motion must be linear and parallel to the image plane: {c['motion'][0]}")
    x0, y0, Z = c["xyz"][0]
    vx, vy = c["motion"][0, 0:2]
    o = 1.0 / (1.0 + math.exp(-c["opacity"][0, 0]))
    if Z <= raster.INRIA_NEAR or o >= 0.99:
        raise ValueError(f"depth {Z} must exceed 0.2 and the opacity {o} stay below 0.99")
    qn = q / max(np.linalg.norm(q), NORMALIZE_EPS)
    Rz = raster.quat_to_rot_as_given(qn)[:2, :2]
    S = Rz @ np.diag([sx * sx, sy * sy]) @ Rz.T
    Jd = np.diag([fx / Z, fy / Z])
    cov = Jd @ S @ Jd + raster.EPS2D * np.eye(2)
    det = cov[0, 0] * cov[1, 1] - cov[0, 1] ** 2
    A, B, Cc = cov[1, 1] / det, -cov[0, 1] / det, cov[0, 0] / det
    zz = Z + 1e-7
    ex, ey = fx * x0 / zz + W / 2.0 - 0.5 - px, fy * y0 / zz + H / 2.0 - 0.5 - py
    wx, wy = fx * vx / zz, fy * vy / zz
    tau = math.exp(c["trbf_scale"][0, 0])
    a2 = 0.5 * A * wx * wx + 0.5 * Cc * wy * wy + B * wx * wy + 1.0 / (tau * tau)
    a1 = A * ex * wx + Cc * ey * wy + B * (ex * wy + ey * wx)
    a0 = 0.5 * A * ex * ex + 0.5 * Cc * ey * ey + B * ex * ey
    m = -a1 / (2.0 * a2)
    q_min = a0 - a1 * a1 / (4.0 * a2)
    reach = math.log(o / raster.ALPHA_MIN) - q_min if raster.ALPHA_MIN > 0 else math.inf
    centre = c["trbf_center"][0, 0]
    alpha = 0.0
    if reach > 0.0:
        h = math.sqrt(reach / a2)
        lo, hi = max(t0 - centre, m - h), min(t1 - centre, m + h)
        if hi > lo:
            r = math.sqrt(a2)
            alpha = (o * math.exp(-q_min) * 0.5 * math.sqrt(math.pi / a2)
                     * (math.erf(r * (hi - m)) - math.erf(r * (lo - m))) / (t1 - t0))
    return c["f_dc"][0] * alpha, alpha
