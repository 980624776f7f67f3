"""The 2DGS reference (tests/gs2d_reference.py) against values worked by
hand, so that it can serve as the independent expectation of refrender's
Gaussian renders (issue 24): a surfel facing the camera seen at its centre,
the low-pass filter's value one pixel from a sub-pixel surfel's centre, the
transmittance cut-off, centre-depth order, and near culling."""
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
