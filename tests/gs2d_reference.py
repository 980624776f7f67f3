"""An independent numpy reference of the official 2DGS forward pass at one
instant, the independent expectation of refrender's 2DGS tests: its renders of a
2DGS model with --pixel-filter point and one time are to match it per pixel.

Rules: hbb1/diff-surfel-rasterization at e0ed0207b3e0669960cfad70852200a4a5847f61
("fix near cull", 2024-11-10), the commit hbb1/2d-gaussian-splatting pins
as submodules/diff-surfel-rasterization (its HEAD 1920a23, pin set by
d6dd136). Read for the rules only; citations are file:line at e0ed020
(fw = cuda_rasterizer/forward.cu, aux = cuda_rasterizer/auxiliary.h,
impl = cuda_rasterizer/rasterizer_impl.cu, cfg = cuda_rasterizer/config.h).

 - T (fw:75-115): 3x3 homogeneous map of (u, v, 1) to (x w, y w, w) in
   pixel index coordinates, x row = fx X + (W-1)/2 Z (ndc2pix fw:106-110,
   with 2DGS's centred projection), w row = the view depth Z; columns are
   the view-space R_u s_u, R_v s_v, mean (quat_to_rotmat aux:213-235, w
   first; scale_to_mat aux:286-292). Here T uses the principal point W/2,
   i.e. continuous coordinates = index + 0.5, and pixel i is evaluated at
   i + 0.5: the same numbers as the rasterizer's pixf = pix (fw:281).
 - Culls, per Gaussian: view depth of the mean <= 0.2 (in_frustum aux:200,
   called fw:186; no x/y frustum cull, it is commented out); the splat
   exactly edge-on, -p_view . n == 0 (DUAL_VISIABLE aux:32, fw:209-214);
   compute_aabb's d == 0 (fw:127, 229), see below; with tile_rule, an
   empty tile rectangle (fw:233-236).
 - Projected centre (point_image, fw:119-145, used by the low-pass filter,
   fw:364): the centre of the conic that is the image of the circle of
   radius `cutoff` in (u, v): D = T diag(c^2, c^2, -1) T^T, centre =
   (D[0,2], D[1,2]) / D[2,2], half extents sqrt(max(1e-4, centre^2 -
   D[i,i]/D[2,2])). cutoff = 3 (fw:216-221, TIGHTBBOX 0 at aux:21).
   Geometrically: the image of the pole, w.r.t. that circle, of the line
   of (u, v) that maps to w = 0. d = D[2,2] = c^2 (Tw.x^2 + Tw.y^2) -
   Tw.z^2 < 0 is an ellipse; d > 0 (the radius-c circle reaches the
   camera's z = 0 plane) is a hyperbola, and the rasterizer goes on
   unchanged: its centre is still the point used by the filter, no
   special case and no "no filter" rule; only d == 0 exactly returns false
   and culls the Gaussian (fw:127, 229). The same holds for the
   pre-909dd85 unit circle with 1 in place of 9.
   History: up to 3a9357f6a4b80ba319560be7965ed6a88ec951c6 ("fix dual
   visible", 2024-06-11; pinned by 2DGS 6d249de) the circle was the unit
   circle, D = T diag(1, 1, -1) T^T, and radius = ceil(3 max(extent))
   (3a9357f fw:129, 224); 909dd85ea202c82e9e04d47e8ebd5caab01493d9 ("fix
   aabb", 2024-06-28, merged as 28c928a, pinned by 2DGS c6e0b75) took
   the radius-`cutoff` circle and radius = ceil(max(extent)); 7bdbd51
   (2024-08-28) made it ceil(max(max(extent), cutoff FilterSize)) with
   FilterSize = 0.707106 (aux:39; fw:230). render(centre="unit-circle")
   takes the 3a9357f centre and radius.
 - Tiles (only with tile_rule=True): 16x16 (cfg:16-17), grid ceil(W/16) x
   ceil(H/16) (impl:235); getRect (aux:67-77) on point_image in index
   coordinates and the int radius: tiles [trunc((p - r)/16),
   trunc((p + r + 15)/16)) clamped to [0, grid]; a Gaussian is evaluated
   only at pixels of those tiles (impl:85-109, fw:289).
 - Order: by the mean's view depth p_view.z (fw:246; key impl:102-104,
   stable radix sort impl:304-309, so ties by index); the per-tile order
   is the global one restricted to the tile.
 - Per pixel (renderCUDA fw:258-448): planes k = x Tw - Tu, l = y Tw - Tv
   (fw:355-356), (u, v) = cross(k, l).xy / .z, skipped if .z == 0
   (fw:358-361); rho3d = u^2 + v^2 (fw:362); rho2d = FilterInvSquare
   |point_image - pixel|^2 with FilterInvSquare = 2 (fw:364-365, aux:40);
   rho = min (fw:366); the hit's depth u Tw.x + v Tw.y + Tw.z, also where
   rho2d wins, skipped if < near_n = 0.2 (fw:369-372, aux:37); alpha =
   min(0.99, o exp(-rho/2)) (fw:378-386), skipped below 1/255 (fw:387);
   stop, without this Gaussian, once T (1 - alpha) < 1e-4 (fw:389-394);
   C += rgb alpha T (fw:396, 417-419); out = C + T bg (fw:431-434).
   History: up to 7bdbd51 the near skip's depth was Tw.z (the mean's
   depth) where rho2d < rho3d (7bdbd51 fw:365); near_depth="centre-if-filter".
 - Colour (fw:20-71): SH of the unit direction mean - camera centre
   (fw:25-27), + 0.5 (fw:63), max(., 0) (fw:70); no upper clamp.

One deliberate difference where the official image depends on its tiling
and not on the model: by default (tile_rule=False) every Gaussian is
evaluated at every pixel. The arithmetic is float64 (the rasterizer's is
float32): equal float32 depths sort by index there, by float64 here.

Conventions: camera-to-world rotation R (columns x right, y down, z
forward, OpenCV/COLMAP) and centre C, focal lengths fx, fy in pixels."""
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


CUTOFF = 3.0                  # fw:220 (TIGHTBBOX 0, aux:21)
FILTER_SIZE = 0.707106        # aux:39
FILTER_INV_SQUARE = 2.0       # aux:40
NEAR = 0.2                    # aux:37 (per hit), aux:200 (per Gaussian)
TILE = 16                     # cfg:16-17


def splat_transform(mean, scale2, quat, R_c2w, C, fx, fy, W, H):
    """T (3x3): columns map u, v and 1 to homogeneous continuous pixel coordinates
    (x w, y w, w), w the view depth; and the mean's view depth."""
    K = np.array([[fx, 0, W / 2.0], [0, fy, H / 2.0], [0, 0, 1.0]])
    Rw2c = np.asarray(R_c2w, dtype=np.float64).T
    L = quat_to_rot(quat)
    tu, tv = Rw2c @ (L[:, 0] * scale2[0]), Rw2c @ (L[:, 1] * scale2[1])
    p = Rw2c @ (np.asarray(mean, dtype=np.float64) - np.asarray(C, dtype=np.float64))
    return K @ np.stack([tu, tv, p], axis=1), p[2]


def screen_box(T, cutoff=CUTOFF):
    """compute_aabb: the centre and half extents of the image of the circle of radius
    `cutoff` (continuous coordinates), or None where the rasterizer gives up (d == 0)."""
    D = T @ np.diag([cutoff * cutoff, cutoff * cutoff, -1.0]) @ T.T
    if D[2, 2] == 0.0:
        return None
    centre = D[:2, 2] / D[2, 2]
    half = np.sqrt(np.maximum(1e-4, centre * centre - np.diag(D)[:2] / D[2, 2]))
    return centre, half


def projected_centre(T, cutoff=CUTOFF):
    """point_image: the centre of the image of the radius-`cutoff` circle (3 at e0ed020;
    1 up to 3a9357f). An ellipse or, if the circle reaches z = 0, a hyperbola: same formula."""
    box = screen_box(T, cutoff)
    return None if box is None else box[0]


def _int(x):
    """float -> int as CUDA converts it (toward zero, saturating, NaN -> 0)."""
    if np.isnan(x):
        return 0
    return int(np.trunc(np.clip(x, -2.0 ** 31, 2.0 ** 31 - 1)))


def tile_rect(centre, half, W, H, rule="cutoff", cutoff=CUTOFF):
    """getRect on the radius of e0ed020 (fw:230) or of 3a9357f (rule="unit-circle"):
    (tx0, tx1, ty0, ty1), tiles tx0 <= tx < tx1, ty0 <= ty < ty1."""
    if rule == "cutoff":
        radius = np.ceil(max(half.max(), cutoff * FILTER_SIZE))
    else:
        radius = np.ceil(3.0 * half.max())
    r = _int(radius)
    gx, gy = (W + TILE - 1) // TILE, (H + TILE - 1) // TILE
    p = centre - 0.5  # point_image is in index coordinates
    clamp = lambda t, g: min(g, max(0, t))
    return (clamp(_int((p[0] - r) / TILE), gx), clamp(_int((p[0] + r + TILE - 1) / TILE), gx),
            clamp(_int((p[1] - r) / TILE), gy), clamp(_int((p[1] + r + TILE - 1) / TILE), gy))


def drawn_pixels(model, i, R_c2w, C, fx, fy, W, H, tile_rule=True):
    """The pixels (H x W booleans) where Gaussian i alone gets alpha >= 1/255 at e0ed020, each rule
    from its source line: culled by in_frustum (aux:200), DUAL_VISIABLE (fw:209-214) or compute_aabb's
    d == 0 (fw:127, 229); with tile_rule, only in the tiles of getRect (fw:232-236, aux:67-77) on
    point_image and radius = ceil(max(extent, 3 FilterSize)) (fw:230), whatever the sign of d (an
    ellipse or, where the radius-3 circle reaches behind the camera's plane, a hyperbola: fw:127 goes
    on, fw:140-144 take its centre and sqrt(max(1e-4, h0)) as for an ellipse); per pixel renderCUDA's
    plane intersection (fw:355-361), rho = min(rho3d, 2 |point_image - pixel|^2) (fw:362-366), the
    hit's depth >= 0.2 (fw:369-372) and min(0.99, o exp(-rho/2)) >= 1/255 (fw:378-387)."""
    mean = np.asarray(model["mean"][i], dtype=np.float64)
    T, depth = splat_transform(mean, model["scale"][i], model["rot"][i], R_c2w, C, fx, fy, W, H)
    out = np.zeros((H, W), dtype=bool)
    p_view = np.asarray(R_c2w, dtype=np.float64).T @ (mean - np.asarray(C, dtype=np.float64))
    normal = np.asarray(R_c2w, dtype=np.float64).T @ quat_to_rot(model["rot"][i])[:, 2]
    box = screen_box(T)
    if depth <= NEAR or np.dot(p_view, normal) == 0.0 or box is None:
        return out
    rect = tile_rect(box[0], box[1], W, H) if tile_rule else None
    for y in range(H):
        for x in range(W):
            if tile_rule and not (rect[0] <= x // TILE < rect[1] and rect[2] <= y // TILE < rect[3]):
                continue
            px, py = x + 0.5, y + 0.5
            k, l = px * T[2] - T[0], py * T[2] - T[1]
            line = np.cross(k, l)
            if line[2] == 0:
                continue
            u, v = line[0] / line[2], line[1] / line[2]
            rho = min(u * u + v * v, FILTER_INV_SQUARE * float(np.sum((box[0] - [px, py]) ** 2)))
            if u * T[2][0] + v * T[2][1] + T[2][2] < NEAR:
                continue
            out[y, x] = min(0.99, model["opacity"][i] * np.exp(-0.5 * rho)) >= 1.0 / 255.0
    return out


def render(model, R_c2w, C, fx, fy, W, H, background, centre="cutoff", tile_rule=False, near_depth="hit"):
    """model: dict with mean (N,3), scale (N,2), rot (N,4 wxyz), opacity (N,),
    sh (N,K,3), degree. Returns an (H, W, 3) image and the final T.
    centre: "cutoff" (e0ed020: radius-3 circle) or "unit-circle" (up to 3a9357f);
    tile_rule: evaluate a Gaussian only in the 16x16 tiles of its getRect;
    near_depth: "hit" (e0ed020) or "centre-if-filter" (up to 7bdbd51)."""
    if centre not in ("cutoff", "unit-circle") or near_depth not in ("hit", "centre-if-filter"):
        raise ValueError("centre: cutoff | unit-circle; near_depth: hit | centre-if-filter")
    R_c2w, C = np.asarray(R_c2w, dtype=np.float64), np.asarray(C, dtype=np.float64)
    items = []
    for i in range(len(model["opacity"])):
        T, depth = splat_transform(model["mean"][i], model["scale"][i], model["rot"][i], R_c2w, C, fx, fy, W, H)
        if depth <= NEAR:
            continue
        p_view = R_c2w.T @ (np.asarray(model["mean"][i], dtype=np.float64) - C)
        if np.dot(p_view, R_c2w.T @ quat_to_rot(model["rot"][i])[:, 2]) == 0.0:
            continue  # exactly edge-on: fw:210-211
        box = screen_box(T, CUTOFF if centre == "cutoff" else 1.0)
        if box is None:
            continue
        c = projected_centre(T) if centre == "cutoff" else projected_centre(T, 1.0)
        rect = None
        if tile_rule:
            rect = tile_rect(box[0], box[1], W, H, rule=centre)
            if (rect[1] - rect[0]) * (rect[3] - rect[2]) == 0:
                continue
        d = np.asarray(model["mean"][i], dtype=np.float64) - C
        colour = sh_to_rgb(model["sh"][i], model["degree"], d / np.linalg.norm(d))
        items.append((depth, i, T, c, colour, rect))
    items.sort(key=lambda it: (it[0], it[1]))
    image = np.zeros((H, W, 3))
    final_t = np.ones((H, W))
    for j in range(H):
        for i in range(W):
            image[j, i], final_t[j, i] = shade_pixel(items, model, i + 0.5, j + 0.5, background, near_depth)
    return image, final_t


def shade_pixel(items, model, px, py, background, near_depth="hit"):
    """One pixel at continuous (px, py) = (i + 0.5, j + 0.5), items sorted front to back:
    (depth, index, T, centre, rgb[, tile rect or None])."""
    colour, t = np.zeros(3), 1.0
    for item in items:
        _, idx, T, centre, rgb = item[:5]
        rect = item[5] if len(item) > 5 else None
        if rect is not None:
            tx, ty = int(np.floor(px)) // TILE, int(np.floor(py)) // TILE
            if not (rect[0] <= tx < rect[1] and rect[2] <= ty < rect[3]):
                continue
        k = px * T[2] - T[0]  # the plane through pixel column px, in (u, v, 1)
        l = py * T[2] - T[1]
        # k x l, written out (np.cross's own products and differences, without its array overhead)
        line = (k[1] * l[2] - k[2] * l[1], k[2] * l[0] - k[0] * l[2], k[0] * l[1] - k[1] * l[0])
        if line[2] == 0:
            continue
        u, v = line[0] / line[2], line[1] / line[2]
        rho3d = u * u + v * v
        rho2d = FILTER_INV_SQUARE * ((centre[0] - px) ** 2 + (centre[1] - py) ** 2)
        depth = u * T[2][0] + v * T[2][1] + T[2][2]
        if near_depth != "hit" and rho2d < rho3d:
            depth = T[2][2]
        if depth < NEAR:
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
