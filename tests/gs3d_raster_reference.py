"""An independent numpy reference of how trained 3D Gaussian Splatting models
are rasterized (EWA splatting, front-to-back alpha compositing), for checking
refrender's C renderer per pixel. Written from the primary sources below,
read for their rules (no code copied); refrender's own C was not read.

Sources (commit, file:line of every rule used)
-----------------------------------------------
INRIA = graphdeco-inria/diff-gaussian-rasterization at
  9c5c2028f6fbee2be239bc4c9421ff894fe4fbe0 (branch dr_aa, "toggle
  antialiasing", 2024-09-06; the commit graphdeco-inria/gaussian-splatting
  pins), files cuda_rasterizer/{forward.cu, auxiliary.h, rasterizer_impl.cu}.
  MAIN = the same repository's main, 59f5f77e3ddbac3ed9db93ec2cfe99ed6c5d121d
  (2023-08-27), cited where its lines differ.
GSPLAT = nerfstudio-project/gsplat v1.5.3,
  937e29912570c372bed6747a5c9bf85fed877bae (2025-07-04), files
  gsplat/rendering.py, gsplat/cuda/include/{Utils.cuh, Common.h},
  gsplat/cuda/csrc/{ProjectionEWA3DGSFused.cu, RasterizeToPixels3DGSFwd.cu,
  IntersectTile.cu, SphericalHarmonicsCUDA.cu}.
3DGS = graphdeco-inria/gaussian-splatting utils/graphics_utils.py at
  ad8f3a12777fb935f8411d3db8b97004d1159e34.

Camera (both)
  World to view: p = R_c2w^T (mean - C); z = p[2] is the view depth.
  INRIA: fx = W / (2 tan_fovx) (rasterizer_impl.cu:224-225), where the
  Python side sets tan_fovx = tan(FoVx / 2) with FoVx = focal2fov(fx, W) =
  2 atan(W / (2 fx)) (3DGS graphics_utils.py:76-77), so tan_fovx = W / (2 fx).
  GSPLAT: explicit K = [[fx, 0, cx], [0, fy, cy]]; cx, cy are arguments here
  (default W/2, H/2); see "Principal point" below.

Projection of the mean and the pixel convention
  INRIA: p_hom = full_proj @ (mean, 1), p_w = 1 / (p_hom.w + 1e-7), p_proj
  = p_hom * p_w (forward.cu:195-197). getProjectionMatrix (3DGS
  graphics_utils.py:51-71) has P[0,0] = 2n/(r-l) = 1/tan_fovx (:64), P[0,2]
  = (r+l)/(r-l) = 0 (:66), P[3,2] = 1 (:68), so p_hom.x = x / tan_fovx and
  p_hom.w = z. ndc2Pix(v, S) = ((v + 1) S - 1) / 2 (auxiliary.h:40-43), so
      point_image.x = (x / tan_fovx / (z + 1e-7) + 1) W/2 - 1/2
                    = fx x / (z + 1e-7) + W/2 - 0.5,
  and the pixel with integer index i is evaluated at pixf = i
  (forward.cu:297, d = point_image - pixf at :350). GSPLAT: mean2d = fx x/z
  + cx (Utils.cuh:536) and pixel j is evaluated at px = j + 0.5
  (RasterizeToPixels3DGSFwd.cu:62-63). Both give the same offset
  d = fx x/z + W/2 - (i + 0.5) up to INRIA's 1e-7 added to z, which this
  reference keeps (relative effect 1e-7/z).

3D covariance
  Sigma = R(q) diag(s)^2 R(q)^T with q = (w, x, y, z): INRIA computeCov3D
  forward.cu:114-148 (w = q.x :124; no normalisation in CUDA :123, the
  Python activation normalises); GSPLAT Utils.cuh:142-164 (normalises),
  :191-205. View space: Sigma_c = R_w2c Sigma R_w2c^T.

2D covariance (EWA, Jacobian at a clamped mean)
  INRIA computeCov2D forward.cu:74-109: limx = 1.3 tan_fovx (:82-83), t.x =
  clamp(x/z, -limx, limx) z (:84-87), J = [[fx/z, 0, -fx t.x/z^2], [0, fy/z,
  -fy t.y/z^2]] (:89-92), cov = J W Sigma W^T J^T (:94-106).
  GSPLAT persp_proj Utils.cuh:498-537: lim_x_pos = (W - cx)/fx + 0.3
  tan_fovx, lim_x_neg = cx/fx + 0.3 tan_fovx with tan_fovx = 0.5 W/fx
  (:514-519); tx = z clamp(x/z, -lim_x_neg, lim_x_pos) (:523-524); J as INRIA
  (:527-535). With cx = W/2 both limits are 1.3 tan_fovx: the same clamp
  (off centre: "Principal point" below).
  Only J uses the clamped position; the mean is projected unclamped.

Principal point (cx, cy), arguments of project() and render()
  cx, cy are in pixel-edge coordinates: pixel j spans [j, j + 1] and the
  optical axis meets the image at (cx, cy); centred = (W/2, H/2), as in
  COLMAP's and nerfstudio's intrinsics. None = centred, bit-identical to the
  reference before it took a principal point.
  GSPLAT uses cx, cy in exactly these places of the forward pass (v1.5.3):
  - K read row-major: fx = K[0,0], fy = K[1,1], cx = K[0,2], cy = K[1,2];
    the skew K[0,1] is never read (ProjectionEWA3DGSFused.cu:110-121; the
    packed kernel, rasterization()'s default packed=True at rendering.py:48,
    the same at ProjectionEWA3DGSPacked.cu:126-137).
  - persp_proj (Utils.cuh:498-537; the file is gsplat/cuda/include/Utils.cuh
    at this commit): tan_fovx = 0.5 W / fx, tan_fovy = 0.5 H / fy, whatever
    cx, cy (:514-515); the limits lim_x_pos = (W - cx)/fx + 0.3 tan_fovx,
    lim_x_neg = cx/fx + 0.3 tan_fovx, y likewise with H, cy, fy (:516-519);
    tx = z min(lim_x_pos, max(-lim_x_neg, x/z)), ty likewise (:523-524); J
    from tx, ty (:527-534); cov2d = J Sigma_c J^T (:535); the mean
    mean2d = (fx x/z + cx, fy y/z + cy), unclamped (:536). In pixels the
    clamp keeps fx tx/z + cx within [-0.3 fx tan_fovx, W + 0.3 fx tan_fovx]
    = [-0.15 W, 1.15 W]: a window fixed on the image, wherever cx lies
    (the interval is never empty: its width is 1.3 W / fx).
  - The radius (extend, ceil of extend sqrt(cov2d_xx)) does not involve cx
    (ProjectionEWA3DGSFused.cu:164-184, ProjectionEWA3DGSPacked.cu:181-199);
    the off-image drop compares mean2d, which carries cx, with [0, W] x
    [0, H] (Fused :193-198, Packed :205-209); the tiles are taken from
    mean2d and the radii only (IntersectTile.cu:55-77).
  - The pixel centre px = j + 0.5, py = i + 0.5 does not involve cx
    (RasterizeToPixels3DGSFwd.cu:62-63); nor does the SH direction (camera
    centre from the inverse view matrix, rendering.py:491).
  INRIA has no principal point: GaussianRasterizationSettings carries only
  tanfovx, tanfovy, the view and the full projection matrix (MAIN
  diff_gaussian_rasterization/__init__.py:157-169); the focal is W /
  (2 tan_fovx) (MAIN rasterizer_impl.cu:222-223); computeCov2D clamps x/z to
  +-1.3 tan_fovx, symmetric about the optical axis (MAIN forward.cu:82-87),
  which 3DGS's getProjectionMatrix puts at the image centre (P[0,2] = 0 for
  its symmetric frustum, graphics_utils.py:66). So Inria's clamp window is
  W/2 +- 0.65 W = [-0.15 W, 1.15 W], the same as gsplat's when centred.
  Off centre, project() and render() refuse an INRIA variant (ValueError)
  unless inria_off_centre_extension=True: THIS REFERENCE'S EXTENSION, NOT
  INRIA'S CODE, namely what Inria's CUDA computes when handed a full
  projection matrix whose third column holds P[0,2] = 2 cx/W - 1, P[1,2] =
  2 cy/H - 1 (the values that put the optical axis at pixel-edge cx, cy):
  point_image.x = ((x/tan_fovx + (2 cx/W - 1) z) / (z + 1e-7) + 1) W/2 - 1/2
  = fx x/(z + 1e-7) + cx - 1/2 up to the 1e-7, the mean unclamped
  (forward.cu:195-197, MAIN :198-200 and :233 with ndc2Pix); the Jacobian
  clamp stays +-1.3 W/(2 fx) about the optical axis (only tan_fovx reaches
  computeCov2D, MAIN forward.cu:216), so its window in pixels, [cx - 0.65 W,
  cx + 0.65 W], moves with the principal point. (getProjectionMatrix's own (r+l)/(r-l) for an asymmetric frustum,
  r = n (W - cx)/fx, l = -n cx/fx, is 1 - 2 cx/W, the opposite sign:
  3DGS never builds one, and the extension does not use that formula.)

The FoV handed to the rasterizer (rasterizer_tan_fov=(tanfovx, tanfovy), INRIA variants only)
  FDGS = fudan-zvg/4d-gaussian-splatting at 63725f21 (its own copy of the
  rasterizer, diff-gaussian-rasterization/cuda_rasterizer/). Its reader sets
  FovX = FovY = -1 for a transforms.json camera with fl_x, fl_y, cx, cy
  (scene/dataset_readers.py:275-293) and the renderer hands the rasterizer
  tanfovx = tan(FoVx * 0.5), tanfovy likewise (gaussian_renderer/
  __init__.py:34-35): tan(-0.5). The rasterizer's focal_x = W / (2 tanfovx),
  focal_y = H / (2 tanfovy) (rasterizer_impl.cu:235-236) reach only
  computeCov2D (forward.cu:451), which clamps with limx = 1.3 tanfovx as
  min(limx, max(-limx, x/z)) (forward.cu:206-211; with limx < 0 that is limx
  for every x/z) and builds J from focal_x, focal_y and the clamped t
  (:213-216). The mean is projected by the full projection matrix built from
  the true fl_x, fl_y (forward.cu:446-448, scene/cameras.py:66-67), so
  point_image uses the true fx, fy here; in_frustum reads only the view
  depth (auxiliary.h:153); the radius follows from this cov2D (forward.cu:
  464-467); the SH direction is mean - camera centre. rasterizer_tan_fov=None:
  tanfovx = W / (2 fx), as above.

Dilation, antialiasing
  INRIA: det_cov = det(cov) BEFORE, cov += 0.3 I, det = det AFTER
  (forward.cu:215-219); antialiasing: opacity *= sqrt(max(2.5e-5,
  det_cov / det)) (:222-223, applied :265); det == 0 drops (:228-229);
  conic = cov^-1 (:230-231). MAIN adds the 0.3 inside computeCov2D
  (MAIN forward.cu:110-111) and has no antialiasing (opacity raw, :254).
  GSPLAT add_blur (Utils.cuh:380-388): compensation = sqrt(max(0,
  det_orig / det_blur)), eps2d = 0.3 (rendering.py:46), det_blur <= 0 drops
  (ProjectionEWA3DGSFused.cu:154-159); "antialiased" multiplies opacities by
  it (rendering.py:452-453). So both: factor = sqrt(det(S)/det(S + 0.3 I)),
  the floors differ (INRIA 0.005 after the sqrt, GSPLAT 0).

Precomputed colours and quaternions as given (both optional, for models whose
own code forms per-Gaussian colours and rotations before the rasterizer, e.g.
SpacetimeGaussians, tests/stg_reference.py)
  model["colors_precomp"] (N, 3): INRIA's colors_precomp path: the SH step
  is skipped (MAIN forward.cu:241-247, `if (colors_precomp == nullptr)`),
  and the blend reads the given colours (MAIN rasterizer_impl.cu:321,
  feature_ptr): no + 0.5, no clamp at 0, no upper clamp. The same lines in
  SpacetimeGaussians' forward_lite (427abfc5, thirdparty/gaussian_splatting/
  submodules/forward_lite/cuda_rasterizer/forward.cu:316-322,
  rasterizer_impl.cu:374).
  model["quaternion_as_given"] = True: R(q) is the CUDA's matrix of q as it
  arrives, not normalised (MAIN and forward_lite forward.cu:127, `q = rot;//
  / glm::length(rot)`, matrix :134-138): for q = 0 every product vanishes
  and R = I; for a non-unit q, R is not a rotation (quat_to_rot_as_given).
  model["cov3d_precomp"] (N, 3, 3): the cov3D_precomp path (world_covariance), for models whose
  own code forms each 3D covariance, e.g. real-time 4DGS's conditional covariance at t
  (tests/fdgs_reference.py); "scale" and "rot" are then not read.
  Without these keys nothing changes: SH colours, normalised quaternions, covariances from them.

Culling (applied here in both modes)
  INRIA in_frustum: view z <= 0.2 culled (auxiliary.h:151-175, :166).
  GSPLAT: z < near_plane = 0.01 or z > far_plane = 1e10 culled
  (ProjectionEWA3DGSFused.cu:72; rendering.py:43-44); opacity (times the
  compensation if antialiased) < 1/255 culled (:165-175, rendering.py:426
  passes opacities) -- equivalent to the per-pixel alpha skip anyway.

Screen extent and tiles (only with tile_rule=True)
  INRIA: on the dilated cov, mid = (a + c)/2, lambda1/2 = mid +- sqrt(max(0.1,
  mid^2 - det)), radius = ceil(3 sqrt(max(lambda1, lambda2)))
  (forward.cu:237-240); getRect (auxiliary.h:45-55), 16x16 tiles (config.h
  BLOCK_X/Y), grid = ceil(W/16) x ceil(H/16) (rasterizer_impl.cu:236):
      rect_min = clamp((int)((p - r) / 16), 0, grid)   C truncation to 0
      rect_max = clamp((int)((p + r + 15) / 16), 0, grid)
  with p = point_image (pixel-index coordinates); an empty rect returns
  before radii is set (forward.cu:244-245) and radii 0 emits no tile key
  (rasterizer_impl.cu:85). Tiles x in [rect_min.x, rect_max.x).
  GSPLAT: extend = min(3.33, sqrt(2 ln(opacity / (1/255)))) with the
  (compensated) opacity (ProjectionEWA3DGSFused.cu:164-179), radius_x =
  ceil(extend sqrt(cov_xx)), radius_y likewise, dilated cov (:183-184);
  dropped if both radii <= radius_clip = 0 (:186-190) or the box lies off
  the image: mean2d.x + rx <= 0 or mean2d.x - rx >= W (y likewise)
  (:193-198). Tiles (IntersectTile.cu:55-77): none if a radius <= 0; tile_min
  = min(max(0, floor(mean2d/16 - r/16)), tiles), tile_max = min(ceil(mean2d/16
  + r/16), tiles) (the (uint32_t) cast of a negative float saturates to 0 on
  the GPU; HEAD casts to int32 then max 0: the same). Note that with
  opacity <= 1 extend is at most sqrt(2 ln 255) = 3.329, so the GSPLAT box
  always contains every pixel with alpha >= 1/255: its tile rule cuts
  nothing (save float rounding at the edge).

Order
  Both sort by (tile, float bits of the view depth z) with a stable cub
  radix sort over keys emitted in Gaussian index order (INRIA
  rasterizer_impl.cu:102-104, 306; GSPLAT IntersectTile.cu:95-108, 317):
  per pixel, ascending z, ties by index.

Colour
  dir = (mean - camera centre) / |.| in WORLD space, real SH as
  forward.cu:20-62 (constants auxiliary.h:21-38; GSPLAT
  SphericalHarmonicsCUDA.cu:29-75 has the same signs, e.g. degree 1 =
  C1 (-y sh1 + z sh2 - x sh3), rendering.py:491,511), + 0.5, clamped below
  at 0 (forward.cu:63-70; rendering.py:525). No upper clamp in the
  rasterizers (the gaussian-splatting render() clamps the composited image
  to [0, 1] afterwards; this reference does not).

Per pixel, front to back (T = 1, C = 0)
  INRIA renderCUDA forward.cu:349-377:
      power = -0.5 (A dx^2 + C dy^2) - B dx dy,  d = mean - pixel
      power > 0            -> skip            (:352-354)
      alpha = min(0.99, o' exp(power))        (:360)
      alpha < 1/255        -> skip            (:361-362)
      test_T = T (1 - alpha)
      test_T < 1e-4        -> stop, this Gaussian NOT composited (:363-368)
      C += colour alpha T; T = test_T         (:371-377)
  GSPLAT rasterize_to_pixels_3dgs_fwd_kernel RasterizeToPixels3DGSFwd.cu:
      sigma = -power; alpha = min(0.999, o' exp(-sigma))   (:145-148)
      sigma < 0 or alpha < 1/255 -> skip     (:149-151; Common.h:54)
      next_T <= 1e-4 -> stop, not composited (:153-157)
      C += colour alpha T; T = next_T        (:160-168)
  Output C + T background, final T (forward.cu:389-392;
  RasterizeToPixels3DGSFwd.cu:178-183).

Deliberate differences from the GPU code: float64 throughout (the CUDA is
float32; discrete decisions -- ceil of the radius, power > 0, alpha < 1/255,
the T threshold, tile truncation -- are taken exactly as written, but on
float64 values, so a value sitting on a float32 boundary may fall the other
way); with tile_rule=False every Gaussian that survives the culling above is
evaluated at every pixel (the tile-dependent drops -- empty rect, GSPLAT's
radius and off-image box -- are applied only with tile_rule=True).
"""
import math

import numpy as np

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396)
SH_C3 = (-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154, -0.4570457994644658,
         1.445305721320277, -0.5900435899266435)

TILE = 16
ALPHA_MIN = 1.0 / 255.0
T_MIN = 1e-4
EPS2D = 0.3

# Per variant: (family, antialiasing, alpha clamp)
VARIANTS = {
    "inria": ("inria", False, 0.99),              # forward.cu:360
    "inria-antialiased": ("inria", True, 0.99),
    "gsplat": ("gsplat", False, 0.999),           # RasterizeToPixels3DGSFwd.cu:148 (v1.5.3)
    "gsplat-antialiased": ("gsplat", True, 0.999),
}
INRIA_NEAR = 0.2       # auxiliary.h:166, culled if z <= 0.2
GSPLAT_NEAR = 0.01     # rendering.py:43, culled if z < 0.01
GSPLAT_FAR = 1e10      # rendering.py:44, culled if z > 1e10
INRIA_AA_FLOOR = 2.5e-5  # forward.cu:223, inside the sqrt
GSPLAT_EXTEND = 3.33   # ProjectionEWA3DGSFused.cu:164


def quat_to_rot(q):
    """Unit quaternion (w, x, y, z) to its rotation matrix (normalised first, as GSPLAT)."""
    return quat_to_rot_as_given(np.asarray(q, np.float64) / np.linalg.norm(q))


def quat_to_rot_as_given(q):
    """The CUDA's matrix of q = (w, x, y, z) WITHOUT normalising it (MAIN forward.cu:127-138): the
    unit-quaternion formula applied to q as it is. q = 0 gives the identity."""
    w, x, y, z = np.asarray(q, np.float64)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def sh_colour(sh, degree, d):
    """RGB of the SH coefficients sh (K, 3) in unit direction d: real SH up to degree 3, + 0.5,
    clamped below at 0 (forward.cu:20-70)."""
    sh = np.asarray(sh, np.float64)
    x, y, z = d
    r = SH_C0 * sh[0]
    if degree >= 1:
        r = r + SH_C1 * (-y * sh[1] + z * sh[2] - x * sh[3])
    if degree >= 2:
        xx, yy, zz = x * x, y * y, z * z
        r = r + (SH_C2[0] * x * y * sh[4] + SH_C2[1] * y * z * sh[5] + SH_C2[2] * (2 * zz - xx - yy) * sh[6]
                 + SH_C2[3] * x * z * sh[7] + SH_C2[4] * (xx - yy) * sh[8])
    if degree >= 3:
        xx, yy, zz = x * x, y * y, z * z
        r = r + (SH_C3[0] * y * (3 * xx - yy) * sh[9] + SH_C3[1] * x * y * z * sh[10]
                 + SH_C3[2] * y * (4 * zz - xx - yy) * sh[11] + SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy) * sh[12]
                 + SH_C3[4] * x * (4 * zz - xx - yy) * sh[13] + SH_C3[5] * z * (xx - yy) * sh[14]
                 + SH_C3[6] * x * (xx - 3 * yy) * sh[15])
    return np.maximum(r + 0.5, 0.0)


def _c_trunc_div(num, den):
    """(int)(num / den) as C does it: truncation toward zero."""
    return int(math.trunc(num / den))


def principal_point(family, W, H, cx, cy, inria_off_centre_extension):
    """(cx, cy) in pixel-edge coordinates, W/2 and H/2 when not given. INRIA's rasterizer has no
    principal point: an off-centre one is refused unless the caller asks for this reference's
    extension (module docstring, "Principal point")."""
    cx = W / 2.0 if cx is None else float(cx)
    cy = H / 2.0 if cy is None else float(cy)
    if not (math.isfinite(cx) and math.isfinite(cy)):
        raise ValueError("principal point (cx, cy) = (%r, %r) is not finite" % (cx, cy))
    centred = cx == W / 2.0 and cy == H / 2.0
    if family == "inria" and not centred and not inria_off_centre_extension:
        raise ValueError("principal point (%r, %r) is off the image centre (%r, %r): Inria's rasterizer "
                         "has none (only tan_fovx, tan_fovy); pass inria_off_centre_extension=True for "
                         "this reference's extension, which is not Inria's code" % (cx, cy, W / 2.0, H / 2.0))
    return cx, cy


def jacobian_tangents(family, x, y, z, fx, fy, W, H, cx, cy):
    """The clamped (t.x / z, t.y / z) at which the EWA Jacobian is evaluated. INRIA (and its
    off-centre extension): +-1.3 tan_fov about the optical axis, tan_fovx = W / (2 fx)
    (forward.cu:82-87). GSPLAT persp_proj: the limits follow the image edges through cx, cy,
    x/z in [-(cx/fx + 0.3 tan_fovx), (W - cx)/fx + 0.3 tan_fovx] (Utils.cuh:514-524)."""
    tanx, tany = W / (2.0 * fx), H / (2.0 * fy)
    if family == "inria":
        limx, limy = 1.3 * tanx, 1.3 * tany
        return min(limx, max(-limx, x / z)), min(limy, max(-limy, y / z))
    txz = min((W - cx) / fx + 0.3 * tanx, max(-(cx / fx + 0.3 * tanx), x / z))
    tyz = min((H - cy) / fy + 0.3 * tany, max(-(cy / fy + 0.3 * tany), y / z))
    return txz, tyz


def inria_point_image(x, y, z, fx, fy, W, H, cx, cy):
    """INRIA's point_image (pixel-index coordinates): full_proj, the 1e-7 in p_w, ndc2Pix
    (forward.cu:195-197, auxiliary.h:40-43). The principal point enters as the projection
    matrix's third column P[0,2] = 2 cx/W - 1, P[1,2] = 2 cy/H - 1 (0 when centred, as 3DGS's
    getProjectionMatrix builds it: the extension only)."""
    tanx, tany = W / (2.0 * fx), H / (2.0 * fy)
    ndc_x = (x / tanx + (2.0 * cx / W - 1.0) * z) / (z + 1e-7)
    ndc_y = (y / tany + (2.0 * cy / H - 1.0) * z) / (z + 1e-7)
    return ((ndc_x + 1.0) * W - 1.0) * 0.5, ((ndc_y + 1.0) * H - 1.0) * 0.5


def world_covariance(model, n):
    """Gaussian n's 3D covariance in world space: model["cov3d_precomp"][n] (3, 3) when given (the
    rasterizer's cov3D_precomp path: preprocessCUDA takes the six stored entries as they are and
    skips computeCov3D, e.g. fudan-zvg/4d-gaussian-splatting 63725f21 diff-gaussian-rasterization/
    cuda_rasterizer/forward.cu:411-414, Inria's own `if (cov3D_precomp != nullptr)` branch), else
    R(q) diag(s^2) R(q)^T from the scales and quaternion."""
    if "cov3d_precomp" in model:
        cov = np.asarray(model["cov3d_precomp"][n], np.float64)
        return 0.5 * (cov + cov.T)
    Rq = (quat_to_rot_as_given if model.get("quaternion_as_given") else quat_to_rot)(model["rot"][n])
    s = np.asarray(model["scale"][n], np.float64)
    return Rq @ np.diag(s * s) @ Rq.T


def handed_jacobian(tan_fov, x, y, z, W, H):
    """The rasterizer's focal lengths and clamped (t.x/z, t.y/z) when it is handed tan_fov =
    (tanfovx, tanfovy) (FDGS rasterizer_impl.cu:235-236, forward.cu:206-211), as written: min(limx,
    max(-limx, x/z)) with limx = 1.3 tanfovx, whatever its sign."""
    tanx, tany = tan_fov
    limx, limy = 1.3 * tanx, 1.3 * tany
    return W / (2.0 * tanx), H / (2.0 * tany), min(limx, max(-limx, x / z)), min(limy, max(-limy, y / z))


def project(model, R_c2w, C, fx, fy, W, H, variant="inria", cx=None, cy=None, inria_off_centre_extension=False,
            rasterizer_tan_fov=None):
    """Per Gaussian, what the preprocess step produces. Returns a list (index order) of dicts, or
    None where the Gaussian is culled whatever the tiling. Keys: index, depth (view z), xy (the
    mean in the variant's own 2D coordinates), pix_offset (0 for INRIA's pixel-index pixf, 0.5 for
    GSPLAT's j + 0.5), cov2d_raw (2x2 before the 0.3), cov2d (after), conic (A, B, C), opacity
    (times the antialiasing factor if any), aa_factor, colour, radius (INRIA int, GSPLAT (rx, ry)),
    tiles ((x0, x1, y0, y1), half-open, or None: dropped under the tile rule), jacobian_txz
    (the clamped (t.x/z, t.y/z) of the EWA Jacobian).
    cx, cy: the principal point in pixel-edge coordinates (K[0,2], K[1,2]: pixel j spans
    [j, j + 1]); None means W/2, H/2. Off centre, the INRIA variants raise ValueError unless
    inria_off_centre_extension=True (this reference's extension, not Inria's code; the GSPLAT
    variants ignore the flag)."""
    family, aa, _ = VARIANTS[variant]
    if rasterizer_tan_fov is not None and family != "inria":
        raise ValueError("rasterizer_tan_fov is an INRIA rasterizer's argument, not gsplat's")
    cx, cy = principal_point(family, W, H, cx, cy, inria_off_centre_extension)
    R_c2w, C = np.asarray(R_c2w, np.float64), np.asarray(C, np.float64)
    Rw2c = R_c2w.T
    out = []
    for n in range(len(model["opacity"])):
        mean = np.asarray(model["mean"][n], np.float64)
        x, y, z = Rw2c @ (mean - C)
        if family == "inria" and z <= INRIA_NEAR:
            out.append(None)
            continue
        if family == "gsplat" and (z < GSPLAT_NEAR or z > GSPLAT_FAR):
            out.append(None)
            continue
        sigma_c = Rw2c @ world_covariance(model, n) @ Rw2c.T
        if rasterizer_tan_fov is None:
            jfx, jfy = fx, fy
            txz, tyz = jacobian_tangents(family, x, y, z, fx, fy, W, H, cx, cy)
        else:
            jfx, jfy, txz, tyz = handed_jacobian(rasterizer_tan_fov, x, y, z, W, H)
        J = np.array([[jfx / z, 0.0, -jfx * txz / z], [0.0, jfy / z, -jfy * tyz / z]])
        raw = J @ sigma_c @ J.T
        raw = 0.5 * (raw + raw.T)
        det0 = raw[0, 0] * raw[1, 1] - raw[0, 1] * raw[1, 0]
        cov = raw + EPS2D * np.eye(2)
        det = cov[0, 0] * cov[1, 1] - cov[0, 1] * cov[1, 0]
        if family == "inria":
            if det == 0.0:
                out.append(None)
                continue
            factor = math.sqrt(max(INRIA_AA_FLOOR, det0 / det)) if aa else 1.0
        else:
            if det <= 0.0:
                out.append(None)
                continue
            factor = math.sqrt(max(0.0, det0 / det)) if aa else 1.0
        conic = (cov[1, 1] / det, -cov[0, 1] / det, cov[0, 0] / det)
        opacity = float(model["opacity"][n]) * factor
        d = mean - C
        if "colors_precomp" in model:  # MAIN forward.cu:241 skips the SH; rasterizer_impl.cu:321 blends these
            colour = np.asarray(model["colors_precomp"][n], np.float64)
        else:
            colour = sh_colour(np.asarray(model["sh"][n])[: (model["degree"] + 1) ** 2], model["degree"],
                               d / np.linalg.norm(d))
        g = {"index": n, "depth": z, "cov2d_raw": raw, "cov2d": cov, "conic": conic, "opacity": opacity,
             "aa_factor": factor, "colour": colour, "jacobian_txz": (txz, tyz)}
        if family == "inria":
            g["xy"] = inria_point_image(x, y, z, fx, fy, W, H, cx, cy)
            g["pix_offset"] = 0.0
            mid = 0.5 * (cov[0, 0] + cov[1, 1])
            root = math.sqrt(max(0.1, mid * mid - det))
            radius = int(math.ceil(3.0 * math.sqrt(max(mid + root, mid - root))))
            gx, gy = (W + TILE - 1) // TILE, (H + TILE - 1) // TILE
            px, py = g["xy"]
            x0 = min(gx, max(0, _c_trunc_div(px - radius, TILE)))
            y0 = min(gy, max(0, _c_trunc_div(py - radius, TILE)))
            x1 = min(gx, max(0, _c_trunc_div(px + radius + TILE - 1, TILE)))
            y1 = min(gy, max(0, _c_trunc_div(py + radius + TILE - 1, TILE)))
            g["radius"] = radius
            g["tiles"] = (x0, x1, y0, y1) if (x1 - x0) * (y1 - y0) != 0 else None
        else:
            g["xy"] = (fx * x / z + cx, fy * y / z + cy)
            g["pix_offset"] = 0.5
            if opacity < ALPHA_MIN:  # ProjectionEWA3DGSFused.cu:171-175
                out.append(None)
                continue
            extend = min(GSPLAT_EXTEND, math.sqrt(2.0 * math.log(opacity / ALPHA_MIN)))
            rx = math.ceil(extend * math.sqrt(cov[0, 0]))
            ry = math.ceil(extend * math.sqrt(cov[1, 1]))
            g["radius"] = (int(rx), int(ry))
            mx, my = g["xy"]
            tiles = None
            clipped = rx <= 0 and ry <= 0                                              # radius_clip = 0
            off_image = mx + rx <= 0 or mx - rx >= W or my + ry <= 0 or my - ry >= H
            if not clipped and not off_image and rx > 0 and ry > 0:                    # IntersectTile.cu:57
                tw, th = math.ceil(W / float(TILE)), math.ceil(H / float(TILE))
                x0 = min(max(0, math.floor(mx / TILE - rx / TILE)), tw)
                y0 = min(max(0, math.floor(my / TILE - ry / TILE)), th)
                x1 = min(max(0, math.ceil(mx / TILE + rx / TILE)), tw)
                y1 = min(max(0, math.ceil(my / TILE + ry / TILE)), th)
                tiles = (x0, x1, y0, y1) if (x1 - x0) * (y1 - y0) > 0 else None
            g["tiles"] = tiles
        out.append(g)
    return out


def render(model, R_c2w, C, fx, fy, W, H, background, variant="inria", tile_rule=False, cx=None, cy=None,
           inria_off_centre_extension=False, rasterizer_tan_fov=None):
    """Render (H, W) pixels of model (dict as tests/gsply.py read() returns) through the camera
    (R_c2w: columns x right, y down, z forward; centre C; principal point (cx, cy) in pixel-edge
    coordinates, the image centre when None -- see project() for the INRIA variants off centre).
    Returns (image (H, W, 3) float64, final_T (H, W)). See the module docstring for every rule."""
    if variant not in VARIANTS:
        raise ValueError("variant must be one of %s" % sorted(VARIANTS))
    family, _, alpha_max = VARIANTS[variant]
    gs = [g for g in project(model, R_c2w, C, fx, fy, W, H, variant, cx, cy, inria_off_centre_extension,
                             rasterizer_tan_fov) if g is not None]
    if tile_rule:
        gs = [g for g in gs if g["tiles"] is not None]
    gs.sort(key=lambda g: (g["depth"], g["index"]))
    cols = np.arange(W, dtype=np.float64)[None, :]
    rows = np.arange(H, dtype=np.float64)[:, None]
    tcol, trow = np.arange(W)[None, :] // TILE, np.arange(H)[:, None] // TILE
    image = np.zeros((H, W, 3))
    T = np.ones((H, W))
    done = np.zeros((H, W), dtype=bool)
    for g in gs:
        a, b, c = g["conic"]
        dx = g["xy"][0] - (cols + g["pix_offset"])
        dy = g["xy"][1] - (rows + g["pix_offset"])
        power = -0.5 * (a * dx * dx + c * dy * dy) - b * dx * dy
        alpha = np.minimum(alpha_max, g["opacity"] * np.exp(np.minimum(power, 0.0)))
        ok = ~done & ~(power > 0.0) & ~(alpha < ALPHA_MIN)
        if tile_rule:
            x0, x1, y0, y1 = g["tiles"]
            ok &= (tcol >= x0) & (tcol < x1) & (trow >= y0) & (trow < y1)
        test_T = T * (1.0 - alpha)
        stop = ok & ((test_T < T_MIN) if family == "inria" else (test_T <= T_MIN))
        done |= stop
        add = ok & ~stop
        image += np.where(add, alpha * T, 0.0)[:, :, None] * g["colour"][None, None, :]
        T = np.where(add, test_T, T)
    image = image + T[:, :, None] * np.asarray(background, np.float64)[None, None, :]
    return image, T
