"""Self-tests of gs3d_raster_reference against hand-worked values (numbers worked on paper and
written out here, not the reference's code run twice)."""
import math

import numpy as np
import pytest

import gs3d_raster_reference as ref

C0, C1 = 0.28209479177387814, 0.4886025119029199
CLASSIC = ["inria", "gsplat"]
ALL = ["inria", "inria-antialiased", "gsplat", "gsplat-antialiased"]
BG = np.array([0.1, 0.2, 0.3])
EYE = np.eye(3)
ORIGIN = np.zeros(3)


def model(gaussians, degree=0):
    """gaussians: list of (mean, scale, opacity, sh (K,3) or rgb (3,))."""
    k = (degree + 1) ** 2
    sh = []
    for g in gaussians:
        c = np.asarray(g[3], np.float64)
        if c.ndim == 1:  # an RGB colour: the DC term that gives it, no higher terms
            s = np.zeros((k, 3))
            s[0] = (c - 0.5) / C0
            c = s
        sh.append(c)
    return {"mean": np.array([g[0] for g in gaussians], np.float64),
            "scale": np.array([g[1] for g in gaussians], np.float64),
            "rot": np.tile([1.0, 0, 0, 0], (len(gaussians), 1)),
            "opacity": np.array([g[2] for g in gaussians], np.float64),
            "sh": np.array(sh), "degree": degree}


@pytest.mark.parametrize("variant", ALL)
def test_on_axis_isotropic(variant):
    # f = 20, z = 5, sigma = 0.5: f sigma / z = 2 px, cov2D = 4 + 0.3 = 4.3 on the diagonal.
    # W = H = 15: the mean lands on pixel index 15/2 - 0.5 = 7 exactly.
    m = model([((0, 0, 5.0), (0.5, 0.5, 0.5), 0.8, (0.7, 0.4, 0.2))])
    g = ref.project(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, variant)[0]
    assert np.allclose(g["cov2d"], [[4.3, 0], [0, 4.3]], atol=1e-12)
    assert np.allclose(g["xy"], (7.0, 7.0) if variant.startswith("inria") else (7.5, 7.5), atol=1e-9)
    o = 0.8 * (4.0 / 4.3 if variant.endswith("antialiased") else 1.0)  # sqrt(det 4 I / det 4.3 I) = 4/4.3
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, BG, variant)
    col = np.array([0.7, 0.4, 0.2])
    for (row, c, d2) in [(7, 7, 0.0), (7, 9, 4.0), (9, 9, 8.0), (4, 7, 9.0)]:
        a = o * math.exp(-0.5 * d2 / 4.3)
        assert np.allclose(img[row, c], a * col + (1 - a) * BG, atol=1e-9), (row, c)
        assert abs(T[row, c] - (1 - a)) < 1e-9
    # the classic centre by hand: 0.8 * 0.7 + 0.2 * 0.1 = 0.58
    if variant in CLASSIC:
        assert abs(img[7, 7, 0] - 0.58) < 1e-9


@pytest.mark.parametrize("variant", CLASSIC)
def test_pixel_centre_convention(variant):
    # W = 16, f = 16, x/z = 3.5/16: fx x/z + W/2 = 11.5 (pixel-edge coordinates) = pixel index 11,
    # so pixel 11 sees the peak (alpha = opacity) and pixels 10 and 12 are equal.
    z = 4.0
    m = model([((z * 3.5 / 16, 0, z), (0.3, 0.3, 0.3), 0.6, (1.0, 1.0, 1.0))])
    img, T = ref.render(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, np.zeros(3), variant)
    assert abs(T[7, 11] - T[8, 11]) < 1e-6  # rows: y = 0 is between rows 7 and 8
    row = img[7, :, 0]
    assert abs(row[10] - row[12]) < 1e-6 and row[11] > row[10]
    # peak in x, half a pixel off in y: cov = (16*0.3/4)^2 + 0.3 = 1.74
    assert abs(row[11] - 0.6 * math.exp(-0.5 * 0.25 / 1.74)) < 1e-6


@pytest.mark.parametrize("variant", CLASSIC)
def test_jacobian_clamp_far_off_axis(variant):
    # W = H = 16, f = 16: tan(fov/2) = 0.5, limit 1.3 * 0.5 = 0.65 (gsplat: 8/16 + 0.3*0.5, the same).
    # Unit isotropic Gaussian at (4, 0, 4): x/z = 1 is clamped to 0.65, so J row 0 = (4, 0, -2.6):
    # cov_xx = 16 + 6.76 + 0.3 = 23.06 (unclamped: 16 + 16 + 0.3 = 32.3), cov_yy = 16.3, cov_xy = 0.
    m = model([((4.0, 0, 4.0), (1.0, 1.0, 1.0), 0.9, (1.0, 1.0, 1.0))])
    g = ref.project(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, variant)[0]
    assert np.allclose(g["cov2d"], [[23.06, 0], [0, 16.3]], atol=1e-9)
    img, T = ref.render(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, np.zeros(3), variant)
    # pixel (row 7, col 15): the mean is at pixel index (23.5, 7.5): d = (8.5, 0.5)
    a = 0.9 * math.exp(-0.5 * (8.5 ** 2 / 23.06 + 0.25 / 16.3))
    a_unclamped = 0.9 * math.exp(-0.5 * (8.5 ** 2 / 32.3 + 0.25 / 16.3))
    assert abs(a - 0.18645) < 1e-5 and abs(a_unclamped - 0.29187) < 1e-5
    assert abs(img[7, 15, 0] - a) < 1e-6
    # mirrored Gaussian at x = -4: pixel column 0 is its mirror image
    m2 = model([((-4.0, 0, 4.0), (1.0, 1.0, 1.0), 0.9, (1.0, 1.0, 1.0))])
    img2, _ = ref.render(m2, EYE, ORIGIN, 16.0, 16.0, 16, 16, np.zeros(3), variant)
    assert abs(img2[7, 0, 0] - a) < 1e-6


@pytest.mark.parametrize("variant", ["inria-antialiased", "gsplat-antialiased"])
def test_antialias_factor_subpixel(variant):
    # f = 20, z = 5: screen std = 4 sigma. Flat Gaussian sigma = (0.075, 0.25, 0): s_x^2 = 0.09,
    # s_y^2 = 1, so the factor is sqrt(0.09/0.39) * sqrt(1/1.3) = 0.42133
    m = model([((0, 0, 5.0), (0.075, 0.25, 0.0), 0.9, (1.0, 1.0, 1.0))])
    g = ref.project(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, variant)[0]
    f = math.sqrt(0.09 / 0.39) * math.sqrt(1 / 1.3)
    assert abs(f - 0.421325) < 1e-5
    assert abs(g["aa_factor"] - f) < 1e-9
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, np.zeros(3), variant)
    assert abs(img[7, 7, 0] - 0.9 * f) < 1e-9 and abs(T[7, 7] - (1 - 0.9 * f)) < 1e-9
    # the classic variant keeps the full opacity at the centre
    img_c, _ = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, np.zeros(3), variant.split("-")[0])
    assert abs(img_c[7, 7, 0] - 0.9) < 1e-9


def test_antialias_floor_differs():
    # s^2 = 1e-4 per axis (sigma = 0.0025 at f/z = 4): det ratio = (1e-4/0.3001)^2 = 1.11e-7.
    # INRIA floors the ratio at 2.5e-5: factor 0.005, alpha 0.99*0.005 = 0.00495 >= 1/255: drawn.
    # gsplat: factor 1e-4/0.3001 = 3.33e-4, opacity 3.3e-4 < 1/255: culled, background only.
    m = model([((0, 0, 5.0), (0.0025, 0.0025, 0.0025), 0.99, (1.0, 1.0, 1.0))])
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, BG, "inria-antialiased")
    assert abs(T[7, 7] - (1 - 0.00495)) < 1e-9
    assert np.allclose(img[7, 7], 0.00495 + (1 - 0.00495) * BG, atol=1e-9)
    g = ref.project(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, "gsplat-antialiased")[0]
    assert g is None
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, BG, "gsplat-antialiased")
    assert np.all(T == 1.0) and np.allclose(img, BG)


@pytest.mark.parametrize("variant", CLASSIC)
def test_stop_rule_three_opaque(variant):
    # Three wide Gaussians on the axis, opacity 0.98, listed far-to-near in index order.
    # Centre pixel: red alpha 0.98 (T 0.02); green: T 0.02*0.02 = 4e-4 >= 1e-4, composited with
    # weight 0.98*0.02 = 0.0196; blue: 4e-4*0.02 = 8e-6 < 1e-4: stop, blue is NOT composited.
    m = model([((0, 0, 4.0), (1, 1, 1), 0.98, (0.0, 0.0, 1.0)),
               ((0, 0, 2.0), (1, 1, 1), 0.98, (1.0, 0.0, 0.0)),
               ((0, 0, 3.0), (1, 1, 1), 0.98, (0.0, 1.0, 0.0))])
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, BG, variant)
    assert abs(T[7, 7] - 4e-4) < 1e-12
    assert np.allclose(img[7, 7], [0.98 + 4e-4 * 0.1, 0.0196 + 4e-4 * 0.2, 4e-4 * 0.3], atol=1e-9)


@pytest.mark.parametrize("variant,t_expected", [("inria", 0.01), ("gsplat", 0.001)])
def test_alpha_clamp(variant, t_expected):
    # opacity 1 at the peak: INRIA clamps alpha to 0.99, gsplat v1.5.3 to 0.999
    m = model([((0, 0, 5.0), (0.5, 0.5, 0.5), 1.0, (1.0, 1.0, 1.0))])
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, np.zeros(3), variant)
    assert abs(T[7, 7] - t_expected) < 1e-12


@pytest.mark.parametrize("variant", CLASSIC)
def test_depth_order_not_index(variant):
    # index 0 is far and blue, index 1 near and red, both 0.5 at the centre:
    # 0.5 red + 0.25 blue + 0.25 background
    m = model([((0, 0, 6.0), (1, 1, 1), 0.5, (0.0, 0.0, 1.0)), ((0, 0, 3.0), (1, 1, 1), 0.5, (1.0, 0.0, 0.0))])
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, BG, variant)
    assert np.allclose(img[7, 7], [0.5 + 0.025, 0.05, 0.25 + 0.075], atol=1e-9)


def test_near_plane():
    # z = 0.15: culled by INRIA (z <= 0.2), kept by gsplat (z >= 0.01); peak alpha = opacity 0.7
    m = model([((0, 0, 0.15), (0.01, 0.01, 0.01), 0.7, (1.0, 1.0, 1.0))])
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, np.zeros(3), "inria")
    assert np.all(T == 1.0)
    img, T = ref.render(m, EYE, ORIGIN, 20.0, 20.0, 15, 15, np.zeros(3), "gsplat")
    assert abs(T[7, 7] - 0.3) < 1e-12


def tail_scene():
    # W = H = 32, f = 32, z = 4. Flat Gaussian with (f sigma / z)^2 = 3.7: cov2D = 4 I (std 2 px).
    # INRIA: pixel-index mean (9.6, 8): x = -5.9 z / 32, y = -7.5 z / 32.
    z = 4.0
    return model([((-5.9 * z / 32, -7.5 * z / 32, z), (math.sqrt(3.7) * z / 32, math.sqrt(3.7) * z / 32, 0.0),
                    0.99, (1.0, 1.0, 1.0))])


def test_tile_rule_cuts_tail_inria():
    # INRIA radius: mid = 4, det = 16, mid^2 - det = 0 -> sqrt(max(0.1, 0)) = 0.3162,
    # lambda = 4.3162, ceil(3 * 2.0776) = ceil(6.233) = 7. getRect x: (int)((9.6-7)/16) = 0,
    # (int)((9.6+7+15)/16) = (int)1.975 = 1: only tile column 0 (pixels 0..15).
    # Pixel (row 8, col 16): dx = 6.4 = 3.2 std, alpha = 0.99 exp(-5.12) = 0.005917 >= 1/255:
    # drawn by brute force, cut by the tile rule. Column 15 (dx = 5.4) is drawn by both.
    m = tail_scene()
    g = ref.project(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, "inria")[0]
    assert g["radius"] == 7 and g["tiles"] == (0, 1, 0, 1)
    a16, a15 = 0.99 * math.exp(-5.12), 0.99 * math.exp(-0.5 * 5.4 ** 2 / 4)
    assert abs(a16 - 0.005917) < 1e-6
    brute, Tb = ref.render(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, np.zeros(3), "inria", tile_rule=False)
    tiled, Tt = ref.render(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, np.zeros(3), "inria", tile_rule=True)
    assert abs(brute[8, 16, 0] - a16) < 1e-6 and tiled[8, 16, 0] == 0.0 and Tt[8, 16] == 1.0
    assert abs(brute[8, 15, 0] - a15) < 1e-6 and abs(tiled[8, 15, 0] - a15) < 1e-6


def test_tile_rule_gsplat_cuts_nothing():
    # gsplat: extend = min(3.33, sqrt(2 ln(0.99 * 255))) = 3.326, rx = ceil(6.652) = 7,
    # mean2d = (10.1, 8.5) (pixel edges): tile columns floor((10.1-7)/16) = 0 .. ceil((10.1+7)/16) = 2,
    # both; tile rows 0 .. ceil((8.5+7)/16) = 1 (rows >= 16 are >= 3.75 std away: alpha < 1/255).
    m = tail_scene()
    g = ref.project(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, "gsplat")[0]
    assert g["radius"] == (7, 7) and g["tiles"] == (0, 2, 0, 1)
    brute, Tb = ref.render(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, np.zeros(3), "gsplat", tile_rule=False)
    tiled, Tt = ref.render(m, EYE, ORIGIN, 32.0, 32.0, 32, 32, np.zeros(3), "gsplat", tile_rule=True)
    assert np.array_equal(brute, tiled) and np.array_equal(Tb, Tt)
    assert abs(brute[8, 16, 0] - 0.99 * math.exp(-5.12)) < 1e-6  # 3.2 std, as INRIA's brute force


@pytest.mark.parametrize("variant", CLASSIC)
def test_sh_degree1_world_direction(variant):
    # Camera looking along world +x: columns x_cam = (0,-1,0), y_cam = (0,0,-1), z_cam = (1,0,0).
    R = np.array([[0, 0, 1], [-1, 0, 0], [0, -1, 0]], np.float64)
    assert abs(np.linalg.det(R) - 1) < 1e-12
    sh = np.zeros((4, 3))
    sh[1], sh[2], sh[3] = 0.1, 0.3, 0.2  # y, z, x coefficients
    # Gaussian at world (2, 0, 0), camera at (-1, 0, 0): world direction (1, 0, 0), view (0, 0, 3).
    # colour = 0.5 + C1 (-y sh1 + z sh2 - x sh3) = 0.5 - 0.2 C1 = 0.402280 (a view-space direction
    # (0, 0, 1) would give 0.5 + 0.3 C1 instead).
    m = model([((2.0, 0, 0), (0.5, 0.5, 0.5), 0.5, sh)], degree=1)
    C = np.array([-1.0, 0, 0])
    g = ref.project(m, R, C, 20.0, 20.0, 15, 15, variant)[0]
    assert abs(g["depth"] - 3.0) < 1e-12
    assert np.allclose(g["colour"], 0.5 - 0.2 * C1, atol=1e-12) and abs(0.5 - 0.2 * C1 - 0.402280) < 1e-6
    img, T = ref.render(m, R, C, 20.0, 20.0, 15, 15, BG, variant)
    assert np.allclose(img[7, 7], 0.5 * (0.5 - 0.2 * C1) + 0.5 * BG, atol=1e-9)
    # world (2, 0, 3): direction (3, 0, 3)/|.| = (1, 0, 1)/sqrt 2: 0.5 + C1 (0.3 - 0.2)/sqrt 2;
    # it is above the centre (view y = -3 < 0: up).
    m2 = model([((2.0, 0, 3.0), (0.5, 0.5, 0.5), 0.5, sh)], degree=1)
    g2 = ref.project(m2, R, C, 20.0, 20.0, 15, 15, variant)[0]
    assert np.allclose(g2["colour"], 0.5 + C1 * 0.1 / math.sqrt(2), atol=1e-12)
    assert g2["xy"][1] < 7.0
    # negative results clamp at 0: DC -3 gives 0.5 - 3 C0 < 0
    sh3 = sh.copy()
    sh3[0] = -3.0
    g3 = ref.project(model([((2.0, 0, 0), (0.5, 0.5, 0.5), 0.5, sh3)], degree=1), R, C, 20.0, 20.0, 15, 15,
                     variant)[0]
    assert np.all(g3["colour"] == 0.0)


def scene_off_axis():
    # Unit isotropic Gaussians at z = 4 with x/z and y/z = +-0.6 and +-1.0, and one on the axis.
    return model([((-2.4, 2.4, 4.0), (1, 1, 1), 0.9, (1.0, 1.0, 1.0)),
                  ((2.4, -2.4, 4.0), (1, 1, 1), 0.7, (0.2, 0.5, 0.9)),
                  ((4.0, 4.0, 4.0), (1, 1, 1), 0.5, (0.9, 0.1, 0.3)),
                  ((0.0, 0.0, 6.0), (0.4, 0.2, 0.3), 0.8, (0.3, 0.9, 0.4))])


@pytest.mark.parametrize("variant", ALL)
@pytest.mark.parametrize("tile_rule", [False, True])
def test_centred_principal_point_is_the_default(variant, tile_rule):
    # cx = W/2, cy = H/2 given explicitly (and, for INRIA, through the extension) changes nothing
    m = scene_off_axis()
    base = ref.render(m, EYE, ORIGIN, 16.0, 18.0, 16, 14, BG, variant, tile_rule)
    for kw in ({"cx": 8.0, "cy": 7.0}, {"cx": 8.0, "cy": 7.0, "inria_off_centre_extension": True}):
        img, T = ref.render(m, EYE, ORIGIN, 16.0, 18.0, 16, 14, BG, variant, tile_rule, **kw)
        assert np.array_equal(img, base[0]) and np.array_equal(T, base[1])


def off_centre_cov(t):
    # f = 16, z = 4, sigma = I: J = [[4, 0, -4 t_x], [0, 4, -4 t_y]], cov = J J^T + 0.3 I
    # = [[16.3 + 16 t_x^2, 16 t_x t_y], [16 t_x t_y, 16.3 + 16 t_y^2]]
    return np.array([[16.3 + 16 * t[0] ** 2, 16 * t[0] * t[1]], [16 * t[0] * t[1], 16.3 + 16 * t[1] ** 2]])


@pytest.mark.parametrize("variant", ["gsplat", "gsplat-antialiased"])
def test_gsplat_off_centre_clamp(variant):
    # W = H = 16, f = 16, tan_fov = 0.5, principal point (4, 12). gsplat persp_proj limits:
    # x/z in [-(4/16 + 0.15), 12/16 + 0.15] = [-0.4, 0.9], y/z in [-(12/16 + 0.15), 4/16 + 0.15] = [-0.9, 0.4].
    # Gaussian 0 at x/z = -0.6, y/z = +0.6: beyond 0.4, inside 0.9, so both clamp to 0.4 in magnitude:
    # t = (-0.4, 0.4), cov = [[18.86, -2.56], [-2.56, 18.86]] (unclamped or symmetric +-0.65 clamp:
    # [[22.06, -5.76], [-5.76, 22.06]]). Gaussian 1, mirrored (x/z = +0.6, y/z = -0.6), is inside the
    # wide limits: unclamped, 22.06. Gaussian 2 at (1, 1): clamped to (0.9, 0.4).
    g = ref.project(scene_off_axis(), EYE, ORIGIN, 16.0, 16.0, 16, 16, variant, cx=4.0, cy=12.0)
    assert np.allclose(g[0]["jacobian_txz"], (-0.4, 0.4), atol=1e-12)
    assert np.allclose(g[0]["cov2d"], [[18.86, -2.56], [-2.56, 18.86]], atol=1e-9)
    assert np.allclose(g[1]["jacobian_txz"], (0.6, -0.6), atol=1e-12)
    assert np.allclose(g[1]["cov2d"], [[22.06, -5.76], [-5.76, 22.06]], atol=1e-9)
    assert np.allclose(g[2]["jacobian_txz"], (0.9, 0.4), atol=1e-12)
    assert np.allclose(g[2]["cov2d"], off_centre_cov((0.9, 0.4)), atol=1e-9)
    # means: mean2d = f x/z + c (pixel edges): (-9.6 + 4, 9.6 + 12) = (-5.6, 21.6), (13.6, 2.4)
    assert np.allclose(g[0]["xy"], (-5.6, 21.6), atol=1e-12) and np.allclose(g[1]["xy"], (13.6, 2.4), atol=1e-12)
    if variant == "gsplat":
        # pixel (row 15, col 0), centre (0.5, 15.5): d = (-6.1, 6.1), along the eigenvector (-1, 1) of
        # the clamped cov, eigenvalue 18.86 + 2.56 = 21.42: alpha = 0.9 exp(-0.5 * 74.42 / 21.42);
        # Gaussian 2's mean (20, 13.6) is 19.5 px away in x: alpha 1e-5, skipped
        one = model([((-2.4, 2.4, 4.0), (1, 1, 1), 0.9, (1.0, 1.0, 1.0))])
        img, T = ref.render(one, EYE, ORIGIN, 16.0, 16.0, 16, 16, np.zeros(3), variant, cx=4.0, cy=12.0)
        a = 0.9 * math.exp(-0.5 * 74.42 / 21.42)
        assert abs(a - 0.158418) < 1e-6 and abs(0.9 * math.exp(-0.5 * 74.42 / 27.82) - 0.236245) < 1e-6
        assert abs(img[15, 0, 0] - a) < 1e-9 and abs(T[15, 0] - (1 - a)) < 1e-9


def test_gsplat_off_centre_mirror():
    # Mirroring x -> -x with cx -> W - cx swaps gsplat's two x limits and mirrors the pixel centres
    # j + 0.5 -> W - (j + 0.5): the image is mirrored column for column.
    m = scene_off_axis()
    mirrored = dict(m, mean=m["mean"] * [-1.0, 1.0, 1.0])
    for tile_rule in (False, True):
        img, T = ref.render(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, BG, "gsplat", tile_rule, cx=4.5, cy=12.0)
        img2, T2 = ref.render(mirrored, EYE, ORIGIN, 16.0, 16.0, 16, 16, BG, "gsplat", tile_rule, cx=11.5, cy=12.0)
        assert np.allclose(img2, img[:, ::-1], atol=1e-12) and np.allclose(T2, T[:, ::-1], atol=1e-12)


@pytest.mark.parametrize("variant", ["inria", "inria-antialiased"])
def test_inria_off_centre_extension(variant):
    # Inria's rasterizer has no principal point: refused off centre unless the extension is asked for
    m = scene_off_axis()
    with pytest.raises(ValueError, match="principal point"):
        ref.project(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, variant, cx=4.0, cy=12.0)
    # The extension: clamp +-1.3 * 0.5 = +-0.65 about the optical axis whatever cx, cy, so Gaussians
    # 0 and 1 (|x/z| = |y/z| = 0.6) are unclamped, Gaussian 2 clamps to (0.65, 0.65) (gsplat: (0.9, 0.4))
    g = ref.project(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, variant, cx=4.0, cy=12.0, inria_off_centre_extension=True)
    assert np.allclose(g[0]["jacobian_txz"], (-0.6, 0.6), atol=1e-12)
    assert np.allclose(g[0]["cov2d"], [[22.06, -5.76], [-5.76, 22.06]], atol=1e-9)
    assert np.allclose(g[2]["jacobian_txz"], (0.65, 0.65), atol=1e-12)
    assert np.allclose(g[2]["cov2d"], off_centre_cov((0.65, 0.65)), atol=1e-9)
    # point_image = f x/(z + 1e-7) + c - 0.5 (pixel index): (-9.6 + 3.5, 9.6 + 11.5) = (-6.1, 21.1)
    assert np.allclose(g[0]["xy"], (-6.1, 21.1), atol=1e-6)
    assert np.allclose(g[1]["xy"], (13.1, 1.9), atol=1e-6)


def test_gsplat_off_image_drop_uses_principal_point():
    # sigma = 0.1 at (-2.4, 0, 4), opacity 0.9, f = 16, W = H = 16: extend = sqrt(2 ln(0.9 * 255)) = 3.2975.
    # cx = 4: x/z = -0.6 clamps to -0.4, cov_xx = 0.01 (16 + 2.56) + 0.3 = 0.4856, rx = ceil(2.298) = 3,
    # mean2d.x = -9.6 + 4 = -5.6 and -5.6 + 3 <= 0: dropped (ProjectionEWA3DGSFused.cu:193-198).
    # cx = 8: unclamped, cov_xx = 0.01 (16 + 5.76) + 0.3 = 0.5176, rx = ceil(2.372) = 3, mean2d.x = -1.6: kept.
    m = model([((-2.4, 0.0, 4.0), (0.1, 0.1, 0.1), 0.9, (1.0, 1.0, 1.0))])
    off = ref.project(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, "gsplat", cx=4.0, cy=8.0)[0]
    assert abs(off["cov2d"][0, 0] - 0.4856) < 1e-12 and off["radius"] == (3, 3) and off["tiles"] is None
    centred = ref.project(m, EYE, ORIGIN, 16.0, 16.0, 16, 16, "gsplat", cx=8.0, cy=8.0)[0]
    assert abs(centred["cov2d"][0, 0] - 0.5176) < 1e-12 and centred["radius"] == (3, 3)
    assert centred["tiles"] == (0, 1, 0, 1)
