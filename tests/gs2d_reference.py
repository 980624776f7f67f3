"""An independent numpy reference of the official 2DGS forward pass at one
instant (hbb1/diff-surfel-rasterization, cuda_rasterizer/forward.cu, read
for its rules; Huang et al., SIGGRAPH 2024, Eqs. 8-10), for the Gaussian
splat work (issue 24): refrender's renders of a 2DGS model with
--pixel-filter point and one time are to match it per pixel.

It follows the rasterizer's own construction, not a ray tracer's: each
surfel's 3x3 homogeneous map T from its (u, v, 1) to (pixel x w, pixel y w,
w) (computeCov3D), the projected ellipse's centre from the dual conic
(computeCenter), and per pixel the intersection of the two planes through
the pixel (k, l), rho3d = u^2 + v^2, the low-pass rho2d = 2 |centre -
pixel|^2 (FilterInvSquare = 2), G = exp(-min/2), alpha = min(0.99, o G)
skipped below 1/255, front to back by the centre's view depth, stopping
before the Gaussian that would bring T below 1e-4; a hit whose depth (of
the plane intersection, also where rho2d wins: forward.cu at e0ed020, the
commit hbb1/2d-gaussian-splatting pins) is below 0.2 is skipped. Colour: SH of the
direction from the camera centre to the mean, + 0.5, clamped at 0.

Two deliberate differences, both where the official image depends on its
tiling and not on the model: every Gaussian is evaluated at every pixel
(the rasterizer only at pixels of the 16x16 tiles its 3-sigma square
touches), and the sort is global (per tile in the rasterizer; the same
order). Near culling is as the rasterizer's: centre depth <= 0.2, and per pixel as above.

Conventions: camera-to-world rotation R (columns x right, y down, z
forward, OpenCV/COLMAP) and centre C; pixel (i, j) is evaluated at
(i + 0.5, j + 0.5) with the principal point at (W/2, H/2), the
rasterizer's pixf, the same as pixel indices with (W - 1)/2."""
import numpy as np

SH_C0 = 0.28209479177387814
SH_C1 = 0.4886025119029199
SH_C2 = [1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396]
SH_C3 = [-0.5900435899266435, 2.890611442640554, -0.4570457994644658, 0.3731763325901154, -0.4570457994644658,
         1.445305721320277, -0.5900435899266435]


def sh_to_rgb(sh, degree, d):
    """sh: (K, 3) coefficients, d: unit direction. sh_utils.eval_sh + 0.5, clamped at 0."""
    x, y, z = d
    r = SH_C0 * sh[0]
    if degree > 0:
        r = r - SH_C1 * y * sh[1] + SH_C1 * z * sh[2] - SH_C1 * x * sh[3]
    if degree > 1:
        xx, yy, zz = x * x, y * y, z * z
        r = (r + SH_C2[0] * x * y * sh[4] + SH_C2[1] * y * z * sh[5] + SH_C2[2] * (2 * zz - xx - yy) * sh[6]
             + SH_C2[3] * x * z * sh[7] + SH_C2[4] * (xx - yy) * sh[8])
    if degree > 2:
        xx, yy, zz = x * x, y * y, z * z
        r = (r + SH_C3[0] * y * (3 * xx - yy) * sh[9] + SH_C3[1] * x * y * z * sh[10]
             + SH_C3[2] * y * (4 * zz - xx - yy) * sh[11] + SH_C3[3] * z * (2 * zz - 3 * xx - 3 * yy) * sh[12]
             + SH_C3[4] * x * (4 * zz - xx - yy) * sh[13] + SH_C3[5] * z * (xx - yy) * sh[14]
             + SH_C3[6] * x * (xx - 3 * yy) * sh[15])
    return np.maximum(r + 0.5, 0.0)


def quat_to_rot(q):
    """Unit quaternion (w, x, y, z) to a rotation matrix (build_rotation)."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def splat_transform(mean, scale2, quat, R_c2w, C, fx, fy, W, H):
    """T (3x3): columns map u, v and 1 to homogeneous pixel coordinates."""
    K = np.array([[fx, 0, W / 2.0], [0, fy, H / 2.0], [0, 0, 1.0]])
    Rw2c = R_c2w.T
    L = quat_to_rot(quat)
    tu, tv = Rw2c @ (L[:, 0] * scale2[0]), Rw2c @ (L[:, 1] * scale2[1])
    p = Rw2c @ (np.asarray(mean, dtype=np.float64) - C)
    return K @ np.stack([tu, tv, p], axis=1), p[2]


def projected_centre(T):
    """Centre of the image of the unit circle: the dual conic T diag(1,1,-1) T^T's last column."""
    D = T @ np.diag([1.0, 1.0, -1.0]) @ T.T
    return np.array([D[0, 2] / D[2, 2], D[1, 2] / D[2, 2]])


def render(model, R_c2w, C, fx, fy, W, H, background):
    """model: dict with mean (N,3), scale (N,2), rot (N,4 wxyz), opacity (N,),
    sh (N,K,3), degree. Returns an (H, W, 3) image and the final T."""
    R_c2w, C = np.asarray(R_c2w, dtype=np.float64), np.asarray(C, dtype=np.float64)
    items = []
    for i in range(len(model["opacity"])):
        T, depth = splat_transform(model["mean"][i], model["scale"][i], model["rot"][i], R_c2w, C, fx, fy, W, H)
        if depth <= 0.2:
            continue
        d = np.asarray(model["mean"][i], dtype=np.float64) - C
        colour = sh_to_rgb(model["sh"][i], model["degree"], d / np.linalg.norm(d))
        items.append((depth, i, T, projected_centre(T), colour))
    items.sort(key=lambda it: (it[0], it[1]))
    image = np.zeros((H, W, 3))
    final_t = np.ones((H, W))
    for j in range(H):
        for i in range(W):
            image[j, i], final_t[j, i] = shade_pixel(items, model, i + 0.5, j + 0.5, background)
    return image, final_t


def shade_pixel(items, model, px, py, background):
    colour, t = np.zeros(3), 1.0
    for _, idx, T, centre, rgb in items:
        k = -T[0] + px * T[2]  # the plane through pixel column px, in (u, v, 1)
        l = -T[1] + py * T[2]
        det = k[0] * l[1] - k[1] * l[0]
        if det == 0:
            continue
        u = (l[2] * k[1] - k[2] * l[1]) / det
        v = -(l[2] * k[0] - k[2] * l[0]) / det
        rho3d = u * u + v * v
        rho2d = 2.0 * ((centre[0] - px) ** 2 + (centre[1] - py) ** 2)
        if u * T[2][0] + v * T[2][1] + T[2][2] < 0.2:  # the hit's depth, also where rho2d wins
            continue
        alpha = min(0.99, model["opacity"][idx] * np.exp(-0.5 * min(rho3d, rho2d)))
        if alpha < 1.0 / 255.0:
            continue
        test_t = t * (1 - alpha)
        if test_t < 1e-4:
            break
        colour += rgb * alpha * t
        t = test_t
    return colour + t * np.asarray(background, dtype=np.float64), t
