"""The 3DGRT reference (tests/gs3d_grt_reference.py) against values worked
by hand: a Gaussian seen through its centre has alpha = opacity; a ray
passing at 1 sigma gets exp(-1/2); the 0.0113 response cut; hits ordered by
closest approach; compositing goes on while T > 0.001, the hit that
crosses it included."""
import numpy as np

import gs2d_reference as ref2d
import gs3d_grt_reference as ref


def one(mean, scale, opacity, colour, rot=(1, 0, 0, 0)):
    dc = (np.asarray(colour, float) - 0.5) / ref2d.SH_C0
    return {"mean": np.array([mean], float), "scale": np.array([scale], float), "rot": np.array([rot], float),
            "opacity": np.array([opacity], float), "sh": dc.reshape(1, 1, 3), "degree": 0}


def join(*models):
    m = {k: np.concatenate([x[k] for x in models]) for k in ("mean", "scale", "rot", "opacity", "sh")}
    m["degree"] = 0
    return m


Z = np.array([0.0, 0.0, 1.0])


def test_through_the_centre_alpha_is_the_opacity():
    rgb, T = ref.trace(one([0, 0, 5], [0.3, 0.2, 0.1], 0.7, [1, 0, 0]), np.zeros(3), Z, (0, 0, 0))
    assert np.allclose(rgb, [0.7, 0, 0]) and abs(T - 0.3) < 1e-12


def test_one_sigma_off_axis_gives_exp_minus_half_and_the_cut_is_0_0113():
    m = one([0.2, 0, 5], [0.2, 1, 1], 0.5, [0, 1, 0])  # x scale 0.2: the ray passes at 1 sigma
    (t, _, alpha), = ref.hits(m, np.zeros(3), Z)
    assert abs(alpha - 0.5 * np.exp(-0.5)) < 1e-12 and abs(t - 5) < 1e-12
    far = one([0.2 * 2.99, 0, 5], [0.2, 1, 1], 1.0, [0, 1, 0])  # exp(-0.5 * 2.99^2) = 0.0114: a hit
    farther = one([0.2 * 3.0, 0, 5], [0.2, 1, 1], 1.0, [0, 1, 0])  # exp(-4.5) = 0.0111: none
    assert len(ref.hits(far, np.zeros(3), Z)) == 1 and not ref.hits(farther, np.zeros(3), Z)


def test_order_is_closest_approach_and_compositing_includes_the_hit_crossing_0_001():
    near, mid, far = (one([0, 0, z], [0.2, 0.2, 0.2], 0.99, c) for z, c in
                      ((3, [1, 0, 0]), (4, [0, 1, 0]), (5, [0, 0, 1])))
    rgb, T = ref.trace(join(far, near, mid), np.zeros(3), Z, (1, 1, 1))
    # red: T 1 -> 0.01; green: T = 0.01 > 0.001, composited, T -> 1e-4; blue: T <= 0.001, not composited
    assert np.allclose(rgb, [0.99, 0.01 * 0.99, 0] + 1e-4 * np.ones(3)) and abs(T - 1e-4) < 1e-15
