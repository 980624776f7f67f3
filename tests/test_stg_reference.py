"""Self-checks of tests/stg_reference.py, the independent reference of SpacetimeGaussians "lite"
models (427abfc5) that tests/test_stg_lite.py judges refrender with: the PLY written in save_ply's
layout and read back; each rule of the model at time t worked by hand; a zero quaternion drawn as
the identity; the flat Gaussian's erf closed form against a midpoint quadrature of the
reference's own instants (1000, within 1e-5: the rule's error at the two 1/255 cuts is below
6e-6 here); and, for each error a renderer could make, that the reference with that error planted
changes test_stg_lite.py's scenes by more than 1e-3 (ten times its 1e-4 tolerance): the 1/2 in
the temporal RBF, rot normalised before omega D is added, f_dc taken as SH (SH_C0 f_dc + 0.5), a
per-Gaussian colour clamp (to [0, 1], or at 0 only as the SH path's), a temporal opacity cut-off
(0.02), the motion coefficients read per axis (x1 x2 x3 y1 ..., as the comment in ourslite.py
suggests), torch's 1e-12 in normalize ignored; and the clamped-instants average against the
clamped average and the plain one. No refrender run: numpy only, a few seconds."""
import math

import numpy as np
import pytest

import gs3d_raster_reference as raster
import stg_reference as stg
import test_stg_lite as judged

SENSITIVE = 1e-3


def test_the_ply_round_trip_keeps_save_plys_layout(tmp_path):
    raw = judged.mixed_model()
    path = tmp_path / "m.ply"
    stg.write_stg_lite_ply(path, raw)
    data = path.read_bytes()
    head, _, body = data.partition(b"end_header\n")
    lines = head.decode().splitlines()
    assert lines[:3] == ["ply", "format binary_little_endian 1.0", f"element vertex {len(raw['xyz'])}"]
    names = [l.split()[2] for l in lines[3:]]
    assert names == ["x", "y", "z", "trbf_center", "trbf_scale", "nx", "ny", "nz", *[f"motion_{i}" for i in range(9)],
                     "f_dc_0", "f_dc_1", "f_dc_2", "opacity", "scale_0", "scale_1", "scale_2",
                     "rot_0", "rot_1", "rot_2", "rot_3", "omega_0", "omega_1", "omega_2", "omega_3"]
    assert all(l.startswith("property float ") for l in lines[3:])
    assert len(body) == 32 * 4 * len(raw["xyz"])
    back = stg.read_stg_lite_ply(path)
    for key in stg.FIELDS:
        want = np.asarray(raw[key], np.float64).reshape(back[key].shape)
        assert np.array_equal(back[key], want.astype(np.float32).astype(np.float64)), key
    v = np.frombuffer(body, "<f4").reshape(-1, 32)
    assert np.all(v[:, 5:8] == 0)  # the normals
    assert np.array_equal(v[:, 8:17], np.asarray(raw["motion"], np.float32))


def one(**kw):
    return judged.stack([judged.gaussian(**kw)])


def test_the_rules_at_time_t_by_hand():
    raw = one(xyz=(1.0, 2.0, 3.0), colour=(1.7, -0.2, 0.4), opacity=0.8, scale=(0.5, 0.25, 2.0),
              rot=(2.0, 0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0, 4.0),
              motion=(1, 2, 3, 4, 5, 6, 7, 8, 9), centre=0.25, tau=0.5)
    at = stg.stg_lite_at(raw, 0.75)  # D = 0.5
    D = 0.5
    assert np.allclose(at["mean"][0], [1 + D + 4 * D * D + 7 * D ** 3, 2 + 2 * D + 5 * D * D + 8 * D ** 3,
                                       3 + 3 * D + 6 * D * D + 9 * D ** 3])
    assert np.allclose(at["rot"][0], np.array([2.0, 0, 0, 2.0]) / math.sqrt(8.0))  # (2,0,0,0) + 0.5 (0,0,0,4)
    assert np.allclose(at["scale"][0], [0.5, 0.25, 2.0])
    assert math.isclose(at["opacity"][0], 0.8 * math.exp(-1.0), rel_tol=1e-6)  # (D / tau)^2 = 1, no 1/2
    assert np.allclose(at["colors_precomp"][0], [1.7, -0.2, 0.4])
    assert at["quaternion_as_given"]


def test_a_zero_quaternion_is_the_identity_and_a_tiny_one_is_scaled_by_torchs_eps():
    assert np.array_equal(raster.quat_to_rot_as_given([0, 0, 0, 0]), np.eye(3))
    zero = one(xyz=(0.1, 0.0, 3.0), colour=(0.9, 0.4, 0.2), opacity=0.8, scale=(0.5, 0.1, 0.2), rot=(0, 0, 0, 0))
    ident = one(xyz=(0.1, 0.0, 3.0), colour=(0.9, 0.4, 0.2), opacity=0.8, scale=(0.5, 0.1, 0.2), rot=(1, 0, 0, 0))
    a = stg.render_instant(zero, 0.3, np.eye(3), np.zeros(3), 30.0, 30.0, 40, 30)[0]
    b = stg.render_instant(ident, 0.3, np.eye(3), np.zeros(3), 30.0, 30.0, 40, 30)[0]
    assert np.array_equal(a, b) and a.max() > 0.5
    tiny = one(xyz=(0.1, 0.0, 3.0), colour=(0.9, 0.4, 0.2), opacity=0.8, scale=(0.5, 0.1, 0.2), rot=(0, 0, 6e-13, 0))
    q = stg.stg_lite_at(tiny, 0.3)["rot"][0]
    assert np.allclose(q, [0, 0, 0.6, 0])
    assert np.allclose(raster.quat_to_rot_as_given(q), np.diag([0.28, 1.0, 0.28]))


def test_the_flat_gaussians_closed_form_is_the_quadrature_of_the_reference():
    raw = judged.flat_model()
    W, H, F = judged.FLAT_W, judged.FLAT_H, judged.FLAT_F
    t0, t1 = judged.SHUTTER
    n = 1000
    image, alpha = stg.fine_average(raw, t0, t1, n, np.eye(3), np.zeros(3), F, F, W, H)
    closed = np.zeros((H, W, 4))
    for y in range(H):
        for x in range(W):
            rgb, a = stg.single_gaussian_integral(raw, F, F, W, H, x, y, t0, t1)
            closed[y, x] = (*rgb, a)
    quad = np.concatenate([image, alpha[..., None]], axis=-1)
    assert np.abs(closed - quad).max() < 1e-5, np.abs(closed - quad).max()
    assert alpha.max() > 0.1 and (alpha > 1e-3).sum() > 15  # a streak
    for x, y in judged.FLAT_PIXELS:
        assert alpha[y, x] > 5e-4, (x, y)
        assert judged.FLAT_ROWS[0] <= y < judged.FLAT_ROWS[1]
    # the last named pixel: the 1/255 cut shortens its interval (without it, its integral is larger)
    x, y = judged.FLAT_PIXELS[-1]
    saved = raster.ALPHA_MIN
    raster.ALPHA_MIN = 0.0
    try:
        uncut = stg.fine_average(raw, t0, t1, 400, np.eye(3), np.zeros(3), F, F, W, H)[1]
    finally:
        raster.ALPHA_MIN = saved
    assert uncut[y, x] - alpha[y, x] > 2e-4 and alpha[y, x] < 1e-3


def test_the_closed_form_refuses_what_it_does_not_cover():
    base = dict(xyz=(0.0, 0.0, 2.0), colour=(1, 1, 1), opacity=0.5, scale=(0.1, 0.1, 1e-9))
    for bad in (dict(scale=(0.1, 0.1, 0.05)), dict(rot=(1, 0.2, 0, 0)), dict(omega=(0, 0, 0, 1)),
                dict(motion=(0, 0, 0.1, 0, 0, 0, 0, 0, 0)), dict(motion=(0, 0, 0, 1, 0, 0, 0, 0, 0)),
                dict(opacity=0.995), dict(xyz=(0, 0, 0.1))):
        with pytest.raises(ValueError):
            stg.single_gaussian_integral(one(**{**base, **bad}), 20, 20, 8, 8, 4, 4, 0, 1)


# Planted errors: each replaces one rule of stg_lite_at.

def half_rbf(raw, t):
    at = stg.stg_lite_at(raw, t)
    c, D = stg._columns(raw), stg.time_offset(raw, t)[:, 0]
    at["opacity"] = 1 / (1 + np.exp(-c["opacity"][:, 0])) * np.exp(-0.5 * (D / np.exp(c["trbf_scale"][:, 0])) ** 2)
    return at


def normalised_before_omega(raw, t):
    at = stg.stg_lite_at(raw, t)
    c, D = stg._columns(raw), stg.time_offset(raw, t)
    unit = c["rot"] / np.maximum(np.linalg.norm(c["rot"], axis=1), 1e-12)[:, None]
    v = unit + D * c["omega"]
    at["rot"] = v / np.maximum(np.linalg.norm(v, axis=1), 1e-12)[:, None]
    return at


def colour_as_sh(raw, t):
    at = stg.stg_lite_at(raw, t)
    at["colors_precomp"] = raster.SH_C0 * at["colors_precomp"] + 0.5
    return at


def colour_clamped(raw, t):
    at = stg.stg_lite_at(raw, t)
    at["colors_precomp"] = np.clip(at["colors_precomp"], 0.0, 1.0)
    return at


def colour_clamped_at_zero(raw, t):
    at = stg.stg_lite_at(raw, t)
    at["colors_precomp"] = np.maximum(at["colors_precomp"], 0.0)
    return at


def temporal_cut_off(raw, t):
    at = stg.stg_lite_at(raw, t)
    at["opacity"] = np.where(at["opacity"] < 0.02, 0.0, at["opacity"])
    return at


def motion_per_axis(raw, t):
    at = stg.stg_lite_at(raw, t)
    c, D = stg._columns(raw), stg.time_offset(raw, t)
    m = c["motion"].reshape(-1, 3, 3)  # [axis][power]
    at["mean"] = c["xyz"] + m[:, :, 0] * D + m[:, :, 1] * D * D + m[:, :, 2] * D ** 3
    return at


def unit_normalised(raw, t):
    at = stg.stg_lite_at(raw, t)
    c, D = stg._columns(raw), stg.time_offset(raw, t)
    v = c["rot"] + D * c["omega"]
    n = np.linalg.norm(v, axis=1)
    at["rot"] = np.where(n[:, None] > 0, v / np.where(n > 0, n, 1.0)[:, None], v)
    return at


PLANTED = [half_rbf, normalised_before_omega, colour_as_sh, colour_clamped, colour_clamped_at_zero, temporal_cut_off,
           motion_per_axis]


def sharp_difference(at, times=judged.SHARP_TIMES):
    """The largest change of the sharp test's images (its background, every instant) by a planted rule."""
    W, H = 64, 48
    R, C, f = judged.mixed_camera(W, H)
    raw = judged.mixed_model()
    worst = 0.0
    for t in times:
        good = stg.render_instant(raw, t, R, C, f, f, W, H, (0.1, 0.2, 0.3))[0]
        bad = stg.render_instant(raw, t, R, C, f, f, W, H, (0.1, 0.2, 0.3), at=at)[0]
        worst = max(worst, np.abs(good - bad).max())
    return worst


@pytest.mark.parametrize("planted", PLANTED, ids=lambda p: p.__name__)
def test_each_planted_error_changes_the_sharp_scene_by_more_than_1e_3(planted):
    assert sharp_difference(planted) > SENSITIVE, planted.__name__


def test_torchs_eps_matters_on_the_tiny_quaternion_scene():
    W, H = 40, 30
    raw = judged.stack([judged.gaussian((0.6, 0.1, 3.5), (0.1, 0.6, 0.9), 0.8, (0.6, 0.15, 0.3), rot=(0, 0, 6e-13, 0))])
    good = stg.render_instant(raw, 0.25, np.eye(3), np.zeros(3), 30.0, 30.0, W, H)[0]
    bad = stg.render_instant(raw, 0.25, np.eye(3), np.zeros(3), 30.0, 30.0, W, H, at=unit_normalised)[0]
    assert np.abs(good - bad).max() > SENSITIVE


def test_the_integral_scene_keeps_its_depth_order_and_stays_away_from_the_T_stop():
    """The fine average's error bound assumes no jumps but the 1/255 cuts: no depth order change over
    the shutter, and the final T above 0.02 (so T never came below 1e-4 / (1 - 0.99) = 0.01, where
    the rasterizer stops)."""
    raw = judged.mixed_model()
    W, H = 32, 24
    R, C, f = judged.mixed_camera(W, H)
    orders = set()
    for t in np.linspace(*judged.SHUTTER, 1001):
        z = (stg.means_at(raw, t) - C) @ R[:, 2]
        orders.add(tuple(np.argsort(z)))
    assert len(orders) == 1
    for k in range(64):
        t = judged.SHUTTER[0] + (judged.SHUTTER[1] - judged.SHUTTER[0]) * (k + 0.5) / 64
        assert stg.render_instant(raw, t, R, C, f, f, W, H)[1].min() > 0.02


def test_the_clamped_mode_is_not_the_clamped_average_nor_the_plain_one():
    raw = judged.mixed_model()
    W, H = 32, 24
    R, C, f = judged.mixed_camera(W, H)
    clamped, _ = stg.fine_average(raw, *judged.SHUTTER, 64, R, C, f, f, W, H, clamp=True)
    plain, _ = stg.fine_average(raw, *judged.SHUTTER, 64, R, C, f, f, W, H)
    assert np.abs(clamped - plain).max() > 0.05
    assert np.abs(clamped - np.clip(plain, 0, 1)).max() > 10 * SENSITIVE


@pytest.mark.parametrize("planted", PLANTED, ids=lambda p: p.__name__)
def test_each_planted_error_changes_the_shutter_integral(planted):
    """The integral scene (32x24, shutter [0.2, 0.7]) at 32 instants: each planted error moves some
    pixel by more than 1e-3 (the tolerances there are standard errors, of order 1e-3 for the
    thesis sampler: this shows the errors are not below the integral test's reach by design)."""
    raw = judged.mixed_model()
    W, H = 32, 24
    R, C, f = judged.mixed_camera(W, H)
    good, _ = stg.fine_average(raw, *judged.SHUTTER, 32, R, C, f, f, W, H)
    bad, _ = stg.fine_average(raw, *judged.SHUTTER, 32, R, C, f, f, W, H, at=planted)
    assert np.abs(good - bad).max() > SENSITIVE, planted.__name__
