"""Self-checks of tests/fdgs_reference.py (real-time 4DGS, fudan-zvg/4d-gaussian-splatting at
63725f21), each against an argument independent of the reference's own formulas:
  - the conditional 3D Gaussian at t against the 4D Gaussian's quadratic form (the identity
    q4(x, t) = q3(x - mean(t)) + dt^2 / Sigma_tt with Sigma_4 inverted numerically), and against
    the closed form of a rotation in the x-t plane assembled by hand;
  - the Python matrices (general_utils.py) against the CUDA's glm matrices (forward.cu) read
    column-major, for both conventions;
  - the conventions agree where the 4D rotation equals its row-and-column reversal and differ
    otherwise (in the x-t plane the reversal turns the rotation the other way: the velocity flips);
  - the marginal cut (> 0.05), the 4D SH (sh_degree_t = 0 is 3DGS's SH; the harmonics' values at
    dir_t = T/4; none below spatial degree 3 as the CUDA nests them);
  - each planted error changes the images test_fdgs.py judges by more than 1e-3, and that scene's
    preconditions (depth order, cut crossings in the shutter, no marginal at the cut at a sharp time);
  - a checkpoint written with torch reads back as the capture() tuple (skipped without torch)."""
import math

import numpy as np
import pytest

import fdgs_reference as fdgs
import gs3d_raster_reference as raster
import test_fdgs as judged

RNG = np.random.default_rng(5)


def one_gaussian(xyz=(0.0, 0.0, 3.0), scaling=(0.3, 0.2, 0.25), scaling_t=0.4, rotation=(1, 0, 0, 0),
                 rotation_r=(1, 0, 0, 0), opacity=0.8, t=1.0, features=None, degree=3, degree_t=2):
    if features is None:
        features = np.zeros((48, 3))
        features[0] = 1.0
    return fdgs.make_capture(np.array([xyz]), np.array([features]), np.log([scaling]), np.array([rotation]),
                             np.array([math.log(opacity / (1 - opacity))]), np.array([t]),
                             np.log([scaling_t]), np.array([rotation_r]), degree, degree_t)


def glm_mat4(*values):
    """glm::mat4(v0..v15) as a math matrix: glm fills column by column (column-major)."""
    return np.array(values, np.float64).reshape(4, 4).T


def cuda_covariance(scale4, ql, qr, convention):
    """FWD computeCov3D_conditional's Sigma from the normalised quaternions: after 900c592 the
    matrices of forward.cu:315-327 at 63725f21, before it those of forward.cu:301-313 at 5094ca8
    (kept as a comment at 63725f21); R = M_r * M_l, M = S * R, Sigma = M^T M (:329-331)."""
    a, b, c, d = fdgs.normalize(ql)
    p, q, r, s = fdgs.normalize(qr)
    if convention == "after-900c592":
        M_l = glm_mat4(a, b, -c, d, -b, a, d, c, c, -d, a, b, -d, -c, -b, a)
        M_r = glm_mat4(p, q, -r, -s, -q, p, s, -r, r, -s, p, -q, s, r, q, p)
    else:
        M_l = glm_mat4(a, -b, -c, -d, b, a, -d, c, c, d, a, -b, d, -c, b, a)
        M_r = glm_mat4(p, q, r, s, -q, p, -s, r, -r, s, p, -q, -s, -r, q, p)
    M = np.diag(scale4) @ (M_r @ M_l)
    return M.T @ M


@pytest.mark.parametrize("convention", fdgs.CONVENTIONS)
def test_python_and_cuda_matrices_give_one_covariance(convention):
    for _ in range(20):
        s = np.exp(RNG.normal(0, 0.5, 4))
        ql, qr = RNG.normal(size=4) * 1.7, RNG.normal(size=4) * 0.6
        ref = fdgs.covariance_4d(np.log(s[:3]), math.log(s[3]), ql, qr, convention)
        assert np.allclose(ref, cuda_covariance(s, ql, qr, convention), atol=1e-12)


@pytest.mark.parametrize("convention", fdgs.CONVENTIONS)
def test_the_conditional_gaussian_is_the_4d_quadratic_form_split(convention):
    """(x - m, dt) Sigma_4^-1 (x - m, dt)^T = (x - mean(t))^T cov3^-1 (x - mean(t)) + dt^2/Sigma_tt
    at random points: the conditional mean, covariance and marginal of the 4D Gaussian."""
    for _ in range(10):
        scaling, scaling_t = RNG.normal(-1, 0.5, 3), RNG.normal(-1, 0.5)
        ql, qr = RNG.normal(size=4), RNG.normal(size=4)
        sigma4 = fdgs.covariance_4d(scaling, scaling_t, ql, qr, convention)
        inv4 = np.linalg.inv(sigma4)
        dt = RNG.normal(0, 0.5)
        offset, cov3, marginal = fdgs.condition(sigma4, dt)
        for x in RNG.normal(0, 0.4, (5, 3)):
            v = np.append(x, dt)
            q3 = (x - offset) @ np.linalg.solve(cov3, x - offset)
            assert abs(v @ inv4 @ v - (q3 + dt * dt / sigma4[3, 3])) < 1e-8 * (1 + v @ inv4 @ v)
        assert marginal == pytest.approx(math.exp(-0.5 * dt * dt / sigma4[3, 3]), rel=1e-14)


def test_a_rotation_in_the_x_t_plane_by_hand_and_the_two_conventions_turn_it_opposite_ways():
    """Left (cos f, 0, 0, sin f) and right (cos f, 0, 0, -sin f): M_l M_r is a rotation by 2f in the
    x-t plane only (by hand from general_utils.py:123-130: the y-z blocks cancel). Then Sigma_xx =
    c^2 sx^2 + s^2 st^2, Sigma_xt = c s (sx^2 - st^2), Sigma_tt = s^2 sx^2 + c^2 st^2 (c, s of 2f).
    The reversal maps the (x, t) block onto itself with the angle negated: Sigma_xt changes sign,
    so the conditional mean moves the other way, the rest is equal."""
    f = 0.3
    sx, sy, sz, st = 0.5, 0.2, 0.3, 0.25
    c, s = math.cos(2 * f), math.sin(2 * f)
    for convention, sign in (("before-900c592", 1.0), ("after-900c592", -1.0)):
        sigma4 = fdgs.covariance_4d(np.log([sx, sy, sz]), math.log(st), (math.cos(f), 0, 0, math.sin(f)),
                                    (math.cos(f), 0, 0, -math.sin(f)), convention)
        s_xt = sign * c * s * (sx * sx - st * st)
        s_tt = s * s * sx * sx + c * c * st * st
        expect = np.diag([c * c * sx * sx + s * s * st * st, sy * sy, sz * sz, s_tt])
        expect[0, 3] = expect[3, 0] = s_xt
        assert np.allclose(sigma4, expect, atol=1e-14), convention
        offset, cov3, _ = fdgs.condition(sigma4, 0.7)
        assert np.allclose(offset, [s_xt / s_tt * 0.7, 0, 0], atol=1e-14)
        assert cov3[0, 0] == pytest.approx(expect[0, 0] - s_xt * s_xt / s_tt, abs=1e-14)
        assert cov3[0, 0] == pytest.approx(sx * sx * st * st / s_tt, abs=1e-14)  # det of the block / Sigma_tt


def test_the_conventions_agree_where_the_rotation_equals_its_reversal_and_differ_otherwise():
    """Left (a, 0, c, 0) and right (p, q, 0, 0) give M_l, M_r equal to their own row-and-column
    reversals (by hand from general_utils.py:123-130), so A does too: both conventions draw the
    same Gaussian; a generic pair does not."""
    W, H = 24, 18
    R, C, f = np.eye(3), np.zeros(3), 20.0
    ql, qr = (0.8, 0.0, 0.5, 0.0), (0.6, 0.7, 0.0, 0.0)
    A = fdgs.rotation_4d(ql, qr, "before-900c592")
    assert np.allclose(A, A[::-1, ::-1]) and not np.allclose(A, np.eye(4))
    images = {}
    for name, (l, r) in (("symmetric", (ql, qr)), ("generic", ((0.8, 0.3, 0.1, -0.4), (0.9, 0.1, -0.5, 0.3)))):
        cap = one_gaussian(rotation=l, rotation_r=r, scaling=(0.5, 0.1, 0.3), scaling_t=0.3, t=1.1)
        images[name] = [fdgs.render_instant(cap, 1.0, conv, (0, 2), R, C, f, f, W, H)[0] for conv in fdgs.CONVENTIONS]
    assert np.abs(images["symmetric"][0] - images["symmetric"][1]).max() < 1e-12
    assert np.abs(images["generic"][0] - images["generic"][1]).max() > 1e-2


def test_the_marginal_cut_keeps_only_above_0_05_and_scales_the_opacity():
    """FWD:333-336: marginal = exp(-dt^2 / (2 Sigma_tt)); drawn only if > 0.05, opacity times it."""
    cap = one_gaussian(scaling_t=0.4, t=1.0, opacity=0.8)  # identity rotation: Sigma_tt = 0.16
    for marginal in (0.0501, 0.0499, 0.5, 1.0):
        dt = math.sqrt(-2.0 * 0.16 * math.log(marginal))
        for t in (1.0 + dt, 1.0 - dt):
            m = fdgs.fdgs_at(cap, t, "after-900c592", (0, 2), (0, 0, 0))
            assert len(m["opacity"]) == (1 if marginal > 0.05 else 0), (marginal, t)
            if marginal > 0.05:
                assert m["opacity"][0] == pytest.approx(0.8 * marginal, rel=1e-6)
            assert len(fdgs.fdgs_at(cap, t, "after-900c592", (0, 2), (0, 0, 0), cut=False)["opacity"]) == 1


def test_4d_sh_without_time_degree_is_3dgs_sh_and_the_harmonics_are_cosines_in_t_over_T():
    for _ in range(10):
        sh = RNG.normal(0, 0.5, (48, 3))
        d = RNG.normal(size=3)
        d /= np.linalg.norm(d)
        for degree in range(4):
            assert np.allclose(fdgs.sh4d_colour(sh, degree, 0, d, 0.37, 2.0), raster.sh_colour(sh, degree, d),
                               atol=1e-14)
        b = fdgs.sh_basis(d)
        base = b @ sh[:16]
        t1, t2 = b @ sh[16:32], b @ sh[32:48]
        # dir_t = T/4 (either sign): cos(pi/2) = 0, cos(pi) = -1
        for dir_t in (0.5, -0.5):
            assert np.allclose(fdgs.sh4d_colour(sh, 3, 2, d, dir_t, 2.0), np.maximum(base + 0.5 - t2, 0), atol=1e-12)
        assert np.allclose(fdgs.sh4d_colour(sh, 3, 1, d, 0.0, 2.0), np.maximum(base + 0.5 + t1, 0), atol=1e-12)
        # the CUDA nests the time terms inside deg > 2 (FWD:123, :142): none at degree 2
        assert np.allclose(fdgs.sh4d_colour(sh, 2, 2, d, 0.0, 2.0), fdgs.sh4d_colour(sh, 2, 0, d, 0.0, 2.0))


def test_the_view_direction_is_the_canonical_means():
    """A Gaussian moving along x (the x-t rotation above): the colour follows the direction to
    xyz, not to the shifted mean; only the Python-path variant follows the mean."""
    f = 0.3
    sh = np.zeros((48, 3))
    sh[0], sh[3] = 1.0, 1.5  # l1p1: -C1 x
    cap = one_gaussian(xyz=(0.0, 0.0, 2.0), rotation=(math.cos(f), 0, 0, math.sin(f)),
                       rotation_r=(math.cos(f), 0, 0, -math.sin(f)), scaling=(0.5, 0.2, 0.2), scaling_t=0.25,
                       t=1.0, features=sh)
    m = fdgs.fdgs_at(cap, 1.2, "before-900c592", (0, 2), (0, 0, 0))
    assert abs(m["mean"][0][0]) > 0.05
    canonical = raster.sh_colour(sh, 3, np.array([0.0, 0.0, 1.0]))
    assert np.allclose(m["colors_precomp"][0], canonical, atol=1e-6)
    py = fdgs.fdgs_at(cap, 1.2, "before-900c592", (0, 2), (0, 0, 0), view_direction="python")
    assert np.abs(py["colors_precomp"][0] - canonical).max() > 1e-2


@pytest.mark.parametrize("convention", fdgs.CONVENTIONS)
def test_each_planted_error_changes_the_judged_images(convention):
    """The scenes of test_fdgs.py: the other convention, the Python path's view direction, no cut,
    and time harmonics at any degree (here degree 3: the same, so it is not planted) each move the
    sharp images by more than 1e-3 at some judged time."""
    W, H = 64, 48
    R, C, f = judged.camera(W, H)
    cap = judged.mixed_capture()
    other = [c for c in fdgs.CONVENTIONS if c != convention][0]
    plants = {"other convention": (other, {}), "python view direction": (convention, {"view_direction": "python"}),
              "no cut": (convention, {"cut": False})}
    worst = dict.fromkeys(plants, 0.0)
    for t in judged.SHARP_TIMES:
        ref = fdgs.render_instant(cap, t, convention, judged.TIME_DURATION, R, C, f, f, W, H)[0]
        for name, (conv, kw) in plants.items():
            img = fdgs.render_instant(cap, t, conv, judged.TIME_DURATION, R, C, f, f, W, H, **kw)[0]
            worst[name] = max(worst[name], np.abs(img - ref).max())
    assert all(v > 1e-3 for v in worst.values()), worst


@pytest.mark.parametrize("convention", fdgs.CONVENTIONS)
def test_the_judged_scene_keeps_its_preconditions(convention):
    """Depth order fixed over the whole drawn window (the integral's bound assumes no order swap),
    cut crossings inside the shutter, no marginal within 1e-3 of the cut at a sharp time (float
    against double), and the T = 2 time harmonics matter (T = 1 would change the images)."""
    W, H = 64, 48
    R, C, f = judged.camera(W, H)
    cap = judged.mixed_capture()
    assert len(fdgs.cut_crossings(cap, convention, *judged.SHUTTER)) >= 4
    for t in judged.SHARP_TIMES:
        m = fdgs.fdgs_at(cap, t, convention, judged.TIME_DURATION, C, cut=False)
        assert np.all(np.abs(m["marginal"] - fdgs.MARGINAL_CUT) > 1e-3), t
    in_front = {}  # (i, j) drawn together -> is i in front of j
    for t in np.linspace(*judged.TIME_DURATION, 201):
        m = fdgs.fdgs_at(cap, t, convention, judged.TIME_DURATION, C)
        depth = dict(zip(m["index"], (m["mean"] - C) @ R[:, 2]))
        for i in depth:
            for j in depth:
                if i < j:
                    assert in_front.setdefault((i, j), depth[i] < depth[j]) == (depth[i] < depth[j]), (t, i, j)
    assert len(in_front) > 30
    ref = fdgs.render_instant(cap, judged.SHARP_TIMES[2], convention, judged.TIME_DURATION, R, C, f, f, W, H)[0]
    wrong_T = fdgs.render_instant(cap, judged.SHARP_TIMES[2], convention, 1.0, R, C, f, f, W, H)[0]
    assert np.abs(ref - wrong_T).max() > 1e-3


def test_a_torch_checkpoint_reads_back_as_the_capture_tuple(tmp_path):
    torch = fdgs.torch_or_none()
    if torch is None:
        pytest.skip("python3-torch not installed: cannot write a checkpoint")
    cap = judged.mixed_capture()
    path = tmp_path / "chkpnt.pth"
    fdgs.save_checkpoint_with_torch(path, cap, 30000)
    loaded, iteration = torch.load(str(path), map_location="cpu")
    assert iteration == 30000 and len(loaded) == 19
    assert loaded[0] == 3 and loaded[18] == 2 and loaded[16] is True
    back = fdgs.unpack(loaded)
    for k in ("xyz", "features_dc", "features_rest", "scaling", "rotation", "opacity", "t", "scaling_t", "rotation_r"):
        assert np.array_equal(back[k], fdgs.unpack(cap)[k]), k
    assert back["features_dc"].shape[1:] == (1, 3) and back["features_rest"].shape[1:] == (47, 3)


def test_prefilter_var_widens_only_the_marginal():
    """prefilter_var > 0 (ModelParams, arguments/__init__.py:62; off by default and in every
    config) adds to Sigma_tt in the marginal only (FWD:333), not in the conditioning (FWD:337-351)."""
    cap = one_gaussian(rotation=(0.9, 0.2, -0.1, 0.3), rotation_r=(0.8, -0.3, 0.4, 0.1), t=1.0)
    plain = fdgs.fdgs_at(cap, 1.3, "after-900c592", (0, 2), (0, 0, 0))
    wide = fdgs.fdgs_at(cap, 1.3, "after-900c592", (0, 2), (0, 0, 0), prefilter_var=0.05)
    sigma4 = fdgs.covariance_4d(*[fdgs.unpack(cap)[k][0] for k in ("scaling",)], fdgs.unpack(cap)["scaling_t"][0, 0],
                                (0.9, 0.2, -0.1, 0.3), (0.8, -0.3, 0.4, 0.1), "after-900c592")
    assert np.array_equal(plain["mean"], wide["mean"]) and np.array_equal(plain["cov3d_precomp"], wide["cov3d_precomp"])
    assert wide["marginal"][0] == pytest.approx(math.exp(-0.5 * 0.09 / (sigma4[3, 3] + 0.05)), rel=1e-6)


def test_the_early_checkpoint_differs_from_the_full_degree_one():
    """test_fdgs.py's early checkpoint (active degrees 1 and 0): drawing all stored degrees instead
    moves its images by more than 1e-3."""
    W, H = 64, 48
    R, C, f = judged.camera(W, H)
    early = judged.early_capture()
    t = judged.SHARP_TIMES[1]
    a = fdgs.render_instant(early, t, "after-900c592", judged.TIME_DURATION, R, C, f, f, W, H)[0]
    b = fdgs.render_instant(early, t, "after-900c592", judged.TIME_DURATION, R, C, f, f, W, H, sh_degree=3,
                            sh_degree_t=2)[0]
    assert np.abs(a - b).max() > 1e-3
