"""The 2DGS reference (tests/gs2d_reference.py) against values worked by
hand, so that it can serve as the independent expectation of refrender's
Gaussian renders: a surfel facing the camera seen at its centre,
the low-pass filter's value one pixel from a sub-pixel surfel's centre, the
transmittance cut-off, centre-depth order, and near culling; and the rules
of forward.cu at e0ed020 against independent geometric arguments: the
filter's centre is the centre of the image of the radius-3 circle (the
unit circle up to 3a9357f), i.e. the image of the pole of the splat's
vanishing line, or the midpoint of two parallel tangents' points of
contact; the hyperbola case (drawn, not culled); the tile rule; the near
skip's depth."""
import numpy as np

import gs2d_reference as ref

W = H = 16
F = 20.0  # focal length in pixels
R = np.eye(3)  # camera looking down +z (OpenCV axes)
C = np.zeros(3)


def one(mean, scale, opacity=0.8, colour=(0.9, 0.2, 0.1), rot=(1, 0, 0, 0)):
    dc = (np.asarray(colour) - 0.5) / ref.SH_C0
    return {"mean": np.array([mean], float), "scale": np.array([scale], float), "rot": np.array([rot], float),
            "opacity": np.array([opacity]), "sh": dc.reshape(1, 1, 3), "degree": 0}


def test_a_facing_surfel_at_its_centre_has_its_opacity():
    # the centre at depth 5 projects onto pixel (8, 8)'s centre (8.5, 8.5): u = v = 0
    m = one([0.5 * 5 / F, 0.5 * 5 / F, 5.0], [1.0, 1.0])
    img, t = ref.render(m, R, C, F, F, W, H, background=(0, 0, 0))
    assert np.allclose(img[8, 8], 0.8 * np.array([0.9, 0.2, 0.1]), atol=1e-12)
    assert abs(t[8, 8] - 0.2) < 1e-12


def test_the_low_pass_filter_shows_a_sub_pixel_surfel():
    # a surfel far smaller than a pixel: rho3d is huge one pixel away, rho2d = 2 * 1^2 = 2, G = e^-1
    m = one([0.5 * 5 / F, 0.5 * 5 / F, 5.0], [1e-4, 1e-4], opacity=0.5)
    img, _ = ref.render(m, R, C, F, F, W, H, background=(0, 0, 0))
    assert np.allclose(img[8, 9], 0.5 * np.exp(-1.0) * np.array([0.9, 0.2, 0.1]), atol=1e-12)
    assert np.allclose(img[8, 8], 0.5 * np.array([0.9, 0.2, 0.1]), atol=1e-12)  # the centre: rho2d = 0


def test_order_is_by_centre_depth_and_transmittance_stops_before_1e_4():
    near = one([0.5 * 4 / F, 0.5 * 4 / F, 4.0], [1.0, 1.0], opacity=0.99, colour=(1, 0, 0))
    far = one([0.5 * 6 / F, 0.5 * 6 / F, 6.0], [1.0, 1.0], opacity=0.99, colour=(0, 1, 0))
    third = one([0.5 * 7 / F, 0.5 * 7 / F, 7.0], [1.0, 1.0], opacity=0.99, colour=(0, 0, 1))
    m = {k: np.concatenate([far[k], third[k], near[k]]) for k in ("mean", "scale", "rot", "opacity", "sh")}
    m["degree"] = 0
    img, t = ref.render(m, R, C, F, F, W, H, background=(1, 1, 1))
    # red (T 1 -> 0.01), green (0.01 -> 1e-4: test_T = 1e-4 is not below 1e-4, kept), then blue would
    # bring T to 1e-6 < 1e-4: the pass stops before it, and the background gets T = 1e-4
    expect = 0.99 * np.array([1, 0, 0]) + 0.01 * 0.99 * np.array([0, 1, 0]) + 1e-4 * np.ones(3)
    assert np.allclose(img[8, 8], expect, atol=1e-9)
    assert abs(t[8, 8] - 1e-4) < 1e-12


def test_surfels_nearer_than_0_2_are_culled():
    m = one([0.0, 0.0, 0.15], [1.0, 1.0])
    img, t = ref.render(m, R, C, F, F, W, H, background=(0.3, 0.3, 0.3))
    assert np.allclose(img, 0.3) and np.all(t == 1)


# ---- the projected centre (point_image) -------------------------------------------------------------------

W17 = 17  # odd: the principal point 8.5 is pixel 8's centre


def about_x(theta):
    """Quaternion (w, x, y, z) of a rotation by theta about the x axis: u stays x, v = (0, cos, sin)."""
    return [np.cos(theta / 2), np.sin(theta / 2), 0.0, 0.0]


def midpoint_centre_y(r, sv, theta, z0, f, cy0):
    """A splat at (0, 0, z0) turned by theta about x (u along x, v = (0, cos, sin)): the image of its circle
    of radius r is symmetric about the principal column and its two horizontal tangents touch it at the
    images of v = +-r (the tangents of the circle parallel to u); the conic's centre is their midpoint."""
    y = lambda v: f * (v * sv * np.cos(theta)) / (z0 + v * sv * np.sin(theta))
    return cy0 + 0.5 * (y(r) + y(-r))


def test_a_face_on_splat_has_both_centres_at_the_projected_mean():
    # turned about the view axis only, elongated: the centre is the mean's projection, whatever the circle
    q = [np.cos(np.pi / 12), 0, 0, np.sin(np.pi / 12)]
    T, _ = ref.splat_transform([0.3, -0.2, 4.0], [2.0, 0.5], q, R, C, F, F, W, H)
    expect = np.array([8 + F * 0.3 / 4, 8 - F * 0.2 / 4])  # (9.5, 7.0)
    assert np.allclose(ref.projected_centre(T), expect, atol=1e-12)
    assert np.allclose(ref.projected_centre(T, 1.0), expect, atol=1e-12)


def test_a_tilted_splat_centre_is_the_midpoint_of_its_tangent_points_and_depends_on_the_circle():
    th = np.radians(60)
    T, _ = ref.splat_transform([0, 0, 5.0], [0.5, 1.0], about_x(th), R, C, F, F, W, H)
    c3, c1 = ref.projected_centre(T), ref.projected_centre(T, 1.0)
    # by hand: r = 3: y(3) = 30/7.598 = 3.948, y(-3) = -30/2.402 = -12.490, centre 8 - 4.271;
    #          r = 1: y(1) = 10/5.866 = 1.705, y(-1) = -10/4.134 = -2.419, centre 8 - 0.357
    assert np.allclose(c3, [8.0, midpoint_centre_y(3, 1.0, th, 5.0, F, 8.0)], atol=1e-9)
    assert np.allclose(c1, [8.0, midpoint_centre_y(1, 1.0, th, 5.0, F, 8.0)], atol=1e-9)
    assert abs(c3[1] - (8 - 4.2708)) < 1e-3 and abs(c1[1] - (8 - 0.3571)) < 1e-3
    assert abs(c3[1] - c1[1]) > 3.9


def rodrigues(axis, phi):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    A = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) * np.cos(phi) + np.sin(phi) * A + (1 - np.cos(phi)) * np.outer(a, a), a


def test_a_general_tilted_splat_centre_is_the_image_of_the_pole_of_its_vanishing_line():
    # projectively, the conic's centre is the pole of the image's line at infinity; its preimage in (u, v) is
    # the vanishing line {w = 0} = {tu_z u + tv_z v + p_z = 0}, whose pole w.r.t. u^2 + v^2 = r^2 is
    # -r^2 (tu_z, tv_z) / p_z: the centre is the pinhole image of mean + u0 tu + v0 tv
    Rot, a = rodrigues([1.0, 2.0, 0.5], np.radians(70))
    q = [np.cos(np.radians(35)), *(np.sin(np.radians(35)) * a)]
    cam, _ = rodrigues([0, 1, 0], np.radians(10))
    centre_cam = np.array([0.2, 0.1, -1.0])
    mean, s = np.array([0.4, -0.3, 5.0]), np.array([0.3, 1.2])
    tu, tv = cam.T @ (Rot[:, 0] * s[0]), cam.T @ (Rot[:, 1] * s[1])
    p = cam.T @ (mean - centre_cam)
    T, _ = ref.splat_transform(mean, s, q, cam, centre_cam, F, F, W, H)
    got = {}
    for r in (1.0, 3.0):
        assert r * r * (tu[2] ** 2 + tv[2] ** 2) < p[2] ** 2  # an ellipse
        u0, v0 = -r * r * tu[2] / p[2], -r * r * tv[2] / p[2]
        X = p + u0 * tu + v0 * tv
        got[r] = ref.projected_centre(T, r)
        assert np.allclose(got[r], [F * X[0] / X[2] + W / 2, F * X[1] / X[2] + H / 2], atol=1e-9)
    assert np.linalg.norm(got[3.0] - got[1.0]) > 1.0


def test_the_low_pass_filter_is_centred_on_the_cutoff_circle_centre():
    # u thin (1e-4) along x, v = 1 turned 60 deg about x, at depth 5; pixel (8, 4): px = 8.5 is the principal
    # column, so u = 0; the ray's slope -0.2 meets v/2 = -0.2 (5 + v sqrt3/2): v = -1/(0.5 + 0.1 sqrt3)
    th = np.radians(60)
    m = one([0, 0, 5.0], [1e-4, 1.0], opacity=0.9, rot=about_x(th))
    v = -1.0 / (0.5 + 0.1 * np.sqrt(3))
    rho3d = v * v  # 2.2064
    rgb = np.array([0.9, 0.2, 0.1])
    for rule, r in (("cutoff", 3), ("unit-circle", 1)):
        cy = midpoint_centre_y(r, 1.0, th, 5.0, F, 8.5)  # 4.2292 (cutoff), 8.1429 (unit circle)
        rho2d = 2 * (cy - 4.5) ** 2  # 0.1467 (the filter wins), 26.54 (rho3d wins)
        img, _ = ref.render(m, R, C, F, F, W17, W17, background=(0, 0, 0), centre=rule)
        assert np.allclose(img[4, 8], 0.9 * np.exp(-0.5 * min(rho3d, rho2d)) * rgb, atol=1e-9), rule
    a, _ = ref.render(m, R, C, F, F, W17, W17, background=(0, 0, 0))
    b, _ = ref.render(m, R, C, F, F, W17, W17, background=(0, 0, 0), centre="unit-circle")
    assert abs(a[4, 8, 0] - b[4, 8, 0]) > 0.4  # red: 0.753 vs 0.269


def test_where_the_cutoff_circle_crosses_the_camera_plane_the_splat_is_drawn_with_the_hyperbola_centre():
    # v = 4 turned 30 deg at depth 5: 9 (4 sin30)^2 = 36 > 25, the radius-3 circle reaches z = 0 (its image
    # is a hyperbola), 1 (4 sin30)^2 = 4 < 25 (the unit circle's is an ellipse). compute_aabb goes on: d != 0.
    th = np.radians(30)
    m = one([0, 0, 5.0], [0.5, 4.0], opacity=0.8, rot=about_x(th))
    T, _ = ref.splat_transform(m["mean"][0], m["scale"][0], m["rot"][0], R, C, F, F, W17, W17)
    # tangent points y(3) = 20 * 10.392 / 11 = 18.895, y(-3) = 20 * -10.392 / -1 = 207.846: centre 8.5 + 113.37
    cy = midpoint_centre_y(3, 4.0, th, 5.0, F, 8.5)
    assert np.allclose(ref.projected_centre(T), [8.5, cy], atol=1e-9) and abs(cy - 121.87) < 0.01
    bg = np.array([0.3, 0.3, 0.3])
    img, _ = ref.render(m, R, C, F, F, W17, W17, background=bg)
    assert np.allclose(img[8, 8], 0.8 * np.array([0.9, 0.2, 0.1]) + 0.2 * bg, atol=1e-12)  # the mean: rho3d = 0
    # getRect: radius = ceil((207.846 - 18.895) / 2) = 95 (no vertical tangent: x's floor 1e-2 is smaller),
    # rows from trunc((121.37 - 95) / 16) = 1: only tile row 1 (pixel rows 16..) holds it; row 8 is background
    img, _ = ref.render(m, R, C, F, F, W17, W17, background=bg, tile_rule=True)
    assert np.allclose(img[:16], bg, atol=1e-12)


def test_the_tile_rule_cuts_a_tail():
    # face-on, sigma = 20 * 0.475 / 5 = 1.9 px, centre at index (10, 10) = continuous (10.5, 10.5) of a 32x32
    # image (2x2 tiles): extent 3 * 1.9 = 5.7, radius 6, tiles x: trunc(4/16) = 0 .. trunc(31/16) = 1, only tile 0
    m = one([-5.5 * 5 / F, -5.5 * 5 / F, 5.0], [0.475, 0.475], opacity=0.99)
    bg, rgb = np.array([0.1, 0.2, 0.3]), np.array([0.9, 0.2, 0.1])
    full, _ = ref.render(m, R, C, F, F, 32, 32, background=bg)
    cut, _ = ref.render(m, R, C, F, F, 32, 32, background=bg, tile_rule=True)
    for i in (15, 16):  # 5 and 6 px right of the centre: u = 5/1.9, 6/1.9 (alpha 0.031, 0.0068 > 1/255)
        a = 0.99 * np.exp(-0.5 * ((i - 10) / 1.9) ** 2)
        assert np.allclose(full[10, i], a * rgb + (1 - a) * bg, atol=1e-12)
    assert np.allclose(cut[10, 15], full[10, 15], atol=1e-15)
    assert np.allclose(cut[:, 16:], bg, atol=1e-15) and np.allclose(cut[16:, :], bg, atol=1e-15)


def test_the_near_skip_takes_the_hit_depth_also_where_the_filter_wins():
    # sub-pixel surfel at depth 1 turned 89 deg about x. Column 8's rays (slope b) meet its plane at
    # t = 1 / (1 - b tan89): b = +0.05 (row 9): t = -0.54, behind; b = -0.05 (row 7): t = 0.259 > 0.2.
    # The filter wins at both (rho3d ~ 1e8), rho2d = 2 * 1^2
    m = one([0, 0, 1.0], [1e-4, 1e-4], opacity=0.8, rot=about_x(np.radians(89)))
    lit = 0.8 * np.exp(-1.0) * np.array([0.9, 0.2, 0.1])
    img, _ = ref.render(m, R, C, F, F, W17, W17, background=(0, 0, 0))  # e0ed020
    assert np.allclose(img[9, 8], 0, atol=1e-15) and np.allclose(img[7, 8], lit, atol=1e-6)
    old, _ = ref.render(m, R, C, F, F, W17, W17, background=(0, 0, 0), near_depth="centre-if-filter")  # <= 7bdbd51
    assert np.allclose(old[9, 8], lit, atol=1e-6) and np.allclose(old[7, 8], lit, atol=1e-6)


def tilted_scene(n=14, seed=7):
    """n thin (u 0.003-0.01), long (v 0.4-0.8) splats turned 50-75 deg about random axes, depth 2.5-5."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(2.5, 5.0, n)
    xy = rng.uniform(-0.45, 0.45, (n, 2)) * z[:, None]
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1)[:, None]
    ang = rng.uniform(0.9, 1.3, n)
    q = np.concatenate([np.cos(ang / 2)[:, None], np.sin(ang / 2)[:, None] * axis], axis=1)
    scale = np.stack([rng.uniform(0.003, 0.01, n), rng.uniform(0.4, 0.8, n)], axis=1)
    rgb = rng.uniform(0.1, 0.9, (n, 3))
    return {"mean": np.concatenate([xy, z[:, None]], axis=1), "scale": scale, "rot": q,
            "opacity": rng.uniform(0.6, 0.95, n), "sh": ((rgb - 0.5) / ref.SH_C0)[:, None, :], "degree": 0}


def test_fourteen_tilted_elongated_splats_the_two_centre_rules_differ():
    m = tilted_scene()
    a, _ = ref.render(m, R, C, F, F, 24, 24, background=(0, 0, 0))
    b, _ = ref.render(m, R, C, F, F, 24, 24, background=(0, 0, 0), centre="unit-circle")
    diff = np.abs(a - b).max(axis=2)
    assert diff.max() > 1e-2 and (diff > 1e-2).sum() > 20  # 0.75 at most, on ~200 of 576 pixels


def test_unknown_rule_names_are_refused():
    import pytest
    with pytest.raises(ValueError):
        ref.render(one([0, 0, 5.0], [1.0, 1.0]), R, C, F, F, 4, 4, (0, 0, 0), centre="unit")
