"""Independent reference: when is each image row (or column) exposed?

Three published rolling-shutter conventions, re-derived from the upstream
sources only (read with git from mirrors of the public repositories).  Nothing
here is taken from this project's own sources.  numpy only; importing this
module has no side effects.

Conventions
-----------
1. "3dgs-deblur" (SpectacularAI/3dgs-deblur, pinning a fork of gsplat):
   per pixel, time relative to the frame's reference pose ("middle"),
       tau_k(row) = t_ro * ((row + 0.5)/H - 0.5) + (k/(n-1) - 0.5) * T_e
   (the k-term is 0 when n == 1).  Each row therefore has an exposure window of
   length T_e centred on  t_ro * ((row + 0.5)/H - 0.5).  Pixel centre
   (i + 0.5), division by H (not H - 1); readout always top -> bottom.
2. "gsplat" (nerfstudio-project/gsplat, 3DGUT integration): relative frame time
   in [0, 1] between a start pose (0) and an end pose (1),
       top->bottom  floor(y)/(H-1),   bottom->top  (H - ceil(y))/(H-1),
       left->right  floor(x)/(W-1),   right->left  (W - ceil(x))/(W-1),
       GLOBAL       0  (start pose).
   x, y are the pixel centre (j + 0.5, i + 0.5), so floor gives the index and
   ceil gives index + 1; e.g. row i top->bottom -> i/(H-1).
3. "3dgut" (nv-tlabs/3dgrut, threedgut_tracer): the same four rolling formulas
   (floor / ceil, division by dim - 1) but the GLOBAL case returns 0.5.

Differences gsplat vs 3DGUT
---------------------------
* GLOBAL: gsplat's shutter_relative_frame_time returns 0.0 (variable initialised
  to 0, no GLOBAL case); 3DGUT's relativeShutterTime returns 0.5 (default case).
  In BOTH code bases the point projection path exits early for GLOBAL using the
  START pose, and for a global camera start == end in practice (gsplat requires
  viewmats_rs None; 3dgrut sets end = start), so the difference is only visible
  if a caller supplies two different poses with GLOBAL.
* 3DGUT's per-pixel *render* ray (gutRenderer.cu) uses one pose interpolated at
  0.5 for every pixel (a source comment says per-pixel interpolation would be
  needed for proper rolling shutter); only particle projection uses the per-row
  time.  gsplat's world-space rasteriser generates each pixel's ray at its own
  relative time (element_to_world_ray_shutter_pose).
* floor/ceil and the (dim - 1) divisor are identical in both.  Neither guards
  dim == 1 (0/0 -> NaN in float); gsplat's newer gsplat/sensors kernel clamps
  the divisor to max(dim, 2) - 1.
* Neither gsplat nor 3DGUT has an exposure window: a pixel is a single instant.
  3dgs-deblur, in contrast, is centred (signed time about the frame middle),
  divides by H, uses the pixel centre without floor, and has a window T_e.
"""

import numpy as np

__all__ = [
    "READOUTS",
    "deblur3dgs_row_centre",
    "deblur3dgs_row_window",
    "deblur3dgs_sample_times",
    "gsplat_pixel_time",
    "gsplat_row_instant",
    "glm_slerp",
    "gsplat_shutter_pose",
    "gsplat_sh_campos",
    "dgut_pixel_time",
    "dgut_row_instant",
]

READOUTS = ("top_to_bottom", "bottom_to_top", "left_to_right", "right_to_left", "global")

_ALIASES = {
    "rolling_top_to_bottom": "top_to_bottom",
    "rolling_bottom_to_top": "bottom_to_top",
    "rolling_left_to_right": "left_to_right",
    "rolling_right_to_left": "right_to_left",
    "globalshutter": "global",
    "global_shutter": "global",
}


def _readout(name):
    key = str(name).strip().lower().replace("-", "_")
    key = _ALIASES.get(key, key)
    if key not in READOUTS:
        raise ValueError("unknown readout %r; expected one of %s" % (name, READOUTS))
    return key


def _div(num, den):
    """IEEE float division as on the GPU (0/0 -> nan, x/0 -> +-inf), no warnings."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.true_divide(np.asarray(num, dtype=np.float64), np.float64(den))
    return out[()] if np.ndim(out) == 0 else out


# ---------------------------------------------------------------------------
# 1. 3dgs-deblur
# ---------------------------------------------------------------------------

def deblur3dgs_row_centre(row, H, t_ro):
    """Signed time of row `row`'s exposure centre relative to the frame middle.

    c(row) = t_ro * ((row + 0.5) / H - 0.5)      (top row earliest)

    Source: repo SpectacularAI/3dgs-deblur at commit
    f7df8e0b82874a2bf68bf39e8d1db55e8e0ebd5e pins submodule `gsplat`
    (.gitmodules lines 4-6, url https://github.com/SpectacularAI/gsplat) to
    commit 64154bb463039919cbdff27daa57fa31849763a8 (tree entry).
    In SpectacularAI/gsplat @ 64154bb463039919cbdff27daa57fa31849763a8,
    gsplat/cuda/csrc/forward.cu, kernel rasterize_forward:
      lines 335-336  py = (float)i + 0.5  (i = pixel row, so pixel CENTRE),
      line 360       roll_time = rolling_shutter_time * (py / img_size.y - 0.5),
      lines 362-363  per blur sample blur_i of n_blur_samples:
                     blur_rel = (n>1 ? (blur_i/(n-1) - 0.5) * exposure_time : 0)
                                + roll_time,
      lines 408-411  the splat is drawn at xy + blur_rel * pix_vel, i.e.
                     blur_rel is time (seconds) relative to the pose the splat
                     was projected with (the frame's reference pose).
    Same formulas in backward.cu lines 176-177, 192, 196.  Units: seconds
    (gsplat/rasterize.py lines 52-53 docstring).  The line carries the comment
    "check sign"; the sign as written makes lower rows (larger y) later.
    """
    row = np.asarray(row, dtype=np.float64)
    out = t_ro * ((row + 0.5) / float(H) - 0.5)
    return out[()] if np.ndim(out) == 0 else out


def deblur3dgs_row_window(row, H, open, close, t_ro):
    """Exposure window (t_start, t_end) of pixel row `row` under 3dgs-deblur.

    Mapping onto the scene clock: the source's times are offsets from the
    frame's reference pose; that reference is the middle of the frame, so
    offset tau maps to  mid + tau  with  mid = (open + close) / 2.  The
    exposure length is T_e = close - open (as required by the brief).  The
    blur samples k = 0..n-1 sit at (k/(n-1) - 0.5) * T_e about the row centre,
    so the row's window is
        [mid + c(row) - T_e/2,  mid + c(row) + T_e/2],
        c(row) = t_ro * ((row + 0.5)/H - 0.5),
    length exactly close - open for every row.  Windows of rows r and H-1-r
    are mirror images about mid; for t_ro > 0 the top/bottom rows extend
    beyond [open, close] by t_ro * (1 - 1/H) / 2.  (The dataset converter
    process_synthetic_inputs.py line 157 in 3dgs-deblur divides the whole
    first-to-last blur pose span by exposure_time + rolling_shutter_time,
    consistent with the frame's total span being T_e + t_ro, not T_e.)

    Source lines: see deblur3dgs_row_centre (forward.cu 335-336, 360, 362-363).
    """
    c = deblur3dgs_row_centre(row, H, t_ro)
    mid = 0.5 * (open + close)
    half = 0.5 * (close - open)
    return mid + c - half, mid + c + half


def deblur3dgs_sample_times(row, H, open, close, t_ro, n):
    """Scene times of the n blur samples of row `row` (forward.cu line 363).

    n == 1: the single sample is at the row centre mid + c(row);
    n > 1: mid + c(row) + (k/(n-1) - 0.5) * (close - open), k = 0..n-1,
    i.e. both window end points are sampled.
    """
    n = int(n)
    if n < 1:
        raise ValueError("n must be >= 1")
    mid = 0.5 * (open + close)
    c = float(deblur3dgs_row_centre(float(row), H, t_ro))
    if n == 1:
        return np.array([mid + c])
    k = np.arange(n, dtype=np.float64)
    return mid + c + (k / (n - 1) - 0.5) * (close - open)


# ---------------------------------------------------------------------------
# 2. gsplat (upstream)
# ---------------------------------------------------------------------------

def _rolling_time(x, y, W, H, readout, global_value):
    r = _readout(readout)
    if r == "top_to_bottom":
        return _div(np.floor(y), H - 1)
    if r == "bottom_to_top":
        return _div(H - np.ceil(y), H - 1)
    if r == "left_to_right":
        return _div(np.floor(x), W - 1)
    if r == "right_to_left":
        return _div(W - np.ceil(x), W - 1)
    shape = np.broadcast(np.asarray(x), np.asarray(y)).shape
    out = np.full(shape, float(global_value))
    return out[()] if out.ndim == 0 else out


def gsplat_pixel_time(x, y, W, H, readout):
    """gsplat relative frame time in [0, 1] of image point (x, y).

    (x, y) are continuous image coordinates; the renderer passes the pixel
    CENTRE (col + 0.5, row + 0.5).
      top_to_bottom  floor(y) / (H - 1)
      bottom_to_top  (H - ceil(y)) / (H - 1)
      left_to_right  floor(x) / (W - 1)
      right_to_left  (W - ceil(x)) / (W - 1)
      global         0.0  (start pose)
    The pose used is lerp/slerp(start, end, t): t = 0 start, t = 1 end.
    H == 1 (or W == 1) gives 0/0 = nan, as the float code would.

    Source: repo nerfstudio-project/gsplat, current snapshot commit
    90d7b4b349e379ccf9ee6a8cef76aa40f48bb32e:
      gsplat/cuda/include/Cameras.h lines 38-45 (enum ShutterType, GLOBAL last);
      gsplat/cuda/include/Cameras.cuh lines 504-528 (shutter_relative_frame_time;
        t initialised 0.f, no GLOBAL case), lines 486-492 (element_to_image_point
        returns (j + 0.5, i + 0.5)), lines 417-429 (interpolate_shutter_pose:
        (1-t)*t_start + t*t_end, slerp(q_start, q_end, t)), lines 567-578
        (projection: GLOBAL exits early with the start pose);
      gsplat/cuda/csrc/RasterizeToPixelsFromWorld3DGS.cuh line 385 (per-pixel
        ray via element_to_world_ray_shutter_pose(j, i, ...));
      gsplat/cuda/csrc/Rendering.cpp lines 360-368 (GLOBAL requires
        viewmats_rs None; rolling requires viewmats_rs, the end pose);
      gsplat/rendering.py lines 278-279, 479-481 (API: rolling_shutter,
        viewmats_rs "the second viewmat").
    Added in commit 463482551072418d67ab2b971e6396ba1a96b5e6 "Implement 3DGUT
    (#667)": same formulas in Cameras.cuh lines 299-327, pixel centre in
    RasterizeToPixelsFromWorld3DGSFwd.cu lines 77-78 and 100.
    Newer gsplat/sensors/kernels/cuda/csrc/camera_kernel.cuh lines 570-597
    (compute_relative_frame_time_opencv) gives the same values but clamps the
    divisor to max(dim, 2) - 1 and returns 0 for GLOBAL.
    """
    return _rolling_time(x, y, W, H, readout, 0.0)


def gsplat_row_instant(row, col, W, H, open, close, readout):
    """Scene time at which gsplat samples pixel (row, col): pixel centre, and
    relative time 0 -> open (start pose), 1 -> close (end pose), linear.
    Global shutter -> open."""
    t = gsplat_pixel_time(np.asarray(col, dtype=np.float64) + 0.5,
                          np.asarray(row, dtype=np.float64) + 0.5, W, H, readout)
    return open + t * (close - open)


def _quat_cast(R):
    """glm::quat_cast of a rotation matrix: a unit quaternion (w, x, y, z) of R (its sign is free: the
    slerp below takes the short arc)."""
    w = np.sqrt(max(0.0, 1.0 + np.trace(R))) / 2
    x = np.copysign(np.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = np.copysign(np.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    q = np.array([w, x, y, z])
    return q / np.linalg.norm(q)


def _quat_matrix(q):
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def glm_slerp(x, y, a):
    """glm::slerp(x, y, a) (g-truc/glm 33b4a62, the submodule gsplat v1.5.3 pins:
    glm/ext/quaternion_common.inl lines 41-73): y negated when dot(x, y) < 0 (the short arc); a
    componentwise lerp when cos > 1 - epsilon (float's, 1.19e-7, as gsplat calls it on floats);
    else (sin((1 - a) angle) x + sin(a angle) z) / sin(angle), angle = acos(cos)."""
    x, z = np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64)
    cos = float(x @ z)
    if cos < 0:
        z, cos = -z, -cos
    if cos > 1 - np.finfo(np.float32).eps:
        return x + a * (z - x)
    angle = np.arccos(cos)
    return (np.sin((1 - a) * angle) * x + np.sin(a * angle) * z) / np.sin(angle)


def gsplat_shutter_pose(viewmat_start, viewmat_end, u):
    """gsplat's camera at relative frame time u between two world-to-camera 4x4 matrices: (R_w2c,
    t_w2c, centre). Source: nerfstudio-project/gsplat v1.5.3 (937e299),
    gsplat/cuda/include/Cameras.cuh:
      lines 40-61  RollingShutterParameters: q = quat_cast of each viewmat's rotation, t its
                   translation column (row-major input);
      lines 276-288 interpolate_shutter_pose: t_rs = (1 - u) t_start + u t_end,
                   q_rs = normalize(glm::slerp(q_start, q_end, u));
      lines 260-274 ShutterPose: camera_world_position = rotate(inverse(q), -t), the world ray
                   (-R^-1 t, R^-1 camera_ray).
    The same rule on main: gsplat/cuda/include/Cameras.cuh interpolate_shutter_pose and
    _torch_cameras.py. Not the centres lerped: the centre -R(u)^T t_rs bends when the camera turns."""
    V0, V1 = np.asarray(viewmat_start, dtype=np.float64), np.asarray(viewmat_end, dtype=np.float64)
    t = (1 - u) * V0[:3, 3] + u * V1[:3, 3]
    q = glm_slerp(_quat_cast(V0[:3, :3]), _quat_cast(V1[:3, :3]), u)
    R = _quat_matrix(q / np.linalg.norm(q))
    return R, t, R.T @ -t


def gsplat_sh_campos(viewmat, viewmat_rs):
    """The camera position gsplat evaluates every Gaussian's SH from under a rolling shutter: the
    mean of the two poses' centres (gsplat v1.5.3 gsplat/rendering.py lines 491-494:
    campos = inverse(viewmats)[:3, 3]; with viewmats_rs, 0.5 (campos + campos_rs)), one for the
    whole image, whatever the row's pose."""
    c0 = np.linalg.inv(np.asarray(viewmat, dtype=np.float64))[:3, 3]
    c1 = np.linalg.inv(np.asarray(viewmat_rs, dtype=np.float64))[:3, 3]
    return 0.5 * (c0 + c1)


# ---------------------------------------------------------------------------
# 3. 3DGUT (nv-tlabs/3dgrut)
# ---------------------------------------------------------------------------

def dgut_pixel_time(x, y, W, H, readout):
    """3DGUT relative shutter time in [0, 1] of image point (x, y).

    Rolling cases identical to gsplat (floor / ceil, divide by dim - 1, float):
      top_to_bottom  floor(y) / (H - 1)     bottom_to_top  (H - ceil(y)) / (H - 1)
      left_to_right  floor(x) / (W - 1)     right_to_left  (W - ceil(x)) / (W - 1)
      global         0.5  (default branch of relativeShutterTime).
    Pixel coordinates are continuous with pixel centres at i + 0.5 (ray grid
    threedgrut/datasets/utils.py lines 54-55 uses arange + 0.5), so a pixel
    centre's row index is floor(y).
    Caveats (see module docstring): for GLOBAL the projection path
    (projectPointWithShutter) exits early with the START pose, and the render
    pass uses a single pose at relative time 0.5 for all pixels.

    Source: repo nv-tlabs/3dgrut, current snapshot commit
    a37ef721012dea0f29c0fcfff2d525023b4e854a:
      threedgut_tracer/include/3dgut/kernels/cuda/sensors/cameraProjections.cuh
        lines 50-65 (relativeShutterTime), lines 218-257
        (projectPointWithShutter: start pose, GLOBAL early exit line 230,
        iterations with slerp/mix(start, end, alpha) lines 246-251);
      threedgut_tracer/include/3dgut/sensors/cameraModels.h lines 51-57
        (enum ShutterType, default GlobalShutter);
      threedgut_tracer/include/3dgut/sensors/sensors.h lines 53-66
        (interpolatedSensorPose: mix/slerp(start, end, relativeTime));
      threedgut_tracer/src/gutRenderer.cu lines 265-267 and 390 (render uses
        the pose interpolated at 0.5);
      threedgut_tracer/tracer.py lines 377-379 (timestamps start=0, end=1),
        lines 405-412 (no end pose -> end = start).
    Present since the initial commit 92a50a4538e907e657a30735be70ee8ade630a86
    (same file, lines 35-49).
    """
    return _rolling_time(x, y, W, H, readout, 0.5)


def dgut_row_instant(row, col, W, H, open, close, readout):
    """Scene time of pixel (row, col) under 3DGUT's relativeShutterTime:
    pixel centre, relative 0 -> open, 1 -> close; global -> (open+close)/2."""
    t = dgut_pixel_time(np.asarray(col, dtype=np.float64) + 0.5,
                        np.asarray(row, dtype=np.float64) + 0.5, W, H, readout)
    return open + t * (close - open)


# ---------------------------------------------------------------------------
# self-checks
# ---------------------------------------------------------------------------

def _self_check():
    W, H = 7, 5
    op, cl = 2.0, 3.0
    rows = np.arange(H)
    cols = np.arange(W)

    # --- gsplat ---------------------------------------------------------
    assert gsplat_pixel_time(0.5, 0.5, W, H, "top_to_bottom") == 0.0
    assert gsplat_pixel_time(0.5, H - 0.5, W, H, "top_to_bottom") == 1.0
    assert gsplat_pixel_time(0.5, 0.5, W, H, "bottom_to_top") == 1.0
    assert gsplat_pixel_time(0.5, H - 0.5, W, H, "bottom_to_top") == 0.0
    assert gsplat_pixel_time(0.5, 0.5, W, H, "left_to_right") == 0.0
    assert gsplat_pixel_time(W - 0.5, 0.5, W, H, "left_to_right") == 1.0
    assert gsplat_pixel_time(0.5, 0.5, W, H, "right_to_left") == 1.0
    assert gsplat_pixel_time(W - 0.5, 0.5, W, H, "right_to_left") == 0.0
    assert gsplat_pixel_time(3.5, 2.5, W, H, "global") == 0.0
    assert gsplat_pixel_time(3.5, 2.5, W, H, "GLOBAL") == 0.0
    assert gsplat_pixel_time(3.5, 2.5, W, H, "ROLLING_TOP_TO_BOTTOM") == 0.5
    np.testing.assert_allclose(gsplat_pixel_time(0.5, rows + 0.5, W, H, "top_to_bottom"), rows / (H - 1))
    np.testing.assert_allclose(gsplat_pixel_time(0.5, rows + 0.5, W, H, "bottom_to_top"), (H - 1 - rows) / (H - 1))
    np.testing.assert_allclose(gsplat_pixel_time(cols + 0.5, 0.5, W, H, "right_to_left"), (W - 1 - cols) / (W - 1))
    # piecewise constant within a pixel, and on integer boundaries floor/ceil differ
    assert gsplat_pixel_time(0.0, 2.0, W, H, "top_to_bottom") == 2 / (H - 1)
    assert gsplat_pixel_time(0.0, 2.99, W, H, "top_to_bottom") == 2 / (H - 1)
    assert gsplat_pixel_time(0.0, 2.0, W, H, "bottom_to_top") == (H - 2) / (H - 1)
    assert np.isnan(gsplat_pixel_time(0.5, 0.5, W, 1, "top_to_bottom"))
    np.testing.assert_allclose(gsplat_row_instant(rows, 0, W, H, op, cl, "top_to_bottom"),
                               op + rows / (H - 1) * (cl - op))
    assert gsplat_row_instant(0, 0, W, H, op, cl, "top_to_bottom") == op
    assert gsplat_row_instant(H - 1, 0, W, H, op, cl, "top_to_bottom") == cl
    assert gsplat_row_instant(2, 3, W, H, op, cl, "global") == op
    assert gsplat_row_instant(0, W - 1, W, H, op, cl, "left_to_right") == cl

    # --- 3DGUT: same rolling values, global 0.5 --------------------------
    ys = np.linspace(0.0, H - 1e-3, 97)
    xs = np.linspace(0.0, W - 1e-3, 97)
    for r in READOUTS[:4]:
        np.testing.assert_array_equal(dgut_pixel_time(xs, ys, W, H, r), gsplat_pixel_time(xs, ys, W, H, r))
    assert dgut_pixel_time(3.5, 2.5, W, H, "global") == 0.5
    assert dgut_row_instant(1, 1, W, H, op, cl, "global") == 0.5 * (op + cl)
    assert dgut_row_instant(H - 1, 0, W, H, op, cl, "bottom_to_top") == op

    # --- 3dgs-deblur -------------------------------------------------------
    t_ro = 0.4
    mid = 0.5 * (op + cl)
    s, e = deblur3dgs_row_window(rows, H, op, cl, t_ro)
    np.testing.assert_allclose(e - s, cl - op)                      # length == close - open
    np.testing.assert_allclose(s + s[::-1], 2 * mid - (cl - op))    # mirror rows symmetric
    np.testing.assert_allclose((s + e) / 2 + ((s + e) / 2)[::-1], 2 * mid)
    np.testing.assert_allclose((s + e) / 2, mid + t_ro * ((rows + 0.5) / H - 0.5))
    assert np.all(np.diff(s) > 0)                                   # top row first
    np.testing.assert_allclose(np.diff(s), t_ro / H)                # per-row step t_ro/H
    # odd H: middle row's window is exactly [open, close]
    sm, em = deblur3dgs_row_window(H // 2, H, op, cl, t_ro)
    np.testing.assert_allclose([sm, em], [op, cl])
    # no rolling shutter: every row's window is [open, close]
    s0, e0 = deblur3dgs_row_window(rows, H, op, cl, 0.0)
    np.testing.assert_allclose(s0, op)
    np.testing.assert_allclose(e0, cl)
    # samples: end points included for n > 1, centre for n == 1
    smp = deblur3dgs_sample_times(1, H, op, cl, t_ro, 5)
    sw, ew = deblur3dgs_row_window(1, H, op, cl, t_ro)
    np.testing.assert_allclose([smp[0], smp[-1]], [sw, ew])
    np.testing.assert_allclose(deblur3dgs_sample_times(1, H, op, cl, t_ro, 1), [(sw + ew) / 2])
    # total span first-row start to last-row end = T_e + t_ro*(1 - 1/H)
    np.testing.assert_allclose(e[-1] - s[0], (cl - op) + t_ro * (1 - 1.0 / H))


if __name__ == "__main__":
    _self_check()
    print("rolling_shutter_reference: all self-checks passed")
